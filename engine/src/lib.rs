//! # Shutter
//!
//! Renders what a real camera sees — depth of field and motion blur — by estimating the pixel integral
//! over pixel area (x,y), lens (u,v) and shutter time (t) with several techniques on raw Vulkan, and
//! measures each against a CPU distribution ray tracer of the same scene model (DESIGN.md).
//!
//! Data flows one way: [`scene`] → [`scene::CameraSpaceScene`] → technique passes → image → metrics.

pub mod bounds;
pub mod error;
pub mod geometry;
pub mod image;
pub mod image_io;
pub mod limits;
pub mod metrics;
pub mod plan;
pub mod reference;
pub mod sampling;
pub mod scene;
pub mod shading;
pub mod techniques;
pub mod vk;

pub use error::{Error, Result};

/// SPIR-V compiled from `shaders-glsl/` by `build.rs`, one constant per named permutation.
pub mod shaders {
    /// Pipeline stage of a compiled shader.
    #[derive(Clone, Copy, Debug, PartialEq, Eq)]
    pub enum ShaderStage {
        Vertex,
        Geometry,
        Fragment,
        Compute,
    }
    /// One compiled permutation of one GLSL stage file.
    #[derive(Clone, Copy, Debug)]
    pub struct ShaderSource {
        /// Path under `shaders-glsl/`.
        pub file: &'static str,
        pub permutation: &'static str,
        pub stage: ShaderStage,
        pub defines: &'static [&'static str],
        /// SPIR-V bytes (little-endian words).
        pub spirv: &'static [u8],
    }
    include!(concat!(env!("OUT_DIR"), "/shaders.rs"));
}
