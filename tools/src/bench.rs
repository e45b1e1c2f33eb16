//! `shutter bench`: what each technique and setting costs on one scene, measured honestly.
//!
//! Every configuration is prepared once (upload, pipelines, targets), warmed up (lavapipe compiles
//! shaders lazily on the first frame), then the timed frames run **interleaved** — frame k of every
//! configuration before frame k + 1 of any — so drift on a shared machine hits all of them alike and
//! the ratios to the first configuration are measured in one run. Per configuration: median, min and
//! max GPU ms per frame (timestamp queries) and per named pass, median CPU ms to record, submit and wait
//! for a frame, and — from one extra, separately prepared instrumented frame so the atomics never
//! disturb the timings — the sample counters (fragments, samples tested, hits, STE, shading
//! invocations). Prints a markdown table; writes JSON and CSV on request.

use std::fmt::Write as _;
use std::path::PathBuf;

use anyhow::{bail, Context, Result};
use serde::{Deserialize, Serialize};
use shutter::progress::{check_interrupt, Progress};
use shutter::scene::Scene;
use shutter::techniques::{RenderSettings, Renderer, SampleCounters, Technique};

/// One configuration: `technique[:key=value...]` with keys spp, shadow-map, transparency, bound, shading, per-pass,
/// intervals, clusters, hull; unset keys
/// take the command's defaults.
#[derive(Clone, Debug)]
pub struct Config {
    pub label: String,
    pub technique: Technique,
    pub settings: RenderSettings,
}

impl Config {
    pub fn parse(spec: &str, defaults: &RenderSettings) -> Result<Config> {
        let mut parts = spec.split(':');
        let technique: Technique = parts.next().unwrap_or_default().trim().parse()?;
        let mut settings = *defaults;
        settings.set_all(parts).with_context(|| format!("in `{spec}`"))?;
        Ok(Config { label: spec.to_string(), technique, settings })
    }
}

#[derive(Clone, Debug, Serialize, Deserialize)]
#[serde(expecting = "a statistic object (median, min, max)")]
pub struct Stat {
    pub median: f64,
    pub min: f64,
    pub max: f64,
}

impl Stat {
    /// A statistic that was not measured (NaN).
    pub fn missing() -> Stat {
        Stat { median: f64::NAN, min: f64::NAN, max: f64::NAN }
    }
    pub fn of(mut v: Vec<f64>) -> Stat {
        v.sort_by(|a, b| a.total_cmp(b));
        if v.is_empty() {
            return Stat { median: f64::NAN, min: f64::NAN, max: f64::NAN };
        }
        let n = v.len();
        let median = if n % 2 == 1 { v[n / 2] } else { 0.5 * (v[n / 2 - 1] + v[n / 2]) };
        Stat { median, min: v[0], max: v[n - 1] }
    }
}

#[derive(Clone, Debug, Serialize, Deserialize)]
#[serde(expecting = "a sample-counter object")]
pub struct Counters {
    pub fragments: u64,
    pub samples_tested: u64,
    pub samples_hit: u64,
    pub sample_test_efficiency: f64,
    pub shading_invocations: u64,
    /// Texture-space shading: atlas texels shaded by pass 1's shade and conservative sub-passes.
    #[serde(default)]
    pub atlas_texels: Option<(u64, u64)>,
    /// Decoupled shading: the memoization cache's lookups, hits, evictions and lost stores.
    #[serde(default)]
    pub cache: Option<(u64, u64, u64, u64)>,
    /// Decoupled shading's deferred mode: keys the hash table had no room for.
    #[serde(default)]
    pub cache_overflows: Option<u64>,
}

impl From<SampleCounters> for Counters {
    fn from(c: SampleCounters) -> Self {
        Counters {
            fragments: c.fragments,
            samples_tested: c.samples_tested,
            samples_hit: c.samples_hit,
            sample_test_efficiency: c.sample_test_efficiency(),
            shading_invocations: c.shading_invocations,
            atlas_texels: c.atlas_texels,
            cache: c.cache.map(|k| (k.lookups, k.hits, k.evictions, k.busy)),
            cache_overflows: c.cache.map(|k| k.overflows),
        }
    }
}

#[derive(Clone, Debug, Serialize, Deserialize)]
#[serde(expecting = "a configuration's result object")]
pub struct ConfigResult {
    pub label: String,
    pub technique: String,
    pub spp: u32,
    pub bound: String,
    pub shading: String,
    pub passes: u32,
    pub msaa: u32,
    /// Per-object paths of an `auto` frame ("pinhole" when the plan has nothing to simulate).
    pub plan: Option<String>,
    pub gpu_ms: Stat,
    /// GPU ms per named pass (triangles, stochastic, forward, accumulate, ...).
    pub passes_ms: Vec<(String, Stat)>,
    pub cpu_frame_ms: Stat,
    /// Process CPU ms per frame, every thread (absent in reports of older binaries).
    #[serde(default = "Stat::missing")]
    pub process_cpu_ms: Stat,
    /// Median GPU ms ÷ the first configuration's.
    pub ratio_to_first: f64,
    /// The median of the paired per-frame ratios (frame k ÷ the first configuration's frame k of the
    /// same interleaved round) with its bootstrap 95 % interval: the spread a reader needs before
    /// calling a ratio real (absent in older reports, and for the first configuration).
    #[serde(default)]
    pub paired_ratio: Option<RatioInterval>,
    /// GPU ms of every timed frame, in round order (absent in older reports).
    #[serde(default)]
    pub gpu_ms_frames: Vec<f64>,
    /// The first timed frame's image against the first configuration's (absent where the sizes
    /// differ, and in older reports): whether two paths that claim the same answer give it.
    #[serde(default)]
    pub image_vs_first: Option<ImageDiff>,
    pub counters: Option<Counters>,
    /// The device's pipeline statistics of the instrumented frame (absent without counters, on a
    /// device without pipeline-statistics queries, and in older reports).
    #[serde(default)]
    pub pipeline_statistics: Option<shutter::vk::PipelineStatistics>,
}

/// A ratio's median and its bootstrap 95 % interval ([`paired_ratio_interval`]).
#[derive(Clone, Copy, Debug, Serialize, Deserialize, PartialEq)]
pub struct RatioInterval {
    pub median: f64,
    pub low: f64,
    pub high: f64,
}

impl RatioInterval {
    /// `1.234 [1.201–1.270]`.
    pub fn cell(&self) -> String {
        format!("{:.3} [{:.3}–{:.3}]", self.median, self.low, self.high)
    }
}

/// How far one image is from another: root mean square and largest absolute difference over the
/// RGB channels, and whether every value is bit-identical.
#[derive(Clone, Copy, Debug, Serialize, Deserialize, PartialEq)]
pub struct ImageDiff {
    pub rmse: f64,
    pub max_abs: f64,
    pub identical: bool,
}

impl ImageDiff {
    pub fn of(a: &shutter::image::LinearImage, b: &shutter::image::LinearImage) -> Option<ImageDiff> {
        if (a.width, a.height) != (b.width, b.height) || a.pixels.is_empty() {
            return None;
        }
        let (mut sum, mut max, mut identical) = (0.0f64, 0.0f64, true);
        for (p, q) in a.pixels.iter().zip(&b.pixels) {
            for c in 0..3 {
                identical &= p[c].to_bits() == q[c].to_bits();
                let d = (p[c] as f64 - q[c] as f64).abs();
                sum += d * d;
                max = max.max(d);
            }
        }
        Some(ImageDiff { rmse: (sum / (3 * a.pixels.len()) as f64).sqrt(), max_abs: max, identical })
    }

    /// `identical`, or the RMSE and largest difference.
    pub fn cell(&self) -> String {
        if self.identical {
            "identical".into()
        } else {
            format!("RMSE {:.4}, max {:.3}", self.rmse, self.max_abs)
        }
    }
}

/// The median of the paired ratios `num[k] / den[k]` and its 95 % percentile-bootstrap interval:
/// `resamples` resamplings of the pairs with replacement (a fixed-seed generator, so a report is
/// reproducible from its frames), the 2.5th and 97.5th percentiles of their medians. Pairing by
/// round cancels the drift both configurations saw in that round; the interval shows what is left.
/// None with fewer than two pairs or a non-positive time.
pub fn paired_ratio_interval(num: &[f64], den: &[f64], resamples: usize, seed: u64) -> Option<RatioInterval> {
    let ratios: Vec<f64> = num.iter().zip(den).map(|(n, d)| n / d).collect();
    if ratios.len() < 2 || num.len() != den.len() || ratios.iter().any(|r| !r.is_finite() || *r <= 0.0) {
        return None;
    }
    let median = Stat::of(ratios.clone()).median;
    let mut next = splitmix64(seed);
    let n = ratios.len();
    let mut medians: Vec<f64> = (0..resamples.max(1))
        .map(|_| Stat::of((0..n).map(|_| ratios[(next() % n as u64) as usize]).collect()).median)
        .collect();
    medians.sort_by(|a, b| a.total_cmp(b));
    let at = |q: f64| medians[((q * (medians.len() - 1) as f64).round() as usize).min(medians.len() - 1)];
    Some(RatioInterval { median, low: at(0.025), high: at(0.975) })
}

/// SplitMix64 from `seed`: enough for bootstrap resampling indices, and no dependency.
pub fn splitmix64(seed: u64) -> impl FnMut() -> u64 {
    let mut state = seed;
    move || {
        state = state.wrapping_add(0x9E37_79B9_7F4A_7C15);
        let mut z = state;
        z = (z ^ (z >> 30)).wrapping_mul(0xBF58_476D_1CE4_E5B9);
        z = (z ^ (z >> 27)).wrapping_mul(0x94D0_49BB_1331_11EB);
        z ^ (z >> 31)
    }
}

/// Bootstrap resamples of [`paired_ratio_interval`] in a report.
pub const BOOTSTRAP_RESAMPLES: usize = 2000;

/// A configuration the device or the scene refused, and why (bench's `skip_refused`).
#[derive(Clone, Debug, Serialize, Deserialize)]
pub struct Refusal {
    pub label: String,
    pub reason: String,
}

#[derive(Clone, Debug, Serialize, Deserialize)]
#[serde(expecting = "a `shutter bench --json` report (a JSON object)")]
pub struct BenchReport {
    pub scene: String,
    pub width: u32,
    pub height: u32,
    pub device: String,
    pub driver: String,
    pub api_version: String,
    pub frames: usize,
    pub warmup: usize,
    pub results: Vec<ConfigResult>,
    /// Configurations that were refused instead of timed (only with `skip_refused`).
    #[serde(default)]
    pub refused: Vec<Refusal>,
    /// Commit, driver, CPU, command and environment (absent in reports written before it existed).
    #[serde(default)]
    pub provenance: Option<crate::provenance::Provenance>,
}

pub struct BenchArgs {
    pub configs: Vec<Config>,
    pub frames: usize,
    pub warmup: usize,
    pub counters: bool,
    /// List a configuration the device or scene refuses (in `refused`) instead of failing; the
    /// first configuration that prepares is the baseline.
    pub skip_refused: bool,
}

/// A configuration the device or scene cannot run (a missing feature, an unsupported combination,
/// a limit) — as opposed to a failure, which still stops the run.
pub fn is_refusal(e: &shutter::Error) -> bool {
    matches!(
        e,
        shutter::Error::MissingFeature { .. } | shutter::Error::Unsupported(_) | shutter::Error::Limit { .. }
    )
}

fn uses_stochastic(r: &ConfigResult, c: &Config) -> bool {
    c.technique == Technique::STOCHASTIC
        || (c.technique == Technique::AUTO && r.plan.as_deref().is_some_and(|p| p != "pinhole"))
}

pub fn run(renderer: &mut Renderer, scene: &Scene, a: &BenchArgs) -> Result<BenchReport> {
    Ok(run_with_images(renderer, scene, a)?.0)
}

/// [`run`], and the first timed frame's image of each configuration that ran (in the order of the
/// report's results).
pub fn run_with_images(
    renderer: &mut Renderer,
    scene: &Scene,
    a: &BenchArgs,
) -> Result<(BenchReport, Vec<shutter::image::LinearImage>)> {
    if a.configs.is_empty() {
        bail!("no configurations to benchmark");
    }
    let progress = Progress::new("bench", ((a.warmup + a.frames) * a.configs.len()) as u64, "frames");
    progress.set_message("preparing");
    let mut prepared = Vec::with_capacity(a.configs.len());
    let mut refused = Vec::new();
    let mut configs = Vec::with_capacity(a.configs.len());
    for c in &a.configs {
        match renderer.prepare(scene, c.technique, &c.settings) {
            Ok(p) => {
                prepared.push(p);
                configs.push(c.clone());
            }
            Err(e) if a.skip_refused && is_refusal(&e) => {
                progress.inc((a.warmup + a.frames) as u64);
                refused.push(Refusal { label: c.label.clone(), reason: e.to_string() })
            }
            Err(e) => return Err(anyhow::Error::new(e).context(format!("preparing `{}`", c.label))),
        }
    }
    if configs.is_empty() {
        bail!(
            "every configuration was refused: {}",
            refused.iter().map(|r| format!("`{}`: {}", r.label, r.reason)).collect::<Vec<_>>().join("; ")
        );
    }
    let a = &BenchArgs {
        configs,
        frames: a.frames,
        warmup: a.warmup,
        counters: a.counters,
        skip_refused: a.skip_refused,
    };
    let mut outputs: Vec<Vec<shutter::techniques::RenderOutput>> = vec![Vec::new(); a.configs.len()];
    for round in 0..a.warmup + a.frames {
        progress.set_message(if round < a.warmup { "warm-up" } else { "timed" });
        for (i, p) in prepared.iter_mut().enumerate() {
            check_interrupt()?;
            let out =
                renderer.render_prepared(p).with_context(|| format!("rendering `{}`", a.configs[i].label))?;
            if round >= a.warmup {
                outputs[i].push(out);
            }
            progress.inc(1);
        }
    }
    drop(prepared);
    progress.finish();

    let mut results = Vec::with_capacity(a.configs.len());
    for (c, outs) in a.configs.iter().zip(&outputs) {
        let first = &outs[0];
        let mut names: Vec<String> = Vec::new();
        for o in outs {
            for (n, _) in &o.timings.passes {
                if !names.contains(n) {
                    names.push(n.clone());
                }
            }
        }
        let passes_ms = names
            .iter()
            .map(|n| (n.clone(), Stat::of(outs.iter().map(|o| o.timings.get(n).unwrap_or(0.0)).collect())))
            .collect();
        let plan = first.stats.plan.as_ref().map(|p| match p.auto_frame().0 {
            shutter::plan::AutoFrame::Stochastic => p
                .objects
                .iter()
                .map(|o| format!("{}={}", o.name, o.effects.name()))
                .collect::<Vec<_>>()
                .join(" "),
            shutter::plan::AutoFrame::Pinhole => "pinhole".to_string(),
            shutter::plan::AutoFrame::Accumulation => "accumulation".to_string(),
        });
        let stochastic_options = c.technique == Technique::STOCHASTIC || c.technique == Technique::AUTO;
        let mut r = ConfigResult {
            label: c.label.clone(),
            technique: c.technique.name().into(),
            spp: c.settings.spp,
            bound: if stochastic_options { c.settings.stochastic.bound.name() } else { "-".into() },
            shading: if stochastic_options {
                c.settings.stochastic.shading.name().into()
            } else {
                "-".into()
            },
            passes: first.stats.passes,
            msaa: first.stats.msaa_samples,
            plan,
            gpu_ms: Stat::of(outs.iter().map(|o| o.timings.total_ms()).collect()),
            passes_ms,
            cpu_frame_ms: Stat::of(outs.iter().map(|o| o.stats.cpu_frame_ms).collect()),
            process_cpu_ms: Stat::of(outs.iter().map(|o| o.stats.process_cpu_ms).collect()),
            ratio_to_first: f64::NAN,
            paired_ratio: None,
            gpu_ms_frames: outs.iter().map(|o| o.timings.total_ms()).collect(),
            image_vs_first: ImageDiff::of(&first.image, &outputs[0][0].image),
            counters: None,
            pipeline_statistics: None,
        };
        if a.counters {
            let mut s = c.settings;
            s.stochastic.instrumented = true;
            let out =
                renderer.render(scene, c.technique, &s).with_context(|| format!("counting `{}`", c.label))?;
            if uses_stochastic(&r, c) {
                r.counters = out.stats.counters.map(Counters::from);
            }
            r.pipeline_statistics = out.stats.pipeline_statistics;
        }
        results.push(r);
    }
    let base = results[0].gpu_ms.median;
    let base_frames = results[0].gpu_ms_frames.clone();
    for (i, r) in results.iter_mut().enumerate() {
        r.ratio_to_first = r.gpu_ms.median / base;
        if i > 0 {
            r.paired_ratio =
                paired_ratio_interval(&r.gpu_ms_frames, &base_frames, BOOTSTRAP_RESAMPLES, 0x5EED + i as u64);
        }
    }
    let caps = &renderer.device().caps;
    let s0 = &a.configs[0].settings;
    let images = outputs.into_iter().map(|mut o| o.swap_remove(0).image).collect();
    let report = BenchReport {
        scene: scene.name.clone(),
        width: s0.width,
        height: s0.height,
        device: caps.device_name.clone(),
        driver: format!("{} ({})", caps.driver_name, caps.driver_info),
        api_version: caps.api_version.clone(),
        frames: a.frames,
        warmup: a.warmup,
        results,
        refused,
        provenance: Some(crate::provenance::Provenance::of(caps)),
    };
    Ok((report, images))
}

impl BenchReport {
    pub fn markdown(&self) -> String {
        let mut md = format!(
            "Scene `{}`, {}×{}; {} / {}, Vulkan {}; {} timed frame(s) per configuration after {} warm-up, \
             interleaved; GPU ms = sum of timestamped passes per frame.\n\n",
            self.scene,
            self.width,
            self.height,
            self.device,
            self.driver,
            self.api_version,
            self.frames,
            self.warmup
        );
        if let Some(p) = &self.provenance {
            md.push_str(&p.markdown());
            md.push('\n');
        }
        md.push_str("| configuration | passes × MSAA | GPU ms median (min–max) | × first | paired ratio [95 % CI] | image vs first | CPU frame ms | per pass (median ms) | fragments | samples tested | hits | STE | shading inv. | atlas texels (shade + gutter) | cache lookups / hits / evictions / lost / overflows | pipeline statistics (device) |\n");
        md.push_str("|---|---:|---:|---:|---:|---|---:|---|---:|---:|---:|---:|---:|---:|---:|---|\n");
        for r in &self.results {
            let per_pass: Vec<String> =
                r.passes_ms.iter().map(|(n, s)| format!("{n} {:.2}", s.median)).collect();
            let (f, t, h, ste, inv) = match &r.counters {
                Some(c) => (
                    c.fragments.to_string(),
                    c.samples_tested.to_string(),
                    c.samples_hit.to_string(),
                    format!("{:.4}", c.sample_test_efficiency),
                    c.shading_invocations.to_string(),
                ),
                None => ("-".into(), "-".into(), "-".into(), "-".into(), "-".into()),
            };
            let texels = match r.counters.as_ref().and_then(|c| c.atlas_texels) {
                Some((shaded, gutter)) => format!("{shaded} + {gutter}"),
                None => "-".into(),
            };
            let cache = match r.counters.as_ref().and_then(|c| c.cache) {
                Some((l, h, e, b)) => {
                    let o = r.counters.as_ref().and_then(|c| c.cache_overflows).unwrap_or(0);
                    format!("{l} / {h} / {e} / {b} / {o}")
                }
                None => "-".into(),
            };
            let _ = writeln!(
                md,
                "| {} | {} × {} | {:.2} ({:.2}–{:.2}) | {:.3} | {} | {} | {:.2} | {} | {f} | {t} | {h} | {ste} | {inv} | {texels} | {cache} | {} |",
                r.label,
                r.passes,
                r.msaa,
                r.gpu_ms.median,
                r.gpu_ms.min,
                r.gpu_ms.max,
                r.ratio_to_first,
                r.paired_ratio.map(|p| p.cell()).unwrap_or_else(|| "-".into()),
                r.image_vs_first.map(|d| d.cell()).unwrap_or_else(|| "-".into()),
                r.cpu_frame_ms.median,
                per_pass.join(", "),
                r.pipeline_statistics.map(|p| p.summary()).unwrap_or_else(|| "-".into())
            );
        }
        for r in &self.refused {
            let _ = writeln!(md, "\nrefused `{}`: {}", r.label, r.reason);
        }
        for r in self.results.iter().filter(|r| r.plan.is_some()) {
            let _ = writeln!(md, "\n`{}` plan: {}", r.label, r.plan.as_deref().unwrap_or(""));
        }
        md
    }

    pub fn csv(&self) -> String {
        let mut s = self.provenance.as_ref().map(|p| p.csv_comment()).unwrap_or_default();
        s.push_str(
            "scene,width,height,device,driver,label,technique,spp,bound,shading,passes,msaa,gpu_ms_median,gpu_ms_min,\
             gpu_ms_max,ratio_to_first,cpu_frame_ms_median,fragments,samples_tested,samples_hit,ste,shading_invocations,\
             atlas_texels_shaded,atlas_texels_gutter,cache_lookups,cache_hits,cache_evictions,cache_lost,cache_overflows\n",
        );
        for r in &self.results {
            let c = r.counters.as_ref();
            let _ = writeln!(
                s,
                "{},{},{},\"{}\",\"{}\",\"{}\",{},{},{},{},{},{},{:.4},{:.4},{:.4},{:.4},{:.4},{},{},{},{},{},{},{},{},{},{},{},{}",
                self.scene,
                self.width,
                self.height,
                self.device,
                self.driver.replace('"', "'"),
                r.label,
                r.technique,
                r.spp,
                r.bound,
                r.shading,
                r.passes,
                r.msaa,
                r.gpu_ms.median,
                r.gpu_ms.min,
                r.gpu_ms.max,
                r.ratio_to_first,
                r.cpu_frame_ms.median,
                c.map(|c| c.fragments.to_string()).unwrap_or_default(),
                c.map(|c| c.samples_tested.to_string()).unwrap_or_default(),
                c.map(|c| c.samples_hit.to_string()).unwrap_or_default(),
                c.map(|c| format!("{:.6}", c.sample_test_efficiency)).unwrap_or_default(),
                c.map(|c| c.shading_invocations.to_string()).unwrap_or_default(),
                c.and_then(|c| c.atlas_texels).map(|t| t.0.to_string()).unwrap_or_default(),
                c.and_then(|c| c.atlas_texels).map(|t| t.1.to_string()).unwrap_or_default(),
                c.and_then(|c| c.cache).map(|k| k.0.to_string()).unwrap_or_default(),
                c.and_then(|c| c.cache).map(|k| k.1.to_string()).unwrap_or_default(),
                c.and_then(|c| c.cache).map(|k| k.2.to_string()).unwrap_or_default(),
                c.and_then(|c| c.cache).map(|k| k.3.to_string()).unwrap_or_default(),
                c.and_then(|c| c.cache_overflows).map(|o| o.to_string()).unwrap_or_default(),
            );
        }
        s
    }

    pub fn write(&self, json: Option<&PathBuf>, csv: Option<&PathBuf>) -> Result<()> {
        if let Some(p) = json {
            shutter::image_io::write_file_atomically(p, serde_json::to_string_pretty(self)?.as_bytes())?;
            errln!("wrote {}", p.display());
        }
        if let Some(p) = csv {
            shutter::image_io::write_file_atomically(p, self.csv().as_bytes())?;
            errln!("wrote {}", p.display());
        }
        Ok(())
    }
}

/// One configuration compared across two sets of bench runs ([`compare`]).
#[derive(Clone, Debug)]
pub struct Comparison {
    pub label: String,
    /// Median over runs of each run's median GPU ms per frame: old, new.
    pub gpu_ms: (f64, f64),
    /// Median over runs of each run's median CPU frame ms: old, new.
    pub cpu_frame_ms: (f64, f64),
    /// Median over runs of each run's median process CPU ms per frame: old, new (NaN when a side's
    /// reports lack it).
    pub process_cpu_ms: (f64, f64),
}

impl Comparison {
    pub fn gpu_ratio(&self) -> f64 {
        self.gpu_ms.1 / self.gpu_ms.0
    }
    pub fn cpu_ratio(&self) -> f64 {
        self.cpu_frame_ms.1 / self.cpu_frame_ms.0
    }
    pub fn process_ratio(&self) -> f64 {
        self.process_cpu_ms.1 / self.process_cpu_ms.0
    }
}

/// Compares the configurations common to every report of `old` and `new` (the JSON of `shutter
/// bench`, e.g. of two binaries run alternately): per configuration the median over runs of the runs'
/// medians, so one disturbed run moves nothing.
pub fn compare(old: &[BenchReport], new: &[BenchReport]) -> Result<Vec<Comparison>> {
    let (Some(first), false, false) = (old.first(), old.is_empty(), new.is_empty()) else {
        bail!("bench-compare needs at least one report on each side");
    };
    let pick = |reports: &[BenchReport], label: &str, f: &dyn Fn(&ConfigResult) -> f64| -> Option<f64> {
        let v: Option<Vec<f64>> =
            reports.iter().map(|r| r.results.iter().find(|c| c.label == label).map(f)).collect();
        v.map(|v| Stat::of(v).median)
    };
    let mut out = Vec::new();
    for c in &first.results {
        let gpu = |r: &ConfigResult| r.gpu_ms.median;
        let cpu = |r: &ConfigResult| r.cpu_frame_ms.median;
        let process = |r: &ConfigResult| r.process_cpu_ms.median;
        if let (Some(go), Some(gn), Some(co), Some(cn)) = (
            pick(old, &c.label, &gpu),
            pick(new, &c.label, &gpu),
            pick(old, &c.label, &cpu),
            pick(new, &c.label, &cpu),
        ) {
            let process_cpu_ms = (
                pick(old, &c.label, &process).unwrap_or(f64::NAN),
                pick(new, &c.label, &process).unwrap_or(f64::NAN),
            );
            out.push(Comparison {
                label: c.label.clone(),
                gpu_ms: (go, gn),
                cpu_frame_ms: (co, cn),
                process_cpu_ms,
            });
        }
    }
    if out.is_empty() {
        bail!("no configuration label is in every report");
    }
    Ok(out)
}

/// The comparison as a markdown table.
pub fn comparison_markdown(scene: &str, runs: (usize, usize), rows: &[Comparison]) -> String {
    let mut s = format!(
        "`{scene}`: medians over {} old and {} new runs (each run's median frame); GPU ms: summed \
         timestamp scopes, CPU frame ms: wall time of a frame, process CPU ms: CPU time of every thread \
         of the process during a frame\n\n\
         | config | GPU ms old | new | new ÷ old | CPU frame ms old | new | new ÷ old | process CPU ms old | new | new ÷ old |\n\
         |---|---:|---:|---:|---:|---:|---:|---:|---:|---:|\n",
        runs.0, runs.1
    );
    for r in rows {
        let _ = writeln!(
            s,
            "| `{}` | {:.2} | {:.2} | {:.3} | {:.2} | {:.2} | {:.3} | {:.2} | {:.2} | {:.3} |",
            r.label,
            r.gpu_ms.0,
            r.gpu_ms.1,
            r.gpu_ratio(),
            r.cpu_frame_ms.0,
            r.cpu_frame_ms.1,
            r.cpu_ratio(),
            r.process_cpu_ms.0,
            r.process_cpu_ms.1,
            r.process_ratio()
        );
    }
    s
}

/// Reads a report written by `shutter bench --json`.
pub fn read_report(path: &std::path::Path) -> Result<BenchReport> {
    // A report is kilobytes; a 64 MiB cap keeps a wrong path (a disk image) from being read whole.
    let bytes = shutter::limits::read_capped(path, 64 << 20, "bench report", "64 MiB")?;
    let text = String::from_utf8_lossy(&bytes);
    // The parser's message may quote the file (a huge string): a fragment of it, escaped.
    serde_json::from_str(&text).map_err(|e| {
        anyhow::anyhow!(
            "parsing {} as a bench report: {}",
            path.display(),
            shutter::limits::quote_safely(&e.to_string(), 300)
        )
    })
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn a_constant_ratio_has_no_spread_and_noise_widens_the_interval() {
        let base: Vec<f64> = (0..12).map(|k| 10.0 + (k % 5) as f64).collect();
        let twice: Vec<f64> = base.iter().map(|b| 2.0 * b).collect();
        let r = paired_ratio_interval(&twice, &base, 500, 1).unwrap();
        assert_eq!((r.median, r.low, r.high), (2.0, 2.0, 2.0));
        // Drift both saw in a round cancels in the pairing: the ratio stays exact.
        let drift: Vec<f64> =
            base.iter().enumerate().map(|(k, b)| b * (1.0 + 0.3 * (k % 3) as f64)).collect();
        let drift2: Vec<f64> = drift.iter().map(|b| 1.5 * b).collect();
        assert_eq!(paired_ratio_interval(&drift2, &drift, 500, 2).unwrap().median, 1.5);
        // Noise of its own: the interval contains the median and has width.
        let noisy: Vec<f64> =
            base.iter().enumerate().map(|(k, b)| b * (1.0 + 0.1 * ((k * 7 % 5) as f64 - 2.0))).collect();
        let n = paired_ratio_interval(&noisy, &base, 2000, 3).unwrap();
        assert!(n.low < n.median && n.median < n.high, "{n:?}");
        assert!(n.low >= 0.8 - 1e-12 && n.high <= 1.2 + 1e-12, "{n:?}");
        // The same frames give the same interval (a fixed seed).
        assert_eq!(paired_ratio_interval(&noisy, &base, 2000, 3), Some(n));
    }

    #[test]
    fn too_few_or_bad_frames_have_no_interval() {
        assert_eq!(paired_ratio_interval(&[1.0], &[1.0], 100, 0), None);
        assert_eq!(paired_ratio_interval(&[1.0, 2.0], &[1.0], 100, 0), None);
        assert_eq!(paired_ratio_interval(&[1.0, 2.0], &[0.0, 1.0], 100, 0), None);
        assert_eq!(paired_ratio_interval(&[1.0, f64::NAN], &[1.0, 1.0], 100, 0), None);
    }

    #[test]
    fn image_diff_tells_identical_from_close() {
        use shutter::image::LinearImage;
        let mut a = LinearImage::new(4, 2);
        a.pixels.iter_mut().enumerate().for_each(|(i, p)| *p = [i as f32 * 0.1, 0.5, 0.25, 1.0]);
        let mut b = a.clone();
        assert_eq!(ImageDiff::of(&a, &b).map(|d| (d.identical, d.rmse)), Some((true, 0.0)));
        b.pixels[3][1] += 0.3;
        let d = ImageDiff::of(&a, &b).unwrap();
        assert!(!d.identical && (d.max_abs - 0.3).abs() < 1e-6, "{d:?}");
        assert!((d.rmse - (0.09f64 / 24.0).sqrt()).abs() < 1e-6, "{d:?}");
        // Alpha is not compared; another size is no comparison.
        let mut c = a.clone();
        c.pixels[0][3] = 0.0;
        assert!(ImageDiff::of(&a, &c).unwrap().identical);
        assert_eq!(ImageDiff::of(&a, &LinearImage::new(2, 4)), None);
    }
}
