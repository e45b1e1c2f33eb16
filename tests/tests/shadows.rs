//! Shadow maps (`pinhole`, `accumulation`; docs/SHADOWS.md) against the CPU reference's shadow rays,
//! lavapipe with validation on. The GPU renders `accumulation` with the very samples of the reference
//! (`render_reference_shared_samples`), so the two differ only where the shadow map's answer differs
//! from the shadow ray's:
//!
//! * plain maps (opaque casters) for a directional, a spot and a point light (a cube): the error falls
//!   as the map's resolution grows and is small at the largest; no acne (a lit surface stays lit);
//! * stochastic maps (an alpha caster) and coloured stochastic maps (a tinted one): unbiased (the
//!   mean over the shadow matches the reference's per channel) and the noise falls as S grows;
//! * a moving caster: the maps follow each pass' shutter time;
//! * the stochastic rasterizer with depth of field: its shading pass reads the same maps (still
//!   casters), against the reference with its samples; moving casters it refuses, and `auto` takes
//!   accumulation for them.

use std::sync::Arc;

use glam::{Mat4, Vec3};
use shutter::image::LinearImage;
use shutter::mirror::shadow_maps::ShadowSettings;
use shutter::reference::{render_reference_shared_samples, ReferenceSettings};
use shutter::scene::builtin::builtin_mesh;
use shutter::scene::{Environment, ImageSettings, Light, Material, Mesh, Object, Scene};
use shutter::techniques::accumulation::accumulation_samples;
use shutter::techniques::{RenderSettings, Renderer, Technique};
use shutter::transparency::TransparencyMethod;
use shutter_tests::{camera, renderer, same_sample_reference, save_comparison, square};

const W: u32 = 64;
const H: u32 = 48;
const SEED: u64 = 7;

fn mesh(name: &str, detail: Option<u32>) -> Arc<Mesh> {
    Arc::new(builtin_mesh(name, detail).expect("built-in").expect("mesh"))
}

fn object(name: &str, mesh: Arc<Mesh>, transforms: Vec<(f32, Mat4)>, material: Material) -> Object {
    Object { name: name.into(), mesh, transforms, material }
}

/// A ground plane under a caster (a box, or a square pane lying flat) lit by `light`, seen from
/// above at an angle.
fn scene(light: Light, caster: Object) -> Scene {
    let mut cam = camera(50.0, 0.0, 5.0);
    cam.open.position = Vec3::new(0.0, 4.5, 2.0);
    cam.open.look_at = Vec3::new(-0.3, 0.0, 0.0);
    let ground = Material { albedo: Vec3::splat(0.6), ..Material::default() };
    Scene {
        name: "shadows".into(),
        image: ImageSettings { width: W, height: H, spp: 4, seed: SEED, display: Default::default() },
        camera: cam,
        objects: vec![
            object("ground", mesh("plane", Some(2)), vec![(0.0, Mat4::from_scale(Vec3::splat(2.5)))], ground),
            caster,
        ],
        lights: vec![light],
        environment: Environment {
            ambient: Vec3::splat(0.05),
            background: Vec3::new(0.2, 0.3, 0.5),
            ..Default::default()
        },
    }
}

fn a_box(transforms: Vec<(f32, Mat4)>) -> Object {
    let m = Material { albedo: Vec3::new(0.7, 0.5, 0.3), ..Material::default() };
    object("box", mesh("box", None), transforms, m)
}

fn still_box() -> Object {
    a_box(vec![(0.0, Mat4::from_translation(Vec3::new(0.1, 0.8, 0.0)) * Mat4::from_scale(Vec3::splat(0.6)))])
}

/// A flat square pane at height 1 with coverage `alpha` and `tint`.
fn pane(alpha: f32, tint: Vec3) -> Object {
    let m = Material { albedo: Vec3::new(0.9, 0.9, 0.9), alpha, tint, ..Material::default() };
    let t = Mat4::from_translation(Vec3::new(0.3, 0.8, 0.0))
        * Mat4::from_rotation_x(-std::f32::consts::FRAC_PI_2);
    object("pane", square(1.0), vec![(0.0, t)], m)
}

fn directional() -> Light {
    Light::Directional { direction: Vec3::new(-1.0, -1.2, -0.1), color: Vec3::splat(1.0), shadows: true }
}
fn spot() -> Light {
    Light::Spot {
        position: Vec3::new(1.2, 2.4, 0.1),
        direction: Vec3::new(-0.6, -1.0, -0.05),
        inner_deg: 30.0,
        outer_deg: 45.0,
        color: Vec3::splat(6.0),
        shadows: true,
    }
}
fn point() -> Light {
    Light::Point { position: Vec3::new(1.4, 2.0, 0.1), color: Vec3::splat(4.0), shadows: true }
}

/// The reference with the samples of an `accumulation` render of `spp` passes.
fn reference(scene: &Scene, spp: u32) -> LinearImage {
    let rs = ReferenceSettings {
        width: W,
        height: H,
        spp,
        seed: SEED,
        progress: false,
        shading: Default::default(),
    };
    render_reference_shared_samples(scene, &rs, &accumulation_samples(spp, SEED)).expect("reference")
}

fn accumulation(r: &mut Renderer, scene: &Scene, spp: u32, shadows: ShadowSettings) -> LinearImage {
    let mut settings = RenderSettings::new(W, H, spp, SEED);
    settings.shadows = shadows;
    r.render(scene, Technique::ACCUMULATION, &settings).expect("accumulation").image
}

/// Mean absolute difference over the colour channels, and the signed mean per channel.
fn errors(a: &LinearImage, b: &LinearImage) -> (f64, [f64; 3]) {
    let n = (a.pixels.len() * 3) as f64;
    let mut abs = 0.0;
    let mut signed = [0.0; 3];
    for (p, q) in a.pixels.iter().zip(&b.pixels) {
        for c in 0..3 {
            let d = (p[c] - q[c]) as f64;
            abs += d.abs();
            signed[c] += d / a.pixels.len() as f64;
        }
    }
    (abs / n, signed)
}

/// Plain maps for each light type: the error against the shadow rays falls with the resolution, and
/// at 512² it is small. Lit surfaces are not darkened (no acne): pixels the reference lights fully
/// differ only at shadow edges, which shrink with the texel size.
#[test]
fn plain_shadow_maps_converge_to_the_shadow_rays() {
    let mut r = renderer();
    for (name, light) in [("directional", directional()), ("spot", spot()), ("point", point())] {
        let s = scene(light, still_box());
        let want = reference(&s, 4);
        let mut errs = vec![];
        for size in [32u32, 64, 128, 512] {
            let got = accumulation(&mut r, &s, 4, ShadowSettings { size, ..ShadowSettings::default() });
            let (e, _) = errors(&got, &want);
            errs.push(e);
            if size == 512 {
                save_comparison(&format!("shadows-plain-{name}"), &want, &got);
            }
        }
        println!("{name}: mean |error| at 32, 64, 128, 512 texels: {errs:?}");
        assert!(
            errs.windows(2).all(|w| w[1] < w[0]),
            "{name}: error should fall with the resolution: {errs:?}"
        );
        assert!(errs[3] < 0.25 * errs[0], "{name}: {errs:?}");
        assert!(errs[3] < 4e-3, "{name}: at 512² the mean error is {}", errs[3]);
        // Without the light's shadows the image differs much more: the maps do shadow.
        let mut unshadowed = s.clone();
        unshadowed.lights = unshadowed.lights.iter().map(|l| without_shadows(*l)).collect();
        let (e_off, _) = errors(&accumulation(&mut r, &unshadowed, 4, ShadowSettings::default()), &want);
        assert!(e_off > 5.0 * errs[3], "{name}: unshadowed {e_off} vs shadowed {}", errs[3]);
    }
}

fn without_shadows(l: Light) -> Light {
    match l {
        Light::Directional { direction, color, .. } => {
            Light::Directional { direction, color, shadows: false }
        }
        Light::Point { position, color, .. } => Light::Point { position, color, shadows: false },
        Light::Spot { position, direction, inner_deg, outer_deg, color, .. } => {
            Light::Spot { position, direction, inner_deg, outer_deg, color, shadows: false }
        }
    }
}

/// A pane of coverage 0.35 (a stochastic map) and tinted panes (coloured maps), under a directional
/// and a point light:
/// * unbiased: at the largest S the mean over the image matches the shadow rays per channel, to a
///   bound set by the texels at the shadow's edges (it halves as the resolution doubles);
/// * the noise (the error against the same map at S = 64) falls as S grows: ≈ 1/√S;
/// * a pure filter (coverage 0) blocks nothing and its hue is exact at every S.
#[test]
fn stochastic_and_coloured_shadow_maps_are_unbiased_and_converge_in_s() {
    let mut r = renderer();
    // Coverage 0.35 and 0.3 (the tinted pane blocks with probability 1 − max τ = 0.3): no S used
    // makes α·S whole, where the stratified masks would be exact.
    let cases = [
        ("alpha", pane(0.35, Vec3::ONE), true),
        ("tinted", pane(0.3, Vec3::new(1.0, 0.35, 0.15)), true),
        ("filter", pane(0.0, Vec3::new(0.2, 0.6, 1.0)), false),
    ];
    let map = |samples| ShadowSettings { size: 512, samples, pcf_radius: 0, ..ShadowSettings::default() };
    for (name, caster, noisy) in cases {
        // A point light's six faces at S = 64 would make a 400 MB atlas: S = 4 and 16 there.
        for (light, counts) in [(directional(), &[4u32, 16, 64][..]), (point(), &[4, 16][..])] {
            let s = scene(light, caster.clone());
            let want = reference(&s, 4);
            let renders: Vec<LinearImage> =
                counts.iter().map(|&n| accumulation(&mut r, &s, 4, map(n))).collect();
            let best = renders.last().expect("renders");
            let (e, signed) = errors(best, &want);
            let kind = if matches!(light, Light::Point { .. }) { "point" } else { "directional" };
            println!("{name} {kind} S {}: mean |error| {e:.5}, signed {signed:.5?}", counts.last().unwrap());
            for (c, m) in signed.iter().enumerate() {
                assert!(m.abs() < 5e-4, "{name} {kind}: channel {c} biased by {m}");
            }
            save_comparison(&format!("shadows-{name}-{kind}"), &want, best);
            let noise: Vec<f64> =
                renders[..renders.len() - 1].iter().map(|img| errors(img, best).0).collect();
            println!("{name} {kind}: noise against the largest S {noise:.6?}");
            if noisy {
                assert!(noise[0] > 1e-4, "{name} {kind}: no noise at S = 4? {noise:?}");
                assert!(noise.windows(2).all(|w| w[1] < 0.7 * w[0]), "{name} {kind}: {noise:?}");
            } else {
                assert!(noise.iter().all(|&e| e < 1e-5), "{name} {kind}: {noise:?}");
            }
        }
    }
}

/// A box moving across the shutter: each pass' map is rendered at that pass' time, so the shadow
/// sweeps with the box as the shadow rays see it.
#[test]
fn shadow_maps_follow_a_moving_caster() {
    let mut r = renderer();
    let at = |x: f32| Mat4::from_translation(Vec3::new(x, 0.8, 0.0)) * Mat4::from_scale(Vec3::splat(0.5));
    let s = scene(directional(), a_box(vec![(0.0, at(-0.8)), (1.0, at(0.8))]));
    let want = reference(&s, 8);
    let got = accumulation(&mut r, &s, 8, ShadowSettings { size: 512, ..ShadowSettings::default() });
    let (e, _) = errors(&got, &want);
    save_comparison("shadows-moving", &want, &got);
    assert!(e < 4e-3, "moving caster: mean |error| {e}");
}

/// The stochastic rasterizer with depth of field (aperture 0.08, focused on the box): its shading pass
/// looks the maps up at each sample's surface point; against the reference with its very samples the
/// error falls with the map's resolution as `accumulation`'s does. With a moving caster it refuses
/// (maps at one time), and `auto` renders that scene with `accumulation`.
#[test]
fn the_stochastic_rasterizer_reads_the_maps_of_still_casters() {
    let mut r = renderer();
    for (name, light) in [("directional", directional()), ("point", point())] {
        let mut s = scene(light, still_box());
        s.camera.aperture_radius = 0.08;
        s.camera.focus_distance = 4.5;
        let mut errs = vec![];
        for size in [64u32, 512] {
            let mut settings = RenderSettings::new(W, H, 4, SEED);
            settings.shadows = ShadowSettings { size, ..ShadowSettings::default() };
            let out = r.render(&s, Technique::STOCHASTIC, &settings).expect("stochastic with shadows");
            let want = same_sample_reference(&s, (W, H), 4, SEED, settings.stochastic.shading, &out);
            let (e, _) = errors(&out.image, &want);
            errs.push(e);
            if size == 512 {
                save_comparison(&format!("shadows-stochastic-{name}"), &want, &out.image);
            }
        }
        println!("stochastic {name}: mean |error| at 64, 512 texels: {errs:?}");
        assert!(errs[1] < 0.5 * errs[0] && errs[1] < 4e-3, "{name}: {errs:?}");
    }
    let at = |x: f32| Mat4::from_translation(Vec3::new(x, 0.8, 0.0)) * Mat4::from_scale(Vec3::splat(0.5));
    let mut moving = scene(directional(), a_box(vec![(0.0, at(-0.8)), (1.0, at(0.8))]));
    moving.camera.aperture_radius = 0.08;
    let settings = RenderSettings::new(W, H, 4, SEED);
    let err = r.render(&moving, Technique::STOCHASTIC, &settings).expect_err("moving casters").to_string();
    assert!(err.contains("moving") && err.contains("accumulation"), "{err}");
    let out = r.render(&moving, Technique::AUTO, &settings).expect("auto takes accumulation");
    assert_eq!((out.stats.passes, out.stats.msaa_samples), (4, 1));
}

/// Depth-based stochastic transparency and depth peeling read the same maps (their opaque pass and
/// their shading draws). They estimate the transparency differently from the reference's samples, so
/// what is compared is the shadows' effect: each method's image with the maps minus the same without
/// them, against the reference's with its shadow rays minus without, on a tinted alpha pane over the
/// ground; the mismatch is a small fraction of the effect.
#[test]
fn depth_based_and_peeling_read_the_shadow_maps() {
    let mut r = renderer();
    for light in [directional(), point()] {
        let s = scene(light, pane(0.35, Vec3::new(1.0, 0.6, 0.4)));
        let mut unshadowed = s.clone();
        unshadowed.lights = unshadowed.lights.iter().map(|l| without_shadows(*l)).collect();
        let (want_on, want_off) = (reference(&s, 4), reference(&unshadowed, 4));
        let effect = |on: &LinearImage, off: &LinearImage| -> Vec<[f32; 3]> {
            on.pixels.iter().zip(&off.pixels).map(|(a, b)| [a[0] - b[0], a[1] - b[1], a[2] - b[2]]).collect()
        };
        let want = effect(&want_on, &want_off);
        let size: f64 = want.iter().flat_map(|p| p.iter()).map(|v| v.abs() as f64).sum();
        for method in [
            TransparencyMethod::Stochastic,
            TransparencyMethod::DepthBased { alpha_correction: true },
            TransparencyMethod::Peeling { layers: 4 },
        ] {
            let mut settings = RenderSettings::new(W, H, 4, SEED);
            settings.transparency = method;
            settings.shadows = ShadowSettings { size: 512, samples: 16, ..ShadowSettings::default() };
            let on = r.render(&s, Technique::ACCUMULATION, &settings).expect("render");
            assert!(on.stats.shadows.is_some(), "{method}");
            settings.shadows.enabled = false;
            let off = r.render(&s, Technique::ACCUMULATION, &settings).expect("render").image;
            let got = effect(&on.image, &off);
            let mismatch: f64 = got
                .iter()
                .zip(&want)
                .flat_map(|(g, w)| (0..3).map(move |c| (g[c] - w[c]).abs() as f64))
                .sum();
            println!("{method}: shadow effect mismatch {:.4} of its size", mismatch / size);
            assert!(mismatch < 0.2 * size, "{method}: mismatch {mismatch} of an effect of {size}");
        }
    }
}

/// A hard sun (travelling +x, 50° above the horizon) over a ground plane, under a thin plate whose
/// straight edge (turned 8° about the vertical, so the rows sample every phase of the texel grid)
/// casts a shadow edge across the image; the camera looks straight down. The images are 96 × 64,
/// `accumulation` with the reference's own samples (4 per pixel).
fn edge_scene() -> Scene {
    let mut cam = camera(30.0, 0.0, 1.6);
    cam.open.position = Vec3::new(0.72, 1.6, 0.0);
    cam.open.look_at = Vec3::new(0.72, 0.0, 0.0);
    cam.open.up = Vec3::NEG_Z;
    let ground = Material { albedo: Vec3::splat(0.6), ..Material::default() };
    let plate = Mat4::from_translation(Vec3::new(-0.5, 0.5, 0.0))
        * Mat4::from_rotation_y(8f32.to_radians())
        * Mat4::from_scale(Vec3::new(0.8, 0.02, 1.4));
    Scene {
        name: "shadow-edge".into(),
        image: ImageSettings {
            width: EDGE_W,
            height: EDGE_H,
            spp: 4,
            seed: SEED,
            display: Default::default(),
        },
        camera: cam,
        objects: vec![
            object("ground", mesh("plane", Some(2)), vec![(0.0, Mat4::from_scale(Vec3::splat(1.5)))], ground),
            a_box_at(plate),
        ],
        lights: vec![Light::Directional {
            direction: Vec3::new(1.0, -1.2, 0.0),
            color: Vec3::splat(1.5),
            shadows: true,
        }],
        environment: Environment {
            ambient: Vec3::splat(0.05),
            background: Vec3::new(0.2, 0.3, 0.5),
            ..Default::default()
        },
    }
}

const EDGE_W: u32 = 96;
const EDGE_H: u32 = 64;

fn a_box_at(t: Mat4) -> Object {
    a_box(vec![(0.0, t)])
}

fn luminance(img: &LinearImage, x: usize, y: usize) -> f64 {
    let p = img.pixels[y * img.width as usize + x];
    (p[0] as f64 + p[1] as f64 + p[2] as f64) / 3.0
}

/// The mean horizontal offset, in pixels, of `got`'s shadow edge from `want`'s, positive towards the
/// light (−x, the image's left): in each row, the integral of `got − want` over a window around the
/// reference's edge, divided by the step's height (lit minus shadowed) — the sub-pixel distance the
/// edge moved, whatever the edge's profile. Returns the mean and the RMS over the rows.
fn edge_offset(got: &LinearImage, want: &LinearImage) -> (f64, f64) {
    let (w, h) = (want.width as usize, want.height as usize);
    let mut offsets = vec![];
    for y in 0..h {
        let lit = (w - 4..w).map(|x| luminance(want, x, y)).sum::<f64>() / 4.0;
        // The edge: the last pixel from the right still above half-way to the shadow's level, found
        // from the right (the plate, further left, is not ground).
        let Some(dark_at) = (0..w).rev().find(|&x| luminance(want, x, y) < 0.5 * lit) else { continue };
        let dark = luminance(want, dark_at.saturating_sub(6), y);
        let (lo, hi) = (dark_at.saturating_sub(8), (dark_at + 9).min(w));
        assert!(lit - dark > 0.1, "row {y}: no edge (lit {lit}, shadow {dark})");
        let moved: f64 = (lo..hi).map(|x| luminance(got, x, y) - luminance(want, x, y)).sum();
        offsets.push(moved / (lit - dark));
    }
    assert!(offsets.len() > h / 2, "the edge crosses only {} rows", offsets.len());
    let n = offsets.len() as f64;
    let mean = offsets.iter().sum::<f64>() / n;
    (mean, (offsets.iter().map(|o| o * o).sum::<f64>() / n).sqrt())
}

/// Issue 28 item 8: a shadow map's edge sits where the shadow rays put it — within a quarter pixel at
/// the default map (1024², PCF 3×3), closer at 4096², and wherever the PCF radius (0, 1, 2) puts its
/// filter: the filter is centred on the receiver and nothing moves the receiver across the map.
#[test]
fn shadow_edges_sit_where_the_shadow_rays_put_them() {
    let mut r = renderer();
    let s = edge_scene();
    let rs = ReferenceSettings {
        width: EDGE_W,
        height: EDGE_H,
        spp: 4,
        seed: SEED,
        progress: false,
        shading: Default::default(),
    };
    let want = render_reference_shared_samples(&s, &rs, &accumulation_samples(4, SEED)).expect("reference");
    let mut offset = |size: u32, pcf_radius: u32| {
        let mut settings = RenderSettings::new(EDGE_W, EDGE_H, 4, SEED);
        settings.shadows = ShadowSettings { size, pcf_radius, ..ShadowSettings::default() };
        let got = r.render(&s, Technique::ACCUMULATION, &settings).expect("accumulation").image;
        if (size, pcf_radius) == (1024, 1) {
            save_comparison("shadows-edge", &want, &got);
        }
        let (mean, rms) = edge_offset(&got, &want);
        println!(
            "map {size}, PCF radius {pcf_radius}: edge offset towards the light {mean:+.3} px (rms {rms:.3})"
        );
        mean
    };
    let at_1024: Vec<f64> = (0..3).map(|pcf| offset(1024, pcf)).collect();
    let at_4096 = offset(4096, 1);
    let at_256: Vec<f64> = (0..3).map(|pcf| offset(256, pcf)).collect();
    for (pcf, o) in at_1024.iter().enumerate() {
        assert!(o.abs() < 0.25, "1024², PCF radius {pcf}: the edge is {o:+.3} px off");
    }
    assert!(at_4096.abs() < 0.1, "4096²: the edge is {at_4096:+.3} px off");
    // Texels of 256² are about a pixel here: the PCF radius must not move the edge.
    let spread =
        |v: &[f64]| v.iter().cloned().fold(f64::MIN, f64::max) - v.iter().cloned().fold(f64::MAX, f64::min);
    assert!(spread(&at_256) < 0.15, "256²: the edge moves with the PCF radius: {at_256:+.3?}");
    assert!(spread(&at_1024) < 0.1, "1024²: the edge moves with the PCF radius: {at_1024:+.3?}");
}

/// No acne, down to a light grazing the surfaces: the ground plane alone, a faceted sphere alone
/// (smooth normals on 12 × 6 facets) and a turned box alone — each can shadow only itself — under a
/// sun 3°, 20° and 60° above the horizon, with the default map and with PCF radius 2. Where the shadow
/// rays leave a pixel lit (and every pixel within two of it: the sphere's terminator, where its
/// facets shadow each other), the map's render is within 3 % of its own render without shadows.
#[test]
fn no_acne_down_to_a_grazing_sun() {
    let mut r = renderer();
    let ground = {
        let m = Material { albedo: Vec3::splat(0.6), ..Material::default() };
        object("ground", mesh("plane", Some(2)), vec![(0.0, Mat4::from_scale(Vec3::splat(2.5)))], m)
    };
    let sphere = {
        let m = Material { albedo: Vec3::new(0.4, 0.6, 0.8), ..Material::default() };
        let t = Mat4::from_translation(Vec3::new(-0.3, 0.6, 0.0)) * Mat4::from_scale(Vec3::splat(0.8));
        object("sphere", mesh("sphere", Some(12)), vec![(0.0, t)], m)
    };
    let turned_box = a_box(vec![(
        0.0,
        Mat4::from_translation(Vec3::new(-0.3, 0.5, 0.0))
            * Mat4::from_rotation_y(0.5)
            * Mat4::from_rotation_x(0.3)
            * Mat4::from_scale(Vec3::splat(0.6)),
    )]);
    for elevation in [3f32, 20.0, 60.0] {
        let e = elevation.to_radians();
        let light = Light::Directional {
            direction: Vec3::new(-e.cos(), -e.sin(), -0.3 * e.cos()),
            color: Vec3::splat(2.0),
            shadows: true,
        };
        for alone in [&ground, &sphere, &turned_box] {
            let mut s = scene(light, still_box());
            s.objects = vec![alone.clone()];
            let mut unshadowed = s.clone();
            unshadowed.lights = unshadowed.lights.iter().map(|l| without_shadows(*l)).collect();
            let (want, want_off) = (reference(&s, 4), reference(&unshadowed, 4));
            let shadowed_px = |x: usize, y: usize| {
                let i = y * W as usize + x;
                (0..3).any(|c| want.pixels[i][c] < want_off.pixels[i][c] - 1e-6)
            };
            for pcf_radius in [1u32, 2] {
                let map = ShadowSettings { pcf_radius, ..ShadowSettings::default() };
                let got = accumulation(&mut r, &s, 4, map);
                let got_off = accumulation(&mut r, &unshadowed, 4, map);
                let (mut lit, mut acne) = (0, vec![]);
                for y in 0..H as usize {
                    for x in 0..W as usize {
                        let i = y * W as usize + x;
                        let near_shadow = (y.saturating_sub(2)..(y + 3).min(H as usize)).any(|v| {
                            (x.saturating_sub(2)..(x + 3).min(W as usize)).any(|u| shadowed_px(u, v))
                        });
                        let background = (0..3).all(|c| want_off.pixels[i][c] == s.environment.background[c]);
                        if near_shadow || background {
                            continue;
                        }
                        lit += 1;
                        if (0..3).any(|c| got.pixels[i][c] < 0.97 * got_off.pixels[i][c] - 1e-4) {
                            acne.push((x, y, got.pixels[i][0] / got_off.pixels[i][0]));
                        }
                    }
                }
                let name = &alone.name;
                if pcf_radius == 1 && elevation == 3.0 {
                    save_comparison(&format!("shadows-acne-{name}"), &want, &got);
                }
                println!(
                    "{name}, sun {elevation}°, PCF radius {pcf_radius}: {} of {lit} lit pixels darkened",
                    acne.len()
                );
                assert!(lit > 150, "{name}, sun {elevation}°: only {lit} lit pixels");
                assert!(
                    acne.is_empty(),
                    "{name}, sun {elevation}°, PCF radius {pcf_radius}: acne at {acne:?}"
                );
            }
        }
    }
}
