//! One view on the GPU: its uniforms (viewport, lens or orthographic extent, depth range, the
//! lights in its space), every object's transforms into it over each key segment of its motion, and
//! the frame set (set 0) that binds them beside the world's.
//!
//! The object → view matrices are the CPU's products ([`crate::scene::CameraSpaceScene`]), the very
//! values the CPU reference and the bounds mirror use, so every consumer moves vertices the same way
//! (docs/MODEL.md "Shutter"); the GPU never re-multiplies world and view matrices.

use ash::vk;
use glam::{Mat3, Mat4};

use super::layout::{
    GpuLight, GpuObjectView, ViewUniforms, FRAME_SET, LIGHT_DIRECTIONAL, LIGHT_POINT, LIGHT_SPOT, MAX_LIGHTS,
    PROJECTION_ORTHOGRAPHIC, PROJECTION_PERSPECTIVE, PROJECTION_THIN_LENS,
};
use super::GpuWorld;
use crate::error::{Error, Result};
use crate::geometry::KeyTimes;
use crate::scene::{CameraSpaceLight, Projection, View};
use crate::vk::{write_descriptors, Buffer, DescriptorPool, DescriptorWrite, Device};

/// A view's block on the device.
pub struct GpuView {
    pub name: String,
    pub width: u32,
    pub height: u32,
    /// Set 0: the world's uniforms and materials with this view's uniforms and object transforms.
    pub frame_set: vk::DescriptorSet,
    /// Per object: its first segment in `ObjectViews` and its key times.
    pub object_keys: Vec<(u32, KeyTimes)>,
    _uniforms: Buffer,
    _object_views: Buffer,
    _pool: DescriptorPool,
}

fn mat4(m: Mat4) -> [f32; 16] {
    m.to_cols_array()
}
fn mat3_padded(m: Mat3) -> [f32; 16] {
    Mat4::from_mat3(m).to_cols_array()
}

/// The uniforms of `view` (see [`ViewUniforms`]).
pub fn view_uniforms(view: &View) -> Result<ViewUniforms> {
    let lights_in_view = &view.space.lights;
    if lights_in_view.len() > MAX_LIGHTS {
        return Err(Error::Limit {
            what: "light count",
            value: lights_in_view.len().to_string(),
            limit: format!("at most {MAX_LIGHTS} lights (MAX_LIGHTS in shaders-glsl/common/frame.glsl)"),
        });
    }
    let mut lights = [GpuLight::default(); MAX_LIGHTS];
    for (dst, l) in lights.iter_mut().zip(lights_in_view) {
        *dst = match *l {
            CameraSpaceLight::Directional { to_light, color } => GpuLight {
                at_open: to_light[0].extend(LIGHT_DIRECTIONAL).to_array(),
                at_close: to_light[1].extend(LIGHT_DIRECTIONAL).to_array(),
                color: color.extend(0.0).to_array(),
                ..GpuLight::default()
            },
            CameraSpaceLight::Point { position, color } => GpuLight {
                at_open: position[0].extend(LIGHT_POINT).to_array(),
                at_close: position[1].extend(LIGHT_POINT).to_array(),
                color: color.extend(0.0).to_array(),
                ..GpuLight::default()
            },
            CameraSpaceLight::Spot { position, axis, cos_inner, cos_outer, color } => GpuLight {
                at_open: position[0].extend(LIGHT_SPOT).to_array(),
                at_close: position[1].extend(LIGHT_SPOT).to_array(),
                color: color.extend(0.0).to_array(),
                spot_open: axis[0].extend(cos_inner).to_array(),
                spot_close: axis[1].extend(cos_outer).to_array(),
            },
        };
    }
    let n = lights_in_view.len() as f32;
    let (viewport, lens, projection) = match view.projection {
        Projection::ThinLens(k) => (
            [k.width, k.height, k.pixel_scale, n],
            [k.aperture_radius, k.focus_distance, k.near, k.far],
            [PROJECTION_THIN_LENS, 0.0, 0.0, 0.0],
        ),
        Projection::Orthographic { width, height, half_extent, near, far } => (
            [width as f32, height as f32, 0.0, n],
            [0.0, 0.0, near, far],
            [PROJECTION_ORTHOGRAPHIC, half_extent.x, half_extent.y, 0.0],
        ),
        Projection::Perspective { width, height, pixel_scale, near, far } => (
            [width as f32, height as f32, pixel_scale, n],
            [0.0, 0.0, near, far],
            [PROJECTION_PERSPECTIVE, 0.0, 0.0, 0.0],
        ),
    };
    Ok(ViewUniforms { viewport, lens, projection, lights })
}

/// Every object's transforms into `view` over each key segment of its motion, in the order of
/// `ObjectViews` (one record per segment, an object's consecutive), and per object its first record
/// and key times.
pub fn object_view_records(view: &View) -> (Vec<GpuObjectView>, Vec<(u32, KeyTimes)>) {
    let mut object_views: Vec<GpuObjectView> = Vec::with_capacity(view.space.objects.len());
    let mut object_keys = Vec::with_capacity(view.space.objects.len());
    for m in &view.space.objects {
        object_keys.push((object_views.len() as u32, m.keys.clone()));
        let (t, inv) = (m.keys.times(), m.keys.inv_len());
        for j in 0..m.segments() {
            object_views.push(GpuObjectView {
                model_view: [mat4(m.model_view[j]), mat4(m.model_view[j + 1])],
                normal_matrix: [mat3_padded(m.normal_matrix[j]), mat3_padded(m.normal_matrix[j + 1])],
                time: [t[j], t[j + 1], inv[j], 0.0],
            });
        }
    }
    (object_views, object_keys)
}

impl GpuView {
    /// Uploads `view`'s block for `world` (whose objects it must list in the same order).
    pub fn new(device: &Device, world: &GpuWorld, view: &View) -> Result<GpuView> {
        let bytes = std::mem::size_of::<ViewUniforms>();
        if bytes as u64 > device.caps.max_uniform_buffer_range as u64 {
            return Err(Error::Limit {
                what: "view uniforms",
                value: format!("{bytes} bytes ({MAX_LIGHTS} lights)"),
                limit: format!(
                    "{} bytes on this device (maxUniformBufferRange; lower MAX_LIGHTS in gpu/layout.rs and \
                     common/frame.glsl)",
                    device.caps.max_uniform_buffer_range
                ),
            });
        }
        let uniforms = Buffer::with_data(
            device,
            &format!("view uniforms:{}", view.name),
            vk::BufferUsageFlags::UNIFORM_BUFFER,
            &[view_uniforms(view)?],
        )?;
        if view.space.objects.len() != world.objects.len() {
            return Err(Error::Unsupported(format!(
                "view `{}` has {} objects, the world {}",
                view.name,
                view.space.objects.len(),
                world.objects.len()
            )));
        }
        let (mut object_views, object_keys) = object_view_records(view);
        if object_views.is_empty() {
            object_views.push(bytemuck::Zeroable::zeroed());
        }
        let object_views = Buffer::with_data(
            device,
            &format!("object views:{}", view.name),
            vk::BufferUsageFlags::STORAGE_BUFFER,
            &object_views,
        )?;
        let pool = DescriptorPool::for_tables(device, 1, &[(&FRAME_SET, 1)])?;
        let frame_set = pool.allocate(&world.frame_layout)?;
        write_descriptors(
            device,
            frame_set,
            &[
                DescriptorWrite::uniform_buffer(0, &world.uniforms),
                DescriptorWrite::storage_buffer(1, &world.materials),
                DescriptorWrite::uniform_buffer(2, &uniforms),
                DescriptorWrite::storage_buffer(3, &object_views),
            ],
        );
        let (width, height) = view.size();
        Ok(GpuView {
            name: view.name.clone(),
            width,
            height,
            frame_set,
            object_keys,
            _uniforms: uniforms,
            _object_views: object_views,
            _pool: pool,
        })
    }
}

impl GpuView {
    /// Object `object`'s segment holding shutter time `t` (its index in `ObjectViews`) and the time
    /// within it: what a draw at one time (a forward pass) pushes.
    pub fn segment_at(&self, object: usize, t: f32) -> (u32, f32) {
        let (first, keys) = &self.object_keys[object];
        let (j, s) = keys.locate(t);
        (first + j as u32, s)
    }
    /// Object `object`'s first segment in `ObjectViews` and its segment count.
    pub fn segments(&self, object: usize) -> (u32, u32) {
        let (first, keys) = &self.object_keys[object];
        (*first, keys.segments() as u32)
    }
}
