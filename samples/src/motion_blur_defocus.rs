//! # Motion blur and depth of field in one frame: the stochastic rasterizer
//!
//! A real camera integrates each pixel over its area, the lens' aperture (u, v) and the time the
//! shutter is open (t). `Technique::STOCHASTIC` estimates that 5D integral directly: every pixel has
//! S samples, each with its own lens point and time, and each triangle is rasterized over its bound
//! in screen space for the whole shutter and lens, testing every covered sample's (u, v, t) against
//! the triangle at that instant through that lens point (docs/STOCHASTIC.md). So blur comes from the
//! same samples that antialias edges; there are no post-process passes to tune.
//!
//! The scene is built in code with the scene builder, in a photographer's terms: an 85 mm lens at
//! f/1.4 on a full-frame sensor, focused at 2.5 m, a 180° shutter (open for half the frame's motion). A ball
//! moves across the plane of focus (motion blur only); a box 4 m behind it is out of focus (defocus
//! only). `docs/MODEL.md` defines what the image should be; Shutter's CPU reference computes it, and
//! with the very same samples (per-sample shading) the GPU image equals it to float rounding, which
//! is what this sample's test checks.

use anyhow::Result;
use shutter::prelude::{Camera, Light, Mat4, Material, Object, Scene, Vec3};
use shutter::scene::builder::FULL_FRAME_HEIGHT_MM;
use shutter::techniques::{Renderer, Technique};

use crate::{mesh, stochastic_settings, Sample};

/// The sample's scene: 160 × 90 pixels, 16 samples per pixel.
pub fn motion_blur_defocus_scene() -> shutter::Result<Scene> {
    // The lens: an 85 mm portrait lens wide open at f/1.4 (aperture radius f / 2N = 30 mm, a 16°
    // field of view), focused at 2.5 m along the view axis: the ball's distance.
    let camera = Camera::looking_at(Vec3::new(0.0, 0.45, 2.5), Vec3::new(0.0, 0.15, 0.0))
        .with_lens(85.0, 1.4, FULL_FRAME_HEIGHT_MM)
        .with_focus_distance(2.5);
    let at = |x: f32, y: f32, z: f32, s: f32| {
        Mat4::from_translation(Vec3::new(x, y, z)) * Mat4::from_scale(Vec3::splat(s))
    };
    Scene::new("motion blur and defocus", camera)
        .with_image(160, 90, 16, 7)
        .with_object(
            Object::new("ground", mesh("plane")?, at(0.0, 0.0, 0.0, 8.0))
                .with_material(Material::diffuse(Vec3::splat(0.5))),
        )
        // The mover: a transform at shutter open and one at close; the motion between is linear.
        .with_object(
            Object::new("ball", mesh("sphere")?, at(-0.3, 0.12, 0.0, 0.12))
                .moving_to(at(0.4, 0.12, 0.0, 0.12))
                .with_material(Material::diffuse(Vec3::new(0.8, 0.25, 0.2))),
        )
        // Out of focus: 3.5 m behind the plane of focus, its circle of confusion is about 1.2 mm on
        // the sensor, 4–5 pixels of this image.
        .with_object(Object::new("box", mesh("box")?, at(0.55, 0.25, -3.5, 0.25)).with_material(Material {
            specular: 0.3,
            roughness: 0.3,
            ..Material::diffuse(Vec3::new(0.2, 0.4, 0.8))
        }))
        .with_light(Light::Directional {
            direction: Vec3::new(-0.5, -1.0, -0.4).normalize(),
            color: Vec3::splat(2.0),
            shadows: false,
        })
        // The transforms above span the whole frame; a 180° shutter sees the first half of it.
        .with_shutter_angle(180.0)
}

/// Renders [`motion_blur_defocus_scene`] with `Technique::STOCHASTIC`.
pub fn motion_blur_defocus(renderer: &mut Renderer) -> Result<Sample> {
    let scene = motion_blur_defocus_scene()?;
    // Size, S and seed from the scene; the device's capabilities checked (see `stochastic_settings`).
    let settings = stochastic_settings(renderer, &scene)?;
    let output = renderer.render(&scene, Technique::STOCHASTIC, &settings)?;
    Ok(Sample { scene, technique: Technique::STOCHASTIC, settings, output })
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::check::{assert_plausible, renderer, rmse, same_sample_reference};

    /// The stochastic image equals the CPU reference with the same samples (per-sample shading: the
    /// same hit, time and lens point per sample), and the blur is there: it differs from a pinhole
    /// render of the same scene by far more than two stochastic renders differ by noise.
    #[test]
    fn motion_blur_defocus_matches_the_reference_and_blurs() {
        let mut r = renderer();
        let sample = motion_blur_defocus(&mut r).expect("sample runs");
        let image = &sample.output.image;
        assert_plausible("motion_blur_defocus", image);

        let same = same_sample_reference(&sample);
        let exact = rmse(&same, image);
        eprintln!("motion_blur_defocus: RMSE against the same-sample reference {exact:e}");
        // Float rounding only (measured 9.9e-8 on lavapipe); a wrong sample, time or lens point costs ~1e-2.
        assert!(exact < 1e-4, "RMSE {exact:e} against the same-sample reference");

        let pinhole = r.render(&sample.scene, Technique::PINHOLE, &sample.settings).expect("pinhole").image;
        let mut other_seed = sample.settings;
        other_seed.seed += 1;
        let noise_image =
            r.render(&sample.scene, Technique::STOCHASTIC, &other_seed).expect("stochastic").image;
        let (blur, noise) = (rmse(&pinhole, image), rmse(&noise_image, image));
        eprintln!(
            "motion_blur_defocus: RMSE against pinhole {blur:.5}, against another seed (noise) {noise:.5}"
        );
        // Measured 0.101 against 0.019 (5.4×).
        assert!(blur > 3.0 * noise, "the blur ({blur}) is not clearly above the noise ({noise})");
    }
}
