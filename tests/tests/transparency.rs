//! Stochastic transparency on the forward path (`pinhole`, `accumulation`; docs/TRANSPARENCY.md):
//!
//! * accumulation against the reference with the very same samples
//!   (`render_reference_shared_samples` with `accumulation_samples`): the GPU's coverage decisions
//!   are the reference's, bit for bit (`common/coverage.glsl` mirrors `transparency.rs`), so alpha
//!   and tinted panes agree to float rounding — one disagreeing decision would show as an error of
//!   about a pane's contrast / S in one pixel;
//! * accumulation and pinhole against the closed-form composite of the panes: unbiased (mean error
//!   over a patch within 4 standard errors) and the per-pixel error at most that of independent
//!   coverage, σ/√S, falling with S;
//! * coverage from a texture's alpha (a generated gradient) on the GPU;
//! * every technique renders tints.

use std::sync::Arc;

use glam::{Vec2, Vec3};
use shutter::image::LinearImage;
use shutter::metrics::compare;
use shutter::reference::{render_reference_shared_samples, ReferenceSettings};
use shutter::scene::{Camera, Mesh, Scene, Texture};
use shutter::techniques::accumulation::accumulation_samples;
use shutter::techniques::{RenderSettings, Technique};
use shutter::transparency::TransparencyMethod;
use shutter_tests::panes::{composite, pane, pane_scene, panes, H, W};
use shutter_tests::{camera, max_abs_diff, renderer, save_comparison, single_object_scene, square};

/// A quad covering pixel rectangle `[x0, x1] × [y0, y1]` at view depth `z`, uv (0..1) across it.
fn pixel_quad(cam: &Camera, [x0, x1, y0, y1]: [f32; 4], z: f32) -> Arc<Mesh> {
    let s = cam.intrinsics(W, H).pixel_scale;
    let p = |x: f32, y: f32| Vec3::new((x - W as f32 / 2.0) / s * z, -(y - H as f32 / 2.0) / s * z, -z);
    Arc::new(
        Mesh::new(
            "pane",
            vec![p(x0, y1), p(x1, y1), p(x1, y0), p(x0, y0)],
            vec![],
            vec![Vec2::new(0.0, 1.0), Vec2::new(1.0, 1.0), Vec2::new(1.0, 0.0), Vec2::ZERO],
            vec![0, 1, 2, 0, 2, 3],
        )
        .expect("quad"),
    )
}

/// Per patch (left: all four panes, right: the last three) and channel: (mean error, per-pixel RMS
/// error, σ of one sample, samples in the patch, the exact value).
fn measure(img: &LinearImage, tinted: bool, spp: u32) -> Vec<(f64, f64, f64, f64, f64)> {
    let p = panes();
    let left = composite(&p, tinted);
    let right = composite(&p[1..], tinted);
    let half = W / 2;
    let mut out = vec![];
    for (cols, (mean, var)) in [(0..half, left), (half..W, right)] {
        for ch in 0..3 {
            let (mut sum, mut sq, mut n) = (0.0f64, 0.0f64, 0.0f64);
            for y in 0..H {
                for x in cols.clone() {
                    let e = img.get(x, y)[ch] as f64 - mean[ch];
                    sum += e;
                    sq += e * e;
                    n += 1.0;
                }
            }
            out.push((sum / n, (sq / n).sqrt(), var[ch].sqrt(), n * spp as f64, mean[ch]));
        }
    }
    out
}

fn settings(spp: u32, seed: u64) -> RenderSettings {
    let mut s = RenderSettings::new(W, H, spp, seed);
    s.transparency = TransparencyMethod::Stochastic;
    s
}

fn shared_sample_reference(scene: &Scene, spp: u32, seed: u64) -> LinearImage {
    let rs =
        ReferenceSettings { width: W, height: H, spp, seed, progress: false, shading: Default::default() };
    render_reference_shared_samples(scene, &rs, &accumulation_samples(spp, seed)).expect("reference")
}

// Against the reference with the same samples only rounding differs: each pass is resolved into an
// RGBA16F target (half an ulp is 2.4e-4 for values in [0.5, 1)); measured RMSE 1.8e-4, largest
// difference 2.4e-4. One coverage decision taken differently would change a pixel by ≥ ~0.02.
const SAME_SAMPLES_RMSE_MAX: f64 = 3e-4;
const SAME_SAMPLES_MAX_DIFF: f32 = 5e-4;

/// Accumulation with alpha panes, with and without tints, in either object order, equals the
/// reference rendering the same samples.
#[test]
fn accumulation_matches_the_same_sample_reference() {
    let mut r = renderer();
    for (tinted, reversed, spp, seed) in [(false, false, 16, 3), (true, false, 16, 4), (true, true, 7, 5)] {
        let scene = pane_scene(tinted, reversed);
        let out = r.render(&scene, Technique::ACCUMULATION, &settings(spp, seed)).expect("render");
        assert_eq!(out.stats.transparency, Some(TransparencyMethod::Stochastic));
        let same = shared_sample_reference(&scene, spp, seed);
        let m = compare(&same, &out.image).unwrap();
        let worst = max_abs_diff(&same, &out.image);
        let name = format!("st-accumulation-tinted-{tinted}-reversed-{reversed}-S{spp}");
        println!("{name}: RMSE {:.2e}, max |diff| {worst:.2e} vs the same samples", m.rmse);
        save_comparison(&name, &same, &out.image);
        assert!(m.rmse <= SAME_SAMPLES_RMSE_MAX, "{name}: RMSE {} vs the same samples", m.rmse);
        assert!(worst <= SAME_SAMPLES_MAX_DIFF, "{name}: max |diff| {worst}");
    }
}

/// Accumulation and pinhole are unbiased estimators of the sorted composite: the mean over each
/// patch is within 4 standard errors (of independent coverage; the stratified masks only err less),
/// the per-pixel RMS error is at most σ/√S, and accumulation's falls from S = 16 to 256.
#[test]
fn stochastic_transparency_converges_to_the_closed_form_composite() {
    let mut r = renderer();
    for tinted in [false, true] {
        let scene = pane_scene(tinted, false);
        let mut rms = vec![];
        for (technique, spp) in
            [(Technique::ACCUMULATION, 16u32), (Technique::ACCUMULATION, 256), (Technique::PINHOLE, 1)]
        {
            let out = r.render(&scene, technique, &settings(spp, 7)).expect("render");
            let s = out.stats.msaa_samples * out.stats.passes;
            let _ = shutter::image_io::save_image(
                shutter_tests::output_dir().join(format!("st-{technique}-tinted-{tinted}-S{s}.png")),
                &out.image,
            );
            let m = measure(&out.image, tinted, s);
            for &(mean_error, rms_error, sigma, samples, value) in &m {
                // Plus the RGBA16F pass target's rounding (2⁻¹¹ relative), which does not average out.
                let bound = 4.0 * sigma / samples.sqrt() + value.abs() / 2048.0;
                println!(
                    "{technique} tinted {tinted} S={s}: mean error {mean_error:+.5} (bound {bound:.5}), RMS {rms_error:.5} (σ/√S {:.5})",
                    sigma / (s as f64).sqrt()
                );
                assert!(mean_error.abs() < bound, "{technique} S={s}: mean error {mean_error} ≥ {bound}");
                assert!(rms_error <= sigma / (s as f64).sqrt(), "{technique} S={s}: RMS {rms_error} > σ/√S");
            }
            if technique == Technique::ACCUMULATION {
                rms.push(m);
            }
        }
        for (a, b) in rms[0].iter().zip(&rms[1]) {
            let ratio = a.1 / b.1;
            println!("tinted {tinted}: RMS fell by {ratio:.2} from S=16 to S=256");
            assert!(ratio > 2.8, "RMS fell by {ratio} from S=16 to 256 (expected ≥ ~4)");
        }
    }
}

/// `alpha_from_texture` on the GPU: a white pane whose texture's alpha rises from 0 to 1 across it,
/// over black: each column's mean is its coverage, as the same-sample reference says (texture
/// filtering differs: trilinear mips on the GPU, bilinear in the reference).
#[test]
fn texture_alpha_is_coverage_on_the_gpu() {
    let cam = camera(40.0, 0.0, 5.0);
    let mut scene = single_object_scene(cam.clone(), square(1.0), glam::Mat4::IDENTITY, None, W, H);
    let n = 64u32;
    let texels: Vec<u8> =
        (0..n).flat_map(|i| [255, 255, 255, ((i as f32 + 0.5) / n as f32 * 255.0).round() as u8]).collect();
    let mut o = pane(pixel_quad(&cam, [0.0, W as f32, 0.0, H as f32], 3.0), Vec3::ONE, 1.0, Vec3::ONE);
    o.material.texture = Some(Arc::new(Texture::from_srgb_rgba8("alpha gradient", n, 1, texels)));
    o.material.alpha_from_texture = true;
    scene.objects = vec![o];
    let (spp, seed) = (64, 2);
    let mut r = renderer();
    let out = r.render(&scene, Technique::ACCUMULATION, &settings(spp, seed)).expect("render");
    let same = shared_sample_reference(&scene, spp, seed);
    save_comparison("st-texture-alpha", &same, &out.image);
    let column = |img: &LinearImage, x: u32| (0..H).map(|y| img.get(x, y)[0] as f64).sum::<f64>() / H as f64;
    let mut worst = 0.0f64;
    for x in 1..W - 1 {
        let (g, c) = (column(&out.image, x), column(&same, x));
        let want = (x as f64 + 0.5) / W as f64;
        worst = worst.max((g - c).abs());
        assert!((g - want).abs() < 0.05, "column {x}: GPU coverage {g}, expected about {want}");
    }
    println!("texture alpha: largest GPU − reference column difference {worst:.4}");
    assert!(worst < 0.03, "GPU and reference columns differ by {worst}");
}

/// Every technique renders coverage and tints: the stochastic rasterizer in its coverage and tint
/// passes (tests/tests/stochastic.rs compares it sample for sample), `auto` with blur by it, without
/// blur by pinhole; with shadows of still casters everywhere (tests/tests/shadows.rs checks them).
#[test]
fn every_technique_renders_tints() {
    let mut r = renderer();
    let s = settings(4, 1);
    let mut scene = pane_scene(true, false);
    let out = r.render(&scene, Technique::STOCHASTIC, &s).expect("stochastic renders tints");
    assert_eq!(out.stats.transparency, Some(TransparencyMethod::Stochastic));
    assert!(out.timings.get("stochastic tint").is_some(), "{:?}", out.timings);
    // `auto` with blur takes the stochastic frame, tints and all.
    scene.camera.aperture_radius = 0.3;
    let out = r.render(&scene, Technique::AUTO, &s).expect("auto with blur and tints is stochastic");
    assert!(out.timings.get("stochastic tint").is_some(), "{:?}", out.timings);
    assert_eq!(out.stats.transparency, Some(TransparencyMethod::Stochastic));
    scene.camera.aperture_radius = 0.0;
    let out = r.render(&scene, Technique::AUTO, &s).expect("auto without blur is pinhole");
    assert_eq!(out.stats.transparency, Some(TransparencyMethod::Stochastic));
    scene.lights = vec![shutter::scene::Light::Point { position: Vec3::Y, color: Vec3::ONE, shadows: true }];
    for t in [Technique::PINHOLE, Technique::ACCUMULATION] {
        r.render(&scene, t, &s).expect("shadow maps with stochastic transparency");
    }
    r.render(&scene, Technique::STOCHASTIC, &s).expect("stochastic transparency with shadow maps");
    // An opaque scene reports no transparency method.
    let mut opaque = pane_scene(false, false);
    for o in &mut opaque.objects {
        o.material.alpha = 1.0;
    }
    let out = r.render(&opaque, Technique::PINHOLE, &s).expect("render");
    assert_eq!(out.stats.transparency, None);
}
