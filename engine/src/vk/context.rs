//! Headless instance and device: one owner ([`Device`], an `Arc`), validation with a counting
//! messenger, device choice, capabilities.
//!
//! Safety contract of this layer: every GPU submission is waited on before the call that made it
//! returns (see `commands.rs`), so an RAII wrapper may destroy its handle in `Drop` at any time the
//! CPU holds it — nothing is in flight. The [`DeviceShared`] outlives every wrapper because each holds
//! an `Arc` to it.

use std::ffi::{c_void, CStr, CString};
use std::mem::ManuallyDrop;
use std::sync::atomic::{AtomicU32, Ordering};
use std::sync::{Arc, Mutex};

use ash::vk;
use gpu_allocator::vulkan::{Allocator, AllocatorCreateDesc};

use crate::error::{Error, Result, VkContext};

const VALIDATION_LAYER: &CStr = c"VK_LAYER_KHRONOS_validation";

/// How to create the device. [`DeviceDesc::from_env`] reads `SHUTTER_DRIVER`, `SHUTTER_DEVICE`,
/// `SHUTTER_VALIDATION` and `SHUTTER_SYNC_VALIDATION`.
///
/// Without a driver or device named, the device is the best by type (a discrete GPU before an
/// integrated one before the CPU) and, among equals, the newest driver: on a machine with both
/// lavapipes, the current one (it is what users' CI machines run, and it is faster).
#[derive(Clone, Debug, Default)]
pub struct DeviceDesc {
    /// Only drivers this names ([`super::drivers::driver_matches`]: `lavapipe-25.0`, `lavapipe`,
    /// `nvidia-h200`); None: any.
    pub driver: Option<String>,
    /// Pick the first device whose name contains this (case-insensitive); None: best by type.
    pub device_name: Option<String>,
    /// Enable the Khronos validation layer and the counting messenger.
    pub validation: bool,
    /// Also enable synchronization validation (slow).
    pub sync_validation: bool,
    /// Features to treat as absent although the device offers them (`SHUTTER_DISABLE`, the CLI's
    /// `--disable`): they are neither enabled on the device nor reported in its [`Capabilities`], so
    /// every technique takes the path it takes on a device without them — or refuses, naming them.
    pub disabled: Vec<Feature>,
}

impl DeviceDesc {
    /// Validation defaults to on in debug builds (and therefore in tests), off in release builds;
    /// `SHUTTER_VALIDATION` overrides it ([`parse_env_flag`]: `1`/`0`, `true`/`false`, `on`/`off`,
    /// `yes`/`no`; anything else is an error).
    pub fn from_env() -> Result<Self> {
        let flag = |name: &'static str| -> Result<Option<bool>> {
            match std::env::var(name) {
                Ok(v) => parse_env_flag(name, &v),
                Err(std::env::VarError::NotPresent) => Ok(None),
                Err(std::env::VarError::NotUnicode(v)) => Err(Error::Environment {
                    name,
                    value: v.to_string_lossy().into_owned(),
                    expected: ENV_FLAG_VALUES,
                }),
            }
        };
        Ok(DeviceDesc {
            driver: std::env::var("SHUTTER_DRIVER").ok().filter(|s| !s.is_empty()),
            device_name: std::env::var("SHUTTER_DEVICE").ok().filter(|s| !s.is_empty()),
            validation: flag("SHUTTER_VALIDATION")?.unwrap_or(cfg!(debug_assertions)),
            sync_validation: flag("SHUTTER_SYNC_VALIDATION")?.unwrap_or(false),
            disabled: match std::env::var("SHUTTER_DISABLE") {
                Ok(v) => Feature::parse_list(&v).map_err(|_| Error::Environment {
                    name: "SHUTTER_DISABLE",
                    value: v.clone(),
                    expected: FEATURE_KEYS,
                })?,
                Err(_) => Vec::new(),
            },
        })
    }
}

const ENV_FLAG_VALUES: &str = "1, true, on or yes to turn it on; 0, false, off or no to turn it off";

/// An on/off environment variable's value, case-insensitive: `1`/`true`/`on`/`yes` or
/// `0`/`false`/`off`/`no`; empty is unset (None); anything else is an error naming the variable.
pub fn parse_env_flag(name: &'static str, value: &str) -> Result<Option<bool>> {
    match value.trim().to_ascii_lowercase().as_str() {
        "" => Ok(None),
        "1" | "true" | "on" | "yes" => Ok(Some(true)),
        "0" | "false" | "off" | "no" => Ok(Some(false)),
        _ => Err(Error::Environment { name, value: value.to_string(), expected: ENV_FLAG_VALUES }),
    }
}

/// What the chosen device can do, queried once.
#[derive(Clone, Debug, serde::Serialize)]
pub struct Capabilities {
    pub device_name: String,
    pub device_type: String,
    pub driver_name: String,
    pub driver_info: String,
    /// `VkDriverId`, e.g. `MESA_LLVMPIPE` (lavapipe).
    pub driver_id: String,
    /// The driver's version from its `driverInfo`, e.g. `25.0.7` ([`super::drivers::driver_version`]).
    pub driver_version: String,
    /// Shutter's name for the driver, e.g. `lavapipe-25.0` ([`super::drivers::driver_key`]): what
    /// `--driver` takes and every report records.
    pub driver_key: String,
    /// The project's driver folder this device came from (`lavapipe-25.0.7`), or None for a system one.
    pub project_driver: Option<String>,
    /// `VK_EXT_mesh_shader` with its `meshShader` feature (the stochastic rasterizer's `--hull mesh`).
    pub mesh_shader: bool,
    /// `maxMeshWorkGroupCount` and `maxMeshWorkGroupTotalCount` (zero without mesh shaders).
    pub max_mesh_work_group_count: [u32; 3],
    pub max_mesh_work_group_total_count: u32,
    /// `taskShader` of `VK_EXT_mesh_shader` beside `meshShader` (`--hull mesh-task`: a task shader
    /// culls clusters of triangles ahead of the mesh shader's bounds).
    pub task_shader: bool,
    /// `maxTaskWorkGroupCount` and `maxTaskWorkGroupTotalCount` (zero without task shaders).
    pub max_task_work_group_count: [u32; 3],
    pub max_task_work_group_total_count: u32,
    /// `meshShaderQueries` of `VK_EXT_mesh_shader` (with `pipelineStatisticsQuery`): an instrumented
    /// frame's statistics count task and mesh shader invocations around mesh draws.
    pub mesh_shader_queries: bool,
    pub api_version: String,
    /// MSAA sample counts usable for colour *and* depth attachments.
    pub framebuffer_sample_counts: Vec<u32>,
    pub geometry_shader: bool,
    /// `shaderClipDistance`: user clip planes (`gl_ClipDistance`).
    pub clip_distance: bool,
    pub sample_rate_shading: bool,
    /// `independentBlend`: colour attachments of one pipeline blended (or write-masked) differently.
    pub independent_blend: bool,
    pub fragment_stores_and_atomics: bool,
    /// Stores from vertex/geometry stages (the bound readback test's debug output).
    pub vertex_pipeline_stores_and_atomics: bool,
    pub conservative_rasterization: bool,
    /// `VkPhysicalDeviceConservativeRasterizationPropertiesEXT` (zeros without the extension): how
    /// far the overestimating rasterizer may grow a primitive on its own, the most extra it may be
    /// asked for, px, and whether it keeps degenerate triangles ([`Capabilities::overestimation`]).
    pub primitive_overestimation_px: f32,
    pub max_extra_primitive_overestimation_px: f32,
    pub degenerate_triangles_rasterized: bool,
    /// `shaderInt64` and `shaderBufferInt64Atomics`: 64-bit atomics on storage buffers (the stochastic
    /// visibility buffer packs a sample's depth and payload into one `atomicMax`).
    pub buffer_int64_atomics: bool,
    /// `shaderInt64`: 64-bit integers in shaders, without atomics (the stochastic shading stages read
    /// the visibility buffer's words; the mask coverage path fills it without atomics).
    pub shader_int64: bool,
    pub max_geometry_output_vertices: u32,
    pub max_geometry_total_output_components: u32,
    pub max_push_constants_size: u32,
    /// Largest range one storage-buffer descriptor may cover, bytes.
    pub max_storage_buffer_range: u32,
    /// Largest range one uniform-buffer descriptor may cover, bytes (the view's uniforms hold
    /// `MAX_LIGHTS` lights).
    pub max_uniform_buffer_range: u32,
    /// MSAA samples sit at the standard sample locations of the Vulkan spec.
    pub standard_sample_locations: bool,
    /// `SAMPLED_IMAGE_FILTER_LINEAR` for optimal-tiling `R32G32B32A32_SFLOAT` (optional in Vulkan):
    /// the interleaved blur's hardware-sampled pairs.
    pub linear_filter_rgba32f: bool,
    /// `subTexelPrecisionBits`: the fraction bits of a linear filter's weights (≥ 4; 8 on lavapipe).
    pub sub_texel_precision_bits: u32,
    pub max_image_dimension_2d: u32,
    /// `maxBoundDescriptorSets` (shadow maps use set 4).
    pub max_bound_descriptor_sets: u32,
    /// Timestamps usable on the graphics queue.
    pub timestamps: bool,
    /// `pipelineStatisticsQuery`: the device's own counters of an instrumented frame
    /// ([`crate::vk::PipelineStatistics`]).
    pub pipeline_statistics: bool,
    /// Nanoseconds per timestamp tick.
    pub timestamp_period_ns: f32,
    pub debug_utils: bool,
    /// What [`DeviceDesc::disabled`] turned off although the device offers it (keys, as given).
    pub disabled: Vec<String>,
}

/// A device capability a technique may depend on.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub enum Feature {
    GeometryShader,
    ClipDistance,
    SampleRateShading,
    IndependentBlend,
    FragmentStoresAndAtomics,
    VertexPipelineStoresAndAtomics,
    ConservativeRasterization,
    /// `VK_EXT_mesh_shader` (`meshShader`); disabling it disables [`Feature::TaskShader`].
    MeshShader,
    /// `VK_EXT_mesh_shader`'s `taskShader`.
    TaskShader,
    BufferInt64Atomics,
    /// 64-bit integers in shaders (`shaderInt64`); disabling it disables [`Feature::BufferInt64Atomics`].
    ShaderInt64,
    TimestampQueries,
    /// Linear filtering of `R32G32B32A32_SFLOAT` images.
    LinearFilterRgba32f,
    /// MSAA with this many samples for colour and depth.
    Msaa(u32),
}

/// Every feature's key, for messages: what `--disable` and `SHUTTER_DISABLE` take.
pub const FEATURE_KEYS: &str =
    "a comma-separated list of geometry-shader, clip-distance, sample-rate-shading, \
     independent-blend, fragment-stores-and-atomics, vertex-pipeline-stores-and-atomics, \
     conservative-rasterization, mesh-shader, task-shader, buffer-int64-atomics, shader-int64, timestamp-queries, linear-filter-rgba32f, msaa-N \
     (N = 2, 4, 8, ...)";

impl Feature {
    /// Every feature but MSAA, whose counts are [`Feature::Msaa`]'s.
    pub const FLAGS: [Feature; 13] = [
        Feature::GeometryShader,
        Feature::ClipDistance,
        Feature::SampleRateShading,
        Feature::IndependentBlend,
        Feature::FragmentStoresAndAtomics,
        Feature::VertexPipelineStoresAndAtomics,
        Feature::ConservativeRasterization,
        Feature::MeshShader,
        Feature::TaskShader,
        Feature::BufferInt64Atomics,
        Feature::ShaderInt64,
        Feature::TimestampQueries,
        Feature::LinearFilterRgba32f,
    ];

    /// Its key on the command line and in `SHUTTER_DISABLE` (`geometry-shader`, `msaa-4`).
    pub fn key(&self) -> String {
        match self {
            Feature::GeometryShader => "geometry-shader".into(),
            Feature::ClipDistance => "clip-distance".into(),
            Feature::SampleRateShading => "sample-rate-shading".into(),
            Feature::IndependentBlend => "independent-blend".into(),
            Feature::FragmentStoresAndAtomics => "fragment-stores-and-atomics".into(),
            Feature::VertexPipelineStoresAndAtomics => "vertex-pipeline-stores-and-atomics".into(),
            Feature::ConservativeRasterization => "conservative-rasterization".into(),
            Feature::MeshShader => "mesh-shader".into(),
            Feature::TaskShader => "task-shader".into(),
            Feature::BufferInt64Atomics => "buffer-int64-atomics".into(),
            Feature::ShaderInt64 => "shader-int64".into(),
            Feature::TimestampQueries => "timestamp-queries".into(),
            Feature::LinearFilterRgba32f => "linear-filter-rgba32f".into(),
            Feature::Msaa(n) => format!("msaa-{n}"),
        }
    }

    /// `a,b c` (commas or spaces; empty: none) into features, refusing an unknown key by name.
    pub fn parse_list(list: &str) -> std::result::Result<Vec<Feature>, String> {
        list.split([',', ' ']).filter(|k| !k.is_empty()).map(str::parse).collect()
    }

    /// The name Vulkan gives it.
    pub fn vulkan_name(&self) -> String {
        match self {
            Feature::GeometryShader => "geometryShader".into(),
            Feature::ClipDistance => "shaderClipDistance".into(),
            Feature::SampleRateShading => "sampleRateShading".into(),
            Feature::IndependentBlend => "independentBlend".into(),
            Feature::FragmentStoresAndAtomics => "fragmentStoresAndAtomics".into(),
            Feature::VertexPipelineStoresAndAtomics => "vertexPipelineStoresAndAtomics".into(),
            Feature::ConservativeRasterization => "VK_EXT_conservative_rasterization".into(),
            Feature::MeshShader => "VK_EXT_mesh_shader (meshShader)".into(),
            Feature::TaskShader => "VK_EXT_mesh_shader (taskShader)".into(),
            Feature::BufferInt64Atomics => "shaderInt64 and shaderBufferInt64Atomics".into(),
            Feature::ShaderInt64 => "shaderInt64".into(),
            Feature::TimestampQueries => "timestampComputeAndGraphics".into(),
            Feature::LinearFilterRgba32f => {
                "VK_FORMAT_FEATURE_SAMPLED_IMAGE_FILTER_LINEAR_BIT for R32G32B32A32_SFLOAT".into()
            }
            Feature::Msaa(n) => {
                format!("{n}x MSAA (framebufferColorSampleCounts & framebufferDepthSampleCounts)")
            }
        }
    }
}

impl std::str::FromStr for Feature {
    type Err = String;
    fn from_str(key: &str) -> std::result::Result<Self, String> {
        if let Some(n) = key.strip_prefix("msaa-") {
            return match n.parse::<u32>() {
                Ok(n) if n >= 2 && n.is_power_of_two() => Ok(Feature::Msaa(n)),
                _ => Err(format!("`{key}`: MSAA counts are 2, 4, 8, ... (one sample cannot be disabled)")),
            };
        }
        Feature::FLAGS
            .into_iter()
            .find(|f| f.key() == key)
            .ok_or_else(|| format!("`{key}` is not a feature: {FEATURE_KEYS}"))
    }
}

impl Capabilities {
    /// Treats `feature` as absent (the device is then created without it): what `--disable` does.
    /// Disabling MSAA n also disables every higher count (a technique asks for the largest count
    /// not above what it wants, [`Capabilities::msaa_samples`]).
    pub fn disable(&mut self, feature: Feature) {
        if self.has(feature) {
            self.disabled.push(feature.key());
        }
        match feature {
            Feature::GeometryShader => self.geometry_shader = false,
            Feature::ClipDistance => self.clip_distance = false,
            Feature::SampleRateShading => self.sample_rate_shading = false,
            Feature::IndependentBlend => self.independent_blend = false,
            Feature::FragmentStoresAndAtomics => self.fragment_stores_and_atomics = false,
            Feature::VertexPipelineStoresAndAtomics => self.vertex_pipeline_stores_and_atomics = false,
            Feature::ConservativeRasterization => self.conservative_rasterization = false,
            Feature::MeshShader => {
                if self.task_shader {
                    self.disable(Feature::TaskShader);
                }
                self.mesh_shader = false;
                self.mesh_shader_queries = false;
            }
            Feature::TaskShader => self.task_shader = false,
            Feature::BufferInt64Atomics => self.buffer_int64_atomics = false,
            Feature::ShaderInt64 => {
                if self.buffer_int64_atomics {
                    self.disable(Feature::BufferInt64Atomics);
                }
                self.shader_int64 = false
            }
            Feature::TimestampQueries => self.timestamps = false,
            Feature::LinearFilterRgba32f => self.linear_filter_rgba32f = false,
            Feature::Msaa(n) => self.framebuffer_sample_counts.retain(|&c| c < n),
        }
    }

    /// The rasterizer's overestimation, where the device offers `VK_EXT_conservative_rasterization`
    /// and it is not disabled: what [`crate::mirror::conservative::choose`] selects the hulls'
    /// dilation by.
    pub fn overestimation(&self) -> Option<crate::mirror::conservative::Overestimation> {
        self.conservative_rasterization.then_some(crate::mirror::conservative::Overestimation {
            primitive_px: self.primitive_overestimation_px,
            max_extra_px: self.max_extra_primitive_overestimation_px,
            degenerate_triangles_rasterized: self.degenerate_triangles_rasterized,
        })
    }

    /// Mesa's software rasterizer (lavapipe, device name "llvmpipe").
    pub fn is_lavapipe(&self) -> bool {
        self.driver_id == format!("{:?}", vk::DriverId::MESA_LLVMPIPE)
    }

    pub fn has(&self, feature: Feature) -> bool {
        match feature {
            Feature::GeometryShader => self.geometry_shader,
            Feature::ClipDistance => self.clip_distance,
            Feature::SampleRateShading => self.sample_rate_shading,
            Feature::IndependentBlend => self.independent_blend,
            Feature::FragmentStoresAndAtomics => self.fragment_stores_and_atomics,
            Feature::VertexPipelineStoresAndAtomics => self.vertex_pipeline_stores_and_atomics,
            Feature::ConservativeRasterization => self.conservative_rasterization,
            Feature::MeshShader => self.mesh_shader,
            Feature::TaskShader => self.task_shader,
            Feature::BufferInt64Atomics => self.buffer_int64_atomics,
            Feature::ShaderInt64 => self.shader_int64,
            Feature::TimestampQueries => self.timestamps,
            Feature::LinearFilterRgba32f => self.linear_filter_rgba32f,
            Feature::Msaa(n) => self.framebuffer_sample_counts.contains(&n),
        }
    }

    /// `Err(Error::MissingFeature)` naming the device, the feature and who needs it.
    pub fn require(&self, feature: Feature, needed_by: &str) -> Result<()> {
        if self.has(feature) {
            return Ok(());
        }
        Err(Error::MissingFeature {
            device: self.device_name.clone(),
            feature: feature.vulkan_name(),
            needed_by: needed_by.to_string(),
        })
    }

    /// Largest supported MSAA count not above `wanted`.
    pub fn msaa_samples(&self, wanted: u32) -> u32 {
        self.framebuffer_sample_counts.iter().copied().filter(|&s| s <= wanted).max().unwrap_or(1)
    }
}

impl std::fmt::Display for Capabilities {
    fn fmt(&self, f: &mut std::fmt::Formatter<'_>) -> std::fmt::Result {
        writeln!(f, "device            {} ({})", self.device_name, self.device_type)?;
        writeln!(f, "driver            {} — {} ({})", self.driver_name, self.driver_info, self.driver_id)?;
        writeln!(
            f,
            "driver name       {} ({})",
            self.driver_key,
            self.project_driver
                .as_deref()
                .map_or("system ICD".to_string(), |p| format!("project driver .drivers/{p}"))
        )?;
        if self.is_lavapipe() {
            writeln!(f, "                  Mesa lavapipe: software Vulkan on the CPU (Shutter's CI target)")?;
        }
        writeln!(f, "api version       {}", self.api_version)?;
        writeln!(f, "MSAA counts       {:?}", self.framebuffer_sample_counts)?;
        writeln!(f, "geometry shader   {}", self.geometry_shader)?;
        writeln!(f, "clip distance     {}", self.clip_distance)?;
        writeln!(
            f,
            "  GS output       {} vertices, {} components",
            self.max_geometry_output_vertices, self.max_geometry_total_output_components
        )?;
        writeln!(f, "sample-rate shading {}", self.sample_rate_shading)?;
        writeln!(f, "independent blend {}", self.independent_blend)?;
        writeln!(f, "fragment stores/atomics {}", self.fragment_stores_and_atomics)?;
        writeln!(f, "vertex-pipeline stores/atomics {}", self.vertex_pipeline_stores_and_atomics)?;
        writeln!(f, "VK_EXT_conservative_rasterization {}", self.conservative_rasterization)?;
        if let Some(o) = self.overestimation() {
            writeln!(
                f,
                "  overestimation  {} px (extra up to {} px), degenerate triangles rasterized {}",
                o.primitive_px, o.max_extra_px, o.degenerate_triangles_rasterized
            )?;
        }
        writeln!(
            f,
            "VK_EXT_mesh_shader {} (task shaders {}, mesh shader queries {})",
            self.mesh_shader, self.task_shader, self.mesh_shader_queries
        )?;
        writeln!(f, "64-bit buffer atomics {}", self.buffer_int64_atomics)?;
        writeln!(f, "64-bit shader integers {}", self.shader_int64)?;
        writeln!(f, "push constants    {} bytes", self.max_push_constants_size)?;
        writeln!(f, "storage buffer range {} bytes", self.max_storage_buffer_range)?;
        writeln!(f, "max image 2D      {}", self.max_image_dimension_2d)?;
        writeln!(f, "timestamps        {} ({} ns/tick)", self.timestamps, self.timestamp_period_ns)?;
        if !self.disabled.is_empty() {
            writeln!(
                f,
                "disabled          {} (offered; --disable / SHUTTER_DISABLE)",
                self.disabled.join(", ")
            )?;
        }
        write!(f, "debug utils       {}", self.debug_utils)
    }
}

/// Validation messages seen so far (warnings and errors; info/verbose are ignored).
#[derive(Default)]
struct ValidationLog {
    errors: AtomicU32,
    warnings: AtomicU32,
    first: Mutex<Option<String>>,
}

/// Counts of validation messages since the device was created.
#[derive(Clone, Debug, Default, PartialEq, Eq)]
pub struct ValidationReport {
    pub errors: u32,
    pub warnings: u32,
    pub first: Option<String>,
}

unsafe extern "system" fn debug_callback(
    severity: vk::DebugUtilsMessageSeverityFlagsEXT,
    _types: vk::DebugUtilsMessageTypeFlagsEXT,
    data: *const vk::DebugUtilsMessengerCallbackDataEXT<'_>,
    user: *mut c_void,
) -> vk::Bool32 {
    // SAFETY: `user` is the `ValidationLog` boxed inside `DeviceShared`, alive until the messenger is
    // destroyed; `data` is valid for the duration of the callback (Vulkan spec).
    let log = unsafe { &*(user as *const ValidationLog) };
    let msg = unsafe { data.as_ref() }
        .and_then(|d| (!d.p_message.is_null()).then(|| unsafe { CStr::from_ptr(d.p_message) }))
        .map(|m| m.to_string_lossy().into_owned())
        .unwrap_or_default();
    let counter = if severity.contains(vk::DebugUtilsMessageSeverityFlagsEXT::ERROR) {
        &log.errors
    } else if severity.contains(vk::DebugUtilsMessageSeverityFlagsEXT::WARNING) {
        &log.warnings
    } else {
        return vk::FALSE;
    };
    counter.fetch_add(1, Ordering::Relaxed);
    eprintln!("[vulkan validation] {msg}");
    if let Ok(mut first) = log.first.lock() {
        first.get_or_insert(msg);
    }
    vk::FALSE
}

/// Owns the instance, the device and the allocator. Never used directly: see [`Device`].
pub struct DeviceShared {
    pub entry: ash::Entry,
    pub instance: ash::Instance,
    pub physical: vk::PhysicalDevice,
    pub raw: ash::Device,
    pub queue: vk::Queue,
    pub queue_family: u32,
    pub caps: Capabilities,
    pub(crate) allocator: ManuallyDrop<Mutex<Allocator>>,
    pub(crate) debug_utils_instance: Option<ash::ext::debug_utils::Instance>,
    pub(crate) debug_utils_device: Option<ash::ext::debug_utils::Device>,
    /// `vkCmdDrawMeshTasksEXT`, where [`Capabilities::mesh_shader`] holds.
    pub(crate) mesh_shader_device: Option<ash::ext::mesh_shader::Device>,
    messenger: vk::DebugUtilsMessengerEXT,
    validation: Box<ValidationLog>,
    pub validation_enabled: bool,
    /// Serialises queue submission (vkQueueSubmit requires external synchronisation).
    pub(crate) queue_lock: Mutex<()>,
    /// Whether the device and instance are Shutter's to destroy: false for a device a caller lent
    /// ([`DeviceShared::from_external`] with [`Ownership::Borrowed`]).
    owns_handles: bool,
    /// What each descriptor set Shutter wrote references, so that binding one in a graph pass can
    /// be checked against the pass' declared accesses (`graph/record.rs`).
    pub(crate) descriptor_refs: super::pipeline::DescriptorRefs,
    /// Every pipeline Shutter made on the device, reused by every later prepare that asks for the
    /// same one ([`super::pipeline::PipelineStore`]); destroyed with the device.
    pub pipelines: super::pipeline::PipelineStore,
}

/// The one owner of the Vulkan device; cheap to clone.
pub type Device = Arc<DeviceShared>;

impl Drop for DeviceShared {
    fn drop(&mut self) {
        // SAFETY: every wrapper holding resources holds an Arc to us, so none is alive; nothing is in
        // flight (every submission is waited on; a caller's recorded frames are retired before their
        // scene is dropped, `embed`). Allocator before device, messenger before instance. A lent
        // device is not waited on (its queues are the caller's to synchronise) nor destroyed: only
        // what Shutter made on it — its memory blocks, its pipelines and its messenger — goes.
        unsafe {
            if self.owns_handles {
                let _ = self.raw.device_wait_idle();
            }
            ManuallyDrop::drop(&mut self.allocator);
            // Ours even on a lent device.
            self.pipelines.destroy_all(&self.raw);
            if self.owns_handles {
                self.raw.destroy_device(None);
            }
            if let Some(du) = &self.debug_utils_instance {
                if self.messenger != vk::DebugUtilsMessengerEXT::null() {
                    du.destroy_debug_utils_messenger(self.messenger, None);
                }
            }
            if self.owns_handles {
                self.instance.destroy_instance(None);
            }
        }
    }
}

fn device_type_rank(t: vk::PhysicalDeviceType) -> u32 {
    match t {
        vk::PhysicalDeviceType::DISCRETE_GPU => 0,
        vk::PhysicalDeviceType::INTEGRATED_GPU => 1,
        vk::PhysicalDeviceType::VIRTUAL_GPU => 2,
        vk::PhysicalDeviceType::CPU => 3,
        _ => 4,
    }
}

fn cstr_field(chars: &[std::ffi::c_char]) -> String {
    // SAFETY: Vulkan guarantees these fixed arrays are NUL-terminated.
    unsafe { CStr::from_ptr(chars.as_ptr()) }.to_string_lossy().into_owned()
}

impl DeviceShared {
    /// Creates a headless instance and device as `desc` says.
    pub fn new(desc: &DeviceDesc) -> Result<Device> {
        let project = ProjectDrivers::load()?;
        // SAFETY: loading the system Vulkan loader; failure is reported, not assumed.
        let entry = unsafe { ash::Entry::load() }.map_err(|e| Error::Loader(e.to_string()))?;
        let layers = unsafe { entry.enumerate_instance_layer_properties() }
            .vk("vkEnumerateInstanceLayerProperties")?;
        let has_layer = |name: &CStr| layers.iter().any(|l| l.layer_name_as_c_str().ok() == Some(name));
        let inst_exts = unsafe { entry.enumerate_instance_extension_properties(None) }
            .vk("vkEnumerateInstanceExtensionProperties")?;
        let mut debug_utils =
            inst_exts.iter().any(|e| e.extension_name_as_c_str().ok() == Some(ash::ext::debug_utils::NAME));
        let validation = desc.validation && has_layer(VALIDATION_LAYER);
        if desc.validation && !validation {
            log::warn!("validation requested but VK_LAYER_KHRONOS_validation is not installed (vulkan-validationlayers)");
            eprintln!("warning: validation requested but VK_LAYER_KHRONOS_validation is not installed");
        }
        if validation {
            // The validation layer always provides debug utils.
            debug_utils = true;
        }

        let app_name = c"shutter";
        let app = vk::ApplicationInfo::default()
            .application_name(app_name)
            .engine_name(app_name)
            .api_version(vk::API_VERSION_1_3);
        let layer_ptrs: Vec<*const std::ffi::c_char> =
            if validation { vec![VALIDATION_LAYER.as_ptr()] } else { vec![] };
        let mut ext_ptrs = vec![];
        if debug_utils {
            ext_ptrs.push(ash::ext::debug_utils::NAME.as_ptr());
        }
        let validation_log = Box::<ValidationLog>::default();
        let severity =
            vk::DebugUtilsMessageSeverityFlagsEXT::ERROR | vk::DebugUtilsMessageSeverityFlagsEXT::WARNING;
        let types = vk::DebugUtilsMessageTypeFlagsEXT::GENERAL
            | vk::DebugUtilsMessageTypeFlagsEXT::VALIDATION
            | vk::DebugUtilsMessageTypeFlagsEXT::PERFORMANCE;
        let mut messenger_info = vk::DebugUtilsMessengerCreateInfoEXT::default()
            .message_severity(severity)
            .message_type(
                vk::DebugUtilsMessageTypeFlagsEXT::GENERAL | vk::DebugUtilsMessageTypeFlagsEXT::VALIDATION,
            )
            .pfn_user_callback(Some(debug_callback))
            .user_data(&*validation_log as *const ValidationLog as *mut c_void);
        let enabled_features = [vk::ValidationFeatureEnableEXT::SYNCHRONIZATION_VALIDATION];
        let mut validation_features =
            vk::ValidationFeaturesEXT::default().enabled_validation_features(&enabled_features);
        let mut inst_info = vk::InstanceCreateInfo::default()
            .application_info(&app)
            .enabled_layer_names(&layer_ptrs)
            .enabled_extension_names(&ext_ptrs);
        if validation {
            // Chained so that instance creation and destruction are validated too.
            inst_info = inst_info.push_next(&mut messenger_info);
            if desc.sync_validation {
                inst_info = inst_info.push_next(&mut validation_features);
            }
        }
        let instance = unsafe { entry.create_instance(&inst_info, None) }.vk("vkCreateInstance")?;
        // From here on, clean up the instance on error.
        let guard = InstanceGuard { instance: Some(instance.clone()) };

        let (debug_utils_instance, messenger) = if validation || debug_utils {
            let du = ash::ext::debug_utils::Instance::new(&entry, &instance);
            let m = if validation {
                let info = vk::DebugUtilsMessengerCreateInfoEXT::default()
                    .message_severity(severity)
                    .message_type(types)
                    .pfn_user_callback(Some(debug_callback))
                    .user_data(&*validation_log as *const ValidationLog as *mut c_void);
                unsafe { du.create_debug_utils_messenger(&info, None) }
                    .vk("vkCreateDebugUtilsMessengerEXT")?
            } else {
                vk::DebugUtilsMessengerEXT::null()
            };
            (Some(du), m)
        } else {
            (None, vk::DebugUtilsMessengerEXT::null())
        };
        let messenger_guard = MessengerGuard { du: debug_utils_instance.clone(), messenger };

        let mut candidates = summaries(&instance, &project)?;
        let names: Vec<String> =
            candidates.iter().map(|c| format!("{} = {} ({})", c.key, c.device_name, c.device_type)).collect();
        if let Some(wanted) = &desc.driver {
            candidates.retain(|c| {
                super::drivers::driver_matches(wanted, &c.driver_id, &c.device_name, &c.driver_info)
            });
            if candidates.is_empty() {
                return Err(Error::NoDevice { wanted: format!("driver {wanted}"), available: names });
            }
        }
        if let Some(wanted) = &desc.device_name {
            let w = wanted.to_lowercase();
            candidates.retain(|c| c.device_name.to_lowercase().contains(&w));
            if candidates.is_empty() {
                return Err(Error::NoDevice { wanted: wanted.clone(), available: names });
            }
        }
        let chosen = candidates.first().cloned().ok_or_else(|| Error::NoDevice {
            wanted: "any Vulkan 1.3 device".into(),
            available: names.clone(),
        })?;
        let physical = chosen.physical;
        let props = unsafe { instance.get_physical_device_properties(physical) };
        if props.api_version < vk::API_VERSION_1_3 {
            return Err(Error::MissingFeature {
                device: cstr_field(&props.device_name),
                feature: "Vulkan 1.3".into(),
                needed_by: "Shutter (dynamic rendering, synchronization2)".into(),
            });
        }

        let families = unsafe { instance.get_physical_device_queue_family_properties(physical) };
        let queue_family = families
            .iter()
            .position(|f| f.queue_flags.contains(vk::QueueFlags::GRAPHICS | vk::QueueFlags::COMPUTE))
            .ok_or_else(|| Error::MissingFeature {
                device: cstr_field(&props.device_name),
                feature: "a graphics+compute queue".into(),
                needed_by: "every technique".into(),
            })? as u32;

        let identity = DriverIdentity {
            driver_version: chosen.driver_version.clone(),
            key: chosen.key.clone(),
            project_driver: chosen.project_driver.clone(),
        };
        let Offered { mut caps, supported, host_query_reset, dynamic_rendering_and_sync2 } =
            offered_capabilities(
                &instance,
                physical,
                queue_family,
                &identity,
                debug_utils_instance.is_some(),
            )?;
        for feature in &desc.disabled {
            caps.disable(*feature);
        }
        let conservative = caps.conservative_rasterization;
        let (mesh, task) = (caps.mesh_shader, caps.task_shader);
        if !dynamic_rendering_and_sync2 {
            return Err(Error::MissingFeature {
                device: cstr_field(&props.device_name),
                feature: "dynamicRendering and synchronization2".into(),
                needed_by: "every technique".into(),
            });
        }
        // Enable what later techniques use, where present; techniques check `caps` before relying on it.
        let features = vk::PhysicalDeviceFeatures::default()
            .geometry_shader(caps.geometry_shader)
            .shader_clip_distance(caps.clip_distance)
            .sample_rate_shading(caps.sample_rate_shading)
            .independent_blend(caps.independent_blend)
            .fragment_stores_and_atomics(caps.fragment_stores_and_atomics)
            .vertex_pipeline_stores_and_atomics(caps.vertex_pipeline_stores_and_atomics)
            .shader_int64(caps.shader_int64)
            .pipeline_statistics_query(caps.pipeline_statistics)
            .sampler_anisotropy(supported.sampler_anisotropy == vk::TRUE)
            .shader_storage_image_write_without_format(
                supported.shader_storage_image_write_without_format == vk::TRUE,
            );
        let mut enable13 =
            // maintenance4: a pipeline stays valid after the layout it was made with is destroyed,
            // which the device's pipeline store relies on (core 1.3 devices all support it).
            vk::PhysicalDeviceVulkan13Features::default()
                .dynamic_rendering(true)
                .synchronization2(true)
                .maintenance4(true);
        let mut enable12 = vk::PhysicalDeviceVulkan12Features::default()
            .host_query_reset(host_query_reset)
            .shader_buffer_int64_atomics(caps.buffer_int64_atomics);
        let priorities = [1.0f32];
        let queue_info = [vk::DeviceQueueCreateInfo::default()
            .queue_family_index(queue_family)
            .queue_priorities(&priorities)];
        let mut dev_ext_ptrs = vec![];
        if conservative {
            dev_ext_ptrs.push(ash::ext::conservative_rasterization::NAME.as_ptr());
        }
        // Task shaders where offered: `--hull mesh-task` culls clusters ahead of the mesh shader.
        let mut enable_mesh = vk::PhysicalDeviceMeshShaderFeaturesEXT::default()
            .mesh_shader(true)
            .task_shader(task)
            .mesh_shader_queries(caps.mesh_shader_queries);
        if mesh {
            dev_ext_ptrs.push(ash::ext::mesh_shader::NAME.as_ptr());
        }
        let mut dev_info = vk::DeviceCreateInfo::default()
            .queue_create_infos(&queue_info)
            .enabled_extension_names(&dev_ext_ptrs)
            .enabled_features(&features)
            .push_next(&mut enable13)
            .push_next(&mut enable12);
        if mesh {
            dev_info = dev_info.push_next(&mut enable_mesh);
        }
        let raw = unsafe { instance.create_device(physical, &dev_info, None) }.vk("vkCreateDevice")?;
        let queue = unsafe { raw.get_device_queue(queue_family, 0) };
        let allocator = Allocator::new(&AllocatorCreateDesc {
            instance: instance.clone(),
            device: raw.clone(),
            physical_device: physical,
            debug_settings: Default::default(),
            buffer_device_address: false,
            allocation_sizes: Default::default(),
        });
        let allocator = match allocator {
            Ok(a) => a,
            Err(e) => {
                unsafe { raw.destroy_device(None) };
                return Err(e.into());
            }
        };
        let debug_utils_device =
            debug_utils_instance.as_ref().map(|_| ash::ext::debug_utils::Device::new(&instance, &raw));
        let mesh_shader_device = mesh.then(|| ash::ext::mesh_shader::Device::new(&instance, &raw));
        std::mem::forget(messenger_guard);
        std::mem::forget(guard);
        Ok(Arc::new(DeviceShared {
            entry,
            instance,
            physical,
            raw,
            queue,
            queue_family,
            caps,
            allocator: ManuallyDrop::new(Mutex::new(allocator)),
            debug_utils_instance,
            debug_utils_device,
            mesh_shader_device,
            messenger,
            validation: validation_log,
            validation_enabled: validation,
            queue_lock: Mutex::new(()),
            owns_handles: true,
            descriptor_refs: Default::default(),
            pipelines: super::pipeline::PipelineStore::new(true),
        }))
    }

    /// Validation messages (errors and warnings) counted so far.
    pub fn validation_report(&self) -> ValidationReport {
        ValidationReport {
            errors: self.validation.errors.load(Ordering::Relaxed),
            warnings: self.validation.warnings.load(Ordering::Relaxed),
            first: self.validation.first.lock().ok().and_then(|f| f.clone()),
        }
    }

    /// `Err(Error::Validation)` if the validation layer has reported any error or warning.
    pub fn check_validation(&self) -> Result<()> {
        let r = self.validation_report();
        if r.errors + r.warnings > 0 {
            return Err(Error::Validation {
                errors: r.errors,
                warnings: r.warnings,
                first: r.first.unwrap_or_default(),
            });
        }
        Ok(())
    }

    /// Names a Vulkan object for debuggers and validation messages (no-op without debug utils).
    pub fn set_name<H: vk::Handle>(&self, handle: H, name: &str) {
        if let Some(du) = &self.debug_utils_device {
            if let Ok(name) = CString::new(name) {
                let info =
                    vk::DebugUtilsObjectNameInfoEXT::default().object_handle(handle).object_name(&name);
                // SAFETY: handle belongs to this device; naming failure is harmless.
                let _ = unsafe { du.set_debug_utils_object_name(&info) };
            }
        }
    }

    /// Opens a debug label region in `cmd` (RenderDoc/validation show pass names).
    pub fn begin_label(&self, cmd: vk::CommandBuffer, name: &str) {
        if let Some(du) = &self.debug_utils_device {
            if let Ok(name) = CString::new(name) {
                let label = vk::DebugUtilsLabelEXT::default().label_name(&name);
                unsafe { du.cmd_begin_debug_utils_label(cmd, &label) };
            }
        }
    }

    pub fn end_label(&self, cmd: vk::CommandBuffer) {
        if let Some(du) = &self.debug_utils_device {
            unsafe { du.cmd_end_debug_utils_label(cmd) };
        }
    }
}

/// Which driver a device is, as Shutter names it ([`Capabilities::driver_key`] and its neighbours).
struct DriverIdentity {
    driver_version: String,
    key: String,
    project_driver: Option<String>,
}

/// What a physical device offers: its [`Capabilities`] as if every optional feature were enabled,
/// the raw feature structs they came from, and whether it has what every technique needs
/// (`dynamicRendering` and `synchronization2`). [`DeviceShared::new`] enables what is offered;
/// [`DeviceShared::from_external`] narrows the capabilities to what its caller enabled.
struct Offered {
    caps: Capabilities,
    supported: vk::PhysicalDeviceFeatures,
    host_query_reset: bool,
    dynamic_rendering_and_sync2: bool,
}

fn offered_capabilities(
    instance: &ash::Instance,
    physical: vk::PhysicalDevice,
    queue_family: u32,
    identity: &DriverIdentity,
    debug_utils: bool,
) -> Result<Offered> {
    let props = unsafe { instance.get_physical_device_properties(physical) };
    let families = unsafe { instance.get_physical_device_queue_family_properties(physical) };
    let dev_exts = unsafe { instance.enumerate_device_extension_properties(physical) }
        .vk("vkEnumerateDeviceExtensionProperties")?;
    let has_dev_ext = |n: &CStr| dev_exts.iter().any(|e| e.extension_name_as_c_str().ok() == Some(n));
    let conservative = has_dev_ext(ash::ext::conservative_rasterization::NAME);
    let mesh_extension = has_dev_ext(ash::ext::mesh_shader::NAME);

    let mut driver_props = vk::PhysicalDeviceDriverProperties::default();
    let mut props2 = vk::PhysicalDeviceProperties2::default().push_next(&mut driver_props);
    unsafe { instance.get_physical_device_properties2(physical, &mut props2) };
    let supported = unsafe { instance.get_physical_device_features(physical) };
    let mut f13 = vk::PhysicalDeviceVulkan13Features::default();
    let mut f12 = vk::PhysicalDeviceVulkan12Features::default();
    let mut f_mesh = vk::PhysicalDeviceMeshShaderFeaturesEXT::default();
    let mut feats2 = vk::PhysicalDeviceFeatures2::default().push_next(&mut f13).push_next(&mut f12);
    if mesh_extension {
        feats2 = feats2.push_next(&mut f_mesh);
    }
    unsafe { instance.get_physical_device_features2(physical, &mut feats2) };
    let mesh_shader = mesh_extension && f_mesh.mesh_shader == vk::TRUE;
    let task_shader = mesh_shader && f_mesh.task_shader == vk::TRUE;
    let mut conservative_props = vk::PhysicalDeviceConservativeRasterizationPropertiesEXT::default();
    if conservative {
        let mut props2 = vk::PhysicalDeviceProperties2::default().push_next(&mut conservative_props);
        unsafe { instance.get_physical_device_properties2(physical, &mut props2) };
    }
    let mut mesh_props = vk::PhysicalDeviceMeshShaderPropertiesEXT::default();
    if mesh_shader {
        let mut props2 = vk::PhysicalDeviceProperties2::default().push_next(&mut mesh_props);
        unsafe { instance.get_physical_device_properties2(physical, &mut props2) };
    }
    let limits = props.limits;
    let counts = limits.framebuffer_color_sample_counts & limits.framebuffer_depth_sample_counts;
    let framebuffer_sample_counts =
        [1u32, 2, 4, 8, 16, 32, 64].into_iter().filter(|&c| counts.as_raw() & c != 0).collect();
    let caps = Capabilities {
        device_name: cstr_field(&props.device_name),
        device_type: format!("{:?}", props.device_type),
        driver_name: cstr_field(&driver_props.driver_name),
        driver_info: cstr_field(&driver_props.driver_info),
        driver_id: format!("{:?}", driver_props.driver_id),
        driver_version: identity.driver_version.clone(),
        driver_key: identity.key.clone(),
        project_driver: identity.project_driver.clone(),
        mesh_shader,
        max_mesh_work_group_count: mesh_props.max_mesh_work_group_count,
        max_mesh_work_group_total_count: mesh_props.max_mesh_work_group_total_count,
        task_shader,
        max_task_work_group_count: mesh_props.max_task_work_group_count,
        max_task_work_group_total_count: mesh_props.max_task_work_group_total_count,
        mesh_shader_queries: mesh_shader
            && f_mesh.mesh_shader_queries == vk::TRUE
            && supported.pipeline_statistics_query == vk::TRUE,
        api_version: format!(
            "{}.{}.{}",
            vk::api_version_major(props.api_version),
            vk::api_version_minor(props.api_version),
            vk::api_version_patch(props.api_version)
        ),
        framebuffer_sample_counts,
        geometry_shader: supported.geometry_shader == vk::TRUE,
        clip_distance: supported.shader_clip_distance == vk::TRUE,
        sample_rate_shading: supported.sample_rate_shading == vk::TRUE,
        independent_blend: supported.independent_blend == vk::TRUE,
        fragment_stores_and_atomics: supported.fragment_stores_and_atomics == vk::TRUE,
        vertex_pipeline_stores_and_atomics: supported.vertex_pipeline_stores_and_atomics == vk::TRUE,
        conservative_rasterization: conservative,
        primitive_overestimation_px: conservative_props.primitive_overestimation_size,
        max_extra_primitive_overestimation_px: conservative_props.max_extra_primitive_overestimation_size,
        degenerate_triangles_rasterized: conservative_props.degenerate_triangles_rasterized == vk::TRUE,
        buffer_int64_atomics: supported.shader_int64 == vk::TRUE
            && f12.shader_buffer_int64_atomics == vk::TRUE,
        shader_int64: supported.shader_int64 == vk::TRUE,
        max_geometry_output_vertices: limits.max_geometry_output_vertices,
        max_geometry_total_output_components: limits.max_geometry_total_output_components,
        max_push_constants_size: limits.max_push_constants_size,
        max_storage_buffer_range: limits.max_storage_buffer_range,
        max_uniform_buffer_range: limits.max_uniform_buffer_range,
        standard_sample_locations: limits.standard_sample_locations == vk::TRUE,
        linear_filter_rgba32f: unsafe {
            instance.get_physical_device_format_properties(physical, vk::Format::R32G32B32A32_SFLOAT)
        }
        .optimal_tiling_features
        .contains(vk::FormatFeatureFlags::SAMPLED_IMAGE_FILTER_LINEAR),
        sub_texel_precision_bits: limits.sub_texel_precision_bits,
        max_image_dimension_2d: limits.max_image_dimension2_d,
        max_bound_descriptor_sets: limits.max_bound_descriptor_sets,
        timestamps: limits.timestamp_compute_and_graphics == vk::TRUE
            && families[queue_family as usize].timestamp_valid_bits > 0,
        timestamp_period_ns: limits.timestamp_period,
        pipeline_statistics: supported.pipeline_statistics_query == vk::TRUE,
        debug_utils,
        disabled: Vec::new(),
    };
    Ok(Offered {
        caps,
        supported,
        host_query_reset: f12.host_query_reset == vk::TRUE,
        dynamic_rendering_and_sync2: f13.dynamic_rendering == vk::TRUE && f13.synchronization2 == vk::TRUE,
    })
}

/// The project's drivers ([`super::drivers`]), offered to the Vulkan loader beside the system's ICDs.
struct ProjectDrivers {
    project: Vec<super::drivers::ProjectDriver>,
}

impl ProjectDrivers {
    /// Makes sure the loader will offer the project's drivers ([`super::drivers::offer_project_drivers`])
    /// and remembers which they are, to tell their devices from the system's.
    fn load() -> Result<Self> {
        Ok(ProjectDrivers { project: super::drivers::offer_project_drivers()? })
    }

    /// The project driver folder whose version a device reports, if any (the folder is named
    /// `FAMILY-VERSION`, e.g. `lavapipe-25.0.7`).
    fn folder_of(&self, family: &str, version: &str) -> Option<String> {
        let name = format!("{family}-{version}");
        self.project.iter().find(|d| d.folder == name).map(|d| d.folder.clone())
    }
}

/// One device a driver offers, as listed before choosing ([`available_drivers`]).
#[derive(Clone, Debug)]
pub struct DriverSummary {
    /// Shutter's name for the driver ([`super::drivers::driver_key`]).
    pub key: String,
    pub device_name: String,
    pub device_type: String,
    pub driver_id: String,
    pub driver_info: String,
    pub driver_version: String,
    pub api_version: String,
    /// The project's driver folder it came from, None for a system ICD.
    pub project_driver: Option<String>,
    physical: vk::PhysicalDevice,
    rank: u32,
}

/// Every device of every driver the instance offers, best first: by type (discrete GPU first, CPU
/// last), then newest driver version.
fn summaries(instance: &ash::Instance, project: &ProjectDrivers) -> Result<Vec<DriverSummary>> {
    let physicals = unsafe { instance.enumerate_physical_devices() }.vk("vkEnumeratePhysicalDevices")?;
    let mut out: Vec<DriverSummary> = physicals
        .iter()
        .map(|&physical| {
            let mut driver_props = vk::PhysicalDeviceDriverProperties::default();
            let mut props2 = vk::PhysicalDeviceProperties2::default().push_next(&mut driver_props);
            // SAFETY: `physical` comes from this instance; the chain holds one valid struct.
            unsafe { instance.get_physical_device_properties2(physical, &mut props2) };
            let props = props2.properties;
            let device_name = cstr_field(&props.device_name);
            let driver_id = format!("{:?}", driver_props.driver_id);
            let driver_info = cstr_field(&driver_props.driver_info);
            let driver_version = super::drivers::driver_version(&driver_info);
            let family = super::drivers::driver_family(&driver_id, &device_name);
            DriverSummary {
                key: super::drivers::driver_key(&driver_id, &device_name, &driver_info),
                project_driver: project.folder_of(&family, &driver_version),
                device_type: format!("{:?}", props.device_type),
                api_version: format!(
                    "{}.{}.{}",
                    vk::api_version_major(props.api_version),
                    vk::api_version_minor(props.api_version),
                    vk::api_version_patch(props.api_version)
                ),
                rank: device_type_rank(props.device_type),
                device_name,
                driver_id,
                driver_info,
                driver_version,
                physical,
            }
        })
        .collect();
    out.sort_by(|a, b| {
        a.rank.cmp(&b.rank).then_with(|| super::drivers::version_cmp(&b.driver_version, &a.driver_version))
    });
    Ok(out)
}

/// Every driver this machine offers Shutter (the system's ICDs and the project's `.drivers/`), best
/// first: the order [`DeviceShared::new`] chooses in. Creates a bare instance (no layers) to ask.
pub fn available_drivers() -> Result<Vec<DriverSummary>> {
    let project = ProjectDrivers::load()?;
    // SAFETY: loading the system Vulkan loader; failure is reported, not assumed.
    let entry = unsafe { ash::Entry::load() }.map_err(|e| Error::Loader(e.to_string()))?;
    let app = vk::ApplicationInfo::default().application_name(c"shutter").api_version(vk::API_VERSION_1_3);
    let info = vk::InstanceCreateInfo::default().application_info(&app);
    // SAFETY: `info` and everything it points to outlive the call.
    let instance = unsafe { entry.create_instance(&info, None) }.vk("vkCreateInstance")?;
    let guard = InstanceGuard { instance: Some(instance.clone()) };
    let list = summaries(&instance, &project);
    drop(guard);
    list
}

/// Destroys the instance if device creation fails half-way.
struct InstanceGuard {
    instance: Option<ash::Instance>,
}
impl Drop for InstanceGuard {
    fn drop(&mut self) {
        if let Some(i) = self.instance.take() {
            unsafe { i.destroy_instance(None) };
        }
    }
}
struct MessengerGuard {
    du: Option<ash::ext::debug_utils::Instance>,
    messenger: vk::DebugUtilsMessengerEXT,
}
impl Drop for MessengerGuard {
    fn drop(&mut self) {
        if let Some(du) = &self.du {
            if self.messenger != vk::DebugUtilsMessengerEXT::null() {
                unsafe { du.destroy_debug_utils_messenger(self.messenger, None) };
            }
        }
    }
}

/// Who destroys a device lent to Shutter ([`DeviceShared::from_external`]).
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub enum Ownership {
    /// The caller keeps the handles: Shutter never destroys the device or the instance, nor waits
    /// on the device when its last [`Device`] clone drops.
    Borrowed,
    /// Shutter takes them: when the last [`Device`] clone drops it waits for the device to idle, then
    /// destroys the device and the instance.
    Owned,
}

/// A Vulkan device made by someone else, and what they enabled on it: the input of
/// [`DeviceShared::from_external`]. Shutter relies only on what is listed here as enabled.
#[derive(Clone)]
pub struct ExternalDevice {
    pub entry: ash::Entry,
    pub instance: ash::Instance,
    /// The `apiVersion` the instance was created with (Shutter needs 1.3).
    pub instance_api_version: u32,
    pub physical_device: vk::PhysicalDevice,
    pub device: ash::Device,
    /// A queue of `queue_family`: Shutter submits its uploads there (never a frame it records for
    /// the caller).
    pub queue: vk::Queue,
    pub queue_family: u32,
    /// The core features enabled at `vkCreateDevice`.
    pub features: vk::PhysicalDeviceFeatures,
    /// The Vulkan 1.2 features enabled (`p_next` is ignored).
    pub features12: vk::PhysicalDeviceVulkan12Features<'static>,
    /// The Vulkan 1.3 features enabled (`p_next` is ignored).
    pub features13: vk::PhysicalDeviceVulkan13Features<'static>,
    /// The device extensions enabled.
    pub device_extensions: Vec<CString>,
    /// `meshShader` of `VkPhysicalDeviceMeshShaderFeaturesEXT` was enabled (with `VK_EXT_mesh_shader`
    /// among `device_extensions`): the stochastic rasterizer's `--hull mesh` may run.
    pub mesh_shader: bool,
    /// `taskShader` was enabled beside `meshShader`: `--hull mesh-task` may run.
    pub task_shader: bool,
    /// `VK_EXT_debug_utils` is enabled on the instance: Shutter names its objects, labels its passes
    /// and adds a messenger of its own that counts validation messages
    /// ([`DeviceShared::check_validation`]).
    pub debug_utils: bool,
    /// The Khronos validation layer is enabled on the instance (reported as
    /// [`DeviceShared::validation_enabled`]; its messages are counted only with `debug_utils`).
    pub validation_layer: bool,
    pub ownership: Ownership,
}

impl std::fmt::Debug for ExternalDevice {
    fn fmt(&self, f: &mut std::fmt::Formatter<'_>) -> std::fmt::Result {
        f.debug_struct("ExternalDevice")
            .field("instance_api_version", &self.instance_api_version)
            .field("physical_device", &self.physical_device)
            .field("device", &self.device.handle())
            .field("queue", &self.queue)
            .field("queue_family", &self.queue_family)
            .field("device_extensions", &self.device_extensions)
            .field("mesh_shader", &self.mesh_shader)
            .field("task_shader", &self.task_shader)
            .field("debug_utils", &self.debug_utils)
            .field("validation_layer", &self.validation_layer)
            .field("ownership", &self.ownership)
            .finish_non_exhaustive()
    }
}

impl ExternalDevice {
    fn has_extension(&self, name: &CStr) -> bool {
        self.device_extensions.iter().any(|e| e.as_c_str() == name)
    }
}

impl DeviceShared {
    /// Shutter on a device someone else created (an engine embedding it): the capabilities are
    /// what the physical device offers narrowed to what `ext` says was enabled, so a technique that
    /// needs a feature left off refuses with [`Error::MissingFeature`] naming it, exactly as on a
    /// device that lacks it.
    ///
    /// Refused with [`Error::MissingFeature`], naming everything missing at once: an instance or
    /// device below Vulkan 1.3, `dynamicRendering` or `synchronization2` not enabled, a queue
    /// family that is not graphics + compute.
    ///
    /// # Safety
    /// * Every handle in `ext` is valid; `device` was created from `physical_device` of `instance`,
    ///   `instance` from `entry` with `instance_api_version`, and `queue` is a queue of `device` in
    ///   `queue_family`.
    /// * Every feature and extension `ext` lists as enabled was enabled when `device` (or, for
    ///   `debug_utils` and `validation_layer`, `instance`) was created.
    /// * [`Ownership::Borrowed`]: `device` and `instance` outlive the returned [`Device`] and every
    ///   clone of it (every Shutter object holds one). [`Ownership::Owned`]: the caller destroys
    ///   neither and stops using them once the last clone has dropped.
    /// * Shutter submits to `queue` (uploads while preparing a scene, and everything
    ///   [`crate::techniques::Renderer::render`] does) under a lock of its own; the caller must not
    ///   submit to the same queue from another thread during those calls (`vkQueueSubmit` needs
    ///   external synchronisation).
    pub unsafe fn from_external(ext: ExternalDevice) -> Result<Device> {
        let instance = &ext.instance;
        let physical = ext.physical_device;
        let props = unsafe { instance.get_physical_device_properties(physical) };
        let device_name = cstr_field(&props.device_name);
        let families = unsafe { instance.get_physical_device_queue_family_properties(physical) };
        let mut missing: Vec<String> = Vec::new();
        if ext.instance_api_version < vk::API_VERSION_1_3 {
            missing.push("an instance created with apiVersion 1.3".into());
        }
        if props.api_version < vk::API_VERSION_1_3 {
            missing.push("Vulkan 1.3".into());
        }
        match families.get(ext.queue_family as usize) {
            Some(f) if f.queue_flags.contains(vk::QueueFlags::GRAPHICS | vk::QueueFlags::COMPUTE) => {}
            Some(_) => missing.push(format!("graphics and compute on queue family {}", ext.queue_family)),
            None => missing.push(format!("queue family {} (it has {})", ext.queue_family, families.len())),
        }
        if ext.features13.dynamic_rendering != vk::TRUE {
            missing.push("dynamicRendering (Vulkan 1.3 feature) enabled".into());
        }
        if ext.features13.synchronization2 != vk::TRUE {
            missing.push("synchronization2 (Vulkan 1.3 feature) enabled".into());
        }
        if !missing.is_empty() {
            return Err(Error::MissingFeature {
                device: device_name,
                feature: missing.join(", "),
                needed_by: "Shutter on a device it is given (every technique)".into(),
            });
        }
        let mut driver_props = vk::PhysicalDeviceDriverProperties::default();
        let mut props2 = vk::PhysicalDeviceProperties2::default().push_next(&mut driver_props);
        unsafe { instance.get_physical_device_properties2(physical, &mut props2) };
        let (driver_id, driver_info) =
            (format!("{:?}", driver_props.driver_id), cstr_field(&driver_props.driver_info));
        let driver_version = super::drivers::driver_version(&driver_info);
        let family = super::drivers::driver_family(&driver_id, &device_name);
        // Only a lookup of the project's driver folders: the loader's environment is the caller's.
        let folder = format!("{family}-{driver_version}");
        let project_driver = super::drivers::project_drivers()
            .ok()
            .and_then(|ds| ds.into_iter().find(|d| d.folder == folder))
            .map(|d| d.folder);
        let identity = DriverIdentity {
            key: super::drivers::driver_key(&driver_id, &device_name, &driver_info),
            driver_version,
            project_driver,
        };
        let Offered { mut caps, .. } =
            offered_capabilities(instance, physical, ext.queue_family, &identity, ext.debug_utils)?;
        // What Shutter may use is what is there *and* enabled.
        let f = &ext.features;
        caps.geometry_shader &= f.geometry_shader == vk::TRUE;
        caps.clip_distance &= f.shader_clip_distance == vk::TRUE;
        caps.sample_rate_shading &= f.sample_rate_shading == vk::TRUE;
        caps.independent_blend &= f.independent_blend == vk::TRUE;
        caps.fragment_stores_and_atomics &= f.fragment_stores_and_atomics == vk::TRUE;
        caps.vertex_pipeline_stores_and_atomics &= f.vertex_pipeline_stores_and_atomics == vk::TRUE;
        caps.pipeline_statistics &= f.pipeline_statistics_query == vk::TRUE;
        caps.buffer_int64_atomics &=
            f.shader_int64 == vk::TRUE && ext.features12.shader_buffer_int64_atomics == vk::TRUE;
        caps.shader_int64 &= f.shader_int64 == vk::TRUE;
        caps.conservative_rasterization &= ext.has_extension(ash::ext::conservative_rasterization::NAME);
        caps.mesh_shader &= ext.mesh_shader && ext.has_extension(ash::ext::mesh_shader::NAME);
        caps.task_shader &= caps.mesh_shader && ext.task_shader;
        // The lending application's mesh-shader feature struct is not known here: no mesh queries.
        caps.mesh_shader_queries = false;
        let mesh_shader_device =
            caps.mesh_shader.then(|| ash::ext::mesh_shader::Device::new(&ext.instance, &ext.device));

        let allocator = Allocator::new(&AllocatorCreateDesc {
            instance: ext.instance.clone(),
            device: ext.device.clone(),
            physical_device: physical,
            debug_settings: Default::default(),
            buffer_device_address: false,
            allocation_sizes: Default::default(),
        })?;
        let validation_log = Box::<ValidationLog>::default();
        let (debug_utils_instance, debug_utils_device, messenger) = if ext.debug_utils {
            let du = ash::ext::debug_utils::Instance::new(&ext.entry, &ext.instance);
            // A messenger of Shutter's own beside any of the caller's: every messenger sees every
            // message, so a validation message during Shutter's work fails `check_validation`.
            let info = vk::DebugUtilsMessengerCreateInfoEXT::default()
                .message_severity(
                    vk::DebugUtilsMessageSeverityFlagsEXT::ERROR
                        | vk::DebugUtilsMessageSeverityFlagsEXT::WARNING,
                )
                .message_type(
                    vk::DebugUtilsMessageTypeFlagsEXT::GENERAL
                        | vk::DebugUtilsMessageTypeFlagsEXT::VALIDATION
                        | vk::DebugUtilsMessageTypeFlagsEXT::PERFORMANCE,
                )
                .pfn_user_callback(Some(debug_callback))
                .user_data(&*validation_log as *const ValidationLog as *mut c_void);
            let m = unsafe { du.create_debug_utils_messenger(&info, None) }
                .vk("vkCreateDebugUtilsMessengerEXT")?;
            let dd = ash::ext::debug_utils::Device::new(&ext.instance, &ext.device);
            (Some(du), Some(dd), m)
        } else {
            (None, None, vk::DebugUtilsMessengerEXT::null())
        };
        Ok(Arc::new(DeviceShared {
            entry: ext.entry,
            instance: ext.instance,
            physical,
            raw: ext.device,
            queue: ext.queue,
            queue_family: ext.queue_family,
            caps,
            allocator: ManuallyDrop::new(Mutex::new(allocator)),
            debug_utils_instance,
            debug_utils_device,
            mesh_shader_device,
            messenger,
            validation: validation_log,
            validation_enabled: ext.validation_layer,
            queue_lock: Mutex::new(()),
            owns_handles: ext.ownership == Ownership::Owned,
            descriptor_refs: Default::default(),
            // Without maintenance4 a pipeline may not outlive its layout: each prepare makes its own.
            pipelines: super::pipeline::PipelineStore::new(ext.features13.maintenance4 == vk::TRUE),
        }))
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn env_flags_take_the_usual_spellings_and_refuse_the_rest() {
        for on in ["1", "true", "TRUE", "on", "On", "yes", " yes "] {
            assert_eq!(parse_env_flag("SHUTTER_VALIDATION", on).unwrap(), Some(true), "{on}");
        }
        for off in ["0", "false", "False", "off", "OFF", "no"] {
            assert_eq!(parse_env_flag("SHUTTER_VALIDATION", off).unwrap(), Some(false), "{off}");
        }
        assert_eq!(parse_env_flag("SHUTTER_VALIDATION", "").unwrap(), None);
        for bad in ["2", "maybe", "enable", "-1"] {
            let e = parse_env_flag("SHUTTER_VALIDATION", bad).unwrap_err().to_string();
            assert_eq!(
                e,
                format!(
                    "environment variable SHUTTER_VALIDATION=\"{bad}\": expected 1, true, on or yes to turn \
                     it on; 0, false, off or no to turn it off"
                )
            );
        }
    }

    /// Every feature's key parses back to it, lists take commas and spaces, and an unknown key or
    /// an MSAA count that is no count is refused naming it.
    #[test]
    fn feature_keys_round_trip_and_unknown_ones_are_refused() {
        let all: Vec<Feature> = Feature::FLAGS.into_iter().chain([2, 4, 8, 16].map(Feature::Msaa)).collect();
        for f in &all {
            assert_eq!(f.key().parse::<Feature>(), Ok(*f), "{}", f.key());
            assert!(FEATURE_KEYS.contains(f.key().trim_end_matches(char::is_numeric)), "{} listed", f.key());
        }
        assert_eq!(
            Feature::parse_list("geometry-shader, msaa-4 buffer-int64-atomics,"),
            Ok(vec![Feature::GeometryShader, Feature::Msaa(4), Feature::BufferInt64Atomics])
        );
        assert_eq!(Feature::parse_list(""), Ok(vec![]));
        for bad in ["geometry", "msaa-1", "msaa-3", "msaa-x", "GEOMETRY-SHADER"] {
            let e = bad.parse::<Feature>().unwrap_err();
            assert!(e.contains(&format!("`{bad}`")), "{bad}: {e}");
        }
    }
}
