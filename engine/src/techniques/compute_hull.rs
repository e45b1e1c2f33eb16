//! The compute-expanded hull: [`HullExpansion::Compute`], a hardware-feature experiment for the
//! stochastic rasterizer.
//!
//! The geometry-shader path bounds every triangle again in every pass, in a stage lavapipe runs on one
//! thread. Here a compute pass (`shaders-glsl/stochastic/expand.comp`, multi-threaded on lavapipe)
//! bounds each triangle once per frame — the same `compute_bound` and pixel-box dilation as the
//! geometry shader (`emit.glsl`) — and appends the strips as a triangle list to a buffer per object
//! (NDC x, y per vertex; the source triangle's index per hull triangle in a second buffer: 8 + 4/3
//! bytes per vertex); every pass then draws those buffers with a plain
//! vertex shader (`hull.vert`) in front of the same fragment shader (permutation `COMPUTE_HULL`,
//! which takes the triangle index from a flat varying instead of `gl_PrimitiveID`).
//!
//! Capacity: a buffer starts at [`INITIAL_VERTICES_PER_TRIANGLE`] vertices per triangle. The shader
//! counts every vertex it needs but writes only within capacity; after the expansion the counts are
//! read back and any object that overflowed gets a buffer 25 % above its count and is expanded again,
//! so no bound is ever dropped (`StochasticRenderer::render`). The counts also size the draws.
//! One object's hull must fit one storage-buffer descriptor (`maxStorageBufferRange`: 128 MiB, about
//! 16.7 M vertices, on lavapipe); an object that needs more is refused with [`Error::Limit`] naming it
//! (splitting objects into several hull buffers is not implemented; `focus-sweep`'s 327,680-triangle
//! sphere needs 12.8 M).

use ash::vk;
use gpu_allocator::MemoryLocation;

use super::gpu_scene::GpuScene;
use crate::error::{Error, Result};
use crate::plan::Effects;
use crate::shaders::{self, ShaderSource};
use crate::vk::{
    as_bytes, write_descriptors, Buffer, DescriptorWrite, Device, Pipeline, PipelineLayout, ShaderModule,
};

/// How each triangle's bound reaches the rasterizer.
#[derive(Clone, Copy, Debug, Default, PartialEq, Eq, Hash)]
pub enum HullExpansion {
    /// A geometry shader bounds and emits every triangle in every pass.
    #[default]
    GeometryShader,
    /// A compute pass bounds every triangle once per frame into buffers; each pass draws them.
    Compute,
}

impl HullExpansion {
    pub const ALL: [HullExpansion; 2] = [HullExpansion::GeometryShader, HullExpansion::Compute];
    pub fn name(&self) -> &'static str {
        match self {
            HullExpansion::GeometryShader => "gs",
            HullExpansion::Compute => "compute",
        }
    }
}

impl std::str::FromStr for HullExpansion {
    type Err = Error;
    fn from_str(s: &str) -> Result<Self> {
        HullExpansion::ALL.into_iter().find(|h| h.name() == s).ok_or_else(|| {
            Error::Unsupported(format!("unknown hull expansion `{s}`; available: gs, compute"))
        })
    }
}

/// Initial hull buffer capacity in vertices per triangle (a dilated octagon-like bound fans into
/// about 8–12 triangles; 48 vertices = 16 triangles). Overflow grows the buffer; see the module docs.
pub const INITIAL_VERTICES_PER_TRIANGLE: u32 = 48;

/// Bytes per hull vertex: NDC x, y.
const HULL_VERTEX_BYTES: u64 = 8;
/// Bytes per hull triangle in the second buffer: the source triangle's index.
const HULL_TRIANGLE_BYTES: u64 = 4;

#[repr(C)]
#[derive(Clone, Copy)]
struct ExpandPush {
    object: u32,
    triangle_count: u32,
    bound: u32,
    capacity: u32,
    dilate: f32,
}

fn expand_shader(effects: Effects) -> ShaderSource {
    match effects {
        Effects::Defocus => shaders::STOCHASTIC_EXPAND_COMP_DEFOCUS,
        Effects::Motion => shaders::STOCHASTIC_EXPAND_COMP_MOTION,
        Effects::Both | Effects::Pinhole => shaders::STOCHASTIC_EXPAND_COMP,
    }
}

/// The fragment shader permutation behind the compute-expanded hull.
pub fn fragment_shader(per_sample: bool, instrumented: bool, effects: Effects) -> ShaderSource {
    use shaders::*;
    use Effects::*;
    match (per_sample, instrumented, effects) {
        (false, false, Both | Pinhole) => STOCHASTIC_STOCHASTIC_FRAG_COMPUTE_HULL,
        (false, false, Defocus) => STOCHASTIC_STOCHASTIC_FRAG_COMPUTE_HULL_DEFOCUS,
        (false, false, Motion) => STOCHASTIC_STOCHASTIC_FRAG_COMPUTE_HULL_MOTION,
        (false, true, Both | Pinhole) => STOCHASTIC_STOCHASTIC_FRAG_COMPUTE_HULL_INSTRUMENTED,
        (false, true, Defocus) => STOCHASTIC_STOCHASTIC_FRAG_COMPUTE_HULL_INSTRUMENTED_DEFOCUS,
        (false, true, Motion) => STOCHASTIC_STOCHASTIC_FRAG_COMPUTE_HULL_INSTRUMENTED_MOTION,
        (true, false, Both | Pinhole) => STOCHASTIC_STOCHASTIC_FRAG_COMPUTE_HULL_PER_SAMPLE,
        (true, false, Defocus) => STOCHASTIC_STOCHASTIC_FRAG_COMPUTE_HULL_PER_SAMPLE_DEFOCUS,
        (true, false, Motion) => STOCHASTIC_STOCHASTIC_FRAG_COMPUTE_HULL_PER_SAMPLE_MOTION,
        (true, true, Both | Pinhole) => STOCHASTIC_STOCHASTIC_FRAG_COMPUTE_HULL_PER_SAMPLE_INSTRUMENTED,
        (true, true, Defocus) => STOCHASTIC_STOCHASTIC_FRAG_COMPUTE_HULL_PER_SAMPLE_INSTRUMENTED_DEFOCUS,
        (true, true, Motion) => STOCHASTIC_STOCHASTIC_FRAG_COMPUTE_HULL_PER_SAMPLE_INSTRUMENTED_MOTION,
    }
}

/// Expansion pipelines and the per-object hull buffers.
pub struct ComputeHull {
    expand: Vec<(Effects, Pipeline)>,
    expand_layout: PipelineLayout,
    /// Per object: the vertices and the per-hull-triangle source indices.
    hulls: Vec<[Buffer; 2]>,
    /// Vertices each object's hull buffer holds.
    capacity: Vec<u32>,
    /// Vertices each object's expansion needed (host-visible, one u32 per object).
    counts: Buffer,
    /// Vertices one hull buffer may hold (`maxStorageBufferRange`).
    max_vertices: u32,
    _shaders: Vec<ShaderModule>,
}

impl ComputeHull {
    /// Pipelines for `paths`, buffers for every object; the geometry sets' bindings 3 (hull), 5 (its source triangles) and 4
    /// (counts) are written here. `geometry_layout` is the stochastic renderer's set 1 of the expansion.
    pub fn new(
        device: &Device,
        scene: &GpuScene,
        paths: &[Effects],
        geometry_layout: &crate::vk::DescriptorSetLayout,
        object_sets: &[vk::DescriptorSet],
        initial_vertices_per_triangle: u32,
    ) -> Result<Self> {
        let expand_layout = PipelineLayout::new(
            device,
            &[&scene.frame_layout, geometry_layout],
            std::mem::size_of::<ExpandPush>() as u32,
            vk::ShaderStageFlags::COMPUTE,
        )?;
        let mut shaders = Vec::new();
        let mut expand = Vec::new();
        for &e in paths {
            let m = ShaderModule::new(device, expand_shader(e))?;
            expand.push((
                e,
                Pipeline::compute(device, &format!("expand hull ({})", e.name()), &expand_layout, &m)?,
            ));
            shaders.push(m);
        }
        let counts = Buffer::with_data(
            device,
            "hull vertex counts",
            vk::BufferUsageFlags::STORAGE_BUFFER,
            &vec![0u32; scene.objects.len().max(1)],
        )?;
        let range = device.caps.max_storage_buffer_range as u64;
        let max_vertices = (range / HULL_VERTEX_BYTES).min(3 * (range / HULL_TRIANGLE_BYTES)) as u32 / 3 * 3;
        let mut hull = ComputeHull {
            expand,
            expand_layout,
            hulls: vec![],
            capacity: vec![],
            counts,
            max_vertices,
            _shaders: shaders,
        };
        for (i, o) in scene.objects.iter().enumerate() {
            let cap = (o.index_count / 3)
                .max(1)
                .saturating_mul(initial_vertices_per_triangle.max(3))
                .min(max_vertices);
            let b = hull_buffer(device, &o.name, cap)?;
            hull.hulls.push(b);
            hull.capacity.push(cap);
            hull.write_set(device, object_sets[i], i);
        }
        Ok(hull)
    }

    fn write_set(&self, device: &Device, set: vk::DescriptorSet, i: usize) {
        let ty = vk::DescriptorType::STORAGE_BUFFER;
        write_descriptors(
            device,
            set,
            &[
                DescriptorWrite::Buffer { binding: 3, ty, buffer: self.hulls[i][0].raw },
                DescriptorWrite::Buffer { binding: 4, ty, buffer: self.counts.raw },
                DescriptorWrite::Buffer { binding: 5, ty, buffer: self.hulls[i][1].raw },
            ],
        );
    }

    /// Zeroes the counts (before recording an expansion).
    pub fn reset_counts(&mut self) -> Result<()> {
        let n = self.capacity.len().max(1);
        self.counts.write(&vec![0u32; n])
    }

    /// Records the expansion of every object on a stochastic path (after the camera-space triangles
    /// are written; the caller places the barriers).
    #[allow(clippy::too_many_arguments)]
    pub fn record_expand(
        &self,
        d: &Device,
        cmd: vk::CommandBuffer,
        scene: &GpuScene,
        object_sets: &[vk::DescriptorSet],
        object_effects: &[Effects],
        bound: u32,
        dilate: f32,
    ) {
        let bind = vk::PipelineBindPoint::COMPUTE;
        d.begin_label(cmd, "expand hulls");
        unsafe {
            d.raw.cmd_bind_descriptor_sets(cmd, bind, self.expand_layout.raw, 0, &[scene.frame_set], &[]);
            for (effects, pipeline) in &self.expand {
                d.raw.cmd_bind_pipeline(cmd, bind, pipeline.raw);
                for (i, o) in scene.objects.iter().enumerate() {
                    let count = o.index_count / 3;
                    if count == 0 || object_effects[i] != *effects {
                        continue;
                    }
                    d.raw.cmd_bind_descriptor_sets(
                        cmd,
                        bind,
                        self.expand_layout.raw,
                        1,
                        &[object_sets[i]],
                        &[],
                    );
                    let push = ExpandPush {
                        object: i as u32,
                        triangle_count: count,
                        bound,
                        capacity: self.capacity[i],
                        dilate,
                    };
                    d.raw.cmd_push_constants(
                        cmd,
                        self.expand_layout.raw,
                        vk::ShaderStageFlags::COMPUTE,
                        0,
                        as_bytes(&push),
                    );
                    d.raw.cmd_dispatch(cmd, count.div_ceil(64), 1, 1);
                }
            }
        }
        d.end_label(cmd);
    }

    /// Reads the counts of the last expansion; grows every buffer that overflowed (rewriting its
    /// descriptor set). Returns true when something grew: the expansion must run again.
    pub fn grow_overflowed(
        &mut self,
        device: &Device,
        scene: &GpuScene,
        object_sets: &[vk::DescriptorSet],
    ) -> Result<bool> {
        let counts = self.counts()?;
        let mut grew = false;
        for (i, &n) in counts.iter().enumerate() {
            if n > self.capacity[i] {
                if n > self.max_vertices {
                    return Err(Error::Limit {
                        what: "compute-expanded hull",
                        value: format!("{n} vertices for object `{}`", scene.objects[i].name),
                        limit: format!(
                            "{} vertices ({} bytes, maxStorageBufferRange); use the geometry-shader hull (--hull gs)",
                            self.max_vertices,
                            self.max_vertices as u64 * HULL_VERTEX_BYTES
                        ),
                    });
                }
                let cap = n.saturating_add(n / 4).min(self.max_vertices);
                self.hulls[i] = hull_buffer(device, &scene.objects[i].name, cap)?;
                self.capacity[i] = cap;
                self.write_set(device, object_sets[i], i);
                grew = true;
            }
        }
        Ok(grew)
    }

    /// Vertices of each object's hull from the last expansion.
    pub fn counts(&self) -> Result<Vec<u32>> {
        Ok(self.counts.mapped()?[..4 * self.capacity.len()]
            .chunks_exact(4)
            .map(|c| u32::from_ne_bytes([c[0], c[1], c[2], c[3]]))
            .collect())
    }

    /// Current capacity of each object's hull buffer, in vertices.
    pub fn capacity(&self) -> &[u32] {
        &self.capacity
    }
}

fn hull_buffer(device: &Device, object: &str, vertices: u32) -> Result<[Buffer; 2]> {
    let storage = vk::BufferUsageFlags::STORAGE_BUFFER;
    Ok([
        Buffer::new(
            device,
            &format!("hull:{object}"),
            vertices as u64 * HULL_VERTEX_BYTES,
            storage,
            MemoryLocation::GpuOnly,
        )?,
        Buffer::new(
            device,
            &format!("hull triangles:{object}"),
            (vertices as u64).div_ceil(3) * HULL_TRIANGLE_BYTES,
            storage,
            MemoryLocation::GpuOnly,
        )?,
    ])
}
