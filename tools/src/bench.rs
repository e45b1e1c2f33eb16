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
    pub counters: Option<Counters>,
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
    /// Commit, driver, CPU, command and environment (absent in reports written before it existed).
    #[serde(default)]
    pub provenance: Option<crate::provenance::Provenance>,
}

pub struct BenchArgs {
    pub configs: Vec<Config>,
    pub frames: usize,
    pub warmup: usize,
    pub counters: bool,
}

fn uses_stochastic(r: &ConfigResult, c: &Config) -> bool {
    c.technique == Technique::STOCHASTIC
        || (c.technique == Technique::AUTO && r.plan.as_deref().is_some_and(|p| p != "pinhole"))
}

pub fn run(renderer: &mut Renderer, scene: &Scene, a: &BenchArgs) -> Result<BenchReport> {
    if a.configs.is_empty() {
        bail!("no configurations to benchmark");
    }
    let progress = Progress::new("bench", ((a.warmup + a.frames) * a.configs.len()) as u64, "frames");
    progress.set_message("preparing");
    let mut prepared = Vec::with_capacity(a.configs.len());
    for c in &a.configs {
        prepared.push(
            renderer
                .prepare(scene, c.technique, &c.settings)
                .with_context(|| format!("preparing `{}`", c.label))?,
        );
    }
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
            counters: None,
        };
        if a.counters && uses_stochastic(&r, c) {
            let mut s = c.settings;
            s.stochastic.instrumented = true;
            let out =
                renderer.render(scene, c.technique, &s).with_context(|| format!("counting `{}`", c.label))?;
            r.counters = out.stats.counters.map(Counters::from);
        }
        results.push(r);
    }
    let base = results[0].gpu_ms.median;
    for r in &mut results {
        r.ratio_to_first = r.gpu_ms.median / base;
    }
    let caps = &renderer.device().caps;
    let s0 = &a.configs[0].settings;
    Ok(BenchReport {
        scene: scene.name.clone(),
        width: s0.width,
        height: s0.height,
        device: caps.device_name.clone(),
        driver: format!("{} ({})", caps.driver_name, caps.driver_info),
        api_version: caps.api_version.clone(),
        frames: a.frames,
        warmup: a.warmup,
        results,
        provenance: Some(crate::provenance::Provenance::of(caps)),
    })
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
        md.push_str("| configuration | passes × MSAA | GPU ms median (min–max) | × first | CPU frame ms | per pass (median ms) | fragments | samples tested | hits | STE | shading inv. | atlas texels (shade + gutter) | cache lookups / hits / evictions / lost / overflows |\n");
        md.push_str("|---|---:|---:|---:|---:|---|---:|---:|---:|---:|---:|---:|---:|\n");
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
                "| {} | {} × {} | {:.2} ({:.2}–{:.2}) | {:.3} | {:.2} | {} | {f} | {t} | {h} | {ste} | {inv} | {texels} | {cache} |",
                r.label,
                r.passes,
                r.msaa,
                r.gpu_ms.median,
                r.gpu_ms.min,
                r.gpu_ms.max,
                r.ratio_to_first,
                r.cpu_frame_ms.median,
                per_pass.join(", ")
            );
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
