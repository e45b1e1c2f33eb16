//! The quality planner (`engine/src/quality_plan.rs`, `shutter render --quality`) against measurements
//! on built-in scenes: the chosen render's FLIP against the ground truth comes within a stated factor
//! of the prediction (its GPU time is a benchmark's: `scripts/quality-targets.sh`); a scene with
//! nothing to simulate stays `pinhole`, without a pilot; over several seeds and two scenes (one object moving; shadow maps) the planned render meets
//! its target in at least 9 cases of 10, and the plan does not swing with the seed (issue 28 item 9).

use shutter::image::LinearImage;
use shutter::metrics::compare;
use shutter::quality_plan::{plan_quality, CostModel, QualityTarget};
use shutter::reference::ReferenceSettings;
use shutter::scene::builtin::builtin_scene;
use shutter::scene::{Light, Scene};
use shutter::techniques::{RenderSettings, Technique};
use shutter_tests::render_reference;
use shutter_tests::{renderer, save_comparison};

/// Predicted FLIP against the reference: within this factor either way.
const FLIP_FACTOR: f64 = 2.0;

#[test]
fn predictions_hold_against_the_reference() {
    let mut r = renderer();
    // The built-in model, not a calibration cached on this machine: the test must not depend on it.
    let (w, h) = (96, 54);
    let cost = CostModel::built_in(&r.device().caps, (w, h));
    for name in ["default", "one-mover"] {
        let scene = builtin_scene(name).unwrap().unwrap();
        let settings = RenderSettings::new(w, h, 16, scene.image.seed);
        let plan = plan_quality(&mut r, &scene, &settings, QualityTarget::Flip(0.05), &cost).unwrap();
        let pilot = plan.pilot.clone().expect("the scene blurs: a pilot");
        let c = &plan.choice;
        let chosen = RenderSettings { spp: c.spp, ..settings };
        let frames = r.render_frames(&scene, c.technique, &chosen, 2).unwrap();
        let ms = frames[1].timings.total_ms();
        let reference = render_reference(
            &scene,
            &ReferenceSettings {
                width: w,
                height: h,
                spp: 1024,
                seed: 77,
                progress: false,
                shading: Default::default(),
            },
        )
        .unwrap();
        let flip = compare(&reference, &frames[1].image).unwrap().flip;
        println!(
            "{name}: {} at S = {}: FLIP {flip:.4} (predicted {:.4}), GPU {ms:.1} ms (predicted {:.1}); pilot noise FLIP {:.4} per sub-frame",
            c.technique, c.spp, c.predicted_flip, c.predicted_ms, pilot.noise_flip
        );
        assert!(plan.reaches_target());
        assert!(
            flip <= FLIP_FACTOR * c.predicted_flip && flip >= c.predicted_flip / FLIP_FACTOR,
            "{name}: FLIP {flip} against the predicted {}",
            c.predicted_flip
        );
        // The predicted GPU ms is a timing: not asserted here (the test binary's other test runs
        // beside this one; CI machines are shared). `scripts/quality-targets.sh` measures it against
        // the median of warm frames of one interleaved run (docs/QUALITY.md).
        assert!(
            c.predicted_ms.is_finite() && c.predicted_ms > 0.0,
            "{name}: predicted {} ms",
            c.predicted_ms
        );
        // On lavapipe the per-object stochastic frame costs ~60× accumulation's passes.
        if r.device().caps.is_lavapipe() {
            assert_eq!(c.technique, Technique::ACCUMULATION);
        }
        // A stricter target takes at least as many samples, and reaches it.
        let finer = plan_quality(&mut r, &scene, &settings, QualityTarget::Flip(0.02), &cost).unwrap();
        assert!(
            finer.choice.spp >= c.spp && finer.reaches_target(),
            "{} against {}",
            finer.choice.spp,
            c.spp
        );
    }
    // Nothing to simulate: pinhole, no pilot (its image is `pinhole`'s, tests/tests/auto.rs).
    let still = builtin_scene("static").unwrap().unwrap();
    let plan =
        plan_quality(&mut r, &still, &RenderSettings::new(w, h, 16, 1), QualityTarget::Final, &cost).unwrap();
    assert_eq!(plan.choice.technique, Technique::PINHOLE);
    assert!(plan.pilot.is_none() && plan.candidates.is_empty());
}

/// The CPU reference of `scene` at `w × h` and `spp` rays per pixel (its own seed).
fn reference(scene: &Scene, (w, h): (u32, u32), spp: u32) -> LinearImage {
    let rs = ReferenceSettings {
        width: w,
        height: h,
        spp,
        seed: 77,
        progress: false,
        shading: Default::default(),
    };
    render_reference(scene, &rs).unwrap()
}

/// `static` with the sun casting shadows and a slight depth of field (every object ~0.3–0.5 px of
/// blur at 96×54, so the planner plans): the shadow maps' bias, not the noise, is most of the error.
fn shadow_scene() -> Scene {
    let mut scene = builtin_scene("static").unwrap().unwrap();
    scene.name = "static-sun-shadows".into();
    scene.camera.aperture_radius = 0.05;
    for light in &mut scene.lights {
        if let Light::Directional { shadows, .. } = light {
            *shadows = true;
        }
    }
    scene
}

/// Issue 28 item 9: `--quality good` on a scene with one object moving picked S = 9 with one seed and
/// S = 72 with another (one pair of seeds measured the noise) and missed by 2.2×; with shadow maps it
/// promised the target while their bias was 10× the noise. Over five seeds on `one-mover` and on a
/// scene with sun shadows, the planned render (the choice's technique, S and shadow maps) meets the
/// target against a high-spp reference in at least 9 cases of 10; between seeds, the predictions
/// agree within 1.25× and, where the noise dominates, S within 2×.
#[test]
fn planned_renders_meet_the_target_over_seeds() {
    let mut r = renderer();
    let (w, h) = (96, 54);
    let cost = CostModel::built_in(&r.device().caps, (w, h));
    let target = QualityTarget::Good;
    let mut met = 0;
    let mut cases = Vec::new();
    for scene in [builtin_scene("one-mover").unwrap().unwrap(), shadow_scene()] {
        let truth = reference(&scene, (w, h), 2048);
        let (mut spps, mut promised, mut pilot_noise) = (Vec::new(), Vec::new(), Vec::new());
        for seed in [1u64, 2, 3, 4, 5] {
            let settings = RenderSettings::new(w, h, 16, seed);
            let plan = plan_quality(&mut r, &scene, &settings, target, &cost).unwrap();
            let c = plan.choice.clone();
            let mut chosen = RenderSettings { spp: c.spp, ..settings };
            if let Some(size) = c.shadow_map {
                chosen.shadows.size = size;
            }
            let image = r.render(&scene, c.technique, &chosen).unwrap().image;
            let flip = compare(&truth, &image).unwrap().flip;
            let ok = flip <= target.flip() as f64;
            met += ok as usize;
            let line = format!(
                "{} seed {seed}: {} S = {} shadow maps {:?}: FLIP {flip:.4} ({}), promised ≤ {:.4} (predicted {:.4}, noise {:.4}, bias {:.4}, noise sd {:.4} of {:.4} at S = 4)",
                scene.name,
                c.technique,
                c.spp,
                c.shadow_map,
                if ok { "met" } else { "MISSED" },
                c.flip_high,
                c.predicted_flip,
                c.noise_flip,
                c.bias_flip,
                plan.pilot.as_ref().unwrap().noise_sd,
                plan.pilot.as_ref().unwrap().noise_flip
            );
            println!("{line}");
            if !ok {
                save_comparison(&format!("quality-plan-{}-seed{seed}", scene.name), &truth, &image);
            }
            cases.push(line);
            spps.push(c.spp);
            promised.push(c.flip_high);
            pilot_noise.push(plan.pilot.as_ref().unwrap().noise_flip);
        }
        // Where the noise dominates, S is steady (one pair of seeds swung it 8×); near a bias floor
        // S is sensitive to the floor's estimate, but what the planner measures and promises agrees:
        // the pilot's noise at S = 4 and the promised bound. (Not the predicted FLIP at the chosen
        // S: S is an integer, so in the noise-dominated regime the prediction steps with it — S = 7
        // against 10 alone moves it 1.2× — while the promise stays just under the target.)
        let (lo, hi) = (*spps.iter().min().unwrap(), *spps.iter().max().unwrap());
        let spread = |v: &[f64]| v.iter().fold((f64::MAX, 0f64), |(a, b), &p| (a.min(p), b.max(p)));
        if scene.name == "one-mover" {
            assert!(hi as f64 <= 2.0 * lo as f64, "{}: S from {lo} to {hi} between seeds", scene.name);
        }
        for (what, values) in [("promised FLIP", &promised), ("the pilot's noise FLIP", &pilot_noise)] {
            let (plo, phi) = spread(values);
            assert!(phi <= 1.25 * plo, "{}: {what} from {plo} to {phi} between seeds", scene.name);
        }
    }
    assert!(met >= 9, "the target was met in {met} of 10 cases:\n{}", cases.join("\n"));
}
