//! Small programs that embed Shutter the way a porting engineer would. Each is a function here (so a
//! test runs it) plus a binary in `src/bin/`.

use std::path::Path;

use anyhow::{Context, Result};
use shutter::techniques::{RenderSettings, Renderer, Technique};

/// Loads a scene (built-in name or .toml path), renders it with `technique` at `width × height` with
/// `spp` samples per pixel, writes `out` (.png or .exr) and returns the GPU milliseconds.
pub fn render_to_png(
    scene: &str,
    technique: Technique,
    width: u32,
    height: u32,
    spp: u32,
    out: &Path,
) -> Result<f64> {
    // 1. The scene: camera, lens, shutter, objects with transforms at shutter open and close.
    let scene =
        shutter::scene::file::load_scene(scene).with_context(|| format!("loading scene `{scene}`"))?;
    // 2. A device (SHUTTER_DEVICE picks one by name) and a renderer that owns per-frame state.
    let device = shutter::vk::create_device()?;
    let mut renderer = Renderer::new(device)?;
    // 3. One frame. The output is linear HDR plus per-pass GPU timestamps.
    let settings = RenderSettings::new(width, height, spp, scene.image.seed);
    let output = renderer.render(&scene, technique, &settings)?;
    // 4. sRGB PNG or linear EXR by extension.
    shutter::image_io::save_image(out, &output.image)?;
    Ok(output.timings.total_ms())
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn render_to_png_writes_a_lit_image() {
        std::env::set_var("SHUTTER_VALIDATION", "1");
        let out = std::env::temp_dir().join(format!("shutter-sample-{}.png", std::process::id()));
        render_to_png("default", Technique::ACCUMULATION, 64, 36, 4, &out).expect("sample runs");
        let img = shutter::image_io::load_image(&out).expect("readable");
        let mean: f32 = img.pixels.iter().map(|p| p[0] + p[1] + p[2]).sum::<f32>() / img.pixels.len() as f32;
        assert!(mean > 0.05, "image is black (mean {mean})");
        let _ = std::fs::remove_file(out);
    }
}
