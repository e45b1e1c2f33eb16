//! # Decoupled shading (Ragan-Kelley et al. 2011)
//!
//! Another way to stop paying S shader runs per pixel: decouple shading from visibility. With
//! `shading=decoupled` (docs/DECOUPLED.md) every visibility sample maps to a *key* — its triangle,
//! the side it sees, and the pixel-sized cell of its surface point at mid-shutter through the lens
//! centre — and takes the radiance of that key, shaded once at the key's shading point. Samples of
//! one pixel that see one blurred surface share a handful of keys. The radiance is memoized in a
//! direct-mapped cache of `cache` entries in the shading pass: a miss shades and stores, so a
//! smaller cache costs time, never a different image. (`aas` uses each triangle's anisotropic
//! grid instead of pixels; the `-deferred` variants shade the frame's keys in a dispatch of their
//! own.)
//!
//! Unlike texture-space shading, the reference mirrors this exactly, so the test compares sample
//! for sample, and checks that the image is not per-sample shading's and does not depend on the
//! cache. The scene is the motion-blur sample's with the moving ball checkered and glossy, where
//! shading once per key rather than per sample changes the image.

use anyhow::Result;
use shutter::prelude::{Material, Scene, Vec3};
use shutter::scene::builtin::checker_texture;
use shutter::techniques::{Renderer, Technique};

use crate::{stochastic_settings, Sample};

/// [`crate::motion_blur_defocus_scene`] with its ball textured and glossy.
pub fn decoupled_shading_scene() -> shutter::Result<Scene> {
    let mut scene = crate::motion_blur_defocus_scene()?;
    scene.name = "decoupled shading".into();
    for o in scene.objects.iter_mut().filter(|o| o.name == "ball") {
        o.material = Material {
            texture: Some(checker_texture()),
            specular: 0.5,
            roughness: 0.25,
            ..Material::diffuse(Vec3::ONE)
        };
    }
    Ok(scene)
}

/// Renders [`decoupled_shading_scene`] with `Technique::STOCHASTIC`, `shading` (`decoupled` for the
/// sample) and a cache of `cache_entries` entries.
pub fn decoupled_shading(renderer: &mut Renderer, shading: &str, cache_entries: u32) -> Result<Sample> {
    let scene = decoupled_shading_scene()?;
    // The cache lives in the shading pass' storage buffer: nothing beyond the stochastic frame's
    // own capabilities (fragment stores and atomics) is needed.
    let mut settings = stochastic_settings(renderer, &scene)?;
    settings.set("shading", shading)?;
    settings.set("cache", &cache_entries.to_string())?;
    let output = renderer.render(&scene, Technique::STOCHASTIC, &settings)?;
    Ok(Sample { scene, technique: Technique::STOCHASTIC, settings, output })
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::check::{assert_plausible, reference, renderer, rmse, same_sample_reference};
    use shutter::reference::ReferenceShading;

    /// Decoupled shading equals the reference's mirror of it with the same samples; it is not
    /// per-sample shading (the reference's per-sample image is clearly further away); and a cache
    /// of 64 entries (misses everywhere) renders the very same image as one of 4096.
    #[test]
    fn decoupled_shading_matches_its_reference_mirror_whatever_the_cache() {
        let mut r = renderer();
        let sample = decoupled_shading(&mut r, "decoupled", 4096).expect("sample runs");
        let image = &sample.output.image;
        assert_plausible("decoupled_shading", image);
        let mirror = same_sample_reference(&sample);
        let per_sample =
            reference(&sample, sample.settings.spp, sample.settings.seed, ReferenceShading::PerSample);
        let (exact, vs_per_sample) = (rmse(&mirror, image), rmse(&per_sample, image));
        eprintln!(
            "decoupled_shading: RMSE against the reference's decoupled mirror {exact:e}, against its \
             per-sample shading with the same samples {vs_per_sample:.5}"
        );
        // Measured 4.7e-5 on lavapipe: the few samples whose cell the GPU's f32 projection rounds to
        // the neighbour (docs/DECOUPLED.md); per-sample shading's image is 0.0054 away. Bound with margin.
        assert!(exact < DECOUPLED_RMSE_MAX, "RMSE {exact:e} against the decoupled mirror");
        assert!(vs_per_sample > 20.0 * exact, "decoupled is per-sample shading: {vs_per_sample}");

        let small = decoupled_shading(&mut r, "decoupled", 64).expect("a small cache");
        let cache = rmse(&small.output.image, image);
        eprintln!("decoupled_shading: RMSE between caches of 64 and 4096 entries {cache:e}");
        // Measured 1.1e-8: the rounding of the order a pixel's radiances are summed in.
        assert!(cache < 1e-6, "the cache changed the image: RMSE {cache:e}");
    }

    const DECOUPLED_RMSE_MAX: f64 = 3e-4;
}
