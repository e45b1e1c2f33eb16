//! Small programs that embed Shutter the way a porting engineer would. Each is a function here (so a
//! test runs it) plus a binary in `src/bin/`.

use std::path::Path;
use std::sync::Arc;

use anyhow::{Context, Result};
use shutter::prelude::{Camera, Light, Mat4, Material, Object, Scene, Vec3};
use shutter::techniques::{RenderSettings, Renderer, Technique};

mod embed_existing_device;
pub use embed_existing_device::{embed_existing_device, EmbeddedFrame};

/// The scene the embedding sample renders, built in code: a ball sliding across a 50 mm f/2 lens'
/// plane of focus in front of a box behind it (out of focus), on a ground plane, lit by the sun,
/// seen through a 180° shutter, 160 × 90 at 16 samples per pixel.
pub fn embedding_scene() -> shutter::Result<Scene> {
    let mesh = |name: &str| -> shutter::Result<Arc<shutter::scene::Mesh>> {
        Ok(Arc::new(shutter::scene::builtin::builtin_mesh(name, None).expect("a built-in mesh")?))
    };
    let camera = Camera::looking_at(Vec3::new(0.0, 1.0, 5.0), Vec3::new(0.0, 0.5, 0.0))
        .with_lens(50.0, 2.0, shutter::scene::builder::FULL_FRAME_HEIGHT_MM)
        .with_focus_distance(5.0);
    Scene::new("embedding", camera)
        .with_image(160, 90, 16, 7)
        .with_object(
            Object::new("ground", mesh("plane")?, Mat4::from_scale(Vec3::splat(6.0)))
                .with_material(Material::diffuse(Vec3::splat(0.6))),
        )
        .with_object(
            Object::new(
                "ball",
                mesh("sphere")?,
                Mat4::from_translation(Vec3::new(-0.8, 0.5, 0.0)) * Mat4::from_scale(Vec3::splat(0.5)),
            )
            .moving_to(Mat4::from_translation(Vec3::new(0.8, 0.5, 0.0)) * Mat4::from_scale(Vec3::splat(0.5)))
            .with_material(Material::diffuse(Vec3::new(0.8, 0.25, 0.2))),
        )
        .with_object(
            Object::new(
                "box",
                mesh("box")?,
                Mat4::from_translation(Vec3::new(1.2, 0.5, -4.0)) * Mat4::from_scale(Vec3::splat(0.5)),
            )
            .with_material(Material {
                specular: 0.3,
                roughness: 0.3,
                ..Material::diffuse(Vec3::new(0.2, 0.4, 0.8))
            }),
        )
        .with_light(Light::Directional {
            direction: Vec3::new(-0.5, -1.0, -0.4).normalize(),
            color: Vec3::splat(2.5),
            shadows: false,
        })
        .with_shutter_angle(180.0)
}

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

    /// The engine's own device, command buffer and image give the very image Shutter's own render
    /// (the CLI's path: `Renderer::render` on the device `SHUTTER_DRIVER` names) gives of the same
    /// scene, with validation on and no readback in Shutter's frame.
    #[test]
    fn embed_existing_device_matches_shutters_own_render() {
        std::env::set_var("SHUTTER_VALIDATION", "1");
        let scene = embedding_scene().expect("the sample scene builds");
        scene.validate().expect("and is valid");
        let embedded = embed_existing_device(&scene).expect("sample runs");
        for pass in ["stochastic coverage", "stochastic shading", "copy to the caller's image"] {
            assert!(embedded.passes.iter().any(|p| p == pass), "no `{pass}` in {:?}", embedded.passes);
        }
        for pass in ["readback", "host read"] {
            assert!(
                !embedded.passes.iter().any(|p| p == pass),
                "`{pass}` in Shutter's frame: {:?}",
                embedded.passes
            );
        }

        let device = shutter::vk::create_device().expect("Shutter's own device");
        assert!(device.validation_enabled, "validation layer missing: install vulkan-validationlayers");
        let mut renderer = Renderer::new(device).expect("renderer");
        let own = renderer
            .render(&scene, Technique::STOCHASTIC, &RenderSettings::from_scene(&scene))
            .expect("Shutter's own render");
        assert_eq!(embedded.driver, renderer.device().caps.driver_key, "both renders on one driver");
        assert_eq!((embedded.image.width, embedded.image.height), (own.image.width, own.image.height));
        // Unclamped RMSE over RGBA, and the largest difference.
        let (mut sum, mut max) = (0f64, 0f32);
        for (a, b) in embedded.image.pixels.iter().zip(&own.image.pixels) {
            for c in 0..4 {
                let d = a[c] - b[c];
                sum += (d as f64) * (d as f64);
                max = max.max(d.abs());
            }
        }
        let rmse = (sum / (own.image.pixels.len() * 4) as f64).sqrt();
        let mean: f32 =
            own.image.pixels.iter().map(|p| p[0] + p[1] + p[2]).sum::<f32>() / own.image.pixels.len() as f32;
        eprintln!(
            "embed_existing_device vs Shutter's own render on {}: RMSE {rmse:e}, max |difference| {max:e}, \
             mean {mean}",
            embedded.driver
        );
        assert!(mean > 0.05, "image is black (mean {mean})");
        assert!(rmse <= 1e-6, "RMSE {rmse:e} (max |difference| {max:e})");
    }

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
