//! # Shutter
//!
//! Renders what a real camera sees — depth of field and motion blur — by estimating the pixel integral
//! over pixel area (x,y), lens (u,v) and shutter time (t) with several techniques on raw Vulkan, and
//! measures each against a CPU distribution ray tracer of the same scene model (docs/MODEL.md).
//!
//! Data flows one way: [`scene`] → world and views ([`gpu`]) → plan ([`plan`]) → a frame graph of
//! passes ([`graph`], built by a technique: [`techniques`]) → image → metrics. `docs/ARCHITECTURE.md`
//! draws it.

pub mod aas;
pub mod bounds;
pub mod calibration;
pub mod decoupled;
pub mod embed;
pub mod error;
pub mod geometry;
pub mod gpu;
pub mod graph;
pub mod hard_cases;
pub mod image;
pub mod image_io;
pub mod interleaved;
pub mod limits;
pub mod metrics;
pub mod plan;
pub mod progress;
pub mod quality_plan;
pub mod reference;
pub mod sampling;
pub mod scene;
pub mod shading;
pub mod shadows;
pub mod techniques;
pub mod texture_space;
pub mod transparency;
pub mod vk;

pub use error::{Error, Result};

/// What an engine embedding Shutter uses, in one import (`use shutter::prelude::*;`): the device
/// it lends ([`ExternalDevice`](crate::embed::ExternalDevice)), scenes built in code
/// ([`Scene`](crate::scene::Scene), [`Camera`](crate::scene::Camera), ...), the renderer and the
/// frames recorded into its command buffers ([`EmbeddedScene`](crate::embed::EmbeddedScene)), and
/// the `ash` and `glam` types they take.
pub mod prelude {
    pub use crate::embed::{EmbeddedScene, ExternalDevice, FrameTarget, FrameToken, Ownership};
    pub use crate::graph::Access;
    pub use crate::image::LinearImage;
    pub use crate::scene::{Camera, Environment, Light, Material, Mesh, Object, Scene};
    pub use crate::techniques::{RenderSettings, Renderer, Technique};
    pub use crate::vk::{Device, Feature};
    pub use crate::{Error, Result};
    pub use ash::vk;
    pub use glam::{Mat4, Quat, Vec3};
}

/// The `ash` Shutter is built on: an embedding engine hands Shutter handles of this very version.
pub use ash;
/// The math types of Shutter's scene model (`Vec3`, `Mat4`, ...), re-exported so a dependent crate
/// builds scenes without pinning `glam` itself.
pub use glam;

#[cfg(test)]
mod shaders_tests;

/// SPIR-V compiled from `shaders-glsl/` by `build.rs`, every permutation declared by the axes of
/// `shaders-glsl/permutations.toml`.
///
/// Pick a permutation with the key struct of its file — one field per axis, enum axes are
/// [`shaders::axes`] enums, bool axes `bool` — or by its constant (file path plus the non-default axis
/// values, in axis order). [`shaders::FILES`] lists every file's permutations, [`shaders::ALL`] all of
/// them.
///
/// ```
/// use shutter::shaders::{self, axes::{Effects, Hull, TransparencyPass}, StochasticFrag};
/// let key = StochasticFrag {
///     hull: Hull::Compute,
///     instrumented: false,
///     effects: Effects::Defocus,
///     transparency_pass: TransparencyPass::Coverage,
/// };
/// let source = key.source();
/// assert_eq!(source.permutation, "COMPUTE_HULL_DEFOCUS");
/// assert_eq!(source.defines, ["COMPUTE_HULL", "NO_MOTION"]);
/// let by_name = shaders::STOCHASTIC_STOCHASTIC_FRAG_COMPUTE_HULL_DEFOCUS;
/// assert_eq!(source.spirv, by_name.spirv);
/// ```
///
/// A value the axis does not have, or an axis the file does not have, fails to compile:
///
/// ```compile_fail
/// use shutter::shaders::{axes::Effects, ExpandComp};
/// let _ = ExpandComp { effects: Effects::Pinhole }.source();
/// ```
///
/// ```compile_fail
/// use shutter::shaders::{axes::Shading, ExpandComp};
/// let _ = ExpandComp { shading: Shading::PerSample, ..Default::default() }.source();
/// ```
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
        /// `DEFAULT`, or the suffixes of its non-default axis values joined by `_` (`PER_SAMPLE_DEFOCUS`).
        pub permutation: &'static str,
        pub stage: ShaderStage,
        /// The defines of its axis values, in axis order (`NAME` or `NAME=VALUE`; `STAGE_*` not listed).
        pub defines: &'static [&'static str],
        /// `(axis, value)` for every axis of its file, in axis order: `("effects", "defocus")`,
        /// `("instrumented", "true")`.
        pub axis_values: &'static [(&'static str, &'static str)],
        /// SPIR-V bytes (little-endian words).
        pub spirv: &'static [u8],
    }
    /// One stage file under `shaders-glsl/` and every permutation compiled from it.
    #[derive(Clone, Copy, Debug)]
    pub struct StageFile {
        /// Path under `shaders-glsl/`.
        pub file: &'static str,
        /// Its axes, in axis order (empty: one permutation, `DEFAULT`).
        pub axes: &'static [&'static str],
        /// The product of its axes, the first axis slowest.
        pub permutations: &'static [ShaderSource],
    }
    include!(concat!(env!("OUT_DIR"), "/shaders.rs"));
}
