//! Technique `interleaved` (docs/INTERLEAVED.md) against its CPU mirror (`shutter::mirror::interleaved`): the
//! same VPLs, split, subsets, filter and composition give the same image, but for the pixels whose
//! centre lies on an edge between two surfaces (the rasterizer and the ray test break the tie
//! differently); the split's variants give identical images; depth of field and motion, rendered as
//! accumulated passes, match the mirror pass for pass; what it does not model is refused.

use shutter::image::LinearImage;
use shutter::mirror::interleaved::{
    frame_passes, pass_vpls, render_frame, Blur, Edges, InterleavedSettings, Pattern,
};
use shutter::reference::VplSettings;
use shutter::scene::builtin::builtin_scene;
use shutter::scene::Scene;
use shutter::techniques::interleaved::{InterleavedOptions, Split};
use shutter::techniques::{RenderSettings, Renderer, Technique};
use shutter_tests::{renderer, save_comparison};

const W: u32 = 80;
const H: u32 = 60;

/// `cornell` with its light's shadows off: the GPU's direct light would otherwise come from a shadow
/// map and the mirror's from exact shadow rays.
fn cornell() -> Scene {
    let mut scene = builtin_scene("cornell").expect("built-in").expect("parses");
    for l in &mut scene.lights {
        if let shutter::scene::Light::Point { shadows, .. } = l {
            *shadows = false;
        }
    }
    scene
}

/// The defaults without VPL visibility (the paper's SNSM), which the CPU mirror reproduces exactly; the
/// default itself has VPL shadow maps.
fn no_visibility() -> InterleavedOptions {
    InterleavedOptions { vpl_maps: None, ..Default::default() }
}

fn gpu(r: &mut Renderer, scene: &Scene, o: InterleavedOptions) -> LinearImage {
    gpu_passes(r, scene, o, 1)
}

/// The GPU image of `spp` passes (a scene with a lens or motion; one pass otherwise).
fn gpu_passes(r: &mut Renderer, scene: &Scene, o: InterleavedOptions, spp: u32) -> LinearImage {
    let mut s = RenderSettings::new(W, H, spp, scene.image.seed);
    s.interleaved = o;
    r.render(scene, Technique::INTERLEAVED, &s).expect("interleaved render").image
}

/// The CPU mirror with `o`'s settings, with exact shadow rays to the VPLs (`visibility`) or none: a
/// frame of `spp` passes ([`shutter::mirror::interleaved::render_frame`]; one for a still pinhole scene), VPLs
/// per pass as the technique traces them.
fn cpu_frame(scene: &Scene, o: &InterleavedOptions, spp: u32, visibility: bool) -> LinearImage {
    let passes = frame_passes(scene, spp, scene.image.seed);
    let v = VplSettings { count: o.photons, clamp: o.clamp, seed: scene.image.seed };
    let sets = pass_vpls(scene, &v, &passes).unwrap();
    render_frame(scene, (W, H), &passes, &sets, &settings(o, visibility)).unwrap()
}

fn settings(o: &InterleavedOptions, visibility: bool) -> InterleavedSettings {
    InterleavedSettings {
        pattern: o.pattern,
        block: o.block,
        blur: o.blur,
        discontinuity: o.discontinuity,
        clamp: o.clamp,
        visibility,
    }
}

/// Pixels where any channel differs by more than `tol`.
fn differing(a: &LinearImage, b: &LinearImage, tol: f32) -> usize {
    a.pixels.iter().zip(&b.pixels).filter(|(p, q)| (0..3).any(|c| (p[c] - q[c]).abs() > tol)).count()
}

#[test]
fn interleaved_matches_its_cpu_mirror() {
    let scene = cornell();
    let mut r = renderer();
    let full = Blur { radius: 4, bilinear: false, edges: Edges::Texel };
    let base = InterleavedOptions { photons: 256, ..no_visibility() };
    let configs = [
        ("brute force", InterleavedOptions { pattern: Pattern::ONE, blur: None, ..base }),
        ("4x4 full", base),
        (
            "4x4 axis bilinear",
            InterleavedOptions { blur: Some(Blur { bilinear: true, edges: Edges::Axis, ..full }), ..base },
        ),
        (
            "8x6 plain one-pass",
            InterleavedOptions {
                pattern: Pattern { n: 8, m: 6 },
                split: Split::OnePass,
                blur: Some(Blur { radius: 8, edges: Edges::Ignore, ..full }),
                ..base
            },
        ),
        ("2x2 none", InterleavedOptions { pattern: Pattern { n: 2, m: 2 }, blur: None, ..base }),
    ];
    for (name, o) in configs {
        let g = gpu(&mut r, &scene, o);
        let c = cpu_frame(&scene, &o, 1, false);
        assert_matches_mirror(name, &c, &g);
    }
}

/// The GPU image `g` equals the mirror's `c` but for the tie-broken edge pixels (the box's corner
/// edges pass through pixel centres) and what the filter spreads of them — a few percent at most;
/// elsewhere the f32 rounding of a rasterized against a ray-traced G-buffer.
fn assert_matches_mirror(name: &str, c: &LinearImage, g: &LinearImage) {
    assert!(g.all_finite());
    let far = differing(c, g, 0.02);
    let n = (W * H) as usize;
    let mut d: Vec<f32> = c
        .pixels
        .iter()
        .zip(&g.pixels)
        .map(|(p, q)| (0..3).map(|k| (p[k] - q[k]).abs()).fold(0.0, f32::max))
        .collect();
    d.sort_by(f32::total_cmp);
    let (median, p90) = (d[n / 2], d[n * 9 / 10]);
    println!("{name}: {far} of {n} pixels differ by more than 0.02; median |Δ| {median:e}, 90th percentile {p90:e}");
    save_comparison(&format!("interleaved-{}", name.replace(' ', "-")), c, g);
    assert!(far * 100 <= 3 * n, "{name}: {far} pixels differ");
    assert!(median < 1e-5 && p90 < 1e-3, "{name}: median {median}, 90th percentile {p90}");
}

/// `cornell` through a lens (focused on the sphere, the back wall blurred) or with the sphere moving
/// across the shutter: rendered as 4 accumulated passes of `accumulation`'s samples, each a whole
/// interleaved frame (a moving scene's VPLs traced per pass), equal to the mirror's frame pass for
/// pass; and with VPL shadow maps rendered per pass for the moving sphere, close to exact visibility.
#[test]
fn depth_of_field_and_motion_match_the_mirror_pass_for_pass() {
    let mut r = renderer();
    let base = InterleavedOptions { photons: 128, ..no_visibility() };
    let mut lens = cornell();
    lens.camera.aperture_radius = 0.08;
    lens.camera.focus_distance = 3.0;
    let mut moving = cornell();
    let sphere = moving.objects.iter_mut().find(|o| o.name == "sphere").expect("the sphere");
    let open = sphere.transform_open();
    sphere.set_close(glam::Mat4::from_translation(glam::Vec3::new(0.3, 0.2, 0.0)) * open);
    let passes = frame_passes(&moving, 4, moving.image.seed);
    assert_eq!(passes.len(), 4);
    assert_eq!(frame_passes(&cornell(), 4, 1).len(), 1, "a still pinhole scene is one pass");
    for (name, scene) in [("lens", &lens), ("motion", &moving)] {
        let g = gpu_passes(&mut r, scene, base, 4);
        let c = cpu_frame(scene, &base, 4, false);
        assert_matches_mirror(&format!("{name} 4 passes"), &c, &g);
        // The passes do differ: the blur is there.
        assert!(differing(&g, &gpu(&mut r, &cornell(), base), 0.02) > 100, "{name}: no blur");
    }
    let exact = cpu_frame(&moving, &base, 4, true);
    let maps = gpu_passes(&mut r, &moving, InterleavedOptions { vpl_maps: Some(32), ..base }, 4);
    let none = gpu_passes(&mut r, &moving, base, 4);
    let (m_maps, m_none) = (
        shutter::metrics::compare(&exact, &maps).unwrap(),
        shutter::metrics::compare(&exact, &none).unwrap(),
    );
    println!("motion, against exact VPL visibility: maps FLIP {:.4}, none {:.4}", m_maps.flip, m_none.flip);
    save_comparison("interleaved-motion-vpl-shadow-maps", &exact, &maps);
    assert!(m_maps.flip < 0.5 * m_none.flip && m_maps.flip < 0.05, "{} against {}", m_maps.flip, m_none.flip);
}

#[test]
fn one_and_two_pass_splits_render_the_same_image() {
    let scene = cornell();
    let mut r = renderer();
    let base = InterleavedOptions { photons: 128, pattern: Pattern { n: 4, m: 2 }, ..no_visibility() };
    let one = gpu(&mut r, &scene, InterleavedOptions { split: Split::OnePass, ..base });
    for block in [(1, 1), (2, 3), (5, 4)] {
        let two = gpu(&mut r, &scene, InterleavedOptions { split: Split::TwoPass, block, ..base });
        assert_eq!(one.pixels, two.pixels, "blocks of {block:?} patterns");
    }
}

#[test]
fn what_interleaved_does_not_model_is_refused() {
    let mut r = renderer();
    let s = RenderSettings::new(32, 24, 1, 1);
    let mut message = |scene: &Scene| match r.render(scene, Technique::INTERLEAVED, &s) {
        Ok(_) => panic!("rendered"),
        Err(e) => e.to_string(),
    };
    // No indirect light to shade.
    let mut plain = cornell();
    plain.environment.indirect = shutter::scene::Indirect::None;
    let m = message(&plain);
    assert!(m.contains("one-bounce"), "{m}");
    // Transparency.
    let mut glass = cornell();
    glass.objects[0].material.alpha = 0.5;
    let m = message(&glass);
    assert!(m.contains("opaque"), "{m}");
}

/// The bilinear pairs fetched by the hardware's linear filter (`bilinear=sampler`, the paper's
/// half-texel trick) against the same pairs lerped in the shader: the sampler quantizes the lerp's
/// fraction to `subTexelPrecisionBits`, so each pair may move by 2^-bits of its two texels'
/// difference, and with the kernel's weights normalized, each of the two passes by at most 2^-bits of
/// the image's largest value.
#[test]
fn hardware_filtered_pairs_match_the_shader_lerp() {
    let scene = cornell();
    let mut r = renderer();
    let caps = r.device().caps.clone();
    if !caps.has(shutter::vk::Feature::LinearFilterRgba32f) {
        println!("skipped: {} cannot filter R32G32B32A32_SFLOAT linearly", caps.device_name);
        return;
    }
    let blur = Some(Blur { radius: 4, bilinear: true, edges: Edges::Texel });
    let base = InterleavedOptions { photons: 128, blur, ..no_visibility() };
    let pairs = gpu(&mut r, &scene, base);
    let sampled = gpu(&mut r, &scene, InterleavedOptions { bilinear_sampler: true, ..base });
    let largest = pairs.pixels.iter().flat_map(|p| p[..3].iter().copied()).fold(0.0f32, f32::max);
    let bound = 2.0 * largest * 0.5f32.powi(caps.sub_texel_precision_bits as i32);
    let worst = pairs
        .pixels
        .iter()
        .zip(&sampled.pixels)
        .flat_map(|(p, q)| (0..3).map(move |c| (p[c] - q[c]).abs()))
        .fold(0.0f32, f32::max);
    println!(
        "hardware-filtered pairs: largest |Δ| {worst:e}, bound {bound:e} ({} sub-texel bits)",
        caps.sub_texel_precision_bits
    );
    assert!(worst <= bound, "{worst} > {bound}");
    // Without pairs there is nothing for the sampler to fetch.
    let mut s = RenderSettings::new(W, H, 1, 1);
    s.interleaved = InterleavedOptions { bilinear_sampler: true, ..no_visibility() };
    let Err(e) = r.render(&scene, Technique::INTERLEAVED, &s) else { panic!("rendered") };
    let e = e.to_string();
    assert!(e.contains("bilinear pairs"), "{e}");
}

/// VPL shadow maps (the paper's SSM, `vpl_maps`, the default): with them the image comes close to the mirror with
/// exact shadow rays to the VPLs, much closer than without visibility (SNSM) — the maps do occlude —
/// and the rest is the maps' resolution and bias.
#[test]
fn vpl_shadow_maps_approach_exact_visibility() {
    let scene = cornell();
    let mut r = renderer();
    let base = InterleavedOptions { photons: 128, ..no_visibility() };
    let exact = cpu_frame(&scene, &base, 1, true);
    // The default options: VPL shadow maps of 32² a face.
    let maps = gpu(&mut r, &scene, InterleavedOptions { photons: 128, ..Default::default() });
    let none = gpu(&mut r, &scene, base);
    let (m_maps, m_none) = (
        shutter::metrics::compare(&exact, &maps).unwrap(),
        shutter::metrics::compare(&exact, &none).unwrap(),
    );
    println!(
        "against exact VPL visibility: shadow maps RMSE {:.4} FLIP {:.4}; none RMSE {:.4} FLIP {:.4}",
        m_maps.rmse, m_maps.flip, m_none.rmse, m_none.flip
    );
    save_comparison("interleaved-vpl-shadow-maps", &exact, &maps);
    assert!(m_maps.flip < 0.5 * m_none.flip && m_maps.rmse < 0.5 * m_none.rmse);
    assert!(m_maps.flip < 0.05, "FLIP {}", m_maps.flip);
}
