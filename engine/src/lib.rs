//! # Shutter
//!
//! Renders what a real camera sees — depth of field and motion blur — by estimating the pixel integral
//! over pixel area (x,y), lens (u,v) and shutter time (t) with several techniques on raw Vulkan, and
//! measures each against a CPU distribution ray tracer of the same scene model (docs/MODEL.md).
//!
//! Data flows one way: [`scene`] → world and views ([`gpu`]) → plan ([`plan`]) → a frame graph of
//! passes ([`graph`], built by a technique: [`techniques`]) → image → metrics. `docs/ARCHITECTURE.md`
//! draws it.
//!
//! # Embedding
//!
//! An engine hands Shutter its own Vulkan device, records Shutter's frames into its own command
//! buffers and gets the result in its own image, to composite without a readback ([`embed`];
//! `docs/EMBEDDING.md`). Everything it needs is in [`prelude`]; [`glam`] and [`ash`] are
//! re-exported so it builds scenes and hands over handles of the very versions Shutter uses.
//!
//! ```no_run
//! use shutter::prelude::*;
//!
//! /// One frame of the engine: `cmd` is recording, `image` is a 160 × 90 `R8G8B8A8_SRGB` image with
//! /// `TRANSFER_DST` usage that the engine samples afterwards.
//! fn engine_frame(engine: ExternalDevice, cmd: vk::CommandBuffer, image: vk::Image) -> shutter::Result<()> {
//!     // SAFETY: the engine's handles are valid, what it lists as enabled was enabled, and they
//!     // outlive every Shutter object (borrowed: Shutter destroys nothing).
//!     let device = unsafe { ExternalDevice { ownership: Ownership::Borrowed, ..engine }.into_device()? };
//!     let mut renderer = Renderer::new(device)?;
//!
//!     // A scene in code: a ball moving across a 50 mm f/2 lens' plane of focus.
//!     let ball = std::sync::Arc::new(shutter::scene::builtin::builtin_mesh("sphere", None).expect("built-in")?);
//!     let camera = Camera::looking_at(Vec3::new(0.0, 1.0, 6.0), Vec3::new(0.0, 0.5, 0.0)).with_lens(50.0, 2.0, 24.0);
//!     let scene = Scene::new("embedded", camera)
//!         .with_image(160, 90, 16, 1)
//!         .with_object(
//!             Object::new("ball", ball, Mat4::from_translation(Vec3::new(-0.5, 0.5, 0.0)))
//!                 .moving_to(Mat4::from_translation(Vec3::new(0.5, 0.5, 0.0))),
//!         )
//!         .with_light(Light::Directional { direction: Vec3::new(-1.0, -1.0, -1.0), color: Vec3::ONE, shadows: false })
//!         .with_shutter_angle(180.0)?;
//!
//!     // Uploaded once (Shutter submits the uploads to the engine's queue and waits for them).
//!     let settings = RenderSettings::from_scene(&scene);
//!     let mut prepared = EmbeddedScene::prepare(&mut renderer, &scene, Technique::STOCHASTIC, &settings)?;
//!
//!     // Recorded into the engine's command buffer, ending in the engine's image, ready to sample.
//!     let target = FrameTarget {
//!         image,
//!         format: vk::Format::R8G8B8A8_SRGB,
//!         width: 160,
//!         height: 90,
//!         before: Access::Nothing,
//!         after: Access::FragmentShaderReadSampledImageOrUniformTexelBuffer,
//!     };
//!     // SAFETY: `cmd` is recording on the device's queue family; the engine submits it and retires
//!     // the frame only after its fence signals; `image` lives until then.
//!     let token = unsafe { prepared.record(cmd, &target)? };
//!     assert!(!token.passes().iter().any(|p| p == "readback"));
//!     // ... the engine ends `cmd`, submits it with its own work and a fence, waits for the fence ...
//!     prepared.retire(token)?;
//!     Ok(())
//! }
//! ```

pub mod calibration;
pub mod embed;
mod error;
pub mod geometry;
pub mod gpu;
pub mod graph;
pub mod hard_cases;
pub mod image;
pub mod image_io;
pub mod limits;
pub mod metrics;
pub mod mirror;
pub mod plan;
pub mod progress;
pub mod quality_plan;
pub mod reference;
pub mod sampling;
pub mod scene;
pub mod shading;
pub mod techniques;
pub mod tonemap;
pub mod transparency;
pub mod vk;

pub use error::{Error, Result};

/// What an engine embedding Shutter uses, in one import (`use shutter::prelude::*;`): the device
/// it lends ([`ExternalDevice`](crate::embed::ExternalDevice)), scenes built in code
/// ([`Scene`](crate::scene::Scene), [`Camera`](crate::scene::Camera), ...), the renderer and the
/// frames recorded into its command buffers ([`EmbeddedScene`](crate::embed::EmbeddedScene)), and
/// the `ash` and `glam` types they take.
pub mod prelude {
    #[doc(no_inline)]
    pub use crate::embed::{EmbeddedScene, ExternalDevice, FrameTarget, FrameToken, Ownership};
    #[doc(no_inline)]
    pub use crate::graph::Access;
    #[doc(no_inline)]
    pub use crate::image::LinearImage;
    #[doc(no_inline)]
    pub use crate::scene::{Camera, Environment, Light, Material, Mesh, Object, Scene};
    #[doc(no_inline)]
    pub use crate::techniques::{RenderSettings, Renderer, Technique};
    #[doc(no_inline)]
    pub use crate::vk::{Device, Feature};
    #[doc(no_inline)]
    pub use crate::{Error, Result};
    #[doc(no_inline)]
    pub use ash::vk;
    #[doc(no_inline)]
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
        /// A task shader (`VK_EXT_mesh_shader`'s `taskShader`): launches the mesh workgroups.
        Task,
        /// A mesh shader (`VK_EXT_mesh_shader`).
        Mesh,
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
