//! The scene model: what is rendered, independent of any technique.
//!
//! A [`Scene`] is fully resolved (meshes loaded and cleaned, textures decoded, transforms as matrices);
//! `file.rs` builds one from TOML, `builtin.rs` holds the embedded scenes and procedural meshes.
//! `camera_space.rs` turns it into the camera-space, linear-in-time form every technique and the CPU
//! reference consume (docs/MODEL.md "Shutter").

pub mod builder;
pub mod builtin;
pub mod camera;
pub mod camera_space;
pub mod extremes;
pub mod file;
pub mod mesh;
pub mod texture;
pub mod validate;
pub mod view;

use std::sync::Arc;

use glam::{Mat4, Vec3};

pub use camera::{Camera, CameraPose, Intrinsics};
pub use camera_space::{CameraSpaceLight, CameraSpaceScene, ObjectMotion};
pub use mesh::{Mesh, MeshStats};
pub use texture::Texture;
pub use view::{Projection, View};

/// Output image settings.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct ImageSettings {
    pub width: u32,
    pub height: u32,
    /// Samples per pixel (meaning depends on the technique: passes for accumulation, rays for the
    /// reference).
    pub spp: u32,
    pub seed: u64,
    /// Exposure and tone curve of the scene's 8-bit (PNG) output; rendering, EXR and metrics stay
    /// linear ([`crate::tonemap`]). Default: [`Display::LINEAR`](crate::tonemap::Display::LINEAR).
    pub display: crate::tonemap::Display,
}

/// Surface description of the one shading model (docs/MODEL.md "Shading").
#[derive(Clone, Debug)]
pub struct Material {
    /// Linear RGB albedo; multiplies the texture when there is one.
    pub albedo: Vec3,
    /// sRGB texture, sampled with repeat addressing.
    pub texture: Option<Arc<Texture>>,
    /// Weight of the specular lobe, 0..1.
    pub specular: f32,
    /// Roughness of the specular lobe, (0, 1].
    pub roughness: f32,
    /// Coverage α, 0..1: the fraction of the surface that is there (and shades); the rest lets light
    /// through, filtered by `tint`. Techniques without transparency reject a material that is not
    /// [`Material::is_opaque`] with a clear error.
    pub alpha: f32,
    /// Coverage also from the texture: α = `alpha` × the texel's alpha (linear, 8-bit) at the hit's
    /// uv. Needs `texture`; off by default so textured scenes keep their images.
    pub alpha_from_texture: bool,
    /// Coloured transmission T (linear RGB, each in 0..1) of the uncovered part 1 − α: no refraction,
    /// the light behind is multiplied per channel. With coverage α and shaded colour C a surface
    /// composites over what lies behind it as `α·C + (1 − α)·T ⊙ behind` (Porter-Duff *over* with a
    /// coloured transmittance `(1 − α)·T`); the transmittance of several layers is the product of
    /// theirs, so the composite does not depend on their order (docs/TRANSPARENCY.md). α = 0 with a
    /// tint is a pure filter (coloured glass); for α = 1 the tint is irrelevant.
    pub tint: Vec3,
    /// One-sided: the surface exists for camera rays only from its front, the side from which its
    /// vertices run counter-clockwise on the image (geometric normal `(b − a) × (c − a)` towards the
    /// ray's origin, the rasterizer's `gl_FrontFacing`); a camera ray reaching its back passes
    /// through as if it were not there (no shading, no tint). Shadows are still cast by both sides
    /// (shadow rays and shadow maps ignore the flag), so a closed mesh renders the same image either
    /// way while every technique may skip its back faces: the rasterizers cull them per draw and per
    /// sample, texture-space shading's pass 1 culls those that face away at every lens point and
    /// shutter time (`texture_space::cull::back_facing`). Off by default (two-sided). The scene file
    /// refuses it on an object whose transform mirrors it (negative determinant: the outside would be
    /// culled); docs/STOCHASTIC.md "One-sided surfaces".
    pub one_sided: bool,
}

impl Default for Material {
    fn default() -> Self {
        Material {
            albedo: Vec3::splat(0.8),
            texture: None,
            specular: 0.0,
            roughness: 0.5,
            alpha: 1.0,
            alpha_from_texture: false,
            tint: Vec3::ONE,
            one_sided: false,
        }
    }
}

impl Material {
    /// Every point of the surface is fully covered: α = 1 and no texture alpha.
    pub fn is_opaque(&self) -> bool {
        self.alpha >= 1.0 && !self.alpha_from_texture
    }
    /// The coverage at a point whose texture alpha (when `alpha_from_texture`) is `texel_alpha`.
    pub fn coverage(&self, texel_alpha: f32) -> f32 {
        if self.alpha_from_texture {
            self.alpha * texel_alpha
        } else {
            self.alpha
        }
    }
    /// The per-channel transmittance `(1 − α)·T` of a point of coverage `coverage`.
    pub fn transmittance(&self, coverage: f32) -> Vec3 {
        (1.0 - coverage) * self.tint
    }
}

/// One placed mesh and how it moves over the shutter.
#[derive(Clone, Debug)]
pub struct Object {
    pub name: String,
    pub mesh: Arc<Mesh>,
    /// Object → world transform keys `(shutter time, transform)`: times strictly increasing from 0;
    /// one key (at 0) for an object that does not move, otherwise the last at 1. Between keys the
    /// motion is linear in camera space (docs/MODEL.md "Shutter"), so a rotation takes several keys
    /// (`motion_keys` in the scene file) not to collapse through its centre.
    pub transforms: Vec<(f32, Mat4)>,
    pub material: Material,
}

impl Object {
    /// The transform at shutter open.
    pub fn transform_open(&self) -> Mat4 {
        self.transforms[0].1
    }
    /// The transform at shutter close.
    pub fn transform_at_close(&self) -> Mat4 {
        self.transforms.last().expect("an object has a transform").1
    }
    /// Two keys: `transform_open()` at open and `close` at close (replacing any others).
    pub fn set_close(&mut self, close: Mat4) {
        let open = self.transform_open();
        self.transforms = vec![(0.0, open), (1.0, close)];
    }
    /// Does the object move (relative to the world)?
    pub fn is_moving(&self) -> bool {
        self.transforms.iter().any(|k| k.1 != self.transforms[0].1)
    }
}

/// Light sources (world space). Directional `direction` points *from* the light into the scene, as
/// does a spot's axis. `shadows`: whether surfaces between a shaded point and the light attenuate it
/// by their transmittance (off by default; the CPU reference traces shadow rays, GPU techniques
/// without shadow maps refuse such a light).
#[derive(Clone, Copy, Debug, PartialEq)]
pub enum Light {
    Directional {
        direction: Vec3,
        color: Vec3,
        shadows: bool,
    },
    /// Falls off with 1/d².
    Point {
        position: Vec3,
        color: Vec3,
        shadows: bool,
    },
    /// A point light restricted to a cone about `direction` (unit): full inside the half-angle
    /// `inner_deg`, none outside `outer_deg` (0 ≤ inner ≤ outer ≤ 90), a smoothstep of the angle's
    /// cosine between them ([`crate::shading::spot_falloff`]); 1/d² like a point light.
    Spot {
        position: Vec3,
        direction: Vec3,
        inner_deg: f32,
        outer_deg: f32,
        color: Vec3,
        shadows: bool,
    },
}

impl Light {
    /// Does the light cast shadows?
    pub fn shadows(&self) -> bool {
        match *self {
            Light::Directional { shadows, .. }
            | Light::Point { shadows, .. }
            | Light::Spot { shadows, .. } => shadows,
        }
    }
}

/// What [`Scene::content_hash`] hashes of a light: lights that existed before spots and shadows in
/// the very text they hashed as then (so cached references stay valid), anything else in full.
#[derive(Debug)]
#[allow(dead_code)] // read through `Debug` only
enum HashedLight {
    Directional { direction: Vec3, color: Vec3 },
    Point { position: Vec3, color: Vec3 },
    Other(Light),
}

impl From<&Light> for HashedLight {
    fn from(l: &Light) -> Self {
        match *l {
            Light::Directional { direction, color, shadows: false } => {
                HashedLight::Directional { direction, color }
            }
            Light::Point { position, color, shadows: false } => HashedLight::Point { position, color },
            other => HashedLight::Other(other),
        }
    }
}

#[derive(Clone, Copy, Debug, PartialEq)]
pub struct Environment {
    /// Constant ambient light, multiplied by albedo.
    pub ambient: Vec3,
    /// Colour of pixels that see no geometry (linear).
    pub background: Vec3,
    /// Light reflected between surfaces ([`Indirect`]).
    pub indirect: Indirect,
}

impl Default for Environment {
    fn default() -> Self {
        Environment { ambient: Vec3::splat(0.05), background: Vec3::ZERO, indirect: Indirect::None }
    }
}

/// Indirect light in the scene model (`[environment] indirect`, docs/INTERLEAVED.md).
#[derive(Clone, Copy, Debug, Default, PartialEq, Eq, Hash)]
pub enum Indirect {
    /// Direct light (and the constant ambient) only.
    #[default]
    None,
    /// One diffuse bounce: the light of the direct lights that one surface reflects diffusely onto
    /// another, reflected diffusely again. A surface point `y` lit by the direct lights (shadowed as
    /// they are) sends out its diffuse radiance `albedo(y) · Σ e·max(n·l, 0)`, the diffuse term of
    /// [`crate::shading::shade`] without ambient or specular; a shaded point `x` adds
    /// `albedo(x)/π · ∫ L(y→x) cos θ dω` over its hemisphere — the Lambertian BRDF whose direct term
    /// `albedo · e · cos θ` the model already uses (light colours are π × irradiance). Transparent
    /// surfaces between `y` and `x` attenuate it as they do shadow rays.
    OneBounce,
}

impl Indirect {
    pub fn name(&self) -> &'static str {
        match self {
            Indirect::None => "none",
            Indirect::OneBounce => "one-bounce",
        }
    }
}

/// A complete scene.
#[derive(Clone, Debug)]
pub struct Scene {
    pub name: String,
    pub image: ImageSettings,
    pub camera: Camera,
    pub objects: Vec<Object>,
    pub lights: Vec<Light>,
    pub environment: Environment,
}

impl Scene {
    pub fn triangle_count(&self) -> usize {
        self.objects.iter().map(|o| o.mesh.triangle_count()).sum()
    }
    /// A 64-bit FNV-1a fingerprint of everything that affects a rendered image — camera, lights,
    /// environment, and per object its transforms, material, mesh data and texture texels (not the
    /// scene's name or `[image]` settings): the key of cached references (`shutter quality`). Stable
    /// across runs and builds (floats are hashed by their bits).
    pub fn content_hash(&self) -> u64 {
        let mut h = Fnv1a::default();
        let lights: Vec<HashedLight> = self.lights.iter().map(HashedLight::from).collect();
        h.text(&format!("{:?}|{:?}|{:?}", self.camera, lights, self.environment));
        for o in &self.objects {
            let m = &o.material;
            // Open and close as before keys existed (so cached references of two-key scenes stay
            // valid), then any interior keys.
            let close = (o.transforms.len() > 1).then(|| o.transform_at_close());
            h.text(&format!(
                "{:?}|{:?}|{:?}|{}|{}|{}",
                o.transform_open(),
                close,
                m.albedo,
                m.specular,
                m.roughness,
                m.alpha
            ));
            // Only when not the defaults, so opaque scenes keep their hashes.
            if m.alpha_from_texture || m.tint != Vec3::ONE {
                h.text(&format!("{}|{:?}", m.alpha_from_texture, m.tint));
            }
            if m.one_sided {
                h.text("one-sided");
            }
            if o.transforms.len() > 2 {
                h.text(&format!("{:?}", &o.transforms[1..o.transforms.len() - 1]));
            }
            let mesh = &o.mesh;
            h.floats(mesh.positions.iter().flat_map(|p| p.to_array()));
            h.floats(mesh.normals.iter().flat_map(|p| p.to_array()));
            h.floats(mesh.uvs.iter().flat_map(|p| p.to_array()));
            h.bytes(mesh.indices.iter().flat_map(|i| i.to_le_bytes()));
            if let Some(t) = &m.texture {
                h.text(&format!("{}x{}", t.width, t.height));
                h.bytes(t.srgb_rgba8.iter().copied());
            }
        }
        h.0
    }
    /// Triangles skipped while cleaning meshes (zero-area, duplicate-vertex), summed over objects.
    pub fn skipped_triangles(&self) -> usize {
        self.objects.iter().map(|o| o.mesh.stats.skipped_degenerate).sum()
    }
    /// Per mesh that lost triangles while cleaning (zero-area, duplicate-vertex), how many, with the
    /// objects that use it (objects share a mesh loaded once), in object order: what the CLI reports.
    pub fn skipped_by_mesh(&self) -> Vec<SkippedTriangles> {
        let mut out: Vec<(&Arc<Mesh>, SkippedTriangles)> = Vec::new();
        for o in self.objects.iter().filter(|o| o.mesh.stats.skipped_degenerate > 0) {
            match out.iter_mut().find(|(m, _)| Arc::ptr_eq(m, &o.mesh)) {
                Some((_, s)) => s.objects.push(o.name.clone()),
                None => out.push((
                    &o.mesh,
                    SkippedTriangles {
                        objects: vec![o.name.clone()],
                        skipped: o.mesh.stats.skipped_degenerate,
                        kept: o.mesh.triangle_count(),
                    },
                )),
            }
        }
        out.into_iter().map(|(_, s)| s).collect()
    }
}

/// One mesh's triangles skipped while cleaning it ([`Scene::skipped_by_mesh`]).
#[derive(Clone, Debug, PartialEq, Eq)]
pub struct SkippedTriangles {
    /// The objects that use the mesh.
    pub objects: Vec<String>,
    /// Zero-area and duplicate-vertex triangles dropped.
    pub skipped: usize,
    /// Triangles rendered.
    pub kept: usize,
}

impl std::fmt::Display for SkippedTriangles {
    fn fmt(&self, f: &mut std::fmt::Formatter) -> std::fmt::Result {
        let names: Vec<String> = self.objects.iter().map(|n| format!("`{n}`")).collect();
        write!(
            f,
            "{} zero-area or duplicate-vertex triangle{} skipped in the mesh of object{} {} ({} kept)",
            self.skipped,
            if self.skipped == 1 { "" } else { "s" },
            if names.len() == 1 { "" } else { "s" },
            names.join(", "),
            self.kept
        )
    }
}

/// 64-bit FNV-1a.
struct Fnv1a(u64);

impl Default for Fnv1a {
    fn default() -> Self {
        Fnv1a(0xcbf2_9ce4_8422_2325)
    }
}

impl Fnv1a {
    fn bytes(&mut self, bytes: impl IntoIterator<Item = u8>) {
        for b in bytes {
            self.0 = (self.0 ^ b as u64).wrapping_mul(0x0100_0000_01b3);
        }
    }
    fn floats(&mut self, v: impl IntoIterator<Item = f32>) {
        self.bytes(v.into_iter().flat_map(|f| f.to_bits().to_le_bytes()));
    }
    fn text(&mut self, s: &str) {
        self.bytes(s.bytes());
        self.bytes([0xff]);
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    /// Cached references are keyed by the content hash: lights without spots or shadows, and opaque
    /// untinted materials, hash exactly as before those existed (the text the derived `Debug` of the
    /// old two-variant `Light` printed); anything new changes the hash.
    #[test]
    fn content_hash_keeps_old_scenes_and_sees_new_keys() {
        let lights = [
            Light::Directional { direction: -Vec3::Y, color: Vec3::ONE, shadows: false },
            Light::Point { position: Vec3::new(1.0, 2.0, 3.0), color: Vec3::splat(2.0), shadows: false },
        ];
        let text = format!("{:?}", lights.iter().map(HashedLight::from).collect::<Vec<_>>());
        assert_eq!(
            text,
            "[Directional { direction: Vec3(-0.0, -1.0, -0.0), color: Vec3(1.0, 1.0, 1.0) }, \
             Point { position: Vec3(1.0, 2.0, 3.0), color: Vec3(2.0, 2.0, 2.0) }]"
        );
        let base = builtin::builtin_scene("static").expect("built-in").expect("parses");
        let hash = base.content_hash();
        let changed = |edit: &dyn Fn(&mut Scene)| {
            let mut s = base.clone();
            edit(&mut s);
            s.content_hash() != hash
        };
        assert!(!changed(&|_| {}));
        assert!(changed(&|s| s.objects[0].material.tint = Vec3::new(1.0, 0.5, 1.0)));
        assert!(changed(&|s| s.objects[0].material.alpha_from_texture = true));
        assert!(changed(&|s| s.objects[0].material.one_sided = true));
        assert!(changed(&|s| {
            if let Some(Light::Directional { shadows, .. } | Light::Point { shadows, .. }) =
                s.lights.first_mut()
            {
                *shadows = true;
            }
        }));
    }
}
