//! GPU images against the CPU ground truth (the distribution ray tracer of the same model).
//!
//! Sizes are small so the suite runs in CI on two cores; the thresholds were set from measured values
//! with a margin, and are printed so a regression shows how far it moved.

use shutter::metrics::compare;
use shutter::reference::ReferenceSettings;
use shutter::scene::builtin::builtin_scene;
use shutter::scene::file::parse_scene;
use shutter::techniques::{RenderSettings, ShadingRate, StochasticOptions, Technique};
use shutter_tests::render_reference;
use shutter_tests::{renderer, same_sample_reference, save_comparison};

fn reference(name: &str, w: u32, h: u32, spp: u32) -> shutter::image::LinearImage {
    let scene = builtin_scene(name).expect("built-in").expect("parses");
    render_reference(
        &scene,
        &ReferenceSettings {
            width: w,
            height: h,
            spp,
            seed: 1,
            progress: false,
            shading: Default::default(),
        },
    )
    .expect("reference")
}

/// Pinhole vs reference on `static` (no blur anywhere): only antialiasing and texture filtering differ.
#[test]
fn pinhole_matches_reference_on_static() {
    let (w, h) = (320, 180);
    let scene = builtin_scene("static").unwrap().unwrap();
    let reference = reference("static", w, h, 64);
    let mut r = renderer();
    let out = r.render(&scene, Technique::PINHOLE, &RenderSettings::new(w, h, 1, 1)).unwrap();
    let m = compare(&reference, &out.image).unwrap();
    println!("static pinhole vs reference: RMSE {:.5} PSNR {:.2} FLIP {:.5}", m.rmse, m.psnr, m.flip);
    save_comparison("static-pinhole", &reference, &out.image);
    assert!(m.flip <= 0.05, "mean FLIP {} > 0.05", m.flip);
}

/// Accumulation on `default` (depth of field + object and camera motion): error falls as passes grow.
#[test]
fn accumulation_converges_to_reference_on_default() {
    let (w, h) = (160, 90);
    let scene = builtin_scene("default").unwrap().unwrap();
    let reference = reference("default", w, h, 512);
    let mut r = renderer();
    let mut errors = vec![];
    for passes in [4u32, 16, 64] {
        let out = r.render(&scene, Technique::ACCUMULATION, &RenderSettings::new(w, h, passes, 2)).unwrap();
        let m = compare(&reference, &out.image).unwrap();
        println!("default accumulation P={passes}: RMSE {:.5} PSNR {:.2} FLIP {:.5}", m.rmse, m.psnr, m.flip);
        save_comparison(&format!("default-accumulation-{passes}"), &reference, &out.image);
        errors.push(m);
    }
    for pair in errors.windows(2) {
        assert!(pair[1].rmse < pair[0].rmse, "RMSE did not fall: {} -> {}", pair[0].rmse, pair[1].rmse);
        assert!(pair[1].flip < pair[0].flip, "FLIP did not fall: {} -> {}", pair[0].flip, pair[1].flip);
    }
    let last = errors.last().unwrap();
    assert!(
        last.rmse < ACCUMULATION_64_RMSE_MAX,
        "RMSE at 64 passes {} >= {}",
        last.rmse,
        ACCUMULATION_64_RMSE_MAX
    );
    assert!(
        last.flip < ACCUMULATION_64_FLIP_MAX,
        "FLIP at 64 passes {} >= {}",
        last.flip,
        ACCUMULATION_64_FLIP_MAX
    );
}

// Measured on lavapipe (Mesa 22.3.6): RMSE 0.0149, FLIP 0.0170 at 64 passes. The floor comes mostly
// from texture filtering (trilinear mips vs the reference's supersampled bilinear) and 64-sample noise.
const ACCUMULATION_64_RMSE_MAX: f64 = 0.022;
const ACCUMULATION_64_FLIP_MAX: f64 = 0.03;

/// A spot light (cone falloff, 1/d², moving with the camera's pan) on the GPU matches the CPU
/// shading model: the stochastic rasterizer shading every sample against the reference with the very
/// same samples (equal up to float rounding), and the pinhole image against the converged reference.
#[test]
fn spot_light_matches_reference() {
    let (w, h) = (96, 64);
    let scene = parse_scene(
        r#"
        [camera]
        position = [0, 3, 6]
        look_at = [0, 0, 0]
        [camera.close]
        position = [0.2, 3, 6]
        [[object]]
        name = "floor"
        mesh = "plane"
        [object.transform]
        scale = 12
        translate = [0, 0, 0]
        [[object]]
        name = "box"
        mesh = "box"
        [object.material]
        albedo = [0.9, 0.6, 0.3]
        specular = 0.4
        roughness = 0.3
        [[light]]
        type = "spot"
        position = [0.5, 4, 0.5]
        direction = [-0.1, -1, -0.2]
        color = [30, 28, 24]
        inner_angle_deg = 18
        outer_angle_deg = 32
        [environment]
        ambient = [0.02, 0.02, 0.02]
        "#,
        std::path::Path::new("."),
        "spot-light",
    )
    .expect("scene parses");
    let mut r = renderer();

    let (spp, seed) = (4, 3);
    let options = StochasticOptions { shading: ShadingRate::PerSample, ..Default::default() };
    let settings = RenderSettings::new(w, h, spp, seed).with_stochastic(options);
    let out = r.render(&scene, Technique::STOCHASTIC, &settings).expect("stochastic render");
    let same = same_sample_reference(&scene, (w, h), spp, seed, ShadingRate::PerSample, &out);
    let m = compare(&same, &out.image).unwrap();
    println!("spot stochastic vs the same samples: RMSE {:.6} FLIP {:.5}", m.rmse, m.flip);
    save_comparison("spot-stochastic-same-samples", &same, &out.image);
    assert!(m.rmse < 1e-4, "RMSE {} vs the reference with the same samples", m.rmse);

    let truth = render_reference(
        &scene,
        &ReferenceSettings {
            width: w,
            height: h,
            spp: 64,
            seed: 1,
            progress: false,
            shading: Default::default(),
        },
    )
    .expect("reference");
    let out = r.render(&scene, Technique::PINHOLE, &RenderSettings::new(w, h, 1, 1)).unwrap();
    let m = compare(&truth, &out.image).unwrap();
    println!("spot pinhole vs reference: RMSE {:.5} PSNR {:.2} FLIP {:.5}", m.rmse, m.psnr, m.flip);
    save_comparison("spot-pinhole", &truth, &out.image);
    let mean = |img: &shutter::image::LinearImage| img.pixels.iter().map(|p| p[1] as f64).sum::<f64>();
    let ratio = mean(&out.image) / mean(&truth);
    // Measured on lavapipe: RMSE 0 (same samples); pinhole FLIP 0.0137 (edges only, the pinhole is
    // not antialiased).
    assert!((ratio - 1.0).abs() < 0.03, "mean green {ratio} of the reference's");
    assert!(m.flip <= 0.03, "mean FLIP {} > 0.03", m.flip);
}
