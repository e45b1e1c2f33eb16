//! `shutter matrix`: the stochastic rasterizer's hardware paths side by side on one driver —
//! coverage (visibility buffer / `gl_SampleMask` per sample / per fragment) × bound expansion
//! (compute / geometry / mesh shader) × shading rate × samples per pass (the MSAA count on the mask
//! path) — timed in one interleaved `bench` run, with the spread of every ratio and whether the
//! images agree; and `--compare`, two drivers' reports side by side.
//!
//! A cell the device refuses (no mesh shaders, an MSAA count it lacks) is listed with the reason,
//! not timed and not a failure: the matrix is the same command on every driver.

use std::fmt::Write as _;
use std::path::{Path, PathBuf};

use anyhow::{Context, Result};
use clap::Args;
use plotters::prelude::*;
use serde::{Deserialize, Serialize};
use shutter::image_io::check_output_file;
use shutter::techniques::{RenderSettings, Renderer};

use crate::bench::{self, paired_ratio_interval, BenchReport, ImageDiff, RatioInterval, BOOTSTRAP_RESAMPLES};
use crate::quality::{format_sig, register_font, PALETTE};
use crate::*;

/// Time the stochastic rasterizer's paths (coverage × hull × shading × samples per pass) on one
/// scene and driver: JSON, markdown and a plot of every ratio with its bootstrap interval; or
/// compare two such reports (e.g. two drivers) with --compare.
#[derive(Args)]
pub struct MatrixArgs {
    #[arg(default_value = "default")]
    pub scene: String,
    /// Coverage paths, comma-separated (visibility, mask, mask-per-fragment).
    #[arg(long, value_delimiter = ',', default_value = "visibility,mask,mask-per-fragment")]
    pub coverage: Vec<String>,
    /// Bound expansions, comma-separated (compute, gs, mesh, mesh-task).
    #[arg(long, value_delimiter = ',', default_value = "compute,gs,mesh,mesh-task")]
    pub hull: Vec<String>,
    /// Shading rates, comma-separated (as render's --shading).
    #[arg(long, value_delimiter = ',', default_value = "per-pixel,per-sample")]
    pub shading: Vec<String>,
    /// Samples per pass, comma-separated: the MSAA count on the mask path, the samples one pass
    /// tests on the visibility path.
    #[arg(long, value_delimiter = ',', default_value = "4,8")]
    pub per_pass: Vec<u32>,
    /// Samples per pixel S.
    #[arg(long, default_value_t = 16)]
    pub spp: u32,
    /// Timed frames per cell, interleaved (frame k of every cell before frame k + 1 of any).
    #[arg(long, default_value_t = 10)]
    pub frames: usize,
    /// Untimed frames per cell first (lavapipe compiles shaders on the first frame).
    #[arg(long, default_value_t = 2)]
    pub warmup: usize,
    /// Image size WxH.
    #[arg(long, value_parser = parse_size, default_value = "320x180")]
    pub size: (u32, u32),
    /// Sample-set seed. Default: the scene's [image] seed.
    #[arg(long)]
    pub seed: Option<u64>,
    /// Collect Shutter's sample counters (one extra instrumented frame per cell).
    #[arg(long)]
    pub counters: bool,
    /// Output stem: writes STEM.json, STEM.md, STEM.png and STEM.svg (with --compare: STEM.md).
    #[arg(long, default_value = "out/matrix")]
    pub out: PathBuf,
    /// Instead of running: rewrite STEM.md, STEM.png and STEM.svg from a report's JSON (e.g. after
    /// a change to the table or the plot), measuring nothing.
    #[arg(long, value_name = "REPORT.json", conflicts_with = "compare")]
    pub from: Option<PathBuf>,
    /// Instead of running: compare two matrix reports (STEM.json of two drivers or machines).
    #[arg(long, num_args = 2, value_names = ["A.json", "B.json"])]
    pub compare: Vec<PathBuf>,
}

/// One cell of the matrix: the path it names, and what it measured or why it was refused.
#[derive(Clone, Debug, Serialize, Deserialize)]
pub struct Cell {
    pub label: String,
    pub coverage: String,
    pub hull: String,
    pub shading: String,
    pub per_pass: u32,
    /// Why the device or scene refused it (then nothing below is measured).
    pub refused: Option<String>,
    /// Median GPU ms per frame and passes × MSAA samples as the frame ran them.
    pub gpu_ms: Option<f64>,
    pub passes: u32,
    pub msaa: u32,
    /// Paired per-frame ratio to the first cell that ran, with its bootstrap 95 % interval.
    pub vs_baseline: Option<RatioInterval>,
    /// The group of equal work: cells of one shading rate and samples per pass.
    pub group: String,
    /// Paired ratio to the fastest cell of its group whose image equals the group's first.
    pub vs_group_fastest: Option<RatioInterval>,
    /// The image against the first cell of its group that ran.
    pub vs_group_first: Option<ImageDiff>,
    /// With --counters: Shutter's sample counters and the device's pipeline statistics of one
    /// instrumented frame.
    #[serde(default)]
    pub counters: Option<bench::Counters>,
    #[serde(default)]
    pub pipeline_statistics: Option<shutter::vk::PipelineStatistics>,
}

#[derive(Clone, Debug, Serialize, Deserialize)]
pub struct MatrixReport {
    pub cells: Vec<Cell>,
    pub bench: BenchReport,
}

/// `STEM.ext`: a stem's own dots stay (`matrix-lavapipe-25.0`), one of the written extensions is
/// replaced (`--out m.json` writes m.md beside it).
fn with_ext(stem: &Path, ext: &str) -> PathBuf {
    let known =
        stem.extension().and_then(|e| e.to_str()).is_some_and(|e| ["json", "md", "png", "svg"].contains(&e));
    if known {
        stem.with_extension(ext)
    } else {
        let mut name = stem.as_os_str().to_owned();
        name.push(".");
        name.push(ext);
        PathBuf::from(name)
    }
}

fn label(coverage: &str, hull: &str, shading: &str, per_pass: u32) -> String {
    format!("{coverage}/{hull}/{shading}/M={per_pass}")
}

fn read(p: &Path) -> Result<MatrixReport> {
    let bytes = shutter::limits::read_capped(p, 64 << 20, "matrix report", "64 MiB")?;
    serde_json::from_slice(&bytes).with_context(|| format!("parsing {} as a matrix report", p.display()))
}

/// Writes STEM.md, STEM.png and STEM.svg of a report and prints the markdown.
fn write_views(matrix: &MatrixReport, stem: &Path) -> Result<()> {
    let paths = ["md", "png", "svg"].map(|e| with_ext(stem, e));
    let md = markdown(matrix);
    shutter::image_io::write_file_atomically(&paths[0], md.as_bytes())?;
    outln!("{md}");
    register_font()?;
    crate::quality::draw_png(&paths[1], (1100, 900), |area| draw(area, matrix))?;
    draw(SVGBackend::new(&paths[2], (1100, 900)).into_drawing_area(), matrix)
        .with_context(|| format!("drawing {}", paths[2].display()))?;
    errln!("wrote {}", paths.map(|p| p.display().to_string()).join(", "));
    Ok(())
}

pub fn run(args: MatrixArgs) -> Result<()> {
    if let Some(from) = &args.from {
        let matrix = read(from)?;
        for e in ["md", "png", "svg"] {
            check_output_file(with_ext(&args.out, e))?;
        }
        return write_views(&matrix, &args.out);
    }
    if !args.compare.is_empty() {
        let (a, b) = (read(&args.compare[0])?, read(&args.compare[1])?);
        let md = compare_markdown(&a, &b);
        let out = with_ext(&args.out, "md");
        check_output_file(&out)?;
        shutter::image_io::write_file_atomically(&out, md.as_bytes())?;
        outln!("{md}");
        errln!("wrote {}", out.display());
        return Ok(());
    }
    let sc = load_scene(&args.scene)?;
    let mut defaults = RenderSettings::from_scene(&sc);
    (defaults.width, defaults.height) = args.size;
    defaults.spp = args.spp;
    defaults.seed = args.seed.unwrap_or(defaults.seed);
    let mut cells = Vec::new();
    let mut configs = Vec::new();
    for c in &args.coverage {
        for h in &args.hull {
            for s in &args.shading {
                for &m in &args.per_pass {
                    let spec = format!("stochastic:coverage={c}:hull={h}:shading={s}:per-pass={m}");
                    let mut config = bench::Config::parse(&spec, &defaults)?;
                    config.label = label(c, h, s, m);
                    cells.push(Cell {
                        label: config.label.clone(),
                        coverage: c.clone(),
                        hull: h.clone(),
                        shading: s.clone(),
                        per_pass: m,
                        refused: None,
                        gpu_ms: None,
                        passes: 0,
                        msaa: 0,
                        vs_baseline: None,
                        group: format!("{s}, M = {m}"),
                        vs_group_fastest: None,
                        vs_group_first: None,
                        counters: None,
                        pipeline_statistics: None,
                    });
                    configs.push(config);
                }
            }
        }
    }
    let stem = args.out.clone();
    let paths = ["json", "md", "png", "svg"].map(|e| with_ext(&stem, e));
    for p in &paths {
        check_output_file(p)?;
    }
    let mut renderer = Renderer::new(create_device()?)?;
    let bench_args = bench::BenchArgs {
        configs,
        frames: args.frames.max(2),
        warmup: args.warmup,
        counters: args.counters,
        skip_refused: true,
    };
    let (report, images) = bench::run_with_images(&mut renderer, &sc, &bench_args)?;
    fill(&mut cells, &report, &images);
    let matrix = MatrixReport { cells, bench: report };
    // The measurements first, so a plot that fails loses none.
    shutter::image_io::write_file_atomically(&paths[0], serde_json::to_string_pretty(&matrix)?.as_bytes())?;
    errln!("wrote {}", paths[0].display());
    write_views(&matrix, &stem)?;
    Ok(())
}

/// Fills the cells from the bench report (its results are the cells that ran, in order) and their
/// first frames' images: refusals, times, ratios to the baseline and, per group of equal work, to
/// the group's fastest cell of the same image.
fn fill(cells: &mut [Cell], report: &BenchReport, images: &[shutter::image::LinearImage]) {
    for r in &report.refused {
        if let Some(c) = cells.iter_mut().find(|c| c.label == r.label) {
            c.refused = Some(r.reason.clone());
        }
    }
    let result = |label: &str| report.results.iter().position(|r| r.label == label);
    for c in cells.iter_mut() {
        if let Some(i) = result(&c.label) {
            let r = &report.results[i];
            c.gpu_ms = Some(r.gpu_ms.median);
            c.counters = r.counters.clone();
            c.pipeline_statistics = r.pipeline_statistics;
            (c.passes, c.msaa) = (r.passes, r.msaa);
            c.vs_baseline = if i == 0 {
                Some(RatioInterval { median: 1.0, low: 1.0, high: 1.0 })
            } else {
                r.paired_ratio
            };
        }
    }
    let groups: Vec<String> = cells.iter().fold(Vec::new(), |mut g, c| {
        if !g.contains(&c.group) {
            g.push(c.group.clone());
        }
        g
    });
    for g in groups {
        let members: Vec<(usize, usize)> = cells
            .iter()
            .enumerate()
            .filter(|(_, c)| c.group == g)
            .filter_map(|(k, c)| result(&c.label).map(|i| (k, i)))
            .collect();
        let Some(&(_, first)) = members.first() else { continue };
        for &(k, i) in &members {
            cells[k].vs_group_first = ImageDiff::of(&images[i], &images[first]);
        }
        // The fastest cell that gives the group's image: "which path wins at equal images".
        let fastest = members
            .iter()
            .filter(|(k, _)| cells[*k].vs_group_first.is_some_and(|d| d.identical))
            .min_by(|a, b| report.results[a.1].gpu_ms.median.total_cmp(&report.results[b.1].gpu_ms.median))
            .map(|&(_, i)| i);
        if let Some(f) = fastest {
            for &(k, i) in &members {
                cells[k].vs_group_fastest = paired_ratio_interval(
                    &report.results[i].gpu_ms_frames,
                    &report.results[f].gpu_ms_frames,
                    BOOTSTRAP_RESAMPLES,
                    0xFA57 + k as u64,
                )
                .or((i == f).then_some(RatioInterval { median: 1.0, low: 1.0, high: 1.0 }));
            }
        }
    }
}

/// "Mesa 25.0.7-2~bpo12+1" of "llvmpipe (Mesa 25.0.7-2~bpo12+1 (LLVM 15.0.6))"; else the name.
fn driver_short(driver: &str) -> String {
    match driver.split_once(" (") {
        Some((name, info)) => {
            let info = info.split(" (").next().unwrap_or(info).trim_end_matches(')');
            format!("{name}, {info}")
        }
        None => driver.to_string(),
    }
}

fn ratio_cell(r: Option<RatioInterval>) -> String {
    r.map(|r| r.cell()).unwrap_or_else(|| "-".into())
}

pub fn markdown(m: &MatrixReport) -> String {
    let b = &m.bench;
    let mut md = format!(
        "Scene `{}`, {}×{}, S = {}; {} / {}, Vulkan {}; {} timed frame(s) per cell after {} warm-up, \
         interleaved. Ratios are medians of paired per-frame ratios (frame k ÷ the other cell's frame \
         k of the same round) with their bootstrap 95 % interval ({BOOTSTRAP_RESAMPLES} resamples): \
         an interval that contains 1 is no measured difference. A group is one shading rate and \
         samples per pass M; `image` compares each cell's image with the group's first cell's.\n\n",
        b.scene,
        b.width,
        b.height,
        b.results.first().map(|r| r.spp).unwrap_or(0),
        b.device,
        b.driver,
        b.api_version,
        b.frames,
        b.warmup
    );
    if let Some(p) = &b.provenance {
        md.push_str(&p.markdown());
        md.push('\n');
    }
    md.push_str(
        "| group | coverage | hull | passes × MSAA | GPU ms | × group's fastest [95 % CI] | × first cell [95 % CI] | image |\n\
         |---|---|---|---:|---:|---:|---:|---|\n",
    );
    // Rows by group, fastest first within each.
    let groups: Vec<&str> = m.cells.iter().fold(Vec::new(), |mut g, c| {
        if !g.contains(&c.group.as_str()) {
            g.push(c.group.as_str());
        }
        g
    });
    let mut summary = String::new();
    for g in &groups {
        let mut rows: Vec<&Cell> = m.cells.iter().filter(|c| c.group == *g && c.gpu_ms.is_some()).collect();
        rows.sort_by(|a, b| a.gpu_ms.unwrap_or(f64::NAN).total_cmp(&b.gpu_ms.unwrap_or(f64::NAN)));
        for c in &rows {
            let _ = writeln!(
                md,
                "| {} | {} | {} | {} × {} | {} | {} | {} | {} |",
                c.group,
                c.coverage,
                c.hull,
                c.passes,
                c.msaa,
                c.gpu_ms.map(format_sig).unwrap_or_else(|| "-".into()),
                ratio_cell(c.vs_group_fastest),
                ratio_cell(c.vs_baseline),
                c.vs_group_first.map(|d| d.cell()).unwrap_or_else(|| "-".into()),
            );
        }
        let same: Vec<&&Cell> =
            rows.iter().filter(|c| c.vs_group_first.is_some_and(|d| d.identical)).collect();
        if let [winner, next, ..] = same.as_slice() {
            let _ = writeln!(
                summary,
                "- {g}: at equal images `{}` wins ({} ms); the next, `{}`, takes {}×.",
                winner.label,
                winner.gpu_ms.map(format_sig).unwrap_or_default(),
                next.label,
                ratio_cell(next.vs_group_fastest)
            );
        }
        let other: Vec<String> = rows
            .iter()
            .filter(|c| c.vs_group_first.is_some_and(|d| !d.identical))
            .map(|c| format!("`{}`", c.label))
            .collect();
        if !other.is_empty() {
            let _ = writeln!(
                summary,
                "  Another image (an approximation, not timed against the winner): {}.",
                other.join(", ")
            );
        }
    }
    if !summary.is_empty() {
        md.push_str("\nPer group:\n\n");
        md.push_str(&summary);
    }
    let counted: Vec<&Cell> =
        m.cells.iter().filter(|c| c.counters.is_some() || c.pipeline_statistics.is_some()).collect();
    if !counted.is_empty() {
        md.push_str(
            "\nCounters of one instrumented frame per cell (`--counters`): Shutter's, and the device's \
             pipeline statistics where it has them.\n\n\
             | cell | fragments | samples tested | hits | STE | shading inv. | pipeline statistics (device) |\n\
             |---|---:|---:|---:|---:|---:|---|\n",
        );
        for c in counted {
            let k = c.counters.as_ref();
            let n = |v: Option<u64>| v.map(|v| v.to_string()).unwrap_or_else(|| "-".into());
            let _ = writeln!(
                md,
                "| `{}` | {} | {} | {} | {} | {} | {} |",
                c.label,
                n(k.map(|k| k.fragments)),
                n(k.map(|k| k.samples_tested)),
                n(k.map(|k| k.samples_hit)),
                k.map(|k| format!("{:.4}", k.sample_test_efficiency)).unwrap_or_else(|| "-".into()),
                n(k.map(|k| k.shading_invocations)),
                c.pipeline_statistics.map(|p| p.summary()).unwrap_or_else(|| "-".into()),
            );
        }
    }
    let refused: Vec<&Cell> = m.cells.iter().filter(|c| c.refused.is_some()).collect();
    if !refused.is_empty() {
        md.push_str("\nRefused on this device (not timed):\n\n");
        for c in refused {
            let _ = writeln!(md, "- `{}`: {}", c.label, c.refused.as_deref().unwrap_or(""));
        }
    }
    md
}

/// Two matrix reports (two drivers, two machines) cell by cell: each side's GPU ms and ratio to its
/// group's fastest, and B's ms ÷ A's.
pub fn compare_markdown(a: &MatrixReport, b: &MatrixReport) -> String {
    let side = |m: &MatrixReport| format!("{} / {}", m.bench.device, m.bench.driver);
    let mut md = format!(
        "A: {} — B: {}; scene `{}` {}×{} (A) and `{}` {}×{} (B). Ratios: paired per-frame medians with \
         bootstrap 95 % intervals, each within its own run; B ÷ A compares medians of separate runs \
         (different drivers), so it has no paired interval.\n\n\
         | cell | A GPU ms | A × group's fastest | B GPU ms | B × group's fastest | B ÷ A | refused |\n\
         |---|---:|---:|---:|---:|---:|---|\n",
        side(a),
        side(b),
        a.bench.scene,
        a.bench.width,
        a.bench.height,
        b.bench.scene,
        b.bench.width,
        b.bench.height
    );
    let mut labels: Vec<&str> = a.cells.iter().map(|c| c.label.as_str()).collect();
    for c in &b.cells {
        if !labels.contains(&c.label.as_str()) {
            labels.push(&c.label);
        }
    }
    for l in labels {
        let (ca, cb) = (a.cells.iter().find(|c| c.label == l), b.cells.iter().find(|c| c.label == l));
        let ms = |c: Option<&Cell>| c.and_then(|c| c.gpu_ms).map(format_sig).unwrap_or_else(|| "-".into());
        let fast = |c: Option<&Cell>| ratio_cell(c.and_then(|c| c.vs_group_fastest));
        let ratio = match (ca.and_then(|c| c.gpu_ms), cb.and_then(|c| c.gpu_ms)) {
            (Some(x), Some(y)) => format!("{:.3}", y / x),
            _ => "-".into(),
        };
        let refused: Vec<String> = [("A", ca), ("B", cb)]
            .iter()
            .filter_map(|(n, c)| c.and_then(|c| c.refused.as_ref()).map(|r| format!("{n}: {r}")))
            .collect();
        let _ = writeln!(
            md,
            "| `{l}` | {} | {} | {} | {} | {ratio} | {} |",
            ms(ca),
            fast(ca),
            ms(cb),
            fast(cb),
            refused.join("; ")
        );
    }
    md
}

/// Every timed cell's ratio to the first cell with its interval, one row each (log scale), coloured
/// by coverage path.
fn draw<DB: DrawingBackend>(root: DrawingArea<DB, plotters::coord::Shift>, m: &MatrixReport) -> Result<()>
where
    DB::ErrorType: 'static,
{
    root.fill(&WHITE)?;
    let cells: Vec<&Cell> = m.cells.iter().filter(|c| c.vs_baseline.is_some()).collect();
    anyhow::ensure!(!cells.is_empty(), "nothing measured to plot");
    let (lo, hi) = cells
        .iter()
        .filter_map(|c| c.vs_baseline)
        .fold((f64::INFINITY, 0.0f64), |(lo, hi), r| (lo.min(r.low), hi.max(r.high)));
    let b = &m.bench;
    let title = format!(
        "{}: GPU ms ÷ first cell ({}x{}, S = {}, {})",
        b.scene,
        b.width,
        b.height,
        b.results.first().map(|r| r.spp).unwrap_or(0),
        driver_short(&b.driver)
    );
    let n = cells.len();
    let labels: Vec<String> = cells.iter().map(|c| c.label.clone()).collect();
    let mut chart = ChartBuilder::on(&root)
        .caption(title, ("sans-serif", 20))
        .margin(16)
        .x_label_area_size(44)
        .y_label_area_size(300)
        .build_cartesian_2d((lo / 1.2).log10()..(hi * 1.2).log10(), -0.5..n as f64 - 0.5)?;
    chart
        .configure_mesh()
        .x_desc("× first cell, median of paired frame ratios with 95 % interval (log)")
        .label_style(("sans-serif", 13))
        .x_label_formatter(&|v| format_sig(10f64.powf(*v)))
        .y_labels(n)
        .y_label_formatter(&|v| {
            let i = v.round() as usize;
            if (v - i as f64).abs() < 1e-6 && i < labels.len() {
                labels[n - 1 - i].clone()
            } else {
                String::new()
            }
        })
        .draw()?;
    let coverages: Vec<&str> = cells.iter().fold(Vec::new(), |mut v, c| {
        if !v.contains(&c.coverage.as_str()) {
            v.push(c.coverage.as_str());
        }
        v
    });
    for (k, c) in cells.iter().enumerate() {
        let r = c.vs_baseline.expect("filtered");
        let y = (n - 1 - k) as f64;
        let i = coverages.iter().position(|&v| v == c.coverage).unwrap_or(0);
        let color = PALETTE[i % PALETTE.len()];
        chart.draw_series(std::iter::once(ErrorBar::new_horizontal(
            y,
            r.low.log10(),
            r.median.log10(),
            r.high.log10(),
            color.stroke_width(2),
            8,
        )))?;
        chart.draw_series(std::iter::once(Circle::new((r.median.log10(), y), 4, color.filled())))?;
    }
    for (i, name) in coverages.iter().enumerate() {
        let color = PALETTE[i % PALETTE.len()];
        chart
            .draw_series(std::iter::empty::<Circle<(f64, f64), i32>>())?
            .label(format!("coverage {name}"))
            .legend(move |(x, y)| Circle::new((x + 8, y), 4, color.filled()));
    }
    chart
        .configure_series_labels()
        .background_style(WHITE.mix(0.9))
        .border_style(BLACK)
        .label_font(("sans-serif", 14))
        .position(SeriesLabelPosition::UpperRight)
        .draw()?;
    root.present()?;
    Ok(())
}
