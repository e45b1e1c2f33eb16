//! `shutter plan`.

use anyhow::Result;
use clap::Args;

use crate::*;

/// Print the effect planner's decision per object (technique `auto`) with the numbers behind it.
#[derive(Args)]
pub struct PlanArgs {
    #[arg(default_value = "default")]
    pub scene: String,
    /// Image size WxH. Default: the scene's [image] size.
    #[arg(long, value_parser = parse_size)]
    pub size: Option<(u32, u32)>,
    /// Blur (pixels, ≥ 0) below which an effect is not simulated.
    #[arg(long, default_value_t = shutter::plan::DEFAULT_THRESHOLD_PX, value_parser = parse_threshold)]
    pub threshold: f32,
    /// Also print what `--shading texture-space` gives each object: its shading space (own uvs or
    /// generated charts, and why), its fitted atlas and its memory, the triangles pass 1 culls, the
    /// texels it shades and how many times each (several where the object turns within the shutter).
    #[arg(long)]
    pub atlases: bool,
    /// Also run the quality planner for this target (draft, good, final): the pilot renders on
    /// the GPU, then every candidate technique with its S, predicted ms and FLIP.
    #[arg(long, conflicts_with = "target_flip")]
    pub quality: Option<String>,
    /// The quality planner for a mean FLIP target in (0, 1).
    #[arg(long)]
    pub target_flip: Option<f32>,
}

pub fn run(args: PlanArgs) -> Result<()> {
    let PlanArgs { scene, size, threshold, atlases, quality, target_flip } = args;
    let sc = load_scene(&scene)?;
    let (w, h) = size.unwrap_or((sc.image.width, sc.image.height));
    outln!("# plan of `{}`\n", sc.name);
    let t0 = std::time::Instant::now();
    let plan = shutter::plan::Plan::with_threshold(&sc, w, h, threshold);
    let ms = t0.elapsed().as_secs_f64() * 1e3;
    outln!(
        "{plan}\n\nplanned in {ms:.3} ms on the CPU ({} vertices)",
        sc.objects.iter().map(|o| o.mesh.positions.len()).sum::<usize>()
    );
    if atlases {
        print_atlas_plan(&sc, w, h)?;
    }
    if let Some(target) = quality_target(quality.as_deref(), target_flip)? {
        let mut renderer = Renderer::new(create_device()?)?;
        let cost = CostModel::load(&renderer.device().caps, (w, h))?;
        let mut settings = RenderSettings::from_scene(&sc);
        (settings.width, settings.height) = (w, h);
        let qp = shutter::quality_plan::plan_quality(&mut renderer, &sc, &settings, target, &cost)?;
        outln!(
            "
{}",
            qp.summary()
        );
        if !qp.candidates.is_empty() {
            outln!(
                "
| candidate | S | shadow maps | predicted GPU ms | predicted FLIP (range) | noise | bias | bias from |\n|---|---:|---:|---:|---|---:|---:|---|"
            );
            for c in &qp.candidates {
                outln!(
                    "| {} | {} | {} | {:.1} | {:.4} ({:.4}–{:.4}) | {:.4} | {:.4} | {} |",
                    c.technique,
                    c.spp,
                    c.shadow_map.map_or("-".to_string(), |s| format!("{s}²")),
                    c.predicted_ms,
                    c.predicted_flip,
                    c.flip_low,
                    c.flip_high,
                    c.noise_flip,
                    c.bias_flip,
                    c.bias
                );
            }
        }
    }
    Ok(())
}
