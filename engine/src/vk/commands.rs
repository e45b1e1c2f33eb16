//! Command recording and submission. Every submission is waited on before returning: Shutter renders
//! offline frames and measures them, so CPU/GPU overlap is not worth the lifetime bookkeeping it costs,
//! and RAII wrappers can free their handles in `Drop` safely.

use ash::vk;

use super::Device;
use crate::error::{Result, VkContext};

/// A command pool with one primary command buffer, reused for each submission.
pub struct CommandRecorder {
    pool: vk::CommandPool,
    cmd: vk::CommandBuffer,
    fence: vk::Fence,
    device: Device,
}

impl CommandRecorder {
    pub fn new(device: &Device, name: &str) -> Result<Self> {
        let info = vk::CommandPoolCreateInfo::default()
            .queue_family_index(device.queue_family)
            .flags(vk::CommandPoolCreateFlags::RESET_COMMAND_BUFFER);
        let pool = unsafe { device.raw.create_command_pool(&info, None) }.vk("vkCreateCommandPool")?;
        // Owned from here on so an error below still destroys the pool.
        let mut rec = CommandRecorder {
            pool,
            cmd: vk::CommandBuffer::null(),
            fence: vk::Fence::null(),
            device: device.clone(),
        };
        let alloc = vk::CommandBufferAllocateInfo::default()
            .command_pool(pool)
            .level(vk::CommandBufferLevel::PRIMARY)
            .command_buffer_count(1);
        rec.cmd = unsafe { device.raw.allocate_command_buffers(&alloc) }.vk("vkAllocateCommandBuffers")?[0];
        rec.fence =
            unsafe { device.raw.create_fence(&vk::FenceCreateInfo::default(), None) }.vk("vkCreateFence")?;
        device.set_name(rec.cmd, name);
        Ok(rec)
    }

    /// Records with `f`, submits, and waits for completion. Returns what `f` returned.
    pub fn submit<R>(&mut self, f: impl FnOnce(&Device, vk::CommandBuffer) -> Result<R>) -> Result<R> {
        let d = &self.device;
        unsafe {
            d.raw
                .reset_command_buffer(self.cmd, vk::CommandBufferResetFlags::empty())
                .vk("vkResetCommandBuffer")?;
            d.raw
                .begin_command_buffer(
                    self.cmd,
                    &vk::CommandBufferBeginInfo::default()
                        .flags(vk::CommandBufferUsageFlags::ONE_TIME_SUBMIT),
                )
                .vk("vkBeginCommandBuffer")?;
        }
        let out = f(d, self.cmd);
        unsafe { d.raw.end_command_buffer(self.cmd) }.vk("vkEndCommandBuffer")?;
        let out = out?;
        let cmds = [vk::CommandBufferSubmitInfo::default().command_buffer(self.cmd)];
        let submit = [vk::SubmitInfo2::default().command_buffer_infos(&cmds)];
        {
            let _q = d.queue_lock.lock().expect("queue lock poisoned");
            unsafe { d.raw.queue_submit2(d.queue, &submit, self.fence) }.vk("vkQueueSubmit2")?;
        }
        unsafe {
            d.raw.wait_for_fences(&[self.fence], true, u64::MAX).vk("vkWaitForFences")?;
            d.raw.reset_fences(&[self.fence]).vk("vkResetFences")?;
        }
        Ok(out)
    }
}

impl Drop for CommandRecorder {
    fn drop(&mut self) {
        unsafe {
            if self.fence != vk::Fence::null() {
                self.device.raw.destroy_fence(self.fence, None);
            }
            self.device.raw.destroy_command_pool(self.pool, None);
        }
    }
}

/// Viewport and scissor both set to `area` (depth range 0–1): the whole render area, or one map's
/// square in an atlas.
pub fn set_viewport(device: &Device, cmd: vk::CommandBuffer, area: vk::Rect2D) {
    let viewport = vk::Viewport {
        x: area.offset.x as f32,
        y: area.offset.y as f32,
        width: area.extent.width as f32,
        height: area.extent.height as f32,
        min_depth: 0.0,
        max_depth: 1.0,
    };
    unsafe {
        device.raw.cmd_set_viewport(cmd, 0, &[viewport]);
        device.raw.cmd_set_scissor(cmd, 0, &[area]);
    }
}

/// A `size`² square of an atlas at `(x, y)`.
pub fn atlas_square(x: u32, y: u32, size: u32) -> vk::Rect2D {
    vk::Rect2D {
        offset: vk::Offset2D { x: x as i32, y: y as i32 },
        extent: vk::Extent2D { width: size, height: size },
    }
}

/// One global barrier from compute shaders' storage writes to the `dst_stages` accesses
/// `dst_access`: consecutive dispatches inside one graph pass.
pub fn compute_write_barrier(
    device: &Device,
    cmd: vk::CommandBuffer,
    dst_stages: vk::PipelineStageFlags2,
    dst_access: vk::AccessFlags2,
) {
    let b = vk::MemoryBarrier2::default()
        .src_stage_mask(vk::PipelineStageFlags2::COMPUTE_SHADER)
        .src_access_mask(vk::AccessFlags2::SHADER_STORAGE_WRITE)
        .dst_stage_mask(dst_stages)
        .dst_access_mask(dst_access);
    let dep = vk::DependencyInfo::default().memory_barriers(std::slice::from_ref(&b));
    unsafe { device.raw.cmd_pipeline_barrier2(cmd, &dep) };
}

/// One pipeline barrier with the given image barriers (synchronization2).
pub fn image_barriers(device: &Device, cmd: vk::CommandBuffer, barriers: &[vk::ImageMemoryBarrier2]) {
    let dep = vk::DependencyInfo::default().image_memory_barriers(barriers);
    unsafe { device.raw.cmd_pipeline_barrier2(cmd, &dep) };
}
