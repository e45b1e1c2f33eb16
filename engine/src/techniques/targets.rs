//! The multipass frame shared by every rasterizing technique: P passes, each rendered into an MSAA
//! colour + reversed-Z depth target, resolved (box filter over the pixel's samples), then added with
//! weight 1/P into an RGBA32F accumulation image (Haeberli & Akeley 1990) that is read back at the end.
//! A technique supplies only the draws of one pass ([`PassTargets::render`]'s `draw` callback).
//! Shader: `shaders-glsl/accumulation/accumulate.comp`.

use ash::vk;

use crate::error::Result;
use crate::image::LinearImage;
use crate::shaders;
use crate::vk::{
    as_bytes, barrier, image_barriers, read_rgba32f, record_readback, write_descriptors, CommandRecorder,
    DescriptorPool, DescriptorSetLayout, DescriptorWrite, Device, GpuTimer, Image, ImageDesc, PassTimings,
    Pipeline, PipelineLayout, ShaderModule,
};

/// Pass colour format (HDR) and depth format. Depth is reversed Z: cleared to 0, nearer is greater.
pub const COLOR_FORMAT: vk::Format = vk::Format::R16G16B16A16_SFLOAT;
pub const DEPTH_FORMAT: vk::Format = vk::Format::D32_SFLOAT;
pub const ACCUM_FORMAT: vk::Format = vk::Format::R32G32B32A32_SFLOAT;

/// Passes recorded per command buffer (bounds command-buffer size and query-pool size).
const PASSES_PER_SUBMIT: usize = 64;

/// Render targets and the accumulate pipeline for passes of one size and MSAA count.
pub struct PassTargets {
    samples: u32,
    accumulate: Pipeline,
    accumulate_layout: PipelineLayout,
    accumulate_set: vk::DescriptorSet,
    _accumulate_set_layout: DescriptorSetLayout,
    _pool: DescriptorPool,
    color_ms: Option<Image>,
    depth: Image,
    resolved: Image,
    accum: Image,
    _shader: ShaderModule,
}

impl PassTargets {
    pub fn new(device: &Device, width: u32, height: u32, samples: u32) -> Result<Self> {
        let (w, h) = (width, height);
        let comp = ShaderModule::new(device, shaders::ACCUMULATION_ACCUMULATE_COMP)?;
        let accumulate_set_layout = DescriptorSetLayout::new(
            device,
            "accumulate set layout",
            &[
                (0, vk::DescriptorType::STORAGE_IMAGE, vk::ShaderStageFlags::COMPUTE),
                (1, vk::DescriptorType::STORAGE_IMAGE, vk::ShaderStageFlags::COMPUTE),
            ],
        )?;
        let accumulate_layout =
            PipelineLayout::new(device, &[&accumulate_set_layout], 4, vk::ShaderStageFlags::COMPUTE)?;
        let accumulate = Pipeline::compute(device, "accumulate", &accumulate_layout, &comp)?;

        let attach = vk::ImageUsageFlags::COLOR_ATTACHMENT;
        let color_ms = if samples > 1 {
            Some(Image::new(
                device,
                "pass color (MSAA)",
                ImageDesc::new_2d(w, h, COLOR_FORMAT, attach | vk::ImageUsageFlags::TRANSIENT_ATTACHMENT)
                    .samples(samples),
            )?)
        } else {
            None
        };
        let depth = Image::new(
            device,
            "pass depth",
            ImageDesc::new_2d(w, h, DEPTH_FORMAT, vk::ImageUsageFlags::DEPTH_STENCIL_ATTACHMENT)
                .samples(samples),
        )?;
        let resolved = Image::new(
            device,
            "pass resolved",
            ImageDesc::new_2d(w, h, COLOR_FORMAT, attach | vk::ImageUsageFlags::STORAGE),
        )?;
        let accum = Image::new(
            device,
            "accumulation",
            ImageDesc::new_2d(
                w,
                h,
                ACCUM_FORMAT,
                vk::ImageUsageFlags::STORAGE
                    | vk::ImageUsageFlags::TRANSFER_SRC
                    | vk::ImageUsageFlags::TRANSFER_DST,
            ),
        )?;
        let pool = DescriptorPool::new(device, 1, &[(vk::DescriptorType::STORAGE_IMAGE, 2)])?;
        let accumulate_set = pool.allocate(&accumulate_set_layout)?;
        write_descriptors(
            device,
            accumulate_set,
            &[
                DescriptorWrite::StorageImage { binding: 0, view: resolved.view },
                DescriptorWrite::StorageImage { binding: 1, view: accum.view },
            ],
        );
        Ok(PassTargets {
            samples,
            accumulate,
            accumulate_layout,
            accumulate_set,
            _accumulate_set_layout: accumulate_set_layout,
            _pool: pool,
            color_ms,
            depth,
            resolved,
            accum,
            _shader: comp,
        })
    }

    /// MSAA samples per pixel of every pass.
    pub fn samples(&self) -> u32 {
        self.samples
    }

    /// Renders `passes` passes, averages them (equal weights) and reads the result back. For each pass
    /// the targets are cleared (colour to `background`, depth to 0), viewport and scissor cover the
    /// image, and `draw(device, cmd, pass_index)` records the pass' draws inside dynamic rendering.
    /// GPU time is reported as `pass_name` (the draws) and `accumulate`.
    pub fn render(
        &self,
        device: &Device,
        rec: &mut CommandRecorder,
        background: [f32; 4],
        passes: usize,
        pass_name: &'static str,
        draw: &mut dyn FnMut(&Device, vk::CommandBuffer, usize),
    ) -> Result<(LinearImage, PassTimings)> {
        let weight = 1.0 / passes.max(1) as f32;
        let mut timings = PassTimings::default();
        let mut timer = GpuTimer::new(device, 2 * PASSES_PER_SUBMIT as u32)?;
        let n_chunks = passes.div_ceil(PASSES_PER_SUBMIT);
        let mut readback = None;
        for ci in 0..n_chunks {
            let range = ci * PASSES_PER_SUBMIT..((ci + 1) * PASSES_PER_SUBMIT).min(passes);
            readback = rec.submit(|d, cmd| {
                timer.reset(cmd);
                if ci == 0 {
                    self.clear_accumulator(d, cmd);
                }
                for pass in range.clone() {
                    let t = timer.begin(cmd, pass_name);
                    self.record_pass(d, cmd, background, pass_name, &mut |d, cmd| draw(d, cmd, pass));
                    timer.end(cmd, t);
                    let t = timer.begin(cmd, "accumulate");
                    self.record_accumulate(d, cmd, weight);
                    timer.end(cmd, t);
                }
                if ci + 1 == n_chunks {
                    Ok(Some(record_readback(
                        d,
                        cmd,
                        &self.accum,
                        vk::ImageLayout::GENERAL,
                        (vk::PipelineStageFlags2::COMPUTE_SHADER, vk::AccessFlags2::SHADER_STORAGE_WRITE),
                    )?))
                } else {
                    Ok(None)
                }
            })?;
            for (name, ms) in timer.results()?.passes {
                match timings.passes.iter_mut().find(|(n, _)| *n == name) {
                    Some((_, acc)) => *acc += ms,
                    None => timings.passes.push((name, ms)),
                }
            }
        }
        let buffer = readback.ok_or_else(|| crate::Error::Unsupported("no passes to render".into()))?;
        let (w, h) = (self.resolved.desc.width, self.resolved.desc.height);
        Ok((read_rgba32f(&buffer, w, h)?, timings))
    }

    fn clear_accumulator(&self, d: &Device, cmd: vk::CommandBuffer) {
        image_barriers(
            d,
            cmd,
            &[barrier(
                &self.accum,
                vk::ImageLayout::UNDEFINED,
                vk::ImageLayout::GENERAL,
                (vk::PipelineStageFlags2::NONE, vk::AccessFlags2::NONE),
                (vk::PipelineStageFlags2::CLEAR, vk::AccessFlags2::TRANSFER_WRITE),
            )],
        );
        let zero = vk::ClearColorValue { float32: [0.0; 4] };
        unsafe {
            d.raw.cmd_clear_color_image(
                cmd,
                self.accum.raw,
                vk::ImageLayout::GENERAL,
                &zero,
                &[self.accum.full_range()],
            )
        };
        image_barriers(
            d,
            cmd,
            &[barrier(
                &self.accum,
                vk::ImageLayout::GENERAL,
                vk::ImageLayout::GENERAL,
                (vk::PipelineStageFlags2::CLEAR, vk::AccessFlags2::TRANSFER_WRITE),
                (
                    vk::PipelineStageFlags2::COMPUTE_SHADER,
                    vk::AccessFlags2::SHADER_STORAGE_READ | vk::AccessFlags2::SHADER_STORAGE_WRITE,
                ),
            )],
        );
    }

    /// One forward pass into `resolved` (layout GENERAL afterwards, ready for the compute read).
    fn record_pass(
        &self,
        d: &Device,
        cmd: vk::CommandBuffer,
        background: [f32; 4],
        label: &str,
        draw: &mut dyn FnMut(&Device, vk::CommandBuffer),
    ) {
        d.begin_label(cmd, label);
        let color_write =
            (vk::PipelineStageFlags2::COLOR_ATTACHMENT_OUTPUT, vk::AccessFlags2::COLOR_ATTACHMENT_WRITE);
        let depth_access = (
            vk::PipelineStageFlags2::EARLY_FRAGMENT_TESTS | vk::PipelineStageFlags2::LATE_FRAGMENT_TESTS,
            vk::AccessFlags2::DEPTH_STENCIL_ATTACHMENT_WRITE
                | vk::AccessFlags2::DEPTH_STENCIL_ATTACHMENT_READ,
        );
        // The previous pass' accumulate read `resolved`; its contents are discarded (UNDEFINED).
        let mut barriers = vec![
            barrier(
                &self.resolved,
                vk::ImageLayout::UNDEFINED,
                vk::ImageLayout::COLOR_ATTACHMENT_OPTIMAL,
                (vk::PipelineStageFlags2::COMPUTE_SHADER, vk::AccessFlags2::SHADER_STORAGE_READ),
                color_write,
            ),
            barrier(
                &self.depth,
                vk::ImageLayout::UNDEFINED,
                vk::ImageLayout::DEPTH_ATTACHMENT_OPTIMAL,
                depth_access,
                depth_access,
            ),
        ];
        if let Some(ms) = &self.color_ms {
            barriers.push(barrier(
                ms,
                vk::ImageLayout::UNDEFINED,
                vk::ImageLayout::COLOR_ATTACHMENT_OPTIMAL,
                color_write,
                color_write,
            ));
        }
        image_barriers(d, cmd, &barriers);

        let clear = vk::ClearValue { color: vk::ClearColorValue { float32: background } };
        let color_attachment = match &self.color_ms {
            Some(ms) => vk::RenderingAttachmentInfo::default()
                .image_view(ms.view)
                .image_layout(vk::ImageLayout::COLOR_ATTACHMENT_OPTIMAL)
                .resolve_mode(vk::ResolveModeFlags::AVERAGE)
                .resolve_image_view(self.resolved.view)
                .resolve_image_layout(vk::ImageLayout::COLOR_ATTACHMENT_OPTIMAL)
                .load_op(vk::AttachmentLoadOp::CLEAR)
                .store_op(vk::AttachmentStoreOp::DONT_CARE)
                .clear_value(clear),
            None => vk::RenderingAttachmentInfo::default()
                .image_view(self.resolved.view)
                .image_layout(vk::ImageLayout::COLOR_ATTACHMENT_OPTIMAL)
                .load_op(vk::AttachmentLoadOp::CLEAR)
                .store_op(vk::AttachmentStoreOp::STORE)
                .clear_value(clear),
        };
        let color_attachments = [color_attachment];
        let depth_attachment = vk::RenderingAttachmentInfo::default()
            .image_view(self.depth.view)
            .image_layout(vk::ImageLayout::DEPTH_ATTACHMENT_OPTIMAL)
            .load_op(vk::AttachmentLoadOp::CLEAR)
            .store_op(vk::AttachmentStoreOp::DONT_CARE)
            .clear_value(vk::ClearValue {
                depth_stencil: vk::ClearDepthStencilValue { depth: 0.0, stencil: 0 },
            });
        let area = vk::Rect2D { offset: vk::Offset2D::default(), extent: self.resolved.extent_2d() };
        let info = vk::RenderingInfo::default()
            .render_area(area)
            .layer_count(1)
            .color_attachments(&color_attachments)
            .depth_attachment(&depth_attachment);
        unsafe {
            d.raw.cmd_begin_rendering(cmd, &info);
            let viewport = vk::Viewport {
                x: 0.0,
                y: 0.0,
                width: self.resolved.desc.width as f32,
                height: self.resolved.desc.height as f32,
                min_depth: 0.0,
                max_depth: 1.0,
            };
            d.raw.cmd_set_viewport(cmd, 0, &[viewport]);
            d.raw.cmd_set_scissor(cmd, 0, &[area]);
        }
        draw(d, cmd);
        unsafe {
            d.raw.cmd_end_rendering(cmd);
        }
        // Resolve (or direct) writes happen in COLOR_ATTACHMENT_OUTPUT; the compute pass reads them.
        image_barriers(
            d,
            cmd,
            &[barrier(
                &self.resolved,
                vk::ImageLayout::COLOR_ATTACHMENT_OPTIMAL,
                vk::ImageLayout::GENERAL,
                color_write,
                (vk::PipelineStageFlags2::COMPUTE_SHADER, vk::AccessFlags2::SHADER_STORAGE_READ),
            )],
        );
        d.end_label(cmd);
    }

    /// `accum += weight · resolved`.
    fn record_accumulate(&self, d: &Device, cmd: vk::CommandBuffer, weight: f32) {
        d.begin_label(cmd, "accumulate");
        unsafe {
            d.raw.cmd_bind_pipeline(cmd, vk::PipelineBindPoint::COMPUTE, self.accumulate.raw);
            d.raw.cmd_bind_descriptor_sets(
                cmd,
                vk::PipelineBindPoint::COMPUTE,
                self.accumulate_layout.raw,
                0,
                &[self.accumulate_set],
                &[],
            );
            d.raw.cmd_push_constants(
                cmd,
                self.accumulate_layout.raw,
                vk::ShaderStageFlags::COMPUTE,
                0,
                as_bytes(&weight),
            );
            d.raw.cmd_dispatch(cmd, self.accum.desc.width.div_ceil(8), self.accum.desc.height.div_ceil(8), 1);
        }
        // The next accumulate reads and writes `accum` again.
        crate::vk::memory_barrier(
            d,
            cmd,
            (vk::PipelineStageFlags2::COMPUTE_SHADER, vk::AccessFlags2::SHADER_STORAGE_WRITE),
            (
                vk::PipelineStageFlags2::COMPUTE_SHADER,
                vk::AccessFlags2::SHADER_STORAGE_READ | vk::AccessFlags2::SHADER_STORAGE_WRITE,
            ),
        );
        d.end_label(cmd);
    }
}
