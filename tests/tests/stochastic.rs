//! Technique `stochastic` on lavapipe with validation on: the GLSL bounds against their CPU mirror, images
//! against the CPU reference (which uses the very same (x, y, u, v, t) samples at equal S and seed),
//! bound-independence of the image, and the hard cases of stochastic rasterization, each with its own
//! small scene.

use std::sync::Arc;

use glam::{Mat4, Quat, Vec2, Vec3};
use shutter::image::LinearImage;
use shutter::metrics::compare;
use shutter::mirror::bounds::{bound, BoundKind, MovingTriangle, ScreenBound};
use shutter::reference::ReferenceSettings;
use shutter::sampling::Pcg32;
use shutter::scene::builtin::{builtin_mesh, builtin_scene};
use shutter::scene::camera_space::CameraSpaceScene;
use shutter::scene::{CameraPose, Mesh, Scene};
use shutter::techniques::stochastic::{DebugOptions, StochasticTechnique, BOUND_DEBUG_STRIDE};
use shutter::techniques::{
    Clusters, FrameTechnique, HullExpansion, Intervals, PreparedFrame, RenderOutput, RenderSettings,
    Renderer, ShadingRate, StochasticOptions, Technique,
};
use shutter_tests::render_reference;
use shutter_tests::{
    camera, max_abs_diff, renderer, same_sample_reference, save_comparison, single_object_scene, square,
};

fn options(bound: BoundKind, shading: ShadingRate) -> StochasticOptions {
    StochasticOptions { bound: bound.into(), shading, instrumented: false, ..Default::default() }
}

fn render(
    r: &mut Renderer,
    scene: &Scene,
    w: u32,
    h: u32,
    spp: u32,
    seed: u64,
    o: StochasticOptions,
) -> RenderOutput {
    r.render(scene, Technique::STOCHASTIC, &RenderSettings::new(w, h, spp, seed).with_stochastic(o))
        .unwrap_or_else(|e| panic!("stochastic render ({} / {}): {e}", o.bound.name(), o.shading.name()))
}

fn reference(scene: &Scene, w: u32, h: u32, spp: u32, seed: u64) -> LinearImage {
    render_reference(
        scene,
        &ReferenceSettings { width: w, height: h, spp, seed, progress: false, shading: Default::default() },
    )
    .expect("reference")
}

fn assert_finite(name: &str, img: &LinearImage) {
    let bad = img.pixels.iter().filter(|p| p.iter().any(|c| !c.is_finite())).count();
    assert_eq!(bad, 0, "{name}: {bad} pixels with NaN/Inf");
}

// ---------------------------------------------------------------------------------------------------
// GLSL bounds == CPU bounds

/// A mesh of `n` unconnected random triangles in front of (and some crossing) the camera.
fn random_triangles(n: usize, seed: u64) -> Arc<Mesh> {
    let mut rng = Pcg32::new(seed, 3);
    let mut r = |lo: f32, hi: f32| lo + (hi - lo) * rng.next_f32();
    let mut positions = Vec::with_capacity(3 * n);
    for i in 0..n {
        let z = if i % 17 == 0 { r(-0.5, 1.5) } else { -r(0.5, 12.0) };
        let c = Vec3::new(r(-1.0, 1.0) * z.abs().max(0.5), r(-0.6, 0.6) * z.abs().max(0.5), z);
        let size = if i % 5 == 0 { r(0.5, 3.0) } else { r(0.005, 0.3) };
        for _ in 0..3 {
            positions.push(c + Vec3::new(r(-1.0, 1.0), r(-1.0, 1.0), r(-1.0, 1.0)) * size);
        }
    }
    let indices = (0..3 * n as u32).collect();
    Arc::new(Mesh::new("random", positions, vec![], vec![], indices).expect("mesh"))
}

/// Every bound kind through the geometry shader (debug output, before dilation) vs `bounds::bound`.
#[test]
fn glsl_bounds_match_cpu_mirror() {
    // 160×90: the records are per triangle, so the image only has to be rendered; at 320×180 its
    // fragments were most of this test's time (docs/CI.md, "Build and test time, 2026-12-08").
    let (w, h) = (160, 90);
    let n = 600;
    let mesh = random_triangles(n, 5);
    let motion = Mat4::from_rotation_translation(Quat::from_rotation_y(0.2), Vec3::new(0.4, -0.1, 0.3));
    let mut r = renderer();
    for (label, close, aperture) in
        [("still", None, 0.1), ("moving", Some(motion), 0.1), ("moving-pinhole", Some(motion), 0.0)]
    {
        let scene =
            single_object_scene(camera(50.0, aperture, 4.0), mesh.clone(), Mat4::IDENTITY, close, w, h);
        let k = scene.camera.intrinsics(w, h);
        let cs = CameraSpaceScene::new(&scene);
        let mv = &cs.objects[0].model_view;
        for kind in BoundKind::ALL {
            let debug = DebugOptions { bound_debug_triangles: n as u32, ..Default::default() };
            let (_, prepared) =
                render_stochastic(&mut r, &scene, 4, options(kind, ShadingRate::PerPixel), debug);
            let sr = prepared.technique_as::<StochasticTechnique>().expect("a stochastic technique").draws();
            let debug = sr.bound_debug().unwrap();
            let mut mismatches = vec![];
            for t in 0..n {
                let v = |i: usize, m: Mat4| m.transform_point3(mesh.positions[3 * t + i]);
                let tri =
                    MovingTriangle { v0: [0, 1, 2].map(|i| v(i, mv[0])), v1: [0, 1, 2].map(|i| v(i, mv[1])) };
                let cpu = bound(&tri, &k, kind);
                let rec = &debug[t * BOUND_DEBUG_STRIDE..(t + 1) * BOUND_DEBUG_STRIDE];
                if let Err(e) = same_bound(&cpu, rec, &k) {
                    mismatches.push(format!("triangle {t} {tri:?}: {e}"));
                }
            }
            println!("{label} {}: {} / {n} mismatches", kind.name(), mismatches.len());
            assert!(
                mismatches.len() <= n / 200,
                "{label} {}: {} of {n} GPU bounds differ from the CPU mirror, e.g.\n{}",
                kind.name(),
                mismatches.len(),
                mismatches.iter().take(5).cloned().collect::<Vec<_>>().join("\n")
            );
        }
        r.device().check_validation().unwrap();
    }
}

/// Renders one frame of technique `stochastic` with `debug` knobs (every object on the
/// defocus+motion path) and returns it with the prepared frame (for the technique's diagnostics).
fn render_stochastic(
    r: &mut Renderer,
    scene: &Scene,
    spp: u32,
    o: StochasticOptions,
    debug: DebugOptions,
) -> (RenderOutput, PreparedFrame) {
    let settings = RenderSettings::new(scene.image.width, scene.image.height, spp, 1).with_stochastic(o);
    let effects = vec![shutter::plan::Effects::Both; scene.objects.len()];
    let mut prepared = r
        .prepare_with(scene, &settings, |ctx| {
            let t: Box<dyn FrameTechnique> = Box::new(StochasticTechnique::new(ctx, o, debug, &effects)?);
            Ok(t)
        })
        .expect("prepare");
    let out = r.render_prepared(&mut prepared).expect("render");
    (out, prepared)
}

/// The GPU record (count, lengths, points) describes the same region as `cpu` within rounding.
fn same_bound(cpu: &ScreenBound, rec: &[f32], k: &shutter::scene::camera::Intrinsics) -> Result<(), String> {
    let pieces = rec[0] as i32;
    let lens: Vec<usize> = (0..pieces.max(0) as usize).map(|i| rec[1 + i] as usize).collect();
    let mut gpu: Vec<Vec<Vec2>> = vec![];
    let mut at = 8;
    for &l in &lens {
        gpu.push((0..l).map(|i| Vec2::new(rec[at + 2 * i], rec[at + 2 * i + 1])).collect());
        at += 2 * l;
    }
    let expect = match cpu {
        ScreenBound::Culled => 0,
        b if b.is_viewport(k) => -1,
        ScreenBound::Union(p) => p.len() as i32,
        _ => 1,
    };
    if pieces != expect {
        return Err(format!("GPU {pieces} pieces, CPU {cpu:?}"));
    }
    let scale = gpu.iter().flatten().map(|p| p.abs().max_element()).fold(1.0, f32::max);
    let tol = 2e-3 + 2e-5 * scale;
    for p in gpu.iter().flatten() {
        if !cpu.contains(*p, tol) {
            return Err(format!("GPU point {p} outside the CPU bound {cpu:?} (GPU {gpu:?})"));
        }
    }
    let gpu_bound =
        if gpu.len() == 1 { ScreenBound::Polygon(gpu[0].clone()) } else { ScreenBound::Union(gpu.clone()) };
    let cpu_points: Vec<Vec2> = match cpu {
        ScreenBound::Polygon(p) => p.clone(),
        ScreenBound::Union(ps) => ps.iter().flatten().copied().collect(),
        ScreenBound::Rect { min, max } => vec![*min, *max, Vec2::new(min.x, max.y), Vec2::new(max.x, min.y)],
        ScreenBound::Culled => vec![],
    };
    if pieces > 0 {
        for p in cpu_points {
            if !gpu_bound.contains(p, tol) {
                return Err(format!("CPU point {p} outside the GPU bound {gpu:?} (CPU {cpu:?})"));
            }
        }
    }
    Ok(())
}

// ---------------------------------------------------------------------------------------------------
// Images against the reference

/// The built-in `default` reduced to one effect: "motion" (aperture closed), "defocus" (nothing moves,
/// camera included) or "both" (as built).
fn effect_scene(effect: &str) -> Scene {
    let mut scene = builtin_scene("default").unwrap().unwrap();
    match effect {
        "motion" => scene.camera.aperture_radius = 0.0,
        "defocus" => {
            scene.camera.close = None;
            for o in &mut scene.objects {
                o.transforms.truncate(1);
            }
        }
        "both" => {}
        _ => unreachable!(),
    }
    scene
}

/// For motion only, defocus only and both, against a 256-spp reference as S grows (2, 8, 32): both
/// shading rates converge (visibility is per sample in both; per-pixel shading only shares radiance
/// within a (triangle, side) group of a pixel). Against the reference with the *same* samples and the
/// same shading rate, the images agree to f32 rounding.
#[test]
fn stochastic_converges_to_reference_for_each_effect() {
    let (w, h) = (160, 90);
    let mut r = renderer();
    for effect in ["motion", "defocus", "both"] {
        let scene = effect_scene(effect);
        let truth = reference(&scene, w, h, 256, 1);
        for shading in ShadingRate::ALL {
            let mut rmse = vec![];
            // S = 2, 8, 32 rather than 4, 16, 64: the same 4× steps with a quarter of the samples
            // (the S = 64 frames were most of this test's time; docs/CI.md).
            for spp in [2u32, 8, 32] {
                let seed = 2;
                let out = render(&mut r, &scene, w, h, spp, seed, options(BoundKind::Adaptive, shading));
                assert_finite(effect, &out.image);
                let m = compare(&truth, &out.image).unwrap();
                println!(
                    "{effect} {} S={spp}: RMSE {:.5} FLIP {:.5} ({} passes, GPU {:.0} ms)",
                    shading.name(),
                    m.rmse,
                    m.flip,
                    out.stats.passes,
                    out.timings.total_ms()
                );
                save_comparison(&format!("stochastic-{effect}-{}-{spp}", shading.name()), &truth, &out.image);
                rmse.push(m.rmse);
                if spp == 8 {
                    let same = same_sample_reference(&scene, (w, h), spp, seed, shading, &out);
                    let m = compare(&same, &out.image).unwrap();
                    println!(
                        "  vs the reference with the same samples and shading rate: RMSE {:.6} FLIP {:.5}",
                        m.rmse, m.flip
                    );
                    assert!(
                        m.rmse < SAME_SAMPLES_RMSE_MAX,
                        "{effect} {}: RMSE {} vs the same samples",
                        shading.name(),
                        m.rmse
                    );
                }
            }
            let factor = 0.7;
            for pair in rmse.windows(2) {
                assert!(
                    pair[1] < factor * pair[0],
                    "{effect} {}: RMSE must fall below {factor}× per 4× samples: {rmse:?}",
                    shading.name()
                );
            }
        }
    }
}

// Against the reference with the same samples and shading rate: visibility is per sample, so only f32
// rounding differs (inside-test borderline samples, sRGB texel decoding, summation order).
const SAME_SAMPLES_RMSE_MAX: f64 = 1e-4;

/// Bounds change the cost, never the result: every bound gives the same image for the same samples,
/// and — the GPU-side conservativeness check — the instrumented shader finds the same number of hits
/// (a bound that missed part of a triangle would lose hits; only the overlapping pieces of the wedges
/// may test, and count, a sample twice).
fn assert_bounds_agree(name: &str, scene: &Scene, w: u32, h: u32, spp: u32, kinds: &[BoundKind]) {
    let mut r = renderer();
    let counted = |o: StochasticOptions| StochasticOptions { instrumented: true, ..o };
    let hull = options(BoundKind::ConvexHull, ShadingRate::PerPixel);
    let base = render(&mut r, scene, w, h, spp, 3, counted(hull));
    assert_finite(name, &base.image);
    let base_hits = base.stats.counters.unwrap().samples_hit;
    assert!(base_hits > 0, "{name}: nothing hit");
    for &kind in kinds {
        let out = render(&mut r, scene, w, h, spp, 3, counted(options(kind, ShadingRate::PerPixel)));
        let c = out.stats.counters.unwrap();
        let d = max_abs_diff(&base.image, &out.image);
        println!(
            "{name}: {} vs convex-hull max |Δ| = {d:e}; tested {} hit {} (hull: {base_hits}) STE {:.4}; GPU {:.0} ms",
            kind.name(),
            c.samples_tested,
            c.samples_hit,
            c.sample_test_efficiency(),
            out.timings.total_ms()
        );
        if d > 1e-6 {
            save_comparison(&format!("{name}-{}-vs-hull", kind.name()), &base.image, &out.image);
        }
        assert!(d <= 1e-6, "{name}: bound {} changes the image (max |Δ| {d})", kind.name());
        if matches!(kind, BoundKind::Wedge | BoundKind::ReducedWedge) {
            assert!(c.samples_hit >= base_hits, "{name}: {} lost hits", kind.name());
        } else {
            assert_eq!(c.samples_hit, base_hits, "{name}: bound {} finds different hits", kind.name());
        }
    }
}

#[test]
fn bounds_agree_on_default() {
    let scene = builtin_scene("default").unwrap().unwrap();
    assert_bounds_agree("default", &scene, 160, 90, 8, &[BoundKind::BoundingBox, BoundKind::Adaptive]);
}

/// `focus-sweep` with its displaced sphere at subdivision 5 (20,480 triangles instead of 327,680): the
/// same shapes and blur, at a cost the CI can afford for nine bounds (the full-detail sphere takes
/// 23–88 s per 96×54 frame per bound on lavapipe; see docs/STOCHASTIC.md).
#[test]
fn bounds_agree_on_focus_sweep() {
    let mut scene = builtin_scene("focus-sweep").unwrap().unwrap();
    let sphere = scene.objects.iter_mut().find(|o| o.name == "displaced-sphere").expect("the sphere");
    sphere.mesh = Arc::new(builtin_mesh("displaced-sphere", Some(5)).unwrap().unwrap());
    assert_bounds_agree("focus-sweep", &scene, 96, 54, 4, &BoundKind::ALL);
}

/// The thesis' volumes (`3d-hexagon`, `wedge`, `reduced-wedge`: view-space prisms drawn by their
/// pinhole image) bound the same samples as the box on still `focus-sweep` with its displaced sphere
/// at subdivision 6 (81,920 strongly defocused triangles, one bound per triangle, each still far
/// under a pixel): identical images, and the same hits. With the full-detail sphere (327,680
/// triangles) each frame spent 5 s in the geometry shader on Debian 12's lavapipe (docs/CI.md).
#[test]
fn thesis_volumes_change_the_cost_never_the_image() {
    let mut r = renderer();
    let mut scene = builtin_scene("focus-sweep").unwrap().unwrap();
    let sphere = scene.objects.iter_mut().find(|o| o.name == "displaced-sphere").expect("the sphere");
    sphere.mesh = Arc::new(builtin_mesh("displaced-sphere", Some(6)).unwrap().unwrap());
    let (w, h, spp) = (48, 27, 4);
    let run = |r: &mut Renderer, kind: BoundKind| {
        let o = StochasticOptions {
            instrumented: true,
            clusters: Clusters::Off,
            ..options(kind, ShadingRate::PerPixel)
        };
        render(r, &scene, w, h, spp, 2, o)
    };
    let base = run(&mut r, BoundKind::BoundingBox);
    for kind in [BoundKind::Hexagon3d, BoundKind::Wedge, BoundKind::ReducedWedge] {
        let out = run(&mut r, kind);
        let d = max_abs_diff(&base.image, &out.image);
        let (a, b) = (base.stats.counters.unwrap(), out.stats.counters.unwrap());
        println!(
            "focus-sweep {}: max |Δ| {d:e}; tested {} (bbox {}), hit {}",
            kind.name(),
            b.samples_tested,
            a.samples_tested,
            b.samples_hit
        );
        assert!(d <= 1e-6, "{}: changes the image by {d}", kind.name());
    }
}

/// Cluster bounds (one bound per cluster of triangles, a per-sample test of whether the sample can see
/// the cluster before its triangles are tested) change the cost, never the image: on `focus-sweep`
/// (a dense, strongly defocused sphere: far fewer fragments), `default` (clusters on some objects under
/// `auto`) and the spinning bar (33 motion keys: clusters per key segment), against one bound per
/// triangle, and exact against the same-sample reference.
#[test]
fn cluster_bounds_change_the_cost_never_the_image() {
    let mut r = renderer();
    let scenes = [
        ("focus-sweep", builtin_scene("focus-sweep").unwrap().unwrap(), (96, 54), 4),
        ("default", builtin_scene("default").unwrap().unwrap(), (160, 90), 8),
        ("spinning-bar", doc_scene("spinning-bar"), (96, 72), 16),
    ];
    for (name, scene, (w, h), spp) in scenes {
        let run = |r: &mut Renderer, clusters: Clusters| {
            let o = StochasticOptions {
                instrumented: true,
                clusters,
                ..options(BoundKind::Adaptive, ShadingRate::PerPixel)
            };
            render(r, &scene, w, h, spp, 6, o)
        };
        let off = run(&mut r, Clusters::Off);
        assert!(off.stats.clusters.iter().all(|&n| n == 0));
        let base = off.stats.counters.unwrap();
        let mut auto = None;
        for clusters in [Clusters::Fixed(4), Clusters::Fixed(16), Clusters::Auto] {
            let out = run(&mut r, clusters);
            let c = out.stats.counters.unwrap();
            let d = max_abs_diff(&off.image, &out.image);
            println!(
                "{name} clusters {} ({:?}): max |Δ| {d:e}; fragments {} (off: {}), tested {} (off: {})",
                clusters.name(),
                out.stats.clusters,
                c.fragments,
                base.fragments,
                c.samples_tested,
                base.samples_tested
            );
            assert!(d <= 1e-6, "{name}: clusters {} change the image by {d}", clusters.name());
            if let Clusters::Fixed(n) = clusters {
                assert!(out.stats.clusters.iter().all(|&k| k == n || k == 0));
            }
            if name == "focus-sweep" && clusters != Clusters::Fixed(4) {
                assert!(
                    c.fragments * 4 < base.fragments,
                    "{name}: clusters {} save no fragments",
                    clusters.name()
                );
            }
            if clusters == Clusters::Auto {
                auto = Some(out);
            }
        }
        if name == "focus-sweep" {
            // auto clusters the dense sphere and nothing else (the loop's render: the frame is
            // deterministic, so a second one would show nothing new).
            let auto = auto.unwrap();
            let sphere = scene.objects.iter().position(|o| o.name == "displaced-sphere").unwrap();
            for (i, &n) in auto.stats.clusters.iter().enumerate() {
                assert_eq!(n > 0, i == sphere, "{}: {n}", scene.objects[i].name);
            }
            let same = same_sample_reference(&scene, (w, h), spp, 6, ShadingRate::PerPixel, &auto);
            let m = compare(&same, &auto.image).unwrap();
            println!("{name} auto clusters: RMSE {:.6} vs the same-sample reference", m.rmse);
            assert!(m.rmse < HARD_RMSE_MAX, "{name}: RMSE {}", m.rmse);
        }
    }
}

/// Interval bounds (a moving object's samples split into K runs of shutter time, each bounded over its
/// own sub-interval) and passes (S split into P visibility buffers, each over its own part of the
/// shutter) change the cost, never the result: the same hits, the same image — and with K > 1 the
/// moving sphere of `one-mover` tests fewer samples. Passes also regroup per-pixel shading, which the
/// reference mirrors exactly.
#[test]
fn interval_bounds_and_passes_change_the_cost_never_the_image() {
    let (w, h, spp) = (160, 90, 16);
    let mut r = renderer();
    for name in ["one-mover", "default"] {
        let scene = builtin_scene(name).unwrap().unwrap();
        let run = |r: &mut Renderer, intervals: Intervals, per_pass: Option<u32>, shading: ShadingRate| {
            let o = StochasticOptions {
                instrumented: true,
                intervals,
                per_pass,
                ..options(BoundKind::Adaptive, shading)
            };
            render(r, &scene, w, h, spp, 4, o)
        };
        let base = run(&mut r, Intervals::Fixed(1), None, ShadingRate::PerPixel);
        let b = base.stats.counters.unwrap();
        for intervals in [Intervals::Fixed(2), Intervals::Fixed(4), Intervals::Auto] {
            let out = run(&mut r, intervals, None, ShadingRate::PerPixel);
            let c = out.stats.counters.unwrap();
            let d = max_abs_diff(&base.image, &out.image);
            println!(
                "{name} intervals {}: max |Δ| {d:e}; tested {} (K=1: {}), hit {}, fragments {} (K=1: {})",
                intervals.name(),
                c.samples_tested,
                b.samples_tested,
                c.samples_hit,
                c.fragments,
                b.fragments
            );
            assert!(d <= 1e-6, "{name}: intervals {} change the image by {d}", intervals.name());
            assert_eq!(
                c.samples_hit,
                b.samples_hit,
                "{name}: intervals {} change the hits",
                intervals.name()
            );
            if name == "one-mover" && intervals == Intervals::Fixed(4) {
                assert!(c.samples_tested < b.samples_tested, "{name}: K = 4 tests no fewer samples");
            }
        }
        for shading in ShadingRate::ALL {
            let out = run(&mut r, Intervals::Auto, Some(4), shading);
            assert_eq!(out.stats.passes, 4);
            assert_eq!(
                out.stats.counters.unwrap().samples_hit,
                b.samples_hit,
                "{name}: 4 passes change the hits"
            );
            let same = same_sample_reference(&scene, (w, h), spp, 4, shading, &out);
            let m = compare(&same, &out.image).unwrap();
            println!(
                "{name} 4 passes {}: RMSE {:.6} vs the same samples and grouping",
                shading.name(),
                m.rmse
            );
            assert!(m.rmse < SAME_SAMPLES_RMSE_MAX, "{name} 4 passes {}: RMSE {}", shading.name(), m.rmse);
        }
    }
}

/// 300 objects (more than a byte of object index): the visibility payload numbers triangles across the
/// frame, so every object meets the others in one buffer; each gets its own colour, so a sample credited
/// to the wrong object would show. Exact against the same-sample reference.
#[test]
fn many_objects_share_one_visibility_buffer() {
    let mut scene =
        hard_scene(0.03, 3.0, square(0.12), Mat4::from_translation(Vec3::new(0.0, 0.0, -3.0)), None);
    let template = scene.objects[0].clone();
    let mut rng = Pcg32::new(11, 3);
    scene.objects = (0..300)
        .map(|i| {
            let mut o = template.clone();
            o.name = format!("square-{i}");
            let p = Vec3::new(
                rng.next_f32() * 2.4 - 1.2,
                rng.next_f32() * 1.8 - 0.9,
                -2.0 - 2.0 * rng.next_f32(),
            );
            o.transforms = vec![(0.0, Mat4::from_translation(p))];
            let close = Mat4::from_translation(p + Vec3::new(0.1 * rng.next_f32(), 0.0, 0.0));
            o.set_close(close);
            o.material.albedo = Vec3::new(rng.next_f32(), rng.next_f32(), rng.next_f32());
            o
        })
        .collect();
    let (w, h) = (scene.image.width, scene.image.height);
    let mut r = renderer();
    for shading in ShadingRate::ALL {
        let out = render(&mut r, &scene, w, h, 8, 5, options(BoundKind::Adaptive, shading));
        let same = same_sample_reference(&scene, (w, h), 8, 5, shading, &out);
        let m = compare(&same, &out.image).unwrap();
        println!("300 objects {}: RMSE {:.6}", shading.name(), m.rmse);
        save_comparison(&format!("many-objects-{}", shading.name()), &same, &out.image);
        assert!(m.rmse < HARD_RMSE_MAX, "300 objects {}: RMSE {}", shading.name(), m.rmse);
    }
}

// ---------------------------------------------------------------------------------------------------
// Hard cases: each its own small scene, every bound family, against the reference at the same samples.

const HARD_SPP: u32 = 16;

fn check_hard_case(name: &str, scene: &Scene) {
    check_hard_case_at(name, scene, HARD_SPP);
}

fn check_hard_case_at(name: &str, scene: &Scene, spp: u32) {
    let (w, h) = (scene.image.width, scene.image.height);
    let mut r = renderer();
    let mut same: Option<LinearImage> = None;
    let mut first: Option<LinearImage> = None;
    for kind in [
        BoundKind::Adaptive,
        BoundKind::ConvexHull,
        BoundKind::BoundingBox,
        BoundKind::Wedge,
        BoundKind::Hexagon3d,
    ] {
        let out = render(&mut r, scene, w, h, spp, 5, options(kind, ShadingRate::PerPixel));
        assert_finite(name, &out.image);
        let same = same.get_or_insert_with(|| {
            let same = same_sample_reference(scene, (w, h), spp, 5, ShadingRate::PerPixel, &out);
            assert_finite(&format!("{name} reference"), &same);
            same
        });
        let m = compare(same, &out.image).unwrap();
        println!(
            "{name} {}: RMSE {:.5} FLIP {:.5} vs the same-sample reference",
            kind.name(),
            m.rmse,
            m.flip
        );
        save_comparison(&format!("hard-{name}-{}", kind.name()), same, &out.image);
        assert!(m.rmse < HARD_RMSE_MAX, "{name} {}: RMSE {} (holes or wrong coverage?)", kind.name(), m.rmse);
        match &first {
            None => first = Some(out.image),
            Some(f) => assert!(
                max_abs_diff(f, &out.image) <= 1e-6,
                "{name}: bound {} changes the image",
                kind.name()
            ),
        }
    }
    // Cluster bounds (two triangles per cluster: every hard case has a handful of triangles) bound the
    // same samples.
    let o = StochasticOptions {
        clusters: Clusters::Fixed(2),
        ..options(BoundKind::Adaptive, ShadingRate::PerPixel)
    };
    let clustered = render(&mut r, scene, w, h, spp, 5, o);
    let d = max_abs_diff(first.as_ref().expect("rendered"), &clustered.image);
    println!("{name} clusters: max |Δ| {d:e}");
    assert!(d <= 1e-6, "{name}: cluster bounds change the image by {d}");
    let ps = render(&mut r, scene, w, h, spp, 5, options(BoundKind::Adaptive, ShadingRate::PerSample));
    assert_finite(name, &ps.image);
    let same = reference(scene, w, h, spp, 5);
    let m = compare(&same, &ps.image).unwrap();
    println!("{name} per-sample: RMSE {:.6}", m.rmse);
    save_comparison(&format!("hard-{name}-per-sample"), &same, &ps.image);
    assert!(m.rmse < HARD_RMSE_MAX, "{name} per-sample: RMSE {}", m.rmse);
}

// Against the reference with the same samples and shading rate: visibility is per sample, so a hole,
// a spurious hit or a misordered sample shows at once; only f32 rounding remains.
const HARD_RMSE_MAX: f64 = 1e-4;

/// A scene of `docs/scenes/` (the hard cases docs/STOCHASTIC.md shows), with lights and materials the
/// single-object helper does not have.
fn doc_scene(name: &str) -> Scene {
    let path = std::path::Path::new(env!("CARGO_MANIFEST_DIR")).join(format!("../docs/scenes/{name}.toml"));
    shutter::scene::file::load_scene_file(&path).expect("scene")
}

/// Issue 10, hard case 1: a lens wider than the camera's height above a big two-triangle ground plane
/// (aperture radius 2 at height 1). Lens points below the plane see its unlit underside; shading the
/// nearest hit once per pixel and writing it to every covered sample (the old coverage pass) drew a
/// hard horizontal edge and lost coverage (RMSE 0.054 at S = 64, 64×36, against accumulation's
/// 0.0088). Visibility per sample and shading groups split by side get it exact.
#[test]
fn hard_lens_wider_than_the_height_above_a_big_plane() {
    check_hard_case_at("lens-wider-than-height", &doc_scene("lens-wider-than-height"), 64);
}

/// Issue 10, hard case 3: one depth per pixel for all covered samples misorders samples even on a
/// single box moving in depth (its faces' samples took the nearest sample's depth): RMSE 0.0049 vs an
/// independent renderer at S = 64, against 0.0031 noise. Per-sample visibility is exact; the lit box
/// (not the ambient-only helper) makes misordered faces visible.
#[test]
fn hard_box_moving_in_depth_keeps_per_sample_depth() {
    check_hard_case_at("box-moving-in-depth", &doc_scene("box-moving-in-depth"), 64);
}

/// Issue 10, hard case 4: rotation. Between motion keys vertices move in straight lines, so a bar
/// turning 180° about the view axis with only its two ends as keys shrinks through its centre without
/// turning at all; with `motion_keys = 33` (`docs/scenes/spinning-bar.toml`) it sweeps a disc, and a
/// pixel at distance ρ from the centre, off the bar's open/close direction, is covered for the
/// fraction 2·asin(w/ρ)/π of the shutter. Checked on the reference (which the two-key scene fails:
/// zero there), on `stochastic` against the same-sample reference for every bound and both shading
/// rates and with the compute-expanded hull, on `auto`, on `accumulation` against the closed form, and
/// on `pinhole` (mid-shutter: the bar stands vertical with keys, is a point without).
#[test]
fn hard_spinning_bar_turns_with_motion_keys() {
    let keyed = doc_scene("spinning-bar");
    assert_eq!(keyed.objects[0].transforms.len(), 33);
    let (w, h, spp) = (keyed.image.width, keyed.image.height, keyed.image.spp);
    let k = keyed.camera.intrinsics(w, h);
    let (half_width, depth) = (0.04f32, 3.0f32);
    // Mean value and mean closed-form coverage over the pixels of the ring at radius [r0, r1]
    // (world units at the bar's depth), at least 30° away from the bar's open and close direction.
    let ring = |img: &LinearImage, r0: f32, r1: f32| -> (f64, f64, usize) {
        let (mut got, mut want, mut n) = (0.0f64, 0.0f64, 0usize);
        for y in 0..h {
            for x in 0..w {
                let p = k.pixel_to_tan(Vec2::new(x as f32 + 0.5, y as f32 + 0.5)) * depth;
                let (rho, angle) = (p.length(), p.y.atan2(p.x).abs());
                if rho < r0 || rho > r1 || angle < 30f32.to_radians() || angle > 150f32.to_radians() {
                    continue;
                }
                got += img.get(x, y)[0] as f64;
                want += (2.0 * (half_width / rho).asin() / std::f32::consts::PI) as f64;
                n += 1;
            }
        }
        (got / n as f64, want / n as f64, n)
    };
    let check_ring = |name: &str, img: &LinearImage, tolerance: f64| {
        for (r0, r1) in [(0.4, 0.5), (0.6, 0.72)] {
            let (got, want, n) = ring(img, r0, r1);
            println!(
                "spinning bar {name}, ring {r0}..{r1} ({n} px): coverage {got:.4}, closed form {want:.4}"
            );
            assert!(n > 40, "{n} pixels");
            assert!((got / want - 1.0).abs() < tolerance, "{name}, ring {r0}..{r1}: {got} vs {want}");
        }
    };
    let truth = reference(&keyed, w, h, spp, 5);
    save_comparison("hard-spinning-bar-reference", &truth, &truth);
    check_ring("reference", &truth, 0.1);
    // Two keys: the bar never leaves the horizontal.
    let mut two = keyed.clone();
    let ends = &keyed.objects[0].transforms;
    two.objects[0].transforms = vec![ends[0], ends[32]];
    let collapsed = reference(&two, w, h, spp, 5);
    save_comparison("hard-spinning-bar-two-keys", &truth, &collapsed);
    assert!(ring(&collapsed, 0.4, 0.72).0 < 1e-3, "two keys cover the ring");

    // stochastic: every bound, both shading rates, exact against the same samples.
    check_hard_case_at("spinning-bar", &keyed, spp);
    let mut r = renderer();
    let o = options(BoundKind::Adaptive, ShadingRate::PerSample);
    let cs = render(&mut r, &keyed, w, h, spp, 5, with_hull(o, HullExpansion::Compute));
    let m = compare(&truth, &cs.image).unwrap();
    println!("spinning bar, compute hull: RMSE {:.6}", m.rmse);
    assert!(m.rmse < HARD_RMSE_MAX, "compute hull: RMSE {}", m.rmse);
    let auto = r.render(&keyed, Technique::AUTO, &RenderSettings::new(w, h, spp, 5)).expect("auto");
    let same = same_sample_reference(&keyed, (w, h), spp, 5, ShadingRate::PerPixel, &auto);
    let m = compare(&same, &auto.image).unwrap();
    println!("spinning bar, auto: RMSE {:.6}", m.rmse);
    assert!(m.rmse < HARD_RMSE_MAX, "auto: RMSE {}", m.rmse);
    // accumulation: other samples (S passes, one time each), the same motion.
    let acc =
        r.render(&keyed, Technique::ACCUMULATION, &RenderSettings::new(w, h, spp, 5)).expect("accumulation");
    save_comparison("hard-spinning-bar-accumulation", &truth, &acc.image);
    check_ring("accumulation", &acc.image, 0.15);
    // pinhole: mid-shutter, 90° on — the bar stands vertical (keys), or is a point (two keys).
    let up = |img: &LinearImage| {
        let p = k.project(Vec3::new(0.0, 0.55, -depth), Vec2::ZERO);
        img.get(p.x as u32, p.y as u32)[0]
    };
    let settings = RenderSettings::new(w, h, 1, 5);
    let pin = r.render(&keyed, Technique::PINHOLE, &settings).expect("pinhole");
    assert!(up(&pin.image) > 0.99, "pinhole with keys: {}", up(&pin.image));
    let pin_two = r.render(&two, Technique::PINHOLE, &settings).expect("pinhole");
    assert!(pin_two.image.pixels.iter().all(|p| p[0] < 1e-6), "the two-key bar at mid-shutter is a point");
}

fn hard_scene(aperture: f32, focus: f32, mesh: Arc<Mesh>, open: Mat4, close: Option<Mat4>) -> Scene {
    let mut s = single_object_scene(camera(50.0, aperture, focus), mesh, open, close, 96, 72);
    s.image.spp = HARD_SPP;
    s
}

fn tri_mesh(name: &str, tris: &[[Vec3; 3]]) -> Arc<Mesh> {
    let positions: Vec<Vec3> = tris.iter().flatten().copied().collect();
    let indices = (0..positions.len() as u32).collect();
    Arc::new(Mesh::new(name, positions, vec![], vec![], indices).expect("mesh"))
}

#[test]
fn hard_triangle_crosses_z0_during_shutter() {
    let open = Mat4::from_translation(Vec3::new(0.2, 0.1, -2.0));
    let close = Mat4::from_translation(Vec3::new(-0.2, 0.0, 1.0));
    check_hard_case("crosses-z0", &hard_scene(0.05, 2.0, square(1.0), open, Some(close)));
}

#[test]
fn hard_camera_moves_through_geometry() {
    let mut scene =
        hard_scene(0.02, 2.0, square(1.5), Mat4::from_translation(Vec3::new(0.0, 0.0, -1.5)), None);
    scene.camera.close = Some(CameraPose {
        position: Vec3::new(0.1, 0.0, -3.0),
        look_at: Vec3::new(0.1, 0.0, -4.0),
        up: Vec3::Y,
    });
    check_hard_case("camera-through-geometry", &scene);
}

#[test]
fn hard_triangle_straddles_focus_plane() {
    let open = Mat4::from_translation(Vec3::new(0.0, 0.0, -3.0)) * Mat4::from_rotation_y(1.35);
    check_hard_case("waist", &hard_scene(0.15, 3.0, square(4.0), open, None));
}

#[test]
fn hard_needle_triangles() {
    let tris: Vec<[Vec3; 3]> = (0..6)
        .map(|i| {
            let y = -0.6 + 0.25 * i as f32;
            let z = -2.0 - 0.7 * i as f32;
            [Vec3::new(-1.5, y, z), Vec3::new(1.5, y + 0.01, z - 0.5), Vec3::new(1.5, y + 0.013, z - 0.5)]
        })
        .collect();
    let close = Mat4::from_translation(Vec3::new(0.0, 0.15, 0.0));
    check_hard_case(
        "needles",
        &hard_scene(0.08, 3.0, tri_mesh("needles", &tris), Mat4::IDENTITY, Some(close)),
    );
}

#[test]
fn hard_circle_of_confusion_much_larger_than_triangle() {
    // s = 36 / tan(25°) = 77.2 px; φ(0.3) = 1.0 · 77.2 · (1/10 − 1/0.3) ≈ −250 px on a 0.04 square (~10 px).
    let scene = hard_scene(1.0, 10.0, square(0.04), Mat4::from_translation(Vec3::new(0.0, 0.0, -0.3)), None);
    let k = scene.camera.intrinsics(96, 72);
    assert!(k.circle_of_confusion_px(0.3).abs() > 200.0);
    check_hard_case("coc-200px", &scene);
}

#[test]
fn hard_zero_motion_with_defocus() {
    check_hard_case(
        "defocus-still",
        &hard_scene(0.2, 4.0, square(1.0), Mat4::from_translation(-2.0 * Vec3::Z), None),
    );
}

#[test]
fn hard_huge_motion() {
    // 16 units across at depth 2 → 16 · 77.2 / 2 ≈ 620 px.
    let open = Mat4::from_translation(Vec3::new(-8.0, 0.0, -2.0));
    let close = Mat4::from_translation(Vec3::new(8.0, 0.3, -2.0));
    check_hard_case("huge-motion", &hard_scene(0.05, 2.0, square(0.5), open, Some(close)));
}

#[test]
fn hard_vertex_exactly_at_focus_plane() {
    let tris = [[Vec3::new(-0.5, -0.4, -3.0), Vec3::new(0.6, -0.2, -1.5), Vec3::new(0.0, 0.6, -5.0)]];
    check_hard_case("vertex-at-focus", &hard_scene(0.1, 3.0, tri_mesh("tri", &tris), Mat4::IDENTITY, None));
}

#[test]
fn hard_edge_on_triangle() {
    // The square's plane contains the lens centre's view ray: zero area through the pinhole, visible
    // from the rest of the lens.
    let open = Mat4::from_translation(Vec3::new(0.0, 0.0, -2.0))
        * Mat4::from_rotation_y(std::f32::consts::FRAC_PI_2);
    check_hard_case("edge-on", &hard_scene(0.1, 4.0, square(1.0), open, None));
    check_hard_case("edge-on-pinhole", &hard_scene(0.0, 4.0, square(1.0), open, None));
}

#[test]
fn hard_beyond_far_plane_at_one_end_of_shutter() {
    let mut scene = hard_scene(
        0.05,
        3.0,
        square(1.0),
        Mat4::from_translation(Vec3::new(0.0, 0.0, -5.0)),
        Some(Mat4::from_translation(Vec3::new(0.0, 0.0, -60.0)) * Mat4::from_scale(Vec3::splat(12.0))),
    );
    scene.camera.far = 20.0;
    check_hard_case("beyond-far", &scene);
}

#[test]
fn hard_surface_on_the_near_plane() {
    // Issue 10, hard case 2: a face at view depth exactly `near` (0.5, exact in f32, as is the translated
    // z). The rounded barycentric depth dipped below `near` for a few per cent of the hits, for other
    // samples on the GPU than in the reference (bounds::tests::surface_on_the_near_plane).
    // At near = 0.1 (not exact in f32) the face's z is near's f32 value; interpolating a still vertex
    // over the shutter as (1 − t)·a + t·b moved it off that value for some t and lost 8 % of the hits on
    // both sides alike: MovingTriangle::at and shutter_lerp are a + (b − a)·t, exact for a still vertex.
    for near in [0.5f32, 0.1] {
        let open = Mat4::from_translation(Vec3::new(0.1 * near / 0.5, 0.05 * near / 0.5, -near));
        for (name, aperture) in [("pinhole", 0.0), ("defocus", 0.02)] {
            let mut scene = hard_scene(aperture, 2.0, square(0.3 * near / 0.5), open, None);
            scene.camera.near = near;
            let name = format!("near-plane-{near}-{name}");
            check_hard_case(&name, &scene);
            // The face is all there: every pixel of its square is fully covered in the reference.
            let same = reference(&scene, scene.image.width, scene.image.height, HARD_SPP, 5);
            let lit = same.pixels.iter().filter(|p| p[0] > 0.99).count();
            assert!(lit > 100, "{name}: the face is missing from the reference ({lit} px)");
        }
    }
}

/// `accumulation` (and `pinhole`, the same vertex stage) keep a face exactly on the near plane: the
/// clip-space depth of a vertex at z = near could round above w and the rasterizer clipped the whole
/// face at near = 0.1 (RMSE 0.377 against the reference); `thin_lens_clip` now clamps the rounding.
#[test]
fn accumulation_keeps_a_surface_on_the_near_plane() {
    let mut r = renderer();
    for near in [0.5f32, 0.1] {
        let open = Mat4::from_translation(Vec3::new(0.1 * near / 0.5, 0.05 * near / 0.5, -near));
        let mut scene = hard_scene(0.0, 2.0, square(0.3 * near / 0.5), open, None);
        scene.camera.near = near;
        let (w, h) = (scene.image.width, scene.image.height);
        let truth = reference(&scene, w, h, 64, 1);
        let out = r
            .render(&scene, Technique::ACCUMULATION, &RenderSettings::new(w, h, 16, 1))
            .expect("accumulation render");
        let m = compare(&truth, &out.image).unwrap();
        println!("near {near}: accumulation RMSE {:.5} vs a 64-spp reference", m.rmse);
        save_comparison(&format!("near-plane-{near}-accumulation"), &truth, &out.image);
        assert!(m.rmse < 0.03, "near {near}: accumulation RMSE {} (the face clipped?)", m.rmse);
    }
}

// ---------------------------------------------------------------------------------------------------
// The compute-expanded hull (HullExpansion::Compute)

fn with_hull(o: StochasticOptions, expansion: HullExpansion) -> StochasticOptions {
    StochasticOptions { expansion, ..o }
}

/// The compute pass bounds and dilates exactly as the geometry shader does, so the images are the
/// same and — instrumented — so are the hits (samples tested may differ: the fragments split along
/// other triangle edges). On `default` for three bounds, and on `one-mover` through `auto` (the
/// motion-only permutation next to the still one).
#[test]
fn compute_hull_matches_the_geometry_shader_hull() {
    let (w, h, spp) = (160, 90, 4);
    let mut r = renderer();
    let scene = builtin_scene("default").unwrap().unwrap();
    for kind in [BoundKind::BoundingBox, BoundKind::ConvexHull, BoundKind::Adaptive] {
        let o = StochasticOptions { instrumented: true, ..options(kind, ShadingRate::PerPixel) };
        let gs = render(&mut r, &scene, w, h, spp, 3, with_hull(o, HullExpansion::GeometryShader));
        let cs = render(&mut r, &scene, w, h, spp, 3, with_hull(o, HullExpansion::Compute));
        let (a, b) = (gs.stats.counters.unwrap(), cs.stats.counters.unwrap());
        println!("{}: gs {a:?}\n  compute {b:?} (expand {:?} ms)", kind.name(), cs.timings.get("expand"));
        assert!(cs.timings.get("expand").is_some());
        assert_eq!(a.samples_hit, b.samples_hit, "{}: hits differ", kind.name());
        let d = max_abs_diff(&gs.image, &cs.image);
        assert!(d <= 1e-6, "{}: compute hull changes the image by {d}", kind.name());
    }
    let scene = builtin_scene("one-mover").unwrap().unwrap();
    let s = |e| {
        RenderSettings::new(w, h, 16, 3)
            .with_stochastic(with_hull(options(BoundKind::Adaptive, ShadingRate::PerSample), e))
    };
    let gs = r.render(&scene, Technique::AUTO, &s(HullExpansion::GeometryShader)).unwrap();
    let cs = r.render(&scene, Technique::AUTO, &s(HullExpansion::Compute)).unwrap();
    let d = max_abs_diff(&gs.image, &cs.image);
    assert!(d <= 1e-6, "auto on one-mover: compute hull changes the image by {d}");
}

/// A hull buffer far too small overflows; the renderer grows it and expands again: the image is the
/// one the default capacity gives, and the buffer ends at least as large as the vertices needed.
#[test]
fn compute_hull_overflow_grows_the_buffer_and_loses_nothing() {
    let (w, h) = (160, 90);
    let mut r = renderer();
    let mut scene = builtin_scene("default").unwrap().unwrap();
    (scene.image.width, scene.image.height) = (w, h);
    let o = with_hull(options(BoundKind::Adaptive, ShadingRate::PerPixel), HullExpansion::Compute);
    let mut images = vec![];
    for per_triangle in [Some(3), None] {
        let debug = DebugOptions { hull_vertices_per_triangle: per_triangle, ..Default::default() };
        let (out, prepared) = render_stochastic(&mut r, &scene, 4, o, debug);
        let sr = prepared.technique_as::<StochasticTechnique>().expect("a stochastic technique").draws();
        let image = out.image;
        let (capacity, used) = sr.hull_usage().unwrap();
        println!("vertices per triangle {per_triangle:?}: capacity {capacity:?}, used {used:?}");
        for (c, u) in capacity.iter().zip(&used) {
            assert!(u <= c, "{used:?} over {capacity:?}");
        }
        if per_triangle == Some(3) {
            let tris: Vec<u32> =
                scene.objects.iter().map(|o| (o.mesh.triangle_count() as u32).max(1) * 3).collect();
            assert!(capacity.iter().zip(&tris).any(|(c, t)| c > t), "nothing grew: {capacity:?}");
        }
        images.push(image);
    }
    assert!(max_abs_diff(&images[0], &images[1]) <= 1e-6, "the overflowed expansion lost coverage");
}

/// The thesis' per-object level of adaptive switching (§4.7): each object draws the kind its own blur
/// selects. On the focus-sweep study's scene (the statue nearly sharp, the buildings blurred) with the
/// box for sharp objects and the hull for blurred ones: the image and the hits are the box's, and the
/// samples tested are exactly the statue's under the box plus the buildings' under the hull, each
/// measured on a scene of that part alone (no depth test in the coverage pass: the counts add up).
#[test]
fn per_object_bounds_follow_each_objects_blur() {
    use shutter::plan::Plan;
    use shutter::techniques::{BoundChoice, ObjectBoundPolicy};
    let mut r = renderer();
    let scene = doc_scene("thesis-sweep");
    let (w, h, spp) = (80, 45, 4);
    let plan = Plan::new(&scene, w, h);
    let statue = plan.objects.iter().find(|o| o.name == "statue").expect("statue").max_coc_px;
    let buildings = plan.objects.iter().filter(|o| o.name != "statue").map(|o| o.max_coc_px);
    let least_building = buildings.fold(f32::INFINITY, f32::min);
    assert!(statue < least_building, "statue {statue} px, buildings from {least_building} px");
    let policy = ObjectBoundPolicy {
        sharp: BoundKind::BoundingBox,
        blurred: BoundKind::ConvexHull,
        threshold_px: 0.5 * (statue + least_building),
    };
    let run = |r: &mut Renderer, scene: &Scene, bound: BoundChoice| {
        let o =
            StochasticOptions { bound, instrumented: true, clusters: Clusters::Off, ..Default::default() };
        render(r, scene, w, h, spp, 5, o)
    };
    let part = |keep_statue: bool| {
        let mut s = scene.clone();
        s.objects.retain(|o| (o.name == "statue") == keep_statue);
        s
    };
    let mixed = run(&mut r, &scene, BoundChoice::PerObject(policy));
    let boxed = run(&mut r, &scene, BoundKind::BoundingBox.into());
    let d = max_abs_diff(&boxed.image, &mixed.image);
    assert!(d <= 1e-6, "per-object bounds change the image by {d}");
    let (m, b) = (mixed.stats.counters.unwrap(), boxed.stats.counters.unwrap());
    assert_eq!(m.samples_hit, b.samples_hit);
    let statue_boxed = run(&mut r, &part(true), BoundKind::BoundingBox.into()).stats.counters.unwrap();
    let buildings_hull = run(&mut r, &part(false), BoundKind::ConvexHull.into()).stats.counters.unwrap();
    println!(
        "per-object: tested {} = statue (bbox) {} + buildings (hull) {}; all bbox {}",
        m.samples_tested, statue_boxed.samples_tested, buildings_hull.samples_tested, b.samples_tested
    );
    assert_eq!(m.samples_tested, statue_boxed.samples_tested + buildings_hull.samples_tested);
    assert!(m.samples_tested < b.samples_tested, "the hull tests fewer samples on the buildings");
}

/// Stochastic transparency in the stochastic rasterizer (issue 12): the coverage stage keeps a hit of
/// a partly covering object only on the samples it covers — the reference's decision for the same
/// sample (`transparency::covered`) — and the tint pass multiplies each tinted object's tint into the
/// samples it does not cover in front of what they see, so blur, coverage and tints come out of one
/// frame, exact against the same-sample reference. On `glass` (three tinted panes of coverage 0.1 over
/// the wall, untextured here, and Spot, one pane sliding, a small aperture), with panes of coverage
/// 0.5, and opaque (1, the baseline: tints then do nothing): per-pixel and per-sample shading, two
/// bounds, S split over 4 passes (the sample index runs across passes), and the compute-expanded hull
/// for the coverage pass (the tint pass draws behind the geometry shader either way).
#[test]
fn stochastic_transparency_matches_the_reference_sample_for_sample() {
    let mut scene = builtin_scene("glass").unwrap().unwrap();
    // The wall without Spot's texture, whose sRGB decoding alone differs by up to 1e-3 between
    // lavapipe and the CPU over the whole wall (an RMSE floor of 4e-4 with or without the panes).
    assert!(scene.objects.iter().any(|o| o.material.tint != Vec3::ONE), "glass has tinted panes");
    for o in &mut scene.objects {
        if o.name == "wall" {
            o.material.texture = None;
        }
    }
    let (w, h, spp) = (64, 36, 16);
    let mut r = renderer();
    for alpha in [1.0f32, 0.1, 0.5] {
        for o in scene.objects.iter_mut().filter(|o| o.name.starts_with("pane")) {
            o.material.alpha = alpha;
        }
        for (shading, kind, per_pass, expansion) in [
            (ShadingRate::PerPixel, BoundKind::BoundingBox, None, HullExpansion::GeometryShader),
            (ShadingRate::PerSample, BoundKind::Adaptive, None, HullExpansion::GeometryShader),
            (ShadingRate::PerPixel, BoundKind::Adaptive, Some(4), HullExpansion::GeometryShader),
            (ShadingRate::PerSample, BoundKind::ConvexHull, None, HullExpansion::Compute),
        ] {
            let o = StochasticOptions { per_pass, expansion, ..options(kind, shading) };
            let out = render(&mut r, &scene, w, h, spp, 5, o);
            assert_eq!(out.timings.get("stochastic tint").is_some(), alpha < 1.0, "a tint pass when tinted");
            let same = same_sample_reference(&scene, (w, h), spp, 5, shading, &out);
            let m = compare(&same, &out.image).unwrap();
            let name = format!(
                "transparency-a{alpha}-{}-{}-{per_pass:?}-{}",
                shading.name(),
                kind.name(),
                expansion.name()
            );
            let differing = (0..(w * h) as usize)
                .filter(|&i| (0..3).any(|c| (same.pixels[i][c] - out.image.pixels[i][c]).abs() > 1e-3))
                .count();
            println!(
                "{name}: RMSE {:.6}, max |Δ| {:.5}, {differing} pixels differ by > 1e-3",
                m.rmse,
                max_abs_diff(&same, &out.image)
            );
            save_comparison(&name, &same, &out.image);
            assert!(m.rmse < HARD_RMSE_MAX, "{name}: RMSE {}", m.rmse);
            // One coverage decision taken differently moves a pixel by a sample's share of the
            // pane-to-background difference (~1/16 of 0.02..0.3); a borderline sample on a pane's
            // diagonal may be inside a different one of its two triangles on each side (f32 rounding
            // of the inside test) and so be decided by the other triangle's hash: a few pixels.
            assert!(differing <= 8, "{name}: {differing} pixels differ");
        }
    }
}

/// Coverage from a texture's alpha in the stochastic rasterizer: the coverage stage looks the alpha up
/// at each hit's uv as the reference does (bilinear at the base level) and draws the sample's count for
/// it, so `foliage`'s leaf cards (the generated `leaves` texture, cut out) come out of one frame with
/// the blur, against the same-sample reference. Its sun's shadows are off here: shadow maps are not
/// shadow rays (tests/tests/shadows.rs compares those).
#[test]
fn texture_alpha_matches_the_reference_sample_for_sample() {
    let mut scene = builtin_scene("foliage").unwrap().unwrap();
    for l in &mut scene.lights {
        if let shutter::scene::Light::Directional { shadows, .. } = l {
            *shadows = false;
        }
    }
    let (w, h, spp) = (80, 45, 8);
    let mut r = renderer();
    for shading in [ShadingRate::PerPixel, ShadingRate::PerSample] {
        let out = render(&mut r, &scene, w, h, spp, 3, options(BoundKind::BoundingBox, shading));
        assert_eq!(out.stats.transparency, Some(shutter::transparency::TransparencyMethod::Stochastic));
        let same = same_sample_reference(&scene, (w, h), spp, 3, shading, &out);
        let m = compare(&same, &out.image).unwrap();
        let differing = (0..(w * h) as usize)
            .filter(|&i| (0..3).any(|c| (same.pixels[i][c] - out.image.pixels[i][c]).abs() > 2e-3))
            .count();
        let name = format!("texture-alpha-{}", shading.name());
        println!("{name}: RMSE {:.6}, {differing} pixels differ by > 2e-3", m.rmse);
        save_comparison(&name, &same, &out.image);
        // The leaves' sRGB colours decode within ~1e-3 of the CPU's; a coverage decision taken
        // differently (an alpha at a count's threshold after f32 rounding of the uv) moves a pixel by
        // a sample's share of leaf-to-ground contrast: a handful of pixels at most.
        assert!(m.rmse < 2e-3, "{name}: RMSE {}", m.rmse);
        assert!(differing * 100 <= (w * h) as usize, "{name}: {differing} pixels differ");
    }
}

// ---------------------------------------------------------------------------------------------------
// One-sided materials

/// A lit scene: a two-sided backdrop, a two-sided box and, last, `card` (a square, one-sided when
/// `one_sided`, coverage `alpha` and a tint below 1) with transform keys `card_keys`.
fn card_scene(card_keys: Vec<(f32, Mat4)>, one_sided: bool, alpha: f32) -> Scene {
    use shutter::scene::{Light, Material, Object};
    let backdrop = Mat4::from_translation(Vec3::new(0.0, 0.0, -5.0));
    let mut s = single_object_scene(camera(50.0, 0.08, 2.5), square(8.0), backdrop, None, 96, 72);
    s.image.spp = HARD_SPP;
    s.objects[0].material.albedo = Vec3::new(0.4, 0.5, 0.6);
    let cube = builtin_mesh("box", None).expect("known").expect("builds");
    s.objects.push(Object {
        name: "box".into(),
        mesh: Arc::new(cube),
        transforms: vec![(
            0.0,
            Mat4::from_translation(Vec3::new(0.7, -0.2, -2.2))
                * Mat4::from_rotation_y(0.6)
                * Mat4::from_scale(Vec3::splat(0.5)),
        )],
        material: Material { albedo: Vec3::new(0.9, 0.6, 0.3), ..Material::default() },
    });
    s.objects.push(Object {
        name: "card".into(),
        mesh: square(1.0),
        transforms: card_keys,
        material: Material {
            albedo: Vec3::new(0.2, 0.9, 0.3),
            alpha,
            tint: if alpha < 1.0 { Vec3::new(0.9, 0.5, 0.5) } else { Vec3::ONE },
            one_sided,
            ..Material::default()
        },
    });
    s.environment.ambient = Vec3::splat(0.2);
    s.lights =
        vec![Light::Directional { direction: Vec3::new(-0.3, -0.4, -1.0), color: Vec3::ONE, shadows: false }];
    s
}

/// Hard case: one-sided faces turning away during the shutter, under defocus. A card turns half a turn
/// about its vertical axis (9 keys), so each sample sees its front or nothing depending on its time
/// and lens point; a one-sided box spins a quarter turn (so its back faces come and go at its
/// silhouette). Exact against the same-sample reference for every bound, clusters and both shading
/// rates; and the one-sidedness shows (the two-sided card's back is seen in the reference).
#[test]
fn hard_one_sided_faces_turn_away_during_the_shutter() {
    let at = Mat4::from_translation(Vec3::new(-0.5, 0.1, -2.5));
    let keys: Vec<(f32, Mat4)> = (0..9)
        .map(|k| (k as f32 / 8.0, at * Mat4::from_rotation_y(std::f32::consts::PI * k as f32 / 8.0)))
        .collect();
    let mut scene = card_scene(keys.clone(), true, 1.0);
    scene.objects[1].material.one_sided = true;
    let open = scene.objects[1].transforms[0].1;
    scene.objects[1].set_close(open * Mat4::from_rotation_x(std::f32::consts::FRAC_PI_2));
    check_hard_case("one-sided", &scene);
    let mut two_sided = scene.clone();
    two_sided.objects[2].material.one_sided = false;
    assert_references_differ("one-sided card vs two-sided", &scene, &two_sided, 0.1);
}

/// The references of `scene` and `other` (the same but for what a test is about) differ somewhere by
/// more than `min`: what the test checks shows in the image.
fn assert_references_differ(what: &str, scene: &Scene, other: &Scene, min: f32) {
    let (w, h) = (scene.image.width, scene.image.height);
    let d = max_abs_diff(&reference(scene, w, h, HARD_SPP, 5), &reference(other, w, h, HARD_SPP, 5));
    println!("{what}: max |Δ| {d}");
    assert!(d > min, "{what}: the images agree to {d}; the test shows nothing");
}

/// A one-sided card turned away from the camera is culled by every rasterizing path: `pinhole`,
/// `accumulation` (opaque, and transparent under every transparency method) and `stochastic` (exact
/// and texture-space shading) render exactly what they render with the card out of sight (behind
/// the camera, so the frame is built the same); two-sided, its back is seen.
#[test]
fn one_sided_backs_are_culled_by_every_rasterizer() {
    use shutter::transparency::TransparencyMethod;
    let away = vec![(0.0, Mat4::from_translation(Vec3::new(-0.4, 0.0, -2.0)) * Mat4::from_rotation_y(2.8))];
    let gone = vec![(0.0, Mat4::from_translation(Vec3::new(0.0, 0.0, 6.0)))];
    let mut r = renderer();
    let (w, h) = (96, 72);
    let mut cases: Vec<(String, Technique, f32, RenderSettings)> = vec![];
    let base = RenderSettings::new(w, h, 8, 5);
    cases.push(("pinhole".into(), Technique::PINHOLE, 1.0, base));
    cases.push(("accumulation".into(), Technique::ACCUMULATION, 1.0, base));
    for &m in TransparencyMethod::ALL {
        cases.push((
            format!("accumulation {m}"),
            Technique::ACCUMULATION,
            0.5,
            RenderSettings { transparency: m, ..base },
        ));
    }
    for shading in [ShadingRate::PerPixel, ShadingRate::PerSample, ShadingRate::TextureSpace] {
        for alpha in [1.0, 0.5] {
            let o = options(BoundKind::Adaptive, shading);
            cases.push((
                format!("stochastic {} α {alpha}", shading.name()),
                Technique::STOCHASTIC,
                alpha,
                base.with_stochastic(o),
            ));
        }
    }
    for (name, technique, alpha, settings) in cases {
        let mut img = |keys: &Vec<(f32, Mat4)>, one_sided: bool| {
            r.render(&card_scene(keys.clone(), one_sided, alpha), technique, &settings)
                .unwrap_or_else(|e| panic!("{name}: {e}"))
                .image
        };
        let (culled, out_of_sight, seen) = (img(&away, true), img(&gone, true), img(&away, false));
        let d = max_abs_diff(&culled, &out_of_sight);
        let shown = max_abs_diff(&seen, &out_of_sight);
        println!("{name}: culled vs out of sight max |Δ| {d:e}; two-sided {shown:.3}");
        save_comparison(&format!("one-sided-{}", name.replace([' ', '/'], "-")), &out_of_sight, &culled);
        assert!(d <= 1e-6, "{name}: the one-sided card's back changes the image by {d}");
        assert!(
            shown > 0.05,
            "{name}: the two-sided card's back is not seen ({shown}): the test shows nothing"
        );
    }
    // The geometry stage, the compute-expanded hull and cluster bounds give the turned-away card no
    // bound at all: not one coverage fragment more than with the card out of sight (two-sided, it has
    // fragments).
    let per_pixel = options(BoundKind::Adaptive, ShadingRate::PerPixel);
    for (name, o) in [
        ("geometry shader", per_pixel),
        ("compute hull", with_hull(per_pixel, HullExpansion::Compute)),
        ("clusters", StochasticOptions { clusters: Clusters::Fixed(2), ..per_pixel }),
    ] {
        let settings =
            RenderSettings::new(w, h, 8, 5).with_stochastic(StochasticOptions { instrumented: true, ..o });
        let mut fragments = |keys: &Vec<(f32, Mat4)>, one_sided: bool| {
            let out = r.render(&card_scene(keys.clone(), one_sided, 1.0), Technique::STOCHASTIC, &settings);
            out.expect("stochastic").stats.counters.expect("instrumented").fragments
        };
        let (culled, out_of_sight, seen) =
            (fragments(&away, true), fragments(&gone, true), fragments(&away, false));
        println!("{name}: coverage fragments {culled} culled, {out_of_sight} out of sight, {seen} two-sided");
        assert_eq!(culled, out_of_sight, "{name}: the turned-away one-sided card was bounded");
        assert!(seen > out_of_sight, "{name}: the two-sided card has no fragments: the test shows nothing");
    }
}

/// The smooth lens (`aperture = { shape = "smooth-disk" }`, the AAS paper's): applied where the lens
/// samples are made, so `stochastic` and the reference integrate the same lens points — exact against
/// the same-sample reference for every bound; and the image differs from the sharp disk's (its
/// transmission falls off towards the rim, so its blur is narrower).
#[test]
fn hard_smooth_lens_matches_the_reference() {
    use shutter::sampling::ApertureShape;
    let open = Mat4::from_translation(Vec3::new(0.1, 0.0, -3.5));
    let mut scene = hard_scene(0.3, 2.0, square(1.0), open, None);
    scene.camera.aperture = ApertureShape::SmoothDisk;
    check_hard_case("smooth-lens", &scene);
    let mut sharp = scene.clone();
    sharp.camera.aperture = ApertureShape::Disk;
    assert_references_differ("smooth lens vs disk", &scene, &sharp, 0.05);
}

// ---------------------------------------------------------------------------------------------------
// Decoupled shading

/// `--shading decoupled` (docs/DECOUPLED.md): the same samples' visibility, each sample shaded at its
/// key's shading point — exactly what the reference's `ReferenceShading::Decoupled` computes, on a
/// scene with depth of field, motion and a panning camera; a memoization cache of one entry (nearly
/// every lookup misses) gives the same image as one of 64k (most hit), and so does a second render
/// (races change what is shaded, never a pixel's radiances: to the f32 rounding of their sum's order);
/// the cache's counters add up.
/// `--shading decoupled`: the pixel grid, the memoization cache.
const DECOUPLED: ShadingRate =
    ShadingRate::Decoupled { grid: shutter::mirror::decoupled::GridKind::Pixel, deferred: false };

/// The reference's decoupled shading on `grid` of `scene` at `w × h`, `spp`, seed 5 (the seed of the
/// decoupled tests' renders), and its count of distinct keys.
fn decoupled_reference(
    scene: &Scene,
    (w, h, spp): (u32, u32, u32),
    grid: shutter::mirror::decoupled::GridKind,
) -> (LinearImage, u64) {
    let settings = ReferenceSettings {
        width: w,
        height: h,
        spp,
        seed: 5,
        progress: false,
        shading: shutter::reference::ReferenceShading::Decoupled(grid),
    };
    let (truth, stats) =
        shutter::reference::render_reference_with_stats(scene, &settings).expect("reference");
    (truth, stats.decoupled_keys.expect("decoupled keys"))
}

#[test]
fn decoupled_shading_matches_the_reference_whatever_the_cache() {
    let scene = builtin_scene("default").expect("built-in").expect("parses");
    let (w, h, spp) = (96, 54, 8);
    let mut r = renderer();
    let mut images = vec![];
    let (truth, keys) = decoupled_reference(&scene, (w, h, spp), shutter::mirror::decoupled::GridKind::Pixel);
    for cache_entries in [1, 1 << 16, 1 << 16] {
        let o = StochasticOptions {
            instrumented: true,
            cache_entries,
            ..options(BoundKind::Adaptive, DECOUPLED)
        };
        let out = render(&mut r, &scene, w, h, spp, 5, o);
        assert_finite("decoupled", &out.image);
        let c = out.stats.counters.expect("instrumented");
        let k = c.cache.expect("cache counters");
        println!(
            "decoupled, cache {cache_entries}: {} lookups, {} hits, {} evictions, {} lost; {} shading invocations",
            k.lookups, k.hits, k.evictions, k.busy, c.shading_invocations
        );
        assert!(k.hits <= k.lookups && k.lookups > 0);
        if cache_entries == 1 {
            assert!(k.hits * 10 < k.lookups, "one entry hits {} of {}", k.hits, k.lookups);
        } else {
            assert!(k.hits * 2 > k.lookups, "64k entries hit {} of {}", k.hits, k.lookups);
            // Every distinct key is shaded at least once (but for the few cells the GPU's f32
            // projection rounds differently); the rest are re-shades after evictions and lost races.
            println!("{keys} distinct keys: {} re-shades", k.misses() as i64 - keys as i64);
            assert!(k.misses() as f64 >= 0.99 * keys as f64, "{} misses for {keys} keys", k.misses());
        }
        images.push(out.image);
    }
    save_comparison("decoupled-default", &truth, &images[1]);
    let m = compare(&truth, &images[1]).unwrap();
    println!("decoupled vs the reference's decoupled shading: RMSE {:.6}, FLIP {:.5}", m.rmse, m.flip);
    assert!(m.rmse < HARD_RMSE_MAX, "RMSE {}", m.rmse);
    // Every sample's radiance is the same whatever the cache did; only the order in which a pixel's
    // radiances are summed follows the hits (looked up first, misses shaded after): f32 rounding.
    for img in &images[1..] {
        let d = max_abs_diff(&images[0], img);
        assert!(d <= 1e-6, "the cache's size or races change the image by {d}");
    }
    let per_sample = reference(&scene, w, h, spp, 5);
    let d = max_abs_diff(&truth, &per_sample);
    println!("decoupled vs per-sample shading (reference): max |Δ| {d}");
    assert!(d > 1e-3, "decoupled shading shades as per-sample shading: the test shows nothing");
}

/// `--shading aas` and `aas-isotropic` (docs/DECOUPLED.md): decoupled shading keyed by each triangle's
/// adaptive anisotropic grid — the same image as the reference's decoupled shading with the same grids
/// (which the CPU computes for both, `decoupled::object_grids`), and fewer distinct shading points than
/// the pixel grid wherever there is blur (`default`: defocus, motion, a panning camera); the isotropic
/// ablation, which ignores motion, never has fewer than full AAS.
#[test]
fn aas_grids_shade_fewer_points_and_match_the_reference() {
    use shutter::mirror::decoupled::GridKind;
    let scene = builtin_scene("default").expect("built-in").expect("parses");
    let (w, h, spp) = (96, 54, 8);
    let mut r = renderer();
    let mut keys = vec![];
    for (rate, kind) in [
        (DECOUPLED, GridKind::Pixel),
        (ShadingRate::Decoupled { grid: GridKind::AasIsotropic, deferred: false }, GridKind::AasIsotropic),
        (ShadingRate::Decoupled { grid: GridKind::Aas, deferred: false }, GridKind::Aas),
    ] {
        let (truth, n) = decoupled_reference(&scene, (w, h, spp), kind);
        let out = render(&mut r, &scene, w, h, spp, 5, options(BoundKind::Adaptive, rate));
        let m = compare(&truth, &out.image).unwrap();
        println!("{}: {n} distinct keys; RMSE {:.6} against the reference", rate.name(), m.rmse);
        save_comparison(&format!("aas-default-{}", rate.name()), &truth, &out.image);
        assert!(m.rmse < HARD_RMSE_MAX, "{}: RMSE {}", rate.name(), m.rmse);
        keys.push(n);
    }
    assert!(keys[2] < keys[0] && keys[1] < keys[0], "AAS keys {keys:?} (pixel, isotropic, AAS)");
    assert!(keys[2] <= keys[1], "motion-aligned AAS has more keys than isotropic: {keys:?}");
}

/// `--shading decoupled-deferred` and `aas-deferred` (Liktor & Dachsbacher's deferred mode,
/// docs/DECOUPLED.md): the hash table allocates each key of the frame once — the shading points shaded
/// are the reference's distinct keys, across passes too (the table lives for the frame) — and the image
/// is the reference's decoupled shading, the same in every run. A table too small for the frame's keys
/// overflows: those samples are shaded on the spot, and the image does not change (but for the f32
/// rounding of a pixel's sum, whose order follows the overflows). The lookups add up, and the memory
/// report counts the compact G-buffer and the table.
#[test]
fn deferred_decoupled_shading_allocates_each_key_once() {
    use shutter::mirror::decoupled::GridKind;
    let scene = builtin_scene("default").expect("built-in").expect("parses");
    let (w, h, spp) = (96, 54, 8);
    let mut r = renderer();
    for grid in [GridKind::Pixel, GridKind::Aas] {
        let (truth, keys) = decoupled_reference(&scene, (w, h, spp), grid);
        let rate = ShadingRate::Decoupled { grid, deferred: true };
        let mut images = vec![];
        // One pass, a second run, two passes of 4 samples; then tables of 1 and 256 entries.
        for (per_pass, cache_entries) in
            [(None, 1 << 16), (None, 1 << 16), (Some(4), 1 << 16), (None, 1), (None, 256)]
        {
            let o = StochasticOptions {
                instrumented: true,
                cache_entries,
                per_pass,
                ..options(BoundKind::Adaptive, rate)
            };
            let out = render(&mut r, &scene, w, h, spp, 5, o);
            assert_finite(rate.name(), &out.image);
            let c = out.stats.counters.expect("instrumented");
            let k = c.cache.expect("cache counters");
            let new_points = k.misses() - k.overflows;
            println!(
                "{}, table {cache_entries}, {} passes: {} lookups, {} hits, {new_points} new points, {} overflows; {} shading invocations; {keys} distinct keys",
                rate.name(),
                out.stats.passes,
                k.lookups,
                k.hits,
                k.overflows,
                c.shading_invocations
            );
            assert!(k.hits + k.overflows <= k.lookups && k.lookups > 0);
            assert_eq!((k.evictions, k.busy), (0, 0), "the deferred table neither evicts nor races");
            // Each new point is shaded once, each overflow on the spot, each sample without a key too.
            assert!(c.shading_invocations >= new_points + k.overflows);
            assert!(c.shading_invocations - new_points - k.overflows < 16, "samples without a key");
            let m = k.memory.expect("the deferred mode reports its memory");
            // The compact G-buffer: one entry per sample of a pass; the table: 32 bytes per entry and
            // the queue's 4, after its 32-byte header.
            assert_eq!(m.samples, (w * h) as u64 * (spp / out.stats.passes) as u64);
            assert_eq!(m.refs_bytes, 4 * m.samples);
            assert_eq!(m.table_bytes, 36 * cache_entries as u64 + 32);
            if cache_entries == 1 << 16 {
                assert_eq!(k.overflows, 0);
                // Every distinct key once (but for the few cells the GPU's f32 projection rounds to
                // the neighbour): no re-shades, across passes either.
                let ratio = new_points as f64 / keys as f64;
                assert!((0.99..=1.01).contains(&ratio), "{new_points} points for {keys} keys");
            } else {
                assert!(k.overflows > 0 && new_points <= cache_entries as u64, "{cache_entries} entries");
            }
            images.push(out.image);
        }
        save_comparison(&format!("deferred-default-{}", rate.name()), &truth, &images[0]);
        let m = compare(&truth, &images[0]).unwrap();
        println!("{} vs the reference's decoupled shading: RMSE {:.6}", rate.name(), m.rmse);
        assert!(m.rmse < HARD_RMSE_MAX, "RMSE {}", m.rmse);
        assert_eq!(images[0].pixels, images[1].pixels, "{}: not deterministic", rate.name());
        let passes = compare(&truth, &images[2]).unwrap();
        assert!(passes.rmse < HARD_RMSE_MAX, "two passes: RMSE {}", passes.rmse);
        for img in &images[3..] {
            let d = max_abs_diff(&images[0], img);
            assert!(d <= 1e-6, "the table's overflow changes the image by {d}");
        }
    }
}
