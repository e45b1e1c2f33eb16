//! `shutter bounds`.

use anyhow::Result;
use clap::Args;

use crate::*;

/// Sample test efficiency and GPU ms of every stochastic bound on a scene, next to pinhole and
/// accumulation at the same samples per pixel (markdown table on stdout).
#[derive(Args)]
pub struct BoundsArgs {
    #[arg(default_value = "default")]
    pub scene: String,
    /// Samples per pixel, comma-separated.
    #[arg(long, value_delimiter = ',', default_value = "4,16")]
    pub spp: Vec<u32>,
    /// Bounds, comma-separated (default: every kind); `per-object[/SHARP/BLURRED/PX]` too.
    #[arg(long, value_delimiter = ',')]
    pub bounds: Vec<String>,
    /// per-pixel | per-sample
    #[arg(long, default_value = "per-pixel")]
    pub shading: String,
    /// Timed frames per configuration; the median is reported.
    #[arg(long, default_value_t = 3)]
    pub frames: usize,
    /// Untimed frames first (lavapipe compiles shaders lazily, on the first frame: about 1 s).
    #[arg(long, default_value_t = 1)]
    pub warmup: usize,
    /// A focus sweep: the table once per focus distance (comma-separated), the camera refocused,
    /// with summary tables of ms and STE per focus distance (the thesis' §8 study); with --out
    /// X.md also the plot of ms against focus distance (first --spp) as X.png and X.svg.
    #[arg(long, value_delimiter = ',')]
    pub focus: Vec<f32>,
    /// With --focus: measure the per-object threshold of SHARP/BLURRED (e.g.
    /// reduced-wedge/3d-hexagon) instead of the bounds table — every split of the objects by
    /// their blur, per focus distance, and the sweep totals per threshold (first --spp only).
    #[arg(long)]
    pub per_object: Option<String>,
    #[command(flatten)]
    pub image: ImageArgs,
}

pub fn run(args: BoundsArgs) -> Result<()> {
    let BoundsArgs {
        scene,
        spp,
        bounds,
        shading,
        frames,
        warmup,
        focus,
        per_object,
        image: ImageArgs { size, seed, out },
    } = args;
    if let Some(out) = &out {
        // The table is markdown; the focus sweep's plot goes beside it as .png and .svg.
        if !out.extension().is_some_and(|e| e.eq_ignore_ascii_case("md")) {
            anyhow::bail!(
                "--out {}: `bounds` writes a markdown table, give a .md path (with --focus the plot \
                 goes beside it as .png and .svg)",
                out.display()
            );
        }
    }
    let sc = load_scene(&scene)?;
    let (width, height) = size.unwrap_or((sc.image.width, sc.image.height));
    let bounds = if bounds.is_empty() {
        shutter::mirror::bounds::BoundKind::ALL.iter().map(|&k| k.into()).collect()
    } else {
        bounds.iter().map(|b| b.parse()).collect::<shutter::Result<Vec<_>>>()?
    };
    // Timed configurations: per S pinhole, accumulation twice and every bound, per focus
    // distance; the per-object sweep times at most one split per object and one more.
    let steps = if per_object.is_some() {
        focus.len() * (sc.objects.len() + 1)
    } else {
        spp.len() * (3 + bounds.len()) * focus.len().max(1)
    };
    let progress = shutter::progress::Progress::new("bounds", steps as u64, "configurations");
    let args = bounds_table::BoundsTableArgs {
        progress,
        spp,
        bounds,
        shading: shading.parse()?,
        frames: frames.max(1),
        warmup,
        width,
        height,
        seed: seed.unwrap_or(sc.image.seed),
    };
    if let Some(out) = &out {
        check_output_file(out)?;
    }
    let mut renderer = Renderer::new(create_device()?)?;
    let md = if let Some(pair) = per_object {
        anyhow::ensure!(!focus.is_empty(), "--per-object needs --focus");
        let (sharp, blurred) =
            pair.split_once('/').ok_or_else(|| anyhow::anyhow!("--per-object {pair}: want SHARP/BLURRED"))?;
        bounds_table::per_object_sweep(&mut renderer, &sc, &args, &focus, (sharp.parse()?, blurred.parse()?))?
    } else if focus.is_empty() {
        bounds_table::run(&mut renderer, &sc, &args)?
    } else {
        bounds_table::sweep(&mut renderer, &sc, &args, &focus, out.as_deref())?
    };
    outln!("{md}");
    if let Some(out) = out {
        write_file_atomically(&out, md.as_bytes())?;
        errln!("wrote {}", out.display());
    }
    Ok(())
}
