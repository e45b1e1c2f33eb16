//! The visibility core of the stochastic frame: triangles → bounds (per triangle behind the geometry
//! shader or the compute-expanded hull, per interval run and key segment, or per cluster) → the 5D
//! inside test per sample → the visibility buffer, one 64-bit word per pixel and sample of a pass
//! (`visibility.glsl`); with tinted objects, the tint pass after it. No shading happens here: the
//! shading stages ([`super::shading`]) read what this leaves, through [`VisibilityHandles`].
//!
//! ```text
//! triangles          (compute, once per frame)
//! cluster bounds     (compute, clustered objects)
//! repeat P × {
//!   clear visibility   (transfer; the tint buffer too)
//!   stochastic coverage  (raster, no attachments)
//!   stochastic tint      (raster, no attachments; tinted objects)
//!   …shading…
//! }
//! ```

use ash::vk;
use gpu_allocator::MemoryLocation;

use super::super::compute_hull::{ComputeHull, HullExpansion, INITIAL_VERTICES_PER_TRIANGLE};
use super::super::{FrameContext, FrameInputs, PrepareContext};
use super::layout::{
    ClustersPush, TrianglesPush, VisibilityPush, TINT_BYTES, VISIBILITY_BUDGET_BYTES, VISIBILITY_BYTES,
};
use super::mask::{
    mask_sample_counts, mask_samples_per_pass, MaskHandles, MaskRate, MaskTarget, MASK_DEPTH_FORMAT,
    MASK_PAYLOAD_FORMAT,
};
use super::objects::{ObjectChoices, StochasticObject};
use super::options::{bounded_segments, gpu_samples, samples_per_pass, DebugOptions, StochasticOptions};
use super::{BOUND_DEBUG_STRIDE, COUNTERS};
use crate::error::{Error, Result};
use crate::gpu::layout::{vertex_input, FRAME_SET_INDEX, OBJECT_SET_INDEX, TECHNIQUE_SET_INDEX};
use crate::gpu::{GpuView, GpuWorld};
use crate::graph::{Access, BufferHandle, FrameGraph, Load, PassContext, ResourceHandle, Store, Tracked};
use crate::mirror::bounds::BoundKind;
use crate::mirror::conservative::{self, Dilation, Need};
use crate::plan::Effects;
use crate::sampling::ShutterCurve;
use crate::shaders::{
    self, axes, ClustersComp, MaskFrag, StochasticFrag, StochasticGeom, StochasticMesh, StochasticTask,
};
use crate::vk::{
    write_descriptors, Buffer, DescriptorPool, DescriptorSetLayout, DescriptorWrite, Faces, GraphicsDesc,
    Pipeline, PipelineLayout, ShaderModule,
};

/// How the frame's S samples per pixel are taken: P passes of M, the image size, the shutter curve
/// that warped their times, the bound dilation and the coverage seed.
pub(super) struct Sampling {
    pub spp: u32,
    pub per_pass: u32,
    pub passes: u32,
    pub size: (u32, u32),
    /// The camera's shutter curve: run k of K covers the warped times of `[k/K, (k+1)/K)`.
    pub shutter: ShutterCurve,
    /// Who dilates the bounds ([`crate::mirror::conservative::choose`]): the shader alone, by the box
    /// [`crate::mirror::bounds::dilation_px`] that reaches every rasterizer sample of a touched pixel,
    /// or the rasterizer's overestimation after a margin in the shader.
    pub dilation: Dilation,
    /// The box half-size the bound shaders dilate by (`dilation`'s shader part; push `dilate`).
    pub dilate: f32,
    /// [`crate::transparency::coverage_seed`] of the render seed.
    pub coverage_seed: u32,
}

impl Sampling {
    /// M and P for the view's size at the settings' S; `tinted`: a tint buffer shares the budget.
    pub fn new(ctx: &PrepareContext<'_>, options: &StochasticOptions, tinted: bool) -> Result<Self> {
        let caps = &ctx.device.caps;
        let (width, height) = ctx.camera.size();
        let max_bytes = VISIBILITY_BUDGET_BYTES.min(caps.max_storage_buffer_range as u64);
        let sample_bytes = VISIBILITY_BYTES + if tinted { TINT_BYTES } else { 0 };
        let pixels = width as u64 * height as u64;
        let spp = ctx.settings.spp;
        // The mask path: M = the multisampled target's samples, an MSAA count of the device.
        let (per_pass, passes) = match options.coverage.mask_rate() {
            None => samples_per_pass(spp, options.per_pass, pixels, sample_bytes, max_bytes)?,
            Some(_) => {
                let counts = mask_sample_counts(ctx.device);
                mask_samples_per_pass(spp, options.per_pass, &counts, pixels, sample_bytes, max_bytes)?
            }
        };
        // The rasterizer's samples per pixel: one at the centre, or the mask target's M — every one
        // of them must lie inside the bound of a pixel the bound touches (gl_SampleMask only clears).
        let raster_samples = if options.coverage.mask_rate().is_some() { per_pass } else { 1 };
        let need =
            Need::PixelsTouched { raster_samples, standard_sample_locations: caps.standard_sample_locations };
        let dilation = conservative::choose(need, caps.overestimation());
        Ok(Sampling {
            spp,
            per_pass,
            passes,
            size: (width, height),
            shutter: ctx.scene.camera.shutter,
            dilation,
            dilate: dilation.shader_box_px(),
            coverage_seed: crate::transparency::coverage_seed(ctx.settings.seed),
        })
    }

    /// Pixels × samples of a pass.
    pub fn pass_samples(&self) -> u64 {
        self.size.0 as u64 * self.size.1 as u64 * self.per_pass as u64
    }

    /// The frame's fields of the coverage push constants of pass `pass` (the whole pass' samples), no
    /// object's.
    pub fn push(&self, pass: u32) -> VisibilityPush {
        VisibilityPush {
            pass_index: pass,
            spp: self.spp,
            per_pass: self.per_pass,
            dilate: self.dilate,
            sample_count: self.per_pass,
            t1: 1.0,
            segment_count: 1,
            cluster_size: 1,
            alpha: 1.0,
            coverage_seed: self.coverage_seed,
            ..bytemuck::Zeroable::zeroed()
        }
    }
}

/// The descriptor set layouts every stochastic pipeline shares: set 2 per object, set 3 per frame.
pub(super) struct SetLayouts {
    pub object: DescriptorSetLayout,
    pub technique: DescriptorSetLayout,
}

impl SetLayouts {
    pub fn both(&self) -> [&DescriptorSetLayout; 2] {
        [&self.object, &self.technique]
    }
}

/// The graph handles the visibility core leaves for the shading stages.
#[derive(Clone)]
pub(super) struct VisibilityHandles {
    /// One 64-bit word per pixel and sample of a pass.
    pub visibility: BufferHandle,
    /// Σ −log₂ T per channel, pixel and sample of a pass (with tinted objects only).
    pub tints: Option<BufferHandle>,
    /// The drawn objects' camera-space triangles (the shading recomputes each hit from them).
    pub triangles: Vec<BufferHandle>,
    /// The counters (instrumented renders only).
    pub counters: Option<BufferHandle>,
    /// What the coverage and tint passes read besides the visibility and tint buffers.
    coverage_uses: Vec<(ResourceHandle, Access)>,
    /// The mask path's target (None on the visibility path).
    mask: Option<MaskHandles>,
    /// Read back after the frame.
    host_reads: Vec<BufferHandle>,
}

/// The visibility core: the per-object records, the coverage pipelines (one shader permutation per
/// effects path in use), the sample tile, the visibility and tint buffers, the counters.
///
/// Every object takes one path ([`Effects`]); [`Effects::Pinhole`] objects (from `auto`'s planner)
/// take the `still` permutation — bounded and tested at mid-shutter through the lens centre — so every
/// object of the frame meets the others in the same visibility buffer.
pub(super) struct Visibility {
    pub objects: Vec<StochasticObject>,
    pub sampling: Sampling,
    instrumented: bool,
    pipelines: Pipelines,
    /// Set 3 ([`super::STOCHASTIC_SET`]), shared with the shading stages.
    pub technique_set: vk::DescriptorSet,
    /// One 64-bit word per pixel and sample of a pass (`visibility.glsl`).
    visibility: Tracked<Buffer>,
    /// Σ −log₂ T per channel, pixel and sample of a pass (with tinted objects only).
    tints: Option<Tracked<Buffer>>,
    pub counters: Tracked<Buffer>,
    bound_debug: Option<Tracked<Buffer>>,
    /// The compute-expanded hull's buffers and pipelines ([`HullExpansion::Compute`]).
    hull: Option<ComputeHull>,
    /// The mask coverage path's target and resolve ([`super::Coverage::Mask`]).
    mask: Option<MaskTarget>,
    /// The mesh-shader hull ([`HullExpansion::Mesh`]): per object, its draws' workgroup grid (one
    /// workgroup per triangle, [`super::mesh_grid`]); empty on the other hulls.
    mesh_grids: Vec<(u32, u32)>,
    _samples: [Buffer; 2],
}

impl Visibility {
    /// The core for the objects `choices` on the effects `paths` in use: its pipelines, its buffers
    /// written into set 3 (`technique_set`, bindings 0–3, 5, 7) and each object's set 2, allocated
    /// from `pool`.
    #[allow(clippy::too_many_arguments)]
    pub fn new(
        ctx: &PrepareContext<'_>,
        options: &StochasticOptions,
        debug: &DebugOptions,
        sampling: Sampling,
        choices: Vec<ObjectChoices>,
        paths: &[Effects],
        layouts: &SetLayouts,
        pool: &DescriptorPool,
        technique_set: vk::DescriptorSet,
    ) -> Result<Self> {
        let (device, world) = (ctx.device, ctx.world);
        let compute = options.expansion == HullExpansion::Compute;
        let sets = layouts.both();
        let tinted = choices.iter().any(|c| c.tint_log.is_some());

        let pipelines = Pipelines::new(ctx, options, debug, paths, &choices, &sets, &sampling)?;

        let storage = vk::BufferUsageFlags::STORAGE_BUFFER;
        let (aperture, shutter) = (ctx.scene.camera.aperture, ctx.scene.camera.shutter);
        let (xy_lens, time) = gpu_samples(sampling.spp, ctx.settings.seed, aperture, shutter);
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
        let per_sample = |name: &str, bytes: u64| -> Result<Tracked<Buffer>> {
            Ok(Tracked::new(Buffer::new(
                device,
                name,
                sampling.pass_samples() * bytes,
                storage | vk::BufferUsageFlags::TRANSFER_DST,
                MemoryLocation::GpuOnly,
            )?))
        };
        let visibility = per_sample("stochastic visibility", VISIBILITY_BYTES)?;
        let tints = if tinted { Some(per_sample("stochastic tints", TINT_BYTES)?) } else { None };

        let mut writes = vec![
            DescriptorWrite::storage_buffer(0, &samples[0]),
            DescriptorWrite::storage_buffer(1, &samples[1]),
            DescriptorWrite::storage_buffer(2, &counters),
            DescriptorWrite::storage_buffer(5, &visibility),
        ];
        if let Some(b) = &bound_debug {
            writes.push(DescriptorWrite::storage_buffer(3, b));
        }
        if let Some(b) = &tints {
            writes.push(DescriptorWrite::storage_buffer(7, b));
        }
        write_descriptors(device, technique_set, &writes);
        let objects = choices
            .into_iter()
            .zip(&world.objects)
            .map(|(c, o)| StochasticObject::new(device, c, o, pool.allocate(&layouts.object)?))
            .collect::<Result<Vec<_>>>()?;
        let hull = if compute {
            let object_sets: Vec<vk::DescriptorSet> = objects.iter().map(|o| o.set).collect();
            Some(ComputeHull::new(
                device,
                world,
                paths,
                &sets,
                &object_sets,
                technique_set,
                debug.hull_vertices_per_triangle.unwrap_or(INITIAL_VERTICES_PER_TRIANGLE),
            )?)
        } else {
            None
        };
        let mask = match options.coverage.mask_rate() {
            Some(_) => {
                Some(MaskTarget::new(device, world, sampling.per_pass, sampling.size, &sets, technique_set)?)
            }
            None => None,
        };
        let mesh_grids = if options.expansion.is_mesh() {
            world
                .objects
                .iter()
                .map(|o| {
                    super::mesh_grid(o.triangle_count(), options.expansion, &device.caps).ok_or_else(|| {
                        Error::Unsupported("a mesh-shader grid past the device's limits".into())
                    })
                })
                .collect::<Result<Vec<_>>>()?
        } else {
            Vec::new()
        };
        Ok(Visibility {
            objects,
            sampling,
            mesh_grids,
            instrumented: options.instrumented,
            pipelines,
            technique_set,
            visibility,
            tints,
            counters,
            bound_debug,
            hull,
            mask,
            _samples: samples,
        })
    }

    /// Samples per pixel of the coverage pass' target: the mask path's M, or 1 (no target).
    pub fn msaa_samples(&self) -> u32 {
        self.mask.as_ref().map_or(1, |m| m.samples)
    }

    /// Whether any object has a triangle.
    pub fn any_drawn(&self) -> bool {
        self.objects.iter().any(StochasticObject::is_drawn)
    }

    /// The compute-expanded hull's buffer capacity and this frame's vertex count per object (None
    /// behind the geometry shader).
    pub fn hull_usage(&self) -> Option<(Vec<u32>, Vec<u32>)> {
        let counts = self.objects.iter().map(|o| o.hull_count).collect();
        self.hull.as_ref().map(|h| (h.capacity().to_vec(), counts))
    }

    /// The geometry shader's debug output of the last frame: per triangle of the first object,
    /// `BOUND_DEBUG_STRIDE` floats (empty without [`DebugOptions::bound_debug_triangles`]).
    pub fn bound_debug(&self) -> Result<Vec<f32>> {
        let Some(b) = &self.bound_debug else { return Ok(vec![]) };
        Ok(b.mapped()?.chunks_exact(4).map(|c| f32::from_ne_bytes([c[0], c[1], c[2], c[3]])).collect())
    }

    /// Work before the frame's graph: the counters reset and, with the compute-expanded hull, the
    /// triangles and the expansion in a graph of their own, their counts read back; an overflowed
    /// buffer grows and the expansion runs again, so no bound is ever dropped.
    pub fn before_frame(&mut self, inputs: &FrameInputs<'_>, frame: &mut FrameContext<'_>) -> Result<()> {
        self.counters.get_mut().write(&[0u32; COUNTERS])?;
        if self.hull.is_none() {
            return Ok(());
        }
        loop {
            self.hull.as_mut().expect("checked").reset_counts()?;
            {
                let this = &*self;
                let hull = this.hull.as_ref().expect("checked");
                let mut g = frame.graph();
                this.add_triangles_pass(&mut g, inputs);
                hull.add_expand_pass(&mut g, inputs, &this.objects, this.technique_set, this.sampling.dilate);
                frame.run(g)?;
            }
            let device = frame.device().clone();
            let object_sets: Vec<vk::DescriptorSet> = self.objects.iter().map(|o| o.set).collect();
            let hull = self.hull.as_mut().expect("checked");
            if !hull.grow_overflowed(&device, inputs.world, &object_sets)? {
                for (o, count) in self.objects.iter_mut().zip(hull.counts()?) {
                    o.hull_count = count;
                }
                return Ok(());
            }
        }
    }

    /// The passes before the frame's repeat (the triangles and cluster bounds, unless the hull's own
    /// graph made them) and the handles of everything the per-pass work reads.
    pub fn add_frame_passes<'a>(
        &'a self,
        g: &mut FrameGraph<'a>,
        inputs: &FrameInputs<'a>,
    ) -> VisibilityHandles {
        if self.hull.is_none() {
            self.add_triangles_pass(g, inputs);
        }
        let mut coverage_uses: Vec<(ResourceHandle, Access)> = Vec::new();
        let mut triangles = Vec::new();
        for o in self.objects.iter().filter(|o| o.is_drawn()) {
            let h = g.import_buffer("camera-space triangles", &o.triangles);
            coverage_uses.push((h.into(), Access::FragmentShaderReadOther));
            triangles.push(h);
        }
        for o in self.objects.iter().filter(|o| o.is_drawn()) {
            if let Some(c) = &o.cluster_bounds {
                let h: ResourceHandle = g.import_buffer("cluster bounds", c).into();
                coverage_uses.push((h, Access::VertexShaderReadOther));
                coverage_uses.push((h, Access::FragmentShaderReadOther));
            }
        }
        if let Some(hull) = &self.hull {
            for (o, [vertices, sources]) in self.objects.iter().zip(hull.buffers()) {
                if o.is_drawn() {
                    for (name, b) in [("hull", vertices), ("hull triangles", sources)] {
                        let h: ResourceHandle = g.import_buffer(name, b).into();
                        coverage_uses.push((h, Access::VertexShaderReadOther));
                    }
                }
            }
        }
        let mut host_reads = Vec::new();
        let mut counters = None;
        if self.instrumented {
            let h = g.import_buffer("stochastic counters", &self.counters);
            // Atomics read and write.
            for access in [Access::FragmentShaderReadOther, Access::FragmentShaderWrite] {
                coverage_uses.push((h.into(), access));
            }
            host_reads.push(h);
            counters = Some(h);
        }
        if let Some(b) = &self.bound_debug {
            let h = g.import_buffer("bound debug", b);
            coverage_uses.push((h.into(), Access::GeometryShaderWrite));
            host_reads.push(h);
        }
        VisibilityHandles {
            mask: self.mask.as_ref().map(|m| m.import(g)),
            visibility: g.import_buffer("stochastic visibility", &self.visibility),
            tints: self.tints.as_ref().map(|t| g.import_buffer("stochastic tints", t)),
            triangles,
            counters,
            coverage_uses,
            host_reads,
        }
    }

    /// One pass' visibility (inside the frame's repeat; `ctx.iteration` is the pass): the buffers
    /// cleared, the coverage draws, then the tint draws.
    pub fn add_pass<'a>(&'a self, g: &mut FrameGraph<'a>, h: &VisibilityHandles, inputs: &FrameInputs<'a>) {
        let (visibility, tints, inputs) = (h.visibility, h.tints, *inputs);
        let (w, hgt) = self.sampling.size;
        // The mask path's resolve writes every word of the visibility buffer: only the tints to clear.
        let cleared: Vec<BufferHandle> =
            [(h.mask.is_none()).then_some(visibility), tints].into_iter().flatten().collect();
        if !cleared.is_empty() {
            let mut clear = g.pass("clear visibility");
            for &b in &cleared {
                clear = clear.overwrite(b, Access::TransferWrite);
            }
            clear.record(move |ctx| {
                for &b in &cleared {
                    ctx.fill_buffer(b, 0);
                }
                Ok(())
            });
        }
        match (&self.mask, h.mask) {
            (Some(mask), Some(target)) => {
                // Payload cleared to 0, depth to 1.0 (nothing); the hardware keeps the nearest hit.
                g.pass("stochastic mask coverage")
                    .color(target.payload, Load::Clear([0.0; 4]), Store::Store)
                    .depth(target.depth, Load::Clear(1.0), Store::Store)
                    .accesses(h.coverage_uses.iter().copied())
                    .record(move |ctx| {
                        self.record_coverage(ctx, &inputs, ctx.iteration);
                        Ok(())
                    });
                mask.add_resolve_pass(g, target, visibility, self.technique_set);
            }
            _ => {
                g.pass("stochastic coverage")
                    .render_area(w, hgt)
                    .access(visibility, Access::FragmentShaderReadOther)
                    .access(visibility, Access::FragmentShaderWrite)
                    .accesses(h.coverage_uses.iter().copied())
                    .record(move |ctx| {
                        self.record_coverage(ctx, &inputs, ctx.iteration);
                        self.record_cluster_coverage(ctx, &inputs, ctx.iteration);
                        Ok(())
                    });
            }
        }
        if let Some(t) = tints {
            // The finished visibility buffer says what each sample sees; the tinted objects multiply
            // their tint into the samples they pass in front of it.
            g.pass("stochastic tint")
                .render_area(w, hgt)
                .access(visibility, Access::FragmentShaderReadOther)
                .access(t, Access::FragmentShaderReadOther)
                .access(t, Access::FragmentShaderWrite)
                .accesses(h.coverage_uses.iter().copied())
                .record(move |ctx| {
                    self.record_tints(ctx, &inputs, ctx.iteration);
                    Ok(())
                });
        }
    }

    /// After the frame's repeat: the host reads of the counters and the bound debug output.
    pub fn add_host_reads(&self, g: &mut FrameGraph<'_>, h: &VisibilityHandles) {
        for &b in &h.host_reads {
            g.host_read(b);
        }
    }

    /// The camera-space triangles of every object, once per frame (they do not depend on the pass): a
    /// compute pass per view (thesis §9.6: the fragment stage reads one record per fragment instead of
    /// transforming three vertices twice); then the cluster bounds from them.
    fn add_triangles_pass<'a>(&'a self, g: &mut FrameGraph<'a>, inputs: &FrameInputs<'a>) {
        let drawn: Vec<usize> = (0..self.objects.len()).filter(|&i| self.objects[i].is_drawn()).collect();
        let handles: Vec<_> = drawn
            .iter()
            .map(|&i| g.import_buffer("camera-space triangles", &self.objects[i].triangles))
            .collect();
        let mut pass = g.pass("triangles");
        for h in handles {
            pass = pass.overwrite(h, Access::ComputeShaderWrite);
        }
        let (world, view) = (inputs.world, inputs.camera);
        let clustered: Vec<usize> =
            drawn.iter().copied().filter(|&i| self.objects[i].choices.clusters > 0).collect();
        pass.record(move |ctx| {
            self.record_triangles(ctx, world, view, &drawn);
            Ok(())
        });
        if clustered.is_empty() {
            return;
        }
        let handles: Vec<_> = clustered
            .iter()
            .map(|&i| {
                let o = &self.objects[i];
                let t = g.import_buffer("camera-space triangles", &o.triangles);
                let c = g.import_buffer("cluster bounds", o.cluster_bounds.as_ref().expect("clustered"));
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

    fn record_triangles(&self, ctx: &PassContext<'_>, world: &GpuWorld, view: &GpuView, objects: &[usize]) {
        let bind = vk::PipelineBindPoint::COMPUTE;
        let layout = &self.pipelines.triangles_layout;
        ctx.bind_pipeline(&self.pipelines.triangles);
        ctx.bind_sets(bind, layout, FRAME_SET_INDEX, &[view.frame_set]);
        for &i in objects {
            let o = &world.objects[i];
            let sets = [o.set, self.objects[i].set];
            ctx.bind_sets(bind, layout, OBJECT_SET_INDEX, &sets);
            let (segment_first, segments) = view.segments(i);
            let push =
                TrianglesPush { segment_first, keys: segments + 1, triangle_count: o.triangle_count() };
            ctx.push(layout, &push);
            ctx.dispatch(o.triangle_count().div_ceil(64), 1, 1);
        }
    }

    /// `clusters.comp` for each clustered object (`objects`) and key segment (the segment holding
    /// mid-shutter for an object that does not move).
    fn record_clusters(&self, ctx: &PassContext<'_>, world: &GpuWorld, view: &GpuView, objects: &[usize]) {
        let bind = vk::PipelineBindPoint::COMPUTE;
        let layout = &self.pipelines.clusters_layout;
        ctx.bind_sets(bind, layout, FRAME_SET_INDEX, &[view.frame_set]);
        for (effects, pipeline) in &self.pipelines.clusters {
            ctx.bind_pipeline(pipeline);
            for &i in objects.iter().filter(|&&i| self.objects[i].choices.effects == *effects) {
                let (o, so) = (&world.objects[i], &self.objects[i]);
                let sets = [o.set, so.set];
                ctx.bind_sets(bind, layout, OBJECT_SET_INDEX, &sets);
                let keys = &so.choices.keys;
                let (first, count, t0, t1) = bounded_segments(keys, effects.motion());
                let n = so.choices.clusters;
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
                    ctx.push(layout, &push);
                    ctx.dispatch(o.triangle_count().div_ceil(n).div_ceil(64), 1, 1);
                }
            }
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
    ) -> Option<VisibilityPush> {
        let s = &self.sampling;
        let count = s.per_pass / runs;
        let first = run * count;
        let o = &self.objects[object];
        let base =
            VisibilityPush { sample_first: first, sample_count: count, ..o.push(object, view, s.push(pass)) };
        let keys = &o.choices.keys;
        if !o.choices.effects.motion() {
            if seg != 0 {
                return None;
            }
            let (segment, _, t0, t1) = bounded_segments(keys, false);
            return Some(VisibilityPush { t0, t1, segment, ..base });
        }
        // The run's samples' shutter times: [ξ0, ξ1) of the unwarped time, through the shutter curve
        // (monotone, the very function that warped the samples; it maps 0 to 0 and 1 to 1 exactly, so
        // a whole-shutter draw gets (0, 1), which emit.glsl bounds from the end vertices themselves).
        let xi = |i: u32| (pass * s.per_pass + i) as f32 / s.spp as f32;
        let (t0, t1) = (s.shutter.warp(xi(first)), s.shutter.warp(xi(first + count)));
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
        Some(VisibilityPush { t0: s0, t1: s1, segment: seg as u32, ..base })
    }

    /// The coverage draws of pass `pass`, inside the attachment-less rendering.
    fn record_coverage(&self, ctx: &mut PassContext<'_>, inputs: &FrameInputs<'_>, pass: u32) {
        let bind = vk::PipelineBindPoint::GRAPHICS;
        let world = inputs.world;
        for (effects, pipeline) in &self.pipelines.coverage {
            self.bind_raster(ctx, pipeline);
            let include = |i: usize| {
                self.objects[i].choices.effects == *effects && self.objects[i].choices.clusters == 0
            };
            let view = inputs.camera;
            if !self.mesh_grids.is_empty() {
                self.record_mesh_runs(ctx, inputs, pass, include);
                continue;
            }
            if self.hull.is_none() {
                self.record_runs(ctx, inputs, pipeline, pass, include, |p| p);
                continue;
            }
            // The compute-expanded hull bounds every segment (fragments name theirs); NO_MOTION: the
            // segment holding mid-shutter and its local time.
            let push = |i: usize| self.coverage_push(view, i, pass, 0, 1, 0).expect("segment 0 always draws");
            // Compute-expanded hull: each object's triangle list, no vertex input.
            ctx.bind_sets(bind, &self.pipelines.layout, FRAME_SET_INDEX, &[inputs.camera.frame_set]);
            for (i, o) in world.objects.iter().enumerate() {
                if !include(i) || self.objects[i].hull_count == 0 {
                    continue;
                }
                ctx.push(&self.pipelines.layout, &push(i));
                let sets = [o.set, self.objects[i].set];
                ctx.bind_sets(bind, &self.pipelines.layout, OBJECT_SET_INDEX, &sets);
                ctx.draw(self.objects[i].hull_count, 1);
            }
        }
    }

    /// The tint draws of pass `pass` (module docs of `stochastic.frag`, TINT_PASS): every tinted
    /// object's coverage draws again behind the geometry shader's convex hull — one convex piece, so
    /// the rasterizer's fill rule runs the fragment stage once per pixel and triangle, and each
    /// uncovered sample adds the tint once — per run and key segment as the coverage draws.
    fn record_tints(&self, ctx: &mut PassContext<'_>, inputs: &FrameInputs<'_>, pass: u32) {
        let hull = BoundKind::ConvexHull.id();
        for (effects, pipeline) in &self.pipelines.tint {
            self.bind_raster(ctx, pipeline);
            let include = |i: usize| {
                self.objects[i].choices.effects == *effects && self.objects[i].choices.tint_log.is_some()
            };
            self.record_runs(ctx, inputs, pipeline, pass, include, |p| VisibilityPush { bound: hull, ..p });
        }
    }

    /// Binds a raster pipeline of the frame and its set 3.
    fn bind_raster(&self, ctx: &PassContext<'_>, pipeline: &Pipeline) {
        let bind = vk::PipelineBindPoint::GRAPHICS;
        ctx.bind_pipeline(pipeline);
        ctx.bind_sets(bind, &self.pipelines.layout, TECHNIQUE_SET_INDEX, &[self.technique_set]);
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
        edit: impl Fn(VisibilityPush) -> VisibilityPush,
    ) {
        let (world, view) = (inputs.world, inputs.camera);
        let max_runs = self.objects.iter().map(|o| o.choices.intervals).max().unwrap_or(1);
        let max_segments = self.objects.iter().map(|o| o.choices.keys.segments()).max().unwrap_or(1);
        for run in 0..max_runs {
            for seg in 0..max_segments {
                let piece = |i: usize| {
                    self.coverage_push(view, i, pass, run, self.objects[i].choices.intervals, seg).map(&edit)
                };
                world.record_object_draws(
                    ctx,
                    view,
                    pipeline,
                    &self.pipelines.layout,
                    |i| include(i) && run < self.objects[i].choices.intervals && piece(i).is_some(),
                    |i| piece(i).expect("included"),
                    |i| Some(self.objects[i].set),
                );
            }
        }
    }

    /// The mesh-shader draws of pass `pass` of the objects `include` admits, the coverage pipeline
    /// bound: the geometry-shader draws' runs, segments and push constants ([`Self::record_runs`]),
    /// each one workgroup per triangle instead of an indexed draw.
    fn record_mesh_runs(
        &self,
        ctx: &mut PassContext<'_>,
        inputs: &FrameInputs<'_>,
        pass: u32,
        include: impl Fn(usize) -> bool,
    ) {
        let bind = vk::PipelineBindPoint::GRAPHICS;
        let (world, view) = (inputs.world, inputs.camera);
        let layout = &self.pipelines.layout;
        ctx.bind_sets(bind, layout, FRAME_SET_INDEX, &[view.frame_set]);
        let max_runs = self.objects.iter().map(|o| o.choices.intervals).max().unwrap_or(1);
        let max_segments = self.objects.iter().map(|o| o.choices.keys.segments()).max().unwrap_or(1);
        for run in 0..max_runs {
            for seg in 0..max_segments {
                for (i, o) in world.objects.iter().enumerate() {
                    let so = &self.objects[i];
                    if o.index_count == 0 || !include(i) || run >= so.choices.intervals {
                        continue;
                    }
                    let Some(push) = self.coverage_push(view, i, pass, run, so.choices.intervals, seg) else {
                        continue;
                    };
                    ctx.push(layout, &push);
                    ctx.bind_sets(bind, layout, OBJECT_SET_INDEX, &[o.set, so.set]);
                    let (x, y) = self.mesh_grids[i];
                    ctx.draw_mesh_tasks(x, y, 1);
                }
            }
        }
    }

    /// The coverage draws of the clustered objects in pass `pass`: per object and key segment (the
    /// one holding mid-shutter for an object that does not move), six vertices per cluster.
    fn record_cluster_coverage(&self, ctx: &mut PassContext<'_>, inputs: &FrameInputs<'_>, pass: u32) {
        let bind = vk::PipelineBindPoint::GRAPHICS;
        let (world, view) = (inputs.world, inputs.camera);
        for (effects, pipeline) in &self.pipelines.cluster_coverage {
            self.bind_raster(ctx, pipeline);
            ctx.bind_sets(bind, &self.pipelines.layout, FRAME_SET_INDEX, &[view.frame_set]);
            for (i, (o, so)) in world.objects.iter().zip(&self.objects).enumerate() {
                let n = so.choices.clusters;
                if n == 0 || so.choices.effects != *effects || !so.is_drawn() {
                    continue;
                }
                let sets = [o.set, so.set];
                let clusters = o.triangle_count().div_ceil(n);
                for seg in 0..so.choices.keys.segments() {
                    let Some(push) = self.coverage_push(view, i, pass, 0, 1, seg) else { continue };
                    ctx.push(&self.pipelines.layout, &push);
                    ctx.bind_sets(bind, &self.pipelines.layout, OBJECT_SET_INDEX, &sets);
                    ctx.draw(6 * clusters, 1);
                }
            }
        }
    }
}

/// The visibility core's pipelines: camera-space triangles, cluster bounds, and the coverage and tint
/// draws (one shader permutation per effects path in use), with their layouts.
struct Pipelines {
    coverage: Vec<(Effects, Pipeline)>,
    /// The tint pass' pipelines (geometry-shader hull), per path with a tinted object.
    tint: Vec<(Effects, Pipeline)>,
    /// Coverage pipelines behind the cluster bounds, and the `clusters.comp` pipelines, per path.
    cluster_coverage: Vec<(Effects, Pipeline)>,
    clusters: Vec<(Effects, Pipeline)>,
    clusters_layout: PipelineLayout,
    triangles: Pipeline,
    triangles_layout: PipelineLayout,
    /// The raster pipelines' layout (its push range carries the push stages).
    layout: PipelineLayout,
    _shaders: Vec<ShaderModule>,
}

impl Pipelines {
    fn new(
        ctx: &PrepareContext<'_>,
        options: &StochasticOptions,
        debug: &DebugOptions,
        paths: &[Effects],
        choices: &[ObjectChoices],
        sets: &[&DescriptorSetLayout],
        sampling: &Sampling,
    ) -> Result<Self> {
        // The mask target's samples (M), and whether every bound draw overestimates.
        let (mask_samples, overestimate) = (sampling.per_pass, sampling.dilation.overestimate());
        let (device, world) = (ctx.device, ctx.world);
        let caps = &device.caps;
        let compute = options.expansion == HullExpansion::Compute;
        let uses = |effects: Effects, f: &dyn Fn(&ObjectChoices) -> bool| {
            choices.iter().any(|c| c.effects == effects && f(c))
        };
        let comp = ShaderModule::new(device, shaders::STOCHASTIC_TRIANGLES_COMP)?;
        let triangles_layout = world.pipeline_layout(
            device,
            sets,
            std::mem::size_of::<TrianglesPush>() as u32,
            vk::ShaderStageFlags::COMPUTE,
        )?;
        let triangles_pipeline =
            Pipeline::compute(device, "camera-space triangles", &triangles_layout, &comp)?;
        // The geometry stage is named only where the device has one.
        let mut push_stages = vk::ShaderStageFlags::VERTEX | vk::ShaderStageFlags::FRAGMENT;
        if caps.geometry_shader {
            push_stages |= vk::ShaderStageFlags::GEOMETRY;
        }
        let mesh = options.expansion.is_mesh();
        if mesh {
            push_stages |= vk::ShaderStageFlags::MESH_EXT;
        }
        if options.expansion == HullExpansion::MeshTask {
            push_stages |= vk::ShaderStageFlags::TASK_EXT;
        }
        let layout =
            world.pipeline_layout(device, sets, std::mem::size_of::<VisibilityPush>() as u32, push_stages)?;
        let (bindings, attributes) = vertex_input();
        let vert = ShaderModule::new(device, shaders::STOCHASTIC_STOCHASTIC_VERT)?;
        let hull_vert = ShaderModule::new(device, shaders::STOCHASTIC_HULL_VERT)?;
        let mut shader_modules = vec![];
        let mut pipelines = Vec::with_capacity(paths.len());
        let mut tint_pipelines = Vec::new();
        // Attachment-less (the visibility path, the tint pass) or into the mask target.
        let raster_into =
            |name: &str, stages: &[&ShaderModule], vertex_input: bool, mask: Option<MaskRate>| {
                let (samples, sample_shading) = match mask {
                    None => (1, None),
                    Some(MaskRate::Sample) => (mask_samples, Some(1.0)),
                    Some(MaskRate::Fragment) => (mask_samples, None),
                };
                Pipeline::graphics(
                    device,
                    &layout,
                    &GraphicsDesc {
                        name,
                        stages,
                        vertex_bindings: if vertex_input { &bindings } else { &[] },
                        vertex_attributes: if vertex_input { &attributes[..1] } else { &[] },
                        color_formats: if mask.is_some() { &[MASK_PAYLOAD_FORMAT] } else { &[] },
                        depth_format: mask.map(|_| MASK_DEPTH_FORMAT),
                        samples,
                        sample_shading,
                        faces: Faces::Both,
                        depth_compare: if mask.is_some() {
                            vk::CompareOp::LESS_OR_EQUAL
                        } else {
                            vk::CompareOp::ALWAYS
                        },
                        depth_write: mask.is_some(),
                        overestimate,
                    },
                )
            };
        let raster = |name: &str, stages: &[&ShaderModule], vertex_input: bool| {
            raster_into(name, stages, vertex_input, None)
        };
        let mask = options.coverage.mask_rate();
        for &effects in paths {
            if uses(effects, &|c| c.tint_log.is_some()) {
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
            let frag = match mask {
                None => StochasticFrag {
                    hull: options.expansion.axis(),
                    instrumented: options.instrumented,
                    effects: effects.shader_axis(),
                    transparency_pass: axes::TransparencyPass::Coverage,
                }
                .source(),
                Some(rate) => MaskFrag {
                    mask_hull: if compute { axes::MaskHull::Compute } else { axes::MaskHull::GeometryShader },
                    mask_rate: match rate {
                        MaskRate::Sample => axes::MaskRate::Sample,
                        MaskRate::Fragment => axes::MaskRate::Fragment,
                    },
                    instrumented: options.instrumented,
                    effects: effects.shader_axis(),
                }
                .source(),
            };
            let frag = ShaderModule::new(device, frag)?;
            // The stages before the fragment shader: the compute hull's plain vertex shader, the mesh
            // shader (the whole geometry front end, no vertex input; behind the culling task shader
            // for mesh-task), or vertex + geometry shader.
            let task_cull = options.expansion == HullExpansion::MeshTask;
            let mut front = Vec::new();
            match options.expansion {
                HullExpansion::Compute => {}
                HullExpansion::Mesh | HullExpansion::MeshTask => {
                    if task_cull {
                        let task = StochasticTask { effects: effects.shader_axis() };
                        front.push(ShaderModule::new(device, task.source())?);
                    }
                    let mesh = StochasticMesh { effects: effects.shader_axis(), task_cull };
                    front.push(ShaderModule::new(device, mesh.source())?);
                }
                HullExpansion::GeometryShader => {
                    let geom = StochasticGeom {
                        bound_debug: debug.bound_debug_triangles > 0,
                        effects: effects.shader_axis(),
                    };
                    front.push(ShaderModule::new(device, geom.source())?);
                }
            };
            let stages: Vec<&ShaderModule> = match options.expansion {
                HullExpansion::Compute => vec![&hull_vert, &frag],
                HullExpansion::GeometryShader => [&vert].into_iter().chain(&front).chain([&frag]).collect(),
                HullExpansion::Mesh | HullExpansion::MeshTask => front.iter().chain([&frag]).collect(),
            };
            let name = format!(
                "stochastic {} coverage ({}, {} hull)",
                options.coverage.name(),
                effects.name(),
                options.expansion.name()
            );
            pipelines.push((effects, raster_into(&name, &stages, !compute && !mesh, mask)?));
            shader_modules.extend(front);
            shader_modules.push(frag);
        }
        // Cluster bounds: a coverage pipeline behind cluster.vert and a clusters.comp pipeline for each
        // path with a clustered object.
        let clusters_layout = world.pipeline_layout(
            device,
            sets,
            std::mem::size_of::<ClustersPush>() as u32,
            vk::ShaderStageFlags::COMPUTE,
        )?;
        let mut cluster_pipelines = Vec::new();
        let mut clusters_pipelines = Vec::new();
        let cluster_vert = ShaderModule::new(device, shaders::STOCHASTIC_CLUSTER_VERT)?;
        for &effects in paths {
            if !uses(effects, &|c| c.clusters > 0) {
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
            cluster_pipelines.push((effects, raster(&name, &[&cluster_vert, &frag], false)?));
            shader_modules.push(frag);
            let comp = ShaderModule::new(device, ClustersComp { effects: effects.shader_axis() }.source())?;
            let name = format!("cluster bounds ({})", effects.name());
            clusters_pipelines.push((effects, Pipeline::compute(device, &name, &clusters_layout, &comp)?));
            shader_modules.push(comp);
        }
        shader_modules.extend([vert, hull_vert, comp, cluster_vert]);
        Ok(Pipelines {
            coverage: pipelines,
            tint: tint_pipelines,
            cluster_coverage: cluster_pipelines,
            clusters: clusters_pipelines,
            clusters_layout,
            triangles: triangles_pipeline,
            triangles_layout,
            layout,
            _shaders: shader_modules,
        })
    }
}
