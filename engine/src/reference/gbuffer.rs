//! The CPU G-buffer of interleaved deferred shading ([`crate::mirror::interleaved`]): per pixel, what the
//! camera sees through the pixel's centre at mid-shutter through the lens centre, or through one
//! pass' sample of (subpixel, lens, time) shared by every pixel ([`render_gbuffer_at`]) — position and shading normal
//! (camera space), albedo, the direct light (the model's shading, shadowed) — and the one-bounce light
//! of a set of VPLs gathered there ([`GBufferScene::gather`]), all of them or each sub-buffer's
//! subset.

use glam::{Vec2, Vec3};

use super::{Hit, ReferenceSettings, Tracer, VirtualPointLight};
use crate::error::Result;
use crate::sampling::PassSample;
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
    /// The shutter time it was rendered at.
    pub time: f32,
}

/// What [`render_gbuffer`] hands to the gathering of VPL light: the G-buffer and a gatherer that
/// traces against the scene.
pub struct GBufferScene<'a> {
    tracer: Tracer<'a>,
    pub gbuffer: GBuffer,
}

/// The G-buffer of `scene` at `width × height`: pixel centres, mid-shutter, the lens centre.
pub fn render_gbuffer(scene: &Scene, width: u32, height: u32) -> Result<GBufferScene<'_>> {
    let centre = PassSample { time: 0.5, lens: Vec2::ZERO, jitter: Vec2::ZERO };
    render_gbuffer_at(scene, width, height, &centre)
}

/// The G-buffer of `scene` at `width × height` seen through `sample`, every pixel's: pixel centre plus
/// its jitter, its lens point (the unit aperture's, mapped to the shape) and its shutter time — one
/// pass of an accumulation frame, as the rasterizer renders it.
pub fn render_gbuffer_at<'a>(
    scene: &'a Scene,
    width: u32,
    height: u32,
    sample: &PassSample,
) -> Result<GBufferScene<'a>> {
    let settings =
        ReferenceSettings { width, height, spp: 1, seed: 0, progress: false, shading: Default::default() };
    super::validate(&settings, scene)?;
    let tracer = Tracer::new(scene, &settings);
    let mut texels = Vec::with_capacity((width * height) as usize);
    let mut lights = Vec::new();
    let time = sample.time;
    for y in 0..height {
        for x in 0..width {
            let pixel = Vec2::new(x as f32 + 0.5, y as f32 + 0.5) + sample.jitter;
            let (o, d) = tracer.intrinsics.primary_ray(pixel, sample.lens);
            let hit = tracer.camera_hit(o, d, time, (x, y), 0).0;
            texels.push(hit.map(|hit| tracer.texel(&hit, d, time, &mut lights)));
        }
    }
    let background = tracer.background;
    Ok(GBufferScene { tracer, gbuffer: GBuffer { width, height, texels, background, time } })
}

impl GBufferScene<'_> {
    /// The one-bounce light `vpls` send to texel `i` before its albedo (`None`: a background texel),
    /// with their shadow rays (`visibility`) or without (the paper's SNSM), clamped at `clamp`.
    pub fn gather(&self, i: usize, vpls: &[VirtualPointLight], clamp: f32, visibility: bool) -> Vec3 {
        let Some(t) = self.gbuffer.texels[i] else { return Vec3::ZERO };
        self.tracer.gather_texel(&t, self.gbuffer.time, vpls, clamp, visibility)
    }
}

impl Tracer<'_> {
    fn texel(&self, hit: &Hit, d: Vec3, time: f32, lights: &mut Vec<crate::shading::ShadingLight>) -> GTexel {
        let x = self.surface_point(hit, d, time, None);
        self.shadowed_lights(&x, time, lights);
        let m = &self.materials[self.surface[hit.id as usize].object as usize];
        let direct = shade(x.position, x.normal, -d, x.albedo, m.specular, m.roughness, lights, self.ambient);
        GTexel { position: x.position, normal: x.normal, albedo: x.albedo, direct }
    }

    /// [`Tracer::gather_at`] at a G-buffer texel: its position raised along its normal (the texel keeps
    /// no geometric normal).
    fn gather_texel(
        &self,
        t: &GTexel,
        time: f32,
        vpls: &[VirtualPointLight],
        clamp: f32,
        visibility: bool,
    ) -> Vec3 {
        let offset = super::SHADOW_RAY_OFFSET * t.position.abs().max_element().max(1.0);
        self.gather_at(t.position + offset * t.normal, t.normal, None, offset, time, vpls, clamp, visibility)
    }
}
