//! `shutter bounds`: what each stochastic bound costs on one scene — sample test efficiency from the
//! instrumented fragment shader (samples hit / samples tested, McGuire et al. 2010's "STE") and GPU
//! milliseconds per frame (median of timed frames after a warm-up frame, uninstrumented), next to
//! `pinhole` and `accumulation` at the same samples per pixel. Prints a markdown table.

use std::path::Path;

use anyhow::{Context, Result};
use plotters::prelude::*;
use shutter::mirror::bounds::BoundKind;
use shutter::plan::Plan;
use shutter::scene::Scene;
use shutter::techniques::{
    BoundChoice, ObjectBoundPolicy, RenderOutput, RenderSettings, Renderer, SampleCounters, ShadingRate,
    StochasticOptions, Technique,
};

use crate::quality::{format_sig, register_font, PALETTE};

/// Accumulation passes per stochastic sample at about equal FLIP against the reference
/// (`scripts/thesis-study.sh`, section 2: stochastic at S = 16 ≈ accumulation at 64 passes on the
/// thesis scene at every focus distance measured; docs/THESIS.md).
pub const EQUAL_QUALITY_PASSES: u32 = 4;

pub struct BoundsTableArgs {
    pub spp: Vec<u32>,
    pub bounds: Vec<BoundChoice>,
    pub shading: ShadingRate,
    pub frames: usize,
    pub warmup: usize,
    pub width: u32,
    pub height: u32,
    pub seed: u64,
    /// One step per timed configuration.
    pub progress: shutter::progress::Progress,
}

fn median(mut v: Vec<f64>) -> f64 {
    v.sort_by(|a, b| a.total_cmp(b));
    if v.is_empty() {
        f64::NAN
    } else {
        v[v.len() / 2]
    }
}

/// Median GPU ms per frame over `frames` frames after `warmup` frames.
fn timed(
    r: &mut Renderer,
    scene: &Scene,
    t: Technique,
    s: &RenderSettings,
    a: &BoundsTableArgs,
) -> Result<f64> {
    shutter::progress::check_interrupt()?;
    let out: Vec<RenderOutput> = r.render_frames(scene, t, s, a.warmup + a.frames)?;
    a.progress.inc(1);
    Ok(median(out.iter().skip(a.warmup).map(|o| o.timings.total_ms()).collect()))
}

/// One measured configuration of [`run`]: samples per pixel, what was rendered, GPU ms, and for the
/// stochastic bounds the sample test efficiency.
pub struct Row {
    pub spp: u32,
    pub label: String,
    pub ms: f64,
    pub ste: Option<f64>,
}

/// [`run`] once per focus distance in `focus` (the scene's camera refocused, nothing else changed): a
/// focus sweep like the thesis' §8 study. Markdown: per focus the full table, then one summary table
/// per S — a row per focus distance, the GPU ms of every configuration and each bound's STE ÷ the box's.
pub fn sweep(
    renderer: &mut Renderer,
    scene: &Scene,
    a: &BoundsTableArgs,
    focus: &[f32],
    plot: Option<&Path>,
) -> Result<String> {
    let (md, all) = sweep_rows(renderer, scene, a, focus)?;
    if let Some(stem) = plot {
        // The report first, so a plot that fails loses no measurement.
        shutter::image_io::write_file_atomically(stem, md.as_bytes())?;
        register_font()?;
        let spp = a.spp[0];
        let title = format!(
            "{}: GPU ms per frame over a focus sweep ({}x{}, S = {spp})",
            scene.name, a.width, a.height
        );
        let (png, svg) = (stem.with_extension("png"), stem.with_extension("svg"));
        crate::quality::draw_png(&png, (960, 640), |area| draw_sweep(area, &title, &all, spp))?;
        draw_sweep(SVGBackend::new(&svg, (960, 640)).into_drawing_area(), &title, &all, spp)
            .with_context(|| format!("drawing {}", svg.display()))?;
        errln!("wrote {} and {}", png.display(), svg.display());
    }
    Ok(md)
}

/// The markdown of [`sweep`] and its rows per focus distance.
#[allow(clippy::type_complexity)]
fn sweep_rows(
    renderer: &mut Renderer,
    scene: &Scene,
    a: &BoundsTableArgs,
    focus: &[f32],
) -> Result<(String, Vec<(f32, Vec<Row>)>)> {
    let mut sections = String::new();
    let mut all: Vec<(f32, Vec<Row>)> = vec![];
    for &f in focus {
        anyhow::ensure!(f.is_finite() && f > 0.0, "focus distance {f}: must be finite and > 0");
        let mut s = scene.clone();
        s.camera.focus_distance = f;
        let (md, rows) = run_rows(renderer, &s, a)?;
        sections.push_str(&format!("### focus distance {f}\n\n{md}\n"));
        all.push((f, rows));
    }
    let mut md = String::new();
    for &spp in &a.spp {
        md.push_str(&summary_table(
            &format!("**S = {spp}: GPU ms per frame** (per focus distance)"),
            &all,
            spp,
            |r, _| Some(format!("{:.1}", r.ms)),
        ));
        md.push_str(&summary_table(&format!("**S = {spp}: STE ÷ the box's STE**"), &all, spp, |r, rows| {
            let ste = r.ste?;
            let bbox = rows.iter().find(|b| b.spp == spp && b.label == "bbox").and_then(|b| b.ste);
            Some(match bbox {
                Some(b) if b > 0.0 => format!("{:.2}", ste / b),
                _ => "–".into(),
            })
        }));
    }
    md.push_str(&sections);
    Ok((md, all))
}

/// The thesis' Fig. 18 for one S: GPU ms per frame (log) against the focus distance, a line per
/// configuration; the stochastic bounds solid, pinhole and accumulation dashed.
fn draw_sweep<DB: DrawingBackend>(
    root: DrawingArea<DB, plotters::coord::Shift>,
    title: &str,
    all: &[(f32, Vec<Row>)],
    spp: u32,
) -> Result<()>
where
    DB::ErrorType: 'static,
{
    root.fill(&WHITE)?;
    let rows = || all.iter().flat_map(|(f, rows)| rows.iter().filter(|r| r.spp == spp).map(move |r| (*f, r)));
    let (mut y0, mut y1) = (f64::INFINITY, 0.0f64);
    for (_, r) in rows() {
        if r.ms > 0.0 {
            y0 = y0.min(r.ms);
            y1 = y1.max(r.ms);
        }
    }
    anyhow::ensure!(y1 > 0.0, "nothing measured to plot");
    let (x0, x1) = all.iter().fold((f32::INFINITY, 0.0f32), |(lo, hi), (f, _)| (lo.min(*f), hi.max(*f)));
    // The legend gets its own column: the lines fill the plot at every height.
    let (plot, legend) = root.split_horizontally(root.dim_in_pixel().0 * 3 / 4);
    let mut chart = ChartBuilder::on(&plot)
        .caption(title, ("sans-serif", 20))
        .margin(16)
        .x_label_area_size(44)
        .y_label_area_size(64)
        .build_cartesian_2d(x0 as f64..x1 as f64, (y0 / 1.3).log10()..(y1 * 1.3).log10())?;
    chart
        .configure_mesh()
        .x_desc("focus distance (scene units)")
        .y_desc("GPU ms per frame (log)")
        .label_style(("sans-serif", 14))
        .y_label_formatter(&|v| format_sig(10f64.powf(*v)))
        .draw()?;
    let labels: Vec<&str> = all
        .first()
        .map(|(_, r)| r.iter().filter(|r| r.spp == spp).map(|r| r.label.as_str()).collect())
        .unwrap_or_default();
    for (i, label) in labels.iter().enumerate() {
        // The quality plot's colours first, then plotters' 99-colour palette.
        let color = if i < PALETTE.len() { PALETTE[i].to_rgba() } else { Palette99::pick(i).to_rgba() };
        let line: Vec<(f64, f64)> = rows()
            .filter(|(_, r)| r.label == *label && r.ms > 0.0)
            .map(|(f, r)| (f as f64, r.ms.log10()))
            .collect();
        let dashed = label.starts_with("accumulation") || *label == "pinhole";
        let style = color.stroke_width(if dashed { 1 } else { 2 });
        if dashed {
            chart.draw_series(DashedLineSeries::new(line.clone(), 6, 4, style))?;
        } else {
            chart.draw_series(LineSeries::new(line.clone(), style))?;
        }
        chart.draw_series(line.iter().map(|&p| Circle::new(p, 3, color.filled())))?;
        let y = 60 + 22 * i as i32;
        legend.draw(&PathElement::new(vec![(8, y), (36, y)], style))?;
        legend.draw(&Text::new(label.to_string(), (44, y - 7), ("sans-serif", 14).into_font()))?;
    }
    root.present()?;
    Ok(())
}

/// One summary table of a sweep under `heading`: a row per focus distance, a column per configuration
/// of S = `spp` for which `cell(row, all rows of that focus)` gives a value.
fn summary_table(
    heading: &str,
    all: &[(f32, Vec<Row>)],
    spp: u32,
    cell: impl Fn(&Row, &[Row]) -> Option<String>,
) -> String {
    let columns: Vec<&str> = all
        .first()
        .map(|(_, rows)| {
            rows.iter()
                .filter(|r| r.spp == spp && cell(r, rows).is_some())
                .map(|r| r.label.as_str())
                .collect()
        })
        .unwrap_or_default();
    let mut md = format!("{heading}\n\n| focus |");
    for c in &columns {
        md.push_str(&format!(" {c} |"));
    }
    md.push_str(&format!("\n|---:|{}\n", "---:|".repeat(columns.len())));
    for (f, rows) in all {
        md.push_str(&format!("| {f} |"));
        for r in rows.iter().filter(|r| r.spp == spp) {
            if let Some(v) = cell(r, rows) {
                md.push_str(&format!(" {v} |"));
            }
        }
        md.push('\n');
    }
    md.push('\n');
    md
}

pub fn run(renderer: &mut Renderer, scene: &Scene, a: &BoundsTableArgs) -> Result<String> {
    Ok(run_rows(renderer, scene, a)?.0)
}

fn run_rows(renderer: &mut Renderer, scene: &Scene, a: &BoundsTableArgs) -> Result<(String, Vec<Row>)> {
    let mut rows = vec![];
    let caps = &renderer.device().caps;
    let mut md = format!(
        "Scene `{}`, {}×{}, shading {}, device {} ({}), median of {} frame(s) after {} warm-up frame(s).\n\n",
        scene.name,
        a.width,
        a.height,
        a.shading.name(),
        caps.device_name,
        caps.driver_info,
        a.frames,
        a.warmup
    );
    md.push_str(&crate::provenance::Provenance::of(caps).markdown());
    md.push('\n');
    md.push_str("| S | technique | bound | GPU ms/frame | fragments | samples tested | samples hit | STE | STE ÷ bbox STE |\n");
    md.push_str("|---:|---|---|---:|---:|---:|---:|---:|---:|\n");
    for &spp in &a.spp {
        let base = RenderSettings::new(a.width, a.height, spp, a.seed);
        let ms = timed(renderer, scene, Technique::PINHOLE, &base, a)?;
        md.push_str(&format!("| {spp} | pinhole (MSAA 4×, no blur) | – | {ms:.1} | | | | | |\n"));
        rows.push(Row { spp, label: "pinhole".into(), ms, ste: None });
        errln!("S={spp} pinhole {ms:.1} ms");
        let ms = timed(renderer, scene, Technique::ACCUMULATION, &base, a)?;
        md.push_str(&format!("| {spp} | accumulation ({spp} passes) | – | {ms:.1} | | | | | |\n"));
        rows.push(Row { spp, label: "accumulation".into(), ms, ste: None });
        errln!("S={spp} accumulation {ms:.1} ms");
        // At equal quality: accumulation needs about 4× the samples for stochastic rasterization's
        // FLIP (the thesis' §9.1 estimate, measured on the thesis scene: docs/THESIS.md).
        let equal = RenderSettings::new(a.width, a.height, EQUAL_QUALITY_PASSES * spp, a.seed);
        let ms = timed(renderer, scene, Technique::ACCUMULATION, &equal, a)?;
        let passes = EQUAL_QUALITY_PASSES * spp;
        md.push_str(&format!(
            "| {spp} | accumulation ({passes} passes, ≈ equal FLIP) | – | {ms:.1} | | | | | |\n"
        ));
        rows.push(Row { spp, label: format!("accumulation ×{EQUAL_QUALITY_PASSES}"), ms, ste: None });
        errln!("S={spp} accumulation {passes} passes {ms:.1} ms");
        let mut bbox_ste = None;
        for &bound in &a.bounds {
            // One bound per triangle: cluster bounds would replace the bound under test.
            let (c, ms, (passes, msaa)) = measure(renderer, scene, &base, bound, a)?;
            let ste = c.sample_test_efficiency();
            if bound == BoundChoice::Kind(BoundKind::BoundingBox) {
                bbox_ste = Some(ste);
            }
            // No sample tested by the box (an empty scene): no ratio, rather than NaN.
            let rel = match bbox_ste {
                Some(b) if b > 0.0 => format!("{:.2}", ste / b),
                Some(_) => "–".into(),
                None => String::new(),
            };
            md.push_str(&format!(
                "| {spp} | stochastic ({passes} × {msaa} MSAA) | {} | {ms:.1} | {} | {} | {} | {ste:.4} | {rel} |\n",
                bound.name(),
                c.fragments,
                c.samples_tested,
                c.samples_hit
            ));
            errln!("S={spp} {} {ms:.1} ms STE {ste:.4}", bound.name());
            rows.push(Row { spp, label: bound.name(), ms, ste: Some(ste) });
        }
    }
    Ok((md, rows))
}

/// One stochastic configuration with `bound`: the counters of an instrumented frame, the median GPU ms
/// of uninstrumented frames, and (passes, MSAA samples). One bound per triangle: cluster bounds would
/// replace the bound under test.
fn measure(
    renderer: &mut Renderer,
    scene: &Scene,
    base: &RenderSettings,
    bound: BoundChoice,
    a: &BoundsTableArgs,
) -> Result<(SampleCounters, f64, (u32, u32))> {
    let opts = StochasticOptions {
        bound,
        shading: a.shading,
        instrumented: true,
        clusters: shutter::techniques::Clusters::Off,
        ..Default::default()
    };
    shutter::progress::check_interrupt()?;
    let counted = renderer.render(scene, Technique::STOCHASTIC, &base.with_stochastic(opts))?;
    let c = counted.stats.counters.expect("instrumented render has counters");
    let settings = base.with_stochastic(StochasticOptions { instrumented: false, ..opts });
    let ms = timed(renderer, scene, Technique::STOCHASTIC, &settings, a)?;
    Ok((c, ms, (counted.stats.passes, counted.stats.msaa_samples)))
}

/// One split of a focus distance's objects: its threshold (px; −1: none sharp), samples tested, GPU ms.
type Split = (f32, u64, f64);

/// The per-object threshold of `sharp`/`blurred` ([`ObjectBoundPolicy`]) measured on a focus sweep.
/// Per focus distance, every object's largest circle of confusion (the plan's) splits the objects in
/// at most n + 1 ways (sharp up to a threshold); each split is rendered, counted and timed. A global
/// threshold picks one split per focus distance, so its sweep totals follow from those rows: the
/// table gives, per candidate threshold (each object radius seen, and "all blurred"), the samples
/// tested and the GPU ms summed over the sweep, first S only.
pub fn per_object_sweep(
    renderer: &mut Renderer,
    scene: &Scene,
    a: &BoundsTableArgs,
    focus: &[f32],
    (sharp, blurred): (BoundKind, BoundKind),
) -> Result<String> {
    let spp = *a.spp.first().ok_or_else(|| anyhow::anyhow!("--spp: need one value"))?;
    let base = RenderSettings::new(a.width, a.height, spp, a.seed);
    // Per focus: the object radii and the splits measured.
    let mut per_focus: Vec<(Vec<f32>, Vec<Split>)> = vec![];
    let mut md = format!(
        "Per-object switching {} (at most the threshold) / {} (above), scene `{}`, {}×{}, S = {spp}, \
         shading {}, device {} ({}), median of {} frame(s) after {} warm-up frame(s).\n\n",
        sharp.name(),
        blurred.name(),
        scene.name,
        a.width,
        a.height,
        a.shading.name(),
        renderer.device().caps.device_name,
        renderer.device().caps.driver_info,
        a.frames,
        a.warmup
    );
    md.push_str(&crate::provenance::Provenance::of(&renderer.device().caps).markdown());
    md.push('\n');
    md.push_str(
        "| focus | objects' largest CoC, px | threshold px | sharp objects | samples tested | GPU ms |\n",
    );
    md.push_str("|---:|---|---:|---:|---:|---:|\n");
    for &f in focus {
        anyhow::ensure!(f.is_finite() && f > 0.0, "focus distance {f}: must be finite and > 0");
        let mut s = scene.clone();
        s.camera.focus_distance = f;
        let radii: Vec<f32> = Plan::new(&s, a.width, a.height)
            .objects
            .iter()
            .filter(|o| o.triangles > 0 && !o.culled)
            .map(|o| o.max_coc_px)
            .collect();
        let mut splits: Vec<f32> = std::iter::once(-1.0).chain(radii.iter().copied()).collect();
        splits.sort_by(|x, y| x.total_cmp(y));
        splits.dedup();
        let shown: Vec<String> = radii.iter().map(|r| format!("{r:.1}")).collect();
        let mut rows = vec![];
        for &t in &splits {
            let policy = ObjectBoundPolicy { sharp, blurred, threshold_px: t };
            let (c, ms, _) = measure(renderer, &s, &base, BoundChoice::PerObject(policy), a)?;
            let n_sharp = radii.iter().filter(|&&r| r <= t).count();
            md.push_str(&format!(
                "| {f} | {} | {} | {n_sharp} | {} | {ms:.1} |\n",
                shown.join(", "),
                if t < 0.0 { "–".to_string() } else { format!("{t:.3}") },
                c.samples_tested
            ));
            errln!("focus {f} threshold {t:.2}: {n_sharp} sharp, {} tested, {ms:.1} ms", c.samples_tested);
            rows.push((t, c.samples_tested, ms));
        }
        per_focus.push((radii, rows));
    }
    let mut candidates: Vec<f32> = per_focus.iter().flat_map(|(r, _)| r.iter().copied()).collect();
    candidates.push(-1.0);
    candidates.sort_by(|x, y| x.total_cmp(y));
    candidates.dedup();
    let totals: Vec<(f32, u64, f64)> = candidates
        .iter()
        .map(|&g| {
            let (mut tested, mut ms) = (0u64, 0.0f64);
            for (_, rows) in &per_focus {
                // This focus distance's split for threshold g: the largest split threshold ≤ g.
                let row = rows.iter().rev().find(|r| r.0 <= g).expect("the -1 split is ≤ every g");
                tested += row.1;
                ms += row.2;
            }
            (g, tested, ms)
        })
        .collect();
    let best_tested = totals.iter().min_by_key(|t| t.1).expect("non-empty");
    let best_ms = totals.iter().min_by(|x, y| x.2.total_cmp(&y.2)).expect("non-empty");
    let mut summary = format!(
        "**Sweep totals per global threshold** (an object draws {} when its largest CoC ≤ the threshold):\n\n\
         | threshold px | samples tested (sweep) | ÷ all {} | GPU ms (sweep) | ÷ all {} |\n|---:|---:|---:|---:|---:|\n",
        sharp.name(),
        blurred.name(),
        blurred.name()
    );
    let (all_blurred_tested, all_blurred_ms) = (totals[0].1, totals[0].2);
    // Rows: all blurred, a power-of-two grid of thresholds (each the largest object radius at most
    // that), all sharp, and the two best; every candidate counted in the minima.
    let mut shown: Vec<usize> = vec![0, totals.len() - 1];
    for grid in [0.25f32, 0.5, 1.0, 2.0, 4.0, 8.0, 16.0, 32.0] {
        shown.extend(totals.iter().rposition(|t| t.0 <= grid));
    }
    let best_tested_at = totals.iter().position(|t| t.1 == best_tested.1).expect("present");
    let best_ms_at = totals.iter().position(|t| t.2.total_cmp(&best_ms.2).is_eq()).expect("present");
    shown.extend([best_tested_at, best_ms_at]);
    shown.sort_unstable();
    shown.dedup();
    for (g, tested, ms) in shown.iter().map(|&i| &totals[i]) {
        let label = if *g < 0.0 {
            format!("– (all {})", blurred.name())
        } else if g.to_bits() == totals[totals.len() - 1].0.to_bits() {
            format!("{g:.3} (all {})", sharp.name())
        } else {
            format!("{g:.3}")
        };
        summary.push_str(&format!(
            "| {label} | {tested} | {:.3} | {ms:.1} | {:.3} |\n",
            *tested as f64 / all_blurred_tested.max(1) as f64,
            ms / all_blurred_ms
        ));
    }
    let at = |g: f32| {
        if g < 0.0 {
            format!("no threshold (all {})", blurred.name())
        } else {
            format!("{g:.3} px")
        }
    };
    summary.push_str(&format!(
        "\n{} candidate thresholds (every object radius of the sweep). Fewest samples tested at {}; least \
         GPU time at {} (any threshold from that radius up to the next object radius picks the same \
         objects).\n\n",
        totals.len(),
        at(best_tested.0),
        at(best_ms.0)
    ));
    Ok(summary + &md)
}
