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

use std::sync::Arc;

use glam::{Mat4, Vec3};

pub use camera::{Camera, CameraPose, Intrinsics};
pub use camera_space::{CameraSpaceLight, CameraSpaceScene, ObjectMotion};
pub use mesh::{Mesh, MeshStats};
pub use texture::Texture;

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

/// One placed mesh. `transform_close` is the object-to-world transform at shutter close (None: still).
#[derive(Clone, Debug)]
pub struct Object {
    pub name: String,
    pub mesh: Arc<Mesh>,
    pub transform_open: Mat4,
    pub transform_close: Option<Mat4>,
    pub material: Material,
}

impl Object {
    pub fn transform_at_close(&self) -> Mat4 {
        self.transform_close.unwrap_or(self.transform_open)
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
    /// Triangles skipped while cleaning meshes (zero-area, duplicate-vertex), summed over objects.
    pub fn skipped_triangles(&self) -> usize {
        self.objects.iter().map(|o| o.mesh.stats.skipped_degenerate).sum()
    }
}
