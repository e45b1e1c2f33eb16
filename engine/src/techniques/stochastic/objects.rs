//! One record per object of the stochastic frame: what the planner and the options chose for it
//! (effects path, bound, intervals, clusters, shading rectangle, transparency) and its GPU side (set 2,
//! camera-space triangles, cluster bounds). The visibility core owns them; the shading stages read them.

use ash::vk;
use gpu_allocator::MemoryLocation;

use super::super::compute_hull::HullExpansion;
use super::super::PrepareContext;
use super::layout::{VisibilityPush, CLUSTER_BYTES, MAX_FRAME_TRIANGLES, TRIANGLE_KEY_BYTES};
use super::options::{
    auto_clusters, auto_intervals, choose_cluster_order, shading_rect, Clusters, DebugOptions, Intervals,
    StochasticOptions, DEFAULT_CLUSTER_TRIANGLES,
};
use crate::error::{Error, Result};
use crate::geometry::KeyTimes;
use crate::gpu::{GpuObject, GpuView};
use crate::graph::Tracked;
use crate::mirror::bounds::BoundKind;
use crate::plan::{Effects, Plan};
use crate::vk::{write_descriptors, Buffer, DescriptorWrite, Device};

/// What the options chose for one object, before any GPU resource exists.
pub(crate) struct ObjectChoices {
    pub effects: Effects,
    /// The bound kind it draws ([`super::BoundChoice::resolve`]).
    pub bound: BoundKind,
    /// Interval bounds per pass ([`Intervals`]; 1 on the still and defocus-only paths).
    pub intervals: u32,
    /// Triangles per cluster of its cluster bounds (0: one bound per triangle; [`Clusters`]), and
    /// its triangles in cluster order when clustered.
    pub clusters: u32,
    pub cluster_order: Option<Vec<u32>>,
    /// Its first triangle in the frame's numbering (the visibility payload), and its count.
    pub triangle_base: u32,
    pub triangle_count: u32,
    /// Its motion key times (its segments are drawn and bounded one by one).
    pub keys: KeyTimes,
    /// Pixels (x, y, width, height) its shading dispatch covers ([`shading_rect`]).
    pub shade_rect: [u32; 4],
    /// Coverage α (stochastic transparency; 1 for opaque objects), from the texture's alpha too (with a
    /// texture and uvs, as the reference), and whether its material is one-sided (no sample sees its
    /// back).
    pub alpha: f32,
    pub texture_alpha: bool,
    pub one_sided: bool,
    /// Its tint as [`crate::transparency::tint_log`] (None: not tinted).
    pub tint_log: Option<[u32; 3]>,
}

impl ObjectChoices {
    /// Every object's tint (None: not tinted), known before the samples per pass (tints take memory).
    pub fn tint_logs(ctx: &PrepareContext<'_>) -> Vec<Option<[u32; 3]>> {
        super::super::forward::transparent_objects(ctx.scene)
            .iter()
            .map(|o| o.tinted.then(|| crate::transparency::tint_log([o.tint[0], o.tint[1], o.tint[2]])))
            .collect()
    }

    /// The choices for every object of the world: `object_effects` its paths, `plan` (of the camera
    /// view) its motion, blur and screen box, `per_pass` the samples per pixel and pass.
    pub fn for_world(
        ctx: &PrepareContext<'_>,
        options: &StochasticOptions,
        debug: &DebugOptions,
        plan: &Plan,
        object_effects: &[Effects],
        per_pass: u32,
    ) -> Result<Vec<ObjectChoices>> {
        let world = ctx.world;
        let (width, height) = ctx.camera.size();
        let compute = options.expansion == HullExpansion::Compute;
        let intrinsics = ctx.scene.camera.intrinsics(width, height);
        let transparent = super::super::forward::transparent_objects(ctx.scene);
        let tint_logs = Self::tint_logs(ctx);
        let mut objects = Vec::with_capacity(world.objects.len());
        // Object i's triangles are numbered from its base on in the visibility payloads.
        let mut total: u64 = 0;
        for (i, (o, g)) in plan.objects.iter().zip(&world.objects).enumerate() {
            let triangle_base = total as u32;
            total += g.triangle_count() as u64;
            if total >= MAX_FRAME_TRIANGLES {
                return Err(Error::Limit {
                    what: "triangles",
                    value: format!("more than {MAX_FRAME_TRIANGLES}"),
                    limit: format!("below {MAX_FRAME_TRIANGLES} in one frame of technique `stochastic`"),
                });
            }
            // Cluster bounds: with the geometry-shader path (the compute hull and the bound debug
            // output are per triangle); the order and mean cluster area measured where clusters may
            // be drawn.
            let mut cluster_order = None;
            let clusters = if compute || debug.bound_debug_triangles > 0 || g.triangle_count() == 0 {
                0
            } else {
                let mut order = |n: u32| {
                    let mesh = &ctx.scene.objects[i].mesh;
                    let mv = ctx.camera.space.objects[i].model_view[0];
                    let (order, area) = choose_cluster_order(mesh, mv, &intrinsics, n as usize);
                    cluster_order = Some(order);
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
            };
            let cluster_order = if clusters > 0 { cluster_order } else { None };
            // Interval bounds need the geometry shader (the compute hull expands once per frame) and a
            // moving object; the bound debug output compares whole-shutter bounds; clusters are
            // bounded over whole key segments. Unbounded motion (a vertex at or behind the near plane
            // at some end): the clipped box of such triangles does not shrink with the interval; one
            // bound.
            let effects = object_effects[i];
            let moving = o.max_motion_px > 0.0 && o.max_motion_px.is_finite() && !o.crosses_near;
            let intervals =
                if compute || debug.bound_debug_triangles > 0 || !effects.motion() || !moving || clusters > 0
                {
                    1
                } else {
                    match options.intervals {
                        Intervals::Auto => auto_intervals(o.max_motion_px, o.max_coc_px, per_pass),
                        Intervals::Fixed(k) => k.min(per_pass),
                    }
                };
            let material = &ctx.scene.objects[i].material;
            objects.push(ObjectChoices {
                effects,
                bound: options.bound.resolve(&ctx.device.caps, o.max_coc_px),
                intervals,
                clusters,
                cluster_order,
                triangle_base,
                triangle_count: g.triangle_count(),
                keys: ctx.camera.space.objects[i].keys.clone(),
                shade_rect: shading_rect(o.screen_box, (width, height)),
                alpha: material.alpha,
                texture_alpha: transparent[i].alpha_from_texture,
                one_sided: material.one_sided,
                tint_log: tint_logs[i],
            });
        }
        Ok(objects)
    }
}

/// One object of the stochastic frame: its choices and its GPU side.
pub(crate) struct StochasticObject {
    /// What the options chose for it (its `cluster_order` moved into `_cluster_order`'s buffer).
    pub choices: ObjectChoices,
    /// Set 2 ([`super::STOCHASTIC_OBJECT_SET`]).
    pub set: vk::DescriptorSet,
    /// The camera view's triangles at every motion key (`triangles.comp`).
    pub triangles: Tracked<Buffer>,
    /// Its cluster bounds when clustered (`clusters.comp`: per key segment and cluster), and the
    /// cluster order they read.
    pub cluster_bounds: Option<Tracked<Buffer>>,
    _cluster_order: Option<Buffer>,
    /// Vertices of its expanded hull this frame (compute expansion).
    pub hull_count: u32,
}

impl StochasticObject {
    /// The object's buffers, written into its set 2 (`set`): the triangles (binding 0) and, clustered,
    /// the cluster bounds and order (3 and 4).
    pub fn new(
        device: &Device,
        mut c: ObjectChoices,
        gpu: &GpuObject,
        set: vk::DescriptorSet,
    ) -> Result<Self> {
        let storage = vk::BufferUsageFlags::STORAGE_BUFFER;
        let keys = c.keys.times().len() as u64;
        let bytes = (gpu.index_count as u64 / 3).max(1) * keys * TRIANGLE_KEY_BYTES;
        let name = &gpu.name;
        let triangles = Buffer::new(
            device,
            &format!("camera-space triangles:{name}"),
            bytes,
            storage,
            MemoryLocation::GpuOnly,
        )?;
        write_descriptors(device, set, &[DescriptorWrite::storage_buffer(0, &triangles)]);
        let (cluster_bounds, cluster_order) = match c.cluster_order.take().filter(|_| c.clusters > 0) {
            Some(order) => {
                let per_segment = (c.triangle_count as u64).div_ceil(c.clusters as u64);
                let bounds = Buffer::new(
                    device,
                    &format!("cluster bounds:{name}"),
                    per_segment * (keys - 1) * CLUSTER_BYTES,
                    storage,
                    MemoryLocation::GpuOnly,
                )?;
                let order = Buffer::with_data(device, &format!("cluster order:{name}"), storage, &order)?;
                write_descriptors(
                    device,
                    set,
                    &[
                        DescriptorWrite::storage_buffer(3, &bounds),
                        DescriptorWrite::storage_buffer(4, &order),
                    ],
                );
                (Some(Tracked::new(bounds)), Some(order))
            }
            None => (None, None),
        };
        Ok(StochasticObject {
            choices: c,
            set,
            triangles: Tracked::new(triangles),
            cluster_bounds,
            _cluster_order: cluster_order,
            hull_count: 0,
        })
    }

    /// Whether it has anything to draw.
    pub fn is_drawn(&self) -> bool {
        self.choices.triangle_count > 0
    }

    /// Object `index`'s fields of the coverage push constants (`visibility_push.glsl`) over `push`'s
    /// frame fields.
    pub fn push(&self, index: usize, view: &GpuView, push: VisibilityPush) -> VisibilityPush {
        let (segment_first, segment_count) = view.segments(index);
        let tint = self.choices.tint_log.unwrap_or([0; 3]);
        VisibilityPush {
            bound: self.choices.bound.id(),
            triangle_base: self.choices.triangle_base,
            triangle_count: self.choices.triangle_count,
            segment_first,
            segment_count,
            cluster_size: self.choices.clusters.max(1),
            alpha: self.choices.alpha,
            alpha_from_texture: self.choices.texture_alpha as u32,
            tint_log_r: tint[0],
            tint_log_g: tint[1],
            tint_log_b: tint[2],
            one_sided: self.choices.one_sided as u32,
            ..push
        }
    }
}
