//! The CPU reference: a distribution ray tracer of the scene model of docs/MODEL.md — the ground truth every
//! GPU image is measured against.
//!
//! It estimates the pixel integral over pixel area, lens and shutter with exactly the samples the GPU
//! techniques use (the seeded [`SampleTile`](crate::sampling::SampleTile) sets) and exactly the same
//! model:
//!
//! * **Camera space.** Everything happens in camera space (+Y up, looking down −Z, view depth
//!   `z = −p.z`). At shutter time `t` in key segment `j` of its object's motion, at local time `s`
//!   ([`KeyTimes::locate`]), a vertex is at `Pj + (Pj+1 − Pj)·s` with `Pj` its camera-space positions
//!   at the keys ([`ObjectMotion::positions`](crate::scene::ObjectMotion::positions); two keys, open and close, unless the object has more);
//!   vertex normals are `mix(Nj, Nj+1, s)` of [`ObjectMotion::normals`](crate::scene::ObjectMotion::normals); lights are
//!   [`CameraSpaceLight::at`](crate::scene::CameraSpaceLight::at)`(t)`.
//! * **Rays.** Sample `s` of pixel `(px, py)` is the thin-lens ray [`Intrinsics::primary_ray`] through
//!   `(px + s.xy.x, py + s.xy.y)` from lens point `aperture.map(s.lens)` at time `shutter.warp(s.time)`.
//!   The pixel value is the plain mean of its samples (box filter); alpha is 1.
//! * **Visibility.** Every triangle test is the GPU's inside test,
//!   [`crate::geometry::intersect_triangle`] (two-sided, edges inclusive, the same barycentrics and
//!   view depth). The nearest hit by that view depth whose depth lies in `[near, far]` wins (the GPU's
//!   clip planes; hits outside are skipped, the ray goes on).
//! * **Shading.** At the hit's barycentric point `w₀·a + w₁·b + w₂·c` of the triangle at `t` (what the
//!   GPU shades). Shading normal = barycentric interpolation (the ray's barycentrics are the GPU's
//!   perspective-correct ones) of the per-vertex `mix(N0, N1, t)`, normalised, and flipped when the
//!   triangle's geometric normal at `t` faces away from the ray origin (the GPU's `gl_FrontFacing`).
//!   UVs are interpolated likewise; albedo is `material.albedo × texture.sample_bilinear(uv)`. The view
//!   vector is `−direction`, i.e. towards the lens sample (thesis §5.1). Radiance is
//!   [`shade`]`(hit, n, view, albedo, specular, roughness, lights(t), ambient)`; a miss sees
//!   `environment.background`.
//! * **One-sided surfaces (camera rays).** A hit on the back of a triangle (the inside test's
//!   `back`: the ray meets it from the side where its vertices run clockwise) whose material is
//!   [`one_sided`](crate::scene::Material::one_sided) is no hit: the ray goes on, untinted. Shadow
//!   rays see both sides.
//! * **Transparency (camera rays).** A surface's coverage α is the material's `alpha` (times the
//!   texture's alpha at the hit's uv with `alpha_from_texture`, [`crate::scene::Material::coverage`]).
//!   Coverage is *stochastic*: the ray stops at a surface with probability α and passes through it
//!   otherwise, decided by [`crate::transparency::covered`] of (seed, pixel, sample index k of the
//!   pixel's S = `spp`, triangle) — stratified per pixel and triangle (exactly ⌊αS⌋ or ⌈αS⌉ of the
//!   pixel's samples stop at a triangle) and the very function the GPU's stochastic transparency
//!   evaluates, so renders are reproducible and the GPU makes the same decisions for the same
//!   samples; passing through multiplies the ray's throughput by the surface's `tint` T. A sample
//!   is `Π_{j<k} T_j · C_k` for the surface k it stops at (background if none), which happens with
//!   probability `α_k · Π_{j<k} (1 − α_j)`; its expectation is therefore the sorted Porter-Duff
//!   composite `Σ_k vis(z_k)·α_k·C_k + vis(∞)·background` with `vis(z) = Π_{z_j < z} (1 − α_j)·T_j`
//!   (docs/TRANSPARENCY.md) — the quantity the GPU's stochastic transparency estimates, with the same
//!   samples. Why stochastic rather than compositing every layer exactly: the coverage and the
//!   rest of the pixel integral (lens, shutter, pixel area) are then sampled together, every
//!   sample stays one path with one shading point (per-pixel shading mirrors the rasterizer), and an
//!   opaque scene's samples are unchanged. The closed-form pane test (`tests.rs`) shows the
//!   convergence: the error falls as 1/√S.
//! * **Shadows.** For each light with `shadows`, a shadow ray leaves the shaded point — offset along
//!   the geometric normal, towards the light's side, by [`SHADOW_RAY_LIFT`] times the largest
//!   coordinate magnitude of the hit triangle (the scale of its rounding error: the least offset that
//!   keeps the surface from shadowing itself, with a margin, so the shadow's edge moves by no more
//!   than that) — at the sample's shutter time, towards the light (directional: to infinity;
//!   point and spot: up to the light's position). Any-hit traversal ([`Bvh::for_each_hit`])
//!   multiplies the transmittance `(1 − α)·T` of every surface it crosses, at the crossing's coverage
//!   (texture alpha included), and stops at the first opaque one (0). No randomness: the light's
//!   colour is multiplied by the exact transmittance before shading. Two hits of one object closer
//!   than [`SHADOW_RAY_OFFSET`] times that scale are one crossing (a ray through the edge two triangles share hits both).
//!   Lights without `shadows` are unoccluded, and no shadow ray is traced for a light that does not
//!   reach the point anyway (behind the surface, outside a spot's cone).
//!
//! * **Indirect light** (`[environment] indirect = "one-bounce"`, [`crate::scene::Indirect`]). Each
//!   camera sample's shading point `x` also traces one bounce ray at the sample's shutter time, in a
//!   cosine-distributed direction around its shading normal ([`cosine_direction`]), from a
//!   multi-jittered set of the pixel's own in a shuffled order (seeded by the render seed and the
//!   pixel: stratified over the pixel's samples, uncorrelated with them). A direction below the
//!   geometric surface carries nothing. The ray stops at the nearest surface of coverage 1 (both
//!   sides, as shadow rays), attenuated by the transmittance of the partly covering ones before it
//!   (which reflect nothing themselves); there `y` sends out the diffuse term of its direct light,
//!   shadowed as above, without ambient or specular. `x` adds `albedo(x)` times it — one sample of the
//!   Lambertian integral `albedo/π ∫ L cos θ dω`, unbiased: the estimate converges to the model's
//!   exact one-bounce answer (the closed-form floor-and-sensor test in `tests.rs`). A ray that
//!   escapes brings nothing (the background and the ambient light no surface).
//!
//! Geometry lives in [`Bvh`]s over [`SegmentTriangle`]s, one per interval between consecutive motion
//! keys of the whole scene (one tree for two-key scenes; boxes at the interval's ends, interpolated at
//! ray time). Rendering is parallel over 16×16-pixel tiles with rayon; every pixel depends only on its
//! own samples, so images are bit-identical for any thread count. Image size and sample count are
//! checked against [`crate::limits`].

mod bvh;
pub mod gbuffer;
pub mod vpl;

use std::time::Instant;

use glam::{DVec3, Vec2, Vec3};
use rayon::prelude::*;

pub use bvh::{Bvh, Hit, SegmentTriangle};
pub use vpl::{virtual_point_lights, virtual_point_lights_at, VirtualPointLight, VplSettings};

use crate::error::{Error, Result};
use crate::geometry::{KeyTimes, MovingTriangle, TriangleHit};
use crate::image::LinearImage;
use crate::limits::{MAX_IMAGE_DIMENSION, MAX_SPP};
use crate::progress::Progress;
use crate::sampling::{pixel_sample_set, Pcg32, Sample5, SAMPLE_TILE_SIZE};
use crate::scene::{Camera, CameraSpaceScene, Indirect, Intrinsics, Scene, Texture};
use crate::shading::{shade, ShadingLight};

/// Version of what the reference computes: bumped whenever the same scene and settings render to
/// different pixels (intersection, shading, sampling). `shutter quality` puts it in the key of its
/// cached references, so a reference rendered by an older version is never reused.
///
/// 5: direct shadow rays leave the surface [`SHADOW_RAY_LIFT`] (2⁻¹⁸) times the triangle's scale
/// above it instead of 10⁻⁴ (issue 28 item 8: the larger offset moved shadow edges by hundredths of a pixel):
/// shadow edges move by that, nothing else.
/// 4: stochastic coverage stratified per pixel and triangle ([`crate::transparency::covered`], shared
/// with the GPU) instead of an independent hash per sample: scenes with alpha or tints render to
/// different pixels (opaque scenes do not change).
/// 3: a pixel's samples in shutter-time order (`sampling::pixel_sample_set`), the hit depth clamped
/// to the triangle's depth range, triangles interpolated over the shutter as `a + (b − a)·t` (exact for
/// still vertices). (2: hits from the shared [`crate::geometry::intersect_triangle`] (the GPU's inside
/// test), nearest by barycentric view depth, shaded at the barycentric point. 1: a Möller–Trumbore of
/// its own, nearest by ray parameter, shaded at `o + t·d`.)
pub const REFERENCE_VERSION: u32 = 5;
/// Relative offset of a secondary ray's origin along the geometric normal (bounce rays, the virtual
/// point lights' gathers, mirrored by the interleaved technique's G-buffer rays), times the largest
/// coordinate magnitude of the shaded triangle, and the distance along a shadow ray below which two
/// hits of one object are one crossing: f32 rounding of the hit point is about 1e-7 of that scale, so
/// the ray clears its own surface with a wide margin, while contact gaps below 1e-4 of the scene's
/// coordinates are not resolved.
pub const SHADOW_RAY_OFFSET: f32 = 1e-4;
/// Relative offset of a direct shadow ray's origin along the geometric normal, times the same scale
/// (module docs, "Shadows"): 64 ulps (2⁻¹⁸). Rounding puts the shaded point up to a few ulps of the
/// scale off its triangle's plane, and the ray's test against its own triangle (and a coplanar or
/// convex neighbour) rounds as much, however grazing the light: 4 ulps already clear them in every
/// case of the test `shadow_rays_clear_their_own_surface` (lights down to 0.06°), 1 ulp does not.
/// Being 26× smaller than [`SHADOW_RAY_OFFSET`], the shadow's edge it moves (the offset over the
/// light's slope) is too.
pub const SHADOW_RAY_LIFT: f32 = 1.0 / 262_144.0;
/// Mixed into the seed of each pixel's bounce directions (one-bounce indirect light), so they are not
/// correlated with its camera samples.
const BOUNCE_SEED: u64 = 0x6f6e_652d_626f_756e;
/// Side of the square pixel tiles rendered in parallel.
pub const TILE: u32 = 16;

/// What to render.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub struct ReferenceSettings {
    pub width: u32,
    pub height: u32,
    /// Rays per pixel, 1..=[`MAX_SPP`].
    pub spp: u32,
    /// Seed of the sample sets (and of stochastic alpha).
    pub seed: u64,
    /// Show progress on stderr ([`crate::progress`]: a bar on a terminal, sparse lines otherwise).
    pub progress: bool,
    /// How often samples are shaded (visibility is always per sample).
    pub shading: ReferenceShading,
}

/// How often the reference shades: the ground truth shades every sample; the per-pixel mode mirrors
/// the stochastic rasterizer's `ShadingRate::PerPixel` (`shaders-glsl/stochastic/shade.glsl`) so that
/// its images can be compared exactly with the same samples.
#[derive(Clone, Copy, Debug, Default, PartialEq, Eq)]
pub enum ReferenceShading {
    /// Every sample shaded at its own hit (the ground truth).
    #[default]
    PerSample,
    /// The pixel's samples in consecutive chunks of `per_pass` (the rasterizer's passes); within a
    /// chunk, samples that hit the same triangle from the same side take the radiance of the first
    /// of them, for at most [`PER_PIXEL_SHADING_GROUPS`] groups per object (samples of later groups are
    /// shaded on their own).
    PerPixel { per_pass: u32 },
    /// Decoupled shading ([`crate::mirror::decoupled`]): every sample takes the radiance of its key's shading
    /// point — on its triangle at mid-shutter, seen from the lens centre, on the sample's side — or of
    /// its own hit when it has no key; keys are cells of the grid [`crate::mirror::decoupled::GridKind`] says.
    /// What `--shading decoupled`, `aas` and `aas-isotropic` (and their `-deferred` modes) compute
    /// whatever their cache does.
    Decoupled(crate::mirror::decoupled::GridKind),
}

/// Groups per object, pixel and pass that per-pixel shading remembers (`SHADE_GROUPS` in
/// `shade.glsl`).
pub const PER_PIXEL_SHADING_GROUPS: usize = 8;

/// What a render cost.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct ReferenceStats {
    /// Triangles in the BVH.
    pub triangles: usize,
    pub bvh_nodes: usize,
    /// Primary rays traced (`width × height × spp`).
    pub rays: u64,
    /// Wall time of the whole call, BVH build included.
    pub seconds: f64,
    /// Wall time of preparing camera-space geometry and building the BVH.
    pub build_seconds: f64,
    /// [`ReferenceShading::Decoupled`]: the distinct keys (shading points) the image's samples name —
    /// what a cache that never forgot would shade ([`crate::mirror::decoupled::key`]).
    pub decoupled_keys: Option<u64>,
}

/// Renders `scene` with the CPU reference.
pub fn render_reference(scene: &Scene, settings: &ReferenceSettings) -> Result<LinearImage> {
    render_reference_with_stats(scene, settings).map(|(image, _)| image)
}

/// [`render_reference`] through a folder of cached images, with whether it came from there. The file
/// name holds everything the pixels depend on — [`REFERENCE_VERSION`] (a reference traced by an older
/// reference is never reused), the scene's content hash, size, samples, seed and shading
/// ([`ReferenceShading::cache_tag`]; the ground truth's names carry none, as before shadings were
/// cached). An entry that does not read back at the right size is traced again and replaced; an entry
/// that cannot be written leaves the traced image returned (the cache only saves time).
///
/// The version is bumped by hand when the reference's output changes; a cache that must never outlive
/// the code that filled it (a test run's, which spans two drivers) is a folder of that run.
pub fn render_reference_cached(
    dir: &std::path::Path,
    scene: &Scene,
    settings: &ReferenceSettings,
) -> Result<(LinearImage, bool)> {
    let path = dir.join(format!(
        "reference-v{REFERENCE_VERSION}-{:016x}-{}x{}-{}spp-seed{}{}.exr",
        scene.content_hash(),
        settings.width,
        settings.height,
        settings.spp,
        settings.seed,
        settings.shading.cache_tag()
    ));
    if let Ok(image) = crate::image_io::load_image(&path) {
        if (image.width, image.height) == (settings.width, settings.height) {
            return Ok((image, true));
        }
    }
    let image = render_reference(scene, settings)?;
    let saved = std::fs::create_dir_all(dir)
        .map_err(|e| Error::io(dir, e))
        .and_then(|()| crate::image_io::save_image(&path, &image));
    if let Err(e) = saved {
        log::warn!("reference cache: {e:#}");
    }
    Ok((image, false))
}

impl ReferenceShading {
    /// What [`render_reference_cached`]'s file names add for this shading: nothing for the ground
    /// truth, the pass size or the grid otherwise.
    pub fn cache_tag(&self) -> String {
        use crate::mirror::decoupled::GridKind;
        match self {
            ReferenceShading::PerSample => String::new(),
            ReferenceShading::PerPixel { per_pass } => format!("-per-pixel{per_pass}"),
            ReferenceShading::Decoupled(GridKind::Pixel) => "-decoupled-pixel".into(),
            ReferenceShading::Decoupled(GridKind::Aas) => "-decoupled-aas".into(),
            ReferenceShading::Decoupled(GridKind::AasIsotropic) => "-decoupled-aas-isotropic".into(),
        }
    }
}

/// Renders `scene` with the CPU reference and reports what it cost.
pub fn render_reference_with_stats(
    scene: &Scene,
    settings: &ReferenceSettings,
) -> Result<(LinearImage, ReferenceStats)> {
    render(scene, settings, None, None).map(|(image, stats, _)| (image, stats))
}

/// Renders `scene` with its one-bounce indirect light estimated by instant radiosity ([`vpl`]: the
/// VPLs of `vpls`, every shaded point gathering every VPL) instead of a bounce ray per sample; also
/// returns how many VPLs there were.
pub fn render_reference_vpl(
    scene: &Scene,
    settings: &ReferenceSettings,
    vpls: &VplSettings,
) -> Result<(LinearImage, ReferenceStats, usize)> {
    render(scene, settings, None, Some(vpls))
}

/// Renders `scene` with every pixel taking the same sample set `samples` (sample k at pixel `(x, y)`
/// is the ray through `(x + s.xy.x, y + s.xy.y)`, lens and time as usual) — what technique
/// `accumulation` does, pass k rendering `samples[k]` everywhere
/// ([`crate::techniques::accumulation::accumulation_samples`]), so its images can be compared
/// with the same samples (stochastic coverage included: sample index k, S = `samples.len()`).
/// `settings.spp` must be `samples.len()`.
pub fn render_reference_shared_samples(
    scene: &Scene,
    settings: &ReferenceSettings,
    samples: &[Sample5],
) -> Result<LinearImage> {
    if samples.len() != settings.spp as usize {
        return Err(limit("shared samples", samples.len(), &format!("spp = {}", settings.spp)));
    }
    render(scene, settings, Some(samples), None).map(|(image, _, _)| image)
}

fn render(
    scene: &Scene,
    settings: &ReferenceSettings,
    shared: Option<&[Sample5]>,
    vpls: Option<&VplSettings>,
) -> Result<(LinearImage, ReferenceStats, usize)> {
    validate(settings, scene)?;
    let (bytes, detail) = memory_estimate(scene, settings);
    crate::limits::check_memory("the CPU reference", bytes, &detail)?;
    let start = Instant::now();
    let mut tracer = Tracer::new(scene, settings);
    tracer.shared = shared.map(|s| s.to_vec());
    if let Some(v) = vpls {
        tracer.check_still_scene()?;
        tracer.vpls = Some((tracer.virtual_point_lights(v, 0.5)?, v.clamp));
    }
    let vpl_count = tracer.vpls.as_ref().map_or(0, |v| v.0.len());
    let build_seconds = start.elapsed().as_secs_f64();

    let (w, h) = (settings.width, settings.height);
    let tiles_x = w.div_ceil(TILE);
    let tiles_y = h.div_ceil(TILE);
    let tile_count = (tiles_x * tiles_y) as u64;
    let bar =
        if settings.progress { Progress::new("reference", tile_count, "tiles") } else { Progress::hidden() };

    let results: Vec<(Vec<[f32; 4]>, Vec<u64>)> = (0..tiles_x * tiles_y)
        .into_par_iter()
        .map_init(Vec::new, |lights, i| {
            // Interrupted: the remaining tiles are skipped (empty) and the render returns the error.
            if crate::progress::interrupted() {
                return (vec![], vec![]);
            }
            let x0 = (i % tiles_x) * TILE;
            let y0 = (i / tiles_x) * TILE;
            let mut keys = vec![];
            let block =
                tracer.render_block(x0, y0, (x0 + TILE).min(w), (y0 + TILE).min(h), lights, &mut keys);
            bar.inc(1);
            keys.sort_unstable();
            keys.dedup();
            (block, keys)
        })
        .collect();
    let mut keys: Vec<u64> = results.iter().flat_map(|r| r.1.iter().copied()).collect();
    keys.sort_unstable();
    keys.dedup();
    let blocks: Vec<&Vec<[f32; 4]>> = results.iter().map(|r| &r.0).collect();
    bar.finish();
    crate::progress::check_interrupt()?;

    let mut image = LinearImage::new(w, h);
    for (i, block) in blocks.iter().enumerate() {
        let i = i as u32;
        let (x0, y0) = ((i % tiles_x) * TILE, (i / tiles_x) * TILE);
        let bw = (x0 + TILE).min(w) - x0;
        for (k, px) in block.iter().enumerate() {
            let k = k as u32;
            image.set(x0 + k % bw, y0 + k / bw, *px);
        }
    }
    let stats = ReferenceStats {
        triangles: tracer.bvhs[0].triangle_count(),
        bvh_nodes: tracer.bvhs.iter().map(|b| b.node_count()).sum(),
        rays: w as u64 * h as u64 * settings.spp as u64,
        seconds: start.elapsed().as_secs_f64(),
        build_seconds,
        decoupled_keys: matches!(settings.shading, ReferenceShading::Decoupled(_))
            .then_some(keys.len() as u64),
    };
    Ok((image, stats, vpl_count))
}

fn limit(what: &'static str, value: impl ToString, limit: &str) -> Error {
    Error::Limit { what, value: value.to_string(), limit: limit.to_string() }
}

/// Host bytes per triangle, whatever its motion: its surface record, per-vertex gathers and the
/// BVH build's scratch. With the two below, fitted to the peak RSS of `shutter reference` on a
/// 1,046,528-triangle sphere at 2, 4 and 8 motion keys (456, 829 and 1651 bytes per triangle above
/// the loaded scene; docs/hard-cases/input.md).
const BYTES_PER_TRIANGLE: u64 = 160;
/// Host bytes per triangle and key of its object (at least 2: a still object has both shutter
/// ends): its camera-space corners and normals.
const BYTES_PER_TRIANGLE_KEY: u64 = 100;
/// Host bytes per triangle and BVH (one BVH per interval between the scene's key times, each holding
/// every triangle over its segment).
const BYTES_PER_TRIANGLE_BVH: u64 = 100;
/// Host bytes per pixel: the tiles' results and the image.
const BYTES_PER_PIXEL: u64 = 48;

/// What [`render_reference`] will allocate for `scene` at `settings`, bytes, and how the figure
/// arose (triangles, BVHs, pixels) — checked against [`crate::limits::memory_limit`] before any work,
/// so a scene too big for the machine is refused with the figure instead of aborting part-way.
pub fn memory_estimate(scene: &Scene, settings: &ReferenceSettings) -> (u64, String) {
    let triangles = scene.triangle_count() as u64;
    let triangle_keys: u64 =
        scene.objects.iter().map(|o| o.mesh.triangle_count() as u64 * o.transforms.len().max(2) as u64).sum();
    let mut times: Vec<f32> = scene.objects.iter().flat_map(|o| o.transforms.iter().map(|k| k.0)).collect();
    times.extend([0.0, 1.0]);
    times.sort_by(f32::total_cmp);
    times.dedup();
    let bvhs = (times.len() as u64).saturating_sub(1).max(1);
    let pixels = settings.width as u64 * settings.height as u64;
    let meshes: u64 = scene.objects.iter().map(|o| o.mesh.heap_bytes()).sum();
    let bytes = meshes
        .saturating_add(triangles.saturating_mul(BYTES_PER_TRIANGLE))
        .saturating_add(triangle_keys.saturating_mul(BYTES_PER_TRIANGLE_KEY))
        .saturating_add(triangles.saturating_mul(bvhs).saturating_mul(BYTES_PER_TRIANGLE_BVH))
        .saturating_add(pixels.saturating_mul(BYTES_PER_PIXEL));
    let detail =
        format!("{triangles} triangles, {bvhs} BVH(s) over the shutter's key intervals, {pixels} pixels");
    (bytes, detail)
}

/// The settings in range and the scene as [`Scene::validate`] wants it.
fn validate(s: &ReferenceSettings, scene: &Scene) -> Result<()> {
    let size = format!("1..={MAX_IMAGE_DIMENSION} (MAX_IMAGE_DIMENSION)");
    if !(1..=MAX_IMAGE_DIMENSION).contains(&s.width) {
        return Err(limit("width", s.width, &size));
    }
    if !(1..=MAX_IMAGE_DIMENSION).contains(&s.height) {
        return Err(limit("height", s.height, &size));
    }
    if !(1..=MAX_SPP).contains(&s.spp) {
        return Err(limit("spp", s.spp, &format!("1..={MAX_SPP} (MAX_SPP)")));
    }
    scene.validate()
}

/// The samples of pixel `(x, y)`: exactly `SampleTile::new(spp, SAMPLE_TILE_SIZE, seed).pixel(x, y)`,
/// generated on the fly so that huge sample counts need no 64×64×spp table.
pub fn pixel_samples(spp: u32, seed: u64, x: u32, y: u32) -> Vec<Sample5> {
    let p = (y % SAMPLE_TILE_SIZE) * SAMPLE_TILE_SIZE + x % SAMPLE_TILE_SIZE;
    pixel_sample_set(spp, &mut Pcg32::new(seed, p as u64 + 1))
}

/// Per-triangle shading data, in build (scene) order.
#[derive(Clone, Copy, Debug)]
struct SurfaceTri {
    uv: [Vec2; 3],
    object: u32,
    /// Where the triangle's vertices and normals at its object's keys start in `Tracer::keyed`.
    key_base: u32,
}

struct SurfaceMaterial<'a> {
    albedo: Vec3,
    /// Texture, only when the mesh also has UVs.
    texture: Option<&'a Texture>,
    specular: f32,
    roughness: f32,
    alpha: f32,
    /// Coverage also from `texture`'s alpha (false when the mesh has no UVs to sample it with).
    alpha_from_texture: bool,
    tint: Vec3,
    /// Camera rays skip its back faces ([`crate::scene::Material::one_sided`]).
    one_sided: bool,
}

impl SurfaceMaterial<'_> {
    /// Coverage 1 everywhere: rays never pass through.
    fn is_opaque(&self) -> bool {
        self.alpha >= 1.0 && !self.alpha_from_texture
    }
}

/// A triangle's camera-space vertices and (unnormalised) vertex normals at one motion key.
type KeyedTriangle = ([Vec3; 3], [Vec3; 3]);

struct Tracer<'a> {
    /// One tree per interval of `intervals`.
    bvhs: Vec<Bvh>,
    /// The union of every object's key times: within one interval every triangle moves linearly.
    intervals: KeyTimes,
    /// Per triangle (from `SurfaceTri::key_base`), its camera-space vertices and (unnormalised)
    /// vertex normals at each key of its object.
    keyed: Vec<KeyedTriangle>,
    surface: Vec<SurfaceTri>,
    /// Each object's key times.
    object_keys: Vec<KeyTimes>,
    materials: Vec<SurfaceMaterial<'a>>,
    camera: &'a Camera,
    intrinsics: Intrinsics,
    scene_space: CameraSpaceScene,
    /// Per light (in `scene_space.lights` order): does it cast shadows?
    shadows: Vec<bool>,
    ambient: Vec3,
    background: Vec3,
    indirect: Indirect,
    spp: u32,
    seed: u64,
    /// [`crate::transparency::coverage_seed`] of `seed`.
    coverage_seed: u32,
    shading: ReferenceShading,
    /// Every pixel's samples, when they are shared ([`render_reference_shared_samples`]).
    shared: Option<Vec<Sample5>>,
    /// [`ReferenceShading::Decoupled`] with an AAS grid: each triangle's (by id); empty: pixels.
    grids: Vec<crate::mirror::aas::bounds::ShadingGrid>,
    /// One-bounce indirect light by instant radiosity ([`render_reference_vpl`]): the VPLs and the
    /// clamping distance; `None`: bounce rays.
    vpls: Option<(Vec<VirtualPointLight>, f32)>,
}

impl<'a> Tracer<'a> {
    fn new(scene: &'a Scene, s: &ReferenceSettings) -> Tracer<'a> {
        let scene_space = CameraSpaceScene::new(scene);
        let n = scene.triangle_count();
        let mut keyed = Vec::with_capacity(2 * n);
        let mut surface = Vec::with_capacity(n);
        let mut materials = Vec::with_capacity(scene.objects.len());
        let mut all_times: Vec<f32> = vec![];
        for (oi, (object, motion)) in scene.objects.iter().zip(&scene_space.objects).enumerate() {
            let mesh = &object.mesh;
            all_times.extend_from_slice(motion.keys.times());
            let positions: Vec<Vec<Vec3>> = mesh.positions.iter().map(|&p| motion.positions(p)).collect();
            let normals: Vec<Vec<Vec3>> = mesh.normals.iter().map(|&n| motion.normals(n)).collect();
            for tri in mesh.indices.chunks_exact(3) {
                let idx = [tri[0] as usize, tri[1] as usize, tri[2] as usize];
                let key_base = keyed.len() as u32;
                for k in 0..motion.keys.times().len() {
                    let normal = idx.map(|i| normals.get(i).map_or(Vec3::ZERO, |n| n[k]));
                    keyed.push((idx.map(|i| positions[i][k]), normal));
                }
                let uv = if mesh.has_uvs() { idx.map(|i| mesh.uvs[i]) } else { [Vec2::ZERO; 3] };
                surface.push(SurfaceTri { uv, object: oi as u32, key_base });
            }
            let m = &object.material;
            materials.push(SurfaceMaterial {
                albedo: m.albedo,
                texture: m.texture.as_deref().filter(|_| mesh.has_uvs()),
                specular: m.specular,
                roughness: m.roughness,
                alpha: m.alpha,
                alpha_from_texture: m.alpha_from_texture && m.texture.is_some() && mesh.has_uvs(),
                tint: m.tint,
                one_sided: m.one_sided,
            });
        }
        let object_keys: Vec<KeyTimes> = scene_space.objects.iter().map(|m| m.keys.clone()).collect();
        let intrinsics = scene.camera.intrinsics(s.width, s.height);
        let grids = match s.shading {
            ReferenceShading::Decoupled(kind) if kind != crate::mirror::decoupled::GridKind::Pixel => {
                crate::mirror::decoupled::object_grids(scene, &scene_space, &intrinsics, kind)
            }
            _ => vec![],
        };
        all_times.push(0.0);
        all_times.push(1.0);
        all_times.sort_by(f32::total_cmp);
        all_times.dedup();
        let intervals = KeyTimes::new(all_times).expect("key times in [0, 1] with both ends");
        // Per interval, each triangle over the key segment of its object holding the interval.
        let bvhs = intervals
            .times()
            .windows(2)
            .map(|w| {
                let mid = 0.5 * (w[0] + w[1]);
                let tris: Vec<SegmentTriangle> = surface
                    .iter()
                    .map(|t| {
                        let keys = &object_keys[t.object as usize];
                        let j = keys.segment_of(mid);
                        let base = t.key_base as usize + j;
                        SegmentTriangle {
                            tri: MovingTriangle { v0: keyed[base].0, v1: keyed[base + 1].0 },
                            t0: keys.times()[j],
                            inv_len: keys.inv_len()[j],
                        }
                    })
                    .collect();
                Bvh::build_interval(&tris, w[0], w[1])
            })
            .collect();
        Tracer {
            bvhs,
            intervals,
            keyed,
            surface,
            object_keys,
            materials,
            camera: &scene.camera,
            intrinsics,
            grids,
            shadows: scene.lights.iter().map(|l| l.shadows()).collect(),
            scene_space,
            ambient: scene.environment.ambient,
            background: scene.environment.background,
            indirect: scene.environment.indirect,
            spp: s.spp,
            seed: s.seed,
            coverage_seed: crate::transparency::coverage_seed(s.seed),
            shading: s.shading,
            shared: None,
            vpls: None,
        }
    }

    /// Triangle `id`'s key segment at shutter time `time` (its vertices and normals at the segment's
    /// keys) and the time within it.
    fn segment_at(&self, id: u32, time: f32) -> ([KeyedTriangle; 2], f32) {
        let tri = &self.surface[id as usize];
        let (j, s) = self.object_keys[tri.object as usize].locate(time);
        let base = tri.key_base as usize + j;
        ([self.keyed[base], self.keyed[base + 1]], s)
    }

    /// Renders pixels `[x0, x1) × [y0, y1)`, row-major.
    fn render_block(
        &self,
        x0: u32,
        y0: u32,
        x1: u32,
        y1: u32,
        lights: &mut Vec<ShadingLight>,
        keys: &mut Vec<u64>,
    ) -> Vec<[f32; 4]> {
        let mut out = Vec::with_capacity(((x1 - x0) * (y1 - y0)) as usize);
        for y in y0..y1 {
            for x in x0..x1 {
                let c = self.render_pixel(x, y, lights, keys);
                out.push([c.x, c.y, c.z, 1.0]);
            }
        }
        out
    }

    /// The pixel's value; with decoupled shading, the keys of its samples go into `keys`.
    fn render_pixel(&self, x: u32, y: u32, lights: &mut Vec<ShadingLight>, keys: &mut Vec<u64>) -> Vec3 {
        let own;
        let samples = match &self.shared {
            Some(shared) => shared.as_slice(),
            None => {
                own = pixel_samples(self.spp, self.seed, x, y);
                own.as_slice()
            }
        };
        let per_pass = match self.shading {
            ReferenceShading::PerSample | ReferenceShading::Decoupled(_) => 1,
            ReferenceShading::PerPixel { per_pass } => per_pass.max(1) as usize,
        };
        // One-bounce indirect light: each sample's bounce direction from a stratified (multi-jittered)
        // set of the pixel's own, in a random order.
        let bounces = (self.indirect == Indirect::OneBounce && self.vpls.is_none()).then(|| {
            let mut rng =
                Pcg32::new(self.seed ^ BOUNCE_SEED, y as u64 * MAX_IMAGE_DIMENSION as u64 + x as u64);
            let mut set = crate::sampling::multi_jittered(self.spp, &mut rng);
            rng.shuffle(&mut set);
            set
        });
        // Per-pixel shading groups of the current chunk: (triangle id, side, object, radiance).
        let mut groups: Vec<(u32, bool, u32, Vec3)> = Vec::new();
        let mut sum = DVec3::ZERO;
        for (k, s) in samples.iter().enumerate() {
            if k % per_pass == 0 {
                groups.clear();
            }
            let pos = Vec2::new(x as f32 + s.xy.x, y as f32 + s.xy.y);
            let lens = self.camera.aperture.map(s.lens);
            let time = self.camera.shutter.warp(s.time);
            let (o, d) = self.intrinsics.primary_ray(pos, lens);
            let (hit, throughput) = self.camera_hit(o, d, time, (x, y), k as u32);
            let Some(hit) = hit else {
                sum += (throughput * self.background).as_dvec3();
                continue;
            };
            let bounce = bounces.as_ref().map(|b| b[k]);
            let radiance = if self.shading == ReferenceShading::PerSample {
                self.shade_hit(&hit, d, time, bounce, lights)
            } else if let ReferenceShading::Decoupled(_) = self.shading {
                self.shade_decoupled(&hit, d, time, bounce, lights, keys)
            } else {
                let side = hit.hit.back;
                let object = self.surface[hit.id as usize].object;
                match groups.iter().find(|g| g.0 == hit.id && g.1 == side) {
                    Some(g) => g.3,
                    None => {
                        let r = self.shade_hit(&hit, d, time, bounce, lights);
                        if groups.iter().filter(|g| g.2 == object).count() < PER_PIXEL_SHADING_GROUPS {
                            groups.push((hit.id, side, object, r));
                        }
                        r
                    }
                }
            };
            sum += (throughput * radiance).as_dvec3();
        }
        (sum / self.spp as f64).as_vec3()
    }

    /// The nearest hit along one primary ray whose view depth lies in `[near, far]`, as the GPU's
    /// visibility keeps it, with stochastic coverage.
    #[cfg(test)]
    fn nearest_hit(&self, o: Vec3, d: Vec3, time: f32, pixel: (u32, u32), sample: u32) -> Option<Hit> {
        self.camera_hit(o, d, time, pixel, sample).0
    }

    /// The coverage of triangle `id`'s material at `hit`: alpha, times the texture's alpha at the
    /// hit's uv with `alpha_from_texture`.
    fn coverage(&self, id: u32, hit: &TriangleHit) -> f32 {
        let tri = &self.surface[id as usize];
        let m = &self.materials[tri.object as usize];
        match m.texture.filter(|_| m.alpha_from_texture) {
            Some(texture) => {
                let w = hit.barycentrics;
                let uv = w.x * tri.uv[0] + w.y * tri.uv[1] + w.z * tri.uv[2];
                m.alpha * texture.sample_alpha_bilinear(uv)
            }
            None => m.alpha,
        }
    }

    /// One camera ray (module docs, "Transparency"): the nearest surface in `[near, far]` it stops
    /// at, each surface stopping it with probability its coverage ([`crate::transparency::covered`]
    /// for sample `sample` of pixel `pixel`'s `spp`), and the product of the tints of the surfaces it
    /// passed through in front of that one (all of them for a miss).
    fn camera_hit(
        &self,
        o: Vec3,
        d: Vec3,
        time: f32,
        (x, y): (u32, u32),
        sample: u32,
    ) -> (Option<Hit>, Vec3) {
        let bvh = &self.bvhs[self.intervals.segment_of(time)];
        // Tinted surfaces passed through: (view depth, triangle). The filter is asked for every
        // surface nearer than the best hit so far, so those in front of the final hit are all here.
        let mut passed: Vec<(f32, u32)> = Vec::new();
        let hit = bvh.intersect_filtered(o, d, time, self.camera.near, self.camera.far, |id, h| {
            let m = &self.materials[self.surface[id as usize].object as usize];
            if m.one_sided && h.back {
                return false;
            }
            if m.is_opaque() {
                return true;
            }
            let alpha = self.coverage(id, h);
            let covered = alpha >= 1.0
                || crate::transparency::covered(self.coverage_seed, x, y, sample, id, alpha, self.spp);
            if !covered && m.tint != Vec3::ONE {
                passed.push((h.depth_z, id));
            }
            covered
        });
        let limit = hit.map_or(f32::INFINITY, |h| h.hit.depth_z);
        let throughput = passed
            .iter()
            .filter(|p| p.0 < limit)
            .fold(Vec3::ONE, |t, p| t * self.materials[self.surface[p.1 as usize].object as usize].tint);
        (hit, throughput)
    }

    /// The transmittance `Π (1 − α)·T` of the surfaces crossed at shutter time `time` by the shadow
    /// ray `o + s·d`, `0 < s < s_max` (module docs, "Shadows"); `offset` is the distance below which
    /// two hits of one object are one crossing.
    fn transmittance(&self, o: Vec3, d: Vec3, s_max: f32, time: f32, offset: f32) -> Vec3 {
        let bvh = &self.bvhs[self.intervals.segment_of(time)];
        let mut blocked = false;
        // Partially transmitting crossings: (object, ray parameter, transmittance).
        let mut crossings: Vec<(u32, f32, Vec3)> = Vec::new();
        bvh.for_each_hit(o, d, time, 0.0, s_max, |id, h, s| {
            let object = self.surface[id as usize].object;
            let m = &self.materials[object as usize];
            let alpha = if m.is_opaque() { 1.0 } else { self.coverage(id, h) };
            let t = (1.0 - alpha) * m.tint;
            if alpha >= 1.0 || t == Vec3::ZERO {
                blocked = true;
                return false;
            }
            if t != Vec3::ONE {
                crossings.push((object, s, t));
            }
            true
        });
        if blocked {
            return Vec3::ZERO;
        }
        crossings.sort_by(|a, b| a.0.cmp(&b.0).then(a.1.total_cmp(&b.1)));
        let same_crossing = offset / d.length();
        let mut v = Vec3::ONE;
        let mut last: Option<(u32, f32)> = None;
        for &(object, s, t) in &crossings {
            if !matches!(last, Some((lo, ls)) if lo == object && s - ls <= same_crossing) {
                v *= t;
            }
            last = Some((object, s));
        }
        v
    }

    /// Radiance towards the lens of a primary ray (direction `d`) at `hit` (`bounce`: as
    /// [`Tracer::shade_side`]).
    fn shade_hit(
        &self,
        hit: &Hit,
        d: Vec3,
        time: f32,
        bounce: Option<Vec2>,
        lights: &mut Vec<ShadingLight>,
    ) -> Vec3 {
        self.shade_side(hit, d, time, None, bounce, lights)
    }

    /// [`ReferenceShading::Decoupled`]: the radiance of the key of a primary ray (direction `d`, shutter
    /// time `time`) that hit `hit`.
    fn shade_decoupled(
        &self,
        hit: &Hit,
        d: Vec3,
        time: f32,
        bounce: Option<Vec2>,
        lights: &mut Vec<ShadingLight>,
        keys: &mut Vec<u64>,
    ) -> Vec3 {
        let ([(p0, _), (p1, _)], s) = self.segment_at(hit.id, 0.5);
        let mid = MovingTriangle { v0: p0, v1: p1 }.at(s);
        let grid = self.grids.get(hit.id as usize).unwrap_or(&crate::mirror::decoupled::PIXEL_GRID);
        let sp = crate::mirror::decoupled::shading_point(&self.intrinsics, &mid, hit.hit.barycentrics, grid);
        let Some(cell) = sp.cell else { return self.shade_hit(hit, d, time, bounce, lights) };
        keys.push(crate::mirror::decoupled::key(hit.id, hit.hit.back, cell));
        let w = sp.barycentrics;
        let point = w.x * mid[0] + w.y * mid[1] + w.z * mid[2];
        let at =
            Hit { id: hit.id, hit: TriangleHit { depth_z: -point.z, barycentrics: w, back: hit.hit.back } };
        // From the lens centre (the origin), on the side the sample saw.
        self.shade_side(&at, point.normalize(), 0.5, Some(hit.hit.back), bounce, lights)
    }

    /// Radiance towards the lens of a ray (direction `d`) at `hit` at shutter time `time`, on the side
    /// `back` says (`None`: the side `d` sees); with one-bounce indirect light, `bounce` is the
    /// sample's point of the unit square its bounce direction is drawn from.
    fn shade_side(
        &self,
        hit: &Hit,
        d: Vec3,
        time: f32,
        back: Option<bool>,
        bounce: Option<Vec2>,
        lights: &mut Vec<ShadingLight>,
    ) -> Vec3 {
        let x = self.surface_point(hit, d, time, back);
        self.shadowed_lights(&x, time, lights);
        let material = &self.materials[self.surface[hit.id as usize].object as usize];
        let direct = shade(
            x.position,
            x.normal,
            -d,
            x.albedo,
            material.specular,
            material.roughness,
            lights,
            self.ambient,
        );
        if let Some((vpls, clamp)) = &self.vpls {
            return direct + x.albedo * self.gather(&x, time, vpls, *clamp);
        }
        match bounce {
            Some(u) => direct + x.albedo * self.bounce_radiance(&x, time, u, lights),
            None => direct,
        }
    }

    /// The surface at `hit` of a ray with direction `d` at shutter time `time`, on the side `back` says
    /// (`None`: the side `d` sees).
    fn surface_point(&self, hit: &Hit, d: Vec3, time: f32, back: Option<bool>) -> SurfacePoint {
        let Hit { id, hit } = *hit;
        let tri = &self.surface[id as usize];
        let material = &self.materials[tri.object as usize];
        let w = hit.barycentrics.to_array();
        let ([(p0, n0), (p1, n1)], s) = self.segment_at(id, time);
        let p = MovingTriangle { v0: p0, v1: p1 }.at(s);
        let geometric = (p[1] - p[0]).cross(p[2] - p[0]);
        let mut n = Vec3::ZERO;
        for (i, &wi) in w.iter().enumerate() {
            n += wi * n0[i].lerp(n1[i], s);
        }
        let mut n = n.try_normalize().or_else(|| geometric.try_normalize()).unwrap_or(-d);
        if back.unwrap_or(geometric.dot(d) > 0.0) {
            n = -n;
        }
        let mut albedo = material.albedo;
        if let Some(texture) = material.texture {
            let uv = w[0] * tri.uv[0] + w[1] * tri.uv[1] + w[2] * tri.uv[2];
            albedo *= texture.sample_bilinear(uv);
        }
        // The barycentric point, as the GPU shades (its depth is exactly `hit.depth_z`).
        let position = hit.point(&p);
        let scale = p.iter().fold(position.abs().max_element(), |m, v| m.max(v.abs().max_element()));
        SurfacePoint {
            position,
            normal: n,
            geometric,
            offset: SHADOW_RAY_OFFSET * scale,
            lift: SHADOW_RAY_LIFT * scale,
            albedo,
        }
    }

    /// The lights at shutter time `time` as they reach `x` (module docs, "Shadows"), into `lights`.
    fn shadowed_lights(&self, x: &SurfacePoint, time: f32, lights: &mut Vec<ShadingLight>) {
        lights.clear();
        lights.extend(self.scene_space.lights.iter().map(|l| l.at(time)));
        for (light, _) in lights.iter_mut().zip(&self.shadows).filter(|(_, &shadows)| shadows) {
            let (l, e) = light.incident(x.position);
            if x.normal.dot(l) <= 0.0 || e == Vec3::ZERO {
                continue; // no light arrives to be shadowed
            }
            let g = x.geometric.normalize_or_zero();
            let (lift, offset) = (x.lift, x.offset);
            let origin = x.position + if g.dot(l) >= 0.0 { lift } else { -lift } * g;
            let v = match light.position() {
                Ok(at) => self.transmittance(origin, at - origin, 1.0, time, offset),
                Err(to_light) => self.transmittance(origin, to_light, f32::INFINITY, time, offset),
            };
            *light = light.attenuated(v);
        }
    }

    /// One-bounce indirect light (module docs, "Indirect light"): the diffuse radiance of the direct
    /// lights reflected by the surface seen from `x` in the cosine-distributed direction that `u`
    /// (a point of the unit square) picks around `x`'s normal, times the transmittance in between —
    /// one sample of `1/π ∫ L(y→x) cos θ dω`.
    fn bounce_radiance(&self, x: &SurfacePoint, time: f32, u: Vec2, lights: &mut Vec<ShadingLight>) -> Vec3 {
        let dir = cosine_direction(x.normal, u);
        // The side of the geometric surface the shading normal faces: a direction below it (where the
        // shading normal tilts away from the geometry) would leave through the surface itself.
        let (g, origin) = x.lit_side();
        if dir.dot(g) <= 0.0 {
            return Vec3::ZERO;
        }
        let bvh = &self.bvhs[self.intervals.segment_of(time)];
        // The nearest surface that stops light (coverage 1); those with less attenuate it.
        let Some((y_hit, s)) = bvh.nearest(origin, dir, time, 0.0, f32::INFINITY, |id, h| {
            let m = &self.materials[self.surface[id as usize].object as usize];
            m.is_opaque() || self.coverage(id, h) >= 1.0
        }) else {
            return Vec3::ZERO;
        };
        let through = self.transmittance(origin, dir, s, time, x.offset);
        if through == Vec3::ZERO {
            return Vec3::ZERO;
        }
        let y = self.surface_point(&y_hit, dir, time, None);
        self.shadowed_lights(&y, time, lights);
        let roughness = self.materials[self.surface[y_hit.id as usize].object as usize].roughness;
        // The diffuse term alone: no specular, no ambient.
        through * shade(y.position, y.normal, -dir, y.albedo, 0.0, roughness, lights, Vec3::ZERO)
    }
}

/// A shaded surface point: position, shading normal (facing the ray), geometric normal (unnormalised),
/// the offset that clears its own surface for a secondary ray, albedo.
struct SurfacePoint {
    position: Vec3,
    normal: Vec3,
    geometric: Vec3,
    /// [`SHADOW_RAY_OFFSET`] times the triangle's scale: secondary rays' origin offset and the
    /// shadow rays' same-crossing distance.
    offset: f32,
    /// [`SHADOW_RAY_LIFT`] times the triangle's scale: the direct shadow rays' origin offset.
    lift: f32,
    albedo: Vec3,
}

impl SurfacePoint {
    /// The unit geometric normal on the side the shading normal faces, and the point raised off the
    /// surface by the offset on that side: where a secondary ray leaving that side starts.
    fn lit_side(&self) -> (Vec3, Vec3) {
        let g = self.geometric.normalize_or_zero();
        let g = if g.dot(self.normal) >= 0.0 { g } else { -g };
        (g, self.position + self.offset * g)
    }
}

/// The direction with cosine-weighted density `cos θ / π` around the unit normal `n` for the point `u`
/// of the unit square (Malley's method: the concentric disk lifted to the hemisphere; the frame of Duff
/// et al. 2017).
pub fn cosine_direction(n: Vec3, u: Vec2) -> Vec3 {
    let p = crate::sampling::concentric_disk(u);
    let z = (1.0 - p.length_squared()).max(0.0).sqrt();
    let (t, b) = crate::sampling::orthonormal_frame(n);
    (p.x * t + p.y * b + z * n).normalize()
}

#[cfg(test)]
mod tests;
