//! The Vulkan layer: one file per concern, small safe helpers over raw `ash`. Techniques touch Vulkan
//! only through these.
//!
//! - `context`: instance, device choice, validation messenger, [`Capabilities`]
//! - `drivers`: the drivers Shutter can run on (the system's and the project's), their names
//! - `memory`: buffers (gpu-allocator); `image`: images, views, samplers, barriers
//! - `pipeline`: shader modules, descriptor layouts/pools/writes, pipeline layouts and pipelines
//! - `commands`: record-submit-wait; `queries`: named GPU timestamps; `transfer`: uploads and readback

mod commands;
mod context;
pub mod drivers;
mod image;
mod memory;
mod pipeline;
mod queries;
mod transfer;

pub use commands::{atlas_square, compute_write_barrier, image_barriers, set_viewport, CommandRecorder};
pub use context::{
    available_drivers, parse_env_flag, Capabilities, Device, DeviceDesc, DeviceShared, DriverSummary,
    ExternalDevice, Feature, Ownership, ValidationReport,
};
pub use image::{aspect_of, barrier, Image, ImageDesc, Sampler};
pub use memory::Buffer;
pub use pipeline::{
    statically_used_descriptors, write_descriptors, Binding, ColorBlend, DescriptorPool, DescriptorRef,
    DescriptorRefs, DescriptorSetLayout, DescriptorWrite, Faces, GraphicsDesc, Pipeline, PipelineLayout,
    PipelineStore, ShaderModule,
};
pub use queries::{
    statistic_flags, GpuTimer, MeshStatistics, PassTimings, PipelineStatistics, StatisticsQuery,
};
pub use transfer::{read_rgba32f, srgb_mip_chain, upload_texture};

/// Creates the device as the environment says (`SHUTTER_DRIVER`, `SHUTTER_DEVICE`, `SHUTTER_VALIDATION`,
/// `SHUTTER_SYNC_VALIDATION`).
pub fn create_device() -> crate::Result<Device> {
    DeviceShared::new(&DeviceDesc::from_env()?)
}
