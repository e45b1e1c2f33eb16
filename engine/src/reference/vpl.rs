//! Instant radiosity (Keller 1997) in the CPU reference: one-bounce indirect light
//! ([`crate::scene::Indirect::OneBounce`]) estimated with virtual point lights instead of a bounce ray
//! per sample — the CPU mirror of what the interleaved-shading work shades on the GPU
//! (docs/INTERLEAVED.md), and the baseline that shades every pixel with every VPL.
//!
//! **Generation: light paths traced on the CPU** (not a reflective shadow map), in camera space at
//! mid-shutter, for still scenes only. Each light gets a share of [`VplSettings::count`] photons in
//! proportion to its power, stratified (multi-jittered) over its emission:
//! * a point light, uniform over the sphere; a spot light, uniform over its outer cone, each photon
//!   weighted by the cone's falloff; the model's light colour `c` is π × the physical intensity (its
//!   direct term is `albedo · c · cos θ / d²`, the Lambertian `albedo/π` times the irradiance
//!   `π c cos θ / d²`), so a photon carries the flux `π c · Ω / N` (Ω: the solid angle sampled);
//! * a directional light, uniform over a disk across the light that covers the scene's bounding
//!   sphere, each photon carrying `π c · area / N`.
//!
//! A photon of a light with `shadows` stops at the nearest surface of coverage 1, attenuated by the
//! transmittance of the partly covering ones before it (as shadow rays); a light without shadows lights
//! every surface its photon crosses (as its unshadowed direct light does). Where a photon lands, a VPL
//! is left with the flux the surface reflects diffusely (its albedo times the photon's) and the
//! surface's normal on the side the photon came from, raised off the surface by the shadow-ray offset.
//!
//! **Gathering** (`Tracer::gather`): a shaded point `x` adds, per VPL `y` on the same side and with a
//! clear (transmittance-weighted) segment to it, `albedo(x)/π · Φ·cos θ_y/π · cos θ_x / max(d², c²)`,
//! `c` the clamping distance ([`VplSettings::clamp`], 0: off). Unclamped, the estimate is unbiased: its
//! expectation over the photons is the model's one-bounce light, which the bounce rays of the path-traced
//! reference also converge to; clamping removes the `1/d²` spikes near a VPL at the cost of energy in
//! corners (the bias `shutter reference --vpls N --clamp C` lets one measure).

use glam::{Vec2, Vec3};

use super::{ReferenceSettings, SurfacePoint, Tracer};
use crate::error::{Error, Result};
use crate::sampling::{multi_jittered, orthonormal_frame, Pcg32};
use crate::scene::{Indirect, Scene};
use crate::shading::ShadingLight;

/// One virtual point light, camera space at mid-shutter.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct VirtualPointLight {
    /// On its surface's lit side, raised off it by the shadow-ray offset.
    pub position: Vec3,
    /// Unit normal of the lit side.
    pub normal: Vec3,
    /// The flux the surface reflects diffusely, in the model's units (module docs).
    pub flux: Vec3,
}

/// How instant radiosity estimates one-bounce indirect light.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct VplSettings {
    /// Photons traced from the lights, in all (each light's share in proportion to its power); every
    /// photon that lands leaves one VPL.
    pub count: u32,
    /// Clamping distance of the `1/d²` term, scene units (0: off, unbiased).
    pub clamp: f32,
    /// Seed of the photons' samples.
    pub seed: u64,
}

/// The most photons [`VplSettings::count`] may ask for.
pub const MAX_VPLS: u32 = 1 << 20;

/// Mixed into the photons' seed.
const VPL_SEED: u64 = 0x7670_6c73_5f69_7221;

/// The VPLs of `scene` (module docs), in camera space at mid-shutter. Errors for a scene that moves
/// (the VPLs of one instant would not light the others) and for a count outside `1 ..= MAX_VPLS`.
pub fn virtual_point_lights(scene: &Scene, s: &VplSettings) -> Result<Vec<VirtualPointLight>> {
    let tracer = Tracer::new(scene, &vpl_tracer_settings(s));
    tracer.check_still_scene()?;
    tracer.virtual_point_lights(s, 0.5)
}

/// The VPLs of `scene` at shutter time `time`, in camera space at that instant: moving scenes
/// included — what lights the surfaces seen at `time` (technique `interleaved` traces a set per pass
/// of a moving scene). Errors for a count outside `1 ..= MAX_VPLS` and a time outside `[0, 1]`.
pub fn virtual_point_lights_at(scene: &Scene, s: &VplSettings, time: f32) -> Result<Vec<VirtualPointLight>> {
    if !(0.0..=1.0).contains(&time) {
        return Err(Error::Unsupported(format!("VPLs at shutter time {time}: a time in [0, 1]")));
    }
    Tracer::new(scene, &vpl_tracer_settings(s)).virtual_point_lights(s, time)
}

fn vpl_tracer_settings(s: &VplSettings) -> ReferenceSettings {
    ReferenceSettings {
        width: 1,
        height: 1,
        spp: 1,
        seed: s.seed,
        progress: false,
        shading: Default::default(),
    }
}

impl Tracer<'_> {
    /// Refuses what the VPL estimate does not model.
    pub(super) fn check_vpl_scene(&self, s: &VplSettings) -> Result<()> {
        if !(1..=MAX_VPLS).contains(&s.count) {
            return Err(Error::Limit {
                what: "vpls",
                value: s.count.to_string(),
                limit: format!("1 ..= {MAX_VPLS}"),
            });
        }
        if !(s.clamp >= 0.0 && s.clamp.is_finite()) {
            return Err(Error::Unsupported(format!(
                "VPL clamping distance {}: a finite distance ≥ 0",
                s.clamp
            )));
        }
        if self.indirect != Indirect::OneBounce {
            return Err(Error::Unsupported(
                "virtual point lights estimate one-bounce indirect light: the scene has none ([environment] indirect = \"one-bounce\")".into(),
            ));
        }
        Ok(())
    }

    /// Refuses a scene that moves: one set of VPLs, traced at one instant, would not light the others.
    pub(super) fn check_still_scene(&self) -> Result<()> {
        if !self.scene_space.is_still() {
            return Err(Error::Unsupported(
                "virtual point lights need a still scene (nothing moving, the camera included): they are traced at one instant".into(),
            ));
        }
        Ok(())
    }

    /// The VPLs at shutter time `time` (module docs).
    pub(super) fn virtual_point_lights(&self, s: &VplSettings, time: f32) -> Result<Vec<VirtualPointLight>> {
        self.check_vpl_scene(s)?;
        let lights: Vec<ShadingLight> = self.scene_space.lights.iter().map(|l| l.at(time)).collect();
        let (centre, radius) = self.bounding_sphere(time);
        // Each light's power (luminance of its flux), for its share of the photons.
        let luminance = |c: Vec3| c.dot(Vec3::new(0.2126, 0.7152, 0.0722)).max(0.0);
        let emission: Vec<(f32, f32)> = lights
            .iter()
            .map(|l| {
                // (sampled measure: solid angle or area, power)
                let (measure, color) = match *l {
                    ShadingLight::Point { color, .. } => (4.0 * std::f32::consts::PI, color),
                    ShadingLight::Spot { cos_outer, color, .. } => {
                        (2.0 * std::f32::consts::PI * (1.0 - cos_outer), color)
                    }
                    ShadingLight::Directional { color, .. } => {
                        (std::f32::consts::PI * radius * radius, color)
                    }
                };
                (measure, std::f32::consts::PI * luminance(color) * measure)
            })
            .collect();
        let total: f32 = emission.iter().map(|e| e.1).sum();
        let mut vpls = Vec::new();
        let lit = total > 0.0; // false for NaN
        if !lit {
            return Ok(vpls);
        }
        for (li, (light, &(measure, power))) in lights.iter().zip(&emission).enumerate() {
            let n = ((s.count as f64 * (power / total) as f64).round() as u32).max(u32::from(power > 0.0));
            if n == 0 {
                continue;
            }
            let mut rng = Pcg32::new(s.seed ^ VPL_SEED, li as u64);
            let mut samples = multi_jittered(n, &mut rng);
            rng.shuffle(&mut samples);
            let shadows = self.shadows[li];
            for u in samples {
                let Some((origin, dir, flux)) = photon(light, u, measure / n as f32, centre, radius) else {
                    continue;
                };
                if flux == Vec3::ZERO {
                    continue;
                }
                self.land_photon(origin, dir, flux, shadows, time, &mut vpls);
            }
        }
        Ok(vpls)
    }

    /// Leaves the VPLs of one photon (module docs).
    fn land_photon(
        &self,
        origin: Vec3,
        dir: Vec3,
        flux: Vec3,
        shadows: bool,
        time: f32,
        vpls: &mut Vec<VirtualPointLight>,
    ) {
        let bvh = &self.bvhs[self.intervals.segment_of(time)];
        let mut leave = |tracer: &Self, hit: &super::Hit, flux: Vec3| {
            let y = tracer.surface_point(hit, dir, time, None);
            vpls.push(VirtualPointLight {
                position: y.lit_side().1,
                normal: y.normal,
                flux: flux * y.albedo,
            });
        };
        if shadows {
            let Some((hit, s)) = bvh.nearest(origin, dir, time, 0.0, f32::INFINITY, |id, h| {
                let m = &self.materials[self.surface[id as usize].object as usize];
                m.is_opaque() || self.coverage(id, h) >= 1.0
            }) else {
                return;
            };
            let through = self.transmittance(origin, dir, s, time, 0.0);
            if through != Vec3::ZERO {
                leave(self, &hit, flux * through);
            }
        } else {
            let mut hits = Vec::new();
            bvh.for_each_hit(origin, dir, time, 0.0, f32::INFINITY, |id, h, _| {
                let m = &self.materials[self.surface[id as usize].object as usize];
                if m.is_opaque() || self.coverage(id, h) >= 1.0 {
                    hits.push(super::Hit { id, hit: *h });
                }
                true
            });
            for hit in &hits {
                leave(self, hit, flux);
            }
        }
    }

    /// The one-bounce light the VPLs send to `x` (module docs, "Gathering"), before `x`'s albedo.
    pub(super) fn gather(&self, x: &SurfacePoint, time: f32, vpls: &[VirtualPointLight], clamp: f32) -> Vec3 {
        let (g, origin) = x.lit_side();
        self.gather_at(origin, x.normal, Some(g), x.offset, time, vpls, clamp, true)
    }

    /// The gathering from `origin` (raised off its surface by `offset`) with shading normal `normal`:
    /// VPLs below the geometric side `side` (when known) are skipped; with `visibility`, each one's
    /// light is multiplied by the transmittance of the segment to it (the paper's SSM), else by 1 (its
    /// SNSM).
    #[allow(clippy::too_many_arguments)]
    pub(super) fn gather_at(
        &self,
        origin: Vec3,
        normal: Vec3,
        side: Option<Vec3>,
        offset: f32,
        time: f32,
        vpls: &[VirtualPointLight],
        clamp: f32,
        visibility: bool,
    ) -> Vec3 {
        let clamp2 = clamp * clamp;
        let mut sum = Vec3::ZERO;
        for v in vpls {
            let d = v.position - origin;
            let d2 = d.length_squared();
            let apart = d2 > 0.0; // false for NaN
            if !apart {
                continue;
            }
            let dir = d / d2.sqrt();
            let (cx, cy) = (normal.dot(dir), -v.normal.dot(dir));
            if cx <= 0.0 || cy <= 0.0 || side.is_some_and(|g| dir.dot(g) <= 0.0) {
                continue;
            }
            let through =
                if visibility { self.transmittance(origin, d, 1.0, time, offset) } else { Vec3::ONE };
            if through == Vec3::ZERO {
                continue;
            }
            sum +=
                through * v.flux * (cx * cy / (std::f32::consts::PI * std::f32::consts::PI * d2.max(clamp2)));
        }
        sum
    }

    /// The camera-space bounding sphere (centre, radius) of every triangle at shutter time `time`.
    fn bounding_sphere(&self, time: f32) -> (Vec3, f32) {
        let (mut lo, mut hi) = (Vec3::INFINITY, Vec3::NEG_INFINITY);
        for id in 0..self.surface.len() as u32 {
            let ([(p0, _), (p1, _)], s) = self.segment_at(id, time);
            for k in 0..3 {
                let p = p0[k].lerp(p1[k], s);
                (lo, hi) = (lo.min(p), hi.max(p));
            }
        }
        if lo.x > hi.x {
            return (Vec3::ZERO, 0.0);
        }
        let centre = 0.5 * (lo + hi);
        (centre, 0.5 * (hi - lo).length() * 1.001)
    }
}

/// One photon of `light` for the point `u` of the unit square: origin, unit direction and flux, the
/// light's sampled measure (solid angle or area) being `share` per photon.
fn photon(
    light: &ShadingLight,
    u: Vec2,
    share: f32,
    centre: Vec3,
    radius: f32,
) -> Option<(Vec3, Vec3, Vec3)> {
    let pi = std::f32::consts::PI;
    match *light {
        ShadingLight::Point { position, color } => Some((position, uniform_sphere(u), pi * color * share)),
        ShadingLight::Spot { position, axis, cos_inner, cos_outer, color } => {
            // Uniform over the outer cone: cos θ uniform in [cos_outer, 1].
            let cos = 1.0 - u.x * (1.0 - cos_outer);
            let sin = (1.0 - cos * cos).max(0.0).sqrt();
            let phi = 2.0 * pi * u.y;
            let (t, b) = orthonormal_frame(axis);
            let dir = (cos * axis + sin * (phi.cos() * t + phi.sin() * b)).normalize();
            let falloff = crate::shading::spot_falloff(cos, cos_inner, cos_outer);
            Some((position, dir, pi * color * falloff * share))
        }
        ShadingLight::Directional { to_light, color } => {
            if radius <= 0.0 {
                return None;
            }
            let d = crate::sampling::concentric_disk(u) * radius;
            let (t, b) = orthonormal_frame(to_light);
            let origin = centre + to_light * (2.0 * radius) + d.x * t + d.y * b;
            Some((origin, -to_light, pi * color * share))
        }
    }
}

/// A uniformly distributed unit vector for the point `u` of the unit square.
fn uniform_sphere(u: Vec2) -> Vec3 {
    let z = 1.0 - 2.0 * u.x;
    let r = (1.0 - z * z).max(0.0).sqrt();
    let phi = 2.0 * std::f32::consts::PI * u.y;
    Vec3::new(r * phi.cos(), r * phi.sin(), z)
}
