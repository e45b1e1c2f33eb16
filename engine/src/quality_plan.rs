//! The quality planner behind `shutter render` with technique `auto` (issue 16): which technique and
//! how many samples per pixel reach a requested error in the least time on this device.
//!
//! **Error.** The GPU techniques are unbiased estimators of the pixel integral (but for what the
//! reference models differently: shadow maps, the f16/f32 targets), so their error against the ground
//! truth is, up to that floor, their noise, which falls with the samples. The planner measures the noise
//! of the scene itself instead of guessing it from the scene's description: a **pilot** renders
//! `accumulation` at [`PILOT_SPP`] passes with two seeds, and the FLIP between the two images estimates
//! either one's FLIP against the truth. (Not 1/√2 of it, as for RMSE: FLIP is not linear in the error,
//! and on `default` and `one-mover` the FLIP against the reference came out 0.9–1.3× the FLIP between
//! the seeds.) At `S` samples the prediction is that value times `(PILOT_SPP / S)^α`, for
//! `S ≥ PILOT_SPP` only. Independent samples would give α = 1/2; the samples are stratified
//! (multi-jittered), so the error falls faster: `default` measured α between 0.54 (S = 11 to 50) and
//! 0.65 (3 to 35) before its floor (`scripts/quality-targets.sh`), and α = 0.6 planned S = 33 for
//! FLIP 0.018 where 0.0197 came out. [`NOISE_EXPONENT`] is the lower end, 0.55: the safe side.
//! Below the pilot the error grows faster still (one jittered sample per pixel aliases every edge), so
//! the planner never extrapolates down. No reference
//! is needed, and the pilot costs `2 × PILOT_SPP` passes (3 frames with the warm-up).
//!
//! **Time.** `accumulation`'s passes cost the same whatever their sample, so its time is the pilot's
//! per pass times `S`. The per-object stochastic frame (`auto` at a fixed `S`) is predicted through a
//! [`CostModel`]: its ms and its noise, each as a ratio to `accumulation`'s at equal `S`, measured on
//! the device by `shutter calibrate` and cached per device and driver ([`CostModel::load`]), or the
//! built-in values for lavapipe (measured on `default`, docs/quality/default.md).
//!
//! **Choice.** Each candidate takes the fewest samples its predicted FLIP allows (at most
//! [`MAX_PLANNED_SPP`]); the cheaper in predicted ms wins. A scene with nothing to simulate is
//! `pinhole`, as `auto` renders it: no pilot, no samples to choose. The choice is per frame: the
//! stochastic candidate is itself `auto`'s per-object plan, but accumulation and stochastic are not
//! mixed within a frame.

use std::path::PathBuf;

use serde::{Deserialize, Serialize};

use crate::error::{Error, Result};
use crate::metrics::compare;
use crate::plan::{AutoFrame, Plan};
use crate::scene::Scene;
use crate::techniques::{RenderOutput, RenderSettings, Renderer, Technique};
use crate::vk::Capabilities;

/// Passes of each pilot render, and the fewest samples the planner asks for.
pub const PILOT_SPP: u32 = 4;
/// How FLIP falls with the samples per pixel: `S^-α` (module docs).
pub const NOISE_EXPONENT: f64 = 0.55;
/// The most samples per pixel the planner asks for.
pub const MAX_PLANNED_SPP: u32 = 1024;

/// A requested image quality: the mean FLIP against the ground truth to reach.
#[derive(Clone, Copy, Debug, PartialEq)]
pub enum QualityTarget {
    /// FLIP 0.04: previews, the noise plain to see.
    Draft,
    /// FLIP 0.018 (the default): what `auto` gave `default` at the scene's S = 16 before the planner
    /// (docs/QUALITY.md, "Quality targets"); noise hard to see at a glance.
    Good,
    /// FLIP 0.01: about where the GPU techniques meet what they model differently from the reference
    /// (shadow maps, targets), their floor on the built-in scenes.
    Final,
    /// A mean FLIP in (0, 1).
    Flip(f32),
}

impl QualityTarget {
    pub fn flip(&self) -> f32 {
        match *self {
            QualityTarget::Draft => 0.04,
            QualityTarget::Good => 0.018,
            QualityTarget::Final => 0.01,
            QualityTarget::Flip(f) => f,
        }
    }

    /// `--target-flip X`: a finite FLIP in (0, 1).
    pub fn from_flip(f: f32) -> Result<Self> {
        if f > 0.0 && f < 1.0 {
            Ok(QualityTarget::Flip(f))
        } else {
            Err(Error::Unsupported(format!("target FLIP {f}: a mean FLIP between 0 and 1, e.g. 0.03")))
        }
    }

    pub fn name(&self) -> String {
        match self {
            QualityTarget::Draft => "draft".into(),
            QualityTarget::Good => "good".into(),
            QualityTarget::Final => "final".into(),
            QualityTarget::Flip(f) => format!("FLIP {f}"),
        }
    }
}

impl std::str::FromStr for QualityTarget {
    type Err = Error;
    fn from_str(s: &str) -> Result<Self> {
        match s {
            "draft" => Ok(QualityTarget::Draft),
            "good" => Ok(QualityTarget::Good),
            "final" => Ok(QualityTarget::Final),
            _ => Err(Error::Unsupported(format!("quality `{s}`: draft, good or final (or --target-flip X)"))),
        }
    }
}

/// How the per-object stochastic frame compares with `accumulation` on one device, at equal samples
/// per pixel (module docs).
#[derive(Clone, Debug, PartialEq, Serialize, Deserialize)]
pub struct CostModel {
    /// `VkDriverId` and device name it was measured on.
    pub driver_id: String,
    pub device_name: String,
    /// The stochastic frame's GPU ms over `accumulation`'s.
    pub stochastic_ms_ratio: f64,
    /// The stochastic frame's noise (FLIP between two seeds) over `accumulation`'s.
    pub stochastic_flip_ratio: f64,
    /// Where the numbers come from.
    pub source: String,
}

impl CostModel {
    /// The built-in model for `caps`' device: lavapipe's measured one, or for another device equal
    /// costs (an uncalibrated guess, said in `source`).
    pub fn built_in(caps: &Capabilities) -> CostModel {
        let (ms, flip, source) = if caps.is_lavapipe() {
            // docs/quality/default.md (160×90, llvmpipe): auto ÷ accumulation at S = 4, 16, 64 is
            // 59.5, 61.8, 54.6 in ms and 0.85, 0.92 in FLIP (S = 64 is the reference's floor).
            (58.0, 0.9, "built-in, measured on lavapipe (docs/quality/default.md)")
        } else {
            (1.0, 1.0, "built-in guess for an uncalibrated device: run `shutter calibrate`")
        };
        CostModel {
            driver_id: caps.driver_id.clone(),
            device_name: caps.device_name.clone(),
            stochastic_ms_ratio: ms,
            stochastic_flip_ratio: flip,
            source: source.into(),
        }
    }

    /// Where `shutter calibrate` caches the model of `caps`' device: `$SHUTTER_CACHE_DIR`, else
    /// `$XDG_CACHE_HOME/shutter`, else `$HOME/.cache/shutter`; one file per driver and device.
    pub fn cache_path(caps: &Capabilities) -> Option<PathBuf> {
        let dir = std::env::var_os("SHUTTER_CACHE_DIR")
            .map(PathBuf::from)
            .or_else(|| std::env::var_os("XDG_CACHE_HOME").map(|d| PathBuf::from(d).join("shutter")))
            .or_else(|| std::env::var_os("HOME").map(|d| PathBuf::from(d).join(".cache/shutter")))?;
        let name: String = format!("{}-{}", caps.driver_id, caps.device_name)
            .chars()
            .map(|c| if c.is_ascii_alphanumeric() || c == '-' || c == '_' { c } else { '_' })
            .collect();
        Some(dir.join(format!("cost-{name}.toml")))
    }

    /// The cached calibration of `caps`' device, or the built-in model. A cache file that does not
    /// parse, or names another device, is an error (rather than silently ignored).
    pub fn load(caps: &Capabilities) -> Result<CostModel> {
        let Some(path) = Self::cache_path(caps) else { return Ok(Self::built_in(caps)) };
        let text = match std::fs::read_to_string(&path) {
            Ok(t) => t,
            Err(e) if e.kind() == std::io::ErrorKind::NotFound => return Ok(Self::built_in(caps)),
            Err(e) => return Err(Error::io(&path, e)),
        };
        let model: CostModel = toml::from_str(&text).map_err(|e| {
            Error::Unsupported(format!(
                "cost model {}: {e} (delete it or run `shutter calibrate`)",
                path.display()
            ))
        })?;
        if !model.is_valid() {
            return Err(Error::Unsupported(format!(
                "cost model {}: its ratios must be finite and > 0 (delete it or run `shutter calibrate` on a scene that blurs)",
                path.display()
            )));
        }
        if model.driver_id != caps.driver_id || model.device_name != caps.device_name {
            return Err(Error::Unsupported(format!(
                "cost model {} is for {} ({}), not this {} ({})",
                path.display(),
                model.device_name,
                model.driver_id,
                caps.device_name,
                caps.driver_id
            )));
        }
        Ok(model)
    }

    /// Both ratios finite and positive (a scene with nothing to simulate measures no noise).
    pub fn is_valid(&self) -> bool {
        [self.stochastic_ms_ratio, self.stochastic_flip_ratio].iter().all(|r| r.is_finite() && *r > 0.0)
    }

    /// Writes the model where [`CostModel::load`] finds it; returns the path. Refuses a model that is
    /// not [`CostModel::is_valid`].
    pub fn save(&self, caps: &Capabilities) -> Result<PathBuf> {
        if !self.is_valid() {
            return Err(Error::Unsupported(format!(
                "cost model not saved: ratios {} (ms) and {} (noise) — measure it on a scene that blurs, e.g. `shutter calibrate default`",
                self.stochastic_ms_ratio, self.stochastic_flip_ratio
            )));
        }
        let path = Self::cache_path(caps)
            .ok_or_else(|| Error::Unsupported("no cache directory: set SHUTTER_CACHE_DIR or HOME".into()))?;
        if let Some(dir) = path.parent() {
            std::fs::create_dir_all(dir).map_err(|e| Error::io(dir, e))?;
        }
        let text = toml::to_string(self).map_err(|e| Error::Unsupported(format!("cost model: {e}")))?;
        std::fs::write(&path, text).map_err(|e| Error::io(&path, e))?;
        Ok(path)
    }
}

/// One way to render the frame, with its predicted cost and error.
#[derive(Clone, Debug, PartialEq)]
pub struct Candidate {
    pub technique: Technique,
    pub spp: u32,
    pub predicted_ms: f64,
    pub predicted_flip: f64,
}

/// What the pilot measured.
#[derive(Clone, Debug, PartialEq)]
pub struct Pilot {
    pub spp: u32,
    /// FLIP between the two seeds' images.
    pub flip_between: f64,
    /// GPU ms of one warm pilot frame.
    pub ms: f64,
}

/// The planner's answer.
#[derive(Clone, Debug, PartialEq)]
pub struct QualityPlan {
    pub target: QualityTarget,
    /// The chosen candidate (the first of `candidates`).
    pub choice: Candidate,
    /// Every candidate, cheapest first; empty when nothing is to simulate.
    pub candidates: Vec<Candidate>,
    /// `None`: nothing to simulate, `pinhole`.
    pub pilot: Option<Pilot>,
    pub cost: CostModel,
}

impl QualityPlan {
    /// Whether the choice's predicted FLIP reaches the target (false when even
    /// [`MAX_PLANNED_SPP`] samples do not).
    pub fn reaches_target(&self) -> bool {
        self.choice.predicted_flip <= self.target.flip() as f64 * 1.0001
    }

    /// One line: the choice, its prediction and where it comes from.
    pub fn summary(&self) -> String {
        let c = &self.choice;
        match &self.pilot {
            None => format!(
                "quality {}: nothing to simulate, pinhole (MSAA 4x): the sharp image, no samples to choose",
                self.target.name()
            ),
            Some(p) => format!(
                "quality {} (FLIP ≤ {}): {} at S = {}, predicted {:.1} GPU ms, FLIP {:.4}{} (pilot: accumulation S = {} twice, FLIP {:.4} between seeds, {:.1} ms; cost model: {})",
                self.target.name(),
                self.target.flip(),
                c.technique,
                c.spp,
                c.predicted_ms,
                c.predicted_flip,
                if self.reaches_target() { "" } else { " — the target is out of reach within the sample limit" },
                p.spp,
                p.flip_between,
                p.ms,
                self.cost.source
            ),
        }
    }
}

/// The GPU ms of a frame (the CPU frame time where the device has no timestamps).
fn frame_ms(out: &RenderOutput) -> f64 {
    let gpu = out.timings.total_ms();
    if gpu > 0.0 {
        gpu
    } else {
        out.stats.cpu_frame_ms
    }
}

/// The second seed of a noise measurement (mixed into the settings' seed).
const OTHER_SEED: u64 = 0x9e37_79b9_7f4a_7c15;

/// What one render configuration measures for the planner: its GPU ms and its noise.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct NoiseMeasurement {
    /// The median GPU ms of the warm frames.
    pub ms: f64,
    /// FLIP between the images of two seeds.
    pub flip_between: f64,
}

/// Renders `technique` at `settings` for one warm-up and `warm_frames` timed frames, then once with
/// another seed: the pilot's and `shutter calibrate`'s measurement.
pub fn measure_noise(
    renderer: &mut Renderer,
    scene: &Scene,
    technique: Technique,
    settings: &RenderSettings,
    warm_frames: usize,
) -> Result<NoiseMeasurement> {
    let frames = renderer.render_frames(scene, technique, settings, warm_frames.max(1) + 1)?;
    let mut ms: Vec<f64> = frames[1..].iter().map(frame_ms).collect();
    ms.sort_by(f64::total_cmp);
    let other = RenderSettings { seed: settings.seed ^ OTHER_SEED, ..*settings };
    let other = renderer.render(scene, technique, &other)?;
    let flip_between = compare(&frames[1].image, &other.image)?.flip;
    Ok(NoiseMeasurement { ms: ms[ms.len() / 2], flip_between })
}

/// The predicted FLIP at `spp` samples from a noise of `flip_between` between two pilots of
/// `pilot_spp` (module docs).
pub fn predicted_flip(flip_between: f64, pilot_spp: u32, spp: u32) -> f64 {
    flip_between * (pilot_spp as f64 / spp as f64).powf(NOISE_EXPONENT)
}

/// The fewest samples whose [`predicted_flip`] is at most `target`, within
/// `pilot_spp ..= MAX_PLANNED_SPP` (module docs: no extrapolation below the pilot).
pub fn samples_for(flip_between: f64, pilot_spp: u32, target: f64) -> u32 {
    let s = (pilot_spp as f64 * (flip_between / target).powf(1.0 / NOISE_EXPONENT)).ceil();
    let lo = pilot_spp.clamp(1, MAX_PLANNED_SPP) as f64;
    let mut spp = if s.is_finite() { s.clamp(lo, MAX_PLANNED_SPP as f64) as u32 } else { MAX_PLANNED_SPP };
    // The ceiling may land one short by rounding.
    while spp < MAX_PLANNED_SPP && predicted_flip(flip_between, pilot_spp, spp) > target {
        spp += 1;
    }
    spp
}

/// Plans `scene` at `settings`' size and seed for `target` on `renderer`'s device with `cost`
/// (module docs): the pilot renders, then the cheapest candidate.
pub fn plan_quality(
    renderer: &mut Renderer,
    scene: &Scene,
    settings: &RenderSettings,
    target: QualityTarget,
    cost: &CostModel,
) -> Result<QualityPlan> {
    let plan = Plan::new(scene, settings.width, settings.height);
    if plan.auto_frame().0 == AutoFrame::Pinhole {
        let choice =
            Candidate { technique: Technique::PINHOLE, spp: 1, predicted_ms: 0.0, predicted_flip: 0.0 };
        return Ok(QualityPlan { target, choice, candidates: vec![], pilot: None, cost: cost.clone() });
    }
    let pilot_settings = RenderSettings { spp: PILOT_SPP, ..*settings };
    let NoiseMeasurement { ms, flip_between } =
        measure_noise(renderer, scene, Technique::ACCUMULATION, &pilot_settings, 1)?;
    let pilot = Pilot { spp: PILOT_SPP, flip_between, ms };
    let per_pass = ms / PILOT_SPP as f64;
    let t = target.flip() as f64;
    let acc_spp = samples_for(flip_between, PILOT_SPP, t);
    let accumulation = Candidate {
        technique: Technique::ACCUMULATION,
        spp: acc_spp,
        predicted_ms: per_pass * acc_spp as f64,
        predicted_flip: predicted_flip(flip_between, PILOT_SPP, acc_spp),
    };
    // The stochastic frame's noise at S is the ratio times accumulation's.
    let st_noise = flip_between * cost.stochastic_flip_ratio;
    let st_spp = samples_for(st_noise, PILOT_SPP, t);
    let stochastic = Candidate {
        technique: Technique::AUTO,
        spp: st_spp,
        predicted_ms: per_pass * st_spp as f64 * cost.stochastic_ms_ratio,
        predicted_flip: predicted_flip(st_noise, PILOT_SPP, st_spp),
    };
    let mut candidates = vec![accumulation, stochastic];
    // Cheapest first among those reaching the target; if none does, the lowest error.
    candidates.sort_by(|a, b| {
        let (ra, rb) = (a.predicted_flip <= t * 1.0001, b.predicted_flip <= t * 1.0001);
        rb.cmp(&ra).then(if ra {
            a.predicted_ms.total_cmp(&b.predicted_ms)
        } else {
            a.predicted_flip.total_cmp(&b.predicted_flip)
        })
    });
    Ok(QualityPlan {
        target,
        choice: candidates[0].clone(),
        candidates,
        pilot: Some(pilot),
        cost: cost.clone(),
    })
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn targets_parse_and_samples_meet_them() {
        assert_eq!("good".parse::<QualityTarget>().unwrap().flip(), 0.018);
        assert!("better".parse::<QualityTarget>().is_err());
        for bad in [0.0, 1.0, -0.1, f32::NAN, f32::INFINITY] {
            assert!(QualityTarget::from_flip(bad).is_err(), "{bad}");
        }
        // Four times the samples: 4^-α of the noise.
        let f = predicted_flip(0.08, 8, 8);
        assert!((predicted_flip(0.08, 8, 32) - 4f64.powf(-NOISE_EXPONENT) * f).abs() < 1e-12);
        for (between, target) in [(0.08, 0.03), (0.2, 0.015), (0.01, 0.06), (0.5, 0.001)] {
            let s = samples_for(between, 8, target);
            assert!((8..=MAX_PLANNED_SPP).contains(&s));
            if s < MAX_PLANNED_SPP {
                assert!(predicted_flip(between, 8, s) <= target, "{between} {target} {s}");
            }
            if s > 8 && s < MAX_PLANNED_SPP {
                assert!(predicted_flip(between, 8, s - 1) > target, "{between} {target} {s}: not the fewest");
            }
        }
        assert_eq!(samples_for(f64::NAN, 8, 0.03), MAX_PLANNED_SPP);
        // A calibration on a scene without blur measures no noise: not a model.
        let model = |ms: f64, flip: f64| CostModel {
            driver_id: String::new(),
            device_name: String::new(),
            stochastic_ms_ratio: ms,
            stochastic_flip_ratio: flip,
            source: String::new(),
        };
        assert!(model(58.0, 0.9).is_valid());
        for (ms, flip) in [(1.7, 0.0), (0.0, 1.0), (f64::NAN, 1.0), (1.0, f64::INFINITY)] {
            assert!(!model(ms, flip).is_valid(), "{ms} {flip}");
        }
    }
}
