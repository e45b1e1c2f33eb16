//! `shutter calibrate`.

use anyhow::{Context, Result};
use clap::Args;

use std::path::PathBuf;

use shutter::mirror::bounds::BoundKind;
use shutter::techniques::{RenderSettings, Renderer};

use crate::{bench, create_device, load_scene, parse_size, provenance};

/// Measure this driver: the quality planner's cost model (accumulation against the per-object
/// stochastic frame at equal S), which stochastic bound is cheapest (the images do not depend
/// on it: bbox, convex-hull and adaptive benched interleaved) and which exact coverage path
/// (visibility buffer or the per-sample mask path, same image, benched interleaved). All are saved
/// to the user's calibration file, which `render`/`auto` read from then on (engine/src/calibration.rs).
#[derive(Args)]
pub struct CalibrateArgs {
    #[arg(default_value = "default")]
    pub scene: String,
    /// Image sizes to measure the cost model at (repeat the flag or separate by commas): the two
    /// techniques scale differently with the pixel count, so the planner interpolates between
    /// sizes. The bound is measured at the last.
    #[arg(long, value_parser = parse_size, value_delimiter = ',', default_values = ["160x90", "640x360"])]
    pub size: Vec<(u32, u32)>,
    #[arg(long, default_value_t = 16)]
    pub spp: u32,
    #[arg(long, default_value_t = 3)]
    pub frames: usize,
    #[arg(long, default_value_t = 1)]
    pub warmup: usize,
    /// Measure only these (repeat or separate by commas): `cost`, `bound`, `coverage`; default all.
    #[arg(long, value_enum, value_delimiter = ',')]
    pub only: Vec<Measure>,
}

/// What `shutter calibrate` measures.
#[derive(Clone, Copy, Debug, PartialEq, Eq, clap::ValueEnum)]
pub enum Measure {
    Cost,
    Bound,
    Coverage,
}

pub fn run(args: CalibrateArgs) -> Result<()> {
    let CalibrateArgs { scene, size: sizes, spp, frames, warmup, only } = args;
    let measures = |m: Measure| only.is_empty() || only.contains(&m);
    for &size in sizes.iter().filter(|_| measures(Measure::Cost)) {
        match calibrate_cost(&scene, size, spp, frames.max(1)) {
            Ok(report) => outln!("{report}\n"),
            // A scene without blur measures no noise: the bound calibration below still runs.
            Err(e) => outln!("{e:#}\n"),
        }
    }
    let size = *sizes.last().context("no --size")?;
    let sc = load_scene(&scene)?;
    let mut defaults = RenderSettings::from_scene(&sc);
    (defaults.width, defaults.height) = size;
    defaults.spp = spp;
    let mut renderer = Renderer::new(create_device()?)?;
    if measures(Measure::Bound) {
        calibrate_bound(&mut renderer, &sc, &scene, &defaults, frames.max(1), warmup)?;
    }
    if measures(Measure::Coverage) {
        calibrate_coverage(&mut renderer, &sc, &scene, &defaults, frames.max(1), warmup)?;
    }
    Ok(())
}

/// `--bound device`'s bound: bbox, convex-hull and adaptive benched interleaved, the fastest saved.
fn calibrate_bound(
    renderer: &mut Renderer,
    sc: &shutter::scene::Scene,
    scene: &str,
    defaults: &RenderSettings,
    frames: usize,
    warmup: usize,
) -> Result<()> {
    let (size, spp) = ((defaults.width, defaults.height), defaults.spp);
    let kinds = [BoundKind::BoundingBox, BoundKind::ConvexHull, BoundKind::Adaptive];
    let configs = kinds
        .iter()
        .map(|k| bench::Config::parse(&format!("stochastic:bound={}", k.name()), defaults))
        .collect::<Result<Vec<_>>>()?;
    let args = bench::BenchArgs { configs, frames, warmup, counters: false, skip_refused: false };
    let report = bench::run(renderer, sc, &args)?;
    outln!("{}", report.markdown());
    let ms: Vec<f64> = report.results.iter().map(|r| r.gpu_ms.median).collect();
    let best = (0..kinds.len()).min_by(|&a, &b| ms[a].total_cmp(&ms[b])).expect("three kinds");
    let adaptive = ms[2];
    let caps = &renderer.device().caps;
    outln!("fastest: `{}` ({:.2}x adaptive)", kinds[best].name(), ms[best] / adaptive);
    let entry = shutter::calibration::Calibration {
        driver: caps.driver_key.clone(),
        bound: Some(kinds[best].name().to_string()),
        bound_measured: Some(format!(
            "`shutter calibrate` ({scene}, {}x{}, S = {spp}, {frames} interleaved frames): {}; {}",
            size.0,
            size.1,
            kinds
                .iter()
                .zip(&ms)
                .map(|(k, m)| format!("{} {:.2}x", k.name(), m / adaptive))
                .collect::<Vec<_>>()
                .join(", "),
            measured_on(caps)
        )),
        ..Default::default()
    };
    let path = save_calibration(entry.clone())?;
    let (now, why) = shutter::techniques::stochastic::device_bound(caps);
    outln!("saved to {}; `--bound device` draws `{}` from now on ({why})", path.display(), now.name());
    outln!(
        "calibration entry for this driver (the project ships its own in engine/data/calibrations.toml):\n\n{}",
        toml::to_string(&shutter::calibration::CalibrationFile { calibration: vec![entry] })?
    );
    Ok(())
}

/// `coverage=device`'s path: the visibility buffer and the per-sample mask path (the exact ones,
/// [`shutter::calibration::EXACT_COVERAGE`]) benched interleaved, each at its own samples per pass
/// (what `coverage=device` would run) and with per-sample shading, whose image does not depend on
/// how S splits into passes — so the two must agree up to the order of the f32 sums over passes
/// ([`SAME_IMAGE_RMSE`]), and a difference is an error, not a
/// calibration. The mask path is saved only where its paired ratio's whole 95 % interval lies below
/// 1; otherwise the visibility path (a device lacking either path records nothing).
/// Largest RMSE between the two paths' images that is rounding (as the same-sample tests allow).
const SAME_IMAGE_RMSE: f64 = 1e-4;

fn calibrate_coverage(
    renderer: &mut Renderer,
    sc: &shutter::scene::Scene,
    scene: &str,
    defaults: &RenderSettings,
    frames: usize,
    warmup: usize,
) -> Result<()> {
    let (size, spp) = ((defaults.width, defaults.height), defaults.spp);
    let paths = shutter::calibration::EXACT_COVERAGE;
    let configs = paths
        .iter()
        .map(|p| {
            bench::Config::parse(&format!("stochastic:coverage={}:shading=per-sample", p.name()), defaults)
        })
        .collect::<Result<Vec<_>>>()?;
    let args = bench::BenchArgs { configs, frames, warmup, counters: false, skip_refused: true };
    let report = bench::run(renderer, sc, &args)?;
    outln!("{}", report.markdown());
    if report.results.len() < paths.len() {
        outln!("coverage: the device takes only one exact path, nothing to calibrate");
        return Ok(());
    }
    let mask = &report.results[1];
    // Equal up to the order of the f32 sums over passes (the paths split S differently).
    let identical = mask.image_vs_first.as_ref().is_some_and(|d| d.identical || d.rmse < SAME_IMAGE_RMSE);
    let faster = mask.paired_ratio.as_ref().is_some_and(|r| r.high < 1.0);
    let chosen = if identical && faster { paths[1] } else { paths[0] };
    let ratio =
        mask.paired_ratio.as_ref().map_or_else(|| format!("{:.2}", mask.ratio_to_first), |r| r.cell());
    let caps = &renderer.device().caps;
    let entry = shutter::calibration::Calibration {
        driver: caps.driver_key.clone(),
        coverage: Some(chosen.name().to_string()),
        coverage_measured: Some(format!(
            "`shutter calibrate --only coverage` ({scene}, {}x{}, S = {spp}, {frames} interleaved frames): \
             mask {ratio}x visibility, images {}; {}",
            size.0,
            size.1,
            mask.image_vs_first
                .as_ref()
                .map_or_else(|| "not compared".into(), |d| format!("equal ({})", d.cell())),
            measured_on(caps)
        )),
        ..Default::default()
    };
    if !identical {
        anyhow::bail!(
            "the mask path's image differs from the visibility path's ({}): a bug, please report it; \
             nothing saved",
            mask.image_vs_first.as_ref().map_or_else(|| "not compared".into(), |d| d.cell())
        );
    }
    let path = save_calibration(entry.clone())?;
    let (now, why) = shutter::techniques::stochastic::Coverage::Device.resolve_for(caps, false)?;
    outln!("saved to {}; `coverage=device` takes `{}` from now on ({why})", path.display(), now.name());
    outln!(
        "calibration entry for this driver:\n\n{}",
        toml::to_string(&shutter::calibration::CalibrationFile { calibration: vec![entry] })?
    );
    Ok(())
}

/// `shutter calibrate`'s cost model ([`shutter::calibration::measure_cost_point`]) on `scene` at
/// `size` and S = `spp`, saved where the quality planner loads it. Returns a report.
fn calibrate_cost(scene: &str, size: (u32, u32), spp: u32, frames: usize) -> Result<String> {
    let sc = load_scene(scene)?;
    let mut settings = RenderSettings::from_scene(&sc);
    (settings.width, settings.height, settings.spp) = (size.0, size.1, spp);
    let mut renderer = Renderer::new(create_device()?)?;
    let caps = renderer.device().caps.clone();
    let point =
        shutter::calibration::measure_cost_point(&mut renderer, &sc, &settings, frames, &measured_on(&caps))?;
    let (ms, noise) = (point.stochastic_ms_ratio, point.stochastic_flip_ratio);
    let path = save_calibration(shutter::calibration::Calibration {
        driver: caps.driver_key.clone(),
        cost: vec![point.clone()],
        ..Default::default()
    })?;
    Ok(format!(
        "cost model for {} ({}): the per-object stochastic frame takes {ms:.2}x accumulation's GPU ms and has {noise:.2}x its noise at equal S; saved to {} (the quality planner's, `render --quality`)\n{}",
        caps.driver_key,
        caps.device_name,
        path.display(),
        point.measured
    ))
}

fn measured_on(caps: &shutter::vk::Capabilities) -> String {
    let p = provenance::Provenance::of(caps);
    let date = std::process::Command::new("date")
        .arg("+%Y-%m-%d")
        .output()
        .ok()
        .map(|o| String::from_utf8_lossy(&o.stdout).trim().to_string())
        .unwrap_or_default();
    format!("{}, {}, {}, commit {:.10}, {date}", p.device, p.driver_info, p.cpu, p.commit)
}

/// Adds `entry` to the user's calibration file (replacing the same driver's fields); returns the path.
fn save_calibration(entry: shutter::calibration::Calibration) -> Result<PathBuf> {
    let (path, mut file) = shutter::calibration::CalibrationFile::user()?;
    let path = path.context("no cache directory for the calibration: set SHUTTER_CACHE_DIR or HOME")?;
    file.upsert(entry);
    file.save(&path)?;
    Ok(path)
}
