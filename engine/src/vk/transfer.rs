//! Uploads (textures with mips) and readback of images to the CPU.

use ash::vk;
use gpu_allocator::MemoryLocation;

use super::{barrier, image_barriers, Buffer, CommandRecorder, Device, Image, ImageDesc};
use crate::error::Result;
use crate::image::LinearImage;
use crate::scene::texture::{linear_to_srgb, Texture};

/// The mip chain of a texture as sRGB RGBA8 levels, box-filtered in linear light on the CPU
/// (deterministic across drivers, unlike blits). Alpha (linear, coverage for `alpha_from_texture`)
/// is box-filtered too; colour is weighted by alpha (the mean of the covered texels' colours).
pub fn srgb_mip_chain(tex: &Texture) -> Vec<(u32, u32, Vec<u8>)> {
    let mut levels = vec![(tex.width, tex.height, tex.srgb_rgba8.clone())];
    let mut cur: Vec<[f32; 4]> = tex
        .linear
        .iter()
        .zip(tex.srgb_rgba8.chunks_exact(4))
        .map(|(c, b)| c.extend(b[3] as f32 / 255.0).to_array())
        .collect();
    let (mut w, mut h) = (tex.width, tex.height);
    while w > 1 || h > 1 {
        let (nw, nh) = ((w / 2).max(1), (h / 2).max(1));
        let mut next = vec![[0.0f32; 4]; (nw * nh) as usize];
        for y in 0..nh {
            for x in 0..nw {
                // Colour weighted by alpha (the covered part's: a cut-out's transparent texels do not
                // darken its edges at coarser levels — texture-space shading's pre-filter reads
                // them); the plain mean where all four are transparent. All alpha 1: the plain mean,
                // bit for bit.
                let (mut acc, mut weighted, mut alpha) = ([0.0f32; 4], [0.0f32; 3], 0.0f32);
                for dy in 0..2 {
                    for dx in 0..2 {
                        let (sx, sy) = ((2 * x + dx).min(w - 1), (2 * y + dy).min(h - 1));
                        let c = cur[(sy * w + sx) as usize];
                        for i in 0..4 {
                            acc[i] += c[i];
                        }
                        for i in 0..3 {
                            weighted[i] += c[i] * c[3];
                        }
                        alpha += c[3];
                    }
                }
                let mut texel = acc.map(|v| v / 4.0);
                if alpha > 0.0 {
                    for i in 0..3 {
                        texel[i] = weighted[i] / alpha;
                    }
                }
                next[(y * nw + x) as usize] = texel;
            }
        }
        let bytes = next
            .iter()
            .flat_map(|c| {
                let e = |v: f32| (linear_to_srgb(v) * 255.0 + 0.5) as u8;
                [e(c[0]), e(c[1]), e(c[2]), (c[3] * 255.0 + 0.5) as u8]
            })
            .collect();
        levels.push((nw, nh, bytes));
        cur = next;
        (w, h) = (nw, nh);
    }
    levels
}

/// Creates a sampled `R8G8B8A8_SRGB` image with the full mip chain of `tex`, ready for sampling.
pub fn upload_texture(device: &Device, rec: &mut CommandRecorder, tex: &Texture) -> Result<Image> {
    let levels = srgb_mip_chain(tex);
    let desc = ImageDesc::new_2d(
        tex.width,
        tex.height,
        vk::Format::R8G8B8A8_SRGB,
        vk::ImageUsageFlags::SAMPLED | vk::ImageUsageFlags::TRANSFER_DST,
    )
    .mips(levels.len() as u32);
    let image = Image::new(device, &format!("texture:{}", tex.name), desc)?;
    let total: usize = levels.iter().map(|l| l.2.len()).sum();
    let mut staging = Buffer::new(
        device,
        "texture staging",
        total as u64,
        vk::BufferUsageFlags::TRANSFER_SRC,
        MemoryLocation::CpuToGpu,
    )?;
    let mut data = Vec::with_capacity(total);
    let mut regions = vec![];
    for (i, (w, h, bytes)) in levels.iter().enumerate() {
        regions.push(
            vk::BufferImageCopy::default()
                .buffer_offset(data.len() as u64)
                .image_subresource(
                    vk::ImageSubresourceLayers::default()
                        .aspect_mask(vk::ImageAspectFlags::COLOR)
                        .mip_level(i as u32)
                        .layer_count(1),
                )
                .image_extent(vk::Extent3D { width: *w, height: *h, depth: 1 }),
        );
        data.extend_from_slice(bytes);
    }
    staging.write(&data)?;
    rec.submit(|d, cmd| {
        image_barriers(
            d,
            cmd,
            &[barrier(
                &image,
                vk::ImageLayout::UNDEFINED,
                vk::ImageLayout::TRANSFER_DST_OPTIMAL,
                (vk::PipelineStageFlags2::NONE, vk::AccessFlags2::NONE),
                (vk::PipelineStageFlags2::COPY, vk::AccessFlags2::TRANSFER_WRITE),
            )],
        );
        unsafe {
            d.raw.cmd_copy_buffer_to_image(
                cmd,
                staging.raw,
                image.raw,
                vk::ImageLayout::TRANSFER_DST_OPTIMAL,
                &regions,
            )
        };
        image_barriers(
            d,
            cmd,
            &[barrier(
                &image,
                vk::ImageLayout::TRANSFER_DST_OPTIMAL,
                vk::ImageLayout::SHADER_READ_ONLY_OPTIMAL,
                (vk::PipelineStageFlags2::COPY, vk::AccessFlags2::TRANSFER_WRITE),
                (vk::PipelineStageFlags2::FRAGMENT_SHADER, vk::AccessFlags2::SHADER_SAMPLED_READ),
            )],
        );
        Ok(())
    })?;
    Ok(image)
}

/// Converts a completed readback buffer into a [`LinearImage`].
pub fn read_rgba32f(buffer: &Buffer, width: u32, height: u32) -> Result<LinearImage> {
    let bytes = buffer.mapped()?;
    let n = (width * height) as usize;
    let mut img = LinearImage::new(width, height);
    for i in 0..n {
        let mut px = [0f32; 4];
        for (c, v) in px.iter_mut().enumerate() {
            let o = i * 16 + c * 4;
            *v = f32::from_le_bytes([bytes[o], bytes[o + 1], bytes[o + 2], bytes[o + 3]]);
        }
        img.pixels[i] = px;
    }
    Ok(img)
}

#[cfg(test)]
mod tests {
    use super::*;

    /// Colour at coarser levels is the covered part's: a 2×2 block of one opaque red texel among
    /// transparent black ones is red at level 1 (alpha ¼), not a dark red; an opaque texture is the
    /// plain mean.
    #[test]
    fn mips_weigh_colour_by_alpha() {
        let cut_out = Texture::from_srgb_rgba8(
            "cut-out",
            2,
            2,
            vec![200, 30, 30, 255, 0, 0, 0, 0, 0, 0, 0, 0, 0, 0, 0, 0],
        );
        let levels = srgb_mip_chain(&cut_out);
        assert_eq!(levels.len(), 2);
        let (w, h, texel) = &levels[1];
        assert_eq!((*w, *h), (1, 1));
        assert_eq!(&texel[..3], &[200, 30, 30]);
        assert_eq!(texel[3], 64);
        let opaque = Texture::from_srgb_rgba8("opaque", 2, 1, vec![255, 255, 255, 255, 0, 0, 0, 255]);
        let mean = crate::scene::texture::linear_to_srgb(0.5);
        let (_, _, texel) = &srgb_mip_chain(&opaque)[1];
        assert_eq!(texel[0], (mean * 255.0 + 0.5) as u8);
        assert_eq!(texel[3], 255);
    }
}
