//! Technique `auto` (the effect planner, engine/src/plan.rs) on lavapipe with validation on: nothing to
//! simulate means the pinhole technique bit for bit; objects on the pinhole path spend no sample tests;
//! the motion-only and defocus-only shader permutations match the CPU reference at the same samples;
//! mixed frames converge to the reference as `stochastic` does.

use std::sync::Arc;

use glam::{Mat4, Vec3};
use shutter::image::LinearImage;
use shutter::metrics::compare;
use shutter::mirror::bounds::BoundKind;
use shutter::plan::{Effects, Plan};
use shutter::reference::ReferenceSettings;
use shutter::scene::builtin::{builtin_mesh, builtin_scene};
use shutter::scene::Scene;
use shutter::techniques::{
    RenderOutput, RenderSettings, Renderer, ShadingRate, StochasticOptions, Technique,
};
use shutter_tests::render_reference;
use shutter_tests::{camera, renderer, same_sample_reference, save_comparison, single_object_scene};

fn render(
    r: &mut Renderer,
    scene: &Scene,
    t: Technique,
    w: u32,
    h: u32,
    spp: u32,
    o: StochasticOptions,
) -> RenderOutput {
    r.render(scene, t, &RenderSettings::new(w, h, spp, 2).with_stochastic(o))
        .unwrap_or_else(|e| panic!("{} render of {}: {e}", t.name(), scene.name))
}

fn reference(scene: &Scene, w: u32, h: u32, spp: u32, seed: u64) -> LinearImage {
    render_reference(
        scene,
        &ReferenceSettings { width: w, height: h, spp, seed, progress: false, shading: Default::default() },
    )
    .expect("reference")
}

fn options(shading: ShadingRate, instrumented: bool) -> StochasticOptions {
    StochasticOptions { bound: BoundKind::Adaptive.into(), shading, instrumented, ..Default::default() }
}

fn scene(name: &str) -> Scene {
    builtin_scene(name).unwrap().unwrap()
}

/// `static` with a small aperture focused on Spot: Spot stays sharp (|φ| ≈ 0.1 px → pinhole path),
/// the near and far objects and the ground are defocused (defocus-only path), nothing moves.
fn static_with_aperture() -> Scene {
    let mut s = scene("static");
    s.name = "static-aperture".into();
    s.camera.aperture_radius = 0.05;
    s
}

#[test]
fn auto_is_the_pinhole_technique_when_nothing_needs_simulating() {
    let mut r = renderer();
    let s = scene("static");
    for (w, h, spp) in [(320, 180, 16), (160, 90, 4)] {
        let o = options(ShadingRate::PerPixel, false);
        let auto = render(&mut r, &s, Technique::AUTO, w, h, spp, o);
        let pinhole = render(&mut r, &s, Technique::PINHOLE, w, h, spp, o);
        let plan = auto.stats.plan.as_ref().expect("auto reports its plan");
        assert!(!plan.needs_stochastic(), "{plan}");
        assert_eq!(
            (auto.stats.passes, auto.stats.msaa_samples),
            (pinhole.stats.passes, pinhole.stats.msaa_samples)
        );
        assert!(
            auto.image.pixels == pinhole.image.pixels,
            "auto differs from pinhole on `static` at {w}x{h}"
        );
        assert!(auto.stats.counters.is_none());
    }
}

/// On `one-mover` only the blue sphere moves (the camera has no aperture): the planner puts it alone on
/// the motion-only path and the others on the `still` permutation — bounded by their own dilated
/// triangle at mid-shutter through the lens centre. Where an object truly has no blur that is exactly
/// what the full permutation bounds and tests, so the counters and the image equal `stochastic`'s: the
/// permutations skip work, never samples. (The still objects pay the sample tests of their own pixels
/// in the coverage pass; before visibility came first they were drawn by the forward pipeline.)
#[test]
fn objects_on_the_pinhole_path_lose_no_samples() {
    let (w, h, spp) = (160, 90, 4);
    let mut r = renderer();
    let s = scene("one-mover");
    let plan = Plan::new(&s, w, h);
    for o in &plan.objects {
        let want = if o.name == "blue-sphere" { Effects::Motion } else { Effects::Pinhole };
        assert_eq!(o.effects, want, "{plan}");
    }
    let o = options(ShadingRate::PerPixel, true);
    let auto = render(&mut r, &s, Technique::AUTO, w, h, spp, o);
    let all = render(&mut r, &s, Technique::STOCHASTIC, w, h, spp, o);
    let (a, e) = (auto.stats.counters.unwrap(), all.stats.counters.unwrap());
    println!("auto {a:?}\nstochastic {e:?}");
    assert!(a.samples_tested > 0 && a.samples_hit > 0);
    assert_eq!(
        (a.fragments, a.samples_tested, a.samples_hit, a.shading_invocations),
        (e.fragments, e.samples_tested, e.samples_hit, e.shading_invocations)
    );
    let d = compare(&all.image, &auto.image).unwrap();
    println!("auto vs stochastic: RMSE {:e}", d.rmse);
    assert!(d.rmse < 1e-6, "auto differs from stochastic on one-mover: RMSE {}", d.rmse);
}

/// The motion-only and defocus-only permutations against the reference at the very same samples and
/// shading rate: they skip the lens or the time where the scene has none, and lose nothing.
#[test]
fn effect_permutations_match_the_same_sample_reference() {
    let sphere = Arc::new(builtin_mesh("sphere", None).unwrap().unwrap());
    let at = Mat4::from_translation(Vec3::new(0.0, 0.0, -3.0)) * Mat4::from_scale(Vec3::splat(0.6));
    let moved = Mat4::from_translation(Vec3::new(0.5, 0.1, 0.0)) * at;
    let cases = [
        (
            "motion",
            single_object_scene(camera(50.0, 0.0, 3.0), sphere.clone(), at, Some(moved), 96, 72),
            Effects::Motion,
        ),
        (
            "defocus",
            single_object_scene(camera(50.0, 0.2, 6.0), sphere.clone(), at, None, 96, 72),
            Effects::Defocus,
        ),
        ("both", single_object_scene(camera(50.0, 0.2, 6.0), sphere, at, Some(moved), 96, 72), Effects::Both),
    ];
    let mut r = renderer();
    for (name, s, want) in cases {
        let plan = Plan::new(&s, 96, 72);
        assert_eq!(plan.objects[0].effects, want, "{plan}");
        let spp = 16;
        for shading in ShadingRate::ALL {
            let out = render(&mut r, &s, Technique::AUTO, 96, 72, spp, options(shading, false));
            let same = same_sample_reference(&s, (96, 72), spp, 2, shading, &out);
            let m = compare(&same, &out.image).unwrap();
            println!("{name} {}: RMSE {:.6} vs the same-sample reference", shading.name(), m.rmse);
            save_comparison(&format!("auto-{name}-{}", shading.name()), &same, &out.image);
            assert!(m.rmse < SAME_SAMPLES_RMSE_MAX, "{name} {}: RMSE {}", shading.name(), m.rmse);
        }
    }
}

// Visibility per sample and the reference's shading rate: only f32 rounding differs.
const SAME_SAMPLES_RMSE_MAX: f64 = 1e-4;

/// The scene with every effect removed (aperture 0, nothing moving).
fn still(s: &Scene) -> Scene {
    let mut t = s.clone();
    t.camera.aperture_radius = 0.0;
    t.camera.close = None;
    for o in &mut t.objects {
        o.transforms.truncate(1);
    }
    t
}

/// Mixed frames (pinhole-path objects next to motion-only or defocus-only ones) match the reference as
/// well as their parts do: at S = 16 and 64 against a 256-spp reference, auto's RMSE is within 10 % of
/// the larger of `stochastic`'s RMSE on the scene and the plain pipeline's own RMSE on the scene
/// without effects (the forward path's shading and texture filtering differ from the reference's:
/// measured 0.018 on `static` at 160×90, against 0.006 for per-sample stochastic). A seam, a depth
/// mismatch between the two paths or a lost object would show far above that.
#[test]
fn auto_matches_the_reference_like_its_parts() {
    let (w, h) = (160, 90);
    let mut r = renderer();
    for s in [scene("one-mover"), static_with_aperture()] {
        let plan = Plan::new(&s, w, h);
        assert!(plan.needs_stochastic() && plan.objects.iter().any(|o| !o.effects.is_stochastic()), "{plan}");
        let truth = reference(&s, w, h, 256, 1);
        let s0 = still(&s);
        let o = options(ShadingRate::PerSample, false);
        let floor = compare(
            &reference(&s0, w, h, 256, 1),
            &render(&mut r, &s0, Technique::PINHOLE, w, h, 4, o).image,
        )
        .unwrap()
        .rmse;
        for spp in [16u32, 64] {
            let auto = render(&mut r, &s, Technique::AUTO, w, h, spp, o);
            let sto = render(&mut r, &s, Technique::STOCHASTIC, w, h, spp, o);
            let (ma, ms) = (compare(&truth, &auto.image).unwrap(), compare(&truth, &sto.image).unwrap());
            println!(
                "{} S={spp}: auto RMSE {:.5} FLIP {:.5} ({:.0} ms); stochastic RMSE {:.5} FLIP {:.5} ({:.0} ms); \
                 plain pipeline on the still scene {floor:.5}",
                s.name,
                ma.rmse,
                ma.flip,
                auto.timings.total_ms(),
                ms.rmse,
                ms.flip,
                sto.timings.total_ms()
            );
            save_comparison(&format!("auto-{}-{spp}", s.name), &truth, &auto.image);
            assert!(
                ma.rmse <= 1.1 * ms.rmse.max(floor),
                "{} S={spp}: auto RMSE {} vs stochastic {} and the plain pipeline's floor {floor}",
                s.name,
                ma.rmse,
                ms.rmse
            );
        }
    }
}
