//! The quality planner behind `shutter render` with technique `auto` (issue 16): which technique and
//! how many samples per pixel reach a requested error in the least time on this device.
//!
//! **Error.** A candidate's error against the ground truth is its noise, which falls with the
//! samples, and its bias, which does not: what the GPU path models differently from the reference
//! (shadow maps, mip filtering, a stochastic shading rate other than per sample). The planner
//! measures both on the scene itself instead of guessing them from its description.
//!
//! *Noise.* The **pilot** renders `accumulation` [`PILOT_SUBFRAMES`] times at [`PILOT_SPP`] passes,
//! each sub-frame with its own seed. Each sub-frame's FLIP map against the mean of the others is its
//! noise (the bias, the same in every sub-frame, cancels; the others' mean adds 1/(n − 1) of a
//! sub-frame's variance: the safe side). The mean of those maps is the noise map at the pilot's S;
//! the spread of the sub-frames' means gives the range (below). One pair of seeds, as before issue
//! 28, varied by 3× between seeds on a scene whose one moving object dominates the noise (where its
//! few ghost copies fall); on the planner test's scenes the six sub-frames' spread was 4–27 % of
//! their mean (a standard error of 2–11 %). At `S`
//! samples the noise map is scaled by `(PILOT_SPP / S)^α`, for `S ≥ PILOT_SPP` only. Independent
//! samples would give α = 1/2; the samples are stratified (multi-jittered), so the error falls
//! faster: `default` measured α between 0.54 (S = 11 to 50) and 0.65 (3 to 35) before its floor
//! (`scripts/quality-targets.sh`). [`NOISE_EXPONENT`] is the lower end, 0.55: the safe side. Below
//! the pilot the error grows faster still (one jittered sample per pixel aliases every edge), so the
//! planner never extrapolates down.
//!
//! *Bias.* The first sub-frame's very samples go through the CPU reference
//! ([`render_reference_shared_samples`]): the two images share their noise, so their difference is
//! the forward path's bias image, exactly, whatever its cause. Its FLIP map is taken on the pilot's
//! estimate of the truth (the sub-frames' mean less the bias). Where the scene has shadow maps, the
//! first sub-frame is rendered again with maps of 2× and 4× the side (up to 8192²): more candidates,
//! each with its own measured bias and cost. The stochastic frame's bias is its own: it reads the
//! same shadow maps but shades textures at level 0, as the reference does (accumulation filters them
//! through mips), so the frame at the pilot's S is compared with the reference at the very same
//! samples, shaded per sample (the difference holds the shadow maps' bias and, where the rate is not
//! per sample, the rate's) — measured only when the frame could win on time without it (a bias only
//! adds samples); otherwise it is assumed to be accumulation's.
//!
//! *Together.* Noise and bias are independent, so per pixel their colour errors add in quadrature;
//! FLIP grows more slowly than the colour error, so the quadrature of the two FLIP maps per pixel,
//! averaged, is the safe side of the combination (it lies between the larger part and their sum).
//! The prediction has a range for the one render to come: the noise's 95 % prediction interval
//! (one-sided Student t times the sub-frames' standard deviation, widened by the mean's standard
//! error) and the bias within [`BIAS_MARGIN`]; the planner takes the fewest S whose **high end**
//! meets the target.
//! Where the bias alone exceeds the target, the target is out of reach (said so), and S is the
//! fewest whose high end is within 5 % of the bias floor. The pilot costs
//! `PILOT_SUBFRAMES × PILOT_SPP` passes plus a warm-up sub-frame, the reference at `PILOT_SPP` rays
//! per pixel, and with shadow maps a warm-up and a sub-frame per bigger map. No full reference is
//! needed.
//!
//! **Time.** `accumulation`'s passes cost the same whatever their sample, so its time is the pilot's
//! per pass times `S`. The per-object stochastic frame (`auto` at a fixed `S`) is predicted through a
//! [`CostModel`]: its ms and its noise, each as a ratio to `accumulation`'s at equal `S`, measured on
//! the device by `shutter calibrate` and kept per driver and version ([`crate::calibration`]: the
//! user's file first, then the built-in `engine/data/calibrations.toml`, with entries for both
//! lavapipe versions).
//!
//! **Choice.** Each candidate takes the fewest samples its predicted FLIP allows (at most
//! [`MAX_PLANNED_SPP`]); the cheaper in predicted ms wins. A scene with nothing to simulate is
//! `pinhole`, as `auto` renders it: no pilot, no samples to choose. The choice is per frame: the
//! stochastic candidate is itself `auto`'s per-object plan, but accumulation and stochastic are not
//! mixed within a frame.

use serde::{Deserialize, Serialize};

use crate::error::{Error, Result};
use crate::image::LinearImage;
use crate::metrics::flip_error_map;
use crate::plan::{AutoFrame, Plan};
use crate::reference::{render_reference_shared_samples, ReferenceSettings};
use crate::scene::Scene;
use crate::techniques::accumulation::accumulation_samples;
use crate::techniques::{RenderOutput, RenderSettings, Renderer, Technique};
use crate::vk::Capabilities;

/// Passes of each pilot sub-frame, and the fewest samples the planner asks for.
pub const PILOT_SPP: u32 = 4;
/// Sub-frames of the pilot, each with its own seed (module docs, "Error").
pub const PILOT_SUBFRAMES: usize = 6;
/// Warm frames of the first sub-frame the pilot times: their median is its GPU ms.
pub const PILOT_TIMED_FRAMES: usize = 3;
/// The bias' relative uncertainty in the prediction's range (module docs, "Together"): the pilot
/// estimates it from one sub-frame's samples, and on the sun-shadow test scene (96×54, seeds 1–5)
/// the floor measured against a 2,048-spp reference came out up to 1.11× the estimate.
pub const BIAS_MARGIN: f64 = 0.15;
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
    /// The stochastic frame's noise over `accumulation`'s at equal S, each measured against the mean of
    /// other seeds ([`measure_noise`]).
    pub stochastic_flip_ratio: f64,
    /// Where the numbers come from.
    pub source: String,
}

impl CostModel {
    /// The project's built-in model for `caps`' device at `size` (`engine/data/calibrations.toml`),
    /// ignoring the user's calibrations: equal costs where the file has no entry for the driver.
    pub fn built_in(caps: &Capabilities, size: (u32, u32)) -> CostModel {
        crate::calibration::cost_model_from(
            caps,
            crate::calibration::CalibrationFile::built_in()
                .calibration
                .into_iter()
                .map(|c| ("built-in".to_string(), c))
                .filter(|(_, c)| c.applies_to(caps)),
            size,
        )
    }

    /// The model the planner uses on `caps`' device for a `size` image: the user's calibration
    /// (`shutter calibrate`), else the built-in one ([`crate::calibration`]). A user file that does
    /// not parse is an error.
    pub fn load(caps: &Capabilities, size: (u32, u32)) -> Result<CostModel> {
        crate::calibration::cost_model(caps, size)
    }

    /// Both ratios finite and positive (a scene with nothing to simulate measures no noise).
    pub fn is_valid(&self) -> bool {
        [self.stochastic_ms_ratio, self.stochastic_flip_ratio].iter().all(|r| r.is_finite() && *r > 0.0)
    }
}

/// One way to render the frame, with its predicted cost and error.
#[derive(Clone, Debug, PartialEq)]
pub struct Candidate {
    pub technique: Technique,
    pub spp: u32,
    /// The shadow maps' side this candidate renders with, where it is not the settings' own.
    pub shadow_map: Option<u32>,
    pub predicted_ms: f64,
    /// The predicted mean FLIP against the ground truth, at the central noise estimate.
    pub predicted_flip: f64,
    /// The prediction's range for one render: the noise's 95 % prediction interval from the
    /// sub-frames' spread ([`Pilot::noise_sd`]) and the bias within [`BIAS_MARGIN`]; the planner
    /// picks S so that the high end meets the target.
    pub flip_low: f64,
    pub flip_high: f64,
    /// The noise part alone at S (central) and the bias part alone (the FLIP its bias image costs on
    /// this scene): the floor the prediction tends to as S grows.
    pub noise_flip: f64,
    pub bias_flip: f64,
    /// What the bias is and where its number comes from.
    pub bias: String,
}

/// What the pilot measured.
#[derive(Clone, Debug, PartialEq)]
pub struct Pilot {
    /// Passes of each sub-frame.
    pub spp: u32,
    /// Sub-frames (each `accumulation` at `spp` with its own seed).
    pub subframes: usize,
    /// The noise of one sub-frame: the mean over the sub-frames of its FLIP against the mean of the
    /// others.
    pub noise_flip: f64,
    /// The standard deviation of the sub-frames' values: how far one render's noise strays.
    pub noise_sd: f64,
    /// The standard error of `noise_flip` (`noise_sd` over √n).
    pub noise_se: f64,
    /// The sub-frames' FLIPs, in seed order.
    pub noise_flips: Vec<f64>,

    /// GPU ms of one warm sub-frame.
    pub ms: f64,
    /// `accumulation`'s bias at the settings' shadow maps: FLIP of its bias image, measured against
    /// the CPU reference with the first sub-frame's samples (None: not measured, see `notes`).
    pub bias_flip: Option<f64>,
    /// What could not be measured, and why.
    pub notes: Vec<String>,
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
    /// Plans `scene` for `target` with the device's own cost model ([`CostModel::load`]: the user's
    /// `shutter calibrate` file, else the built-in calibration of the driver) and applies the choice
    /// to `technique` and `settings`: what `shutter render` does for `auto` without `--spp`.
    pub fn plan_and_apply(
        renderer: &mut Renderer,
        scene: &Scene,
        technique: &mut Technique,
        settings: &mut RenderSettings,
        target: QualityTarget,
    ) -> Result<QualityPlan> {
        let cost = CostModel::load(&renderer.device().caps, (settings.width, settings.height))?;
        let plan = plan_quality(renderer, scene, settings, target, &cost)?;
        plan.apply(technique, settings);
        Ok(plan)
    }

    /// Sets `technique`, S and the shadow maps' size to the choice's (nothing when there was nothing
    /// to simulate: `technique` stays `auto`, which renders the scene as `pinhole`).
    pub fn apply(&self, technique: &mut Technique, settings: &mut RenderSettings) {
        if self.pilot.is_some() {
            (*technique, settings.spp) = (self.choice.technique, self.choice.spp);
            if let Some(size) = self.choice.shadow_map {
                settings.shadows.size = size;
            }
        }
    }

    /// Whether the choice's prediction reaches the target at the high end of its noise estimate
    /// (false when even [`MAX_PLANNED_SPP`] samples do not, or a bias alone exceeds it).
    pub fn reaches_target(&self) -> bool {
        self.choice.flip_high <= self.target.flip() as f64 * 1.0001
    }

    /// One line: the choice, its prediction with its range and parts, and where they come from.
    pub fn summary(&self) -> String {
        let c = &self.choice;
        match &self.pilot {
            None => format!(
                "quality {}: nothing to simulate, pinhole (MSAA 4x): the sharp image, no samples to choose",
                self.target.name()
            ),
            Some(p) => format!(
                "quality {} (FLIP ≤ {}): {} at S = {}{}, predicted {:.1} GPU ms, FLIP {:.4} (95 %: {:.4}–{:.4}; noise {:.4} and bias {:.4}: {}){} (pilot: accumulation S = {} × {} seeds, noise FLIP {:.4} per sub-frame, sd {:.4}, {:.1} ms each; cost model: {}){}",
                self.target.name(),
                self.target.flip(),
                c.technique,
                c.spp,
                c.shadow_map.map(|s| format!(", shadow maps {s}²")).unwrap_or_default(),
                c.predicted_ms,
                c.predicted_flip,
                c.flip_low,
                c.flip_high,
                c.noise_flip,
                c.bias_flip,
                c.bias,
                if self.reaches_target() { "" } else { " — the target is out of reach: see the bias, or the sample limit" },
                p.spp,
                p.subframes,
                p.noise_flip,
                p.noise_sd,
                p.ms,
                self.cost.source,
                if p.notes.is_empty() { String::new() } else { format!("; {}", p.notes.join("; ")) }
            ),
        }
    }

    /// What a render with the choice promises: its high end, and the central prediction.
    pub fn promise(&self) -> String {
        let c = &self.choice;
        match &self.pilot {
            None => "pinhole: nothing to simulate, no error predicted".into(),
            Some(_) => format!(
                "promised FLIP ≤ {:.4} against the ground truth (predicted {:.4}, range {:.4}–{:.4}; target {}{})",
                c.flip_high,
                c.predicted_flip,
                c.flip_low,
                c.flip_high,
                self.target.flip(),
                if self.reaches_target() { "" } else { ", out of reach" }
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

/// The seed of the pilot's sub-frame `k`: the settings' own for the first, then the measurement's
/// second seed (as [`measure_noise`]) and its multiples mixed in.
fn subframe_seed(seed: u64, k: usize) -> u64 {
    if k == 0 {
        seed
    } else {
        seed ^ OTHER_SEED.wrapping_mul(k as u64)
    }
}

/// What one render configuration measures for the planner: its GPU ms and its noise.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct NoiseMeasurement {
    /// The median GPU ms of the warm frames.
    pub ms: f64,
    /// The noise as the pilot measures it (each seed's image against the mean of the others), less
    /// what the others' own noise adds (the factor `sqrt(k / (k − 1))` for `k` seeds): one image's
    /// noise, comparable between measurements of different seed counts.
    pub noise_flip: f64,
}

/// Renders `technique` at `settings` for one warm-up and `warm_frames` timed frames, then once with
/// each further seed up to `seeds` (at least 2): `shutter calibrate`'s measurement, a ratio of two
/// techniques' noise on one scene (the planner's own noise estimate is the pilot's,
/// [`plan_quality`]). The noise is measured as the pilot measures accumulation's, so that the ratio
/// scales the pilot's estimate like for like.
pub fn measure_noise(
    renderer: &mut Renderer,
    scene: &Scene,
    technique: Technique,
    settings: &RenderSettings,
    warm_frames: usize,
    seeds: usize,
) -> Result<NoiseMeasurement> {
    let seeds = seeds.max(2);
    let (ms, image) = measure_ms(renderer, scene, technique, settings, warm_frames)?;
    let mut images = vec![image];
    for k in 1..seeds {
        let other = RenderSettings { seed: subframe_seed(settings.seed, k), ..*settings };
        images.push(renderer.render(scene, technique, &other)?.image);
    }
    let (_, flips) = noise_against_the_others(&images)?;
    let mean = flips.iter().sum::<f64>() / flips.len() as f64;
    let k = seeds as f64;
    Ok(NoiseMeasurement { ms, noise_flip: mean / (k / (k - 1.0)).sqrt() })
}

/// Renders `technique` at `settings` for one warm-up and `warm_frames` timed frames: the median GPU
/// ms of the timed frames, and the last frame's image.
pub fn measure_ms(
    renderer: &mut Renderer,
    scene: &Scene,
    technique: Technique,
    settings: &RenderSettings,
    warm_frames: usize,
) -> Result<(f64, LinearImage)> {
    let mut frames = renderer.render_frames(scene, technique, settings, warm_frames.max(1) + 1)?;
    let mut ms: Vec<f64> = frames[1..].iter().map(frame_ms).collect();
    ms.sort_by(f64::total_cmp);
    Ok((ms[ms.len() / 2], frames.pop().expect("a frame").image))
}

/// Each image of independent seeds against the mean of the others: their mean FLIP map and each
/// one's mean FLIP. What all share (the bias) cancels; the others' mean adds 1/(k − 1) of one
/// image's variance (the safe side).
fn noise_against_the_others(images: &[LinearImage]) -> Result<(Vec<f32>, Vec<f64>)> {
    let k = images.len();
    let inv = 1.0 / k as f32;
    let pooled = combine(&images.iter().map(|i| (i, inv)).collect::<Vec<_>>());
    let others_w = 1.0 / (k - 1) as f32;
    let mut noise_map = vec![0f32; pooled.pixels.len()];
    let mut noise_flips = Vec::with_capacity(k);
    for img in images {
        let others = combine(&[(&pooled, k as f32 * others_w), (img, -others_w)]);
        let map = flip_values(&others, img)?;
        noise_flips.push(map.iter().map(|&v| v as f64).sum::<f64>() / map.len() as f64);
        for (m, v) in noise_map.iter_mut().zip(&map) {
            *m += v / k as f32;
        }
    }
    Ok((noise_map, noise_flips))
}

/// How the noise part of FLIP scales from `pilot_spp` samples to `spp` (module docs).
pub fn noise_scale(pilot_spp: u32, spp: u32) -> f64 {
    noise_scale_with(pilot_spp, spp, NOISE_EXPONENT)
}

/// [`noise_scale`] with the exponent `alpha`.
pub fn noise_scale_with(pilot_spp: u32, spp: u32, alpha: f64) -> f64 {
    (pilot_spp as f64 / spp as f64).powf(alpha)
}

/// The predicted FLIP at `spp` samples from a noise of `noise` at `pilot_spp`, without bias (module
/// docs).
pub fn predicted_flip(noise: f64, pilot_spp: u32, spp: u32) -> f64 {
    noise * noise_scale(pilot_spp, spp)
}

/// A candidate's error model: per pixel, the FLIP of the pilot's noise at `pilot_spp` samples and
/// the FLIP of the candidate's bias image (module docs, "Error").
#[derive(Clone, Debug, PartialEq)]
pub struct ErrorModel {
    pub pilot_spp: u32,
    /// Per pixel: the noise's FLIP at `pilot_spp`.
    pub noise: Vec<f32>,
    /// Per pixel: the bias' FLIP (empty: none).
    pub bias: Vec<f32>,
    /// How the noise falls with S: `S^-exponent` (fitted from the pilot renders, [`Pilot`]).
    pub exponent: f64,
    /// The relative half-width of the noise's range per t (one render's spread and the mean's, over
    /// the mean) and the t factor (0: exact).
    pub noise_rel_spread: f64,
    pub t: f64,
}

impl ErrorModel {
    /// The mean over the pixels of the noise, scaled to `spp` and by `factor`, combined with the
    /// bias scaled by `bias_factor` in quadrature per pixel (module docs: noise and bias are
    /// independent; per pixel their colour errors add in quadrature, and FLIP grows more slowly than
    /// the colour error, so quadrature of the FLIPs is the safe side).
    fn flip_at(&self, spp: u32, factor: f64, bias_factor: f64) -> f64 {
        let k = noise_scale_with(self.pilot_spp, spp, self.exponent) * factor;
        let n = self.noise.len().max(1) as f64;
        if self.bias.is_empty() {
            return self.noise.iter().map(|&v| v as f64 * k).sum::<f64>() / n;
        }
        self.noise
            .iter()
            .zip(&self.bias)
            .map(|(&v, &b)| ((v as f64 * k).powi(2) + (b as f64 * bias_factor).powi(2)).sqrt())
            .sum::<f64>()
            / n
    }
    /// The central prediction at `spp`.
    pub fn central(&self, spp: u32) -> f64 {
        self.flip_at(spp, 1.0, 1.0)
    }
    /// The high end at `spp`: the noise at its estimate plus `t` spreads, the bias with
    /// [`BIAS_MARGIN`].
    pub fn high(&self, spp: u32) -> f64 {
        self.flip_at(spp, 1.0 + self.t * self.noise_rel_spread, 1.0 + BIAS_MARGIN)
    }
    /// The low end at `spp`.
    pub fn low(&self, spp: u32) -> f64 {
        self.flip_at(spp, (1.0 - self.t * self.noise_rel_spread).max(0.0), 1.0 - BIAS_MARGIN)
    }
    /// The noise alone at `spp` (central).
    pub fn noise_flip(&self, spp: u32) -> f64 {
        let n = self.noise.len().max(1) as f64;
        self.noise.iter().map(|&v| v as f64).sum::<f64>() / n
            * noise_scale_with(self.pilot_spp, spp, self.exponent)
    }
    /// The bias alone: the floor the prediction tends to.
    pub fn bias_flip(&self) -> f64 {
        self.bias.iter().map(|&v| v as f64).sum::<f64>() / self.bias.len().max(1) as f64
    }

    /// The fewest samples in `pilot_spp ..= MAX_PLANNED_SPP` whose high end is at most `target`.
    /// Where none is (the bias alone, or the sample limit), the fewest whose high end is within 5 %
    /// of the floor's: more samples would buy nothing the bias leaves.
    pub fn samples_for(&self, target: f64) -> u32 {
        let lo = self.pilot_spp.clamp(1, MAX_PLANNED_SPP);
        let goal = if self.high(MAX_PLANNED_SPP) <= target {
            target
        } else {
            let floor = self.bias_flip() * (1.0 + BIAS_MARGIN);
            if floor > 0.0 && floor * 1.05 >= self.high(MAX_PLANNED_SPP) {
                floor * 1.05
            } else {
                return MAX_PLANNED_SPP;
            }
        };
        if self.high(lo) <= goal {
            return lo;
        }
        // The high end falls with S: bisect for the fewest samples reaching the goal.
        let (mut bad, mut good) = (lo, MAX_PLANNED_SPP);
        while good - bad > 1 {
            let mid = bad + (good - bad) / 2;
            if self.high(mid) <= goal {
                good = mid;
            } else {
                bad = mid;
            }
        }
        good
    }
}

/// Per-pixel FLIP of `test` against `reference`.
fn flip_values(reference: &LinearImage, test: &LinearImage) -> Result<Vec<f32>> {
    Ok(flip_error_map(reference, test)?.0.pixels.iter().map(|p| p[0]).collect())
}

/// `Σ weights[i] · images[i]`, per colour channel (alpha 1).
fn combine(images: &[(&LinearImage, f32)]) -> LinearImage {
    let (w, h) = (images[0].0.width, images[0].0.height);
    let mut out = LinearImage::new(w, h);
    for (i, px) in out.pixels.iter_mut().enumerate() {
        for (img, wt) in images {
            let p = img.pixels[i];
            for c in 0..3 {
                px[c] += wt * p[c];
            }
        }
        px[3] = 1.0;
    }
    out
}

/// The one-sided 95 % Student t for `n - 1` degrees of freedom (n ≥ 2), the range's factor.
fn t95(n: usize) -> f64 {
    const T: [f64; 10] = [6.314, 2.920, 2.353, 2.132, 2.015, 1.943, 1.895, 1.860, 1.833, 1.812];
    T.get(n.saturating_sub(2)).copied().unwrap_or(1.645)
}

/// What the pilot measures: the sub-frames' noise map and spread, the warm ms, and the bias images.
struct PilotData {
    pilot: Pilot,
    noise_map: Vec<f32>,
    /// The pooled mean of the sub-frames minus accumulation's bias image: the truth as far as the
    /// pilot knows it.
    truth: LinearImage,
    /// accumulation's bias as a FLIP map on `truth` (its image is GPU minus same-sample
    /// reference, at the settings' shadow maps).
    bias_map: Option<Vec<f32>>,
    /// Bigger shadow maps ([`BIGGER_SHADOW_MAPS`]): their side, the bias image and the ms of one
    /// sub-frame.
    bigger_shadows: Vec<(u32, LinearImage, f64)>,
}

/// The pilot (module docs, "Error"): [`PILOT_SUBFRAMES`] `accumulation` sub-frames of [`PILOT_SPP`]
/// passes, each with its own seed; the first sub-frame's samples through the CPU reference; where
/// the scene has shadow maps, the first sub-frame again with maps of 2× and 4× the side.
fn run_pilot(renderer: &mut Renderer, scene: &Scene, settings: &RenderSettings) -> Result<PilotData> {
    let k = PILOT_SUBFRAMES;
    let base = RenderSettings { spp: PILOT_SPP, ..*settings };
    let mut images = Vec::with_capacity(k);
    let mut ms = 0.0;
    for i in 0..k {
        let s = RenderSettings { seed: subframe_seed(settings.seed, i), ..base };
        // The first is timed: the median of PILOT_TIMED_FRAMES after a warm-up frame (one frame's
        // time swings with whatever else the machine runs); the others are each the first frame of
        // their preparation, which pays for first uses (3× a warm frame on lavapipe at 96×54): untimed.
        let image = if i == 0 {
            let (median, image) =
                measure_ms(renderer, scene, Technique::ACCUMULATION, &s, PILOT_TIMED_FRAMES)?;
            ms = median;
            image
        } else {
            let mut frames = renderer.render_frames(scene, Technique::ACCUMULATION, &s, 1)?;
            frames.pop().expect("a frame").image
        };
        images.push(image);
    }
    let inv = 1.0 / k as f32;
    let pooled = combine(&images.iter().map(|i| (i, inv)).collect::<Vec<_>>());
    // Each sub-frame against the mean of the others.
    let (noise_map, noise_flips) = noise_against_the_others(&images)?;
    let noise_flip = noise_flips.iter().sum::<f64>() / k as f64;
    let var = noise_flips.iter().map(|f| (f - noise_flip).powi(2)).sum::<f64>() / (k - 1) as f64;
    let noise_sd = var.sqrt();
    let noise_se = noise_sd / (k as f64).sqrt();

    // The bias: the first sub-frame against the reference with its very samples, which differ only
    // where the forward path models the scene differently (shadow maps, mip filtering, ...).
    let mut notes = Vec::new();
    let reference_settings = ReferenceSettings {
        width: settings.width,
        height: settings.height,
        spp: PILOT_SPP,
        seed: settings.seed,
        progress: false,
        shading: Default::default(),
    };
    let reference = render_reference_shared_samples(
        scene,
        &reference_settings,
        &accumulation_samples(PILOT_SPP, settings.seed),
    );
    let (bias, truth) = match reference {
        Ok(r) => {
            let d = combine(&[(&images[0], 1.0), (&r, -1.0)]);
            let truth = combine(&[(&pooled, 1.0), (&d, -1.0)]);
            (Some((d, r)), truth)
        }
        Err(e) => {
            notes.push(format!("bias not measured: the reference refused the scene ({e})"));
            (None, pooled.clone())
        }
    };
    // Bigger shadow maps: their own bias with the same samples, and their cost.
    let mut bigger_shadows = Vec::new();
    if let Some((_, r)) = &bias {
        if settings.shadows.enabled && scene.lights.iter().any(|l| l.shadows()) {
            for factor in BIGGER_SHADOW_MAPS {
                let size = settings.shadows.size.saturating_mul(factor);
                if size > MAX_SHADOW_MAP {
                    notes.push(format!("shadow maps of {size}² not tried (at most {MAX_SHADOW_MAP}²)"));
                    break;
                }
                let mut s = base;
                s.shadows.size = size;
                let mut frames = renderer.render_frames(scene, Technique::ACCUMULATION, &s, 2)?;
                let out = frames.pop().expect("a frame");
                let d = combine(&[(&out.image, 1.0), (r, -1.0)]);
                bigger_shadows.push((size, d, frame_ms(&out)));
            }
        }
    }
    let bias_image = bias.map(|(d, _)| d);
    let acc_bias_map = bias_image.as_ref().map(|d| bias_map(&truth, d)).transpose()?;
    let bias_flip = acc_bias_map.as_ref().map(|m| m.iter().map(|&v| v as f64).sum::<f64>() / m.len() as f64);
    let pilot = Pilot {
        spp: PILOT_SPP,
        subframes: k,
        noise_flip,
        noise_se,
        noise_sd,
        noise_flips,
        ms,
        bias_flip,
        notes,
    };
    Ok(PilotData { pilot, noise_map, truth, bias_map: acc_bias_map, bigger_shadows })
}

/// The largest shadow map the planner tries (the settings' limit).
const MAX_SHADOW_MAP: u32 = 8192;
/// The shadow maps the planner tries besides the settings' own, as multiples of their side.
const BIGGER_SHADOW_MAPS: [u32; 2] = [2, 4];

/// A candidate to be priced: its model, its ms per sample, and how to describe it.
#[derive(Clone)]
struct Priced {
    technique: Technique,
    shadow_map: Option<u32>,
    model: ErrorModel,
    ms_per_sample: f64,
    bias: String,
}

impl Priced {
    fn candidate(&self, target: f64) -> Candidate {
        let spp = self.model.samples_for(target);
        Candidate {
            technique: self.technique,
            spp,
            shadow_map: self.shadow_map,
            predicted_ms: self.ms_per_sample * spp as f64,
            predicted_flip: self.model.central(spp),
            flip_low: self.model.low(spp),
            flip_high: self.model.high(spp),
            noise_flip: self.model.noise_flip(spp),
            bias_flip: self.model.bias_flip(),
            bias: self.bias.clone(),
        }
    }
}

/// The FLIP map of `bias` on the pilot's truth: what the bias alone costs on this image.
fn bias_map(truth: &LinearImage, bias: &LinearImage) -> Result<Vec<f32>> {
    flip_values(truth, &combine(&[(truth, 1.0), (bias, 1.0)]))
}

/// Plans `scene` at `settings`' size and seed for `target` on `renderer`'s device with `cost`
/// (module docs): the pilot renders, then the cheapest candidate whose high end meets the target.
pub fn plan_quality(
    renderer: &mut Renderer,
    scene: &Scene,
    settings: &RenderSettings,
    target: QualityTarget,
    cost: &CostModel,
) -> Result<QualityPlan> {
    let plan = Plan::new(scene, settings.width, settings.height);
    if plan.auto_frame().0 == AutoFrame::Pinhole {
        let choice = Candidate {
            technique: Technique::PINHOLE,
            spp: 1,
            shadow_map: None,
            predicted_ms: 0.0,
            predicted_flip: 0.0,
            flip_low: 0.0,
            flip_high: 0.0,
            noise_flip: 0.0,
            bias_flip: 0.0,
            bias: "none predicted".into(),
        };
        return Ok(QualityPlan { target, choice, candidates: vec![], pilot: None, cost: cost.clone() });
    }
    let data = run_pilot(renderer, scene, settings)?;
    let p = &data.pilot;
    let t = target.flip() as f64;
    // The range is for the render to come, not for the mean of renders: a prediction interval,
    // one render's spread (the sub-frames' standard deviation) and the mean's together.
    let rel_spread = if p.noise_flip > 0.0 {
        p.noise_sd * (1.0 + 1.0 / p.subframes as f64).sqrt() / p.noise_flip
    } else {
        0.0
    };
    let noise_model = |scale: f32, bias: Vec<f32>| ErrorModel {
        pilot_spp: PILOT_SPP,
        noise: data.noise_map.iter().map(|v| v * scale).collect(),
        bias,
        exponent: NOISE_EXPONENT,
        noise_rel_spread: rel_spread,
        t: t95(p.subframes),
    };
    let shadows = settings.shadows.enabled && scene.lights.iter().any(|l| l.shadows());
    let what = if shadows {
        format!("shadow maps {}², texture filtering and shading against the reference", settings.shadows.size)
    } else {
        "texture filtering and shading against the reference".to_string()
    };
    let (acc_bias, acc_bias_text) = match &data.bias_map {
        Some(m) => (m.clone(), format!("{what}, measured with the pilot's samples")),
        None => (vec![], "not measured".to_string()),
    };
    let per_pass = p.ms / PILOT_SPP as f64;
    let mut priced = vec![Priced {
        technique: Technique::ACCUMULATION,
        shadow_map: None,
        model: noise_model(1.0, acc_bias.clone()),
        ms_per_sample: per_pass,
        bias: acc_bias_text.clone(),
    }];
    for (size, d2, ms2) in &data.bigger_shadows {
        // The truth is the pooled mean less the bias at the settings' maps; the bigger maps' image
        // is that truth plus their own bias image.
        priced.push(Priced {
            technique: Technique::ACCUMULATION,
            shadow_map: Some(*size),
            model: noise_model(1.0, bias_map(&data.truth, d2)?),
            ms_per_sample: ms2 / PILOT_SPP as f64,
            bias: format!(
                "shadow maps {size}², texture filtering and shading against the reference, measured with the pilot's samples"
            ),
        });
    }
    // The per-object stochastic frame, where `auto` renders one (not when it falls back to
    // accumulation itself): its noise is the cost model's ratio times accumulation's; it reads the
    // same shadow maps and mip chains, so it carries accumulation's bias, plus its shading rate's
    // where that is not exact — measured only if the frame could win on time without it.
    if plan.auto_frame().0 == AutoFrame::Stochastic {
        let mut st = Priced {
            technique: Technique::AUTO,
            shadow_map: None,
            model: noise_model(cost.stochastic_flip_ratio as f32, acc_bias.clone()),
            ms_per_sample: per_pass * cost.stochastic_ms_ratio,
            bias: acc_bias_text.clone(),
        };
        // Its own bias, where it could win on time without one (a bias only adds samples): the
        // frame at the pilot's S against the reference with the very same samples, shaded per
        // sample — the difference is what the frame models differently from the reference (shadow
        // maps; its shading rate where that is not per sample), exactly. Accumulation's bias is no
        // estimate of it: the stochastic frame shades textures at level 0 as the reference does,
        // where accumulation's forward passes filter them through mips.
        let rate = settings.stochastic.shading;
        let cheapest_other =
            priced.iter().map(|c| c.candidate(t)).map(|c| c.predicted_ms).fold(f64::INFINITY, f64::min);
        let unbiased = Priced { model: noise_model(cost.stochastic_flip_ratio as f32, vec![]), ..st.clone() };
        if unbiased.candidate(t).predicted_ms < cheapest_other {
            let s = RenderSettings { spp: PILOT_SPP, ..*settings };
            let frame = renderer.render(scene, Technique::AUTO, &s)?.image;
            let same_samples = ReferenceSettings {
                width: s.width,
                height: s.height,
                spp: PILOT_SPP,
                seed: s.seed,
                progress: false,
                shading: crate::reference::ReferenceShading::PerSample,
            };
            match crate::reference::render_reference(scene, &same_samples) {
                Ok(r) => {
                    st.model.bias = bias_map(&data.truth, &combine(&[(&frame, 1.0), (&r, -1.0)]))?;
                    st.bias = format!(
                        "shadow maps and shading {} against the reference, measured with the frame's own samples",
                        rate.name()
                    );
                }
                Err(e) => {
                    st.bias = format!("{acc_bias_text} (its own not measured: the reference refused it: {e})")
                }
            }
        } else {
            st.bias =
                format!("{acc_bias_text} (its own not measured: slower than the others even without a bias)");
        }
        priced.push(st);
    }
    let mut candidates: Vec<Candidate> = priced.iter().map(|c| c.candidate(t)).collect();
    // Cheapest first among those whose high end reaches the target; if none does, the lowest error.
    candidates.sort_by(|a, b| {
        let (ra, rb) = (a.flip_high <= t * 1.0001, b.flip_high <= t * 1.0001);
        rb.cmp(&ra).then(if ra {
            a.predicted_ms.total_cmp(&b.predicted_ms)
        } else {
            a.flip_high.total_cmp(&b.flip_high).then(a.predicted_ms.total_cmp(&b.predicted_ms))
        })
    });
    Ok(QualityPlan {
        target,
        choice: candidates[0].clone(),
        candidates,
        pilot: Some(data.pilot),
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
        let model = |noise: f32, bias: Vec<f32>, rel_se: f64| ErrorModel {
            pilot_spp: 8,
            noise: vec![noise; 4],
            bias,
            exponent: NOISE_EXPONENT,
            noise_rel_spread: rel_se,
            t: 2.0,
        };
        for (between, target) in [(0.08, 0.03), (0.2, 0.015), (0.01, 0.06), (0.5, 0.001)] {
            let m = model(between, vec![], 0.0);
            let s = m.samples_for(target);
            assert!((8..=MAX_PLANNED_SPP).contains(&s));
            if s < MAX_PLANNED_SPP {
                assert!(m.high(s) <= target, "{between} {target} {s}");
            }
            if s > 8 && s < MAX_PLANNED_SPP {
                assert!(m.high(s - 1) > target, "{between} {target} {s}: not the fewest");
            }
        }
        assert_eq!(model(f32::NAN, vec![], 0.0).samples_for(0.03), MAX_PLANNED_SPP);
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

    /// The high end takes the noise's uncertainty; a bias raises the prediction and sets a floor
    /// the samples cannot go below; a bias above the target is out of reach, and the planner then
    /// stops where more samples buy nothing.
    #[test]
    fn the_prediction_takes_its_uncertainty_and_the_bias() {
        let m = |bias: Vec<f32>, rel_se: f64| ErrorModel {
            pilot_spp: 4,
            noise: vec![0.04, 0.08, 0.0, 0.04],
            bias,
            exponent: NOISE_EXPONENT,
            noise_rel_spread: rel_se,
            t: 2.0,
        };
        let exact = m(vec![], 0.0);
        let unsure = m(vec![], 0.1);
        assert!((exact.central(4) - 0.04).abs() < 1e-7);
        assert!((unsure.high(4) - 0.048).abs() < 1e-7 && (unsure.low(4) - 0.032).abs() < 1e-7);
        // The upper end meets the target: more samples than the central estimate needs.
        assert!(unsure.samples_for(0.02) > exact.samples_for(0.02));
        // Per pixel in quadrature: never below either part, never above their sum.
        let biased = m(vec![0.0, 0.0, 0.03, 0.03], 0.0);
        for s in [4, 16, 64] {
            let (n, b, c) = (biased.noise_flip(s), biased.bias_flip(), biased.central(s));
            assert!(c >= n.max(b) - 1e-9 && c <= n + b + 1e-9, "S {s}: {c} from {n} and {b}");
        }
        assert!(biased.samples_for(0.02) > exact.samples_for(0.02));
        assert!(biased.central(MAX_PLANNED_SPP) > biased.bias_flip());
        // A bias above the target: out of reach; S where the noise adds at most 5 % to the floor.
        let hopeless = m(vec![0.05; 4], 0.0);
        let (s, floor) = (hopeless.samples_for(0.02), 1.05 * 0.05 * (1.0 + BIAS_MARGIN));
        assert!(s < MAX_PLANNED_SPP && hopeless.high(s) <= floor && hopeless.high(s - 1) > floor);
    }
}
