//! Small programs that embed Shutter the way a porting engineer would: one file per technique,
//! readable top to bottom, each a function here (so a test runs it and checks it against Shutter's
//! CPU reference) plus a binary in `src/bin/` that writes its image (`samples/README.md`).
//!
//! A reading order:
//!
//! 1. [`render_to_png`]: load a scene, make a device and a renderer, render one frame, save it.
//! 2. [`motion_blur_defocus`]: a scene built in code (an 85 mm f/1.4 lens, a 180° shutter, one mover,
//!    one object out of focus) rendered by the stochastic rasterizer, `Technique::STOCHASTIC`.
//! 3. [`stochastic_transparency`]: a tinted, partly covering pane in the same frame as the blur.
//! 4. [`shadow_maps`]: a shadow-casting sun and the `shadow-map` setting.
//! 5. [`texture_space_shading`]: `shading=texture-space`, shading once per frame into atlases.
//! 6. [`decoupled_shading`]: `shading=decoupled` and its memoization `cache`.
//! 7. [`interleaved_shading`]: `Technique::INTERLEAVED`, one bounce of indirect light.
//! 8. [`embed_existing_device`]: the engine's own device, command buffer and image.

use std::path::Path;
use std::sync::Arc;

use anyhow::{Context, Result};
use shutter::prelude::{Camera, Feature, Light, Mat4, Material, Mesh, Object, Scene, Vec3};
use shutter::techniques::{RenderOutput, RenderSettings, Renderer, Technique};

mod decoupled_shading;
mod embed_existing_device;
mod interleaved_shading;
mod motion_blur_defocus;
mod shadow_maps;
mod stochastic_transparency;
mod texture_space_shading;
pub use decoupled_shading::{decoupled_shading, decoupled_shading_scene};
pub use embed_existing_device::{embed_existing_device, EmbeddedFrame};
pub use interleaved_shading::{interleaved_shading, interleaved_shading_scene};
pub use motion_blur_defocus::{motion_blur_defocus, motion_blur_defocus_scene};
pub use shadow_maps::{shadow_maps, shadow_maps_scene};
pub use stochastic_transparency::{stochastic_transparency, stochastic_transparency_scene};
pub use texture_space_shading::{texture_space_shading, texture_space_shading_scene};

/// What a technique sample rendered: the scene, how, and the frame (linear HDR, with its passes'
/// GPU times), so that a caller can save it and a test can render the same scene another way.
pub struct Sample {
    pub scene: Scene,
    pub technique: Technique,
    pub settings: RenderSettings,
    pub output: RenderOutput,
}

impl Sample {
    /// Writes the image (sRGB PNG or linear EXR by the extension of `out`).
    pub fn save(&self, out: &Path) -> Result<()> {
        shutter::image_io::save_image(out, &self.output.image)
            .with_context(|| format!("writing {}", out.display()))?;
        Ok(())
    }
}

/// A renderer on the device `SHUTTER_DEVICE` names (the first one otherwise); `SHUTTER_VALIDATION=1`
/// turns the validation layer on, and its messages into errors.
pub fn renderer() -> Result<Renderer> {
    let device = shutter::vk::create_device().context("creating a Vulkan device")?;
    Ok(Renderer::new(device)?)
}

/// A built-in procedural mesh: `plane` (2 × 2 in XZ, facing +Y), `box` (2 × 2 × 2), `sphere`
/// (radius 1), all centred on the origin.
pub fn mesh(name: &str) -> shutter::Result<Arc<Mesh>> {
    let mesh = shutter::scene::builtin::builtin_mesh(name, None)
        .unwrap_or_else(|| panic!("`{name}` is not a built-in mesh"))?;
    Ok(Arc::new(mesh))
}

/// Settings for `Technique::STOCHASTIC` on `renderer`'s device, after checking what the technique
/// needs. Its visibility buffer keeps the nearest hit of every sample with a 64-bit `atomicMax` from
/// the fragment stage, so fragment stores and 64-bit buffer atomics are required (there is no
/// fallback: `Technique::ACCUMULATION` renders the same effects without them). Each triangle is
/// expanded to its bound over lens and shutter by a geometry shader by default; without one the
/// compute expansion (`hull=compute`) does the same work.
pub fn stochastic_settings(renderer: &Renderer, scene: &Scene) -> Result<RenderSettings> {
    let caps = &renderer.device().caps;
    caps.require(Feature::FragmentStoresAndAtomics, "technique `stochastic`'s visibility buffer")?;
    caps.require(Feature::BufferInt64Atomics, "technique `stochastic`'s visibility buffer")?;
    let mut settings = RenderSettings::from_scene(scene);
    if !caps.has(Feature::GeometryShader) {
        settings.set("hull", "compute")?;
    }
    Ok(settings)
}

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

/// What the samples' tests share: a renderer with validation on, the CPU reference of a sample's
/// scene, and image measures.
#[cfg(test)]
pub(crate) mod check {
    use shutter::image::LinearImage;
    use shutter::reference::{render_reference, ReferenceSettings, ReferenceShading};
    use shutter::techniques::Renderer;

    use crate::Sample;

    /// A renderer with the validation layer on (its messages fail the render).
    pub fn renderer() -> Renderer {
        std::env::set_var("SHUTTER_VALIDATION", "1");
        let r = crate::renderer().expect("a device and a renderer");
        assert!(r.device().validation_enabled, "validation layer missing: install vulkan-validationlayers");
        r
    }

    /// The CPU reference of `sample`'s scene with `spp` rays per pixel, `seed` and `shading`.
    pub fn reference(sample: &Sample, spp: u32, seed: u64, shading: ReferenceShading) -> LinearImage {
        let s = &sample.settings;
        let settings =
            ReferenceSettings { width: s.width, height: s.height, spp, seed, progress: false, shading };
        render_reference(&sample.scene, &settings).expect("the CPU reference")
    }

    /// The CPU reference with the very samples of `sample`'s stochastic render (its S and seed) and
    /// its shading rate's mirror (per sample, per pixel over each pass' samples, or decoupled).
    pub fn same_sample_reference(sample: &Sample) -> LinearImage {
        let s = &sample.settings;
        let per_pass = s.spp / sample.output.stats.passes.max(1);
        let shading =
            s.stochastic.shading.exact().reference(per_pass).expect("the reference mirrors the exact rates");
        reference(sample, s.spp, s.seed, shading)
    }

    /// RMSE over the colour channels, unclamped.
    pub fn rmse(a: &LinearImage, b: &LinearImage) -> f64 {
        assert_eq!((a.width, a.height), (b.width, b.height), "image sizes");
        let sum: f64 = a
            .pixels
            .iter()
            .zip(&b.pixels)
            .flat_map(|(p, q)| (0..3).map(move |c| ((p[c] - q[c]) as f64).powi(2)))
            .sum();
        (sum / (a.pixels.len() * 3) as f64).sqrt()
    }

    /// Mean over the colour channels of the pixels `keep` selects (by x, y).
    pub fn mean_where(img: &LinearImage, keep: impl Fn(u32, u32) -> bool) -> f64 {
        let (mut sum, mut n) = (0f64, 0usize);
        for (i, p) in img.pixels.iter().enumerate() {
            let (x, y) = (i as u32 % img.width, i as u32 / img.width);
            if keep(x, y) {
                sum += (p[0] + p[1] + p[2]) as f64 / 3.0;
                n += 1;
            }
        }
        assert!(n > 0, "no pixel selected");
        sum / n as f64
    }

    /// Every value finite, and the image not black (mean above 0.05).
    pub fn assert_plausible(name: &str, img: &LinearImage) {
        assert!(img.all_finite(), "{name}: NaN or infinity in the image");
        let mean = mean_where(img, |_, _| true);
        eprintln!("{name}: mean {mean:.4}");
        assert!(mean > 0.05, "{name}: image is black (mean {mean})");
    }
}
