//! The stochastic frame's two coverage paths (engine/src/techniques/stochastic/mask.rs): the mask path
//! per sample finds the same nearest hits as the visibility buffer, so its images are the same-sample
//! reference's — on the built-in scenes and on every hard case, with each shading rate the reference
//! mirrors and behind both hulls. The per-fragment mode's error is the hard-case matrix' business
//! (tests/tests/hard_cases.rs, its own column).

use shutter::hard_cases::CASES;
use shutter::metrics::compare;
use shutter::scene::builtin::builtin_scene;
use shutter::scene::Scene;
use shutter::techniques::stochastic::{Coverage, MaskRate};
use shutter::techniques::{
    HullExpansion, RenderOutput, RenderSettings, Renderer, ShadingRate, StochasticOptions, Technique,
};
use shutter_tests::{max_abs_diff, renderer, same_sample_reference};

/// As tests/tests/stochastic.rs: only f32 rounding may differ from the same-sample reference.
const SAME_SAMPLES_RMSE_MAX: f64 = 1e-4;

fn render(
    r: &mut Renderer,
    scene: &Scene,
    (w, h): (u32, u32),
    spp: u32,
    o: StochasticOptions,
) -> RenderOutput {
    r.render(scene, Technique::STOCHASTIC, &RenderSettings::new(w, h, spp, 3).with_stochastic(o))
        .unwrap_or_else(|e| panic!("{} coverage: {e:#}", o.coverage.name()))
}

#[test]
fn mask_coverage_per_sample_is_the_same_sample_reference() {
    let mut r = renderer();
    let size = (96, 54);
    for name in ["default", "one-mover"] {
        let scene = builtin_scene(name).unwrap().unwrap();
        for (spp, expansion) in [(16, HullExpansion::GeometryShader), (8, HullExpansion::Compute)] {
            for shading in ShadingRate::ALL {
                let o = StochasticOptions {
                    coverage: Coverage::Mask(MaskRate::Sample),
                    shading,
                    expansion,
                    ..Default::default()
                };
                let out = render(&mut r, &scene, size, spp, o);
                assert!(out.stats.msaa_samples > 1, "{name}: the mask path ran without MSAA");
                assert_eq!(out.stats.msaa_samples * out.stats.passes, spp);
                let same = same_sample_reference(&scene, size, spp, 3, shading, &out);
                let m = compare(&same, &out.image).unwrap();
                println!(
                    "{name} S={spp} {} hull, {}: MSAA {}x × {} passes, RMSE {:.2e} vs the same-sample reference",
                    expansion.name(),
                    shading.name(),
                    out.stats.msaa_samples,
                    out.stats.passes,
                    m.rmse
                );
                assert!(m.rmse < SAME_SAMPLES_RMSE_MAX, "{name} {}: RMSE {}", shading.name(), m.rmse);
            }
        }
    }
}

/// Every hard case: the mask path per sample against the visibility path at the same samples (both
/// exact, so the images agree to rounding); the per-fragment mode is printed beside it.
#[test]
fn mask_coverage_per_sample_matches_the_visibility_buffer_on_every_hard_case() {
    let mut r = renderer();
    let (size, spp) = ((48, 27), 4);
    for case in CASES {
        let scene = case.scene().unwrap();
        let with = |coverage| StochasticOptions { coverage, ..Default::default() };
        let visibility = render(&mut r, &scene, size, spp, with(Coverage::Visibility));
        let mask = render(&mut r, &scene, size, spp, with(Coverage::Mask(MaskRate::Sample)));
        let fragment = render(&mut r, &scene, size, spp, with(Coverage::Mask(MaskRate::Fragment)));
        let m = compare(&visibility.image, &mask.image).unwrap();
        let f = compare(&visibility.image, &fragment.image).unwrap();
        println!(
            "{}: mask RMSE {:.2e} (max |Δ| {:.2e}); mask-per-fragment RMSE {:.4}",
            case.name,
            m.rmse,
            max_abs_diff(&visibility.image, &mask.image),
            f.rmse
        );
        // The same hits, ties included (mask.frag): the very same image, bit for bit.
        let d = max_abs_diff(&visibility.image, &mask.image);
        assert!(
            d == 0.0,
            "{}: mask per sample differs from the visibility buffer by {d} (RMSE {})",
            case.name,
            m.rmse
        );
    }
}
