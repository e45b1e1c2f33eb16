//! `shutter bounds`: what each stochastic bound costs on one scene — sample test efficiency from the
//! instrumented fragment shader (samples hit / samples tested, McGuire et al. 2010's "STE") and GPU
//! milliseconds per frame (median of timed frames after a warm-up frame, uninstrumented), next to
//! `pinhole` and `accumulation` at the same samples per pixel. Prints a markdown table.

use anyhow::Result;
use shutter::bounds::BoundKind;
use shutter::scene::Scene;
use shutter::techniques::{
    RenderOutput, RenderSettings, Renderer, ShadingRate, StochasticOptions, Technique,
};

pub struct BoundsTableArgs {
    pub spp: Vec<u32>,
    pub bounds: Vec<BoundKind>,
    pub shading: ShadingRate,
    pub frames: usize,
    pub warmup: usize,
    pub width: u32,
    pub height: u32,
    pub seed: u64,
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
    let out: Vec<RenderOutput> = r.render_frames(scene, t, s, a.warmup + a.frames)?;
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
pub fn sweep(renderer: &mut Renderer, scene: &Scene, a: &BoundsTableArgs, focus: &[f32]) -> Result<String> {
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
    Ok(md)
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
    md.push_str("| S | technique | bound | GPU ms/frame | fragments | samples tested | samples hit | STE | STE ÷ bbox STE |\n");
    md.push_str("|---:|---|---|---:|---:|---:|---:|---:|---:|\n");
    for &spp in &a.spp {
        let base = RenderSettings::new(a.width, a.height, spp, a.seed);
        let ms = timed(renderer, scene, Technique::PINHOLE, &base, a)?;
        md.push_str(&format!("| {spp} | pinhole (MSAA 4×, no blur) | – | {ms:.1} | | | | | |\n"));
        rows.push(Row { spp, label: "pinhole".into(), ms, ste: None });
        eprintln!("S={spp} pinhole {ms:.1} ms");
        let ms = timed(renderer, scene, Technique::ACCUMULATION, &base, a)?;
        md.push_str(&format!("| {spp} | accumulation ({spp} passes) | – | {ms:.1} | | | | | |\n"));
        rows.push(Row { spp, label: "accumulation".into(), ms, ste: None });
        eprintln!("S={spp} accumulation {ms:.1} ms");
        let mut bbox_ste = None;
        for &bound in &a.bounds {
            // One bound per triangle: cluster bounds would replace the bound under test.
            let opts = StochasticOptions {
                bound: bound.into(),
                shading: a.shading,
                instrumented: true,
                clusters: shutter::techniques::Clusters::Off,
                ..Default::default()
            };
            let counted = renderer.render(scene, Technique::STOCHASTIC, &base.with_stochastic(opts))?;
            let c = counted.stats.counters.expect("instrumented render has counters");
            let ste = c.sample_test_efficiency();
            if bound == BoundKind::BoundingBox {
                bbox_ste = Some(ste);
            }
            let settings = base.with_stochastic(StochasticOptions { instrumented: false, ..opts });
            let ms = timed(renderer, scene, Technique::STOCHASTIC, &settings, a)?;
            let rel = bbox_ste.map(|b| format!("{:.2}", ste / b)).unwrap_or_default();
            md.push_str(&format!(
                "| {spp} | stochastic ({} × {} MSAA) | {} | {ms:.1} | {} | {} | {} | {ste:.4} | {rel} |\n",
                counted.stats.passes,
                counted.stats.msaa_samples,
                bound.name(),
                c.fragments,
                c.samples_tested,
                c.samples_hit
            ));
            eprintln!("S={spp} {} {ms:.1} ms STE {ste:.4}", bound.name());
            rows.push(Row { spp, label: bound.name().into(), ms, ste: Some(ste) });
        }
    }
    Ok((md, rows))
}
