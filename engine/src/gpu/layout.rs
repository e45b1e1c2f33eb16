//! Every structure the CPU shares with GLSL, and the one descriptor-set numbering of every pipeline,
//! compute and graphics alike. Structs are `#[repr(C)]` + `bytemuck::Pod` (no padding, so their bytes
//! are exactly what the shaders read).
//!
//! Checked: each technique declares what its shaders expect of their pipeline layout
//! ([`ShaderInterface`]: binding tables per set, push struct) in its `SHADER_INTERFACES`, and a test
//! (`engine/src/gpu/layout_tests.rs`, `cargo test -p shutter --lib layout_tests`) reflects every
//! compiled permutation's SPIR-V and checks its descriptor set/binding numbers, descriptor types and
//! names against those tables, its push-constant block against the push struct, and the std140/std430
//! layout of every struct in [`SHARED_STRUCTS`] (offsets, sizes, array strides) against the Rust
//! structs. A stage file without an interface fails it.
//!
//! | set | what | owner | bindings |
//! |---|---|---|---|
//! | 0 | frame | world + one view ([`super::GpuView`]) | [`FRAME_SET`] |
//! | 1 | object | world ([`super::GpuWorld`]), one per object | [`OBJECT_SET`] |
//! | 2 | technique, per object | the technique | e.g. the stochastic rasterizer's triangles and hulls |
//! | 3 | technique, per frame | the technique | e.g. sample tables, counters, pass images |
//!
//! GLSL side: `shaders-glsl/common/frame.glsl` (set 0) and `shaders-glsl/common/object.glsl` (set 1).

use ash::vk;
use bytemuck::{Pod, Zeroable};

pub use crate::vk::Binding;

/// `MAX_LIGHTS` in `common/frame.glsl`.
pub const MAX_LIGHTS: usize = 256;

/// Descriptor set numbers ([module docs](self)).
pub const FRAME_SET_INDEX: u32 = 0;
pub const OBJECT_SET_INDEX: u32 = 1;
pub const TECHNIQUE_OBJECT_SET_INDEX: u32 = 2;
pub const TECHNIQUE_SET_INDEX: u32 = 3;
/// The shadow maps a shading stage reads ([`crate::techniques::shadow_maps::SHADOW_SET`]) when its
/// technique's own sets 2 and 3 are taken (the stochastic shading pass); the forward pipelines, whose
/// set 3 is free, bind them there (`common/shadow.glsl`).
pub const SHADOW_SET_INDEX: u32 = 4;

const fn binding(binding: u32, ty: vk::DescriptorType, block: &'static str) -> Binding {
    Binding { binding, ty, block }
}

const UBO: vk::DescriptorType = vk::DescriptorType::UNIFORM_BUFFER;
const SSBO: vk::DescriptorType = vk::DescriptorType::STORAGE_BUFFER;

/// Set 0: the world's uniforms and materials, one view's uniforms and per-object transforms.
pub const FRAME_SET: [Binding; 4] = [
    binding(0, UBO, "WorldUniforms"),
    binding(1, SSBO, "Materials"),
    binding(2, UBO, "ViewUniforms"),
    binding(3, SSBO, "ObjectViews"),
];

/// Set 1: one object's albedo texture and mesh (for shaders that fetch vertices themselves).
pub const OBJECT_SET: [Binding; 3] = [
    binding(0, vk::DescriptorType::COMBINED_IMAGE_SAMPLER, "albedo_texture"),
    binding(1, SSBO, "Vertices"),
    binding(2, SSBO, "Indices"),
];

/// `WorldUniforms` (std140; vec4s only).
#[repr(C)]
#[derive(Clone, Copy, Debug, Default, Pod, Zeroable)]
pub struct WorldUniforms {
    /// rgb, unused.
    pub ambient: [f32; 4],
    /// rgb, 1.
    pub background: [f32; 4],
}

/// `Material` (std430), one per object.
#[repr(C)]
#[derive(Clone, Copy, Debug, Default, Pod, Zeroable)]
pub struct GpuMaterial {
    /// rgb albedo, specular weight.
    pub albedo_specular: [f32; 4],
    /// roughness, has_texture (0/1), alpha, alpha_from_texture (0/1).
    pub params: [f32; 4],
}

/// `Light` (std140 array element): a light in one view's space at shutter open and close.
#[repr(C)]
#[derive(Clone, Copy, Debug, Default, Pod, Zeroable)]
pub struct GpuLight {
    /// xyz: direction to the light (w = `LIGHT_DIRECTIONAL`) or position (w = `LIGHT_POINT`,
    /// `LIGHT_SPOT`).
    pub at_open: [f32; 4],
    pub at_close: [f32; 4],
    /// rgb, unused.
    pub color: [f32; 4],
    /// Spot only: xyz the unit axis at shutter open (from the light into the scene), w cos of the
    /// inner half-angle.
    pub spot_open: [f32; 4],
    /// Spot only: xyz the axis at shutter close, w cos of the outer half-angle.
    pub spot_close: [f32; 4],
}

/// Light kinds in [`GpuLight::at_open`]`[3]` (`LIGHT_*` in `common/frame.glsl`).
pub const LIGHT_DIRECTIONAL: f32 = 0.0;
pub const LIGHT_POINT: f32 = 1.0;
pub const LIGHT_SPOT: f32 = 2.0;

/// Projection kinds in [`ViewUniforms::projection`]`[0]`.
pub const PROJECTION_THIN_LENS: f32 = 0.0;
pub const PROJECTION_ORTHOGRAPHIC: f32 = 1.0;
pub const PROJECTION_PERSPECTIVE: f32 = 2.0;

/// `ViewUniforms` (std140; vec4s only).
#[repr(C)]
#[derive(Clone, Copy, Debug, Pod, Zeroable)]
pub struct ViewUniforms {
    /// width, height (pixels), pixel scale s (thin lens; 0 otherwise), light count.
    pub viewport: [f32; 4],
    /// aperture radius A, focus distance F, near, far.
    pub lens: [f32; 4],
    /// kind (`PROJECTION_*`), orthographic half extents x, y (world units), unused.
    pub projection: [f32; 4],
    pub lights: [GpuLight; MAX_LIGHTS],
}

/// `ShadowHeader` (std430, `common/shadow.glsl`): what every shadow lookup shares
/// ([`crate::techniques::shadow_maps`]).
#[repr(C)]
#[derive(Clone, Copy, Debug, Pod, Zeroable)]
pub struct GpuShadowHeader {
    /// Samples per texel S, MSAA per sub-map, sub-maps, PCF radius.
    pub counts: [u32; 4],
    /// `ObjectView` records per lookup space, unused ×3.
    pub spaces: [u32; 4],
    /// Depth slack (texels at the receiver), unused ×3.
    pub bias: [f32; 4],
    /// Per light: has a map (0/1), first view, view count (1 or 6), lookup space.
    pub lights: [[u32; 4]; MAX_LIGHTS],
}

/// `ShadowView` (std430): one rendered face of a light's shadow map.
#[repr(C)]
#[derive(Clone, Copy, Debug, Pod, Zeroable)]
pub struct GpuShadowView {
    /// The light's lookup space → this face's view space (column-major).
    pub base_to_face: [f32; 16],
    /// Kind (`PROJECTION_*`), half extent x or pixel scale, half extent y, size (texels).
    pub projection: [f32; 4],
    /// Near, far, atlas x and y of the first sub-map's tile.
    pub depth: [f32; 4],
}

/// `ObjectView` (std430): one key segment of one object's motion seen from one view (an object with
/// K motion keys has K − 1, consecutive in the buffer; [`super::GpuView::segment_at`]).
#[repr(C)]
#[derive(Clone, Copy, Debug, Pod, Zeroable)]
pub struct GpuObjectView {
    /// Object → view space at the segment's first and last key (column-major).
    pub model_view: [[f32; 16]; 2],
    /// Inverse transpose of the upper 3×3, in a mat4 (std430 alignment).
    pub normal_matrix: [[f32; 16]; 2],
    /// The segment's key times t0, t1, then 1 / (t1 − t0) as the CPU rounded it
    /// ([`crate::geometry::KeyTimes`]), unused.
    pub time: [f32; 4],
}

/// Interleaved vertex (vertex input and `Vertex` in `common/object.glsl`): position, normal, uv.
#[repr(C)]
#[derive(Clone, Copy, Debug, Default, Pod, Zeroable)]
pub struct Vertex {
    pub position: [f32; 3],
    pub normal: [f32; 3],
    pub uv: [f32; 2],
}

/// Vertex input of [`Vertex`] for pipelines that draw meshes through the input assembler.
pub fn vertex_input() -> ([vk::VertexInputBindingDescription; 1], [vk::VertexInputAttributeDescription; 3]) {
    let attribute = |location, format, offset| vk::VertexInputAttributeDescription {
        location,
        binding: 0,
        format,
        offset: offset as u32,
    };
    (
        [vk::VertexInputBindingDescription {
            binding: 0,
            stride: std::mem::size_of::<Vertex>() as u32,
            input_rate: vk::VertexInputRate::VERTEX,
        }],
        [
            attribute(0, vk::Format::R32G32B32_SFLOAT, std::mem::offset_of!(Vertex, position)),
            attribute(1, vk::Format::R32G32B32_SFLOAT, std::mem::offset_of!(Vertex, normal)),
            attribute(2, vk::Format::R32G32_SFLOAT, std::mem::offset_of!(Vertex, uv)),
        ],
    )
}

/// A GLSL-shared struct's name and layout, for the reflection test: built by `shared_struct!` from the
/// Rust struct, compared with the struct or block of that name in the compiled SPIR-V.
#[derive(Clone, Copy, Debug)]
pub struct SharedStruct {
    /// The GLSL struct or block type name.
    pub glsl: &'static str,
    pub size: usize,
    /// The fields the GLSL declares, in declaration order.
    pub members: &'static [SharedMember],
}

/// One field of a [`SharedStruct`].
#[derive(Clone, Copy, Debug)]
pub struct SharedMember {
    pub name: &'static str,
    pub offset: usize,
    pub size: usize,
    /// `(length, element size)` when the Rust field is an array. A GLSL array must match both (the
    /// element size is its `ArrayStride`); a GLSL vector or matrix is a Rust array too (`[f32; 4]` for
    /// a `vec4`), whose size alone is compared.
    pub array: Option<(usize, usize)>,
    /// The scalar (or struct) under any arrays.
    pub component: Component,
    /// A struct's own layout, where the reflection test checks its members too (a header struct a
    /// push-constant block embeds: [`GpuField::LAYOUT`]).
    pub layout: Option<&'static SharedStruct>,
}

/// The scalar (or struct) a [`SharedMember`] is made of.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub enum Component {
    F32,
    U32,
    I32,
    /// A struct, by its GLSL name.
    Struct(&'static str),
}

/// A Rust type that may be the field of a [`SharedStruct`]: what GLSL type it stands for.
pub trait GpuField {
    const COMPONENT: Component;
    /// `(length, element size)` of an array.
    const ARRAY: Option<(usize, usize)> = None;
    /// A struct's [`SharedStruct`], for a struct whose members the reflection test is to check
    /// wherever it is a member (not one of [`SHARED_STRUCTS`], which are checked everywhere).
    const LAYOUT: Option<&'static SharedStruct> = None;
}

impl GpuField for f32 {
    const COMPONENT: Component = Component::F32;
}
impl GpuField for u32 {
    const COMPONENT: Component = Component::U32;
}
impl GpuField for i32 {
    const COMPONENT: Component = Component::I32;
}
impl<T: GpuField, const N: usize> GpuField for [T; N] {
    const COMPONENT: Component = T::COMPONENT;
    const ARRAY: Option<(usize, usize)> = Some((N, std::mem::size_of::<T>()));
}
impl GpuField for GpuLight {
    const COMPONENT: Component = Component::Struct("Light");
}

impl SharedMember {
    /// The field `name` at `offset` of `S`, whose type `field` names (`|s: &S| &s.name`).
    pub const fn of<S, F: GpuField>(name: &'static str, offset: usize, _field: fn(&S) -> &F) -> Self {
        SharedMember {
            name,
            offset,
            size: std::mem::size_of::<F>(),
            array: F::ARRAY,
            component: F::COMPONENT,
            layout: F::LAYOUT,
        }
    }
}

/// `shared_struct!("GlslName", RustType, [field, ...])`: the [`SharedStruct`] of `RustType`, with the
/// fields GLSL declares in GLSL's order.
macro_rules! shared_struct {
    ($glsl:literal, $t:ty, [$($m:ident),* $(,)?]) => {
        $crate::gpu::layout::SharedStruct {
            glsl: $glsl,
            size: std::mem::size_of::<$t>(),
            members: &[$($crate::gpu::layout::SharedMember::of::<$t, _>(
                stringify!($m),
                std::mem::offset_of!($t, $m),
                |s: &$t| &s.$m,
            )),*],
        }
    };
}
pub(crate) use shared_struct;

/// The structs of sets 0 and 1 as GLSL declares them (techniques list their push constants and
/// records beside their own code). The reflection test finds each, by name, in the shaders.
pub const SHARED_STRUCTS: &[SharedStruct] = &[
    shared_struct!("WorldUniforms", WorldUniforms, [ambient, background]),
    shared_struct!("Material", GpuMaterial, [albedo_specular, params]),
    shared_struct!("Light", GpuLight, [at_open, at_close, color, spot_open, spot_close]),
    shared_struct!("ViewUniforms", ViewUniforms, [viewport, lens, projection, lights]),
    shared_struct!("ObjectView", GpuObjectView, [model_view, normal_matrix, time]),
    shared_struct!("Vertex", Vertex, [position, normal, uv]),
    shared_struct!("ShadowHeader", GpuShadowHeader, [counts, spaces, bias, lights]),
    shared_struct!("ShadowView", GpuShadowView, [base_to_face, projection, depth]),
];

/// What a group of shader stage files expects of the pipeline layout the Rust side builds for them:
/// the binding table of each descriptor set and the push-constant struct. Each technique declares its
/// shaders' interfaces beside the code that builds their pipelines (`SHADER_INTERFACES`), and
/// [`crate::techniques::shader_interfaces`] collects them; the reflection test checks every compiled
/// permutation of every file against its interface, and fails for a file that has none.
#[derive(Clone, Copy, Debug)]
pub struct ShaderInterface {
    /// Stage files under `shaders-glsl/` (all their permutations).
    pub files: &'static [&'static str],
    /// The binding table of each set, by set number; `None`: no bindings in that set.
    pub sets: [Option<&'static [Binding]>; 5],
    /// The push-constant block; `None`: none.
    pub push: Option<SharedStruct>,
}

impl ShaderInterface {
    /// The interface of a pipeline layout from [`super::GpuWorld::pipeline_layout`]: [`FRAME_SET`] and
    /// [`OBJECT_SET`], then the technique's sets 2 (per object) and 3.
    pub const fn technique(
        files: &'static [&'static str],
        technique_object_set: Option<&'static [Binding]>,
        technique_set: Option<&'static [Binding]>,
        push: Option<SharedStruct>,
    ) -> Self {
        ShaderInterface {
            files,
            sets: [Some(&FRAME_SET), Some(&OBJECT_SET), technique_object_set, technique_set, None],
            push,
        }
    }

    /// The same whose shading reads shadow maps in set [`SHADOW_SET_INDEX`] (`shadow` its table).
    pub const fn with_shadows(self, shadow: &'static [Binding]) -> Self {
        let [frame, object, technique_object, technique, _] = self.sets;
        ShaderInterface { sets: [frame, object, technique_object, technique, Some(shadow)], ..self }
    }
}
