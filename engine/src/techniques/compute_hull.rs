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
//! so no bound is ever dropped (`StochasticDraws::before_frame`). The counts also size the draws.
//! One object's hull must fit one storage-buffer descriptor (`maxStorageBufferRange`: 128 MiB, about
//! 16.7 M vertices, on lavapipe); an object that needs more is refused with [`Error::Limit`] naming it
//! (splitting objects into several hull buffers is not implemented; `focus-sweep`'s 327,680-triangle
//! sphere needs 12.8 M).

use ash::vk;
use bytemuck::{Pod, Zeroable};
use gpu_allocator::MemoryLocation;

use super::stochastic::StochasticObject;
use super::FrameInputs;
use crate::error::{Error, Result};
use crate::gpu::layout::{
    shared_struct, SharedStruct, FRAME_SET_INDEX, OBJECT_SET_INDEX, TECHNIQUE_SET_INDEX,
};
use crate::gpu::GpuWorld;
use crate::graph::{Access, BufferHandle, FrameGraph, Tracked};
use crate::plan::Effects;
use crate::shaders::{axes, ExpandComp};
use crate::vk::{
    write_descriptors, Buffer, DescriptorSetLayout, DescriptorWrite, Device, Pipeline, PipelineLayout,
    ShaderModule,
};

/// How each triangle's bound reaches the rasterizer.
#[derive(Clone, Copy, Debug, Default, PartialEq, Eq, Hash)]
pub enum HullExpansion {
    /// A geometry shader bounds and emits every triangle in every pass.
    #[default]
    GeometryShader,
    /// A compute pass bounds every triangle once per frame into buffers; each pass draws them.
    Compute,
    /// A mesh shader (`VK_EXT_mesh_shader`, `shaders-glsl/stochastic/stochastic.mesh`) bounds and
    /// emits every triangle in every pass, as the geometry shader does: the same triangles reach the
    /// rasterizer, so the image is bit-identical to [`HullExpansion::GeometryShader`]'s.
    Mesh,
    /// [`HullExpansion::Mesh`] behind a task shader (`shaders-glsl/stochastic/stochastic.task`) that
    /// culls, per cluster of 32 triangles, those whose box over the draw's lens and times misses the
    /// image and one-sided ones back-facing throughout: only triangles that emit no hit are dropped,
    /// so the image is bit-identical too.
    MeshTask,
}

impl HullExpansion {
    pub const ALL: [HullExpansion; 4] =
        [HullExpansion::GeometryShader, HullExpansion::Compute, HullExpansion::Mesh, HullExpansion::MeshTask];
    pub fn name(&self) -> &'static str {
        match self {
            HullExpansion::GeometryShader => "gs",
            HullExpansion::Compute => "compute",
            HullExpansion::Mesh => "mesh",
            HullExpansion::MeshTask => "mesh-task",
        }
    }
}

impl HullExpansion {
    /// The bound is expanded in a mesh shader (with or without the task shader's culling).
    pub fn is_mesh(self) -> bool {
        matches!(self, HullExpansion::Mesh | HullExpansion::MeshTask)
    }

    /// The coverage fragment shader's hull axis: the mesh shader hands it the triangle as
    /// `gl_PrimitiveID`, as the geometry shader does.
    pub fn axis(self) -> axes::Hull {
        match self {
            HullExpansion::GeometryShader | HullExpansion::Mesh | HullExpansion::MeshTask => {
                axes::Hull::GeometryShader
            }
            HullExpansion::Compute => axes::Hull::Compute,
        }
    }
}

impl std::str::FromStr for HullExpansion {
    type Err = Error;
    fn from_str(s: &str) -> Result<Self> {
        crate::error::parse_named(&HullExpansion::ALL, |h| h.name(), "hull expansion", s)
    }
}

/// Initial hull buffer capacity in vertices per triangle (a dilated octagon-like bound fans into
/// about 8–12 triangles; 48 vertices = 16 triangles). Overflow grows the buffer; see the module docs.
pub const INITIAL_VERTICES_PER_TRIANGLE: u32 = 48;

/// Bytes per hull vertex: NDC x, y.
const HULL_VERTEX_BYTES: u64 = 8;
/// Bytes per hull triangle in the second buffer: the source triangle's index.
const HULL_TRIANGLE_BYTES: u64 = 4;

/// Push constants of `expand.comp`.
#[repr(C)]
#[derive(Clone, Copy, Debug, Pod, Zeroable)]
pub struct ExpandPush {
    pub object: u32,
    pub triangle_count: u32,
    pub bound: u32,
    pub capacity: u32,
    pub dilate: f32,
    /// The object's motion key segments.
    pub segment_count: u32,
    /// Bounds are made for segments `[segment_begin, segment_begin + segments)`, over local times
    /// `[t0, t1]` of each: all segments over (0, 1) for an object that moves, the one holding
    /// mid-shutter at its local time (t0 = t1) for one that does not (NO_MOTION).
    pub segment_begin: u32,
    pub segments: u32,
    pub t0: f32,
    pub t1: f32,
    /// 1: the object is one-sided; triangles that face away at every lens point over [t0, t1] get no
    /// bound.
    pub one_sided: u32,
}

/// For the reflection test.
pub const EXPAND_STRUCTS: &[SharedStruct] = &[shared_struct!(
    "Push",
    ExpandPush,
    [
        object,
        triangle_count,
        bound,
        capacity,
        dilate,
        segment_count,
        segment_begin,
        segments,
        t0,
        t1,
        one_sided
    ]
)];

/// Expansion pipelines and the per-object hull buffers.
pub struct ComputeHull {
    expand: Vec<(Effects, Pipeline)>,
    expand_layout: PipelineLayout,
    /// Per object: the vertices and the per-hull-triangle source indices (set 2, bindings 1 and 2).
    hulls: Vec<[Tracked<Buffer>; 2]>,
    /// Vertices each object's hull buffer holds.
    capacity: Vec<u32>,
    /// Vertices each object's expansion needed (host-visible, one u32 per object; set 3, binding 4).
    counts: Tracked<Buffer>,
    /// Vertices one hull buffer may hold (`maxStorageBufferRange`).
    max_vertices: u32,
    _shaders: Vec<ShaderModule>,
}

impl ComputeHull {
    /// Pipelines for `paths`, buffers for every object of `world`. `sets` are the stochastic
    /// rasterizer's set 2 and 3 layouts; the hull bindings of `object_sets` (set 2) and the counts'
    /// binding of `technique_set` (set 3) are written here.
    pub fn new(
        device: &Device,
        world: &GpuWorld,
        paths: &[Effects],
        sets: &[&DescriptorSetLayout; 2],
        object_sets: &[vk::DescriptorSet],
        technique_set: vk::DescriptorSet,
        initial_vertices_per_triangle: u32,
    ) -> Result<Self> {
        let expand_layout = world.pipeline_layout(
            device,
            sets,
            std::mem::size_of::<ExpandPush>() as u32,
            vk::ShaderStageFlags::COMPUTE,
        )?;
        let mut shaders = Vec::new();
        let mut expand = Vec::new();
        for &e in paths {
            let m = ShaderModule::new(device, ExpandComp { effects: e.shader_axis() }.source())?;
            expand.push((
                e,
                Pipeline::compute(device, &format!("expand hull ({})", e.name()), &expand_layout, &m)?,
            ));
            shaders.push(m);
        }
        let counts = Tracked::new(Buffer::with_data(
            device,
            "hull vertex counts",
            vk::BufferUsageFlags::STORAGE_BUFFER,
            &vec![0u32; world.objects.len().max(1)],
        )?);
        write_descriptors(device, technique_set, &[DescriptorWrite::storage_buffer(4, &counts)]);
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
        for (i, o) in world.objects.iter().enumerate() {
            let cap = o
                .triangle_count()
                .max(1)
                .saturating_mul(initial_vertices_per_triangle.max(3))
                .min(max_vertices);
            hull.hulls.push(hull_buffers(device, &o.name, cap)?);
            hull.capacity.push(cap);
            hull.write_set(device, object_sets[i], i);
        }
        Ok(hull)
    }

    fn write_set(&self, device: &Device, set: vk::DescriptorSet, i: usize) {
        write_descriptors(
            device,
            set,
            &[
                DescriptorWrite::storage_buffer(1, &self.hulls[i][0]),
                DescriptorWrite::storage_buffer(2, &self.hulls[i][1]),
            ],
        );
    }

    /// Each object's hull buffers (vertices, source triangles).
    pub fn buffers(&self) -> &[[Tracked<Buffer>; 2]] {
        &self.hulls
    }

    /// Zeroes the counts (a host write before the graph that expands).
    pub fn reset_counts(&mut self) -> Result<()> {
        let n = self.capacity.len().max(1);
        self.counts.get_mut().write(&vec![0u32; n])
    }

    /// Adds the expansion of every object on a stochastic path (after the triangles pass that writes
    /// their camera-space triangles) and the host read of the counts: each object's set 2, path, bound
    /// and motion key times from its record, `technique_set` the set 3.
    pub(crate) fn add_expand_pass<'a>(
        &'a self,
        g: &mut FrameGraph<'a>,
        inputs: &FrameInputs<'a>,
        objects: &'a [StochasticObject],
        technique_set: vk::DescriptorSet,
        dilate: f32,
    ) {
        let world = inputs.world;
        let view_set = inputs.camera.frame_set;
        // Every object: auto's still objects take the `still` permutation of the same expansion.
        let drawn = |i: usize| world.objects[i].triangle_count() > 0;
        let mut reads: Vec<BufferHandle> = vec![];
        let mut writes: Vec<BufferHandle> = vec![];
        for i in (0..world.objects.len()).filter(|&i| drawn(i)) {
            reads.push(g.import_buffer("camera-space triangles", &objects[i].triangles));
            writes.push(g.import_buffer("hull", &self.hulls[i][0]));
            writes.push(g.import_buffer("hull triangles", &self.hulls[i][1]));
        }
        let counts = g.import_buffer("hull vertex counts", &self.counts);
        let mut pass = g.pass("expand");
        for h in reads {
            pass = pass.access(h, Access::ComputeShaderReadOther);
        }
        for h in writes {
            pass = pass.overwrite(h, Access::ComputeShaderWrite);
        }
        // Atomics read and write the counts.
        pass = pass.access(counts, Access::ComputeShaderReadOther).access(counts, Access::ComputeShaderWrite);
        pass.record(move |ctx| {
            let bind = vk::PipelineBindPoint::COMPUTE;
            let layout = &self.expand_layout;
            ctx.bind_sets(bind, layout, FRAME_SET_INDEX, &[view_set]);
            ctx.bind_sets(bind, layout, TECHNIQUE_SET_INDEX, &[technique_set]);
            for (effects, pipeline) in &self.expand {
                ctx.bind_pipeline(pipeline);
                for (i, o) in world.objects.iter().enumerate() {
                    if !drawn(i) || objects[i].choices.effects != *effects {
                        continue;
                    }
                    let sets = [o.set, objects[i].set];
                    ctx.bind_sets(bind, layout, OBJECT_SET_INDEX, &sets);
                    let keys = &objects[i].choices.keys;
                    let segment_count = keys.segments() as u32;
                    let (segment_begin, segments, t0, t1) =
                        super::stochastic::bounded_segments(keys, effects.motion());
                    let push = ExpandPush {
                        object: i as u32,
                        triangle_count: o.triangle_count(),
                        bound: objects[i].choices.bound.id(),
                        capacity: self.capacity[i],
                        dilate,
                        segment_count,
                        segment_begin,
                        segments,
                        t0,
                        t1,
                        one_sided: o.one_sided as u32,
                    };
                    ctx.push(layout, &push);
                    ctx.dispatch((o.triangle_count() * segments).div_ceil(64), 1, 1);
                }
            }
            Ok(())
        });
        g.host_read(counts);
    }

    /// Reads the counts of the last expansion; grows every buffer that overflowed (rewriting its
    /// descriptor set). Returns true when something grew: the expansion must run again.
    pub fn grow_overflowed(
        &mut self,
        device: &Device,
        world: &GpuWorld,
        object_sets: &[vk::DescriptorSet],
    ) -> Result<bool> {
        let counts = self.counts()?;
        let mut grew = false;
        for (i, &n) in counts.iter().enumerate() {
            if n > self.capacity[i] {
                if n > self.max_vertices {
                    return Err(Error::Limit {
                        what: "compute-expanded hull",
                        value: format!("{n} vertices for object `{}`", world.objects[i].name),
                        limit: format!(
                            "{} vertices ({} bytes, maxStorageBufferRange); use the geometry-shader hull (--hull gs)",
                            self.max_vertices,
                            self.max_vertices as u64 * HULL_VERTEX_BYTES
                        ),
                    });
                }
                let cap = n.saturating_add(n / 4).min(self.max_vertices);
                self.hulls[i] = hull_buffers(device, &world.objects[i].name, cap)?;
                self.capacity[i] = cap;
                self.write_set(device, object_sets[i], i);
                grew = true;
            }
        }
        Ok(grew)
    }

    /// Vertices of each object's hull from the last expansion.
    pub fn counts(&self) -> Result<Vec<u32>> {
        self.counts.read_u32s(self.capacity.len())
    }

    /// Current capacity of each object's hull buffer, in vertices.
    pub fn capacity(&self) -> &[u32] {
        &self.capacity
    }
}

fn hull_buffers(device: &Device, object: &str, vertices: u32) -> Result<[Tracked<Buffer>; 2]> {
    let storage = vk::BufferUsageFlags::STORAGE_BUFFER;
    Ok([
        Tracked::new(Buffer::new(
            device,
            &format!("hull:{object}"),
            vertices as u64 * HULL_VERTEX_BYTES,
            storage,
            MemoryLocation::GpuOnly,
        )?),
        Tracked::new(Buffer::new(
            device,
            &format!("hull triangles:{object}"),
            (vertices as u64).div_ceil(3) * HULL_TRIANGLE_BYTES,
            storage,
            MemoryLocation::GpuOnly,
        )?),
    ])
}
