//! The CPU G-buffer of interleaved deferred shading ([`crate::interleaved`]): per pixel, what the
//! pinhole camera sees through the pixel's centre at mid-shutter — position and shading normal
//! (camera space), albedo, the direct light (the model's shading, shadowed) — and the one-bounce light
//! of a set of VPLs gathered there ([`Tracer::gather_irradiance`]), all of them or each sub-buffer's
//! subset.

use glam::{Vec2, Vec3};

use super::{Hit, ReferenceSettings, Tracer, VirtualPointLight};
use crate::error::Result;
use crate::scene::Scene;
use crate::shading::shade;

/// One texel: `None` where the pixel's centre sees the background.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct GTexel {
    pub position: Vec3,
    pub normal: Vec3,
    pub albedo: Vec3,
    /// The direct light towards the camera (ambient included).
    pub direct: Vec3,
}

/// A G-buffer of `width × height` texels, row-major, and the scene's background.
#[derive(Clone, Debug)]
pub struct GBuffer {
    pub width: u32,
    pub height: u32,
    pub texels: Vec<Option<GTexel>>,
    pub background: Vec3,
}

/// What [`render_gbuffer`] hands to the gathering of VPL light: the G-buffer and a gatherer that
/// traces against the scene.
pub struct GBufferScene<'a> {
    tracer: Tracer<'a>,
    pub gbuffer: GBuffer,
}

/// The G-buffer of `scene` at `width × height`.
pub fn render_gbuffer(scene: &Scene, width: u32, height: u32) -> Result<GBufferScene<'_>> {
    let settings =
        ReferenceSettings { width, height, spp: 1, seed: 0, progress: false, shading: Default::default() };
    super::validate(&settings, &scene.camera)?;
    let tracer = Tracer::new(scene, &settings);
    let mut texels = Vec::with_capacity((width * height) as usize);
    let mut lights = Vec::new();
    for y in 0..height {
        for x in 0..width {
            let (o, d) = tracer.intrinsics.primary_ray(Vec2::new(x as f32 + 0.5, y as f32 + 0.5), Vec2::ZERO);
            let hit = tracer.camera_hit(o, d, 0.5, (x, y), 0).0;
            texels.push(hit.map(|hit| tracer.texel(&hit, d, &mut lights)));
        }
    }
    let background = tracer.background;
    Ok(GBufferScene { tracer, gbuffer: GBuffer { width, height, texels, background } })
}

impl GBufferScene<'_> {
    /// The one-bounce light `vpls` send to texel `i` before its albedo (`None`: a background texel),
    /// with their shadow rays (`visibility`) or without (the paper's SNSM), clamped at `clamp`.
    pub fn gather(&self, i: usize, vpls: &[VirtualPointLight], clamp: f32, visibility: bool) -> Vec3 {
        let Some(t) = self.gbuffer.texels[i] else { return Vec3::ZERO };
        self.tracer.gather_texel(&t, vpls, clamp, visibility)
    }
}

impl Tracer<'_> {
    fn texel(&self, hit: &Hit, d: Vec3, lights: &mut Vec<crate::shading::ShadingLight>) -> GTexel {
        let x = self.surface_point(hit, d, 0.5, None);
        self.shadowed_lights(&x, 0.5, lights);
        let m = &self.materials[self.surface[hit.id as usize].object as usize];
        let direct = shade(x.position, x.normal, -d, x.albedo, m.specular, m.roughness, lights, self.ambient);
        GTexel { position: x.position, normal: x.normal, albedo: x.albedo, direct }
    }

    /// [`Tracer::gather_at`] at a G-buffer texel: its position raised along its normal (the texel keeps
    /// no geometric normal).
    fn gather_texel(&self, t: &GTexel, vpls: &[VirtualPointLight], clamp: f32, visibility: bool) -> Vec3 {
        let offset = super::SHADOW_RAY_OFFSET * t.position.abs().max_element().max(1.0);
        self.gather_at(t.position + offset * t.normal, t.normal, None, offset, 0.5, vpls, clamp, visibility)
    }
}
