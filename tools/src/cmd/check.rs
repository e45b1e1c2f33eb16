//! `shutter check`: a rendering regression check a driver's CI can run.
//!
//! A **suite** (a TOML file, `check/smoke.toml` in the repository) lists cases — a scene, a
//! configuration in `bench`'s syntax (`stochastic:shading=per-sample`), size, samples, seed — and the
//! thresholds each is held to. Beside it, in a folder named after the suite, lie the expected images
//! (`<case>.exr`, small linear EXRs) and `conditions.toml`, what they were recorded on (commit,
//! driver, device, CPU). `--update` renders every case and writes both; a check renders every case
//! and compares it with its expected image in one of two tiers:
//!
//! * **exact**, where this run's driver, device and CPU are the recorded ones: llvmpipe is
//!   deterministic on one CPU, so any changed pixel is a change;
//! * **tolerance** elsewhere (another driver, or the same one JIT-compiling for another CPU, which may
//!   round differently): RMSE and mean FLIP within the case's thresholds. The report says which tier
//!   ran and why.
//!
//! A case may also ask for **the same-sample CPU reference** (`reference = true`): the reference
//! integrates the very samples the GPU path does, so for the exact paths (stochastic per-sample,
//! per-pixel and decoupled shading on the visibility path, per-sample mask coverage) the two agree to
//! f32 rounding on every driver. This comparison needs no recorded image and holds the same on every
//! machine: it catches a driver that renders wrongly and consistently, which the expected images of
//! that very driver would not.
//!
//! `--timing` then renders every case `--rounds` more times, interleaved, and compares each case's GPU
//! frame time with a baseline recorded on this driver and machine (`--record-timing`): a case is
//! reported slower or faster only where the 95 % bootstrap interval of the ratio of medians lies
//! wholly beyond ±[`TIMING_MARGIN`]. Timing only reports unless `--timing-gate` is given.
//!
//! Exit 0 when every case passes, 1 when any regressed (a metric beyond its threshold), 2 when none
//! regressed but some case could not run (no expected image, a refused configuration, a device
//! error). Per case the report gives the tier, both metrics, the thresholds and the render time; a
//! failed case leaves its expected and actual images and the FLIP map in `--out`. `--report` writes a
//! JUnit XML file (`.xml`) or this command's JSON (`.json`).
//!
//! Thresholds: `--measure-thresholds` derives each case's from what machines and other seeds move
//! its image ([`thresholds`]), into `thresholds.toml` beside the expected images; a threshold the
//! case sets in the suite file wins, and the suite's defaults apply to cases not measured.

use std::collections::BTreeMap;
use std::fmt::Write as _;
use std::path::{Path, PathBuf};
use std::time::Instant;

use anyhow::{bail, Context, Result};
use clap::Args;
use serde::{Deserialize, Serialize};

use shutter::image::LinearImage;
use shutter::image_io::{load_image, save_image};
use shutter::metrics::{compare, write_flip_diff_png};
use shutter::reference::{render_reference, ReferenceSettings};
use shutter::scene::file::load_scene;
use shutter::scene::Scene;
use shutter::techniques::stochastic::{Coverage, MaskRate};
use shutter::techniques::{RenderOutput, RenderSettings, Renderer, Technique};

use crate::bench::{Config, Stat};
use crate::provenance::Provenance;

mod thresholds;
use thresholds::ThresholdFile;

/// Exit code of a check in which no case regressed but some could not run.
pub const EXIT_NOT_RUN: i32 = 2;

/// Run the rendering regression check: every case of a suite against its expected image.
#[derive(Args)]
pub struct CheckArgs {
    /// The suite: a name (`smoke`: `check/smoke.toml` of the working directory, of the release
    /// archive this binary came in, or of the source tree it was built from) or a suite file's path.
    #[arg(long, default_value = "smoke")]
    pub suite: String,
    /// Record the expected images and their conditions from this run instead of checking.
    #[arg(long)]
    pub update: bool,
    /// Write a report: JUnit XML (`.xml`) or JSON (`.json`).
    #[arg(long)]
    pub report: Option<PathBuf>,
    /// Where a failed case leaves its expected and actual images and FLIP map.
    #[arg(long, default_value = "target/check")]
    pub out: PathBuf,
    /// Only the cases whose name contains this.
    #[arg(long)]
    pub only: Option<String>,
    /// Also time every case (`--rounds` interleaved renders) against the timing baseline.
    #[arg(long)]
    pub timing: bool,
    /// Time every case and write the timing baseline (implies `--timing`; leaves expected images alone).
    #[arg(long)]
    pub record_timing: bool,
    /// The timing baseline (default: `timing-DRIVER.toml` in the suite's expected-image folder).
    #[arg(long)]
    pub timing_baseline: Option<PathBuf>,
    /// Renders per case for `--timing`, interleaved round by round.
    #[arg(long, default_value_t = 5, value_parser = clap::value_parser!(u32).range(2..=1000))]
    pub rounds: u32,
    /// Exit 1 when a case is slower beyond the noise (`--timing` only reports without it).
    #[arg(long)]
    pub timing_gate: bool,
    /// Also render every case with other seeds and record this machine's spread and the reseed's in
    /// `thresholds.toml` beside the expected images, deriving each case's thresholds (run once per
    /// driver and CPU; the runs accumulate).
    #[arg(long, conflicts_with = "update")]
    pub measure_thresholds: bool,
    /// Workers that render cases side by side, each on its own device (default: the CPU's threads,
    /// at most 4; `--timing` rounds always run on one). 1 renders them one after the other.
    #[arg(long, value_parser = clap::value_parser!(u32).range(1..=64))]
    pub jobs: Option<u32>,
}

/// The slowdown or speedup a timing comparison reports only beyond: the 95 % interval of the ratio of
/// medians must lie wholly above 1 + this (slower) or below 1 − this (faster). Back-to-back runs of
/// `check --timing` on one idle machine differ by a few per cent; a loaded one by more, which the
/// interval widens for.
pub const TIMING_MARGIN: f64 = 0.10;

/// A suite file.
#[derive(Deserialize)]
#[serde(deny_unknown_fields)]
struct SuiteFile {
    /// Values every case takes unless it sets its own.
    #[serde(default)]
    defaults: CaseFields,
    #[serde(rename = "case")]
    cases: Vec<CaseFile>,
}

#[derive(Clone, Default, Deserialize)]
#[serde(deny_unknown_fields)]
struct CaseFields {
    size: Option<String>,
    spp: Option<u32>,
    seed: Option<u64>,
    max_flip: Option<f64>,
    max_rmse: Option<f64>,
    /// False for a case whose image varies from run to run on one machine (a cache filled by
    /// concurrent invocations in whatever order they run): it takes the tolerance tier everywhere.
    exact: Option<bool>,
    /// Also compare with the same-sample CPU reference (exact paths only).
    reference: Option<bool>,
    /// A path the device may lack (mesh shaders, say): its refusal skips the case instead of failing
    /// to run it.
    optional: Option<bool>,
    /// The RMSE the same-sample reference comparison allows (f32 rounding; default 1e-4).
    max_reference_rmse: Option<f64>,
}

#[derive(Deserialize)]
#[serde(deny_unknown_fields)]
struct CaseFile {
    /// Unique in the suite; the expected image's file name.
    name: String,
    /// A built-in scene or a scene file (relative to the suite file).
    scene: String,
    /// `technique[:key=value...]`, as `bench -c`.
    config: String,
    #[serde(flatten)]
    fields: CaseFields,
}

/// One case, its defaults applied.
#[derive(Clone)]
struct Case {
    name: String,
    scene: String,
    config: String,
    size: (u32, u32),
    spp: u32,
    seed: u64,
    max_flip: f64,
    max_rmse: f64,
    exact: bool,
    /// `Some(max RMSE)`: compare with the same-sample CPU reference too.
    reference: Option<f64>,
    optional: bool,
    /// Where `max_rmse` and `max_flip` come from: "case", "suite defaults" or "measured".
    threshold_source: &'static str,
}

/// The RMSE a same-sample reference comparison allows unless the case sets its own: the engine's own
/// same-sample tests hold the exact paths to it (their differences are f32 rounding, ~1e-6).
const DEFAULT_REFERENCE_RMSE: f64 = 1e-4;

/// What the expected images were recorded on (`conditions.toml`).
#[derive(Clone, Debug, PartialEq, Serialize, Deserialize)]
struct Conditions {
    commit: String,
    driver: String,
    driver_info: String,
    device: String,
    cpu: String,
}

impl Conditions {
    fn of(p: &Provenance) -> Conditions {
        Conditions {
            commit: p.commit.clone(),
            driver: p.driver.clone(),
            driver_info: p.driver_info.clone(),
            device: p.device.clone(),
            cpu: p.cpu.clone(),
        }
    }

    /// The facts that decide whether llvmpipe's output may be compared bit for bit (the commit does
    /// not: a check exists to compare commits).
    fn same_machine(&self, o: &Conditions) -> bool {
        (&self.driver, &self.driver_info, &self.device, &self.cpu)
            == (&o.driver, &o.driver_info, &o.device, &o.cpu)
    }
}

#[derive(Clone, Copy, Debug, PartialEq, Eq, Serialize)]
#[serde(rename_all = "lowercase")]
enum Tier {
    Exact,
    Tolerance,
}

#[derive(Clone, Copy, Debug, PartialEq, Eq, Serialize)]
#[serde(rename_all = "kebab-case")]
enum Outcome {
    Pass,
    Regression,
    NotRun,
    Recorded,
    /// An optional case the device refused (a feature it lacks).
    Skipped,
}

/// One case's result, as the JSON report gives it.
#[derive(Serialize)]
struct CaseResult {
    name: String,
    scene: String,
    config: String,
    size: String,
    spp: u32,
    seed: u64,
    outcome: Outcome,
    tier: Option<Tier>,
    rmse: Option<f64>,
    flip: Option<f64>,
    max_rmse: f64,
    max_flip: f64,
    /// Where the thresholds come from: the case, the suite's defaults, or `thresholds.toml`.
    threshold_source: &'static str,
    /// `--measure-thresholds`: the smallest RMSE and FLIP another seed moved the image by.
    reseed_rmse: Option<f64>,
    reseed_flip: Option<f64>,
    /// RMSE against the same-sample CPU reference, where the case asks for it.
    reference_rmse: Option<f64>,
    max_reference_rmse: Option<f64>,
    /// GPU frame time, median and range over `--rounds` renders (`--timing`).
    gpu_ms: Option<Stat>,
    /// The baseline's, and the verdict ("within noise", "slower", "faster", or why not compared).
    baseline_gpu_ms: Option<Stat>,
    timing: Option<String>,
    /// Render time of the case, wall clock, including its preparation (pipelines, upload).
    seconds: f64,
    /// Why it regressed or did not run; where its images went.
    message: String,
}

#[derive(Serialize)]
struct Report {
    suite: String,
    provenance: Provenance,
    /// What the expected images were recorded on (None: none recorded).
    recorded: Option<Conditions>,
    tier: Option<Tier>,
    /// Why that tier.
    tier_reason: String,
    passed: usize,
    regressed: usize,
    not_run: usize,
    skipped: usize,
    seconds: f64,
    /// `--timing`: the baseline compared with, and the cases slower beyond the noise.
    timing_baseline: Option<String>,
    slower: usize,
    cases: Vec<CaseResult>,
}

/// The suite file `spec` names: a path, else `check/<spec>.toml` here, else beside this binary as
/// the release archive lays it out (`bin/shutter`, `share/shutter/check/`: `scripts/package.sh`),
/// else in the source tree it was built from.
fn suite_path(spec: &str) -> Result<PathBuf> {
    let path = PathBuf::from(spec);
    if spec.ends_with(".toml") || path.is_file() {
        return Ok(path);
    }
    let file = format!("{spec}.toml");
    let mut places = vec![Path::new("check").join(&file)];
    if let Some(bin) = std::env::current_exe().ok().and_then(|e| e.parent().map(Path::to_path_buf)) {
        places.push(bin.join("../share/shutter/check").join(&file));
    }
    places.push(Path::new(env!("CARGO_MANIFEST_DIR")).join("..").join("check").join(&file));
    if let Some(p) = places.iter().find(|p| p.is_file()) {
        return Ok(p.clone());
    }
    bail!(
        "no suite `{spec}` in {} (give a suite file's path with --suite)",
        places.iter().map(|p| p.display().to_string()).collect::<Vec<_>>().join(", ")
    )
}

fn load_suite(path: &Path) -> Result<Vec<Case>> {
    let text = std::fs::read_to_string(path).with_context(|| format!("reading suite {}", path.display()))?;
    let suite: SuiteFile =
        toml::from_str(&text).with_context(|| format!("parsing suite {}", path.display()))?;
    let mut names = std::collections::BTreeSet::new();
    let mut cases = Vec::new();
    for c in suite.cases {
        let d = &suite.defaults;
        let f = &c.fields;
        let named = |what: &str| format!("suite {}, case `{}`: {what}", path.display(), c.name);
        if c.name.is_empty() || !c.name.chars().all(|ch| ch.is_ascii_alphanumeric() || "-_.".contains(ch)) {
            bail!("{}", named("a name is letters, digits, `-`, `_` and `.` (it names the expected image)"));
        }
        if !names.insert(c.name.clone()) {
            bail!("{}", named("named twice"));
        }
        let size = f.size.clone().or(d.size.clone()).ok_or_else(|| anyhow::anyhow!(named("no size")))?;
        let size = crate::parse_size(&size).map_err(|e| anyhow::anyhow!(named(&e)))?;
        let threshold = |v: Option<f64>, key: &str| -> Result<f64> {
            match v {
                Some(t) if t.is_finite() && t >= 0.0 => Ok(t),
                Some(_) => bail!("{}", named(&format!("{key} must be a finite number ≥ 0"))),
                None => bail!("{}", named(&format!("no {key}"))),
            }
        };
        // A scene file is found relative to the suite.
        let scene = if c.scene.ends_with(".toml") {
            path.parent().unwrap_or(Path::new(".")).join(&c.scene).display().to_string()
        } else {
            c.scene.clone()
        };
        cases.push(Case {
            threshold_source: if f.max_flip.is_some() || f.max_rmse.is_some() {
                "case"
            } else {
                "suite defaults"
            },
            max_flip: threshold(f.max_flip.or(d.max_flip), "max_flip")?,
            max_rmse: threshold(f.max_rmse.or(d.max_rmse), "max_rmse")?,
            spp: f.spp.or(d.spp).ok_or_else(|| anyhow::anyhow!(named("no spp")))?,
            seed: f.seed.or(d.seed).unwrap_or(1),
            exact: f.exact.or(d.exact).unwrap_or(true),
            reference: if f.reference.or(d.reference).unwrap_or(false) {
                Some(threshold(
                    f.max_reference_rmse.or(d.max_reference_rmse).or(Some(DEFAULT_REFERENCE_RMSE)),
                    "max_reference_rmse",
                )?)
            } else {
                None
            },
            optional: f.optional.or(d.optional).unwrap_or(false),
            name: c.name,
            scene,
            config: c.config,
            size,
        });
    }
    Ok(cases)
}

/// The expected images' folder: beside the suite file, named after it.
fn expected_dir(suite: &Path) -> PathBuf {
    let stem = suite.file_stem().map(|s| s.to_string_lossy().into_owned()).unwrap_or_default();
    suite.parent().unwrap_or(Path::new(".")).join(stem)
}

/// A case rendered: its scene and configuration (for the reference) and the frame.
struct Rendered {
    scene: Scene,
    config: Config,
    out: RenderOutput,
}

fn render_case(renderer: &mut Renderer, case: &Case) -> Result<Rendered> {
    let scene = load_scene(&case.scene)?;
    let defaults = RenderSettings::new(case.size.0, case.size.1, case.spp, case.seed);
    let config = Config::parse(&case.config, &defaults)?;
    let out = renderer.render(&scene, config.technique, &config.settings)?;
    Ok(Rendered { scene, config, out })
}

/// The same-sample CPU reference of a rendered case: the samples its passes integrated, shaded at
/// its rate. An error names why the path has no exact mirror (texture-space shading, per-fragment
/// mask coverage, another technique).
fn same_sample_reference(r: &Rendered) -> Result<LinearImage> {
    if r.config.technique != Technique::STOCHASTIC {
        bail!(
            "the same-sample reference mirrors `stochastic` only (`{}` filters or shades differently)",
            r.config.technique.name()
        );
    }
    if r.out.stats.coverage == Some(Coverage::Mask(MaskRate::Fragment)) {
        bail!("per-fragment mask coverage approximates each sample's depth: no exact mirror");
    }
    let s = &r.config.settings;
    let per_pass = s.spp / r.out.stats.passes.max(1);
    let shading = s.stochastic.shading.reference(per_pass).ok_or_else(|| {
        anyhow::anyhow!(
            "shading `{}` approximates the exact rates: no exact mirror",
            s.stochastic.shading.name()
        )
    })?;
    let settings = ReferenceSettings {
        width: s.width,
        height: s.height,
        spp: s.spp,
        seed: s.seed,
        progress: false,
        shading,
    };
    Ok(render_reference(&r.scene, &settings)?)
}

pub fn run(args: CheckArgs) -> Result<i32> {
    let start = Instant::now();
    let suite = suite_path(&args.suite)?;
    let mut cases = load_suite(&suite)?;
    if let Some(only) = &args.only {
        cases.retain(|c| c.name.contains(only.as_str()));
    }
    let dir = expected_dir(&suite);
    let mut measured = ThresholdFile::load(&dir)?;
    for case in cases.iter_mut().filter(|c| c.threshold_source != "case") {
        if let Some(m) = measured.cases.get(&case.name) {
            if let (Some(rmse), Some(flip)) = (m.max_rmse, m.max_flip) {
                (case.max_rmse, case.max_flip, case.threshold_source) = (rmse, flip, "measured");
            }
        }
    }
    let mut renderer = Renderer::new(crate::create_device()?)?;
    let provenance = Provenance::of(&renderer.device().caps);
    let here = Conditions::of(&provenance);
    let conditions_file = dir.join("conditions.toml");
    let recorded: Option<Conditions> = if args.update {
        None
    } else {
        match std::fs::read_to_string(&conditions_file) {
            Ok(t) => {
                Some(toml::from_str(&t).with_context(|| format!("parsing {}", conditions_file.display()))?)
            }
            Err(_) => None,
        }
    };
    let (tier, tier_reason) = match &recorded {
        _ if args.update => (None, format!("recording into {}", dir.display())),
        None => {
            (None, format!("nothing recorded: {} is missing (run with --update)", conditions_file.display()))
        }
        Some(r) if r.same_machine(&here) => (
            Some(Tier::Exact),
            format!("driver, device and CPU are the recorded ones ({}, {})", r.driver, r.cpu),
        ),
        Some(r) => (
            Some(Tier::Tolerance),
            format!(
                "recorded on {} / {} ({}), running on {} / {} ({}): thresholds, not bits",
                r.driver, r.device, r.cpu, here.driver, here.device, here.cpu
            ),
        ),
    };
    errln!("check: suite {} ({} cases) — {tier_reason}", suite.display(), cases.len());
    if args.update {
        std::fs::create_dir_all(&dir).with_context(|| format!("creating {}", dir.display()))?;
    }
    // Cases run on `--jobs` workers, each with its own device: on lavapipe a first frame is mostly
    // LLVM compiling its pipelines, one thread per pipeline, so a cold shader cache takes about
    // half as long on two workers as on one. Results keep the suite's order.
    let jobs = args.jobs.map_or_else(default_jobs, |j| j as usize).clamp(1, cases.len().max(1));
    let ctx = CaseContext { dir: &dir, tier, args: &args };
    let mut slots: Vec<Option<(CaseResult, Option<[f64; 2]>)>> = (0..cases.len()).map(|_| None).collect();
    if jobs == 1 {
        for (i, case) in cases.iter().enumerate() {
            slots[i] = Some(check_case(&mut renderer, case, &ctx)?);
        }
    } else {
        let next = std::sync::atomic::AtomicUsize::new(0);
        let done = std::sync::Mutex::new(&mut slots);
        let mut main = Some(&mut renderer);
        std::thread::scope(|scope| -> Result<()> {
            let workers: Vec<_> = (0..jobs)
                .map(|w| {
                    let (next, done, cases, ctx) = (&next, &done, &cases, &ctx);
                    // The first worker takes the main renderer (the timing rounds reuse it, warm).
                    let own = if w == 0 { main.take() } else { None };
                    scope.spawn(move || -> Result<()> {
                        let mut spare = None;
                        let renderer = match own {
                            Some(r) => r,
                            None => spare.insert(Renderer::new(crate::create_device()?)?),
                        };
                        loop {
                            let i = next.fetch_add(1, std::sync::atomic::Ordering::Relaxed);
                            let Some(case) = cases.get(i) else { return Ok(()) };
                            let result = check_case(renderer, case, ctx)?;
                            done.lock().expect("a worker panicked")[i] = Some(result);
                        }
                    })
                })
                .collect();
            for w in workers {
                w.join().expect("a check worker panicked")?;
            }
            Ok(())
        })?;
    }
    let mut results = Vec::with_capacity(cases.len());
    for (case, slot) in cases.iter().zip(slots) {
        let (mut r, reseed) = slot.expect("every case ran");
        if let (Some(reseed), Some(rmse), Some(flip)) = (reseed, r.rmse, r.flip) {
            let machine = format!("{} / {} / {}", here.driver, here.device, here.cpu);
            let m = measured.cases.entry(case.name.clone()).or_default();
            m.update(&machine, [rmse, flip], reseed);
            if !m.note.is_empty() {
                r.message = join(&r.message, &m.note);
            }
        }
        results.push(r);
    }
    let mut timing_baseline = None;
    if args.timing || args.record_timing {
        let path = args
            .timing_baseline
            .clone()
            .unwrap_or_else(|| dir.join(format!("timing-{}.toml", provenance.driver)));
        timing_baseline = Some(path.display().to_string());
        time_cases(&mut renderer, &cases, &mut results, &args, &path, &here)?;
    }
    if args.measure_thresholds {
        measured.save(&dir)?;
        errln!("check: wrote {}", ThresholdFile::path(&dir).display());
    }
    if args.update {
        let text = format!(
            "# What the expected images beside this file were recorded on (`shutter check --update`).\n{}",
            toml::to_string(&here)?
        );
        std::fs::write(&conditions_file, text)
            .with_context(|| format!("writing {}", conditions_file.display()))?;
    }
    let count = |o: Outcome| results.iter().filter(|r| r.outcome == o).count();
    let report = Report {
        suite: suite.display().to_string(),
        provenance,
        recorded,
        tier,
        tier_reason,
        passed: count(Outcome::Pass) + count(Outcome::Recorded),
        regressed: count(Outcome::Regression),
        not_run: count(Outcome::NotRun),
        skipped: count(Outcome::Skipped),
        seconds: start.elapsed().as_secs_f64(),
        timing_baseline,
        slower: results
            .iter()
            .filter(|r| r.timing.as_deref().is_some_and(|t| t.starts_with("slower")))
            .count(),
        cases: results,
    };
    errln!(
        "check: {} passed, {} regressed, {} not run, {} skipped in {:.1} s",
        report.passed,
        report.regressed,
        report.not_run,
        report.skipped,
        report.seconds
    );
    if let Some(path) = &args.report {
        let text = match path.extension().and_then(|e| e.to_str()) {
            Some("xml") => junit(&report),
            Some("json") => serde_json::to_string_pretty(&report)? + "\n",
            _ => bail!("--report {}: a .xml (JUnit) or .json file", path.display()),
        };
        std::fs::write(path, text).with_context(|| format!("writing {}", path.display()))?;
        errln!("check: wrote {}", path.display());
    }
    if args.timing_gate && report.slower > 0 {
        errln!(
            "check: {} cases slower than the timing baseline beyond the noise (--timing-gate)",
            report.slower
        );
    }
    Ok(if report.regressed > 0 || (args.timing_gate && report.slower > 0) {
        1
    } else if report.not_run > 0 {
        EXIT_NOT_RUN
    } else {
        0
    })
}

/// Compares `image` with the expected one in `tier`; a regression leaves its images in `out/<case>/`.
fn judge(
    r: &mut CaseResult,
    image: &LinearImage,
    expected_path: &Path,
    tier: Option<Tier>,
    out: &Path,
) -> Result<()> {
    let Some(tier) = tier else {
        r.message = "no recorded conditions (run with --update)".into();
        return Ok(());
    };
    let expected = match load_image(expected_path) {
        Ok(e) => e,
        Err(e) => {
            r.message = format!("no expected image: {e}");
            return Ok(());
        }
    };
    let m = match compare(&expected, image) {
        Ok(m) => m,
        Err(e) => {
            r.message = format!("not comparable with {}: {e}", expected_path.display());
            return Ok(());
        }
    };
    (r.rmse, r.flip) = (Some(m.rmse), Some(m.flip));
    let mut beyond = Vec::new();
    match tier {
        Tier::Exact => {
            let changed = expected
                .pixels
                .iter()
                .flatten()
                .zip(image.pixels.iter().flatten())
                .filter(|(a, b)| a.to_bits() != b.to_bits())
                .count();
            if changed > 0 {
                beyond.push(format!("{changed} channel values differ from the recorded ones (exact tier)"));
            }
        }
        Tier::Tolerance => {
            if m.rmse.is_nan() || m.rmse > r.max_rmse {
                beyond.push(format!("RMSE {:.3e} > {}", m.rmse, r.max_rmse));
            }
            if m.flip.is_nan() || m.flip > r.max_flip {
                beyond.push(format!("FLIP {:.3e} > {}", m.flip, r.max_flip));
            }
        }
    }
    if beyond.is_empty() {
        r.outcome = Outcome::Pass;
        return Ok(());
    }
    r.outcome = Outcome::Regression;
    let dir = out.join(&r.name);
    std::fs::create_dir_all(&dir).with_context(|| format!("creating {}", dir.display()))?;
    save_image(dir.join("expected.png"), &expected)?;
    save_image(dir.join("actual.png"), image)?;
    save_image(dir.join("actual.exr"), image)?;
    write_flip_diff_png(dir.join("flip.png"), &expected, image)?;
    r.message = format!("{}; expected, actual and FLIP map in {}", beyond.join(", "), dir.display());
    Ok(())
}

/// Compares a rendered case with its same-sample CPU reference; beyond `max` it is a regression
/// (images in `out/<case>/`: `reference.png` and the FLIP map against it), and a path with no exact
/// mirror is a case that could not run.
fn judge_reference(r: &mut CaseResult, rendered: &Rendered, max: f64, out: &Path) -> Result<()> {
    let reference = match same_sample_reference(rendered) {
        Ok(image) => image,
        Err(e) => {
            if r.outcome == Outcome::Pass {
                r.outcome = Outcome::NotRun;
            }
            r.message = join(&r.message, &format!("no same-sample reference: {e:#}"));
            return Ok(());
        }
    };
    let m = compare(&reference, &rendered.out.image)?;
    r.reference_rmse = Some(m.rmse);
    if !m.rmse.is_nan() && m.rmse <= max {
        return Ok(());
    }
    r.outcome = Outcome::Regression;
    let dir = out.join(&r.name);
    std::fs::create_dir_all(&dir).with_context(|| format!("creating {}", dir.display()))?;
    save_image(dir.join("reference.png"), &reference)?;
    save_image(dir.join("actual.png"), &rendered.out.image)?;
    write_flip_diff_png(dir.join("flip-vs-reference.png"), &reference, &rendered.out.image)?;
    r.message = join(
        &r.message,
        &format!(
            "same-sample reference RMSE {:.3e} > {max}; reference, actual and FLIP map in {}",
            m.rmse,
            dir.display()
        ),
    );
    Ok(())
}

/// What every case's check shares.
struct CaseContext<'a> {
    dir: &'a Path,
    tier: Option<Tier>,
    args: &'a CheckArgs,
}

/// Workers a check runs its cases on unless `--jobs` says: the CPU's threads, at most 4 (lavapipe
/// rasterizes on every core already; the workers overlap the single-threaded pipeline compiles).
fn default_jobs() -> usize {
    std::thread::available_parallelism().map_or(1, |n| n.get()).min(4)
}

/// Renders and judges one case (records it with `--update`); with `--measure-thresholds`, also the
/// smallest RMSE and FLIP [`thresholds::RESEED_COUNT`] other seeds move its image by.
fn check_case(
    renderer: &mut Renderer,
    case: &Case,
    ctx: &CaseContext,
) -> Result<(CaseResult, Option<[f64; 2]>)> {
    let mut reseed = None;
    let t0 = Instant::now();
    let rendered = render_case(renderer, case);
    let seconds = t0.elapsed().as_secs_f64();
    let expected_path = ctx.dir.join(format!("{}.exr", case.name));
    let mut r = CaseResult {
        name: case.name.clone(),
        scene: case.scene.clone(),
        config: case.config.clone(),
        size: format!("{}x{}", case.size.0, case.size.1),
        spp: case.spp,
        seed: case.seed,
        outcome: Outcome::NotRun,
        // A case that is not reproducible bit for bit never takes the exact tier.
        tier: ctx.tier.map(|t| if case.exact { t } else { Tier::Tolerance }),
        rmse: None,
        flip: None,
        max_rmse: case.max_rmse,
        max_flip: case.max_flip,
        threshold_source: case.threshold_source,
        reseed_rmse: None,
        reseed_flip: None,
        reference_rmse: None,
        max_reference_rmse: case.reference,
        gpu_ms: None,
        baseline_gpu_ms: None,
        timing: None,
        seconds,
        message: String::new(),
    };
    match (rendered, ctx.args.update) {
        (Err(e), _)
            if case.optional && e.downcast_ref::<shutter::Error>().is_some_and(crate::bench::is_refusal) =>
        {
            r.outcome = Outcome::Skipped;
            r.message = format!("skipped (optional, refused here): {e:#}");
        }
        (Err(e), _) => r.message = format!("could not render: {e:#}"),
        (Ok(rendered), true) => {
            save_image(&expected_path, &rendered.out.image)?;
            r.outcome = Outcome::Recorded;
            r.message = format!("wrote {}", expected_path.display());
        }
        (Ok(rendered), false) => {
            let tier = r.tier;
            judge(&mut r, &rendered.out.image, &expected_path, tier, &ctx.args.out)?;
            if let Some(max) = case.reference {
                judge_reference(&mut r, &rendered, max, &ctx.args.out)?;
            }
            if ctx.args.measure_thresholds && r.rmse.is_some() {
                reseed = Some(reseed_spread(renderer, case, &expected_path)?);
                (r.reseed_rmse, r.reseed_flip) = reseed.map_or((None, None), |[a, b]| (Some(a), Some(b)));
            }
        }
    }
    errln!(
        "  {:<10} {:<28} {:>6.2} s  {}{}{}",
        match r.outcome {
            Outcome::Pass => "pass",
            Outcome::Regression => "REGRESSION",
            Outcome::NotRun => "NOT RUN",
            Outcome::Recorded => "recorded",
            Outcome::Skipped => "skipped",
        },
        r.name,
        r.seconds,
        match (r.rmse, r.flip) {
            (Some(rmse), Some(flip)) => format!(
                "RMSE {rmse:.2e} (≤ {:.1e}), FLIP {flip:.2e} (≤ {:.1e}, {}){}",
                r.max_rmse,
                r.max_flip,
                r.threshold_source,
                match (r.reseed_rmse, r.reseed_flip) {
                    (Some(rr), Some(rf)) => format!(", reseed RMSE {rr:.2e} FLIP {rf:.2e}"),
                    _ => String::new(),
                }
            ),
            _ => String::new(),
        },
        match (r.reference_rmse, r.max_reference_rmse) {
            (Some(rmse), Some(max)) => format!(", same-sample reference RMSE {rmse:.2e} (≤ {max})"),
            _ => String::new(),
        },
        if r.message.is_empty() { String::new() } else { format!("  {}", r.message) }
    );
    Ok((r, reseed))
}

/// The smallest RMSE and FLIP against the expected image over [`thresholds::RESEED_COUNT`] renders
/// of `case` with other seeds.
fn reseed_spread(renderer: &mut Renderer, case: &Case, expected_path: &Path) -> Result<[f64; 2]> {
    let expected = load_image(expected_path)?;
    let mut reseed = [f64::INFINITY; 2];
    for k in 1..=thresholds::RESEED_COUNT {
        let other = Case { seed: case.seed.wrapping_add(k), ..case.clone() };
        let m = compare(&expected, &render_case(renderer, &other)?.out.image)?;
        reseed = [reseed[0].min(m.rmse), reseed[1].min(m.flip)];
    }
    Ok(reseed)
}

fn join(a: &str, b: &str) -> String {
    if a.is_empty() {
        b.to_string()
    } else {
        format!("{a}; {b}")
    }
}

/// A timing baseline: what it was recorded on and each case's GPU frame times.
#[derive(Serialize, Deserialize)]
struct TimingBaseline {
    conditions: Conditions,
    rounds: u32,
    /// Case name → GPU ms of each render.
    cases: BTreeMap<String, Vec<f64>>,
}

/// `--timing`: `rounds` interleaved renders of every case that rendered, their GPU times compared
/// with (or, with `--record-timing`, written as) the baseline at `path`.
fn time_cases(
    renderer: &mut Renderer,
    cases: &[Case],
    results: &mut [CaseResult],
    args: &CheckArgs,
    path: &Path,
    here: &Conditions,
) -> Result<()> {
    let timed: Vec<usize> = (0..cases.len())
        .filter(|&i| matches!(results[i].outcome, Outcome::Pass | Outcome::Recorded | Outcome::Regression))
        .collect();
    let mut frames: Vec<Vec<f64>> = vec![Vec::new(); cases.len()];
    errln!("check: timing {} cases, {} interleaved rounds", timed.len(), args.rounds);
    for _ in 0..args.rounds {
        for &i in &timed {
            let rendered = render_case(renderer, &cases[i])?;
            frames[i].push(rendered.out.timings.total_ms());
        }
    }
    let baseline: Option<TimingBaseline> = if args.record_timing {
        None
    } else {
        match std::fs::read_to_string(path) {
            Ok(t) => Some(toml::from_str(&t).with_context(|| format!("parsing {}", path.display()))?),
            Err(_) => None,
        }
    };
    let comparable = baseline.as_ref().map(|b| b.conditions.same_machine(here));
    for &i in &timed {
        let r = &mut results[i];
        let now = Stat::of(frames[i].clone());
        r.gpu_ms = Some(now.clone());
        r.timing = Some(match (&baseline, comparable) {
            _ if args.record_timing => "recorded".into(),
            (None, _) => format!("no baseline at {} (record one with --record-timing)", path.display()),
            (Some(b), Some(false)) => format!(
                "baseline recorded on {} / {} ({}): another machine, not compared",
                b.conditions.driver, b.conditions.device, b.conditions.cpu
            ),
            (Some(b), _) => match b.cases.get(&r.name) {
                None => "not in the baseline".into(),
                Some(base) => {
                    r.baseline_gpu_ms = Some(Stat::of(base.clone()));
                    timing_verdict(&frames[i], base)
                }
            },
        });
        errln!(
            "  timing     {:<28} {:>8.2} ms [{:.2}–{:.2}]  {}",
            r.name,
            now.median,
            now.min,
            now.max,
            r.timing.as_deref().unwrap_or_default()
        );
    }
    if args.record_timing {
        let baseline = TimingBaseline {
            conditions: here.clone(),
            rounds: args.rounds,
            cases: timed.iter().map(|&i| (cases[i].name.clone(), frames[i].clone())).collect(),
        };
        let text = format!(
            "# GPU frame times of `shutter check --record-timing` (ms per render, interleaved rounds).\n{}",
            toml::to_string(&baseline)?
        );
        if let Some(parent) = path.parent() {
            std::fs::create_dir_all(parent).with_context(|| format!("creating {}", parent.display()))?;
        }
        std::fs::write(path, text).with_context(|| format!("writing {}", path.display()))?;
        errln!("check: wrote timing baseline {}", path.display());
    }
    Ok(())
}

/// The ratio of the medians of `now` and `base` with its 95 % percentile-bootstrap interval (the two
/// runs resampled independently: they are not paired), and whether that interval lies beyond
/// ±[`TIMING_MARGIN`].
fn timing_verdict(now: &[f64], base: &[f64]) -> String {
    let Some((ratio, low, high)) = unpaired_ratio_interval(now, base, 2000, 0x5eed) else {
        return "not compared (fewer than two frames or a zero time)".into();
    };
    let interval = format!("{ratio:.3}× the baseline [{low:.3}–{high:.3}]");
    if low > 1.0 + TIMING_MARGIN {
        format!("slower: {interval}")
    } else if high < 1.0 - TIMING_MARGIN {
        format!("faster: {interval}")
    } else {
        format!("within noise: {interval}")
    }
}

/// Median of `num` over median of `den`, and the 2.5th and 97.5th percentiles of that ratio over
/// `resamples` independent resamplings of both with replacement (SplitMix64, fixed seed).
fn unpaired_ratio_interval(num: &[f64], den: &[f64], resamples: usize, seed: u64) -> Option<(f64, f64, f64)> {
    let ok = |v: &[f64]| v.len() >= 2 && v.iter().all(|x| x.is_finite() && *x > 0.0);
    if !ok(num) || !ok(den) {
        return None;
    }
    let mut next = crate::bench::splitmix64(seed);
    let mut resample =
        |v: &[f64]| Stat::of((0..v.len()).map(|_| v[(next() % v.len() as u64) as usize]).collect()).median;
    let mut ratios: Vec<f64> = (0..resamples.max(1)).map(|_| resample(num) / resample(den)).collect();
    ratios.sort_by(|a, b| a.total_cmp(b));
    let at = |q: f64| ratios[((q * (ratios.len() - 1) as f64).round() as usize).min(ratios.len() - 1)];
    Some((Stat::of(num.to_vec()).median / Stat::of(den.to_vec()).median, at(0.025), at(0.975)))
}

/// The report as JUnit XML: one test suite, one test case per case; a regression is a `failure`, a
/// case that could not run an `error`.
fn junit(report: &Report) -> String {
    fn esc(s: &str) -> String {
        s.chars()
            .map(|c| match c {
                '&' => "&amp;".into(),
                '<' => "&lt;".into(),
                '>' => "&gt;".into(),
                '"' => "&quot;".into(),
                c if (c as u32) < 0x20 && !"\t\n\r".contains(c) => " ".into(),
                c => c.to_string(),
            })
            .collect()
    }
    let suite =
        Path::new(&report.suite).file_stem().map(|s| s.to_string_lossy().into_owned()).unwrap_or_default();
    let mut x = String::from("<?xml version=\"1.0\" encoding=\"UTF-8\"?>\n");
    let _ = writeln!(
        x,
        "<testsuite name=\"shutter check {}\" tests=\"{}\" failures=\"{}\" errors=\"{}\" skipped=\"{}\" time=\"{:.3}\">",
        esc(&suite),
        report.cases.len(),
        report.regressed,
        report.not_run,
        report.skipped,
        report.seconds
    );
    let mut props = BTreeMap::new();
    props.insert("driver", report.provenance.driver.clone());
    props.insert("device", report.provenance.device.clone());
    props.insert("cpu", report.provenance.cpu.clone());
    props.insert("commit", report.provenance.commit.clone());
    props.insert("tier", report.tier_reason.clone());
    x.push_str("  <properties>\n");
    for (k, v) in props {
        let _ = writeln!(x, "    <property name=\"{k}\" value=\"{}\"/>", esc(&v));
    }
    x.push_str("  </properties>\n");
    for c in &report.cases {
        let _ = write!(
            x,
            "  <testcase classname=\"shutter.check.{}\" name=\"{}\" time=\"{:.3}\"",
            esc(&suite),
            esc(&c.name),
            c.seconds
        );
        let metrics = match (c.rmse, c.flip) {
            (Some(rmse), Some(flip)) => format!(
                "RMSE {rmse:.3e} (max {}), FLIP {flip:.3e} (max {}), {} tier",
                c.max_rmse,
                c.max_flip,
                match c.tier {
                    Some(Tier::Exact) => "exact",
                    _ => "tolerance",
                }
            ),
            _ => String::new(),
        };
        let mut metrics = metrics;
        if let (Some(rmse), Some(max)) = (c.reference_rmse, c.max_reference_rmse) {
            metrics = join(&metrics, &format!("same-sample reference RMSE {rmse:.3e} (max {max})"));
        }
        if let (Some(ms), Some(t)) = (&c.gpu_ms, &c.timing) {
            metrics = join(&metrics, &format!("GPU {:.3} ms [{:.3}–{:.3}]: {t}", ms.median, ms.min, ms.max));
        }
        match c.outcome {
            Outcome::Pass | Outcome::Recorded => {
                let _ = writeln!(x, ">\n    <system-out>{}</system-out>\n  </testcase>", esc(&metrics));
            }
            Outcome::Regression => {
                let _ = writeln!(
                    x,
                    ">\n    <failure message=\"{}\">{}</failure>\n  </testcase>",
                    esc(&c.message),
                    esc(&format!("{} `{}` on {}: {metrics}", c.name, c.config, c.scene))
                );
            }
            Outcome::NotRun => {
                let _ = writeln!(x, ">\n    <error message=\"{}\"/>\n  </testcase>", esc(&c.message));
            }
            Outcome::Skipped => {
                let _ = writeln!(x, ">\n    <skipped message=\"{}\"/>\n  </testcase>", esc(&c.message));
            }
        }
    }
    x.push_str("</testsuite>\n");
    x
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn timing_verdict_reports_only_beyond_the_noise() {
        let base = [10.0, 10.2, 9.9, 10.1, 10.0];
        assert!(timing_verdict(&[10.1, 9.95, 10.05, 10.2, 9.9], &base).starts_with("within noise"));
        assert!(timing_verdict(&[13.0, 13.1, 12.9, 13.2, 13.0], &base).starts_with("slower"));
        assert!(timing_verdict(&[7.0, 7.1, 6.9, 7.2, 7.0], &base).starts_with("faster"));
        // 30 % slower in the median, but so noisy that the interval reaches back below the margin.
        assert!(timing_verdict(&[6.0, 20.0, 13.0, 7.0, 19.0], &base).starts_with("within noise"));
        assert!(timing_verdict(&[10.0], &base).starts_with("not compared"));
    }
}
