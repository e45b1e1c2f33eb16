//! `shutter render`: one frame of a scene with a technique (or `auto`'s quality planner), written
//! as an image, with the frame's report.

use anyhow::{bail, Context, Result};
use clap::Args;
use shutter::quality_plan::{QualityPlan, QualityTarget};
use shutter::techniques::{RenderSettings, Renderer, Technique};

use shutter::image_io::{check_image_output, save_image_displayed};

use crate::{
    create_device, default_out, load_scene, quality_target, technique_names, DisplayArgs, ImageArgs,
};

/// Render a scene on the GPU.
#[derive(Args)]
pub struct RenderArgs {
    /// A built-in scene name or a path to a .toml scene file.
    #[arg(default_value = "default")]
    pub scene: String,
    /// The technique (`shutter techniques` lists them). `auto` simulates per object only the
    /// effects the scene calls for (see `shutter plan`).
    #[arg(long, default_value = "auto", value_parser = technique_names())]
    pub technique: String,
    /// Samples per pixel S (accumulation: passes; stochastic: MSAA samples × passes). Default: the
    /// scene's [image] spp; for `auto`, the samples the quality target needs (--quality).
    #[arg(long)]
    pub spp: Option<u32>,
    /// `auto` without --spp: draft, good (the default) or final — a mean FLIP against the ground
    /// truth of 0.04, 0.018 or 0.01. A pilot measures the scene's noise and the cost model
    /// (`shutter calibrate`) the techniques' cost; the planner takes the technique and S that
    /// reach it in the least predicted time (docs/QUALITY.md, "Quality targets").
    #[arg(long, conflicts_with_all = ["spp", "target_flip"])]
    pub quality: Option<String>,
    /// `auto` without --spp: a mean FLIP target in (0, 1) instead of --quality's names.
    #[arg(long, conflicts_with = "spp")]
    pub target_flip: Option<f32>,
    /// Stochastic bound: device (the one calibrated fastest on the device, `shutter probe` says
    /// which), bbox, 2d-hexagon, parallel-edge-triangle, variable-radius-triangle, 3d-hexagon,
    /// wedge, reduced-wedge, convex-hull, adaptive, or per-object[/SHARP/BLURRED/PX] (a kind per
    /// object from its blur, the thesis §4.7). The image does not depend on it.
    #[arg(long, default_value = "device")]
    pub bound: String,
    /// Stochastic shading rate: per-sample (the default: every sample shaded, unbiased) |
    /// per-pixel (a pixel's samples of one triangle shaded once: ~10 % cheaper, with an error
    /// floor; docs/HARD_CASES.md) | texture-space (adaptive texture-space
    /// shading: each object shaded once into a mip atlas at a level per triangle, looked up per
    /// sample; docs/ATSS.md) | texture-space-per-pixel | decoupled | aas | aas-isotropic (decoupled
    /// shading on the pixel grid or the AAS grids, memoization cache of --cache entries) |
    /// decoupled-deferred | aas-deferred | aas-isotropic-deferred (the same keys in a hash table
    /// of --cache entries, new points shaded by a dispatch of their own; docs/DECOUPLED.md).
    #[arg(long, default_value = "per-sample")]
    pub shading: String,
    /// Stochastic: count samples tested / hit and shading invocations (atomics; slower).
    #[arg(long)]
    pub instrumented: bool,
    /// Stochastic: force M samples per pixel and pass (S = M × passes; M must divide S). Default:
    /// all S in one pass where the visibility buffer fits 256 MiB and the device's largest storage buffer.
    #[arg(long)]
    pub per_pass: Option<u32>,
    /// Stochastic: expand the bounds in a geometry shader (gs), a compute pass (compute), a mesh
    /// shader (mesh; needs VK_EXT_mesh_shader) or a mesh shader behind a task shader that culls
    /// off-image and back-facing triangles (mesh-task; needs its taskShader).
    #[arg(long, default_value = "gs")]
    pub hull: String,
    /// Stochastic: interval bounds — split each moving object's samples into K runs of shutter
    /// time, each bounded over its own sub-interval (`auto`: per object from its motion and blur;
    /// 1: off).
    #[arg(long, default_value = "auto")]
    pub intervals: String,
    /// Cluster bounds (stochastic/auto): `auto` (per object: dense meshes whose triangles are small
    /// next to their blur), `off` (one bound per triangle), or N triangles per cluster for every
    /// object.
    #[arg(long, default_value = "auto")]
    pub clusters: String,
    /// Stochastic `--shading decoupled`, `aas`…: entries of the memoization cache, or with
    /// `…-deferred` of the hash table (1 to 4194304).
    #[arg(long, default_value_t = shutter::techniques::stochastic::DEFAULT_CACHE_ENTRIES)]
    pub cache: u32,
    /// How alpha < 1, alpha_from_texture and tints are rendered: `stochastic` (stochastic
    /// transparency, stratified per-pixel masks over the S = MSAA × passes samples, tints
    /// multiplied into the uncovered samples; every technique); pinhole and accumulation only:
    /// `stochastic/corrected` (with Enderton's alpha correction: the transparent samples' share
    /// rescaled to the exact total alpha, the exact transmittance behind), `depth-based`
    /// (depth-based stochastic transparency: the masks write depth only, every fragment adds
    /// vis(z)·α·C, alpha-corrected), `depth-based/uncorrected`, `peeling/K` (depth peeling of K
    /// layers, default 8: exact up to K layers). Used only when the scene has transparency.
    #[arg(long, default_value = "stochastic")]
    pub transparency: String,
    /// Shadow maps of lights with `shadows = true` (pinhole, accumulation, auto without blur):
    /// SIZE[/SAMPLES[/PCF]] — texels per side of each map (a point light has six), depth samples
    /// per texel of a stochastic map (casters with alpha < 1 or tints; opaque casters get one),
    /// and the PCF radius in texels (docs/SHADOWS.md).
    #[arg(long, default_value = "1024/4/1")]
    pub shadow_map: String,
    /// Further settings, KEY=VALUE, repeatable, applied after the flags above (which are keys of
    /// the same grammar): every key `shutter techniques` lists, as `bench -c` and `quality -s`
    /// take them; e.g. for technique `interleaved` vpls=N, pattern=NxM, vpl-maps=SIZE|off
    /// (docs/INTERLEAVED.md).
    #[arg(long = "set", value_name = "KEY=VALUE")]
    pub set: Vec<String>,
    #[command(flatten)]
    pub image: ImageArgs,
    #[command(flatten)]
    pub display: DisplayArgs,
}

pub fn run(args: RenderArgs) -> Result<()> {
    let RenderArgs {
        scene,
        technique,
        spp,
        quality,
        target_flip,
        bound,
        shading,
        instrumented,
        per_pass,
        hull,
        intervals,
        clusters,
        cache,
        transparency,
        shadow_map,
        set,
        image: ImageArgs { size, seed, out },
        display,
    } = args;
    let mut technique: Technique = technique.parse()?;
    let target = quality_target(quality.as_deref(), target_flip)?;
    if target.is_some() && technique != Technique::AUTO {
        bail!("--quality and --target-flip choose the technique and S of `auto`; `{technique}` takes --spp");
    }
    let sc = load_scene(&scene)?;
    // The flags are settings keys like --set's (one grammar: RenderSettings::set).
    let mut settings = RenderSettings::from_scene(&sc);
    let flags = [
        ("bound", bound),
        ("shading", shading),
        ("hull", hull),
        ("intervals", intervals),
        ("clusters", clusters),
        ("cache", cache.to_string()),
        ("transparency", transparency),
        ("shadow-map", shadow_map),
    ];
    for (key, value) in flags.iter().chain(&per_pass.map(|p| ("per-pass", p.to_string()))) {
        settings.set(key, value).with_context(|| format!("--{key}"))?;
    }
    settings.stochastic.instrumented = instrumented;
    if sc.environment.indirect != shutter::scene::Indirect::None && technique != Technique::INTERLEAVED {
        errln!(
            "note: `{}` renders direct light only; the scene's indirect light (`{}`) is rendered by technique `interleaved` and the reference",
            technique.name(),
            sc.environment.indirect.name()
        );
    }
    settings.set_all(set.iter().map(String::as_str)).context("--set")?;
    if let Some((w, h)) = size {
        (settings.width, settings.height) = (w, h);
    }
    if let Some(s) = spp {
        settings.spp = s;
    }
    if let Some(s) = seed {
        settings.seed = s;
    }
    // Before any rendering: a bad output path fails now, not after minutes of work.
    let out = match out {
        Some(o) => o,
        None => default_out(&scene, technique.name(), "png")?,
    };
    check_image_output(&out)?;
    let device = create_device()?;
    let device_name = device.caps.device_name.clone();
    let mut renderer = Renderer::new(device)?;
    renderer.show_progress(true);
    // `auto` without --spp: the quality planner picks the technique and S.
    let mut promise = None;
    if technique == Technique::AUTO && spp.is_none() {
        let target = target.unwrap_or(QualityTarget::Good);
        let qp = QualityPlan::plan_and_apply(&mut renderer, &sc, &mut technique, &mut settings, target)?;
        outln!("auto: {}", qp.summary());
        promise = Some(qp.promise());
    }
    let output = renderer.render(&sc, technique, &settings)?;
    shutter::progress::check_interrupt()?;
    save_image_displayed(&out, &output.image, &display.over(sc.image.display))?;
    for line in output.report(&sc, technique, &settings, &device_name) {
        outln!("{line}");
    }
    if let Some(p) = &promise {
        outln!("  quality: {p}");
    }
    outln!("wrote {}", out.display());
    Ok(())
}
