//! The scene model: what is rendered, independent of any technique.
//!
//! A [`Scene`] is fully resolved (meshes loaded and cleaned, textures decoded, transforms as matrices);
//! `file.rs` builds one from TOML, `builtin.rs` holds the embedded scenes and procedural meshes.
//! `camera_space.rs` turns it into the camera-space, linear-in-time form every technique and the CPU
//! reference consume (DESIGN.md "Shutter").

pub mod builtin;
pub mod camera;
pub mod camera_space;
pub mod file;
pub mod mesh;
pub mod texture;
pub mod view;

use std::sync::Arc;

use glam::{Mat4, Vec3};

pub use camera::{Camera, CameraPose, Intrinsics};
pub use camera_space::{CameraSpaceLight, CameraSpaceScene, ObjectMotion};
pub use mesh::{Mesh, MeshStats};
pub use texture::Texture;
pub use view::{Projection, View};

/// Output image settings.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub struct ImageSettings {
    pub width: u32,
    pub height: u32,
    /// Samples per pixel (meaning depends on the technique: passes for accumulation, rays for the
    /// reference).
    pub spp: u32,
    pub seed: u64,
}

/// Surface description of the one shading model (DESIGN.md "Shading").
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
    /// Coverage, 0..1. Techniques without transparency reject alpha < 1 with a clear error.
    pub alpha: f32,
}

impl Default for Material {
    fn default() -> Self {
        Material { albedo: Vec3::splat(0.8), texture: None, specular: 0.0, roughness: 0.5, alpha: 1.0 }
    }
}

/// One placed mesh and how it moves over the shutter.
#[derive(Clone, Debug)]
pub struct Object {
    pub name: String,
    pub mesh: Arc<Mesh>,
    /// Object → world transform keys `(shutter time, transform)`: times strictly increasing from 0;
    /// one key (at 0) for an object that does not move, otherwise the last at 1. Between keys the
    /// motion is linear in camera space (DESIGN.md "Shutter"), so a rotation takes several keys
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

/// Light sources (world space). Directional `direction` points *from* the light into the scene.
#[derive(Clone, Copy, Debug, PartialEq)]
pub enum Light {
    Directional { direction: Vec3, color: Vec3 },
    Point { position: Vec3, color: Vec3 },
}

#[derive(Clone, Copy, Debug, PartialEq)]
pub struct Environment {
    /// Constant ambient light, multiplied by albedo.
    pub ambient: Vec3,
    /// Colour of pixels that see no geometry (linear).
    pub background: Vec3,
}

impl Default for Environment {
    fn default() -> Self {
        Environment { ambient: Vec3::splat(0.05), background: Vec3::ZERO }
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
        h.text(&format!("{:?}|{:?}|{:?}", self.camera, self.lights, self.environment));
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
