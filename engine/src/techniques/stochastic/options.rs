//! The stochastic frame's choices, made before any GPU work: the shading rate, bounds, interval and
//! cluster decisions per object, samples per pass, the sample tile as the shaders read it, and each
//! object's shading rectangle. Pure CPU code, unit-tested here.

use crate::error::{Error, Result};
use crate::geometry::KeyTimes;
use crate::mirror::bounds::BoundKind;
use crate::sampling::{ApertureShape, SampleTile, ShutterCurve, SAMPLE_TILE_SIZE};
use crate::techniques::settings::{key, number, OptionKey};

use super::super::compute_hull::HullExpansion;
use super::mask::Coverage;
use super::shading::DEFAULT_CACHE_ENTRIES;

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
    /// per frame into its own mip atlas at a level chosen per triangle ([`crate::techniques::texture_space`],
    /// level 0 at most [`TEXTURE_SPACE_FINEST`]², fitted per object), at the lens centre and
    /// mid-shutter — or, for an object that turns in camera space within the shutter, at several
    /// times, weighed by the samples that see each texel then
    /// ([`crate::mirror::texture_space::rate::shading_time_count`]); every sample looks its radiance up there. Not mirrored by the reference (its shading is view-independent).
    TextureSpace,
    /// [`ShadingRate::TextureSpace`]'s atlases, looked up once per pixel and (triangle, side) group as
    /// [`ShadingRate::PerPixel`] shades — at the group's first hit (the paper's per-pixel, "MSAA",
    /// lookup: at the pixel centre).
    TextureSpacePerPixel,
    /// Decoupled shading (Ragan-Kelley et al. 2011; [`crate::mirror::decoupled`], docs/DECOUPLED.md): every
    /// sample takes the radiance of its key — (triangle, side, cell of `grid` around its surface point
    /// at mid-shutter through the lens centre) — which is shaded at the key's shading point. The grid:
    /// pixels (`decoupled`), or each triangle's adaptive anisotropic grid (Vaidyanathan et al. 2012,
    /// [`crate::mirror::aas::bounds`]: oriented along its motion, stretched by its blur; `aas`), or that grid
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
    Decoupled { grid: crate::mirror::decoupled::GridKind, deferred: bool },
}

/// The largest level 0 side of the atlases of [`ShadingRate::TextureSpace`], texels — the paper's;
/// each object's is fitted to what its triangles ask for ([`AtlasSize`](crate::techniques::texture_space::AtlasSize)).
pub const TEXTURE_SPACE_FINEST: u32 = 2048;
/// Texels between the atlas' levels.
pub const TEXTURE_SPACE_GUTTER: u32 = 4;

impl ShadingRate {
    /// The rates the reference mirrors sample for sample ([`crate::reference::ReferenceShading`]).
    pub const ALL: [ShadingRate; 2] = [ShadingRate::PerPixel, ShadingRate::PerSample];
    /// Every rate, by name.
    pub const NAMED: [ShadingRate; 10] = {
        use crate::mirror::decoupled::GridKind::*;
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
        use crate::mirror::decoupled::GridKind::*;
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
    pub fn decoupled_grid(&self) -> Option<crate::mirror::decoupled::GridKind> {
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

/// The stochastic frame's settings keys ([`StochasticOptions::set`] parses them).
pub const KEYS: &[OptionKey] = &[
    key("bound", "stochastic", "a bound or a per-object policy (docs/STOCHASTIC.md)", "bbox"),
    key("shading", "stochastic", "a shading rate", "per-pixel"),
    key("per-pass", "stochastic", "samples per pass", "8"),
    key("hull", "stochastic", "gs, compute, mesh or mesh-task", "compute"),
    key("coverage", "stochastic", "device, visibility, mask or mask-per-fragment", "mask"),
    key("intervals", "stochastic", "time intervals of the bounds: auto or a power of two", "4"),
    key("clusters", "stochastic", "cluster bounds: auto, off or triangles per cluster", "32"),
    key("cache", "stochastic", "decoupled shading's cache entries", "4096"),
];

/// Settings of the `stochastic` technique.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub struct StochasticOptions {
    /// The bound kind, or the device's calibrated choice ([`BoundChoice::Device`], the default).
    pub bound: BoundChoice,
    pub shading: ShadingRate,
    /// Count samples tested / hit and shading invocations with atomics (slower).
    pub instrumented: bool,
    /// Samples per pixel and pass M (S = M × passes): `None` takes all S in one pass where the visibility
    /// buffer fits [`VISIBILITY_BUDGET_BYTES`](super::VISIBILITY_BUDGET_BYTES) ([`samples_per_pass`]);
    /// `Some(m)` forces m (an experiment: more passes, each paying the bounds' rasterization again).
    pub per_pass: Option<u32>,
    /// Geometry shader or compute-expanded hull ([`HullExpansion`]).
    pub expansion: HullExpansion,
    /// How the coverage pass keeps each sample's nearest hit: the visibility buffer's 64-bit atomics
    /// or the hardware's multisampled depth test ([`Coverage`]; the device's choice by default).
    pub coverage: Coverage,
    /// Interval bounds: into how many runs of time-ordered samples each object's draw is split, each
    /// bounded over its own sub-interval of the shutter ([`Intervals`]).
    pub intervals: Intervals,
    /// Cluster bounds: objects drawn one bound per cluster of triangles ([`Clusters`]).
    pub clusters: Clusters,
    /// [`ShadingRate::Decoupled`]: entries of the memoization cache or of the deferred mode's hash
    /// table, 1 ..= [`MAX_CACHE_ENTRIES`](super::MAX_CACHE_ENTRIES) (default [`DEFAULT_CACHE_ENTRIES`]).
    pub cache_entries: u32,
}

/// Cluster bounds: an object is drawn with one bound per cluster of N triangles, neighbours in a Morton
/// order of their centroids ([`crate::mirror::bounds::cluster::cluster_order`]) (the union
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
/// ([`crate::mirror::bounds::cluster::cluster_order`]), whichever gives the smaller clusters on screen (the
/// built-in meshes are generated patch by patch, tighter than a Morton curve; an OBJ may store its
/// triangles in any order). Without a measured area (a vertex at the near plane): the Morton order.
pub fn choose_cluster_order(
    mesh: &crate::scene::Mesh,
    model_view: glam::Mat4,
    k: &crate::scene::Intrinsics,
    n: usize,
) -> (Vec<u32>, Option<f32>) {
    let stored: Vec<u32> = (0..mesh.triangle_count() as u32).collect();
    let morton = crate::mirror::bounds::cluster::cluster_order(mesh);
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
            coverage: Coverage::Device,
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

/// Samples per pixel and pass M and passes P (S = M × P) for `pixels` pixels, the per-sample buffers (`bytes`
/// per pixel and sample of a pass: [`VISIBILITY_BYTES`](super::VISIBILITY_BYTES), plus
/// [`TINT_BYTES`](super::TINT_BYTES) with tints) at most `max_bytes` —
/// [`VISIBILITY_BUDGET_BYTES`](super::VISIBILITY_BUDGET_BYTES) or the device's `maxStorageBufferRange`,
/// whichever is less: `forced` when given (it must divide S and fit), else the largest divisor of S that
/// fits.
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

impl StochasticOptions {
    /// Sets one of the stochastic frame's keys ([`KEYS`]); `Ok(false)` when `key` is not one of them.
    pub fn set(&mut self, key: &str, value: &str) -> Result<bool> {
        match key {
            "bound" => self.bound = value.parse()?,
            "shading" => self.shading = value.parse()?,
            "per-pass" => self.per_pass = Some(number(key, value)?),
            "hull" => self.expansion = value.parse()?,
            "coverage" => self.coverage = value.parse()?,
            "intervals" => self.intervals = value.parse()?,
            "clusters" => self.clusters = value.parse()?,
            "cache" => self.cache_entries = number(key, value)?,
            _ => return Ok(false),
        }
        Ok(true)
    }
}

#[cfg(test)]
mod tests {
    use super::super::layout::VISIBILITY_BUDGET_BYTES;
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
