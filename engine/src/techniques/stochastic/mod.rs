//! Technique `stochastic`: stochastic rasterization of motion blur and depth of field on the conventional
//! pipeline (McGuire, Enderton, Shirley & Luebke, HPG 2010; Toth & Linder 2008).
//!
//! **Visibility first, shading second.** S samples per pixel are split into P passes of M = S / P
//! samples ([`samples_per_pass`]; one pass unless the visibility buffer would be too large). In every
//! pass each triangle goes through a geometry shader that replaces it by a conservative screen-space
//! bound of everywhere it can land over the lens and the shutter (`bounds`, selectable per draw,
//! mirrored on the CPU in [`crate::mirror::bounds`]), dilated by half a pixel; for every pixel the bound
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
//! The (x, y, u, v, t) samples are those of the CPU reference ([`SampleTile`](crate::sampling::SampleTile): 64×64 pixels × S
//! stratified samples, aperture shape and shutter curve applied here, never in the shaders), so at
//! equal S and seed the two estimate the pixel integral with the very same samples.
//! Shaders: `shaders-glsl/stochastic/`.

mod layout;
mod mask;
mod objects;
mod options;
mod shading;
mod visibility;

pub use layout::*;
pub use mask::{
    mask_sample_counts, mask_samples_per_pass, Coverage, MaskRate, MaskResolvePush, MASK_DEPTH_FORMAT,
    MASK_DEPTH_SCALE, MASK_PAYLOAD_FORMAT,
};
pub(crate) use objects::StochasticObject;
pub use options::*;
pub use shading::{
    DecoupledMemory, CACHE_ENTRY_BYTES, DEFAULT_CACHE_ENTRIES, DEFERRED_ARGS_OFFSET,
    DEFERRED_QUEUE_HEADER_BYTES, DEFERRED_REF_BYTES, MAX_CACHE_ENTRIES, MSAA_GBUFFER_BYTES_PER_SAMPLE,
};

use ash::vk;

use super::compute_hull::HullExpansion;
use super::multipass::accumulation_image;
use super::shadow_maps::ShadowMaps;
use super::{
    FrameContext, FrameInputs, FrameTechnique, PrepareContext, TechniqueCapabilities, TechniqueFrame,
    TechniqueInfo,
};
use crate::error::{Error, Result};
use crate::graph::Tracked;
use crate::image::LinearImage;
use crate::mirror::bounds::BoundKind;
use crate::plan::{Effects, Plan};
use crate::vk::{write_descriptors, DescriptorPool, DescriptorSetLayout, DescriptorWrite, Feature, Image};
use objects::ObjectChoices;
use shading::ShadingPass;
use visibility::{Sampling, SetLayouts, Visibility};

/// The registry entry.
pub const INFO: TechniqueInfo = TechniqueInfo {
    name: "stochastic",
    summary: "stochastic rasterization, visibility first: a conservative bound per triangle, the 5D inside \
              test per sample into a visibility buffer, then shading (McGuire et al. 2010; Toth & Linder 2008)",
    keys: &[KEYS, super::shadow_maps::KEYS],
    // Per coverage path: `Coverage::resolve` (the visibility buffer's atomics, or the mask path's).
    required_features: &[],
    capabilities: TechniqueCapabilities { transparency: true, transparency_methods: false, embeddable: true },
    prepare,
};

fn prepare(ctx: &PrepareContext<'_>) -> Result<Box<dyn FrameTechnique>> {
    let effects = vec![Effects::Both; ctx.scene.objects.len()];
    Ok(Box::new(StochasticTechnique::new(ctx, ctx.settings.stochastic, DebugOptions::default(), &effects)?))
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
    /// [`crate::mirror::decoupled::DEFERRED_PROBES`] of the hash table's (shaded on the spot).
    pub overflows: u64,
    /// The deferred mode's memory (None for the memoization cache).
    pub memory: Option<DecoupledMemory>,
}

impl CacheCounters {
    pub fn misses(&self) -> u64 {
        self.lookups - self.hits
    }
}

/// u32 counters of the counters buffer (`Counters` in `stochastic.frag` and `shade.glsl`).
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

/// The stochastic path of a set of objects, as its data flows: the visibility core (`Visibility` in
/// `visibility.rs`: per-object records, coverage pipelines, visibility buffer) feeds the shading pass
/// (`ShadingPass` in `shading/mod.rs`: one `ShadingStage` per shading rate), which adds into the
/// accumulation image.
pub struct StochasticDraws {
    visibility: Visibility,
    shading: ShadingPass,
    /// Σ (radiance, 1) / S over every sample of the frame.
    accum: Tracked<Image>,
    options: StochasticOptions,
    _pool: DescriptorPool,
    /// Last: the pipelines' layouts above name them.
    _set_layouts: SetLayouts,
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
        let (paths, coverage) = check(ctx, &options, &debug, object_effects)?;
        // The mask path draws one bound per triangle (a mask fragment names one triangle).
        let clusters = if coverage.mask_rate().is_some() { Clusters::Off } else { options.clusters };
        let options = StochasticOptions { coverage, clusters, ..options };
        // Tinted objects (coverage below 1 and a tint): a tint pass per frame pass behind the geometry
        // shader's one-piece convex hull (every sample tested once per triangle), and a tint buffer.
        let tinted = ObjectChoices::tint_logs(ctx).iter().any(Option::is_some);
        if tinted {
            device.caps.require(
                Feature::GeometryShader,
                "tints in technique `stochastic` (the tint pass draws behind the geometry-shader hull)",
            )?;
        }
        let sampling = Sampling::new(ctx, &options, tinted)?;
        let choices =
            ObjectChoices::for_world(ctx, &options, &debug, plan, object_effects, sampling.per_pass)?;
        let shadows = shading::shadow_maps(ctx)?;
        let stage = shading::stage(ctx, &options, sampling.pass_samples(), shadows.as_ref())?;

        let all = crate::gpu::scene_stages(&device.caps);
        let object_table = stage.object_bindings();
        let technique_table = if coverage.mask_rate().is_some() {
            &STOCHASTIC_SET[..]
        } else {
            &STOCHASTIC_SET[..STOCHASTIC_BINDINGS_WITHOUT_MASK]
        };
        let layouts = SetLayouts {
            object: DescriptorSetLayout::from_table(
                device,
                "stochastic object set layout",
                object_table,
                all,
            )?,
            technique: DescriptorSetLayout::from_table(
                device,
                "stochastic set layout",
                technique_table,
                all,
            )?,
        };
        let shading = ShadingPass::new(ctx, &options, stage, shadows, &layouts, &paths, tinted)?;
        let accum = Tracked::new(accumulation_image(device, "stochastic accumulation", sampling.size)?);

        let n_objects = world.objects.len() as u32;
        let pool = DescriptorPool::for_tables(
            device,
            n_objects + 1,
            &[(object_table, n_objects), (technique_table, 1)],
        )?;
        let technique_set = pool.allocate(&layouts.technique)?;
        write_descriptors(
            device,
            technique_set,
            &[DescriptorWrite::StorageImage { binding: 6, view: accum.view }],
        );
        let visibility = Visibility::new(
            ctx,
            &options,
            &debug,
            sampling,
            choices,
            &paths,
            &layouts,
            &pool,
            technique_set,
        )?;
        let object_sets: Vec<vk::DescriptorSet> = visibility.objects.iter().map(|o| o.set).collect();
        shading.stage.write_sets(device, technique_set, &object_sets);
        Ok(StochasticDraws { visibility, shading, accum, options, _pool: pool, _set_layouts: layouts })
    }

    /// Samples per pixel and pass, and passes.
    pub fn samples_per_pass(&self) -> (u32, u32) {
        (self.visibility.sampling.per_pass, self.visibility.sampling.passes)
    }

    /// The counters of the last frame (instrumented renders only).
    pub fn counters(&self) -> Result<Option<SampleCounters>> {
        if !self.options.instrumented {
            return Ok(None);
        }
        let raw = self.visibility.counters.read_u32s(COUNTERS)?;
        let stage = &self.shading.stage;
        Ok(Some(SampleCounters {
            samples_tested: raw[0] as u64,
            samples_hit: raw[1] as u64,
            shading_invocations: raw[2] as u64,
            fragments: raw[3] as u64,
            atlas_texels: stage.atlas_texels()?,
            cache: stage.cache_counters(&raw, self.visibility.sampling.pass_samples()),
        }))
    }

    /// The deferred mode's memory (None with the other rates).
    pub fn decoupled_memory(&self) -> Option<DecoupledMemory> {
        self.shading.stage.decoupled_memory(self.visibility.sampling.pass_samples())
    }

    /// The compute-expanded hull's buffer capacity and this frame's vertex count per object (None
    /// behind the geometry shader).
    pub fn hull_usage(&self) -> Option<(Vec<u32>, Vec<u32>)> {
        self.visibility.hull_usage()
    }

    /// The geometry shader's debug output of the last frame: per triangle of the first object,
    /// `BOUND_DEBUG_STRIDE` floats (empty without [`DebugOptions::bound_debug_triangles`]).
    pub fn bound_debug(&self) -> Result<Vec<f32>> {
        self.visibility.bound_debug()
    }

    /// The bound kind each object draws.
    pub fn bounds(&self) -> Vec<BoundKind> {
        self.visibility.objects.iter().map(|o| o.choices.bound).collect()
    }

    /// Interval count of each object (1: bounded over the whole shutter).
    pub fn object_intervals(&self) -> Vec<u32> {
        self.visibility.objects.iter().map(|o| o.choices.intervals).collect()
    }

    /// Work before the frame's graph: counters reset, the compute-expanded hull's own graph.
    fn before_frame(&mut self, inputs: &FrameInputs<'_>, frame: &mut FrameContext<'_>) -> Result<()> {
        self.shading.stage.before_frame()?;
        self.visibility.before_frame(inputs, frame)
    }

    /// The frame as a graph, visibility first, shading second:
    /// `triangles` → (`cluster bounds`) → (shadow maps, atlases, cache clear) → `clear accumulation` →
    /// repeat P × { `clear visibility` → `stochastic coverage` → (`stochastic tint`) →
    /// `stochastic shading` } → readback ([`FrameContext::finish`]: or the copy into an embedding
    /// caller's image).
    fn render<'a>(&'a self, frame: &mut FrameContext<'_>, inputs: &FrameInputs<'a>) -> Result<LinearImage> {
        let mut g = frame.graph();
        let accum = g.import_image("stochastic accumulation", &self.accum);
        if !self.visibility.any_drawn() {
            // Nothing to draw (no object, or none with a triangle): every sample sees the background.
            // The shading pass cannot add it here: its background dispatch binds a drawn object's
            // sets (the pipeline's layout needs some), and there is none — and no permutation exists
            // without objects. The image is the background, as the reference's.
            g.clear_color("background (nothing drawn)", accum, inputs.world.background);
            return frame.finish(g, accum);
        }
        let (visibility, shading) = (&self.visibility, &self.shading);
        let seen = visibility.add_frame_passes(&mut g, inputs);
        let shading_uses = shading.add_frame_passes(&mut g, inputs, &seen);
        g.clear_color("clear accumulation", accum, [0.0; 4]);
        g.repeat(visibility.sampling.passes, |g| {
            visibility.add_pass(g, &seen, inputs);
            shading.add_pass(g, visibility, &seen, &shading_uses, accum, inputs);
            Ok(())
        })?;
        visibility.add_host_reads(&mut g, &seen);
        frame.finish(g, accum)
    }

    /// This frame's result.
    fn technique_frame(&self, image: LinearImage) -> Result<TechniqueFrame> {
        Ok(TechniqueFrame {
            image,
            passes: self.visibility.sampling.passes,
            msaa_samples: self.visibility.msaa_samples(),
            counters: self.counters()?,
            clusters: self.visibility.objects.iter().map(|o| o.choices.clusters).collect(),
        })
    }
}

/// Triangles per task workgroup of `--hull mesh-task` (`TASK_CLUSTER` in
/// `shaders-glsl/stochastic/task_payload.glsl`).
pub(super) const TASK_CLUSTER: u32 = 32;

/// The mesh-shader hull's workgroup grid for `triangles` triangles: for [`HullExpansion::Mesh`] one
/// mesh workgroup each, (x, y) with x · y ≥ triangles, x within `maxMeshWorkGroupCount[0]`, y within
/// `[1]`, x · y within `maxMeshWorkGroupTotalCount`; for [`HullExpansion::MeshTask`] one task
/// workgroup per [`TASK_CLUSTER`] triangles within the task limits (each launches at most
/// [`TASK_CLUSTER`] mesh workgroups in x). `None` where no grid fits.
pub(super) fn mesh_grid(
    triangles: u32,
    hull: HullExpansion,
    caps: &crate::vk::Capabilities,
) -> Option<(u32, u32)> {
    if hull == HullExpansion::MeshTask {
        let fits = caps.max_mesh_work_group_count[0] >= TASK_CLUSTER
            && caps.max_mesh_work_group_total_count >= TASK_CLUSTER;
        let grid = grid_within(
            triangles.div_ceil(TASK_CLUSTER),
            caps.max_task_work_group_count,
            caps.max_task_work_group_total_count,
        );
        return grid.filter(|_| fits);
    }
    grid_within(triangles, caps.max_mesh_work_group_count, caps.max_mesh_work_group_total_count)
}

/// [`mesh_grid`] for the limits `max` (per dimension) and `total`: as few rows as `max[0]` allows,
/// and rows as short as those rows allow, so that fewer than `y` workgroups lie past the last
/// triangle (each is launched and emits nothing: on lavapipe a dispatch apiece).
fn grid_within(triangles: u32, max: [u32; 3], total: u32) -> Option<(u32, u32)> {
    let [max_x, max_y, _] = max;
    if triangles == 0 {
        return Some((0, 1));
    }
    if max_x == 0 {
        return None;
    }
    let y = triangles.div_ceil(max_x);
    let x = triangles.div_ceil(y);
    (y <= max_y && u64::from(x) * u64::from(y) <= u64::from(total)).then_some((x, y))
}

/// The checks before anything is built; the effects paths in use and the coverage path taken.
fn check(
    ctx: &PrepareContext<'_>,
    options: &StochasticOptions,
    debug: &DebugOptions,
    object_effects: &[Effects],
) -> Result<(Vec<Effects>, Coverage)> {
    let (world, caps, spp) = (ctx.world, &ctx.device.caps, ctx.settings.spp);
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
    match options.expansion {
        HullExpansion::GeometryShader => caps.require(
            Feature::GeometryShader,
            "technique `stochastic` with the geometry-shader hull (--hull compute needs none)",
        )?,
        HullExpansion::Mesh | HullExpansion::MeshTask => {
            caps.require(
                Feature::MeshShader,
                "technique `stochastic` with the mesh-shader hull (--hull gs and --hull compute do not)",
            )?;
            let task = options.expansion == HullExpansion::MeshTask;
            if task {
                caps.require(
                    Feature::TaskShader,
                    "technique `stochastic` with --hull mesh-task (--hull mesh needs no task shader)",
                )?;
            }
            // One workgroup per triangle (or per cluster of them behind the task shader): every
            // object's triangles must fit one draw's grid.
            let largest = world.objects.iter().map(|o| o.triangle_count()).max().unwrap_or(0);
            if mesh_grid(largest, options.expansion, caps).is_none() {
                let limit = if task {
                    format!(
                        "{} task workgroups of {TASK_CLUSTER} triangles (the device's \
                         maxTaskWorkGroupTotalCount; --hull gs or compute has no such limit)",
                        caps.max_task_work_group_total_count
                    )
                } else {
                    format!(
                        "{} (the device's maxMeshWorkGroupTotalCount: one workgroup per triangle; \
                         --hull gs or compute has no such limit)",
                        caps.max_mesh_work_group_total_count
                    )
                };
                return Err(Error::Limit {
                    what: "triangles of one object with the mesh-shader hull",
                    value: largest.to_string(),
                    limit,
                });
            }
        }
        HullExpansion::Compute => {}
    }
    let (coverage, _) = options.coverage.resolve_for(caps, matches!(options.clusters, Clusters::Fixed(_)))?;
    if coverage.mask_rate().is_some() {
        let path = format!("the `{}` coverage path", coverage.name());
        if let Clusters::Fixed(_) = options.clusters {
            return Err(Error::Unsupported(format!(
                "cluster bounds on {path}: a mask fragment names one triangle (clusters=off or auto)"
            )));
        }
        if options.instrumented {
            caps.require(Feature::FragmentStoresAndAtomics, &format!("the sample counters of {path}"))?;
        }
        if ObjectChoices::tint_logs(ctx).iter().any(Option::is_some) {
            caps.require(
                Feature::FragmentStoresAndAtomics,
                &format!("tints on {path} (the tint pass' atomics)"),
            )?;
        }
        if options.shading.decoupled_grid().is_some() {
            caps.require(
                Feature::BufferInt64Atomics,
                &format!("`--shading {}` (its cache's 64-bit keys) on {path}", options.shading.name()),
            )?;
        }
    }
    if options.expansion != HullExpansion::GeometryShader && debug.bound_debug_triangles > 0 {
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
    Ok((paths, coverage))
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
        let objects = &self.draws.visibility.objects;
        objects
            .iter()
            .any(|o| o.choices.alpha < 1.0 || o.choices.texture_alpha)
            .then_some(crate::transparency::TransparencyMethod::Stochastic)
    }

    fn shadows(&self) -> Option<String> {
        self.draws.shading.shadows.as_ref().map(ShadowMaps::summary)
    }

    fn coverage(&self) -> Option<Coverage> {
        Some(self.draws.options.coverage)
    }
}

#[cfg(test)]
mod mesh_grid_tests {
    use super::grid_within;

    /// The grid covers every triangle, one workgroup each, within every limit; past the total, none.
    #[test]
    fn the_mesh_grid_covers_every_triangle_within_the_limits() {
        // The spec's minimums: 65,535 per dimension, 2²² in all.
        let (max, total) = ([65_535, 65_535, 65_535], 1 << 22);
        assert_eq!(grid_within(0, max, total), Some((0, 1)));
        assert_eq!(grid_within(1, max, total), Some((1, 1)));
        assert_eq!(grid_within(65_535, max, total), Some((65_535, 1)));
        assert_eq!(grid_within(65_536, max, total), Some((32_768, 2)));
        // Spot subdivided twice (`arena`): two rows of 46,848, not two of 65,535.
        assert_eq!(grid_within(93_696, max, total), Some((46_848, 2)));
        for n in [7u32, 65_534, 65_536, 93_697, 327_680, 1_000_003, 4_000_000] {
            let (x, y) = grid_within(n, max, total).unwrap();
            assert!(u64::from(x) * u64::from(y) >= u64::from(n) && x <= max[0] && y <= max[1], "{n}");
            // No row wasted, and fewer workgroups than rows past the last triangle.
            assert!(u64::from(x) * u64::from(y - 1) < u64::from(n), "{n}");
            assert!(u64::from(x) * u64::from(y) - u64::from(n) < u64::from(y), "{n}");
        }
        assert_eq!(grid_within(1 << 23, max, total), None);
        assert_eq!(grid_within(5, [0, 0, 0], 0), None);
    }
}
