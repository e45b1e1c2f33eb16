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

pub fn run(renderer: &mut Renderer, scene: &Scene, a: &BoundsTableArgs) -> Result<String> {
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
        eprintln!("S={spp} pinhole {ms:.1} ms");
        let ms = timed(renderer, scene, Technique::ACCUMULATION, &base, a)?;
        md.push_str(&format!("| {spp} | accumulation ({spp} passes) | – | {ms:.1} | | | | | |\n"));
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
        }
    }
    Ok(md)
}
