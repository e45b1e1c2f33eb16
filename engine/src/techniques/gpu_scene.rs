//! The scene on the GPU, shared by every technique: vertex/index buffers in object space, per-object
//! model-view at shutter open and close plus material (SSBO), lights at open and close (UBO), albedo
//! textures with mips. Layouts mirror `shaders-glsl/common/frame.glsl`.

use ash::vk;
use glam::{Mat3, Mat4};

use crate::error::{Error, Result};
use crate::scene::{CameraSpaceLight, CameraSpaceScene, Scene};
use crate::vk::{
    as_bytes, upload_texture, write_descriptors, Buffer, CommandRecorder, DescriptorPool,
    DescriptorSetLayout, DescriptorWrite, Device, Image, PipelineLayout, Sampler,
};

/// `MAX_LIGHTS` in `common/frame.glsl`.
pub const MAX_LIGHTS: usize = 16;

#[repr(C)]
#[derive(Clone, Copy, Default)]
struct GpuLight {
    at_open: [f32; 4],
    at_close: [f32; 4],
    color: [f32; 4],
}

/// `FrameUniforms` in `common/frame.glsl` (std140: only vec4s, so no padding surprises).
#[repr(C)]
#[derive(Clone, Copy)]
struct FrameUniforms {
    viewport: [f32; 4],
    lens: [f32; 4],
    ambient: [f32; 4],
    background: [f32; 4],
    lights: [GpuLight; MAX_LIGHTS],
}

/// `ObjectData` in `common/frame.glsl` (std430).
#[repr(C)]
#[derive(Clone, Copy)]
struct ObjectData {
    model_view: [[f32; 16]; 2],
    normal_matrix: [[f32; 16]; 2],
    albedo_specular: [f32; 4],
    material: [f32; 4],
}

/// Interleaved vertex: position, normal, uv (object space). 32 bytes.
#[repr(C)]
#[derive(Clone, Copy)]
pub struct Vertex {
    pub position: [f32; 3],
    pub normal: [f32; 3],
    pub uv: [f32; 2],
}

/// One object's draw data.
pub struct GpuObject {
    pub name: String,
    pub vertices: Buffer,
    pub indices: Buffer,
    pub index_count: u32,
    /// Set 1: the albedo texture (a white texel when untextured).
    pub material_set: vk::DescriptorSet,
}

/// Everything a technique needs to draw the scene. Descriptor set 0 = frame (UBO + object SSBO),
/// set 1 = per-object material.
pub struct GpuScene {
    pub objects: Vec<GpuObject>,
    pub frame_set: vk::DescriptorSet,
    pub frame_layout: DescriptorSetLayout,
    pub material_layout: DescriptorSetLayout,
    pub width: u32,
    pub height: u32,
    pub background: [f32; 4],
    _frame_ubo: Buffer,
    _object_ssbo: Buffer,
    _textures: Vec<Image>,
    _sampler: Sampler,
    _pool: DescriptorPool,
}

fn mat4(m: Mat4) -> [f32; 16] {
    m.to_cols_array()
}
fn mat3_padded(m: Mat3) -> [f32; 16] {
    Mat4::from_mat3(m).to_cols_array()
}

impl GpuScene {
    /// Uploads `scene` for an image of `width × height`.
    pub fn upload(
        device: &Device,
        rec: &mut CommandRecorder,
        scene: &Scene,
        width: u32,
        height: u32,
    ) -> Result<GpuScene> {
        let cs = CameraSpaceScene::new(scene);
        if cs.lights.len() > MAX_LIGHTS {
            return Err(Error::Limit {
                what: "light count",
                value: cs.lights.len().to_string(),
                limit: format!("at most {MAX_LIGHTS} lights (MAX_LIGHTS in shaders-glsl/common/frame.glsl)"),
            });
        }
        let k = scene.camera.intrinsics(width, height);
        let env = scene.environment;
        let mut lights = [GpuLight::default(); MAX_LIGHTS];
        for (dst, l) in lights.iter_mut().zip(&cs.lights) {
            *dst = match *l {
                CameraSpaceLight::Directional { to_light, color } => GpuLight {
                    at_open: to_light[0].extend(0.0).to_array(),
                    at_close: to_light[1].extend(0.0).to_array(),
                    color: color.extend(0.0).to_array(),
                },
                CameraSpaceLight::Point { position, color } => GpuLight {
                    at_open: position[0].extend(1.0).to_array(),
                    at_close: position[1].extend(1.0).to_array(),
                    color: color.extend(0.0).to_array(),
                },
            };
        }
        let frame = FrameUniforms {
            viewport: [width as f32, height as f32, k.pixel_scale, cs.lights.len() as f32],
            lens: [k.aperture_radius, k.focus_distance, k.near, k.far],
            ambient: env.ambient.extend(0.0).to_array(),
            background: env.background.extend(1.0).to_array(),
            lights,
        };
        let frame_ubo =
            Buffer::with_data(device, "frame uniforms", vk::BufferUsageFlags::UNIFORM_BUFFER, &[frame])?;
        let object_data: Vec<ObjectData> = scene
            .objects
            .iter()
            .zip(&cs.objects)
            .map(|(o, m)| ObjectData {
                model_view: [mat4(m.model_view[0]), mat4(m.model_view[1])],
                normal_matrix: [mat3_padded(m.normal_matrix[0]), mat3_padded(m.normal_matrix[1])],
                albedo_specular: o.material.albedo.extend(o.material.specular).to_array(),
                material: [
                    o.material.roughness,
                    if o.material.texture.is_some() && o.mesh.has_uvs() { 1.0 } else { 0.0 },
                    o.material.alpha,
                    0.0,
                ],
            })
            .collect();
        let object_ssbo =
            Buffer::with_data(device, "object data", vk::BufferUsageFlags::STORAGE_BUFFER, &object_data)?;

        let frame_layout = DescriptorSetLayout::new(
            device,
            "frame set layout",
            &[
                (
                    0,
                    vk::DescriptorType::UNIFORM_BUFFER,
                    vk::ShaderStageFlags::ALL_GRAPHICS | vk::ShaderStageFlags::COMPUTE,
                ),
                (
                    1,
                    vk::DescriptorType::STORAGE_BUFFER,
                    vk::ShaderStageFlags::ALL_GRAPHICS | vk::ShaderStageFlags::COMPUTE,
                ),
            ],
        )?;
        let material_layout = DescriptorSetLayout::new(
            device,
            "material set layout",
            &[(0, vk::DescriptorType::COMBINED_IMAGE_SAMPLER, vk::ShaderStageFlags::FRAGMENT)],
        )?;
        let n = scene.objects.len() as u32;
        let pool = DescriptorPool::new(
            device,
            n + 1,
            &[
                (vk::DescriptorType::UNIFORM_BUFFER, 1),
                (vk::DescriptorType::STORAGE_BUFFER, 1),
                (vk::DescriptorType::COMBINED_IMAGE_SAMPLER, n),
            ],
        )?;
        let frame_set = pool.allocate(&frame_layout)?;
        write_descriptors(
            device,
            frame_set,
            &[
                DescriptorWrite::Buffer {
                    binding: 0,
                    ty: vk::DescriptorType::UNIFORM_BUFFER,
                    buffer: frame_ubo.raw,
                },
                DescriptorWrite::Buffer {
                    binding: 1,
                    ty: vk::DescriptorType::STORAGE_BUFFER,
                    buffer: object_ssbo.raw,
                },
            ],
        );

        let sampler = Sampler::trilinear_repeat(device, "albedo sampler")?;
        let white = crate::scene::Texture::from_srgb_rgba8("white", 1, 1, vec![255; 4]);
        let mut textures = vec![upload_texture(device, rec, &white)?];
        // Objects sharing one texture share one image.
        let mut texture_index: Vec<(*const crate::scene::Texture, usize)> = vec![];
        let mut objects = Vec::with_capacity(scene.objects.len());
        for o in &scene.objects {
            let mesh = &o.mesh;
            let vertices: Vec<Vertex> = (0..mesh.positions.len())
                .map(|i| Vertex {
                    position: mesh.positions[i].to_array(),
                    normal: mesh.normals[i].to_array(),
                    uv: mesh.uvs.get(i).map(|u| u.to_array()).unwrap_or([0.0; 2]),
                })
                .collect();
            let vb = Buffer::with_data(
                device,
                &format!("vertices:{}", o.name),
                vk::BufferUsageFlags::VERTEX_BUFFER | vk::BufferUsageFlags::STORAGE_BUFFER,
                &vertices,
            )?;
            let ib = Buffer::with_data(
                device,
                &format!("indices:{}", o.name),
                vk::BufferUsageFlags::INDEX_BUFFER | vk::BufferUsageFlags::STORAGE_BUFFER,
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
            let set = pool.allocate(&material_layout)?;
            write_descriptors(
                device,
                set,
                &[DescriptorWrite::SampledImage {
                    binding: 0,
                    view: textures[tex_slot].view,
                    sampler: sampler.raw,
                }],
            );
            objects.push(GpuObject {
                name: o.name.clone(),
                vertices: vb,
                indices: ib,
                index_count: mesh.indices.len() as u32,
                material_set: set,
            });
        }
        Ok(GpuScene {
            objects,
            frame_set,
            frame_layout,
            material_layout,
            width,
            height,
            background: frame.background,
            _frame_ubo: frame_ubo,
            _object_ssbo: object_ssbo,
            _textures: textures,
            _sampler: sampler,
            _pool: pool,
        })
    }

    /// Records one indexed draw per non-empty object `i` with `include(i)`, with a graphics pipeline
    /// whose layout has set 0 = frame (bound here), set 1 = material, then `object_sets(i)` from set 2
    /// on, and push constants `push(i)` for `stages`. The pipeline and any other sets are the caller's.
    #[allow(clippy::too_many_arguments)]
    pub fn record_object_draws<P: Copy>(
        &self,
        d: &Device,
        cmd: vk::CommandBuffer,
        layout: &PipelineLayout,
        stages: vk::ShaderStageFlags,
        include: impl Fn(usize) -> bool,
        push: impl Fn(usize) -> P,
        object_sets: impl Fn(usize) -> Option<vk::DescriptorSet>,
    ) {
        let bind = vk::PipelineBindPoint::GRAPHICS;
        unsafe {
            d.raw.cmd_bind_descriptor_sets(cmd, bind, layout.raw, 0, &[self.frame_set], &[]);
            for (i, o) in self.objects.iter().enumerate() {
                if o.index_count == 0 || !include(i) {
                    continue;
                }
                d.raw.cmd_push_constants(cmd, layout.raw, stages, 0, as_bytes(&push(i)));
                let mut sets = vec![o.material_set];
                sets.extend(object_sets(i));
                d.raw.cmd_bind_descriptor_sets(cmd, bind, layout.raw, 1, &sets, &[]);
                d.raw.cmd_bind_vertex_buffers(cmd, 0, &[o.vertices.raw], &[0]);
                d.raw.cmd_bind_index_buffer(cmd, o.indices.raw, 0, vk::IndexType::UINT32);
                d.raw.cmd_draw_indexed(cmd, o.index_count, 1, 0, 0, 0);
            }
        }
    }

    /// Vertex input of [`Vertex`] for pipelines that draw the scene's meshes.
    pub fn vertex_input() -> ([vk::VertexInputBindingDescription; 1], [vk::VertexInputAttributeDescription; 3])
    {
        (
            [vk::VertexInputBindingDescription {
                binding: 0,
                stride: 32,
                input_rate: vk::VertexInputRate::VERTEX,
            }],
            [
                vk::VertexInputAttributeDescription {
                    location: 0,
                    binding: 0,
                    format: vk::Format::R32G32B32_SFLOAT,
                    offset: 0,
                },
                vk::VertexInputAttributeDescription {
                    location: 1,
                    binding: 0,
                    format: vk::Format::R32G32B32_SFLOAT,
                    offset: 12,
                },
                vk::VertexInputAttributeDescription {
                    location: 2,
                    binding: 0,
                    format: vk::Format::R32G32_SFLOAT,
                    offset: 24,
                },
            ],
        )
    }
}
