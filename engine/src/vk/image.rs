//! Images with views and allocations, RAII; samplers.

use ash::vk;
use gpu_allocator::vulkan::Allocation;
use gpu_allocator::MemoryLocation;

use super::memory::{allocate, free};
use super::Device;
use crate::error::{Result, VkContext};

/// How to create an [`Image`].
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub struct ImageDesc {
    pub width: u32,
    pub height: u32,
    pub format: vk::Format,
    pub usage: vk::ImageUsageFlags,
    pub samples: u32,
    pub mip_levels: u32,
}

impl ImageDesc {
    pub fn new_2d(width: u32, height: u32, format: vk::Format, usage: vk::ImageUsageFlags) -> Self {
        ImageDesc { width, height, format, usage, samples: 1, mip_levels: 1 }
    }
    pub fn samples(mut self, samples: u32) -> Self {
        self.samples = samples;
        self
    }
    pub fn mips(mut self, mip_levels: u32) -> Self {
        self.mip_levels = mip_levels;
        self
    }
}

/// A 2D image, its memory and a view of all its mips. Freed on drop — unless it is someone else's
/// (`Image::borrowed`).
pub struct Image {
    pub raw: vk::Image,
    pub view: vk::ImageView,
    pub desc: ImageDesc,
    allocation: Option<Allocation>,
    /// Whether `raw` is Shutter's to destroy (false for an image a caller lent).
    owns_image: bool,
    device: Device,
}

pub fn aspect_of(format: vk::Format) -> vk::ImageAspectFlags {
    match format {
        vk::Format::D32_SFLOAT | vk::Format::D16_UNORM => vk::ImageAspectFlags::DEPTH,
        _ => vk::ImageAspectFlags::COLOR,
    }
}

impl Image {
    pub fn new(device: &Device, name: &str, desc: ImageDesc) -> Result<Image> {
        let info = vk::ImageCreateInfo::default()
            .image_type(vk::ImageType::TYPE_2D)
            .format(desc.format)
            .extent(vk::Extent3D { width: desc.width, height: desc.height, depth: 1 })
            .mip_levels(desc.mip_levels)
            .array_layers(1)
            .samples(vk::SampleCountFlags::from_raw(desc.samples))
            .tiling(vk::ImageTiling::OPTIMAL)
            .usage(desc.usage)
            .initial_layout(vk::ImageLayout::UNDEFINED);
        let raw = unsafe { device.raw.create_image(&info, None) }.vk("vkCreateImage")?;
        let reqs = unsafe { device.raw.get_image_memory_requirements(raw) };
        let allocation = match allocate(device, name, reqs, MemoryLocation::GpuOnly, false) {
            Ok(a) => a,
            Err(e) => {
                unsafe { device.raw.destroy_image(raw, None) };
                return Err(e.into());
            }
        };
        let mut image = Image {
            raw,
            view: vk::ImageView::null(),
            desc,
            allocation: Some(allocation),
            owns_image: true,
            device: device.clone(),
        };
        let a = image.allocation.as_ref().expect("just set");
        unsafe { device.raw.bind_image_memory(raw, a.memory(), a.offset()) }.vk("vkBindImageMemory")?;
        let view_info = vk::ImageViewCreateInfo::default()
            .image(raw)
            .view_type(vk::ImageViewType::TYPE_2D)
            .format(desc.format)
            .subresource_range(image.full_range());
        image.view = unsafe { device.raw.create_image_view(&view_info, None) }.vk("vkCreateImageView")?;
        device.set_name(raw, name);
        device.set_name(image.view, name);
        Ok(image)
    }

    /// A caller's image, lent for one frame graph: no view (only transfers may use it) and nothing
    /// destroyed on drop.
    ///
    /// # Safety
    /// `raw` is a 2D colour image of `device` described by `desc` (one layer), valid while the
    /// returned value and any command recorded with it are alive.
    pub(crate) unsafe fn borrowed(device: &Device, raw: vk::Image, desc: ImageDesc) -> Image {
        Image {
            raw,
            view: vk::ImageView::null(),
            desc,
            allocation: None,
            owns_image: false,
            device: device.clone(),
        }
    }

    pub fn full_range(&self) -> vk::ImageSubresourceRange {
        vk::ImageSubresourceRange::default()
            .aspect_mask(aspect_of(self.desc.format))
            .level_count(self.desc.mip_levels)
            .layer_count(1)
    }

    pub fn extent_2d(&self) -> vk::Extent2D {
        vk::Extent2D { width: self.desc.width, height: self.desc.height }
    }
}

impl Drop for Image {
    fn drop(&mut self) {
        unsafe {
            if self.view != vk::ImageView::null() {
                self.device.raw.destroy_image_view(self.view, None);
            }
        }
        free(&self.device, self.allocation.take());
        if self.owns_image {
            unsafe { self.device.raw.destroy_image(self.raw, None) };
        }
    }
}

/// A sampler, RAII.
pub struct Sampler {
    pub raw: vk::Sampler,
    device: Device,
}

impl Sampler {
    fn create(device: &Device, name: &str, info: &vk::SamplerCreateInfo<'_>) -> Result<Sampler> {
        let raw = unsafe { device.raw.create_sampler(info, None) }.vk("vkCreateSampler")?;
        device.set_name(raw, name);
        Ok(Sampler { raw, device: device.clone() })
    }

    /// Trilinear, repeat addressing: how albedo textures are read.
    pub fn trilinear_repeat(device: &Device, name: &str) -> Result<Sampler> {
        let info = vk::SamplerCreateInfo::default()
            .mag_filter(vk::Filter::LINEAR)
            .min_filter(vk::Filter::LINEAR)
            .mipmap_mode(vk::SamplerMipmapMode::LINEAR)
            .address_mode_u(vk::SamplerAddressMode::REPEAT)
            .address_mode_v(vk::SamplerAddressMode::REPEAT)
            .address_mode_w(vk::SamplerAddressMode::REPEAT)
            .max_lod(vk::LOD_CLAMP_NONE);
        Sampler::create(device, name, &info)
    }
}

impl Sampler {
    /// Nearest texel, clamped to the edge: how depth images are fetched.
    pub fn nearest_clamp(device: &Device, name: &str) -> Result<Sampler> {
        let info = vk::SamplerCreateInfo::default()
            .mag_filter(vk::Filter::NEAREST)
            .min_filter(vk::Filter::NEAREST)
            .mipmap_mode(vk::SamplerMipmapMode::NEAREST)
            .address_mode_u(vk::SamplerAddressMode::CLAMP_TO_EDGE)
            .address_mode_v(vk::SamplerAddressMode::CLAMP_TO_EDGE)
            .address_mode_w(vk::SamplerAddressMode::CLAMP_TO_EDGE);
        Sampler::create(device, name, &info)
    }

    /// Linear filtering at unnormalized texel coordinates (texel t's centre at t + 0.5), clamped to
    /// the edge, one level: one fetch that blends two neighbouring texels by a chosen fraction.
    pub fn linear_unnormalized(device: &Device, name: &str) -> Result<Sampler> {
        let info = vk::SamplerCreateInfo::default()
            .mag_filter(vk::Filter::LINEAR)
            .min_filter(vk::Filter::LINEAR)
            .mipmap_mode(vk::SamplerMipmapMode::NEAREST)
            .address_mode_u(vk::SamplerAddressMode::CLAMP_TO_EDGE)
            .address_mode_v(vk::SamplerAddressMode::CLAMP_TO_EDGE)
            .address_mode_w(vk::SamplerAddressMode::CLAMP_TO_EDGE)
            .min_lod(0.0)
            .max_lod(0.0)
            .unnormalized_coordinates(true);
        Sampler::create(device, name, &info)
    }
}

impl Drop for Sampler {
    fn drop(&mut self) {
        unsafe { self.device.raw.destroy_sampler(self.raw, None) };
    }
}

/// One image layout transition as a synchronization2 barrier (whole image).
pub fn barrier(
    image: &Image,
    old: vk::ImageLayout,
    new: vk::ImageLayout,
    src: (vk::PipelineStageFlags2, vk::AccessFlags2),
    dst: (vk::PipelineStageFlags2, vk::AccessFlags2),
) -> vk::ImageMemoryBarrier2<'static> {
    vk::ImageMemoryBarrier2::default()
        .image(image.raw)
        .old_layout(old)
        .new_layout(new)
        .src_stage_mask(src.0)
        .src_access_mask(src.1)
        .dst_stage_mask(dst.0)
        .dst_access_mask(dst.1)
        .subresource_range(image.full_range())
}
