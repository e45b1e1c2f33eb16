//! The scene on the GPU, split by what it depends on (docs/MODEL.md "A frame, as data"):
//!
//! * [`GpuWorld`] — uploaded once per scene and shared by every view: meshes in object space,
//!   materials, textures, the environment;
//! * [`GpuView`] — one per view (the camera; a light's shadow-map view): the view's uniforms
//!   (viewport, lens or orthographic extent, depth range, lights in its space) and every object's
//!   transform into it at shutter open and close.
//!
//! [`layout`] holds every CPU/GLSL-shared struct and the descriptor-set numbering.

pub mod layout;
#[cfg(test)]
mod layout_tests;
mod view;
mod world;

pub use view::{object_view_records, view_uniforms, GpuView};
pub use world::{scene_stages, GpuObject, GpuWorld, SCENE_STAGES};
