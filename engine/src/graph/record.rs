//! What a pass records, through its [`PassContext`]: the typed commands a technique's passes use, so
//! the one `unsafe` of raw command recording is here, next to the contract that makes it sound,
//! instead of in every technique.
//!
//! Each method records one Vulkan command into the pass' command buffer. What the executor
//! guarantees (the command buffer is recording; inside a raster pass, rendering over its attachments
//! has begun) is the first half of [`PassContext`]'s contract. The second half is checked here where
//! it can be:
//!
//! * **Pipelines and layouts** are the engine's RAII wrappers ([`Pipeline`], [`PipelineLayout`]) and
//!   must belong to this pass' device (checked). A pass that records them borrows their owner (the
//!   technique), which outlives the graph's execution.
//! * **Push constants** go through the layout they are pushed to: the stages are the layout's own
//!   range's, and the value must fit in that range (checked: an overflow panics with the sizes, a bug
//!   in the technique, never input).
//! * **Descriptor sets** must lie within the layout's sets (checked) and have been allocated from the
//!   layouts it was built with — not checked here: the set layouts are reflected against every
//!   compiled shader permutation by `gpu/layout_tests.rs`, and every test runs with the validation
//!   layer, which reports an incompatible set.
//! * **Graph resources a draw or dispatch reads through its descriptor sets** must be declared by the
//!   pass (checked at each [`PassContext::draw`], [`PassContext::draw_indexed`],
//!   [`PassContext::dispatch`] and [`PassContext::dispatch_indirect`] after a pipeline or a set
//!   changed): every buffer and image view Shutter writes into a set is recorded per binding
//!   ([`crate::vk::DescriptorRefs`]), every pipeline knows the (set, binding) pairs its shaders
//!   statically use ([`crate::vk::statically_used_descriptors`]), and a used binding that reaches a
//!   resource of this graph the pass did not declare panics with the pipeline, the binding and the
//!   resource. So a set is written once, at prepare time, and what the pass reads through it is
//!   declared once, on the pass; the check keeps the two from drifting apart (a forgotten declaration
//!   is a missing barrier). A binding the bound pipeline does not use is not an access and is not
//!   checked. Not matched: an image bound through a view other than its own
//!   [`crate::vk::Image::view`] (one mip level of an atlas), and resources outside the graph (the
//!   world, the views, the sample tables the host wrote before the frame).
//! * **Graph resources a command names** ([`PassContext::fill_buffer`],
//!   [`PassContext::dispatch_indirect`], [`PassContext::copy_buffer_to_image`]) must have been
//!   declared by the pass with the access the command makes (checked), so their barriers and layouts
//!   are the graph's: a pass cannot touch a resource it did not declare through these.
//!
//! A technique that needs a command not offered here records it raw on [`PassContext::cmd`], under
//! the contract written on [`PassContext`], with a `// SAFETY:` line.

use ash::vk;

use super::{Access, BufferHandle, ImageHandle, PassContext, ResourceHandle};
use crate::vk::{Buffer, DescriptorRef, Pipeline, PipelineLayout};

/// What is bound at each bind point of a pass' command buffer, as far as the declared-access check
/// needs: the pipeline's name and statically used descriptors, the sets by index, and whether that
/// combination was checked since it last changed.
#[derive(Default)]
pub(super) struct Bound {
    graphics: BoundPoint,
    compute: BoundPoint,
}

#[derive(Default)]
struct BoundPoint {
    pipeline: Option<(String, Vec<(u32, u32)>)>,
    sets: Vec<Option<vk::DescriptorSet>>,
    checked: bool,
}

impl Bound {
    fn point(&mut self, bind_point: vk::PipelineBindPoint) -> &mut BoundPoint {
        if bind_point == vk::PipelineBindPoint::COMPUTE {
            &mut self.compute
        } else {
            &mut self.graphics
        }
    }
}

impl PassContext<'_> {
    /// Panics if the pipeline bound at `bind_point` reads, through a set bound there, a resource of
    /// this graph the pass did not declare (module docs); once per change of pipeline or sets.
    fn expect_reads_declared(&self, bind_point: vk::PipelineBindPoint, command: &str) {
        let mut bound = self.bound.borrow_mut();
        let point = bound.point(bind_point);
        if point.checked {
            return;
        }
        point.checked = true;
        let Some((pipeline, used)) = &point.pipeline else { return };
        for &(set_index, binding) in used {
            let Some(Some(set)) = point.sets.get(set_index as usize) else { continue };
            let refs = self.device.descriptor_refs.of(*set);
            let Some((_, what)) = refs.iter().find(|(b, _)| *b == binding) else { continue };
            let resource = self.resources.iter().position(|r| match *what {
                DescriptorRef::Buffer(b) => r.buffer().is_some_and(|buf| buf.raw == b),
                DescriptorRef::View(v) => r.image().is_some_and(|img| img.view == v),
            });
            if let Some(resource) = resource {
                assert!(
                    self.uses.iter().any(|u| u.resource == resource),
                    "{command}: pipeline `{pipeline}` reads set {set_index}, binding {binding}: `{}`, which the \
                     pass did not declare",
                    self.resources[resource].name
                );
            }
        }
    }

    /// Whether this pass declared `resource` with `access`.
    fn declared(&self, resource: ResourceHandle, access: Access) -> bool {
        let index = resource.index();
        self.uses.iter().any(|u| u.resource == index && u.accesses.contains(&access))
    }

    fn expect_declared(&self, resource: ResourceHandle, access: Access, command: &str) {
        assert!(
            self.declared(resource, access),
            "{command}: the pass did not declare `{}` with {access:?}",
            self.resources[resource.index()].name
        );
    }

    /// Binds `pipeline` at its bind point.
    pub fn bind_pipeline(&self, pipeline: &Pipeline) {
        assert!(pipeline.belongs_to(self.device), "a pipeline of another device");
        {
            let mut bound = self.bound.borrow_mut();
            let point = bound.point(pipeline.bind_point);
            point.pipeline = Some((pipeline.name.clone(), pipeline.used_descriptors.clone()));
            point.checked = false;
        }
        // SAFETY: the executor's half of the contract of `PassContext` (recording state); the
        // pipeline is live and of this device (checked above).
        unsafe { self.device.raw.cmd_bind_pipeline(self.cmd, pipeline.bind_point, pipeline.raw) };
    }

    /// Binds `sets` as sets `first..` of `layout` for `bind_point` (what the next draw or dispatch
    /// reads through them is checked against the pass' declarations then: module docs).
    pub fn bind_sets(
        &self,
        bind_point: vk::PipelineBindPoint,
        layout: &PipelineLayout,
        first: u32,
        sets: &[vk::DescriptorSet],
    ) {
        assert!(layout.belongs_to(self.device), "a pipeline layout of another device");
        assert!(
            first as usize + sets.len() <= layout.set_count() as usize,
            "sets {first}..{} beyond the layout's {}",
            first as usize + sets.len(),
            layout.set_count()
        );
        {
            let mut bound = self.bound.borrow_mut();
            let point = bound.point(bind_point);
            for (i, set) in sets.iter().enumerate() {
                let index = first as usize + i;
                if point.sets.len() <= index {
                    point.sets.resize(index + 1, None);
                }
                point.sets[index] = Some(*set);
            }
            point.checked = false;
        }
        // SAFETY: the contract of `PassContext`; the range of sets lies in the layout (checked);
        // their compatibility with it is the layout tests' and the validation layer's (module docs).
        unsafe {
            self.device.raw.cmd_bind_descriptor_sets(self.cmd, bind_point, layout.raw, first, sets, &[])
        };
    }

    /// Pushes `value` at offset 0 of `layout`'s push-constant range, for the range's stages.
    pub fn push<T: bytemuck::Pod>(&self, layout: &PipelineLayout, value: &T) {
        self.push_bytes(layout, bytemuck::bytes_of(value));
    }

    /// Pushes `bytes` at offset 0 of `layout`'s push-constant range (a stage's push built at run time).
    pub fn push_bytes(&self, layout: &PipelineLayout, bytes: &[u8]) {
        assert!(layout.belongs_to(self.device), "a pipeline layout of another device");
        assert!(
            bytes.len() as u32 <= layout.push_bytes(),
            "{} push-constant bytes into a range of {}",
            bytes.len(),
            layout.push_bytes()
        );
        // SAFETY: the contract of `PassContext`; the bytes lie in the layout's one range and the stages
        // are that range's (checked above).
        unsafe { self.device.raw.cmd_push_constants(self.cmd, layout.raw, layout.push_stages(), 0, bytes) };
    }

    /// Dispatches `x × y × z` workgroups of the bound compute pipeline.
    pub fn dispatch(&self, x: u32, y: u32, z: u32) {
        self.expect_reads_declared(vk::PipelineBindPoint::COMPUTE, "dispatch");
        // SAFETY: the contract of `PassContext`.
        unsafe { self.device.raw.cmd_dispatch(self.cmd, x, y, z) };
    }

    /// Dispatches the bound compute pipeline with the workgroup counts at `offset` of `args`, which
    /// the pass declared as [`Access::IndirectBuffer`].
    pub fn dispatch_indirect(&self, args: BufferHandle, offset: u64) {
        self.expect_declared(args.into(), Access::IndirectBuffer, "dispatch_indirect");
        self.expect_reads_declared(vk::PipelineBindPoint::COMPUTE, "dispatch_indirect");
        // SAFETY: the contract of `PassContext`; the buffer is the pass' declared indirect source.
        unsafe { self.device.raw.cmd_dispatch_indirect(self.cmd, self.buffer(args).raw, offset) };
    }

    /// Draws `vertices` vertices, `instances` instances, of the bound graphics pipeline (no vertex
    /// buffers: the shaders fetch what they need).
    pub fn draw(&self, vertices: u32, instances: u32) {
        self.expect_reads_declared(vk::PipelineBindPoint::GRAPHICS, "draw");
        // SAFETY: the contract of `PassContext` (inside a raster pass' rendering).
        unsafe { self.device.raw.cmd_draw(self.cmd, vertices, instances, 0, 0) };
    }

    /// Draws `x × y × z` workgroups of the bound mesh-shader pipeline (`vkCmdDrawMeshTasksEXT`; no
    /// task shader). Panics on a device without [`crate::vk::Capabilities::mesh_shader`]: a technique
    /// refuses `--hull mesh` there before recording.
    pub fn draw_mesh_tasks(&self, x: u32, y: u32, z: u32) {
        self.expect_reads_declared(vk::PipelineBindPoint::GRAPHICS, "draw_mesh_tasks");
        let mesh =
            self.device.mesh_shader_device.as_ref().expect("a mesh-shader draw on a device without them");
        // SAFETY: the contract of `PassContext` (inside a raster pass' rendering).
        unsafe { mesh.cmd_draw_mesh_tasks(self.cmd, x, y, z) };
    }

    /// Draws `indices` indices of `index_buffer` (u32) over `vertex_buffer`, instances
    /// `first_instance..first_instance + instances`. Both buffers are scene geometry the host wrote
    /// before the frame (read-only on the GPU: no declaration needed).
    pub fn draw_indexed(
        &self,
        (vertex_buffer, index_buffer): (&Buffer, &Buffer),
        indices: u32,
        instances: u32,
        first_instance: u32,
    ) {
        self.expect_reads_declared(vk::PipelineBindPoint::GRAPHICS, "draw_indexed");
        // SAFETY: the contract of `PassContext` (inside a raster pass' rendering); the buffers are live
        // for the call and, being the world's, for the graph's execution.
        unsafe {
            self.device.raw.cmd_bind_vertex_buffers(self.cmd, 0, &[vertex_buffer.raw], &[0]);
            self.device.raw.cmd_bind_index_buffer(self.cmd, index_buffer.raw, 0, vk::IndexType::UINT32);
            self.device.raw.cmd_draw_indexed(self.cmd, indices, instances, 0, 0, first_instance);
        }
    }

    /// Sets the cull mode of a pipeline with the dynamic cull-mode state.
    pub fn set_cull_mode(&self, cull: vk::CullModeFlags) {
        // SAFETY: the contract of `PassContext`.
        unsafe { self.device.raw.cmd_set_cull_mode(self.cmd, cull) };
    }

    /// Viewport and scissor to `area` (depth 0–1): one map's square of an atlas.
    pub fn set_viewport(&self, area: vk::Rect2D) {
        crate::vk::set_viewport(self.device, self.cmd, area);
    }

    /// Fills `buffer`, which the pass declared as [`Access::TransferWrite`], with the word `value`.
    pub fn fill_buffer(&self, buffer: BufferHandle, value: u32) {
        self.expect_declared(buffer.into(), Access::TransferWrite, "fill_buffer");
        // SAFETY: the contract of `PassContext`; the pass declared the transfer write.
        unsafe {
            self.device.raw.cmd_fill_buffer(self.cmd, self.buffer(buffer).raw, 0, vk::WHOLE_SIZE, value)
        };
    }

    /// Copies `regions` of `src`, declared [`Access::TransferRead`], into `dst`, declared
    /// [`Access::TransferWrite`] (so in `TRANSFER_DST_OPTIMAL`).
    pub fn copy_buffer_to_image(&self, src: BufferHandle, dst: ImageHandle, regions: &[vk::BufferImageCopy]) {
        self.expect_declared(src.into(), Access::TransferRead, "copy_buffer_to_image");
        self.expect_declared(dst.into(), Access::TransferWrite, "copy_buffer_to_image");
        // SAFETY: the contract of `PassContext`; both resources were declared with these accesses, so
        // the graph put `dst` in TRANSFER_DST_OPTIMAL.
        unsafe {
            self.device.raw.cmd_copy_buffer_to_image(
                self.cmd,
                self.buffer(src).raw,
                self.image(dst).raw,
                vk::ImageLayout::TRANSFER_DST_OPTIMAL,
                regions,
            )
        };
    }

    /// A global barrier from compute shaders' storage writes to `dst_stages`' `dst_access`, between
    /// consecutive dispatches inside this pass (the graph orders passes, not the commands of one).
    pub fn compute_write_barrier(&self, dst_stages: vk::PipelineStageFlags2, dst_access: vk::AccessFlags2) {
        crate::vk::compute_write_barrier(self.device, self.cmd, dst_stages, dst_access);
    }
}
