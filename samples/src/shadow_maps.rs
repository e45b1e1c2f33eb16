//! # Shadows from shadow maps
//!
//! A light with `shadows: true` is attenuated at every shaded point by what lies between the point
//! and the light. Shutter's CPU reference traces a shadow ray per sample; the GPU techniques look
//! the answer up in shadow maps rendered from the light before the frame (docs/SHADOWS.md): a
//! plain depth map for opaque casters, a stochastic one for partly covering casters, a coloured
//! one for tinted ones. The `shadow-map` setting is `SIZE[/SAMPLES[/PCF]]`: texels per side of each
//! map, depth samples per texel (stochastic maps) and the PCF filter's radius; `off` renders the
//! light unshadowed (to price the shadows).
//!
//! The stochastic rasterizer reads the maps in its shading pass for every sample; its samples each
//! have their own time, so it renders shadows only when nothing moves (a moving caster is refused;
//! `Technique::AUTO` then takes accumulation, which renders maps per pass). The scene: a box
//! floating above the ground, under the sun, seen through a 35 mm f/2 lens focused on the box.
//! The test checks the image against the reference's shadow rays with the same samples, and that
//! the shadow is there: the ground behind the box darkens, and nothing brightens.

use anyhow::Result;
use shutter::prelude::{Camera, Light, Mat4, Material, Object, Scene, Vec3};
use shutter::techniques::{Renderer, Technique};

use crate::{mesh, stochastic_settings, Sample};

/// The sample's scene: 160 × 90 pixels, 16 samples per pixel; nothing moves.
pub fn shadow_maps_scene() -> shutter::Result<Scene> {
    let camera = Camera::looking_at(Vec3::new(0.0, 2.5, 5.0), Vec3::new(0.0, 0.5, 0.0)).with_lens(
        35.0,
        2.0,
        shutter::scene::builder::FULL_FRAME_HEIGHT_MM,
    );
    let at = |x: f32, y: f32, z: f32| Mat4::from_translation(Vec3::new(x, y, z));
    Ok(Scene::new("shadow maps", camera)
        .with_image(160, 90, 16, 5)
        .with_object(
            Object::new("ground", mesh("plane")?, Mat4::from_scale(Vec3::splat(6.0)))
                .with_material(Material::diffuse(Vec3::splat(0.7))),
        )
        .with_object(
            Object::new(
                "box",
                mesh("box")?,
                at(0.0, 0.9, 0.0) * Mat4::from_rotation_y(0.5) * Mat4::from_scale(Vec3::splat(0.45)),
            )
            .with_material(Material {
                specular: 0.3,
                roughness: 0.4,
                ..Material::diffuse(Vec3::new(0.8, 0.55, 0.3))
            }),
        )
        .with_object(
            Object::new("ball", mesh("sphere")?, at(-1.6, 0.4, -0.8) * Mat4::from_scale(Vec3::splat(0.4)))
                .with_material(Material::diffuse(Vec3::new(0.3, 0.5, 0.8))),
        )
        // The sun, low from the right: its shadows fall to the left, behind the objects.
        .with_light(Light::Directional {
            direction: Vec3::new(-0.7, -0.8, -0.5).normalize(),
            color: Vec3::splat(2.8),
            shadows: true,
        }))
}

/// Renders [`shadow_maps_scene`] with `Technique::STOCHASTIC` and shadow maps
/// set by `shadow_map` (`SIZE[/SAMPLES[/PCF]]` or `off`).
pub fn shadow_maps(renderer: &mut Renderer, shadow_map: &str) -> Result<Sample> {
    let scene = shadow_maps_scene()?;
    let mut settings = stochastic_settings(renderer, &scene)?;
    // 1024² texels: finer than the image's footprint on the ground, so the map's edge lies within a
    // fraction of a pixel of the rays'; PCF radius 1 for smooth edges. The map's size is checked
    // against the device's largest image when the frame is prepared (an error names both).
    settings.set("shadow-map", shadow_map)?;
    let output = renderer.render(&scene, Technique::STOCHASTIC, &settings)?;
    // The frame lists the maps it drew (None: no shadow-casting light, or `off`).
    if let Some(maps) = &output.stats.shadows {
        eprintln!("shadow maps: {maps}");
    }
    Ok(Sample { scene, technique: Technique::STOCHASTIC, settings, output })
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::check::{assert_plausible, renderer, rmse, same_sample_reference};

    /// Against the reference with the same samples (which traces a shadow ray per sample), only the
    /// map's answer differs from a ray's: within the bound below. The shadow is there: with the maps
    /// off, the ground behind the box and the ball (over 2.5 % of the image) is brighter, and no
    /// pixel is darker.
    #[test]
    fn shadow_maps_match_shadow_rays_and_darken_behind_the_caster() {
        let mut r = renderer();
        let sample = shadow_maps(&mut r, "1024/4/1").expect("sample runs");
        let image = &sample.output.image;
        assert_plausible("shadow_maps", image);
        assert!(sample.output.stats.shadows.is_some(), "no shadow maps drawn");
        let rays = same_sample_reference(&sample);
        let e = rmse(&rays, image);
        let off = shadow_maps(&mut r, "off").expect("sample runs without maps").output.image;
        let e_off = rmse(&rays, &off);
        eprintln!("shadow_maps: RMSE against the same-sample reference {e:.5}; with the maps off {e_off:.5}");
        // Measured 0.0079 on lavapipe: the PCF radius 1 softens the map's edge against the rays' hard
        // one (radius 0: 0.0050), and 0.0044 remains at 4096² (terminators and contacts); 512²
        // gives 0.018. Bound with margin.
        assert!(e < 0.012, "RMSE {e} against shadow rays");
        assert!(e < 0.2 * e_off, "the maps ({e}) are not far closer to the rays than no shadows ({e_off})");

        let n = image.pixels.len();
        let darkened = image.pixels.iter().zip(&off.pixels).filter(|(p, q)| q[1] - p[1] > 0.1).count();
        let brightened = image.pixels.iter().zip(&off.pixels).filter(|(p, q)| p[1] - q[1] > 1e-4).count();
        eprintln!(
            "shadow_maps: {darkened} of {n} pixels darker by 0.1 than without shadows, {brightened} brighter"
        );
        // Measured 485 of 14,400 (3.4 %): the box's and the ball's shadows on the ground.
        assert!(darkened * 40 > n, "only {darkened} of {n} pixels in shadow");
        assert_eq!(brightened, 0, "shadows brightened {brightened} pixels");
    }
}
