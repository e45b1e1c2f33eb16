//! The world on the GPU, uploaded once per scene and shared by every view and technique: meshes in
//! object space, materials, albedo textures with mips, the environment. Nothing here depends on a
//! view or an image size.

use ash::vk;
use glam::Vec3;

use super::layout::{self, GpuMaterial, Vertex, WorldUniforms, FRAME_SET, OBJECT_SET};
use super::GpuView;
use crate::error::Result;
use crate::graph::PassContext;
use crate::scene::{Scene, Texture};
use crate::vk::{
    upload_texture, write_descriptors, Buffer, CommandRecorder, DescriptorPool, DescriptorSetLayout,
    DescriptorWrite, Device, Faces, Image, Pipeline, PipelineLayout, Sampler,
};

/// One object's mesh and its descriptor set (set 1).
pub struct GpuObject {
    pub name: String,
    pub vertices: Buffer,
    pub indices: Buffer,
    pub index_count: u32,
    /// The material is one-sided ([`crate::scene::Material::one_sided`]): its back faces are culled.
    pub one_sided: bool,
    /// Set 1 ([`OBJECT_SET`]): albedo texture (a white texel when untextured), vertices, indices.
    pub set: vk::DescriptorSet,
}

impl GpuObject {
    pub fn triangle_count(&self) -> u32 {
        self.index_count / 3
    }
}

/// The scene's view-independent data on the device, and the layouts of sets 0 and 1.
pub struct GpuWorld {
    pub objects: Vec<GpuObject>,
    /// Layout of set 0 (frame: world + one view); views allocate their sets with it.
    pub frame_layout: DescriptorSetLayout,
    /// Layout of set 1 (object).
    pub object_layout: DescriptorSetLayout,
    /// An empty set layout, for pipeline layouts that skip a set number.
    pub empty_layout: DescriptorSetLayout,
    /// Linear RGB, alpha 1: what a pixel that sees nothing shows.
    pub background: [f32; 4],
    pub(crate) uniforms: Buffer,
    pub(crate) materials: Buffer,
    _textures: Vec<Image>,
    _sampler: Sampler,
    _pool: DescriptorPool,
}

/// Shader stages that may read sets 0 and 1 on every device ([`scene_stages`] adds the mesh stage).
pub const SCENE_STAGES: vk::ShaderStageFlags = vk::ShaderStageFlags::from_raw(
    vk::ShaderStageFlags::ALL_GRAPHICS.as_raw() | vk::ShaderStageFlags::COMPUTE.as_raw(),
);

/// Shader stages that may read the scene's and the techniques' sets on `caps`' device: [`SCENE_STAGES`]
/// and, where the device has mesh (and task) shaders (enabled: a layout may not name the stage
/// otherwise), the mesh (and task) stage.
pub fn scene_stages(caps: &crate::vk::Capabilities) -> vk::ShaderStageFlags {
    let mut stages = SCENE_STAGES;
    if caps.mesh_shader {
        stages |= vk::ShaderStageFlags::MESH_EXT;
    }
    if caps.task_shader {
        stages |= vk::ShaderStageFlags::TASK_EXT;
    }
    stages
}

impl GpuWorld {
    /// Uploads `scene`'s meshes, materials, textures and environment.
    pub fn upload(device: &Device, rec: &mut CommandRecorder, scene: &Scene) -> Result<GpuWorld> {
        let env = scene.environment;
        let world = WorldUniforms {
            ambient: env.ambient.extend(0.0).to_array(),
            background: env.background.extend(1.0).to_array(),
        };
        let uniforms =
            Buffer::with_data(device, "world uniforms", vk::BufferUsageFlags::UNIFORM_BUFFER, &[world])?;
        let materials: Vec<GpuMaterial> = scene
            .objects
            .iter()
            .map(|o| GpuMaterial {
                albedo_specular: o.material.albedo.extend(o.material.specular).to_array(),
                params: [
                    o.material.roughness,
                    if o.material.texture.is_some() && o.mesh.has_uvs() { 1.0 } else { 0.0 },
                    o.material.alpha,
                    if o.material.alpha_from_texture { 1.0 } else { 0.0 },
                ],
            })
            .collect();
        // One element at least: a zero-sized storage buffer cannot be bound.
        let placeholder = [GpuMaterial::default()];
        let materials = Buffer::with_data(
            device,
            "materials",
            vk::BufferUsageFlags::STORAGE_BUFFER,
            if materials.is_empty() { &placeholder } else { &materials },
        )?;
        let stages = scene_stages(&device.caps);
        let frame_layout = DescriptorSetLayout::from_table(device, "frame set layout", &FRAME_SET, stages)?;
        let object_layout =
            DescriptorSetLayout::from_table(device, "object set layout", &OBJECT_SET, stages)?;
        let empty_layout = DescriptorSetLayout::from_table(device, "empty set layout", &[], stages)?;

        let n = scene.objects.len() as u32;
        let pool = DescriptorPool::for_tables(device, n, &[(&OBJECT_SET, n)])?;
        let sampler = Sampler::trilinear_repeat(device, "albedo sampler")?;
        let white = Texture::from_srgb_rgba8("white", 1, 1, vec![255; 4]);
        let mut textures = vec![upload_texture(device, rec, &white)?];
        // Objects sharing one texture share one image.
        let mut texture_index: Vec<(*const Texture, usize)> = vec![];
        let mut objects = Vec::with_capacity(scene.objects.len());
        for o in &scene.objects {
            let mesh = &o.mesh;
            let vertices: Vec<Vertex> = (0..mesh.positions.len())
                .map(|i| Vertex {
                    position: mesh.positions[i].to_array(),
                    normal: mesh.normals.get(i).copied().unwrap_or(Vec3::ZERO).to_array(),
                    uv: mesh.uvs.get(i).map(|u| u.to_array()).unwrap_or([0.0; 2]),
                })
                .collect();
            let mesh_usage = vk::BufferUsageFlags::STORAGE_BUFFER;
            let vb = Buffer::with_data(
                device,
                &format!("vertices:{}", o.name),
                mesh_usage | vk::BufferUsageFlags::VERTEX_BUFFER,
                &vertices,
            )?;
            let ib = Buffer::with_data(
                device,
                &format!("indices:{}", o.name),
                mesh_usage | vk::BufferUsageFlags::INDEX_BUFFER,
                &mesh.indices,
            )?;
            let tex_slot = match &o.material.texture {
                Some(t) if mesh.has_uvs() => {
                    let key = std::sync::Arc::as_ptr(t);
                    match texture_index.iter().find(|(k, _)| *k == key) {
                        Some((_, i)) => *i,
                        None => {
                            textures.push(upload_texture(device, rec, t)?);
                            texture_index.push((key, textures.len() - 1));
                            textures.len() - 1
                        }
                    }
                }
                _ => 0,
            };
            let set = pool.allocate(&object_layout)?;
            write_descriptors(
                device,
                set,
                &[
                    DescriptorWrite::SampledImage {
                        binding: 0,
                        view: textures[tex_slot].view,
                        sampler: sampler.raw,
                    },
                    DescriptorWrite::storage_buffer(1, &vb),
                    DescriptorWrite::storage_buffer(2, &ib),
                ],
            );
            objects.push(GpuObject {
                name: o.name.clone(),
                vertices: vb,
                indices: ib,
                index_count: mesh.indices.len() as u32,
                one_sided: o.material.one_sided,
                set,
            });
        }
        Ok(GpuWorld {
            objects,
            frame_layout,
            object_layout,
            empty_layout,
            background: world.background,
            uniforms,
            materials,
            _textures: textures,
            _sampler: sampler,
            _pool: pool,
        })
    }

    /// A pipeline layout with sets 0 (frame) and 1 (object), then `technique_sets` from set 2 on, and
    /// one push-constant range of `push_bytes` for `push_stages`.
    pub fn pipeline_layout(
        &self,
        device: &Device,
        technique_sets: &[&DescriptorSetLayout],
        push_bytes: u32,
        push_stages: vk::ShaderStageFlags,
    ) -> Result<PipelineLayout> {
        let mut sets = vec![&self.frame_layout, &self.object_layout];
        sets.extend_from_slice(technique_sets);
        PipelineLayout::new(device, &sets, push_bytes, push_stages)
    }

    /// Records one indexed draw per non-empty object `i` with `include(i)` as seen from `view`, with a
    /// bound graphics pipeline whose layout is `layout` ([`GpuWorld::pipeline_layout`]): binds set 0
    /// (the view's frame set) and per object set 1 and `object_set(i)` as set 2 when given, and pushes
    /// `push(i)` (for the layout's push stages). Binding `pipeline` and set 3 is the caller's; with a
    /// [`Faces::PerObject`] pipeline each draw sets the cull mode, back faces for a one-sided object.
    #[allow(clippy::too_many_arguments)]
    pub fn record_object_draws<P: bytemuck::Pod>(
        &self,
        ctx: &PassContext<'_>,
        view: &GpuView,
        pipeline: &Pipeline,
        layout: &PipelineLayout,
        include: impl Fn(usize) -> bool,
        push: impl Fn(usize) -> P,
        object_set: impl Fn(usize) -> Option<vk::DescriptorSet>,
    ) {
        let once = |_| (1, 0);
        self.record_object_draws_instanced(ctx, view, (pipeline, layout), include, push, object_set, once)
    }

    /// [`GpuWorld::record_object_draws`] with `instances(i) = (count, first)` instances of object `i`'s
    /// draw (`gl_InstanceIndex` first..first + count): one draw per object for work that repeats over
    /// many views, such as the faces of many shadow maps, where llvmpipe's cost per draw would dominate.
    #[allow(clippy::too_many_arguments)]
    pub fn record_object_draws_instanced<P: bytemuck::Pod>(
        &self,
        ctx: &PassContext<'_>,
        view: &GpuView,
        (pipeline, layout): (&Pipeline, &PipelineLayout),
        include: impl Fn(usize) -> bool,
        push: impl Fn(usize) -> P,
        object_set: impl Fn(usize) -> Option<vk::DescriptorSet>,
        instances: impl Fn(usize) -> (u32, u32),
    ) {
        let bind = vk::PipelineBindPoint::GRAPHICS;
        ctx.bind_sets(bind, layout, layout::FRAME_SET_INDEX, &[view.frame_set]);
        for (i, o) in self.objects.iter().enumerate() {
            if o.index_count == 0 || !include(i) {
                continue;
            }
            ctx.push(layout, &push(i));
            if pipeline.faces == Faces::PerObject {
                ctx.set_cull_mode(if o.one_sided {
                    vk::CullModeFlags::BACK
                } else {
                    vk::CullModeFlags::NONE
                });
            }
            let mut sets = vec![o.set];
            sets.extend(object_set(i));
            ctx.bind_sets(bind, layout, layout::OBJECT_SET_INDEX, &sets);
            let (count, first) = instances(i);
            ctx.draw_indexed((&o.vertices, &o.indices), o.index_count, count, first);
        }
    }
}
