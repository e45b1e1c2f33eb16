//! Adaptive texture-space shading (Andersson et al. 2014; docs/ATSS.md), on the GPU — so far the
//! first of its pieces: the per-triangle shading rate (`shaders-glsl/texture_space/rate.glsl`, the
//! port of [`crate::texture_space::rate`]), run by [`ShadingRates`] over every triangle of every object
//! at mid-shutter and read back, so that tests compare it with the CPU mirror. Pass 1 of the
//! technique will compute the same in its geometry shader. Not in the registry: it renders no image
//! (its frame is black).

use ash::vk;
use bytemuck::{Pod, Zeroable};
use glam::Vec2;

use super::{FrameContext, FrameInputs, FrameTechnique, PrepareContext, TechniqueFrame};
use crate::error::Result;
use crate::gpu::layout::{shared_struct, Binding, SharedStruct, OBJECT_SET_INDEX, TECHNIQUE_SET_INDEX};
use crate::graph::{Access, Tracked};
use crate::image::LinearImage;
use crate::shaders;
use crate::texture_space::atlas::{shading_space_of, triangle_charts, ShadingSpace};
use crate::vk::{
    write_descriptors, Buffer, DescriptorPool, DescriptorSetLayout, DescriptorWrite, Pipeline,
    PipelineLayout, ShaderModule,
};

/// Set 3 of `levels.comp`.
pub const LEVELS_SET: [Binding; 2] = [
    Binding { binding: 0, ty: vk::DescriptorType::STORAGE_BUFFER, block: "ShadingCoords" },
    Binding { binding: 1, ty: vk::DescriptorType::STORAGE_BUFFER, block: "Levels" },
];

/// Push constants of `levels.comp`.
#[repr(C)]
#[derive(Clone, Copy, Debug, Pod, Zeroable)]
pub struct LevelsPush {
    pub triangle_count: u32,
    /// The object's key segment holding mid-shutter (its `ObjectViews` index) and the time within it.
    pub segment: u32,
    pub segment_time: f32,
    /// Levels of the object's atlas.
    pub level_count: u32,
}

/// For the reflection test.
pub const TEXTURE_SPACE_STRUCTS: &[SharedStruct] =
    &[shared_struct!("Push", LevelsPush, [triangle_count, segment, segment_time, level_count])];

/// One triangle's shading rate as the GPU computed it.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct GpuLevel {
    /// Smallest footprint minor radius over the vertices, texels of level 0.
    pub radius_texels: f32,
    pub spacing_px: f32,
    pub level: u32,
    /// Whether any vertex had a footprint.
    pub valid: bool,
}

/// Per object: its shading space, the per-corner shading coordinates (texels of level 0) and the
/// buffers `levels.comp` reads and writes.
struct ObjectRates {
    space: ShadingSpace,
    coords: Vec<Vec2>,
    set: vk::DescriptorSet,
    _coords: Buffer,
    levels: Tracked<Buffer>,
}

/// Runs `levels.comp` over every object with triangles (module docs).
pub struct ShadingRates {
    finest: u32,
    objects: Vec<Option<ObjectRates>>,
    pipeline: Pipeline,
    layout: PipelineLayout,
    /// Per object (None: no triangles): the last frame's levels.
    pub results: Vec<Option<Vec<GpuLevel>>>,
    size: (u32, u32),
    _set_layout: DescriptorSetLayout,
    _pool: DescriptorPool,
    _shader: ShaderModule,
}

impl ShadingRates {
    /// For every object of the scene, an atlas of `finest²` texels at level 0 (a power of two).
    pub fn new(ctx: &PrepareContext<'_>, finest: u32) -> Result<Self> {
        let (device, world) = (ctx.device, ctx.world);
        crate::texture_space::atlas::MipAtlas::new(finest, 0)?;
        let stages = vk::ShaderStageFlags::COMPUTE;
        let set_layout =
            DescriptorSetLayout::from_table(device, "shading rate set layout", &LEVELS_SET, stages)?;
        let layout = world.pipeline_layout(
            device,
            &[&world.empty_layout, &set_layout],
            std::mem::size_of::<LevelsPush>() as u32,
            stages,
        )?;
        let shader = ShaderModule::new(device, shaders::TEXTURE_SPACE_LEVELS_COMP)?;
        let pipeline = Pipeline::compute(device, "texture-space shading rates", &layout, &shader)?;
        let n = ctx.scene.objects.len() as u32;
        let pool = DescriptorPool::for_tables(device, n.max(1), &[(&LEVELS_SET, n.max(1))])?;
        let storage = vk::BufferUsageFlags::STORAGE_BUFFER;
        let mut objects = Vec::with_capacity(ctx.scene.objects.len());
        for o in &ctx.scene.objects {
            let triangles = o.mesh.indices.len() / 3;
            if triangles == 0 {
                objects.push(None);
                continue;
            }
            let space = shading_space_of(&o.mesh);
            let unit: Vec<Vec2> = match space {
                ShadingSpace::OwnUvs { .. } => {
                    o.mesh.indices.iter().map(|&i| space.to_unit(o.mesh.uvs[i as usize])).collect()
                }
                ShadingSpace::Charts(_) => triangle_charts(&o.mesh, finest, 2)?.uvs,
            };
            let coords: Vec<Vec2> = unit.iter().map(|&t| t * finest as f32).collect();
            let flat: Vec<[f32; 2]> = coords.iter().map(|c| c.to_array()).collect();
            let coords_buffer =
                Buffer::with_data(device, &format!("shading coords:{}", o.name), storage, &flat)?;
            let levels_buffer = Tracked::new(Buffer::with_data(
                device,
                &format!("shading rates:{}", o.name),
                storage,
                &vec![[0f32; 4]; triangles],
            )?);
            let set = pool.allocate(&set_layout)?;
            write_descriptors(
                device,
                set,
                &[
                    DescriptorWrite::storage_buffer(0, &coords_buffer),
                    DescriptorWrite::storage_buffer(1, &levels_buffer),
                ],
            );
            objects.push(Some(ObjectRates {
                space,
                coords,
                set,
                _coords: coords_buffer,
                levels: levels_buffer,
            }));
        }
        Ok(ShadingRates {
            finest,
            objects,
            pipeline,
            layout,
            results: vec![],
            size: ctx.camera.size(),
            _set_layout: set_layout,
            _pool: pool,
            _shader: shader,
        })
    }

    /// Object `i`'s shading space and per-corner shading coordinates (texels of level 0), as the GPU
    /// got them; None for an object without triangles.
    pub fn object(&self, i: usize) -> Option<(ShadingSpace, &[Vec2])> {
        self.objects[i].as_ref().map(|o| (o.space, o.coords.as_slice()))
    }

    /// Levels of the objects' atlases.
    pub fn levels(&self) -> u32 {
        self.finest.trailing_zeros() + 1
    }
}

impl FrameTechnique for ShadingRates {
    fn render(&mut self, inputs: &FrameInputs<'_>, frame: &mut FrameContext<'_>) -> Result<TechniqueFrame> {
        let this = &*self;
        let (world, view) = (inputs.world, inputs.camera);
        let mut g = frame.graph();
        let mut handles = vec![];
        for (i, o) in this.objects.iter().enumerate() {
            if let Some(o) = o {
                handles.push((i, g.import_buffer("shading rates", &o.levels)));
            }
        }
        let mut pass = g.pass("texture-space shading rates");
        for &(_, h) in &handles {
            pass = pass.overwrite(h, Access::ComputeShaderWrite);
        }
        let level_count = this.levels();
        pass.record(move |ctx| {
            let (d, cmd, bind) = (ctx.device, ctx.cmd, vk::PipelineBindPoint::COMPUTE);
            let layout = this.layout.raw;
            unsafe {
                d.raw.cmd_bind_pipeline(cmd, bind, this.pipeline.raw);
                d.raw.cmd_bind_descriptor_sets(cmd, bind, layout, 0, &[view.frame_set], &[]);
                for (i, o) in this.objects.iter().enumerate() {
                    let Some(o) = o else { continue };
                    let object = &world.objects[i];
                    d.raw.cmd_bind_descriptor_sets(cmd, bind, layout, OBJECT_SET_INDEX, &[object.set], &[]);
                    d.raw.cmd_bind_descriptor_sets(cmd, bind, layout, TECHNIQUE_SET_INDEX, &[o.set], &[]);
                    let (segment, segment_time) = view.segment_at(i, 0.5);
                    let push = LevelsPush {
                        triangle_count: object.triangle_count(),
                        segment,
                        segment_time,
                        level_count,
                    };
                    d.raw.cmd_push_constants(
                        cmd,
                        layout,
                        vk::ShaderStageFlags::COMPUTE,
                        0,
                        bytemuck::bytes_of(&push),
                    );
                    d.raw.cmd_dispatch(cmd, object.triangle_count().div_ceil(64), 1, 1);
                }
            }
            Ok(())
        });
        for &(_, h) in &handles {
            g.host_read(h);
        }
        frame.run(g)?;
        let mut results = vec![None; this.objects.len()];
        for (i, o) in this.objects.iter().enumerate() {
            let Some(o) = o else { continue };
            let raw = o.levels.mapped()?;
            let floats: Vec<f32> =
                raw.chunks_exact(4).map(|c| f32::from_ne_bytes([c[0], c[1], c[2], c[3]])).collect();
            results[i] = Some(
                floats
                    .chunks_exact(4)
                    .map(|v| GpuLevel {
                        radius_texels: v[0],
                        spacing_px: v[1],
                        level: v[2] as u32,
                        valid: v[3] > 0.5,
                    })
                    .collect(),
            );
        }
        self.results = results;
        let (w, h) = self.size;
        Ok(TechniqueFrame {
            image: LinearImage::new(w, h),
            passes: 1,
            msaa_samples: 1,
            counters: None,
            clusters: vec![],
        })
    }
}

/// What `texture_space/levels.comp` expects of its layout.
pub const SHADER_INTERFACES: &[crate::gpu::layout::ShaderInterface] =
    &[crate::gpu::layout::ShaderInterface::technique(
        &["texture_space/levels.comp"],
        None,
        Some(&LEVELS_SET),
        Some(TEXTURE_SPACE_STRUCTS[0]),
    )];
