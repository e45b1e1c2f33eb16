//! Technique `stochastic`: stochastic rasterization of motion blur and depth of field on the conventional
//! pipeline (McGuire, Enderton, Shirley & Luebke, HPG 2010; Toth & Linder 2008).
//!
//! **Visibility first, shading second.** S samples per pixel are split into P passes of M = S / P
//! samples ([`samples_per_pass`]; one pass unless the visibility buffer would be too large). In every
//! pass each triangle goes through a geometry shader that replaces it by a conservative screen-space
//! bound of everywhere it can land over the lens and the shutter (`bounds`, selectable per draw,
//! mirrored on the CPU in [`crate::bounds`]), dilated by half a pixel; for every pixel the bound
//! touches, the coverage fragment shader runs the 5D inside test of each of the pass' samples — the
//! ray from the sample's lens point through its (x, y) against the triangle at the sample's time — and
//! keeps each hit in a visibility buffer, one 64-bit word per pixel and sample, `atomicMax` of (view
//! depth, object, triangle): the nearest hit of every sample, exactly, with no depth attachment and no
//! shading. A compute pass then shades the surviving hits from the samples themselves, per sample or
//! once per (triangle, side) group of the pixel ([`ShadingRate`]), and adds them to the frame's
//! accumulation image. This departs from McGuire et al. (who shade in the coverage pass and write one
//! depth per pixel through `gl_FragDepth`): on a CPU rasterizer that masks SIMD lanes, shading there is
//! paid by every bound fragment, and one depth per pixel misorders samples (`docs/STOCHASTIC.md`).
//!
//! The (x, y, u, v, t) samples are those of the CPU reference ([`SampleTile`]: 64×64 pixels × S
//! stratified samples, aperture shape and shutter curve applied here, never in the shaders), so at
//! equal S and seed the two estimate the pixel integral with the very same samples.
//! Shaders: `shaders-glsl/stochastic/`.

use ash::vk;
use bytemuck::{Pod, Zeroable};
use gpu_allocator::MemoryLocation;

use super::compute_hull::{ComputeHull, HullExpansion, INITIAL_VERTICES_PER_TRIANGLE};
use super::multipass::accumulation_image;
use super::shadow_maps::ShadowMaps;
use super::{FrameContext, FrameInputs, FrameTechnique, PrepareContext, TechniqueFrame, TechniqueInfo};
use crate::bounds::BoundKind;
use crate::error::{Error, Result};
use crate::geometry::KeyTimes;
use crate::gpu::layout::{
    shared_struct, vertex_input, Binding, SharedStruct, FRAME_SET_INDEX, OBJECT_SET_INDEX,
    TECHNIQUE_SET_INDEX,
};
use crate::gpu::{GpuView, GpuWorld};
use crate::graph::{Access, FrameGraph, PassContext, ResourceHandle, Tracked};
use crate::image::LinearImage;
use crate::plan::{Effects, Plan};
use crate::sampling::{ApertureShape, SampleTile, ShutterCurve, SAMPLE_TILE_SIZE};
use crate::shaders::{self, axes, ClustersComp, ShadeComp, StochasticFrag, StochasticGeom};
use crate::vk::{
    write_descriptors, Buffer, DescriptorPool, DescriptorSetLayout, DescriptorWrite, Faces, Feature,
    GraphicsDesc, Image, Pipeline, PipelineLayout, ShaderModule,
};

/// The registry entry.
pub const INFO: TechniqueInfo = TechniqueInfo {
    name: "stochastic",
    summary: "stochastic rasterization, visibility first: a conservative bound per triangle, the 5D inside \
              test per sample into a visibility buffer, then shading (McGuire et al. 2010; Toth & Linder 2008)",
    prepare,
};

fn prepare(ctx: &PrepareContext<'_>) -> Result<Box<dyn FrameTechnique>> {
    let effects = vec![Effects::Both; ctx.scene.objects.len()];
    Ok(Box::new(StochasticTechnique::new(ctx, ctx.settings.stochastic, DebugOptions::default(), &effects)?))
}

pub use crate::limits::MAX_STOCHASTIC_SPP;

/// How often the shading pass shades. Visibility is per sample either way.
#[derive(Clone, Copy, Debug, Default, PartialEq, Eq, Hash)]
pub enum ShadingRate {
    /// Once per pixel, pass and group of samples that hit the same triangle from the same side: the
    /// group's first sample is shaded and its radiance stands for the others (at most
    /// [`crate::reference::PER_PIXEL_SHADING_GROUPS`] groups per object; later ones are shaded per
    /// sample). The reference mirrors it ([`crate::reference::ReferenceSettings::shading`]). Not the
    /// default: its radiance is the shading of one point of the pixel's footprint on the triangle,
    /// so its error against the truth stops falling with S (a floor, measured per hard case in
    /// docs/HARD_CASES.md).
    PerPixel,
    /// Every sample shaded with its own hit, time and lens point: unbiased, the default (issue 28:
    /// per-pixel's floor showed up to 0.07 RMSE on hard cases for about 10 % less time).
    #[default]
    PerSample,
    /// Adaptive texture-space shading (Andersson et al. 2014; docs/ATSS.md): every object shaded once
    /// per frame into its own mip atlas at a level chosen per triangle ([`super::texture_space`],
    /// level 0 at most [`TEXTURE_SPACE_FINEST`]², fitted per object), at the lens centre and
    /// mid-shutter — or, for an object that turns in camera space within the shutter, at several
    /// times, weighed by the samples that see each texel then
    /// ([`crate::texture_space::rate::shading_time_count`]); every sample looks its radiance up there. Not mirrored by the reference (its shading is view-independent).
    TextureSpace,
    /// [`ShadingRate::TextureSpace`]'s atlases, looked up once per pixel and (triangle, side) group as
    /// [`ShadingRate::PerPixel`] shades — at the group's first hit (the paper's per-pixel, "MSAA",
    /// lookup: at the pixel centre).
    TextureSpacePerPixel,
    /// Decoupled shading (Ragan-Kelley et al. 2011; [`crate::decoupled`], docs/DECOUPLED.md): every
    /// sample takes the radiance of its key — (triangle, side, cell of `grid` around its surface point
    /// at mid-shutter through the lens centre) — which is shaded at the key's shading point. The grid:
    /// pixels (`decoupled`), or each triangle's adaptive anisotropic grid (Vaidyanathan et al. 2012,
    /// [`crate::aas::bounds`]: oriented along its motion, stretched by its blur; `aas`), or that grid
    /// for defocus only (`aas-isotropic`, the ablation). Where the radiance is kept:
    /// * `deferred: false`: a memoization cache of [`StochasticOptions::cache_entries`] direct-mapped
    ///   entries in the shading pass; a miss shades and stores.
    /// * `deferred: true` (Liktor & Dachsbacher 2012; names end in `-deferred`): a hash table of
    ///   [`StochasticOptions::cache_entries`] entries allocates each key of the frame once, a dispatch
    ///   of its own shades the new ones, and each sample then reads its entry (a key without room is
    ///   shaded on the spot).
    ///
    /// Mirrored by the reference ([`crate::reference::ReferenceShading::Decoupled`]): the same image
    /// whatever the cache.
    Decoupled { grid: crate::decoupled::GridKind, deferred: bool },
}

/// The largest level 0 side of the atlases of [`ShadingRate::TextureSpace`], texels — the paper's;
/// each object's is fitted to what its triangles ask for ([`super::texture_space::AtlasSize`]).
pub const TEXTURE_SPACE_FINEST: u32 = 2048;
/// Texels between the atlas' levels.
pub const TEXTURE_SPACE_GUTTER: u32 = 4;

impl ShadingRate {
    /// The rates the reference mirrors sample for sample ([`crate::reference::ReferenceShading`]).
    pub const ALL: [ShadingRate; 2] = [ShadingRate::PerPixel, ShadingRate::PerSample];
    /// Every rate, by name.
    pub const NAMED: [ShadingRate; 10] = {
        use crate::decoupled::GridKind::*;
        [
            ShadingRate::PerPixel,
            ShadingRate::PerSample,
            ShadingRate::TextureSpace,
            ShadingRate::TextureSpacePerPixel,
            ShadingRate::Decoupled { grid: Pixel, deferred: false },
            ShadingRate::Decoupled { grid: Aas, deferred: false },
            ShadingRate::Decoupled { grid: AasIsotropic, deferred: false },
            ShadingRate::Decoupled { grid: Pixel, deferred: true },
            ShadingRate::Decoupled { grid: Aas, deferred: true },
            ShadingRate::Decoupled { grid: AasIsotropic, deferred: true },
        ]
    };
    pub fn name(&self) -> &'static str {
        use crate::decoupled::GridKind::*;
        match self {
            ShadingRate::PerPixel => "per-pixel",
            ShadingRate::PerSample => "per-sample",
            ShadingRate::TextureSpace => "texture-space",
            ShadingRate::TextureSpacePerPixel => "texture-space-per-pixel",
            ShadingRate::Decoupled { grid: Pixel, deferred: false } => "decoupled",
            ShadingRate::Decoupled { grid: Aas, deferred: false } => "aas",
            ShadingRate::Decoupled { grid: AasIsotropic, deferred: false } => "aas-isotropic",
            ShadingRate::Decoupled { grid: Pixel, deferred: true } => "decoupled-deferred",
            ShadingRate::Decoupled { grid: Aas, deferred: true } => "aas-deferred",
            ShadingRate::Decoupled { grid: AasIsotropic, deferred: true } => "aas-isotropic-deferred",
        }
    }

    /// The reference's mirror of this rate ([`crate::reference::ReferenceShading`]) for a render of
    /// `per_pass` samples per pixel and pass; `None` for texture-space shading, which approximates
    /// the rate [`ShadingRate::exact`] gives.
    pub fn reference(&self, per_pass: u32) -> Option<crate::reference::ReferenceShading> {
        use crate::reference::ReferenceShading;
        match self {
            ShadingRate::PerSample => Some(ReferenceShading::PerSample),
            ShadingRate::PerPixel => Some(ReferenceShading::PerPixel { per_pass }),
            ShadingRate::TextureSpace | ShadingRate::TextureSpacePerPixel => None,
            decoupled => decoupled.decoupled_grid().map(ReferenceShading::Decoupled),
        }
    }

    /// The decoupled rates' grid (None for the others).
    pub fn decoupled_grid(&self) -> Option<crate::decoupled::GridKind> {
        match self {
            ShadingRate::Decoupled { grid, .. } => Some(*grid),
            _ => None,
        }
    }

    /// Whether this is a decoupled rate keeping its radiance in the deferred mode's hash table.
    pub fn deferred(&self) -> bool {
        matches!(self, ShadingRate::Decoupled { deferred: true, .. })
    }

    /// Whether samples look their radiance up in texture-space shading's atlases.
    pub fn texture_space(&self) -> bool {
        matches!(self, ShadingRate::TextureSpace | ShadingRate::TextureSpacePerPixel)
    }

    /// The exact rate whose samples and groups this one shades or looks up.
    pub fn exact(&self) -> ShadingRate {
        match self {
            ShadingRate::TextureSpace => ShadingRate::PerSample,
            ShadingRate::TextureSpacePerPixel => ShadingRate::PerPixel,
            exact => *exact,
        }
    }
}

impl std::str::FromStr for ShadingRate {
    type Err = Error;
    fn from_str(s: &str) -> Result<Self> {
        crate::error::parse_named(&ShadingRate::NAMED, |r| r.name(), "shading rate", s)
    }
}

/// Settings of the `stochastic` technique.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub struct StochasticOptions {
    /// The bound kind, or the device's calibrated choice ([`BoundChoice::Device`], the default).
    pub bound: BoundChoice,
    pub shading: ShadingRate,
    /// Count samples tested / hit and shading invocations with atomics (slower).
    pub instrumented: bool,
    /// Samples per pixel and pass M (S = M × passes): `None` takes all S in one pass where the
    /// visibility buffer fits [`VISIBILITY_BUDGET_BYTES`] ([`samples_per_pass`]); `Some(m)` forces m
    /// (an experiment: more passes, each paying the bounds' rasterization again).
    pub per_pass: Option<u32>,
    /// Geometry shader or compute-expanded hull ([`HullExpansion`]).
    pub expansion: HullExpansion,
    /// Interval bounds: into how many runs of time-ordered samples each object's draw is split, each
    /// bounded over its own sub-interval of the shutter ([`Intervals`]).
    pub intervals: Intervals,
    /// Cluster bounds: objects drawn one bound per cluster of triangles ([`Clusters`]).
    pub clusters: Clusters,
    /// [`ShadingRate::Decoupled`]: entries of the memoization cache or of the deferred mode's hash
    /// table, 1 ..= [`MAX_CACHE_ENTRIES`] (default [`DEFAULT_CACHE_ENTRIES`]).
    pub cache_entries: u32,
}

/// [`StochasticOptions::cache_entries`] by default.
pub const DEFAULT_CACHE_ENTRIES: u32 = 1 << 16;
/// The largest memoization cache (32 bytes an entry: 128 MiB).
pub const MAX_CACHE_ENTRIES: u32 = 1 << 22;
/// Bytes per entry of the memoization cache and of the deferred mode's hash table (`CacheEntry` in
/// `decoupled.glsl`).
pub const CACHE_ENTRY_BYTES: u64 = 32;
/// The deferred mode's queue (`DeferredQueue` in `decoupled.glsl`): its header's bytes, then 4 bytes
/// per hash-table entry; the shading dispatch's indirect arguments lie at this offset.
pub const DEFERRED_QUEUE_HEADER_BYTES: u64 = 32;
pub const DEFERRED_ARGS_OFFSET: u64 = 16;
/// The deferred mode's compact G-buffer: bytes per sample of a pass (its hash-table entry).
pub const DEFERRED_REF_BYTES: u64 = 4;
/// What an MSAA G-buffer would hold per sample for this engine's shading (`common/shading.glsl`'s
/// `shade` inputs): position and normal (3 × f32 each), albedo (3 × f32), specular and shininess
/// (f32 each), the shutter time (f32) — 48 bytes, without the visibility buffer's depth and triangle,
/// which both G-buffers share. The deferred mode's memory is compared with it
/// ([`DecoupledMemory`]).
pub const MSAA_GBUFFER_BYTES_PER_SAMPLE: u64 = 48;

/// Decoupled shading's buffers (`decoupled.glsl`).
struct DecoupledBuffers {
    /// The memoization cache or the deferred mode's hash table, cleared every frame.
    cache: Tracked<Buffer>,
    /// Every triangle's grid (frame numbering; vec4: axis, spacing along it, across it).
    grids: Buffer,
    /// The deferred mode's queue of new entries, with its shading dispatch's indirect arguments
    /// (cleared every frame), and its compact G-buffer: placeholders for the memoization cache.
    queue: Tracked<Buffer>,
    refs: Buffer,
    deferred: bool,
}

/// The deferred mode's memory ([`StochasticDraws::decoupled_memory`]) against the MSAA G-buffer of
/// [`MSAA_GBUFFER_BYTES_PER_SAMPLE`] it replaces: both per sample of a pass (what is held at once).
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub struct DecoupledMemory {
    /// Pixels × samples per pass.
    pub samples: u64,
    /// The compact G-buffer.
    pub refs_bytes: u64,
    /// The hash table and its queue.
    pub table_bytes: u64,
}

impl DecoupledMemory {
    pub fn bytes_per_sample(&self) -> f64 {
        (self.refs_bytes + self.table_bytes) as f64 / self.samples.max(1) as f64
    }
    pub fn msaa_gbuffer_bytes(&self) -> u64 {
        self.samples * MSAA_GBUFFER_BYTES_PER_SAMPLE
    }
}

/// Cluster bounds: an object is drawn with one bound per cluster of N triangles, neighbours in a Morton
/// order of their centroids ([`crate::bounds::cluster::cluster_order`]) (the union
/// of their `bbox` bounds, `clusters.comp`) instead of one per triangle; the fragment stage first
/// rejects each sample whose ray misses the cluster's camera-space box, then tests the cluster's
/// triangles. Same samples, same hits, same image: only the cost changes. It pays where many small
/// triangles share one blur disc (a dense, defocused mesh: the bounds of neighbouring triangles are
/// nearly the same disc, so one bound does the work of N), and costs where triangles are large or
/// sharp (each covered pixel then tests N triangles instead of the few whose bounds cover it).
#[derive(Clone, Copy, Debug, Default, PartialEq, Eq, Hash)]
pub enum Clusters {
    /// Per object ([`auto_clusters`]), clusters of [`DEFAULT_CLUSTER_TRIANGLES`].
    #[default]
    Auto,
    /// One bound per triangle for every object.
    Off,
    /// Clusters of N triangles (a power of two up to [`MAX_CLUSTER_TRIANGLES`]) for every object.
    Fixed(u32),
}

/// Triangles per cluster of [`Clusters::Auto`] (`shutter bench focus-sweep -c stochastic:clusters=8
/// -c stochastic:clusters=16 -c stochastic:clusters=32`, docs/STOCHASTIC.md).
pub const DEFAULT_CLUSTER_TRIANGLES: u32 = 16;
/// Largest cluster: the fragment stage loops over the cluster's triangles per sample.
pub const MAX_CLUSTER_TRIANGLES: u32 = 256;

impl std::str::FromStr for Clusters {
    type Err = Error;
    fn from_str(s: &str) -> Result<Self> {
        match s {
            "auto" => return Ok(Clusters::Auto),
            "off" => return Ok(Clusters::Off),
            _ => {}
        }
        power_of_two_at_most(s, MAX_CLUSTER_TRIANGLES).map(Clusters::Fixed).ok_or_else(|| {
            Error::Unsupported(format!(
                "clusters `{s}`: `auto`, `off` or a power of two up to {MAX_CLUSTER_TRIANGLES} (triangles per cluster)"
            ))
        })
    }
}

impl Clusters {
    pub fn name(&self) -> String {
        match self {
            Clusters::Auto => "auto".into(),
            Clusters::Off => "off".into(),
            Clusters::Fixed(n) => n.to_string(),
        }
    }
}

/// Does an object of `triangles` triangles whose clusters of `n` cover `cluster_area_px` pixels each
/// on average (their lens-centre screen boxes, [`mean_cluster_area_px`]) and whose blur radius is up
/// to `coc_px` pay off drawn in clusters? When a cluster fits in the blur disc: its bound is then
/// barely larger than one triangle's while replacing n of them. Objects with fewer than 2n triangles,
/// a blur under a pixel, no measured area (a vertex at the near plane) or clusters spread wider than
/// their blur (large triangles) keep one bound per triangle.
pub fn auto_clusters(triangles: usize, cluster_area_px: Option<f32>, coc_px: f32, n: u32) -> bool {
    let Some(area) = cluster_area_px else { return false };
    if triangles < 2 * n as usize || coc_px.is_nan() || coc_px < 1.0 {
        return false;
    }
    area <= std::f32::consts::PI * coc_px * coc_px
}

/// The order `mesh`'s triangles form clusters of `n` in, and the clusters' mean area in pixels
/// ([`mean_cluster_area_px`]): the stored order or a Morton order of the centroids
/// ([`crate::bounds::cluster::cluster_order`]), whichever gives the smaller clusters on screen (the
/// built-in meshes are generated patch by patch, tighter than a Morton curve; an OBJ may store its
/// triangles in any order). Without a measured area (a vertex at the near plane): the Morton order.
pub fn choose_cluster_order(
    mesh: &crate::scene::Mesh,
    model_view: glam::Mat4,
    k: &crate::scene::Intrinsics,
    n: usize,
) -> (Vec<u32>, Option<f32>) {
    let stored: Vec<u32> = (0..mesh.triangle_count() as u32).collect();
    let morton = crate::bounds::cluster::cluster_order(mesh);
    // The vertices projected once for both orders.
    let projected = project_vertices(mesh, model_view, k);
    let a = mean_cluster_area(mesh, &projected, &stored, n);
    let b = mean_cluster_area(mesh, &projected, &morton, n);
    match (a, b) {
        (Some(a), Some(b)) if a <= b => (stored, Some(a)),
        (_, b) => (morton, b),
    }
}

/// Lens-centre pixel positions of `mesh`'s vertices through `model_view`; `None` for a vertex at or
/// behind the near plane of `k`.
fn project_vertices(
    mesh: &crate::scene::Mesh,
    model_view: glam::Mat4,
    k: &crate::scene::Intrinsics,
) -> Vec<Option<glam::Vec2>> {
    mesh.positions
        .iter()
        .map(|&p| {
            let v = model_view.transform_point3(p);
            (-v.z > k.near).then(|| k.project(v, glam::Vec2::ZERO))
        })
        .collect()
}

/// Mean area of the pixel boxes of the clusters of `n` triangles (runs of `order`) of `mesh`, whose
/// vertices project to `projected`; `None` when a clustered vertex has no projection or there is no
/// cluster.
fn mean_cluster_area(
    mesh: &crate::scene::Mesh,
    projected: &[Option<glam::Vec2>],
    order: &[u32],
    n: usize,
) -> Option<f32> {
    let (mut sum, mut count) = (0.0f64, 0usize);
    for cluster in order.chunks(n.max(1)) {
        let (mut lo, mut hi) = (glam::Vec2::INFINITY, glam::Vec2::NEG_INFINITY);
        for &t in cluster {
            for &i in &mesh.indices[3 * t as usize..3 * t as usize + 3] {
                let p = projected[i as usize]?;
                (lo, hi) = (lo.min(p), hi.max(p));
            }
        }
        sum += ((hi.x - lo.x) * (hi.y - lo.y)).max(0.0) as f64;
        count += 1;
    }
    (count > 0).then(|| (sum / count as f64) as f32)
}

/// The key segments an object's bounds span over the whole shutter, as `(first segment, segment count,
/// t0, t1)` with `[t0, t1]` the local times bounded in each: every segment over (0, 1) for an object
/// drawn with motion, the one segment holding mid-shutter at its local time (t0 = t1) for one drawn
/// without (NO_MOTION). Shared by the coverage draws, the cluster bounds and the compute-expanded hull.
pub fn bounded_segments(keys: &KeyTimes, motion: bool) -> (u32, u32, f32, f32) {
    if motion {
        (0, keys.segments() as u32, 0.0, 1.0)
    } else {
        let (j, s) = keys.locate(0.5);
        (j as u32, 1, s, s)
    }
}

/// Mean area in pixels of the lens-centre screen boxes of `mesh`'s clusters of `n` triangles (runs of
/// `order`) through `model_view` (the object at shutter open) — how compact its clusters are on
/// screen; `None` when a vertex is at or behind the near plane of `k`.
pub fn mean_cluster_area_px(
    mesh: &crate::scene::Mesh,
    order: &[u32],
    model_view: glam::Mat4,
    k: &crate::scene::Intrinsics,
    n: usize,
) -> Option<f32> {
    mean_cluster_area(mesh, &project_vertices(mesh, model_view, k), order, n)
}

/// How many shutter sub-intervals an object's samples are bounded in, per pass. The samples of a pixel
/// come in time order ([`crate::sampling::pixel_sample_set`]), so run k of K holds exactly the shutter
/// times of `[k/K, (k+1)/K)` (warped by the shutter curve): the draw for run k bounds the triangle
/// between its positions at those two times — a shorter smear, fewer samples per fragment, more draws.
/// Same samples, same hits, same image whatever K: only the cost changes.
#[derive(Clone, Copy, Debug, Default, PartialEq, Eq, Hash)]
pub enum Intervals {
    /// Per object from its screen motion and blur ([`auto_intervals`]).
    #[default]
    Auto,
    /// K for every moving object whose motion is bounded (a power of two; clamped to the samples per
    /// pass).
    Fixed(u32),
}

/// `s` as a power of two no larger than `max` (the numeric values of [`Intervals`] and [`Clusters`]).
fn power_of_two_at_most(s: &str, max: u32) -> Option<u32> {
    s.parse::<u32>().ok().filter(|n| n.is_power_of_two() && *n <= max)
}

impl std::str::FromStr for Intervals {
    type Err = Error;
    fn from_str(s: &str) -> Result<Self> {
        if s == "auto" {
            return Ok(Intervals::Auto);
        }
        power_of_two_at_most(s, MAX_STOCHASTIC_SPP).map(Intervals::Fixed).ok_or_else(|| {
            Error::Unsupported(format!(
                "intervals `{s}`: `auto` or a power of two up to {MAX_STOCHASTIC_SPP}"
            ))
        })
    }
}

impl Intervals {
    pub fn name(&self) -> String {
        match self {
            Intervals::Auto => "auto".into(),
            Intervals::Fixed(k) => k.to_string(),
        }
    }
}

/// Cost of one sample test relative to one fragment invocation of the coverage pass: the ratio the
/// interval count trades. Measured on llvmpipe from `shutter bench default -c stochastic:intervals=1
/// -c stochastic:intervals=4` (fragments and samples tested of each, solved for the two unit costs:
/// ≈ 175 ns a fragment, ≈ 16.5 ns a sample test; `docs/STOCHASTIC.md`).
pub const SAMPLE_TEST_COST_PER_FRAGMENT: f32 = 0.1;

/// Interval count for an object whose vertices move up to `motion_px` over the shutter with blur
/// radius up to `coc_px`, at `per_pass` samples per pass. A triangle's bound spans about
/// `a = 2·coc + 8` px across the motion (a small triangle plus its blur) and `a + m` along it; K runs
/// rasterize about `K·a + m` in that direction, each fragment testing `per_pass / K` samples, so the
/// cost is about `(K·a + m)·(1 + c·per_pass/K)` (c = [`SAMPLE_TEST_COST_PER_FRAGMENT`]): the power of
/// two in `1..=per_pass` where it is least.
pub fn auto_intervals(motion_px: f32, coc_px: f32, per_pass: u32) -> u32 {
    if motion_px.is_nan() || motion_px <= 0.0 || per_pass <= 1 {
        return 1;
    }
    let m = motion_px.min(1e6);
    let a = 2.0 * coc_px.max(0.0) + 8.0;
    let cost =
        |k: u32| (k as f32 * a + m) * (1.0 + SAMPLE_TEST_COST_PER_FRAGMENT * per_pass as f32 / k as f32);
    let mut best = 1;
    let mut k = 2;
    while k <= per_pass {
        if cost(k) < cost(best) {
            best = k;
        }
        k *= 2;
    }
    best
}

impl Default for StochasticOptions {
    fn default() -> Self {
        StochasticOptions {
            bound: BoundChoice::Device,
            shading: ShadingRate::PerSample,
            instrumented: false,
            per_pass: None,
            expansion: HullExpansion::GeometryShader,
            intervals: Intervals::Auto,
            clusters: Clusters::Auto,
            cache_entries: DEFAULT_CACHE_ENTRIES,
        }
    }
}

/// Which bound a render uses: a kind, the one measured fastest on the device, or one per object.
#[derive(Clone, Copy, Debug, Default, PartialEq, Eq, Hash)]
pub enum BoundChoice {
    /// The device's calibrated bound ([`device_bound`]).
    #[default]
    Device,
    Kind(BoundKind),
    /// A kind per object from its blur ([`ObjectBoundPolicy`], the thesis' §4.7 per-object level).
    PerObject(ObjectBoundPolicy),
}

/// The thesis' macroscopic level of adaptive switching (§4.7): each object draws one bound kind,
/// chosen on the CPU from the object's largest circle of confusion in pixels over its depth range
/// ([`crate::plan::ObjectPlan::max_coc_px`], from the object-level bounds an engine keeps for culling):
/// `sharp` up to `threshold_px`, `blurred` above. Either kind may be `adaptive`, the per-triangle
/// level. The bound never changes the image, only its cost. Command line: `per-object` (the
/// thesis' pair at [`ObjectBoundPolicy::THESIS`]) or `per-object/SHARP/BLURRED/PX`.
/// `shutter bounds --focus ... --per-object SHARP/BLURRED` measures the threshold on a focus sweep.
#[derive(Clone, Copy, Debug)]
pub struct ObjectBoundPolicy {
    pub sharp: BoundKind,
    pub blurred: BoundKind,
    pub threshold_px: f32,
}

impl ObjectBoundPolicy {
    /// The thesis' pair (§9.1: the reduced wedge where little is blurred, the 3D hexagon where much
    /// is). The threshold is measured, not the thesis': `shutter bounds docs/scenes/thesis-sweep.toml
    /// --per-object reduced-wedge/3d-hexagon ...` (docs/THESIS.md, "Per-object switching").
    pub const THESIS: ObjectBoundPolicy = ObjectBoundPolicy {
        sharp: BoundKind::ReducedWedge,
        blurred: BoundKind::Hexagon3d,
        threshold_px: PER_OBJECT_THRESHOLD_PX,
    };

    /// The kind an object whose largest circle of confusion is `max_coc_px` pixels draws (NaN:
    /// `blurred`).
    pub fn kind(&self, max_coc_px: f32) -> BoundKind {
        if max_coc_px <= self.threshold_px {
            self.sharp
        } else {
            self.blurred
        }
    }

    /// `SHARP/BLURRED/PX`, the command-line spelling after `per-object/`.
    pub fn spelling(&self) -> String {
        format!("{}/{}/{}", self.sharp.name(), self.blurred.name(), self.threshold_px)
    }
}

impl PartialEq for ObjectBoundPolicy {
    fn eq(&self, o: &Self) -> bool {
        self.sharp == o.sharp
            && self.blurred == o.blurred
            && self.threshold_px.to_bits() == o.threshold_px.to_bits()
    }
}
impl Eq for ObjectBoundPolicy {}
impl std::hash::Hash for ObjectBoundPolicy {
    fn hash<H: std::hash::Hasher>(&self, h: &mut H) {
        (self.sharp, self.blurred, self.threshold_px.to_bits()).hash(h)
    }
}

impl std::str::FromStr for ObjectBoundPolicy {
    type Err = Error;
    /// `SHARP/BLURRED/PX` (PX ≥ 0, finite; `inf` is allowed: always `sharp`).
    fn from_str(s: &str) -> Result<Self> {
        let bad = || {
            Error::Unsupported(format!(
                "per-object bound `{s}`: want SHARP/BLURRED/PX, e.g. bbox/convex-hull/4"
            ))
        };
        let parts: Vec<&str> = s.split('/').collect();
        let [sharp, blurred, px] = parts[..] else { return Err(bad()) };
        let threshold_px: f32 = px.parse().map_err(|_| bad())?;
        if threshold_px.is_nan() || threshold_px < 0.0 {
            return Err(bad());
        }
        Ok(ObjectBoundPolicy { sharp: sharp.parse()?, blurred: blurred.parse()?, threshold_px })
    }
}

impl From<BoundKind> for BoundChoice {
    fn from(k: BoundKind) -> Self {
        BoundChoice::Kind(k)
    }
}

impl std::str::FromStr for BoundChoice {
    type Err = Error;
    fn from_str(s: &str) -> Result<Self> {
        if s == "device" {
            return Ok(BoundChoice::Device);
        }
        if s == "per-object" {
            return Ok(BoundChoice::PerObject(ObjectBoundPolicy::THESIS));
        }
        if let Some(policy) = s.strip_prefix("per-object/") {
            return policy.parse().map(BoundChoice::PerObject);
        }
        s.parse::<BoundKind>()
            .map(BoundChoice::Kind)
            .map_err(|e| Error::Unsupported(format!("{e}, device, per-object[/SHARP/BLURRED/PX]")))
    }
}

impl BoundChoice {
    pub fn name(&self) -> String {
        match self {
            BoundChoice::Device => "device".into(),
            BoundChoice::Kind(k) => k.name().into(),
            BoundChoice::PerObject(p) => format!("per-object/{}", p.spelling()),
        }
    }
    /// The kind this choice means on a device for an object whose largest circle of confusion is
    /// `max_coc_px` pixels.
    pub fn resolve(&self, caps: &crate::vk::Capabilities, max_coc_px: f32) -> BoundKind {
        match self {
            BoundChoice::Device => device_bound(caps).0,
            BoundChoice::Kind(k) => *k,
            BoundChoice::PerObject(p) => p.kind(max_coc_px),
        }
    }
}

/// [`ObjectBoundPolicy::THESIS`]'s threshold: the largest circle of confusion, in pixels, up to which
/// an object draws the reduced wedge rather than the 3D hexagon. Measured, not the thesis' (which gives
/// none): over the thesis scene's focus sweep every object drawn as the reduced wedge tests more samples
/// than as the 3D hexagon (1.34× the samples with every object on it; GPU ms within the frames' noise),
/// so only an object without any blur — where both volumes are the triangle itself — takes it
/// (`shutter bounds docs/scenes/thesis-sweep.toml --spp 16 --frames 3 --warmup 1 --focus
/// 2.5,3,...,30 --per-object reduced-wedge/3d-hexagon`, llvmpipe; docs/THESIS.md, "Per-object
/// switching").
pub const PER_OBJECT_THRESHOLD_PX: f32 = 0.0;

/// Bound used without a chosen one on this device, and why: the driver's calibration
/// ([`crate::calibration::device_bound`]). The bounds all give the same image (only their cost
/// differs), and which is cheapest depends on the rasterizer: llvmpipe pays per strip triangle and per
/// 4×4 block a bound touches, so the two-triangle box beats the tighter many-triangle hull; a GPU
/// rasterizer's per-triangle cost is small and the hull's fewer sample tests should win (not measured:
/// no GPU was available), hence `adaptive` for devices not calibrated.
pub fn device_bound(caps: &crate::vk::Capabilities) -> (BoundKind, String) {
    crate::calibration::device_bound(caps)
}

/// Counters of an instrumented render, summed over all passes.
#[derive(Clone, Copy, Debug, Default, PartialEq, Eq)]
pub struct SampleCounters {
    /// Coverage fragment shader invocations (pixels × passes the bounds touched).
    pub fragments: u64,
    /// (x, y, u, v, t) samples run through the inside test.
    pub samples_tested: u64,
    /// Samples the inside test accepted (before the visibility buffer keeps the nearest).
    pub samples_hit: u64,
    /// Shading evaluations of the shading pass (per pixel: one per group; per sample: visible hits;
    /// texture-space shading: atlas lookups).
    pub shading_invocations: u64,
    /// Texture-space shading: the atlas texels pass 1 shaded, by its shade and its conservative
    /// sub-pass (None with the other rates).
    pub atlas_texels: Option<(u64, u64)>,
    /// Decoupled shading: the memoization cache's counters (None with the other rates).
    pub cache: Option<CacheCounters>,
}

/// What the memoization cache of decoupled shading did over a frame (`decoupled.glsl`). Every keyed
/// sample looks its key up once: `lookups − hits` keys were shaded (misses); samples without a key
/// (`shading_invocations − misses` of them) are shaded at their own hit. In the deferred mode a lookup
/// either finds its key (a hit), claims a new entry (shaded once by the shading dispatch) or overflows
/// (shaded on the spot); there are no evictions nor lost stores.
#[derive(Clone, Copy, Debug, Default, PartialEq, Eq)]
pub struct CacheCounters {
    pub lookups: u64,
    pub hits: u64,
    /// Stores that replaced another key's entry.
    pub evictions: u64,
    /// Stores skipped because another invocation held the entry.
    pub busy: u64,
    /// The deferred mode: keyed samples whose key found no entry within
    /// [`crate::decoupled::DEFERRED_PROBES`] of the hash table's (shaded on the spot).
    pub overflows: u64,
    /// The deferred mode's memory (None for the memoization cache).
    pub memory: Option<DecoupledMemory>,
}

impl CacheCounters {
    pub fn misses(&self) -> u64 {
        self.lookups - self.hits
    }
}

/// u32 counters of the counters buffer (`Counters` in `stochastic.frag` and `shade.comp`).
const COUNTERS: usize = 9;

impl SampleCounters {
    /// Sample test efficiency: hits / tested (McGuire et al. 2010).
    pub fn sample_test_efficiency(&self) -> f64 {
        if self.samples_tested == 0 {
            0.0
        } else {
            self.samples_hit as f64 / self.samples_tested as f64
        }
    }
}

/// Push constants of the stochastic pipelines (`stochastic/push.glsl`).
#[repr(C)]
#[derive(Clone, Copy, Debug, Pod, Zeroable)]
pub struct StochasticPush {
    pub object: u32,
    pub bound: u32,
    pub pass_index: u32,
    pub spp: u32,
    pub per_pass: u32,
    pub dilate: f32,
    pub sample_first: u32,
    pub sample_count: u32,
    pub t0: f32,
    pub t1: f32,
    pub origin_x: u32,
    pub origin_y: u32,
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
    /// Texture-space shading: the atlases' level 0 side and gutter (0 elsewhere).
    pub atlas_finest: u32,
    pub atlas_gutter: u32,
    /// 1: the object's material is one-sided; the coverage stage drops hits on its back.
    pub one_sided: u32,
    /// Decoupled shading: entries of the memoization cache or hash table (0 elsewhere).
    pub cache_entries: u32,
    /// Decoupled shading: the dispatch's phase ([`DecoupledPhase`]; 0, the memoization cache, elsewhere).
    pub decoupled_phase: u32,
}

/// The dispatches of decoupled shading per object and pass (`DC_PHASE_*` in `decoupled.glsl`): the
/// memoization cache's one, or the deferred mode's four.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
#[repr(u32)]
pub enum DecoupledPhase {
    Memo = 0,
    /// Per pixel: each sample's key found in or added to the hash table, its entry in the compact
    /// G-buffer.
    Allocate = 1,
    /// One invocation: the new entries' range and the next dispatch's indirect arguments.
    Args = 2,
    /// Indirect, one invocation per new entry: its shading point shaded.
    Shade = 3,
    /// Per pixel: each sample's radiance read from its entry (or shaded on the spot).
    Resolve = 4,
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
const CLUSTER_BYTES: u64 = 3 * 16;

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

/// Set 3 of the stochastic rasterizer: the sample tile, counters, bound debug output, hull counts, the
/// visibility buffer and the accumulation image.
pub const STOCHASTIC_SET: [Binding; 12] = [
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
];

/// `StochasticPush::object` of the shading pass' dispatch that adds the background for the samples
/// without a hit (`SHADE_BACKGROUND` in `shade.comp`).
pub const SHADE_BACKGROUND: u32 = u32::MAX;

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
        StochasticPush,
        [
            object,
            bound,
            pass_index,
            spp,
            per_pass,
            dilate,
            sample_first,
            sample_count,
            t0,
            t1,
            origin_x,
            origin_y,
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
            atlas_finest,
            atlas_gutter,
            one_sided,
            cache_entries,
            decoupled_phase
        ]
    ),
    shared_struct!("Push", TrianglesPush, [segment_first, keys, triangle_count]),
    shared_struct!(
        "Push",
        ClustersPush,
        [triangle_count, cluster_size, segment_count, segment, t0, t1, one_sided]
    ),
];

/// Samples per pixel and pass M and passes P (S = M × P) for `pixels` pixels, the per-sample buffers
/// (`bytes` per pixel and sample of a pass: [`VISIBILITY_BYTES`], plus [`TINT_BYTES`] with tints) at
/// most `max_bytes` — [`VISIBILITY_BUDGET_BYTES`] or the device's `maxStorageBufferRange`, whichever is
/// less: `forced` when given (it must divide S and fit), else the largest divisor of S that fits.
pub fn samples_per_pass(
    spp: u32,
    forced: Option<u32>,
    pixels: u64,
    bytes: u64,
    max_bytes: u64,
) -> Result<(u32, u32)> {
    let fits = |m: u32| pixels * m as u64 * bytes <= max_bytes;
    match forced {
        Some(m) if m > 0 && spp.is_multiple_of(m) && fits(m) => Ok((m, spp / m)),
        Some(m) if m > 0 && spp.is_multiple_of(m) => Err(Error::Limit {
            what: "samples per pass",
            value: m.to_string(),
            limit: format!(
                "per-sample buffers of {pixels} pixels × M × {bytes} bytes within {max_bytes} bytes"
            ),
        }),
        Some(m) => Err(Error::Unsupported(format!("{m} samples per pass for S = {spp}: it must divide S"))),
        None => match (1..=spp).rev().find(|&m| spp.is_multiple_of(m) && fits(m)) {
            Some(m) => Ok((m, spp / m)),
            None => Err(Error::Limit {
                what: "image size",
                value: format!("{pixels} pixels"),
                limit: format!(
                    "per-sample buffers of one sample per pixel ({bytes} bytes each) within {max_bytes} bytes"
                ),
            }),
        },
    }
}

/// The sample tile as the fragment shader reads it: (x, y, lens u, lens v) and time per sample.
pub fn gpu_samples(
    spp: u32,
    seed: u64,
    aperture: ApertureShape,
    shutter: ShutterCurve,
) -> (Vec<[f32; 4]>, Vec<f32>) {
    let tile = SampleTile::new(spp, SAMPLE_TILE_SIZE, seed);
    let n = (SAMPLE_TILE_SIZE * SAMPLE_TILE_SIZE * spp) as usize;
    let (mut xy_lens, mut time) = (Vec::with_capacity(n), Vec::with_capacity(n));
    for y in 0..SAMPLE_TILE_SIZE {
        for x in 0..SAMPLE_TILE_SIZE {
            for s in tile.pixel(x, y) {
                let lens = aperture.map(s.lens);
                xy_lens.push([s.xy.x, s.xy.y, lens.x, lens.y]);
                time.push(shutter.warp(s.time));
            }
        }
    }
    (xy_lens, time)
}

impl ShadingRate {
    fn axis(self) -> axes::Shading {
        match self {
            ShadingRate::PerPixel => axes::Shading::PerPixel,
            ShadingRate::PerSample => axes::Shading::PerSample,
            ShadingRate::TextureSpace => axes::Shading::TextureSpace,
            ShadingRate::TextureSpacePerPixel => axes::Shading::TextureSpacePerPixel,
            ShadingRate::Decoupled { .. } => axes::Shading::Decoupled,
        }
    }
}

/// The pixels (x, y, width, height) an object's shading dispatch covers: its planned screen box (every
/// circle of confusion of every vertex at both shutter ends, `ObjectPlan::screen_box`) widened by a
/// pixel and by the f32 slack between the CPU's and the GPU's camera-space vertices, clamped to the
/// image; the whole image when the box is unbounded (a vertex at the near plane). Every sample the
/// object can cover lies in the pixels of its bounds, which lie in that box, so the dispatch scans only
/// those pixels of the visibility buffer.
pub fn shading_rect(screen_box: Option<(glam::Vec2, glam::Vec2)>, (w, h): (u32, u32)) -> [u32; 4] {
    let Some((lo, hi)) = screen_box else { return [0, 0, w, h] };
    let size = glam::Vec2::new(w as f32, h as f32);
    let slack = |v: glam::Vec2| glam::Vec2::splat(1.0) + v.abs() * 1e-4 + size * 1e-4;
    let (lo, hi) = ((lo - slack(lo)).floor(), (hi + slack(hi)).ceil());
    if !(lo.is_finite() && hi.is_finite()) {
        return [0, 0, w, h];
    }
    let (x0, y0) = (lo.x.clamp(0.0, w as f32) as u32, lo.y.clamp(0.0, h as f32) as u32);
    let (x1, y1) = (hi.x.clamp(0.0, w as f32) as u32, hi.y.clamp(0.0, h as f32) as u32);
    [x0, y0, x1.saturating_sub(x0), y1.saturating_sub(y0)]
}

/// Bytes per camera-space triangle and motion key (`triangles.comp`): 3 vertices × xyz.
const TRIANGLE_KEY_BYTES: u64 = 9 * 4;

/// Extra knobs for tests: the geometry shader's debug output of every triangle's bound.
#[derive(Clone, Copy, Debug, Default)]
pub struct DebugOptions {
    /// Capacity, in triangles, of the bound debug buffer (0 = off).
    pub bound_debug_triangles: u32,
    /// Initial hull buffer capacity per triangle of the compute expansion (None: the default; a tiny
    /// value exercises the overflow path).
    pub hull_vertices_per_triangle: Option<u32>,
}

/// Floats per triangle in the bound debug buffer (see `stochastic.geom`).
pub const BOUND_DEBUG_STRIDE: usize = 8 + 2 * 48;

/// The stochastic path of a set of objects: coverage pipelines (one shader permutation per effect path
/// in use) and their shading pipelines, the sample tile, the view's camera-space triangles, the
/// visibility buffer, the accumulation image, counters.
///
/// Every object takes one path ([`Effects`]): `object_effects[i]`; [`Effects::Pinhole`] objects (from
/// `auto`'s planner) take the `still` permutation — bounded and tested at mid-shutter through the lens
/// centre — so every object of the frame meets the others in the same visibility buffer.
pub struct StochasticDraws {
    pipelines: Vec<(Effects, Pipeline)>,
    shade_pipelines: Vec<(Effects, Pipeline)>,
    /// The tint pass' pipelines (geometry-shader hull), per path with a tinted object.
    tint_pipelines: Vec<(Effects, Pipeline)>,
    /// Each object's tint as [`crate::transparency::tint_log`] (None: not tinted).
    object_tint_log: Vec<Option<[u32; 3]>>,
    /// Σ −log₂ T per channel, pixel and sample of a pass (with tinted objects only).
    tints: Option<Tracked<Buffer>>,
    /// The decoupled rates' buffers.
    decoupled: Option<DecoupledBuffers>,
    /// Texture-space shading's pass 1 ([`ShadingRate::TextureSpace`]), and the sampler its shading
    /// pass reads the atlases with.
    atlas: Option<super::texture_space::AtlasPasses>,
    _atlas_sampler: Option<crate::vk::Sampler>,
    object_effects: Vec<Effects>,
    /// Interval bounds per object and pass ([`Intervals`]; 1 on the still and defocus-only paths).
    object_intervals: Vec<u32>,
    /// Triangles per cluster of each object's cluster bounds (0: one bound per triangle; [`Clusters`]).
    object_clusters: Vec<u32>,
    /// Each clustered object's cluster bounds (`clusters.comp`: per key segment and cluster).
    cluster_buffers: Vec<Option<Tracked<Buffer>>>,
    /// Each clustered object's triangles in cluster order ([`crate::bounds::cluster::cluster_order`]).
    _cluster_orders: Vec<Buffer>,
    /// Coverage pipelines behind the cluster bounds, and the `clusters.comp` pipelines, per path.
    cluster_pipelines: Vec<(Effects, Pipeline)>,
    clusters_pipelines: Vec<(Effects, Pipeline)>,
    clusters_layout: PipelineLayout,
    /// Pixels (x, y, width, height) each object's shading dispatch covers ([`shading_rect`]).
    shade_rects: Vec<[u32; 4]>,
    /// Each object's first triangle in the frame's numbering (the visibility payload), and its count.
    triangle_bases: Vec<u32>,
    triangle_counts: Vec<u32>,
    /// Each object's motion key times (its segments are drawn and bounded one by one).
    object_keys: Vec<KeyTimes>,
    /// The camera's shutter curve: run k of K covers the warped times of `[k/K, (k+1)/K)`.
    shutter: ShutterCurve,
    layout: PipelineLayout,
    shade_layout: PipelineLayout,
    push_stages: vk::ShaderStageFlags,
    /// Set 2 per object ([`STOCHASTIC_OBJECT_SET`]).
    object_sets: Vec<vk::DescriptorSet>,
    /// Set 3 ([`STOCHASTIC_SET`]).
    technique_set: vk::DescriptorSet,
    options: StochasticOptions,
    /// The bound kind each object draws ([`BoundChoice::resolve`]).
    bounds: Vec<BoundKind>,
    /// Each object's coverage α (stochastic transparency; 1 for opaque objects).
    object_alpha: Vec<f32>,
    /// Per object: coverage from the texture's alpha too (with a texture and uvs, as the reference).
    object_texture_alpha: Vec<bool>,
    /// Per object: a one-sided material, whose back faces no sample sees.
    object_one_sided: Vec<bool>,
    /// [`crate::transparency::coverage_seed`] of the render seed.
    coverage_seed: u32,
    spp: u32,
    per_pass: u32,
    passes: u32,
    size: (u32, u32),
    /// Box half-size of the bound dilation ([`crate::bounds::dilation_px`] for one sample per pixel).
    dilate: f32,
    counters: Tracked<Buffer>,
    bound_debug: Option<Tracked<Buffer>>,
    /// The camera view's triangles at shutter open and close, per object (`triangles.comp`).
    triangles: Vec<Tracked<Buffer>>,
    triangles_pipeline: Pipeline,
    triangles_layout: PipelineLayout,
    /// One 64-bit word per pixel and sample of a pass (`visibility.glsl`).
    visibility: Tracked<Buffer>,
    /// Σ (radiance, 1) / S over every sample of the frame.
    accum: Tracked<Image>,
    /// The compute-expanded hull's buffers and pipelines ([`HullExpansion::Compute`]).
    hull: Option<ComputeHull>,
    /// Vertices of each object's expanded hull this frame (compute expansion).
    hull_counts: Vec<u32>,
    _samples: [Buffer; 2],
    _pool: DescriptorPool,
    _set_layouts: [DescriptorSetLayout; 2],
    _shaders: Vec<ShaderModule>,
    /// The shadow-casting lights' maps (static casters only: rendered once per frame), read by the
    /// shading pass as set 4. Last, so dropped after the pipelines whose layouts name its set layout.
    shadows: Option<ShadowMaps>,
}

impl StochasticDraws {
    /// The path for `object_effects` (one per object of the world) at the settings' samples per pixel
    /// and seed, through the scene camera's aperture shape and shutter curve; `plan` (of the same view)
    /// gives each object's motion, blur and screen box.
    fn new(
        ctx: &PrepareContext<'_>,
        options: StochasticOptions,
        debug: DebugOptions,
        plan: &Plan,
        object_effects: &[Effects],
    ) -> Result<Self> {
        let (device, world) = (ctx.device, ctx.world);
        let (spp, seed) = (ctx.settings.spp, ctx.settings.seed);
        let (aperture, shutter) = (ctx.scene.camera.aperture, ctx.scene.camera.shutter);
        let (width, height) = ctx.camera.size();
        let caps = &device.caps;
        if object_effects.len() != world.objects.len() {
            return Err(Error::Unsupported(format!(
                "{} object paths for {} objects",
                object_effects.len(),
                world.objects.len()
            )));
        }
        let mut paths: Vec<Effects> = object_effects.to_vec();
        paths.sort();
        paths.dedup();
        if options.expansion == HullExpansion::GeometryShader {
            caps.require(
                Feature::GeometryShader,
                "technique `stochastic` with the geometry-shader hull (--hull compute needs none)",
            )?;
        }
        caps.require(
            Feature::FragmentStoresAndAtomics,
            "the stochastic visibility buffer (coverage atomics)",
        )?;
        caps.require(Feature::BufferInt64Atomics, "the stochastic visibility buffer (64-bit atomicMax)")?;
        let compute = options.expansion == HullExpansion::Compute;
        if compute && debug.bound_debug_triangles > 0 {
            return Err(Error::Unsupported(
                "the bound debug output exists for the geometry-shader hull only".into(),
            ));
        }
        if debug.bound_debug_triangles > 0 {
            caps.require(Feature::VertexPipelineStoresAndAtomics, "the bound debug output")?;
            if paths.iter().any(|&e| e != Effects::Both) {
                return Err(Error::Unsupported(
                    "the bound debug output exists for the defocus+motion path only".into(),
                ));
            }
        }
        if spp == 0 || spp > MAX_STOCHASTIC_SPP {
            return Err(Error::Limit {
                what: "spp",
                value: spp.to_string(),
                limit: format!("1..={MAX_STOCHASTIC_SPP} for technique `stochastic`"),
            });
        }
        // Object i's triangles are numbered from triangle_bases[i] on in the visibility payloads.
        let mut triangle_bases = Vec::with_capacity(world.objects.len());
        let mut total: u64 = 0;
        for o in &world.objects {
            triangle_bases.push(total as u32);
            total += o.triangle_count() as u64;
            if total >= MAX_FRAME_TRIANGLES {
                return Err(Error::Limit {
                    what: "triangles",
                    value: format!("more than {MAX_FRAME_TRIANGLES}"),
                    limit: format!("below {MAX_FRAME_TRIANGLES} in one frame of technique `stochastic`"),
                });
            }
        }
        // Tinted objects (coverage below 1 and a tint): a tint pass per frame pass behind the geometry
        // shader's one-piece convex hull (every sample tested once per triangle), and a tint buffer.
        let transparent = super::forward::transparent_objects(ctx.scene);
        let object_tint_log: Vec<Option<[u32; 3]>> = transparent
            .iter()
            .map(|o| o.tinted.then(|| crate::transparency::tint_log([o.tint[0], o.tint[1], o.tint[2]])))
            .collect();
        let tinted = object_tint_log.iter().any(Option::is_some);
        if tinted {
            caps.require(
                Feature::GeometryShader,
                "tints in technique `stochastic` (the tint pass draws behind the geometry-shader hull)",
            )?;
        }
        let max_bytes = VISIBILITY_BUDGET_BYTES.min(caps.max_storage_buffer_range as u64);
        let pixels = width as u64 * height as u64;
        let sample_bytes = VISIBILITY_BYTES + if tinted { TINT_BYTES } else { 0 };
        let (per_pass, passes) = samples_per_pass(spp, options.per_pass, pixels, sample_bytes, max_bytes)?;
        // Cluster bounds: with the geometry-shader path (the compute hull and the bound debug output
        // are per triangle), per object (0: one bound per triangle).
        let intrinsics = ctx.scene.camera.intrinsics(width, height);
        // Each object's cluster order and mean cluster area, measured where clusters may be drawn.
        let mut cluster_orders_cpu: Vec<Option<(Vec<u32>, Option<f32>)>> = vec![None; world.objects.len()];
        let object_clusters: Vec<u32> = plan
            .objects
            .iter()
            .zip(&world.objects)
            .enumerate()
            .map(|(i, (o, g))| {
                if compute || debug.bound_debug_triangles > 0 || g.triangle_count() == 0 {
                    return 0;
                }
                let mut order = |n: u32| {
                    let mesh = &ctx.scene.objects[i].mesh;
                    let mv = ctx.camera.space.objects[i].model_view[0];
                    let chosen = choose_cluster_order(mesh, mv, &intrinsics, n as usize);
                    let area = chosen.1;
                    cluster_orders_cpu[i] = Some(chosen);
                    area
                };
                match options.clusters {
                    Clusters::Off => 0,
                    Clusters::Fixed(n) => {
                        order(n);
                        n
                    }
                    Clusters::Auto => {
                        let n = DEFAULT_CLUSTER_TRIANGLES;
                        // Worth measuring only for an object with a blur and triangles to spare.
                        let candidate =
                            o.max_coc_px >= 1.0 && o.triangles >= 2 * n as usize && !o.crosses_near;
                        if candidate && auto_clusters(o.triangles, order(n), o.max_coc_px, n) {
                            n
                        } else {
                            0
                        }
                    }
                }
            })
            .collect();
        // Interval bounds need the geometry shader (the compute hull expands once per frame) and a
        // moving object; the bound debug output compares whole-shutter bounds; clusters are bounded
        // over whole key segments.
        let object_intervals: Vec<u32> = object_effects
            .iter()
            .zip(&plan.objects)
            .zip(&object_clusters)
            .map(|((e, o), &clusters)| {
                // Unbounded motion (a vertex at or behind the near plane at some end): the clipped
                // box of such triangles does not shrink with the interval; one bound.
                let moving = o.max_motion_px > 0.0 && o.max_motion_px.is_finite() && !o.crosses_near;
                if compute || debug.bound_debug_triangles > 0 || !e.motion() || !moving || clusters > 0 {
                    return 1;
                }
                match options.intervals {
                    Intervals::Auto => auto_intervals(o.max_motion_px, o.max_coc_px, per_pass),
                    Intervals::Fixed(k) => k.min(per_pass),
                }
            })
            .collect();
        let shade_rects = plan.objects.iter().map(|o| shading_rect(o.screen_box, (width, height))).collect();

        // Bindings 5–7 (the shading atlas) only with texture-space shading: lavapipe (Mesa 22.3) crashes
        // binding a set whose combined image sampler was never written.
        let object_table: &[Binding] = if options.shading.texture_space() {
            &STOCHASTIC_OBJECT_SET
        } else {
            &STOCHASTIC_OBJECT_SET[..STOCHASTIC_OBJECT_BINDINGS_WITHOUT_ATLAS]
        };
        let object_set_layout = DescriptorSetLayout::from_table(
            device,
            "stochastic object set layout",
            object_table,
            vk::ShaderStageFlags::ALL_GRAPHICS | vk::ShaderStageFlags::COMPUTE,
        )?;
        let technique_set_layout = DescriptorSetLayout::from_table(
            device,
            "stochastic set layout",
            &STOCHASTIC_SET,
            vk::ShaderStageFlags::ALL_GRAPHICS | vk::ShaderStageFlags::COMPUTE,
        )?;
        let sets = [&object_set_layout, &technique_set_layout];
        let comp = ShaderModule::new(device, shaders::STOCHASTIC_TRIANGLES_COMP)?;
        let triangles_layout = world.pipeline_layout(
            device,
            &sets,
            std::mem::size_of::<TrianglesPush>() as u32,
            vk::ShaderStageFlags::COMPUTE,
        )?;
        let triangles_pipeline =
            Pipeline::compute(device, "camera-space triangles", &triangles_layout, &comp)?;
        // Shadow maps: of still casters only (every sample has its own time; maps at one time are
        // exact only when nothing moves), read by the shading pass as set 4.
        let shadows = if ctx.scene.lights.iter().any(|l| l.shadows()) && ctx.settings.shadows.enabled {
            if crate::shadows::casters_move(ctx.scene) {
                return Err(Error::Unsupported(
                    "shadow-casting lights with moving objects: the stochastic rasterizer renders shadow \
                     maps once per frame, exact only when nothing moves (every sample has its own time); \
                     accumulation renders them per pass (auto takes it for such scenes)"
                        .into(),
                ));
            }
            if caps.max_bound_descriptor_sets <= crate::gpu::layout::SHADOW_SET_INDEX {
                return Err(Error::Unsupported(format!(
                    "shadow maps in the stochastic shading pass are descriptor set {}; this device binds {} \
                     sets (maxBoundDescriptorSets)",
                    crate::gpu::layout::SHADOW_SET_INDEX,
                    caps.max_bound_descriptor_sets
                )));
            }
            ShadowMaps::new(device, world, ctx.scene, &ctx.settings.shadows, &[], seed)?
        } else {
            None
        };
        // Texture-space shading: pass 1's atlases, shaded with the shadow maps (still casters).
        let atlas = if options.shading.texture_space() {
            let layout =
                crate::texture_space::atlas::MipAtlas::new(TEXTURE_SPACE_FINEST, TEXTURE_SPACE_GUTTER)?;
            Some(super::texture_space::AtlasPasses::new(
                ctx,
                layout,
                super::texture_space::AtlasSize::Fitted,
                Some(super::texture_space::BILINEAR_HULL_TEXELS),
                super::texture_space::ATLAS_FORMAT,
                options.instrumented,
                shadows.as_ref(),
            )?)
        } else {
            None
        };
        let atlas_sampler = match &atlas {
            Some(_) => Some(crate::vk::Sampler::nearest_clamp(device, "texture-space atlas")?),
            None => None,
        };
        let shade_sets: Vec<&DescriptorSetLayout> =
            sets.iter().copied().chain(shadows.as_ref().map(ShadowMaps::set_layout)).collect();
        let shade_layout = world.pipeline_layout(
            device,
            &shade_sets,
            std::mem::size_of::<StochasticPush>() as u32,
            vk::ShaderStageFlags::COMPUTE,
        )?;
        let (shadow_axis, shadow_color) =
            shadows.as_ref().map_or((axes::Shadows::None, false), |m| m.lookup());
        // The geometry stage is named only where the device has one.
        let mut push_stages = vk::ShaderStageFlags::VERTEX | vk::ShaderStageFlags::FRAGMENT;
        if caps.geometry_shader {
            push_stages |= vk::ShaderStageFlags::GEOMETRY;
        }
        let layout = world.pipeline_layout(
            device,
            &sets,
            std::mem::size_of::<StochasticPush>() as u32,
            push_stages,
        )?;
        let (bindings, attributes) = vertex_input();
        let vert = ShaderModule::new(device, shaders::STOCHASTIC_STOCHASTIC_VERT)?;
        let hull_vert = ShaderModule::new(device, shaders::STOCHASTIC_HULL_VERT)?;
        let mut shader_modules = vec![];
        let mut pipelines = Vec::with_capacity(paths.len());
        let mut shade_pipelines = Vec::with_capacity(paths.len());
        let mut tint_pipelines = Vec::new();
        let raster = |name: &str, stages: &[&ShaderModule], vertex_input: bool| {
            Pipeline::graphics(
                device,
                &layout,
                &GraphicsDesc {
                    name,
                    stages,
                    vertex_bindings: if vertex_input { &bindings } else { &[] },
                    vertex_attributes: if vertex_input { &attributes[..1] } else { &[] },
                    color_formats: &[],
                    depth_format: None,
                    samples: 1,
                    sample_shading: None,
                    faces: Faces::Both,
                    depth_compare: vk::CompareOp::ALWAYS,
                    depth_write: false,
                },
            )
        };
        for &effects in &paths {
            if (0..object_effects.len()).any(|i| object_effects[i] == effects && object_tint_log[i].is_some())
            {
                let frag = StochasticFrag {
                    hull: axes::Hull::GeometryShader,
                    instrumented: false,
                    effects: effects.shader_axis(),
                    transparency_pass: axes::TransparencyPass::Tint,
                };
                let frag = ShaderModule::new(device, frag.source())?;
                let geom = StochasticGeom { bound_debug: false, effects: effects.shader_axis() };
                let geom = ShaderModule::new(device, geom.source())?;
                let name = format!("stochastic tint ({})", effects.name());
                tint_pipelines.push((effects, raster(&name, &[&vert, &geom, &frag], true)?));
                shader_modules.extend([geom, frag]);
            }
            let frag = StochasticFrag {
                hull: options.expansion.axis(),
                instrumented: options.instrumented,
                effects: effects.shader_axis(),
                transparency_pass: axes::TransparencyPass::Coverage,
            };
            let frag = ShaderModule::new(device, frag.source())?;
            let (first, geom) = if compute {
                (&hull_vert, None)
            } else {
                let geom = StochasticGeom {
                    bound_debug: debug.bound_debug_triangles > 0,
                    effects: effects.shader_axis(),
                };
                (&vert, Some(ShaderModule::new(device, geom.source())?))
            };
            let stages: Vec<&ShaderModule> =
                [Some(first), geom.as_ref(), Some(&frag)].into_iter().flatten().collect();
            let name = format!("stochastic coverage ({}, {} hull)", effects.name(), options.expansion.name());
            let pipeline = raster(&name, &stages, !compute)?;
            pipelines.push((effects, pipeline));
            shader_modules.extend(geom);
            shader_modules.push(frag);
            let shade = ShadeComp {
                shading: options.shading.axis(),
                instrumented: options.instrumented,
                effects: effects.shader_axis(),
                shadows: shadow_axis,
                shadow_color,
                tints: tinted,
            };
            let shade = ShaderModule::new(device, shade.source())?;
            let name = format!("stochastic shading ({}, {})", effects.name(), options.shading.name());
            shade_pipelines.push((effects, Pipeline::compute(device, &name, &shade_layout, &shade)?));
            shader_modules.push(shade);
        }
        // Cluster bounds: a coverage pipeline behind cluster.vert and a clusters.comp pipeline for each
        // path with a clustered object.
        let clusters_layout = world.pipeline_layout(
            device,
            &sets,
            std::mem::size_of::<ClustersPush>() as u32,
            vk::ShaderStageFlags::COMPUTE,
        )?;
        let mut cluster_pipelines = Vec::new();
        let mut clusters_pipelines = Vec::new();
        let cluster_vert = ShaderModule::new(device, shaders::STOCHASTIC_CLUSTER_VERT)?;
        for &effects in &paths {
            if !(0..object_effects.len()).any(|i| object_effects[i] == effects && object_clusters[i] > 0) {
                continue;
            }
            let frag = StochasticFrag {
                hull: axes::Hull::Cluster,
                instrumented: options.instrumented,
                effects: effects.shader_axis(),
                transparency_pass: axes::TransparencyPass::Coverage,
            };
            let frag = ShaderModule::new(device, frag.source())?;
            let name = format!("stochastic coverage ({}, clusters)", effects.name());
            let pipeline = raster(&name, &[&cluster_vert, &frag], false)?;
            cluster_pipelines.push((effects, pipeline));
            shader_modules.push(frag);
            let comp = ShaderModule::new(device, ClustersComp { effects: effects.shader_axis() }.source())?;
            let name = format!("cluster bounds ({})", effects.name());
            clusters_pipelines.push((effects, Pipeline::compute(device, &name, &clusters_layout, &comp)?));
            shader_modules.push(comp);
        }
        shader_modules.extend([vert, hull_vert, comp, cluster_vert]);

        let storage = vk::BufferUsageFlags::STORAGE_BUFFER;
        let (xy_lens, time) = gpu_samples(spp, seed, aperture, shutter);
        let samples = [
            Buffer::with_data(device, "stochastic samples (xy, lens)", storage, &xy_lens)?,
            Buffer::with_data(device, "stochastic samples (time)", storage, &time)?,
        ];
        let counters =
            Tracked::new(Buffer::with_data(device, "stochastic counters", storage, &[0u32; COUNTERS])?);
        let bound_debug = if debug.bound_debug_triangles > 0 {
            let len = debug.bound_debug_triangles as usize * BOUND_DEBUG_STRIDE;
            Some(Tracked::new(Buffer::with_data(device, "bound debug", storage, &vec![0f32; len])?))
        } else {
            None
        };
        let visibility = Tracked::new(Buffer::new(
            device,
            "stochastic visibility",
            pixels * per_pass as u64 * VISIBILITY_BYTES,
            storage | vk::BufferUsageFlags::TRANSFER_DST,
            MemoryLocation::GpuOnly,
        )?);
        let tints = if tinted {
            Some(Tracked::new(Buffer::new(
                device,
                "stochastic tints",
                pixels * per_pass as u64 * TINT_BYTES,
                storage | vk::BufferUsageFlags::TRANSFER_DST,
                MemoryLocation::GpuOnly,
            )?))
        } else {
            None
        };
        let decoupled = if let Some(kind) = options.shading.decoupled_grid() {
            // The memoization cache's seqlock relies on the order of plain (relaxed) atomics, which
            // llvmpipe's sequentially consistent atomics keep and a GPU's need not (decoupled.glsl): on
            // any other device it could return a half-written value, so it is refused there.
            if !options.shading.deferred() && !device.caps.is_lavapipe() {
                return Err(Error::Unsupported(format!(
                    "--shading {}: the memoization cache is exact only where atomics are sequentially consistent (lavapipe); on {} use `{}-deferred`, whose hash table needs no ordering",
                    options.shading.name(),
                    device.caps.device_name,
                    options.shading.name()
                )));
            }
            if !(1..=MAX_CACHE_ENTRIES).contains(&options.cache_entries) {
                return Err(Error::Unsupported(format!(
                    "a decoupled shading cache of {} entries: 1 ..= {MAX_CACHE_ENTRIES}",
                    options.cache_entries
                )));
            }
            let cache = Tracked::new(Buffer::new(
                device,
                "decoupled shading cache",
                options.cache_entries as u64 * CACHE_ENTRY_BYTES,
                storage | vk::BufferUsageFlags::TRANSFER_DST,
                MemoryLocation::GpuOnly,
            )?);
            let intrinsics = ctx.scene.camera.intrinsics(width, height);
            let grids: Vec<[f32; 4]> =
                crate::decoupled::object_grids(ctx.scene, &ctx.camera.space, &intrinsics, kind)
                    .iter()
                    .map(|g| [g.axis.x, g.axis.y, g.along, g.across])
                    .collect();
            let placeholder = [[1.0, 0.0, 1.0, 1.0]];
            let grids = Buffer::with_data(
                device,
                "decoupled grids",
                storage,
                if grids.is_empty() { &placeholder } else { &grids },
            )?;
            // The deferred mode's queue (its header, then an entry per table entry) and compact G-buffer
            // (an entry per pixel and sample of a pass); the memoization cache's pipelines name them
            // too, so it binds placeholders.
            let deferred = options.shading.deferred();
            let (queue_entries, refs) =
                if deferred { (options.cache_entries as u64, pixels * per_pass as u64) } else { (1, 1) };
            let queue = Tracked::new(Buffer::new(
                device,
                "decoupled deferred queue",
                DEFERRED_QUEUE_HEADER_BYTES + 4 * queue_entries,
                storage | vk::BufferUsageFlags::TRANSFER_DST | vk::BufferUsageFlags::INDIRECT_BUFFER,
                MemoryLocation::GpuOnly,
            )?);
            let refs = Buffer::new(
                device,
                "decoupled deferred G-buffer",
                refs * DEFERRED_REF_BYTES,
                storage,
                MemoryLocation::GpuOnly,
            )?;
            Some(DecoupledBuffers { cache, grids, queue, refs, deferred })
        } else {
            None
        };
        let accum = Tracked::new(accumulation_image(device, "stochastic accumulation", (width, height))?);

        let n_objects = world.objects.len() as u32;
        let pool = DescriptorPool::for_tables(
            device,
            n_objects + 1,
            &[(object_table, n_objects), (&STOCHASTIC_SET, 1)],
        )?;
        let technique_set = pool.allocate(&technique_set_layout)?;
        let mut writes = vec![
            DescriptorWrite::storage_buffer(0, &samples[0]),
            DescriptorWrite::storage_buffer(1, &samples[1]),
            DescriptorWrite::storage_buffer(2, &counters),
            DescriptorWrite::storage_buffer(5, &visibility),
            DescriptorWrite::StorageImage { binding: 6, view: accum.view },
        ];
        if let Some(b) = &bound_debug {
            writes.push(DescriptorWrite::storage_buffer(3, b));
        }
        if let Some(b) = &tints {
            writes.push(DescriptorWrite::storage_buffer(7, b));
        }
        if let Some(b) = &decoupled {
            writes.push(DescriptorWrite::storage_buffer(8, &b.cache));
            writes.push(DescriptorWrite::storage_buffer(9, &b.grids));
            writes.push(DescriptorWrite::storage_buffer(10, &b.queue));
            writes.push(DescriptorWrite::storage_buffer(11, &b.refs));
        }
        write_descriptors(device, technique_set, &writes);
        let mut object_sets = Vec::with_capacity(world.objects.len());
        let mut triangles = Vec::with_capacity(world.objects.len());
        let mut cluster_buffers = Vec::with_capacity(world.objects.len());
        let mut cluster_orders = Vec::new();
        for (o, motion) in world.objects.iter().zip(&ctx.camera.space.objects) {
            let keys = motion.keys.times().len() as u64;
            let bytes = (o.index_count as u64 / 3).max(1) * keys * TRIANGLE_KEY_BYTES;
            let t = Buffer::new(
                device,
                &format!("camera-space triangles:{}", o.name),
                bytes,
                storage,
                MemoryLocation::GpuOnly,
            )?;
            let set = pool.allocate(&object_set_layout)?;
            write_descriptors(device, set, &[DescriptorWrite::storage_buffer(0, &t)]);
            if let (Some(a), Some(sampler)) = (&atlas, &atlas_sampler) {
                if let Some((image, levels, coords)) = a.object_resources(object_sets.len()) {
                    write_descriptors(
                        device,
                        set,
                        &[
                            DescriptorWrite::SampledImage {
                                binding: 5,
                                view: image.view,
                                sampler: sampler.raw,
                            },
                            DescriptorWrite::storage_buffer(6, levels),
                            DescriptorWrite::storage_buffer(7, coords),
                        ],
                    );
                }
            }
            let n = object_clusters[object_sets.len()];
            let cluster_buffer = if n > 0 {
                let per_segment = (o.triangle_count() as u64).div_ceil(n as u64);
                let c = Buffer::new(
                    device,
                    &format!("cluster bounds:{}", o.name),
                    per_segment * (keys - 1) * CLUSTER_BYTES,
                    storage,
                    MemoryLocation::GpuOnly,
                )?;
                let (order, _) =
                    cluster_orders_cpu[object_sets.len()].take().expect("measured with the decision");
                let order = Buffer::with_data(device, &format!("cluster order:{}", o.name), storage, &order)?;
                write_descriptors(
                    device,
                    set,
                    &[DescriptorWrite::storage_buffer(3, &c), DescriptorWrite::storage_buffer(4, &order)],
                );
                cluster_orders.push(order);
                Some(Tracked::new(c))
            } else {
                None
            };
            cluster_buffers.push(cluster_buffer);
            object_sets.push(set);
            triangles.push(Tracked::new(t));
        }
        let hull = if compute {
            Some(ComputeHull::new(
                device,
                world,
                &paths,
                &sets,
                &object_sets,
                technique_set,
                debug.hull_vertices_per_triangle.unwrap_or(INITIAL_VERTICES_PER_TRIANGLE),
            )?)
        } else {
            None
        };
        Ok(StochasticDraws {
            pipelines,
            shade_pipelines,
            tint_pipelines,
            object_tint_log,
            tints,
            decoupled,
            atlas,
            _atlas_sampler: atlas_sampler,
            object_effects: object_effects.to_vec(),
            object_intervals,
            object_clusters,
            cluster_buffers,
            _cluster_orders: cluster_orders,
            cluster_pipelines,
            clusters_pipelines,
            clusters_layout,
            shade_rects,
            triangle_bases,
            triangle_counts: world.objects.iter().map(|o| o.triangle_count()).collect(),
            object_keys: ctx.camera.space.objects.iter().map(|m| m.keys.clone()).collect(),
            shutter,
            layout,
            shade_layout,
            push_stages,
            object_sets,
            technique_set,
            options,
            bounds: plan.objects.iter().map(|o| options.bound.resolve(caps, o.max_coc_px)).collect(),
            object_alpha: ctx.scene.objects.iter().map(|o| o.material.alpha).collect(),
            object_texture_alpha: transparent.iter().map(|o| o.alpha_from_texture).collect(),
            object_one_sided: ctx.scene.objects.iter().map(|o| o.material.one_sided).collect(),
            coverage_seed: crate::transparency::coverage_seed(seed),
            spp,
            per_pass,
            passes,
            size: (width, height),
            // One rasterizer sample per pixel, at its centre.
            dilate: crate::bounds::dilation_px(1, caps.standard_sample_locations),
            counters,
            bound_debug,
            triangles,
            triangles_pipeline,
            triangles_layout,
            visibility,
            accum,
            hull,
            hull_counts: vec![0; world.objects.len()],
            _samples: samples,
            _pool: pool,
            _set_layouts: [object_set_layout, technique_set_layout],
            _shaders: shader_modules,
            shadows,
        })
    }

    /// Samples per pixel and pass, and passes.
    pub fn samples_per_pass(&self) -> (u32, u32) {
        (self.per_pass, self.passes)
    }

    /// The counters of the last frame (instrumented renders only).
    pub fn counters(&self) -> Result<Option<SampleCounters>> {
        if !self.options.instrumented {
            return Ok(None);
        }
        let raw = self.counters.read_u32s(COUNTERS)?;
        let atlas = match &self.atlas {
            Some(a) => a.counters()?,
            None => None,
        };
        Ok(Some(SampleCounters {
            samples_tested: raw[0] as u64,
            samples_hit: raw[1] as u64,
            shading_invocations: raw[2] as u64,
            fragments: raw[3] as u64,
            atlas_texels: atlas,
            cache: self.decoupled.as_ref().map(|_| CacheCounters {
                lookups: raw[4] as u64,
                hits: raw[5] as u64,
                evictions: raw[6] as u64,
                busy: raw[7] as u64,
                overflows: raw[8] as u64,
                memory: self.decoupled_memory(),
            }),
        }))
    }

    /// The deferred mode's memory (None with the other rates).
    pub fn decoupled_memory(&self) -> Option<DecoupledMemory> {
        let dc = self.decoupled.as_ref().filter(|dc| dc.deferred)?;
        Some(DecoupledMemory {
            samples: self.size.0 as u64 * self.size.1 as u64 * self.per_pass as u64,
            refs_bytes: dc.refs.size,
            table_bytes: dc.cache.size + dc.queue.size,
        })
    }

    /// The compute-expanded hull's buffer capacity and this frame's vertex count per object (None
    /// behind the geometry shader).
    pub fn hull_usage(&self) -> Option<(Vec<u32>, Vec<u32>)> {
        self.hull.as_ref().map(|h| (h.capacity().to_vec(), self.hull_counts.clone()))
    }

    /// The geometry shader's debug output of the last frame: per triangle of the first object,
    /// `BOUND_DEBUG_STRIDE` floats (empty without [`DebugOptions::bound_debug_triangles`]).
    pub fn bound_debug(&self) -> Result<Vec<f32>> {
        let Some(b) = &self.bound_debug else { return Ok(vec![]) };
        Ok(b.mapped()?.chunks_exact(4).map(|c| f32::from_ne_bytes([c[0], c[1], c[2], c[3]])).collect())
    }

    fn is_drawn(&self, i: usize, world: &GpuWorld) -> bool {
        world.objects[i].triangle_count() > 0
    }

    /// The camera-space triangles of every object, once per frame (they do not depend on the pass): a
    /// compute pass per view (thesis §9.6: the fragment stage reads one record per fragment instead of
    /// transforming three vertices twice).
    fn add_triangles_pass<'a>(&'a self, g: &mut FrameGraph<'a>, inputs: &FrameInputs<'a>) {
        let mut drawn = Vec::new();
        let mut handles = Vec::new();
        for (i, t) in self.triangles.iter().enumerate() {
            if self.is_drawn(i, inputs.world) {
                handles.push(g.import_buffer("camera-space triangles", t));
                drawn.push(i);
            }
        }
        let mut pass = g.pass("triangles");
        for h in handles {
            pass = pass.overwrite(h, Access::ComputeShaderWrite);
        }
        let (world, view) = (inputs.world, inputs.camera);
        let clustered: Vec<usize> = drawn.iter().copied().filter(|&i| self.object_clusters[i] > 0).collect();
        pass.record(move |ctx| {
            self.record_triangles(ctx, world, view, &drawn);
            Ok(())
        });
        if clustered.is_empty() {
            return;
        }
        // The cluster bounds, from the triangles.
        let handles: Vec<_> = clustered
            .iter()
            .map(|&i| {
                let t = g.import_buffer("camera-space triangles", &self.triangles[i]);
                let c =
                    g.import_buffer("cluster bounds", self.cluster_buffers[i].as_ref().expect("clustered"));
                (t, c)
            })
            .collect();
        let mut pass = g.pass("cluster bounds");
        for (t, c) in handles {
            pass = pass.access(t, Access::ComputeShaderReadOther).overwrite(c, Access::ComputeShaderWrite);
        }
        pass.record(move |ctx| {
            self.record_clusters(ctx, world, view, &clustered);
            Ok(())
        });
    }

    /// `clusters.comp` for each clustered object (`objects`) and key segment (the segment holding
    /// mid-shutter for an object that does not move).
    fn record_clusters(&self, ctx: &PassContext<'_>, world: &GpuWorld, view: &GpuView, objects: &[usize]) {
        let (d, cmd) = (ctx.device, ctx.cmd);
        let bind = vk::PipelineBindPoint::COMPUTE;
        let layout = self.clusters_layout.raw;
        unsafe {
            d.raw.cmd_bind_descriptor_sets(cmd, bind, layout, FRAME_SET_INDEX, &[view.frame_set], &[]);
            for (effects, pipeline) in &self.clusters_pipelines {
                d.raw.cmd_bind_pipeline(cmd, bind, pipeline.raw);
                for &i in objects.iter().filter(|&&i| self.object_effects[i] == *effects) {
                    let o = &world.objects[i];
                    let sets = [o.set, self.object_sets[i]];
                    d.raw.cmd_bind_descriptor_sets(cmd, bind, layout, OBJECT_SET_INDEX, &sets, &[]);
                    let keys = &self.object_keys[i];
                    let (first, count, t0, t1) = bounded_segments(keys, effects.motion());
                    let n = self.object_clusters[i];
                    for segment in first..first + count {
                        let push = ClustersPush {
                            triangle_count: o.triangle_count(),
                            cluster_size: n,
                            segment_count: keys.segments() as u32,
                            segment,
                            t0,
                            t1,
                            one_sided: o.one_sided as u32,
                        };
                        d.raw.cmd_push_constants(
                            cmd,
                            layout,
                            vk::ShaderStageFlags::COMPUTE,
                            0,
                            bytemuck::bytes_of(&push),
                        );
                        d.raw.cmd_dispatch(cmd, o.triangle_count().div_ceil(n).div_ceil(64), 1, 1);
                    }
                }
            }
        }
    }

    fn record_triangles(&self, ctx: &PassContext<'_>, world: &GpuWorld, view: &GpuView, objects: &[usize]) {
        let (d, cmd) = (ctx.device, ctx.cmd);
        let bind = vk::PipelineBindPoint::COMPUTE;
        let layout = self.triangles_layout.raw;
        unsafe {
            d.raw.cmd_bind_pipeline(cmd, bind, self.triangles_pipeline.raw);
            d.raw.cmd_bind_descriptor_sets(cmd, bind, layout, FRAME_SET_INDEX, &[view.frame_set], &[]);
            for &i in objects {
                let o = &world.objects[i];
                let sets = [o.set, self.object_sets[i]];
                d.raw.cmd_bind_descriptor_sets(cmd, bind, layout, OBJECT_SET_INDEX, &sets, &[]);
                let (segment_first, segments) = view.segments(i);
                let push =
                    TrianglesPush { segment_first, keys: segments + 1, triangle_count: o.triangle_count() };
                d.raw.cmd_push_constants(
                    cmd,
                    layout,
                    vk::ShaderStageFlags::COMPUTE,
                    0,
                    bytemuck::bytes_of(&push),
                );
                d.raw.cmd_dispatch(cmd, o.triangle_count().div_ceil(64), 1, 1);
            }
        }
    }

    /// Work before the frame's graph: the counters reset and, with the compute-expanded hull, the
    /// triangles and the expansion in a graph of their own, their counts read back; an overflowed
    /// buffer grows and the expansion runs again, so no bound is ever dropped.
    fn before_frame(&mut self, inputs: &FrameInputs<'_>, frame: &mut FrameContext<'_>) -> Result<()> {
        self.counters.get_mut().write(&[0u32; COUNTERS])?;
        if let Some(a) = &mut self.atlas {
            a.reset_counters()?;
        }
        if self.hull.is_none() {
            return Ok(());
        }
        loop {
            let hull = self.hull.as_mut().expect("checked");
            hull.reset_counts()?;
            {
                let this = &*self;
                let hull = this.hull.as_ref().expect("checked");
                let mut g = frame.graph();
                this.add_triangles_pass(&mut g, inputs);
                hull.add_expand_pass(
                    &mut g,
                    inputs,
                    (&this.triangles, &this.object_sets, this.technique_set),
                    (&this.object_effects, &this.object_keys),
                    &this.bounds,
                    this.dilate,
                );
                frame.run(g)?;
            }
            let device = frame.device().clone();
            let hull = self.hull.as_mut().expect("checked");
            if !hull.grow_overflowed(&device, inputs.world, &self.object_sets)? {
                self.hull_counts = hull.counts()?;
                return Ok(());
            }
        }
    }

    /// The bound kind each object draws.
    pub fn bounds(&self) -> &[BoundKind] {
        &self.bounds
    }

    /// Interval count of each object (1: bounded over the whole shutter).
    pub fn object_intervals(&self) -> &[u32] {
        &self.object_intervals
    }

    /// Push constants of object `object` in pass `pass` for the shading pass (and the fields every
    /// coverage draw shares): the whole pass' samples.
    fn base_push(&self, view: &GpuView, object: u32, pass: u32) -> StochasticPush {
        let o = object as usize;
        let (segment_first, segment_count) =
            if o < self.object_keys.len() { view.segments(o) } else { (0, 1) };
        let tint = self.object_tint_log.get(o).copied().flatten().unwrap_or([0; 3]);
        let atlas = self.atlas.as_ref().and_then(|a| a.object_atlas(o));
        StochasticPush {
            object,
            bound: self.bounds.get(o).map_or(0, |b| b.id()),
            pass_index: pass,
            spp: self.spp,
            per_pass: self.per_pass,
            dilate: self.dilate,
            sample_first: 0,
            sample_count: self.per_pass,
            t0: 0.0,
            t1: 1.0,
            origin_x: 0,
            origin_y: 0,
            triangle_base: self.triangle_bases.get(o).copied().unwrap_or(0),
            triangle_count: self.triangle_counts.get(o).copied().unwrap_or(0),
            segment_first,
            segment_count,
            segment: 0,
            cluster_size: self.object_clusters.get(o).copied().unwrap_or(0).max(1),
            alpha: self.object_alpha.get(o).copied().unwrap_or(1.0),
            coverage_seed: self.coverage_seed,
            alpha_from_texture: self.object_texture_alpha.get(o).copied().unwrap_or(false) as u32,
            tint_log_r: tint[0],
            tint_log_g: tint[1],
            tint_log_b: tint[2],
            atlas_finest: atlas.map_or(0, |a| a.finest()),
            atlas_gutter: atlas.map_or(0, |a| a.gutter()),
            one_sided: self.object_one_sided.get(o).copied().unwrap_or(false) as u32,
            cache_entries: if self.decoupled.is_some() { self.options.cache_entries } else { 0 },
            decoupled_phase: DecoupledPhase::Memo as u32,
        }
    }

    /// Push constants of the coverage draw of run `run` of `runs` of object `object` in pass `pass`
    /// over key segment `seg` of its motion, or `None` when none of the run's samples lies in it.
    /// Objects that do not move (NO_MOTION) have one draw per run, over the segment holding
    /// mid-shutter (`seg` 0 stands for it).
    fn coverage_push(
        &self,
        view: &GpuView,
        object: usize,
        pass: u32,
        run: u32,
        runs: u32,
        seg: usize,
    ) -> Option<StochasticPush> {
        let count = self.per_pass / runs;
        let first = run * count;
        let base = StochasticPush {
            sample_first: first,
            sample_count: count,
            ..self.base_push(view, object as u32, pass)
        };
        let keys = &self.object_keys[object];
        if !self.object_effects[object].motion() {
            if seg != 0 {
                return None;
            }
            let (segment, _, t0, t1) = bounded_segments(keys, false);
            return Some(StochasticPush { t0, t1, segment, ..base });
        }
        // The run's samples' shutter times: [ξ0, ξ1) of the unwarped time, through the shutter curve
        // (monotone, the very function that warped the samples; it maps 0 to 0 and 1 to 1 exactly, so
        // a whole-shutter draw gets (0, 1), which emit.glsl bounds from the end vertices themselves).
        let xi = |i: u32| (pass * self.per_pass + i) as f32 / self.spp as f32;
        let (t0, t1) = (self.shutter.warp(xi(first)), self.shutter.warp(xi(first + count)));
        // Segment `seg` holds times [t_a, t_b) (the first from −∞, the last to +∞: KeyTimes).
        // (`seg` runs over the most segments any object has: past this object's last, no draw.)
        let last = keys.segments() - 1;
        if seg > last {
            return None;
        }
        let (t_a, t_b) = (keys.times()[seg], keys.times()[seg + 1]);
        if (seg > 0 && t1 < t_a) || (seg < last && t0 >= t_b) {
            return None;
        }
        // The samples' local times: monotone in t, so those of [max(t0, t_a), min(t1, t_b)] bound them
        // (the same rounded arithmetic as the shaders'; (0, 1) for two keys and the whole shutter).
        let (s0, s1) = (keys.local_time(seg, t0.max(t_a)), keys.local_time(seg, t1.min(t_b)));
        Some(StochasticPush { t0: s0, t1: s1, segment: seg as u32, ..base })
    }

    /// The frame as a graph: `triangles` → `clear accumulation` → repeat P × { `clear visibility` →
    /// `stochastic coverage` (raster, no attachments) → with tinted objects `stochastic tint` (raster,
    /// no attachments) → `stochastic shading` (compute) } → readback ([`FrameContext::finish`]: or the
    /// copy into an embedding caller's image).
    fn render<'a>(&'a self, frame: &mut FrameContext<'_>, inputs: &FrameInputs<'a>) -> Result<LinearImage> {
        let mut g = frame.graph();
        if !(0..inputs.world.objects.len()).any(|i| self.is_drawn(i, inputs.world)) {
            // Nothing to draw (no object, or none with a triangle): every sample sees the background.
            // The shading pass cannot add it here: its background dispatch binds a drawn object's
            // sets (the pipeline's layout needs some), and there is none — and no permutation exists
            // without objects. The image is the background, as the reference's.
            let accum = g.import_image("stochastic accumulation", &self.accum);
            g.clear_color("background (nothing drawn)", accum, inputs.world.background);
            return frame.finish(g, accum);
        }
        if self.hull.is_none() {
            self.add_triangles_pass(&mut g, inputs);
        }
        let world = inputs.world;
        // What the coverage pass reads besides the visibility buffer, and what the shading pass reads.
        let mut coverage_uses: Vec<(ResourceHandle, Access)> = Vec::new();
        let mut shading_uses: Vec<(ResourceHandle, Access)> = Vec::new();
        for (i, t) in self.triangles.iter().enumerate() {
            if self.is_drawn(i, world) {
                let h: ResourceHandle = g.import_buffer("camera-space triangles", t).into();
                coverage_uses.push((h, Access::FragmentShaderReadOther));
                shading_uses.push((h, Access::ComputeShaderReadOther));
            }
        }
        for (i, c) in self.cluster_buffers.iter().enumerate() {
            if let (Some(c), true) = (c, self.is_drawn(i, world)) {
                let h: ResourceHandle = g.import_buffer("cluster bounds", c).into();
                coverage_uses.push((h, Access::VertexShaderReadOther));
                coverage_uses.push((h, Access::FragmentShaderReadOther));
            }
        }
        if let Some(hull) = &self.hull {
            for (i, [vertices, sources]) in hull.buffers().iter().enumerate() {
                if self.is_drawn(i, world) {
                    for (name, b) in [("hull", vertices), ("hull triangles", sources)] {
                        let h: ResourceHandle = g.import_buffer(name, b).into();
                        coverage_uses.push((h, Access::VertexShaderReadOther));
                    }
                }
            }
        }
        let mut host_reads = Vec::new();
        if self.options.instrumented {
            let h = g.import_buffer("stochastic counters", &self.counters);
            // Atomics read and write.
            for access in [Access::FragmentShaderReadOther, Access::FragmentShaderWrite] {
                coverage_uses.push((h.into(), access));
            }
            for access in [Access::ComputeShaderReadOther, Access::ComputeShaderWrite] {
                shading_uses.push((h.into(), access));
            }
            host_reads.push(h);
        }
        if let Some(b) = &self.bound_debug {
            let h = g.import_buffer("bound debug", b);
            coverage_uses.push((h.into(), Access::GeometryShaderWrite));
            host_reads.push(h);
        }
        let mut shadow_handles = None;
        if let Some(maps) = &self.shadows {
            let h = maps.import(&mut g);
            maps.add_frame_passes(&mut g, h, inputs);
            let read = Access::ComputeShaderReadSampledImageOrUniformTexelBuffer;
            shading_uses.extend(ShadowMaps::reads_as(h, read));
            shadow_handles = Some(h);
        }
        let visibility = g.import_buffer("stochastic visibility", &self.visibility);
        let accum = g.import_image("stochastic accumulation", &self.accum);
        let tints = self.tints.as_ref().map(|t| g.import_buffer("stochastic tints", t));
        if let Some(dc) = &self.decoupled {
            // Cleared once a frame: every shading dispatch of every pass shares them.
            let h = g.import_buffer("decoupled shading cache", &dc.cache);
            let q = g.import_buffer("decoupled deferred queue", &dc.queue);
            g.pass("clear decoupled cache")
                .overwrite(h, Access::TransferWrite)
                .overwrite(q, Access::TransferWrite)
                .record(move |ctx| {
                    for b in [h, q] {
                        let b = ctx.buffer(b);
                        unsafe { ctx.device.raw.cmd_fill_buffer(ctx.cmd, b.raw, 0, vk::WHOLE_SIZE, 0) };
                    }
                    Ok(())
                });
            for b in [h, q] {
                shading_uses.push((b.into(), Access::ComputeShaderReadOther));
                shading_uses.push((b.into(), Access::ComputeShaderWrite));
            }
            // The deferred shading dispatch's arguments, written by the dispatch before it.
            shading_uses.push((q.into(), Access::IndirectBuffer));
        }
        if let Some(a) = &self.atlas {
            for h in a.add_passes(&mut g, inputs, shadow_handles).into_iter().flatten() {
                shading_uses
                    .push((h.color.into(), Access::ComputeShaderReadSampledImageOrUniformTexelBuffer));
                shading_uses.push((h.levels.into(), Access::ComputeShaderReadOther));
            }
        }
        if let Some(t) = tints {
            shading_uses.push((t.into(), Access::ComputeShaderReadOther));
        }

        g.clear_color("clear accumulation", accum, [0.0; 4]);
        let inputs = *inputs;
        let (w, h) = self.size;
        g.repeat(self.passes, |g| {
            let mut clear = g.pass("clear visibility").overwrite(visibility, Access::TransferWrite);
            if let Some(t) = tints {
                clear = clear.overwrite(t, Access::TransferWrite);
            }
            clear.record(move |ctx| {
                for b in std::iter::once(visibility).chain(tints) {
                    let b = ctx.buffer(b);
                    unsafe { ctx.device.raw.cmd_fill_buffer(ctx.cmd, b.raw, 0, vk::WHOLE_SIZE, 0) };
                }
                Ok(())
            });
            g.pass("stochastic coverage")
                .render_area(w, h)
                .access(visibility, Access::FragmentShaderReadOther)
                .access(visibility, Access::FragmentShaderWrite)
                .accesses(coverage_uses.iter().copied())
                .record(move |ctx| {
                    self.record_coverage(ctx, &inputs, ctx.iteration);
                    self.record_cluster_coverage(ctx, &inputs, ctx.iteration);
                    Ok(())
                });
            if let Some(t) = tints {
                // The finished visibility buffer says what each sample sees; the tinted objects
                // multiply their tint into the samples they pass in front of it.
                g.pass("stochastic tint")
                    .render_area(w, h)
                    .access(visibility, Access::FragmentShaderReadOther)
                    .access(t, Access::FragmentShaderReadOther)
                    .access(t, Access::FragmentShaderWrite)
                    .accesses(coverage_uses.iter().copied())
                    .record(move |ctx| {
                        self.record_tints(ctx, &inputs, ctx.iteration);
                        Ok(())
                    });
            }
            g.pass("stochastic shading")
                .access(visibility, Access::ComputeShaderReadOther)
                .access(accum, Access::ComputeShaderReadWrite)
                .accesses(shading_uses.iter().copied())
                .record(move |ctx| {
                    self.record_shading(ctx, &inputs, ctx.iteration);
                    Ok(())
                });
            Ok(())
        })?;
        for b in host_reads {
            g.host_read(b);
        }
        frame.finish(g, accum)
    }

    /// The coverage draws of pass `pass`, inside the attachment-less rendering.
    fn record_coverage(&self, ctx: &mut PassContext<'_>, inputs: &FrameInputs<'_>, pass: u32) {
        let (d, cmd) = (ctx.device, ctx.cmd);
        let bind = vk::PipelineBindPoint::GRAPHICS;
        let world = inputs.world;
        for (effects, pipeline) in &self.pipelines {
            self.bind_raster(ctx, pipeline);
            let include = |i: usize| self.object_effects[i] == *effects && self.object_clusters[i] == 0;
            let view = inputs.camera;
            if self.hull.is_none() {
                self.record_runs(ctx, inputs, pipeline, pass, include, |p| p);
                continue;
            }
            // The compute-expanded hull bounds every segment (fragments name theirs); NO_MOTION: the
            // segment holding mid-shutter and its local time.
            let push = |i: usize| self.coverage_push(view, i, pass, 0, 1, 0).expect("segment 0 always draws");
            // Compute-expanded hull: each object's triangle list, no vertex input.
            unsafe {
                d.raw.cmd_bind_descriptor_sets(
                    cmd,
                    bind,
                    self.layout.raw,
                    FRAME_SET_INDEX,
                    &[inputs.camera.frame_set],
                    &[],
                );
                for (i, o) in world.objects.iter().enumerate() {
                    if !include(i) || self.hull_counts[i] == 0 {
                        continue;
                    }
                    d.raw.cmd_push_constants(
                        cmd,
                        self.layout.raw,
                        self.push_stages,
                        0,
                        bytemuck::bytes_of(&push(i)),
                    );
                    let sets = [o.set, self.object_sets[i]];
                    d.raw.cmd_bind_descriptor_sets(cmd, bind, self.layout.raw, OBJECT_SET_INDEX, &sets, &[]);
                    d.raw.cmd_draw(cmd, self.hull_counts[i], 1, 0, 0);
                }
            }
        }
    }

    /// The tint draws of pass `pass` (module docs of `stochastic.frag`, TINT_PASS): every tinted
    /// object's coverage draws again behind the geometry shader's convex hull — one convex piece, so
    /// the rasterizer's fill rule runs the fragment stage once per pixel and triangle, and each
    /// uncovered sample adds the tint once — per run and key segment as the coverage draws.
    fn record_tints(&self, ctx: &mut PassContext<'_>, inputs: &FrameInputs<'_>, pass: u32) {
        let hull = BoundKind::ConvexHull.id();
        for (effects, pipeline) in &self.tint_pipelines {
            self.bind_raster(ctx, pipeline);
            let include = |i: usize| self.object_effects[i] == *effects && self.object_tint_log[i].is_some();
            self.record_runs(ctx, inputs, pipeline, pass, include, |p| StochasticPush { bound: hull, ..p });
        }
    }

    /// Binds a raster pipeline of the frame and its set 3.
    fn bind_raster(&self, ctx: &PassContext<'_>, pipeline: &Pipeline) {
        let (d, cmd, bind) = (ctx.device, ctx.cmd, vk::PipelineBindPoint::GRAPHICS);
        unsafe {
            d.raw.cmd_bind_pipeline(cmd, bind, pipeline.raw);
            d.raw.cmd_bind_descriptor_sets(
                cmd,
                bind,
                self.layout.raw,
                TECHNIQUE_SET_INDEX,
                &[self.technique_set],
                &[],
            );
        }
    }

    /// The geometry-shader draws of pass `pass` of the objects `include` admits with `pipeline`
    /// bound: one per interval run and key segment of every object with that many runs or more whose
    /// samples of the run can lie in the segment, each with its [`Self::coverage_push`] as `edit`
    /// changes it.
    fn record_runs(
        &self,
        ctx: &mut PassContext<'_>,
        inputs: &FrameInputs<'_>,
        pipeline: &Pipeline,
        pass: u32,
        include: impl Fn(usize) -> bool,
        edit: impl Fn(StochasticPush) -> StochasticPush,
    ) {
        let (world, view) = (inputs.world, inputs.camera);
        let max_runs = self.object_intervals.iter().copied().max().unwrap_or(1);
        let max_segments = self.object_keys.iter().map(|k| k.segments()).max().unwrap_or(1);
        for run in 0..max_runs {
            for seg in 0..max_segments {
                let piece = |i: usize| {
                    self.coverage_push(view, i, pass, run, self.object_intervals[i], seg).map(&edit)
                };
                world.record_object_draws(
                    ctx.device,
                    ctx.cmd,
                    view,
                    pipeline,
                    &self.layout,
                    self.push_stages,
                    |i| include(i) && run < self.object_intervals[i] && piece(i).is_some(),
                    |i| piece(i).expect("included"),
                    |i| Some(self.object_sets[i]),
                );
            }
        }
    }

    /// The coverage draws of the clustered objects in pass `pass`: per object and key segment (the
    /// one holding mid-shutter for an object that does not move), six vertices per cluster.
    fn record_cluster_coverage(&self, ctx: &mut PassContext<'_>, inputs: &FrameInputs<'_>, pass: u32) {
        let (d, cmd) = (ctx.device, ctx.cmd);
        let bind = vk::PipelineBindPoint::GRAPHICS;
        let (world, view) = (inputs.world, inputs.camera);
        for (effects, pipeline) in &self.cluster_pipelines {
            self.bind_raster(ctx, pipeline);
            unsafe {
                d.raw.cmd_bind_descriptor_sets(
                    cmd,
                    bind,
                    self.layout.raw,
                    FRAME_SET_INDEX,
                    &[view.frame_set],
                    &[],
                );
            }
            for (i, o) in world.objects.iter().enumerate() {
                let n = self.object_clusters[i];
                if n == 0 || self.object_effects[i] != *effects || !self.is_drawn(i, world) {
                    continue;
                }
                let sets = [o.set, self.object_sets[i]];
                let clusters = o.triangle_count().div_ceil(n);
                for seg in 0..self.object_keys[i].segments() {
                    let Some(push) = self.coverage_push(view, i, pass, 0, 1, seg) else { continue };
                    unsafe {
                        d.raw.cmd_push_constants(
                            cmd,
                            self.layout.raw,
                            self.push_stages,
                            0,
                            bytemuck::bytes_of(&push),
                        );
                        d.raw.cmd_bind_descriptor_sets(
                            cmd,
                            bind,
                            self.layout.raw,
                            OBJECT_SET_INDEX,
                            &sets,
                            &[],
                        );
                        d.raw.cmd_draw(cmd, 6 * clusters, 1, 0, 0);
                    }
                }
            }
        }
    }

    /// The shading dispatches of pass `pass`: the background for the samples without a hit, then one
    /// per object with its sets (each adds its own samples; the accumulation image orders them).
    fn record_shading(&self, ctx: &mut PassContext<'_>, inputs: &FrameInputs<'_>, pass: u32) {
        let (d, cmd) = (ctx.device, ctx.cmd);
        let bind = vk::PipelineBindPoint::COMPUTE;
        let layout = self.shade_layout.raw;
        let (w, h) = self.size;
        let world = inputs.world;
        let view = inputs.camera;
        let barrier = || {
            // Read-modify-write of the accumulation image by consecutive dispatches; the deferred mode's
            // table, queue and G-buffer, and its shading dispatch's indirect arguments.
            crate::vk::compute_write_barrier(
                d,
                cmd,
                vk::PipelineStageFlags2::COMPUTE_SHADER | vk::PipelineStageFlags2::DRAW_INDIRECT,
                vk::AccessFlags2::SHADER_STORAGE_READ
                    | vk::AccessFlags2::SHADER_STORAGE_WRITE
                    | vk::AccessFlags2::INDIRECT_COMMAND_READ,
            );
        };
        unsafe {
            d.raw.cmd_bind_descriptor_sets(
                cmd,
                bind,
                layout,
                FRAME_SET_INDEX,
                &[inputs.camera.frame_set],
                &[],
            );
            d.raw.cmd_bind_descriptor_sets(
                cmd,
                bind,
                layout,
                TECHNIQUE_SET_INDEX,
                &[self.technique_set],
                &[],
            );
            if let Some(maps) = &self.shadows {
                maps.bind(d, cmd, bind, layout, crate::gpu::layout::SHADOW_SET_INDEX);
            }
        }
        let mut first = true;
        let full = [0, 0, w, h];
        let queue = self.decoupled.as_ref().map(|dc| dc.queue.raw);
        let mut dispatch = |pipeline: &Pipeline,
                            object: u32,
                            sets: [vk::DescriptorSet; 2],
                            rect: [u32; 4],
                            phase: DecoupledPhase| {
            let [x0, y0, rw, rh] = rect;
            if rw == 0 || rh == 0 {
                return;
            }
            if !first {
                barrier();
            }
            first = false;
            unsafe {
                d.raw.cmd_bind_pipeline(cmd, bind, pipeline.raw);
                d.raw.cmd_bind_descriptor_sets(cmd, bind, layout, OBJECT_SET_INDEX, &sets, &[]);
                let push = StochasticPush {
                    origin_x: x0,
                    origin_y: y0,
                    decoupled_phase: phase as u32,
                    ..self.base_push(view, object, pass)
                };
                d.raw.cmd_push_constants(
                    cmd,
                    layout,
                    vk::ShaderStageFlags::COMPUTE,
                    0,
                    bytemuck::bytes_of(&push),
                );
                match phase {
                    DecoupledPhase::Args => d.raw.cmd_dispatch(cmd, 1, 1, 1),
                    DecoupledPhase::Shade => d.raw.cmd_dispatch_indirect(
                        cmd,
                        queue.expect("the deferred mode has its queue"),
                        DEFERRED_ARGS_OFFSET,
                    ),
                    _ => d.raw.cmd_dispatch(cmd, rw.div_ceil(8), rh.div_ceil(8), 1),
                }
            }
        };
        // The background dispatch reads no object's data; any permutation does it. Set 1 and 2 of the
        // first drawn object (or of the first object) keep the layout's sets valid.
        let i = (0..world.objects.len()).find(|&i| self.is_drawn(i, world)).unwrap_or(0);
        dispatch(
            &self.shade_pipelines[0].1,
            SHADE_BACKGROUND,
            [world.objects[i].set, self.object_sets[i]],
            full,
            DecoupledPhase::Memo,
        );
        // The deferred mode: allocate, then shade the new entries, then resolve (module docs of
        // decoupled.glsl); the others: one dispatch.
        let phases: &[DecoupledPhase] = if self.decoupled.as_ref().is_some_and(|dc| dc.deferred) {
            &[DecoupledPhase::Allocate, DecoupledPhase::Args, DecoupledPhase::Shade, DecoupledPhase::Resolve]
        } else {
            &[DecoupledPhase::Memo]
        };
        for (effects, pipeline) in &self.shade_pipelines {
            for (i, o) in world.objects.iter().enumerate() {
                if self.object_effects[i] == *effects && self.is_drawn(i, world) {
                    for &phase in phases {
                        dispatch(
                            pipeline,
                            i as u32,
                            [o.set, self.object_sets[i]],
                            self.shade_rects[i],
                            phase,
                        );
                    }
                }
            }
        }
    }

    /// This frame's result.
    fn technique_frame(&self, image: LinearImage) -> Result<TechniqueFrame> {
        Ok(TechniqueFrame {
            image,
            passes: self.passes,
            msaa_samples: 1,
            counters: self.counters()?,
            clusters: self.object_clusters.clone(),
        })
    }
}

/// Technique `stochastic`: every object on the stochastic path simulating both effects.
pub struct StochasticTechnique {
    draws: StochasticDraws,
}

impl StochasticTechnique {
    /// The technique for the objects' paths `object_effects` (technique `stochastic`: all `Both`).
    pub fn new(
        ctx: &PrepareContext<'_>,
        options: StochasticOptions,
        debug: DebugOptions,
        object_effects: &[Effects],
    ) -> Result<Self> {
        let plan = Plan::for_view(ctx.scene, ctx.camera, 0.0);
        Self::planned(ctx, options, debug, &plan, object_effects)
    }

    /// The same with the view's plan already made (`auto` plans the frame first): its per-object
    /// motion, blur and screen boxes set the interval bounds and the shading dispatches.
    pub fn planned(
        ctx: &PrepareContext<'_>,
        options: StochasticOptions,
        debug: DebugOptions,
        plan: &Plan,
        object_effects: &[Effects],
    ) -> Result<Self> {
        Ok(StochasticTechnique { draws: StochasticDraws::new(ctx, options, debug, plan, object_effects)? })
    }

    /// The stochastic path (for its diagnostics: bound debug output, hull usage).
    pub fn draws(&self) -> &StochasticDraws {
        &self.draws
    }
}

impl FrameTechnique for StochasticTechnique {
    fn render(&mut self, inputs: &FrameInputs<'_>, frame: &mut FrameContext<'_>) -> Result<TechniqueFrame> {
        self.draws.before_frame(inputs, frame)?;
        let image = self.draws.render(frame, inputs)?;
        self.draws.technique_frame(image)
    }

    /// Stochastic transparency, when an object covers partly: its coverage stage keeps a hit only on
    /// the samples the object covers.
    fn transparency(&self) -> Option<crate::transparency::TransparencyMethod> {
        let d = &self.draws;
        (d.object_alpha.iter().any(|&a| a < 1.0) || d.object_texture_alpha.iter().any(|&t| t))
            .then_some(crate::transparency::TransparencyMethod::Stochastic)
    }

    fn shadows(&self) -> Option<String> {
        self.draws.shadows.as_ref().map(ShadowMaps::summary)
    }
}

/// What the stochastic rasterizer's shaders expect of the layouts [`StochasticTechnique::new`] builds:
/// sets 2 and 3 from [`STOCHASTIC_OBJECT_SET`] and [`STOCHASTIC_SET`], and [`StochasticPush`] for the
/// raster pipelines (`hull.vert` pushes nothing) and the shading pass, [`TrianglesPush`] for
/// `triangles.comp`. Also `expand.comp`'s: [`ComputeHull`] builds its pipeline with these two sets'
/// layouts (handed over here; it writes the hull bindings of set 2 and the counts' binding of set 3)
/// and [`super::compute_hull::ExpandPush`].
pub const SHADER_INTERFACES: &[crate::gpu::layout::ShaderInterface] = &[
    crate::gpu::layout::ShaderInterface::technique(
        &[
            "stochastic/stochastic.vert",
            "stochastic/stochastic.geom",
            "stochastic/hull.vert",
            "stochastic/cluster.vert",
            "stochastic/stochastic.frag",
        ],
        Some(&STOCHASTIC_OBJECT_SET),
        Some(&STOCHASTIC_SET),
        Some(STOCHASTIC_STRUCTS[0]),
    ),
    // The shading pass: the same sets, and the shadow maps as set 4.
    crate::gpu::layout::ShaderInterface::technique(
        &["stochastic/shade.comp"],
        Some(&STOCHASTIC_OBJECT_SET),
        Some(&STOCHASTIC_SET),
        Some(STOCHASTIC_STRUCTS[0]),
    )
    .with_shadows(&super::shadow_maps::SHADOW_SET),
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
        Some(super::compute_hull::EXPAND_STRUCTS[0]),
    ),
];

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn auto_clusters_take_dense_blurred_meshes_only() {
        use crate::scene::builtin::builtin_scene;
        use crate::scene::View;
        // focus-sweep's sphere at 160×90: clusters of 16 of its 327,680 triangles are far inside its
        // 9 px blur — also when the mesh stores them scrambled (the cluster order sorts them).
        let scene = builtin_scene("focus-sweep").unwrap().unwrap();
        let view = View::camera(&scene, 160, 90);
        let k = scene.camera.intrinsics(160, 90);
        let i = scene.objects.iter().position(|o| o.name == "displaced-sphere").unwrap();
        let mv = view.space.objects[i].model_view[0];
        let mesh = &scene.objects[i].mesh;
        let (order, area) = choose_cluster_order(mesh, mv, &k, 16);
        let area = area.unwrap();
        assert!(area < 1.0, "{area}");
        assert!(order.iter().enumerate().all(|(j, &t)| j as u32 == t), "the stored order is tighter");
        assert!(auto_clusters(327_680, Some(area), 9.3, 16));
        let mut scrambled = (**mesh).clone();
        let tris: Vec<[u32; 3]> = mesh.indices.chunks_exact(3).map(|t| [t[0], t[1], t[2]]).collect();
        scrambled.indices = (0..tris.len()).flat_map(|j| tris[(j * 7919) % tris.len()]).collect();
        let stored: Vec<u32> = (0..tris.len() as u32).collect();
        let as_stored = mean_cluster_area_px(&scrambled, &stored, mv, &k, 16).unwrap();
        let (_, sorted) = choose_cluster_order(&scrambled, mv, &k, 16);
        let sorted = sorted.unwrap();
        assert!(as_stored > 100.0 * area && sorted < 4.0 * area, "{as_stored} and {sorted} vs {area}");
        assert!(auto_clusters(327_680, Some(sorted), 9.3, 16));
        // Clusters as wide as the object (what stored order gave a scrambled mesh) are refused.
        assert!(!auto_clusters(327_680, Some(400.0), 9.3, 16));
        // No blur, too few triangles, or no area (a vertex at the near plane): one per triangle.
        assert!(!auto_clusters(327_680, Some(area), 0.5, 16));
        assert!(!auto_clusters(327_680, Some(area), f32::NAN, 16));
        assert!(!auto_clusters(31, Some(1.0), 20.0, 16));
        assert!(!auto_clusters(327_680, None, 9.3, 16));
        // Clusters parse as the CLI gives them.
        assert_eq!("16".parse::<Clusters>().unwrap(), Clusters::Fixed(16));
        assert_eq!("off".parse::<Clusters>().unwrap(), Clusters::Off);
        assert!("12".parse::<Clusters>().is_err() && "512".parse::<Clusters>().is_err());
    }

    #[test]
    fn auto_intervals_split_long_motion_only() {
        assert_eq!(auto_intervals(0.0, 5.0, 16), 1);
        assert_eq!(auto_intervals(f32::NAN, 0.0, 16), 1);
        assert_eq!(auto_intervals(100.0, 0.0, 1), 1);
        // Short motion under a large blur: one bound over the shutter.
        assert_eq!(auto_intervals(4.0, 20.0, 16), 1);
        // Long motion, sharp: several runs, more for more samples per pass, never past them.
        let k16 = auto_intervals(200.0, 0.0, 16);
        let k64 = auto_intervals(200.0, 0.0, 64);
        assert!(k16 >= 2 && k64 >= k16 && k16 <= 16, "{k16} {k64}");
        assert!(auto_intervals(1e9, 0.0, 8) <= 8);
        for m in [1.0f32, 10.0, 100.0, 1000.0] {
            assert!(auto_intervals(m, 0.0, 16).is_power_of_two());
        }
    }

    #[test]
    fn bound_choices_parse() {
        assert_eq!("device".parse::<BoundChoice>().unwrap(), BoundChoice::Device);
        assert_eq!("bbox".parse::<BoundChoice>().unwrap(), BoundChoice::Kind(BoundKind::BoundingBox));
        assert!("hull".parse::<BoundChoice>().is_err());
        for k in BoundKind::ALL {
            assert_eq!(BoundChoice::from(k).name(), k.name());
        }
        // Per object: the thesis' pair by default, any pair and threshold spelled out; the name
        // parses back to the same choice.
        let thesis = BoundChoice::PerObject(ObjectBoundPolicy::THESIS);
        assert_eq!("per-object".parse::<BoundChoice>().unwrap(), thesis);
        let p: BoundChoice = "per-object/bbox/convex-hull/2.5".parse().unwrap();
        let want = ObjectBoundPolicy {
            sharp: BoundKind::BoundingBox,
            blurred: BoundKind::ConvexHull,
            threshold_px: 2.5,
        };
        assert_eq!(p, BoundChoice::PerObject(want));
        for c in [thesis, p] {
            assert_eq!(c.name().parse::<BoundChoice>().unwrap(), c);
        }
        for bad in [
            "per-object/",
            "per-object/bbox/convex-hull",
            "per-object/bbox/hull/1",
            "per-object/bbox/wedge/-1",
        ] {
            assert!(bad.parse::<BoundChoice>().is_err(), "{bad}");
        }
        assert!("per-object/bbox/wedge/nan".parse::<BoundChoice>().is_err());
        // The threshold is inclusive; NaN blur (never from the plan, but) reads as blurred.
        assert_eq!(want.kind(2.5), BoundKind::BoundingBox);
        assert_eq!(want.kind(2.50001), BoundKind::ConvexHull);
        assert_eq!(want.kind(0.0), BoundKind::BoundingBox);
        assert_eq!(want.kind(f32::NAN), BoundKind::ConvexHull);
    }

    #[test]
    fn shading_rects_hold_the_box_and_stay_in_the_image() {
        use glam::Vec2;
        assert_eq!(shading_rect(None, (320, 180)), [0, 0, 320, 180]);
        let [x, y, w, h] = shading_rect(Some((Vec2::new(10.2, 20.7), Vec2::new(30.5, 40.0))), (320, 180));
        assert!(x <= 9 && y <= 19 && x + w >= 32 && y + h >= 41 && x + w <= 320, "{x} {y} {w} {h}");
        assert_eq!(
            shading_rect(Some((Vec2::new(-50.0, -50.0), Vec2::new(1e4, 1e4))), (320, 180)),
            [0, 0, 320, 180]
        );
        let off = shading_rect(Some((Vec2::new(400.0, 10.0), Vec2::new(500.0, 20.0))), (320, 180));
        assert!(off[2] == 0, "{off:?}");
        assert_eq!(shading_rect(Some((Vec2::NAN, Vec2::ZERO)), (320, 180)), [0, 0, 320, 180]);
    }

    #[test]
    fn samples_per_pass_fits_the_budget() {
        let budget = VISIBILITY_BUDGET_BYTES;
        assert_eq!(samples_per_pass(16, None, 320 * 180, 8, budget).unwrap(), (16, 1));
        let pixels = 1920 * 1080;
        for max in [budget, 128 << 20] {
            let (m, p) = samples_per_pass(256, None, pixels, 8, max).unwrap();
            assert!(m * p == 256 && pixels * m as u64 * 8 <= max && m >= 1, "{m} {p}");
        }
        assert_eq!(samples_per_pass(16, Some(4), 100, 8, budget).unwrap(), (4, 4));
        assert!(samples_per_pass(16, Some(3), 100, 8, budget).is_err());
        assert!(samples_per_pass(16, Some(0), 100, 8, budget).is_err());
        // Forced past the device's range, or not even one sample per pass fits: refused, not clipped.
        assert!(samples_per_pass(16, Some(16), pixels, 8, 128 << 20).is_err());
        assert!(samples_per_pass(16, None, 1 << 30, 8, 128 << 20).is_err());
    }
}
