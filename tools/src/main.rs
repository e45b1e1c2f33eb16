//! `shutter`: render scenes with each technique, render the CPU ground truth, compare images, probe
//! the device.

/// `println!` that returns an error (from the enclosing function, with `?`) where `println!` panics:
/// standard output closed (`shutter compare a b | head -1`) or full (`> /dev/full`).
macro_rules! outln {
    ($($arg:tt)*) => {
        $crate::write_stdout_line(format_args!($($arg)*))?
    };
}

/// `eprintln!` that ignores a closed standard error instead of panicking.
macro_rules! errln {
    ($($arg:tt)*) => {
        $crate::note(format_args!($($arg)*))
    };
}

mod bench;
mod bounds_table;
mod cmd;
mod hard_cases;
mod provenance;
mod quality;

use std::path::{Path, PathBuf};

use anyhow::{bail, Context, Result};
use clap::{Args, Parser, Subcommand};

use shutter::image_io::{
    check_image_output, check_output_file, load_image, save_image_displayed, write_file_atomically,
};
use shutter::quality_plan::{CostModel, QualityTarget};
use shutter::reference::ReferenceSettings;
use shutter::scene::builtin::BUILTIN_SCENES;
use shutter::techniques::{RenderSettings, Renderer, ShadingRate};

#[derive(Parser)]
#[command(
    name = "shutter",
    version,
    about = "Depth of field and motion blur by stochastic rasterization on Vulkan"
)]
struct Cli {
    /// The driver to run on, by Shutter's name for it (`lavapipe-25.0`, `lavapipe-22.3`, `lavapipe`
    /// for the newest lavapipe, or a GPU's name); `shutter probe --all` lists them. Default:
    /// `$SHUTTER_DRIVER`, else the best device by type and, among equals, the newest driver.
    #[arg(long, global = true, value_name = "NAME")]
    driver: Option<String>,
    /// Treat these device features as absent although the device offers them, to see the path
    /// Shutter takes without them (or its refusal): geometry-shader, clip-distance,
    /// sample-rate-shading, independent-blend, fragment-stores-and-atomics,
    /// vertex-pipeline-stores-and-atomics, conservative-rasterization, mesh-shader, task-shader,
    /// buffer-int64-atomics, shader-int64, timestamp-queries, linear-filter-rgba32f, msaa-N.
    /// Comma-separated or repeated; added to `$SHUTTER_DISABLE`. They are not enabled on the device, so validation reports any use.
    #[arg(long, global = true, value_name = "FEATURE", value_delimiter = ',')]
    disable: Vec<String>,
    #[command(subcommand)]
    command: Command,
}

/// `--driver`, set once before any command runs.
static DRIVER: std::sync::OnceLock<Option<String>> = std::sync::OnceLock::new();
/// `--disable`, parsed, set once before any command runs.
static DISABLED: std::sync::OnceLock<Vec<shutter::vk::Feature>> = std::sync::OnceLock::new();

/// The device description the environment gives, with `--driver` (if given) in place of
/// `$SHUTTER_DRIVER` and `--disable`'s features added to `$SHUTTER_DISABLE`'s.
fn device_desc() -> shutter::Result<shutter::vk::DeviceDesc> {
    let mut desc = shutter::vk::DeviceDesc::from_env()?;
    if let Some(Some(d)) = DRIVER.get() {
        desc.driver = Some(d.clone());
    }
    desc.disabled.extend(DISABLED.get().into_iter().flatten().copied());
    Ok(desc)
}

/// The device [`device_desc`] describes.
fn create_device() -> shutter::Result<shutter::vk::Device> {
    shutter::vk::DeviceShared::new(&device_desc()?)
}

#[derive(Subcommand)]
enum Command {
    /// Render a scene on the GPU.
    Render(cmd::render::RenderArgs),
    /// Render the CPU ground truth (distribution ray tracer).
    Reference {
        #[arg(default_value = "default")]
        scene: String,
        /// Rays per pixel.
        #[arg(long, default_value_t = 256)]
        spp: u32,
        /// per-sample (the ground truth) or per-pixel: shade like `stochastic --shading per-pixel`
        /// with --per-pass samples per pass, so the two can be compared exactly; decoupled, aas,
        /// aas-isotropic (with or without -deferred): what those rates compute whatever their cache.
        #[arg(long, default_value = "per-sample")]
        shading: String,
        /// Per-pixel shading: samples per pixel and pass of the stochastic render it mirrors (default:
        /// all of them, its one pass).
        #[arg(long)]
        per_pass: Option<u32>,
        /// One-bounce indirect light by instant radiosity with this many photons from the lights
        /// (every shaded point gathers every VPL; still scenes) instead of a bounce ray per sample.
        #[arg(long)]
        vpls: Option<u32>,
        /// With --vpls: clamp the VPLs' 1/d² at this distance (scene units; 0: off, unbiased).
        #[arg(long, default_value_t = 0.0)]
        clamp: f32,
        /// With --vpls: the CPU mirror of interleaved deferred shading (engine/src/mirror/interleaved.rs) on
        /// a G-buffer of one sample at each pixel's centre (a still pinhole scene) or, for a scene
        /// with a lens or motion, --spp accumulated passes of one (subpixel, lens, time) sample each:
        /// each pixel of an NxM pattern gathers its own subset of the VPLs; 1x1 with --filter none is
        /// the brute force.
        #[arg(long)]
        interleave: Option<String>,
        /// With --interleave: the two-pass split's block, in patterns (BxB).
        #[arg(long, default_value = "4x4")]
        block: String,
        /// With --interleave: `full` (the paper's edge-aware Gaussian), `axis` (the same stopping at
        /// each axis' own edges), `plain` (the Gaussian ignoring discontinuities) or `none`.
        #[arg(long, default_value = "full")]
        filter: String,
        /// With --interleave: the Gaussian's radius in pixels (default: the pattern's larger side).
        #[arg(long)]
        radius: Option<u32>,
        /// With --interleave: fetch the kernel in bilinear pairs.
        #[arg(long)]
        bilinear: bool,
        /// With --interleave: no shadow rays to the VPLs (the paper's SNSM).
        #[arg(long)]
        snsm: bool,
        #[command(flatten)]
        image: ImageArgs,
        #[command(flatten)]
        display: DisplayArgs,
    },
    /// Compare two images: RMSE, PSNR and mean FLIP of B against reference A; with `--max-flip` /
    /// `--max-rmse`, exit 0 within them, 1 beyond, 2 where the images could not be compared.
    Compare(cmd::compare::CompareArgs),
    /// The rendering regression check for a driver's CI: every case of a suite (`check/smoke.toml`)
    /// against its expected image — bit for bit where driver, device and CPU are the recorded ones,
    /// within the case's RMSE and FLIP thresholds elsewhere. Exit 0 pass, 1 regression, 2 not run.
    Check(cmd::check::CheckArgs),
    /// Convert an image between .exr (linear) and .png (sRGB).
    /// With --exposure / --tone, a PNG is written through them (an EXR stays linear).
    Convert {
        input: PathBuf,
        output: PathBuf,
        #[command(flatten)]
        display: DisplayArgs,
    },
    /// Sample test efficiency and GPU ms of every stochastic bound on a scene, next to pinhole and
    /// accumulation at the same samples per pixel (markdown table on stdout).
    Bounds(cmd::bounds::BoundsArgs),
    /// Compare two sets of `bench --json` reports (e.g. an old and a new binary run alternately, see
    /// scripts/bench-ab.sh): per configuration, the median over runs of each run's median GPU ms and
    /// CPU frame ms, and new ÷ old; markdown on stdout.
    BenchCompare {
        /// Reports of the baseline.
        #[arg(long, num_args = 1.., required = true)]
        old: Vec<PathBuf>,
        /// Reports of the candidate.
        #[arg(long, num_args = 1.., required = true)]
        new: Vec<PathBuf>,
        /// Fail (exit 1) when a configuration's new ÷ old exceeds this (in the measures of --gate).
        #[arg(long, value_parser = parse_ratio)]
        max_ratio: Option<f64>,
        /// Which ratio --max-ratio applies to: `process` (process CPU time per frame, every thread —
        /// the steadiest on a shared machine), `cpu` (frame wall time), `gpu` (summed timestamp
        /// scopes) or `all`. Frame and process time include every pass, so they compare binaries
        /// that time different sets of passes.
        #[arg(long, default_value = "all", value_parser = ["process", "cpu", "gpu", "all"])]
        gate: String,
    },
    /// Time techniques and settings on one scene: interleaved frames after warm-up, medians and
    /// min/max of GPU ms per frame and per pass, CPU frame ms, sample counters; markdown on stdout.
    Bench {
        #[arg(default_value = "default")]
        scene: String,
        /// A configuration `technique[:spp=N][:shadow-map=SIZE/S/PCF|off][:bound=B][:shading=RATE (as render's --shading)][:cache=N][:per-pass=M][:intervals=auto|K][:clusters=auto|off|N][:hull=gs|compute|mesh|mesh-task][:coverage=visibility|mask|mask-per-fragment|device]`; repeat for
        /// more. The first is the baseline of the ratios.
        #[arg(short = 'c', long = "config", default_values_t = ["auto".to_string(), "pinhole".to_string()])]
        configs: Vec<String>,
        /// Default samples per pixel. Default: the scene's [image] spp.
        #[arg(long)]
        spp: Option<u32>,
        /// Timed frames per configuration.
        #[arg(long, default_value_t = 10)]
        frames: usize,
        /// Untimed frames per configuration first (lavapipe compiles shaders on the first frame).
        #[arg(long, default_value_t = 2)]
        warmup: usize,
        /// Skip the extra instrumented frame that collects sample counters.
        #[arg(long)]
        no_counters: bool,
        /// List a configuration the device refuses (a missing feature, an unsupported MSAA count)
        /// with its reason instead of failing; the first that runs is the baseline.
        #[arg(long)]
        skip_refused: bool,
        /// Fail (exit 1) when a configuration's median GPU ms exceeds this multiple of the first's.
        #[arg(long, value_parser = parse_ratio)]
        max_ratio: Option<f64>,
        #[arg(long)]
        json: Option<PathBuf>,
        #[arg(long)]
        csv: Option<PathBuf>,
        /// Image size WxH. Default: the scene's [image] size.
        #[arg(long, value_parser = parse_size)]
        size: Option<(u32, u32)>,
        #[arg(long)]
        seed: Option<u64>,
    },
    /// What accuracy costs in time: sweep series of techniques × sample counts against the cached CPU
    /// reference; CSV (resumable), log-log plot of FLIP vs GPU ms with the Pareto front (PNG, SVG),
    /// markdown table with the ms ratio at equal FLIP.
    Quality(cmd::quality::QualityArgs),
    /// Print the effect planner's decision per object (technique `auto`) with the numbers behind it.
    Plan(cmd::plan::PlanArgs),
    /// Print the device, driver and capabilities, and the paths Shutter takes on it.
    Probe {
        /// Every driver found (the system's ICDs and the project's `.drivers/`), each with its
        /// version, capabilities and paths; the first listed is the default.
        #[arg(long)]
        all: bool,
        /// JSON (an array with one object per driver) instead of text.
        #[arg(long)]
        json: bool,
    },
    /// Measure this driver: the quality planner's cost model (accumulation against the per-object
    /// stochastic frame at equal S) and which stochastic bound is cheapest (the images do not depend
    /// on it: bbox, convex-hull and adaptive benched interleaved). Both are saved to the user's
    /// calibration file, which `render`/`auto` read from then on (engine/src/calibration.rs).
    Calibrate(cmd::calibrate::CalibrateArgs),
    /// The stochastic rasterizer's hardware paths side by side on this driver: coverage
    /// (visibility / mask / mask-per-fragment) × hull (compute / gs / mesh) × shading rate × samples
    /// per pass, timed interleaved, every ratio with its bootstrap 95 % interval and whether the
    /// images agree; JSON, markdown and a plot (--out STEM). Cells the device refuses are listed
    /// with the reason. `--compare A.json B.json` sets two reports (two drivers) side by side.
    Matrix(cmd::matrix::MatrixArgs),
    /// Run the hard-case matrix (scenes/hard/*.toml × every technique and shading rate against the
    /// reference, with the convergence check) and print it, or write it into docs/HARD_CASES.md
    /// (`--out`); exits 1 when a cell fails.
    HardCases(hard_cases::HardCasesArgs),
    /// List the built-in scenes.
    Scenes,
    /// List the techniques (the registry, engine/src/techniques/registry.rs) with one line each, and
    /// the settings keys (engine/src/techniques/settings.rs).
    Techniques,
}

/// `--quality NAME` or `--target-flip X` (at most one).
fn quality_target(quality: Option<&str>, target_flip: Option<f32>) -> Result<Option<QualityTarget>> {
    Ok(match (quality, target_flip) {
        (Some(_), Some(_)) => bail!("give --quality or --target-flip, not both"),
        (Some(q), None) => Some(q.parse()?),
        (None, Some(f)) => Some(QualityTarget::from_flip(f)?),
        (None, None) => None,
    })
}

/// The registered techniques' names, with their summaries for `--help`.
fn technique_names() -> clap::builder::PossibleValuesParser {
    shutter::techniques::registry::TECHNIQUES
        .iter()
        .map(|t| clap::builder::PossibleValue::new(t.name()).help(t.summary()))
        .collect::<Vec<_>>()
        .into()
}

/// Image options shared by `render` and `reference`.
#[derive(clap::Args)]
struct ImageArgs {
    /// Image size WxH. Default: the scene's [image] size.
    #[arg(long, value_parser = parse_size)]
    size: Option<(u32, u32)>,
    /// Sample-set seed. Default: the scene's [image] seed.
    #[arg(long)]
    seed: Option<u64>,
    /// Output file, .png (sRGB) or .exr (linear). Default: out/<scene>-<technique>.png for render,
    /// out/<scene>-reference.exr for reference.
    #[arg(long)]
    out: Option<PathBuf>,
}

/// The PNG output's display transform (`shutter::tonemap`); an EXR stays linear.
#[derive(Args, Clone, Copy, Default)]
struct DisplayArgs {
    /// PNG output: exposure in stops (the linear image ×2^EV before the tone curve), |EV| ≤ 64.
    /// Default: the scene's [image] exposure (0).
    #[arg(long, allow_hyphen_values = true, value_parser = parse_exposure)]
    exposure: Option<f32>,
    /// PNG output: tone curve clip (above 1 is white, the default), reinhard (x / (1 + x): nothing
    /// a scene holds clips) or aces (a filmic toe and shoulder). Default: the scene's [image] tone.
    #[arg(long, value_parser = parse_tone)]
    tone: Option<shutter::tonemap::ToneCurve>,
}

impl DisplayArgs {
    /// The scene's display transform with the flags given over it.
    fn over(self, scene: shutter::tonemap::Display) -> shutter::tonemap::Display {
        shutter::tonemap::Display {
            exposure_ev: self.exposure.unwrap_or(scene.exposure_ev),
            curve: self.tone.unwrap_or(scene.curve),
        }
    }
}

/// `--exposure`: finite stops within ±MAX_EXPOSURE_EV.
fn parse_exposure(s: &str) -> std::result::Result<f32, String> {
    let max = shutter::tonemap::MAX_EXPOSURE_EV;
    match s.trim().parse::<f32>() {
        Ok(ev) if shutter::tonemap::exposure_in_range(ev) => Ok(ev),
        _ => Err(format!("`{s}` is not an exposure: give stops in [-{max}, {max}] (e.g. -1.5)")),
    }
}

/// `--tone`: a curve's name.
fn parse_tone(s: &str) -> std::result::Result<shutter::tonemap::ToneCurve, String> {
    shutter::tonemap::ToneCurve::parse(s.trim())
}

fn parse_size(s: &str) -> std::result::Result<(u32, u32), String> {
    let (w, h) = s.split_once(['x', 'X']).ok_or_else(|| format!("size `{s}` is not WxH (e.g. 640x360)"))?;
    let w = w.trim().parse::<u32>().map_err(|e| format!("width `{w}`: {e}"))?;
    let h = h.trim().parse::<u32>().map_err(|e| format!("height `{h}`: {e}"))?;
    if w == 0 || h == 0 {
        return Err(format!("size `{s}`: width and height must be at least 1 pixel"));
    }
    Ok((w, h))
}

/// `--max-ratio`: a finite number > 0.
fn parse_ratio(s: &str) -> std::result::Result<f64, String> {
    match s.trim().parse::<f64>() {
        Ok(r) if r.is_finite() && r > 0.0 => Ok(r),
        _ => Err(format!("`{s}` is not a ratio: give a finite number > 0 (e.g. 1.1)")),
    }
}

/// `plan --threshold`: a finite number of pixels ≥ 0.
fn parse_threshold(s: &str) -> std::result::Result<f32, String> {
    match s.trim().parse::<f32>() {
        Ok(px) if px.is_finite() && px >= 0.0 => Ok(px),
        _ => Err(format!("`{s}` is not a blur threshold: give a finite number of pixels ≥ 0 (e.g. 0.5)")),
    }
}

/// Loads a built-in scene or a scene file and says on stderr what cleaning its meshes skipped, per
/// mesh (the README promises the count).
fn load_scene(spec: &str) -> Result<shutter::scene::Scene> {
    let sc = shutter::scene::file::load_scene(spec)?;
    for skipped in sc.skipped_by_mesh() {
        errln!("note: {skipped}");
    }
    Ok(sc)
}

fn default_out(scene: &str, what: &str, ext: &str) -> Result<PathBuf> {
    let stem = Path::new(scene).file_stem().and_then(|s| s.to_str()).unwrap_or("scene");
    std::fs::create_dir_all("out").context("creating out/")?;
    Ok(PathBuf::from(format!("out/{stem}-{what}.{ext}")))
}

/// `shutter plan --atlases`: texture-space shading's atlas per object (docs/ATSS.md).
fn print_atlas_plan(sc: &shutter::scene::Scene, w: u32, h: u32) -> anyhow::Result<()> {
    use shutter::techniques::stochastic::{TEXTURE_SPACE_FINEST, TEXTURE_SPACE_GUTTER};
    let largest =
        shutter::mirror::texture_space::atlas::MipAtlas::new(TEXTURE_SPACE_FINEST, TEXTURE_SPACE_GUTTER)?;
    let view = shutter::scene::view::View::camera(sc, w, h);
    let t0 = std::time::Instant::now();
    let rows = shutter::techniques::texture_space::plan_atlases(sc, &view, largest);
    let ms = t0.elapsed().as_secs_f64() * 1e3;
    let back = |r: &shutter::techniques::texture_space::AtlasPlan| {
        r.back_facing.map_or_else(|| "two-sided".to_string(), |n| n.to_string())
    };
    outln!(
        "\n## texture-space shading (`--shading texture-space`)\n\nlevel 0 at most {TEXTURE_SPACE_FINEST}², \
         fitted per object; RGBA32F atlas + D32 depth\n"
    );
    outln!(
        "| object | triangles | culled: frustum | culled: back-facing | shaded texels (estimate) | shading times | shading space | level 0 | atlas texels | memory |"
    );
    outln!("|---|---:|---:|---:|---:|---:|---|---:|---:|---:|");
    let mut total = 0;
    for r in &rows {
        match &r.layout {
            Ok((atlas, space)) => {
                let (aw, ah) = atlas.size();
                total += r.bytes();
                outln!(
                    "| {} | {} | {} | {} | {:.0} | {} | {space} | {}² | {aw}×{ah} | {:.2} MB |",
                    r.object,
                    r.triangles,
                    r.culled,
                    back(r),
                    r.texels,
                    r.shading_times,
                    atlas.finest(),
                    r.bytes() as f64 / 1e6
                );
            }
            Err(why) => outln!(
                "| {} | {} | {} | {} | - | - | {why} | - | - | - |",
                r.object,
                r.triangles,
                r.culled,
                back(r)
            ),
        }
    }
    // Folded from +0: an empty sum of f64 is −0, printed "-0".
    let texels: f64 = rows.iter().fold(0.0, |a, r| a + r.texels);
    outln!(
        "\natlases: {:.2} MB in all; about {texels:.0} texels shaded (gutters not counted); laid out in {ms:.1} ms on the CPU",
        total as f64 / 1e6
    );
    Ok(())
}

fn main() {
    install_interrupt_handler();
    // Whatever is still buffered is written before the exit code is decided.
    let result = run().and_then(|()| {
        use std::io::Write;
        std::io::stdout().lock().flush().map_err(|e| StdoutError(e).into())
    });
    if let Err(e) = result {
        if e.chain().any(|c| matches!(c.downcast_ref::<shutter::Error>(), Some(shutter::Error::Interrupted)))
        {
            note(format_args!("interrupted: stopped cleanly, nothing written"));
            std::process::exit(EXIT_INTERRUPTED);
        }
        let stdout = e.chain().find_map(|c| c.downcast_ref::<StdoutError>());
        if stdout.is_some_and(|s| s.0.kind() == std::io::ErrorKind::BrokenPipe) {
            // The reader went away (`| head -1`): stop quietly, as a Unix tool killed by SIGPIPE does.
            std::process::exit(EXIT_BROKEN_PIPE);
        }
        note(format_args!("error: {e:#}"));
        if e.chain().any(|c| c.downcast_ref::<cmd::compare::NotCompared>().is_some()) {
            std::process::exit(cmd::compare::EXIT_NOT_COMPARED);
        }
        std::process::exit(1);
    }
}

/// The shell's code for a process ended by SIGPIPE (128 + 13): what `head` leaves other tools with.
const EXIT_BROKEN_PIPE: i32 = 141;

/// Standard output could not be written (the `outln!` lines).
#[derive(Debug)]
struct StdoutError(std::io::Error);

impl std::fmt::Display for StdoutError {
    fn fmt(&self, f: &mut std::fmt::Formatter) -> std::fmt::Result {
        write!(f, "cannot write to standard output: {}", self.0)
    }
}

impl std::error::Error for StdoutError {}

/// One line on standard output, or a [`StdoutError`] (what `outln!` calls).
fn write_stdout_line(args: std::fmt::Arguments) -> Result<()> {
    use std::io::Write;
    let mut out = std::io::stdout().lock();
    out.write_fmt(args).and_then(|()| out.write_all(b"\n")).map_err(|e| StdoutError(e).into())
}

/// One line on standard error, ignoring a closed one (nothing else could say so).
fn note(args: std::fmt::Arguments) {
    use std::io::Write;
    let _ = writeln!(std::io::stderr().lock(), "{args}");
}

/// The shell's code for a process ended by SIGINT (128 + 2).
const EXIT_INTERRUPTED: i32 = 130;

/// Ctrl-C: the first asks the work to stop at its next step (a tile, a submission of passes, a frame:
/// the device is then idle and everything is freed in order, `shutter::progress`); the second quits at
/// once.
fn install_interrupt_handler() {
    let installed = ctrlc::set_handler(|| {
        if shutter::progress::interrupted() {
            errln!("\ninterrupted again: quitting at once");
            std::process::exit(EXIT_INTERRUPTED);
        }
        shutter::progress::request_interrupt();
        errln!("\ninterrupt: stopping after the current step (Ctrl-C again to quit at once)");
    });
    if let Err(e) = installed {
        errln!("note: no Ctrl-C handler ({e}); Ctrl-C ends the process at once");
    }
}

fn run() -> Result<()> {
    let cli = Cli::parse();
    DRIVER.set(cli.driver.clone()).expect("run() is called once");
    let disabled = cli.disable.iter().map(|k| k.parse()).collect::<Result<Vec<_>, String>>();
    DISABLED.set(disabled.map_err(|e| anyhow::anyhow!("--disable {e}"))?).expect("run() is called once");
    match cli.command {
        Command::Render(args) => cmd::render::run(args)?,
        Command::Reference {
            scene,
            spp,
            vpls,
            clamp,
            interleave: Some(pattern),
            block,
            filter,
            radius,
            bilinear,
            snsm,
            image: ImageArgs { size, seed, out },
            display,
            ..
        } => {
            let sc = load_scene(&scene)?;
            let (width, height) = size.unwrap_or((sc.image.width, sc.image.height));
            let Some(count) = vpls else {
                return Err(anyhow::anyhow!("--interleave shades virtual point lights: give --vpls N"));
            };
            let pattern: shutter::mirror::interleaved::Pattern = pattern.parse()?;
            let block: shutter::mirror::interleaved::Pattern = block.parse()?;
            let radius = radius.unwrap_or(pattern.n.max(pattern.m));
            let blur = shutter::mirror::interleaved::Edges::of_filter(&filter)?
                .map(|edges| shutter::mirror::interleaved::Blur { radius, bilinear, edges });
            let seed = seed.unwrap_or(sc.image.seed);
            let out = match out {
                Some(o) => o,
                None => default_out(&scene, "interleaved-cpu", "exr")?,
            };
            check_image_output(&out)?;
            let start = std::time::Instant::now();
            let v = shutter::reference::VplSettings { count, clamp, seed };
            let passes = shutter::mirror::interleaved::frame_passes(&sc, spp, seed);
            let sets = shutter::mirror::interleaved::pass_vpls(&sc, &v, &passes)?;
            let settings = shutter::mirror::interleaved::InterleavedSettings {
                pattern,
                block: (block.n, block.m),
                blur,
                discontinuity: Default::default(),
                clamp,
                visibility: !snsm,
            };
            let image =
                shutter::mirror::interleaved::render_frame(&sc, (width, height), &passes, &sets, &settings)?;
            let secs = start.elapsed().as_secs_f64();
            shutter::progress::check_interrupt()?;
            save_image_displayed(&out, &image, &display.over(sc.image.display))?;
            outln!(
                "{} interleaved (CPU) {}x{}, {} pass(es): {} VPLs from {count} photons{}, pattern {}, filter {filter}{}, {} in {secs:.1} s; wrote {}",
                sc.name,
                width,
                height,
                passes.len(),
                sets[0].len(),
                if sets.len() > 1 { " (pass 1; a set per pass)" } else { "" },
                pattern.name(),
                if bilinear { " (bilinear)" } else { "" },
                if snsm { "no VPL visibility" } else { "VPL shadow rays" },
                out.display()
            );
        }
        Command::Reference {
            scene,
            spp,
            shading,
            per_pass,
            vpls,
            clamp,
            image: ImageArgs { size, seed, out },
            display,
            ..
        } => {
            let sc = load_scene(&scene)?;
            let (width, height) = size.unwrap_or((sc.image.width, sc.image.height));
            let Some(shading) = shading.parse::<ShadingRate>()?.reference(per_pass.unwrap_or(spp)) else {
                return Err(shutter::Error::Unsupported(
                    "the reference shades per sample, per pixel or decoupled; texture-space shading is a \
                     GPU approximation of per-sample shading (compare it with `--shading per-sample`)"
                        .into(),
                )
                .into());
            };
            let seed = seed.unwrap_or(sc.image.seed);
            let out = match out {
                Some(o) => o,
                None => default_out(&scene, "reference", "exr")?,
            };
            check_image_output(&out)?;
            let settings = ReferenceSettings { width, height, spp, seed, progress: true, shading };
            let start = std::time::Instant::now();
            let (image, stats) = match vpls {
                None => shutter::reference::render_reference_with_stats(&sc, &settings)?,
                Some(count) => {
                    let v = shutter::reference::VplSettings { count, clamp, seed };
                    let (image, stats, n) = shutter::reference::render_reference_vpl(&sc, &settings, &v)?;
                    outln!("instant radiosity: {n} virtual point lights from {count} photons, clamped at {clamp}");
                    (image, stats)
                }
            };
            let secs = start.elapsed().as_secs_f64();
            shutter::progress::check_interrupt()?;
            if let Some(keys) = stats.decoupled_keys {
                outln!("decoupled shading: {keys} distinct keys (shading points) among the samples");
            }
            save_image_displayed(&out, &image, &display.over(sc.image.display))?;
            outln!(
                "{} reference {}x{} spp {} in {:.1} s on {} CPU threads; wrote {}",
                sc.name,
                width,
                height,
                spp,
                secs,
                rayon_threads(),
                out.display()
            );
        }
        Command::Compare(args) => cmd::compare::run(args)?,
        Command::Check(args) => match cmd::check::run(args) {
            Ok(0) => {}
            Ok(code) => std::process::exit(code),
            // A suite that cannot be read, no device: not run (2), not a regression.
            Err(e) => return Err(cmd::compare::NotCompared(format!("{e:#}")).into()),
        },
        Command::Convert { input, output, display } => {
            check_image_output(&output)?;
            save_image_displayed(&output, &load_image(&input)?, &display.over(Default::default()))?;
            outln!("wrote {}", output.display());
        }
        Command::Bounds(args) => cmd::bounds::run(args)?,
        Command::Bench {
            scene,
            configs,
            spp,
            frames,
            warmup,
            no_counters,
            skip_refused,
            max_ratio,
            json,
            csv,
            size,
            seed,
        } => {
            let sc = load_scene(&scene)?;
            let mut defaults = RenderSettings::from_scene(&sc);
            if let Some((w, h)) = size {
                (defaults.width, defaults.height) = (w, h);
            }
            defaults.spp = spp.unwrap_or(defaults.spp);
            defaults.seed = seed.unwrap_or(defaults.seed);
            let configs =
                configs.iter().map(|c| bench::Config::parse(c, &defaults)).collect::<Result<Vec<_>>>()?;
            for path in json.iter().chain(&csv) {
                check_output_file(path)?;
            }
            let mut renderer = Renderer::new(create_device()?)?;
            let args = bench::BenchArgs {
                configs,
                frames: frames.max(1),
                warmup,
                counters: !no_counters,
                skip_refused,
            };
            let report = bench::run(&mut renderer, &sc, &args)?;
            outln!("{}", report.markdown());
            report.write(json.as_ref(), csv.as_ref())?;
            if let Some(max) = max_ratio {
                let over: Vec<String> = report
                    .results
                    .iter()
                    .filter(|r| r.ratio_to_first > max)
                    .map(|r| format!("`{}` {:.3}×", r.label, r.ratio_to_first))
                    .collect();
                if !over.is_empty() {
                    anyhow::bail!("over {max}× the first configuration's median GPU ms: {}", over.join(", "));
                }
                outln!("every configuration within {max}× of `{}`", report.results[0].label);
            }
        }
        Command::BenchCompare { old, new, max_ratio, gate } => {
            let read =
                |paths: &[PathBuf]| paths.iter().map(|p| bench::read_report(p)).collect::<Result<Vec<_>>>();
            let (old, new) = (read(&old)?, read(&new)?);
            let rows = bench::compare(&old, &new)?;
            outln!("{}", bench::comparison_markdown(&old[0].scene, (old.len(), new.len()), &rows));
            if let Some(max) = max_ratio {
                let over: Vec<String> = rows
                    .iter()
                    .filter(|r| {
                        let all = gate == "all";
                        ((all || gate == "gpu") && r.gpu_ratio() > max)
                            || ((all || gate == "cpu") && r.cpu_ratio() > max)
                            || ((all || gate == "process") && r.process_ratio() > max)
                            // Not measured (an older binary) cannot pass a process-time gate.
                            || (gate == "process" && r.process_ratio().is_nan())
                    })
                    .map(|r| {
                        format!(
                            "`{}` GPU {:.3}× frame {:.3}× process {:.3}×",
                            r.label,
                            r.gpu_ratio(),
                            r.cpu_ratio(),
                            r.process_ratio()
                        )
                    })
                    .collect();
                if !over.is_empty() {
                    anyhow::bail!("over {max}× the old runs: {}", over.join(", "));
                }
                outln!("every configuration within {max}× of the old runs ({gate} ratio)");
            }
        }
        Command::Quality(args) => cmd::quality::run(args)?,
        Command::Plan(args) => cmd::plan::run(args)?,
        Command::Probe { all, json } => probe(all, json)?,
        Command::Calibrate(args) => cmd::calibrate::run(args)?,
        Command::Matrix(args) => cmd::matrix::run(args)?,
        Command::HardCases(args) => hard_cases::run(args)?,
        Command::Scenes => {
            for s in BUILTIN_SCENES {
                outln!("{s}");
            }
        }
        Command::Techniques => {
            for t in shutter::techniques::registry::TECHNIQUES {
                let info = t.info();
                outln!("{:<13} {}", t.name(), t.summary());
                let keys: Vec<&str> = info.keys.iter().flat_map(|g| g.iter()).map(|k| k.key).collect();
                outln!("{:<13}   keys: {}", "", keys.join(", "));
                if !info.required_features.is_empty() {
                    let f: Vec<String> =
                        info.required_features.iter().map(|(f, _)| f.vulkan_name()).collect();
                    outln!("{:<13}   needs: {}", "", f.join(", "));
                }
                let c = info.capabilities;
                let can: Vec<&str> = [
                    (c.transparency, "transparency"),
                    (c.transparency_methods, "order-independent transparency methods"),
                    (c.embeddable, "recording into a caller's command buffer"),
                ]
                .into_iter()
                .filter_map(|(has, what)| has.then_some(what))
                .collect();
                if !can.is_empty() {
                    outln!("{:<13}   can: {}", "", can.join(", "));
                }
            }
            outln!("\nsettings (render --set KEY=VALUE, bench -c and quality -s TECHNIQUE:KEY=VALUE:…):");
            for k in shutter::techniques::settings::option_keys() {
                outln!("  {:<13} {:<22} {}", k.key, k.owner, k.values);
            }
        }
    }
    Ok(())
}

/// `shutter probe [--all] [--json]`: the chosen device (or every driver's), its capabilities and the
/// paths Shutter takes on it.
fn probe(all: bool, json: bool) -> Result<()> {
    let devices = if all {
        let list = shutter::vk::available_drivers()?;
        if list.is_empty() {
            bail!("no Vulkan driver found (run scripts/setup.sh)");
        }
        let mut devices = vec![];
        for d in &list {
            // Name the driver by its full version and the device by name: exactly this one.
            let mut desc = device_desc()?;
            desc.driver = Some(format!(
                "{}-{}",
                shutter::vk::drivers::driver_family(&d.driver_id, &d.device_name),
                d.driver_version
            ));
            desc.device_name = Some(d.device_name.clone());
            devices.push(shutter::vk::DeviceShared::new(&desc).with_context(|| format!("driver {}", d.key))?);
        }
        devices
    } else {
        vec![create_device()?]
    };
    if json {
        let rows: Vec<serde_json::Value> = devices
            .iter()
            .enumerate()
            .map(|(i, d)| {
                serde_json::json!({
                    "default": i == 0 && all,
                    "capabilities": d.caps,
                    "validation": d.validation_enabled,
                    "paths": shutter::techniques::feature_paths(&d.caps),
                    "provenance": provenance::Provenance::of(&d.caps),
                })
            })
            .collect();
        outln!("{}", serde_json::to_string_pretty(&rows)?);
        return Ok(());
    }
    if all {
        outln!(
            "{} driver(s); the first is the default when none is named (--driver, SHUTTER_DRIVER):\n",
            devices.len()
        );
        outln!("| name | version | device | type | from | API |");
        outln!("|---|---|---|---|---|---|");
        for d in &devices {
            let c = &d.caps;
            outln!(
                "| {} | {} | {} | {} | {} | {} |",
                c.driver_key,
                c.driver_info,
                c.device_name,
                c.device_type,
                c.project_driver.as_deref().map_or("system ICD".to_string(), |p| format!(".drivers/{p}")),
                c.api_version
            );
        }
    }
    for d in &devices {
        if all {
            outln!("\n## {}\n", d.caps.driver_key);
        }
        outln!("{}", d.caps);
        outln!("validation        {}", if d.validation_enabled { "on" } else { "off" });
        outln!("\npaths Shutter takes on this device:");
        for p in shutter::techniques::feature_paths(&d.caps) {
            outln!("  {:<34} {:<5} {}", p.feature, if p.available { "yes" } else { "no" }, p.path);
        }
    }
    outln!("\n{}", provenance::Provenance::of(&devices[0].caps).markdown().trim_end());
    Ok(())
}

fn rayon_threads() -> usize {
    std::thread::available_parallelism().map(|n| n.get()).unwrap_or(1)
}
