//! What the stochastic frame's shaders share with the CPU: the visibility core's push-constant structs,
//! descriptor tables of sets 2 and 3, buffer strides, and the shader interfaces the reflection test
//! (`gpu/layout_tests.rs`) checks every permutation against. Each shading stage declares its own push
//! struct and interface beside its Rust (`shading/*.rs`).

use ash::vk;
use bytemuck::{Pod, Zeroable};

use crate::gpu::layout::{shared_struct, Binding, SharedStruct};

/// Push constants of the visibility core's coverage and tint draws (`stochastic/visibility_push.glsl`):
/// vertex, geometry and fragment stages, geometry-shader, compute-hull and cluster paths alike. The
/// shading stages push their own (`shading::ShadePush` first).
#[repr(C)]
#[derive(Clone, Copy, Debug, Pod, Zeroable)]
pub struct VisibilityPush {
    pub bound: u32,
    pub pass_index: u32,
    pub spp: u32,
    pub per_pass: u32,
    pub dilate: f32,
    pub sample_first: u32,
    pub sample_count: u32,
    pub t0: f32,
    pub t1: f32,
    pub triangle_base: u32,
    pub triangle_count: u32,
    pub segment_first: u32,
    pub segment_count: u32,
    pub segment: u32,
    pub cluster_size: u32,
    /// The object's coverage α (1: opaque): the coverage stage keeps a hit only where the sample is
    /// covered ([`crate::transparency::covered`]), stochastic transparency with the reference's decisions.
    pub alpha: f32,
    /// [`crate::transparency::coverage_seed`] of the render seed.
    pub coverage_seed: u32,
    /// 1: coverage is `alpha` × the texture's alpha at each hit's uv (the reference's).
    pub alpha_from_texture: u32,
    /// The tint pass: the object's tint as [`crate::transparency::tint_log`] (0 elsewhere).
    pub tint_log_r: u32,
    pub tint_log_g: u32,
    pub tint_log_b: u32,
    /// 1: the object's material is one-sided; the coverage stage drops hits on its back.
    pub one_sided: u32,
}

/// Push constants of `clusters.comp`.
#[repr(C)]
#[derive(Clone, Copy, Debug, Pod, Zeroable)]
pub struct ClustersPush {
    pub triangle_count: u32,
    pub cluster_size: u32,
    pub segment_count: u32,
    pub segment: u32,
    pub t0: f32,
    pub t1: f32,
    /// 1: the object is one-sided; triangles that face away throughout are left out of the boxes.
    pub one_sided: u32,
}

/// Bytes per cluster and key segment (`clusters.comp`): screen box, camera-space box min and max.
pub(super) const CLUSTER_BYTES: u64 = 3 * 16;

/// Push constants of `triangles.comp`.
#[repr(C)]
#[derive(Clone, Copy, Debug, Pod, Zeroable)]
pub struct TrianglesPush {
    pub segment_first: u32,
    pub keys: u32,
    pub triangle_count: u32,
}

/// The bindings of [`STOCHASTIC_OBJECT_SET`] before the shading atlas' (5–7, texture-space only).
pub const STOCHASTIC_OBJECT_BINDINGS_WITHOUT_ATLAS: usize = 5;

/// Set 2 of the stochastic rasterizer, per object: the view's triangles, the compute-expanded hull,
/// the cluster bounds and, with texture-space shading, the object's shading atlas.
pub const STOCHASTIC_OBJECT_SET: [Binding; 8] = [
    Binding { binding: 0, ty: vk::DescriptorType::STORAGE_BUFFER, block: "Triangles" },
    Binding { binding: 1, ty: vk::DescriptorType::STORAGE_BUFFER, block: "Hull" },
    Binding { binding: 2, ty: vk::DescriptorType::STORAGE_BUFFER, block: "HullTriangles" },
    Binding { binding: 3, ty: vk::DescriptorType::STORAGE_BUFFER, block: "Clusters" },
    Binding { binding: 4, ty: vk::DescriptorType::STORAGE_BUFFER, block: "ClusterTriangles" },
    Binding { binding: 5, ty: vk::DescriptorType::COMBINED_IMAGE_SAMPLER, block: "atlas" },
    Binding { binding: 6, ty: vk::DescriptorType::STORAGE_BUFFER, block: "AtlasLevels" },
    Binding { binding: 7, ty: vk::DescriptorType::STORAGE_BUFFER, block: "AtlasCoords" },
];

/// The bindings of [`STOCHASTIC_SET`] before the mask coverage path's target (12–13, mask path only).
pub const STOCHASTIC_BINDINGS_WITHOUT_MASK: usize = 12;

/// Set 3 of the stochastic rasterizer: the sample tile, counters, bound debug output, hull counts, the
/// visibility buffer and the accumulation image; on the mask coverage path also its multisampled target
/// (bindings 12–13). The layout holds those two only where the path is taken: lavapipe (Mesa 22.3)
/// crashes binding a set whose combined image sampler was never written.
pub const STOCHASTIC_SET: [Binding; 14] = [
    Binding { binding: 0, ty: vk::DescriptorType::STORAGE_BUFFER, block: "SamplesXyLens" },
    Binding { binding: 1, ty: vk::DescriptorType::STORAGE_BUFFER, block: "SamplesTime" },
    Binding { binding: 2, ty: vk::DescriptorType::STORAGE_BUFFER, block: "Counters" },
    Binding { binding: 3, ty: vk::DescriptorType::STORAGE_BUFFER, block: "BoundDebug" },
    Binding { binding: 4, ty: vk::DescriptorType::STORAGE_BUFFER, block: "HullCounts" },
    Binding { binding: 5, ty: vk::DescriptorType::STORAGE_BUFFER, block: "Visibility" },
    Binding { binding: 6, ty: vk::DescriptorType::STORAGE_IMAGE, block: "accum" },
    Binding { binding: 7, ty: vk::DescriptorType::STORAGE_BUFFER, block: "TintLog" },
    Binding { binding: 8, ty: vk::DescriptorType::STORAGE_BUFFER, block: "DecoupledCache" },
    Binding { binding: 9, ty: vk::DescriptorType::STORAGE_BUFFER, block: "DecoupledGrids" },
    Binding { binding: 10, ty: vk::DescriptorType::STORAGE_BUFFER, block: "DeferredQueue" },
    Binding { binding: 11, ty: vk::DescriptorType::STORAGE_BUFFER, block: "DeferredRefs" },
    Binding { binding: 12, ty: vk::DescriptorType::COMBINED_IMAGE_SAMPLER, block: "mask_payload" },
    Binding { binding: 13, ty: vk::DescriptorType::COMBINED_IMAGE_SAMPLER, block: "mask_depth" },
];

/// Triangles a frame may hold: the visibility payload is triangle << 1 | back with the triangles
/// numbered across all objects (`visibility.glsl`), and the shading pass' empty group key is all ones.
pub const MAX_FRAME_TRIANGLES: u64 = (1 << 31) - 1;

/// Largest visibility buffer (8 bytes per pixel and sample of a pass) before S is split into more
/// passes.
pub const VISIBILITY_BUDGET_BYTES: u64 = 256 << 20;

/// Bytes per pixel and sample of a pass of the visibility buffer (`visibility.glsl`) and of the tint
/// buffer (`stochastic.frag`, TINT_PASS: `−log₂ T` per channel).
pub const VISIBILITY_BYTES: u64 = 8;
pub const TINT_BYTES: u64 = 12;

/// For the reflection test.
pub const STOCHASTIC_STRUCTS: &[SharedStruct] = &[
    shared_struct!(
        "Push",
        VisibilityPush,
        [
            bound,
            pass_index,
            spp,
            per_pass,
            dilate,
            sample_first,
            sample_count,
            t0,
            t1,
            triangle_base,
            triangle_count,
            segment_first,
            segment_count,
            segment,
            cluster_size,
            alpha,
            coverage_seed,
            alpha_from_texture,
            tint_log_r,
            tint_log_g,
            tint_log_b,
            one_sided
        ]
    ),
    shared_struct!("Push", TrianglesPush, [segment_first, keys, triangle_count]),
    shared_struct!(
        "Push",
        ClustersPush,
        [triangle_count, cluster_size, segment_count, segment, t0, t1, one_sided]
    ),
    shared_struct!("Push", super::mask::MaskResolvePush, [width, height, per_pass]),
];

/// Bytes per camera-space triangle and motion key (`triangles.comp`): 3 vertices × xyz.
pub(super) const TRIANGLE_KEY_BYTES: u64 = 9 * 4;

/// What the stochastic rasterizer's shaders expect of the layouts [`super::StochasticTechnique::new`] builds:
/// sets 2 and 3 from [`STOCHASTIC_OBJECT_SET`] and [`STOCHASTIC_SET`], and [`VisibilityPush`] for the raster
/// pipelines (`hull.vert` pushes nothing), [`TrianglesPush`] for `triangles.comp`. Also
/// `expand.comp`'s: [`ComputeHull`](super::super::compute_hull::ComputeHull) builds its pipeline with these
/// two sets' layouts (handed over here; it writes the hull bindings of set 2 and the counts' binding of set
/// 3) and [`super::super::compute_hull::ExpandPush`].
pub const SHADER_INTERFACES: &[crate::gpu::layout::ShaderInterface] = &[
    crate::gpu::layout::ShaderInterface::technique(
        &[
            "stochastic/stochastic.vert",
            "stochastic/stochastic.geom",
            "stochastic/stochastic.task",
            "stochastic/stochastic.mesh",
            "stochastic/hull.vert",
            "stochastic/cluster.vert",
            "stochastic/stochastic.frag",
            "stochastic/mask.frag",
        ],
        Some(&STOCHASTIC_OBJECT_SET),
        Some(&STOCHASTIC_SET),
        Some(STOCHASTIC_STRUCTS[0]),
    ),
    // The shading stages, each declared beside its Rust and its push constants (shading/*.rs).
    super::shading::EXACT_INTERFACE,
    super::shading::TEXTURE_SPACE_INTERFACE,
    super::shading::DECOUPLED_INTERFACE,
    crate::gpu::layout::ShaderInterface::technique(
        &["stochastic/triangles.comp"],
        Some(&STOCHASTIC_OBJECT_SET),
        Some(&STOCHASTIC_SET),
        Some(STOCHASTIC_STRUCTS[1]),
    ),
    crate::gpu::layout::ShaderInterface::technique(
        &["stochastic/clusters.comp"],
        Some(&STOCHASTIC_OBJECT_SET),
        Some(&STOCHASTIC_SET),
        Some(STOCHASTIC_STRUCTS[2]),
    ),
    crate::gpu::layout::ShaderInterface::technique(
        &["stochastic/expand.comp"],
        Some(&STOCHASTIC_OBJECT_SET),
        Some(&STOCHASTIC_SET),
        Some(super::super::compute_hull::EXPAND_STRUCTS[0]),
    ),
    crate::gpu::layout::ShaderInterface::technique(
        &["stochastic/mask_resolve.comp"],
        Some(&STOCHASTIC_OBJECT_SET),
        Some(&STOCHASTIC_SET),
        Some(STOCHASTIC_STRUCTS[3]),
    ),
];
