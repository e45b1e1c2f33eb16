//! Sample `embed_existing_device`: an engine that owns its Vulkan device lends it to Shutter, records
//! a stochastic frame into its own command buffer, submits it itself and reads its own image back.
//!
//! Everything Vulkan here is the "engine's": instance, device, queue, command pool, fence, target
//! image and readback buffer. Shutter gets borrowed handles ([`Ownership::Borrowed`]) and destroys
//! none of them; its frame ends in the engine's image with the access the engine asked for, and
//! Shutter neither submits the frame nor waits on it.

use std::ffi::{c_char, CStr};

use anyhow::{anyhow, bail, Context, Result};
use shutter::ash::{self, vk};
use shutter::prelude::*;
use shutter::vk::{drivers, parse_env_flag};

const VALIDATION_LAYER: &CStr = c"VK_LAYER_KHRONOS_validation";

/// What the engine got: its image as it read it back, the passes Shutter recorded, and the driver
/// as Shutter names it (`lavapipe-25.0`).
pub struct EmbeddedFrame {
    pub image: LinearImage,
    pub passes: Vec<String>,
    pub driver: String,
}

/// Renders `scene` (its `[image]` size, samples and seed) with technique `stochastic` on a device
/// this function creates, in a command buffer it records and submits, into an `R32G32B32A32_SFLOAT`
/// image it owns and reads back. Validation: the Khronos layer is enabled as the engine's own
/// device does it (`SHUTTER_VALIDATION`, on by default in debug builds; `SHUTTER_SYNC_VALIDATION`),
/// with `VK_EXT_debug_utils`, so Shutter's messenger counts every message and a message is an error.
/// The device is the one Shutter would choose (`SHUTTER_DRIVER`, `SHUTTER_DEVICE`), so the image can
/// be compared with Shutter's own render.
pub fn embed_existing_device(scene: &Scene) -> Result<EmbeddedFrame> {
    // Declared first, dropped last: the engine's objects outlive every Shutter object below.
    let engine = Engine::new()?;
    let (width, height) = (scene.image.width, scene.image.height);
    let frame = engine.frame_resources(width, height)?;

    // 1. Lend the device. Shutter checks what it needs against what the engine says it enabled.
    let lent = ExternalDevice {
        entry: engine.entry.clone(),
        instance: engine.instance.clone(),
        instance_api_version: vk::API_VERSION_1_3,
        physical_device: engine.physical,
        device: engine.device.clone(),
        queue: engine.queue,
        queue_family: engine.queue_family,
        features: engine.features,
        features12: engine.features12,
        features13: engine.features13,
        device_extensions: Vec::new(),
        mesh_shader: false,
        task_shader: false,
        debug_utils: engine.debug_utils,
        validation_layer: engine.validation,
        ownership: Ownership::Borrowed,
    };
    // SAFETY: the handles are the engine's, created as listed above, and `engine` outlives every
    // Shutter object (declared first); nothing else submits to the queue meanwhile.
    let device = unsafe { lent.into_device() }?;
    let mut renderer = Renderer::new(device.clone())?;

    // 2. Upload the scene and build the stochastic frame's pipelines (Shutter submits the uploads).
    let settings = RenderSettings::from_scene(scene);
    let mut prepared = EmbeddedScene::prepare(&mut renderer, scene, Technique::STOCHASTIC, &settings)?;

    // 3. The engine's frame: Shutter's commands, then the engine's own copy of its image.
    let d = &engine.device;
    unsafe {
        d.begin_command_buffer(
            frame.cmd,
            &vk::CommandBufferBeginInfo::default().flags(vk::CommandBufferUsageFlags::ONE_TIME_SUBMIT),
        )?
    };
    let target = FrameTarget {
        image: frame.image,
        format: vk::Format::R32G32B32A32_SFLOAT,
        width,
        height,
        before: Access::Nothing,
        // The engine copies it out next (a compositor would sample it instead).
        after: Access::TransferRead,
    };
    // SAFETY: `cmd` is recording, from a pool of the queue family; `image` matches `target` and lives
    // until the frame is retired; the engine submits `cmd` once and retires after the fence.
    let token = unsafe { prepared.record(frame.cmd, &target) }?;
    frame.record_readback(d, width, height);
    unsafe { d.end_command_buffer(frame.cmd)? };

    // 4. The engine submits and waits: its fence, its queue.
    let cmds = [vk::CommandBufferSubmitInfo::default().command_buffer(frame.cmd)];
    let submit = [vk::SubmitInfo2::default().command_buffer_infos(&cmds)];
    unsafe {
        d.queue_submit2(engine.queue, &submit, frame.fence)?;
        d.wait_for_fences(&[frame.fence], true, u64::MAX)?;
    }
    // The frame has executed: Shutter may reuse what it used.
    let passes = token.passes().to_vec();
    prepared.retire(token)?;

    // 5. The engine reads its own buffer.
    let image = frame.read(d, width, height)?;
    // Every validation message on the engine's instance since Shutter's messenger exists.
    device.check_validation()?;
    let driver = device.caps.driver_key.clone();
    drop(prepared);
    drop(renderer);
    drop(device);
    drop(frame);
    drop(engine);
    Ok(EmbeddedFrame { image, passes, driver })
}

/// The engine's instance and device.
struct Engine {
    entry: ash::Entry,
    instance: ash::Instance,
    physical: vk::PhysicalDevice,
    device: ash::Device,
    queue: vk::Queue,
    queue_family: u32,
    features: vk::PhysicalDeviceFeatures,
    features12: vk::PhysicalDeviceVulkan12Features<'static>,
    features13: vk::PhysicalDeviceVulkan13Features<'static>,
    validation: bool,
    debug_utils: bool,
}

impl Engine {
    fn new() -> Result<Engine> {
        // A real engine picks its own driver. This one offers the loader the project's lavapipe as
        // Shutter does (before any instance exists), so the device it picks below is the one
        // Shutter's own render uses, and the test can compare the two images.
        drivers::offer_project_drivers()?;
        let flag = |name: &'static str| -> Result<Option<bool>> {
            Ok(match std::env::var(name) {
                Ok(v) => parse_env_flag(name, &v)?,
                Err(_) => None,
            })
        };
        let want_validation = flag("SHUTTER_VALIDATION")?.unwrap_or(cfg!(debug_assertions));
        let sync_validation = flag("SHUTTER_SYNC_VALIDATION")?.unwrap_or(false);
        // SAFETY: loading the system's Vulkan loader.
        let entry = unsafe { ash::Entry::load() }.context("loading Vulkan")?;
        let layers = unsafe { entry.enumerate_instance_layer_properties()? };
        let has_layer = layers.iter().any(|l| l.layer_name_as_c_str().ok() == Some(VALIDATION_LAYER));
        if want_validation && !has_layer {
            bail!("validation requested but VK_LAYER_KHRONOS_validation is not installed (vulkan-validationlayers)");
        }
        let validation = want_validation;
        let layer_ptrs: Vec<*const c_char> =
            if validation { vec![VALIDATION_LAYER.as_ptr()] } else { vec![] };
        // debug utils with validation: Shutter adds its counting messenger on this instance.
        let ext_ptrs: Vec<*const c_char> =
            if validation { vec![ash::ext::debug_utils::NAME.as_ptr()] } else { vec![] };
        let app = vk::ApplicationInfo::default()
            .application_name(c"embed_existing_device")
            .api_version(vk::API_VERSION_1_3);
        let enabled = [vk::ValidationFeatureEnableEXT::SYNCHRONIZATION_VALIDATION];
        let mut features = vk::ValidationFeaturesEXT::default().enabled_validation_features(&enabled);
        let mut info = vk::InstanceCreateInfo::default()
            .application_info(&app)
            .enabled_layer_names(&layer_ptrs)
            .enabled_extension_names(&ext_ptrs);
        if validation && sync_validation {
            info = info.push_next(&mut features);
        }
        let instance = unsafe { entry.create_instance(&info, None)? };
        match Self::with_instance(entry, instance.clone(), validation) {
            Ok(e) => Ok(e),
            Err(e) => {
                unsafe { instance.destroy_instance(None) };
                Err(e)
            }
        }
    }

    /// The device on `instance`: the one `SHUTTER_DRIVER` / `SHUTTER_DEVICE` name, else the best by
    /// type and then the newest driver (Shutter's choice).
    fn with_instance(entry: ash::Entry, instance: ash::Instance, validation: bool) -> Result<Engine> {
        let wanted_driver = std::env::var("SHUTTER_DRIVER").ok().filter(|s| !s.is_empty());
        let wanted_name =
            std::env::var("SHUTTER_DEVICE").ok().filter(|s| !s.is_empty()).map(|s| s.to_lowercase());
        let mut candidates = Vec::new();
        for physical in unsafe { instance.enumerate_physical_devices()? } {
            let mut driver = vk::PhysicalDeviceDriverProperties::default();
            let mut props2 = vk::PhysicalDeviceProperties2::default().push_next(&mut driver);
            unsafe { instance.get_physical_device_properties2(physical, &mut props2) };
            let props = props2.properties;
            let name = props.device_name_as_c_str()?.to_string_lossy().into_owned();
            let id = format!("{:?}", driver.driver_id);
            let info = driver.driver_info_as_c_str()?.to_string_lossy().into_owned();
            if wanted_driver.as_deref().is_some_and(|w| !drivers::driver_matches(w, &id, &name, &info)) {
                continue;
            }
            if wanted_name.as_deref().is_some_and(|w| !name.to_lowercase().contains(w)) {
                continue;
            }
            let rank = match props.device_type {
                vk::PhysicalDeviceType::DISCRETE_GPU => 0,
                vk::PhysicalDeviceType::INTEGRATED_GPU => 1,
                vk::PhysicalDeviceType::VIRTUAL_GPU => 2,
                vk::PhysicalDeviceType::CPU => 3,
                _ => 4,
            };
            candidates.push((rank, drivers::driver_version(&info), physical));
        }
        candidates.sort_by(|a, b| a.0.cmp(&b.0).then_with(|| drivers::version_cmp(&b.1, &a.1)));
        let &(_, _, physical) = candidates
            .first()
            .ok_or_else(|| anyhow!("no Vulkan device matches SHUTTER_DRIVER / SHUTTER_DEVICE"))?;
        let families = unsafe { instance.get_physical_device_queue_family_properties(physical) };
        let queue_family = families
            .iter()
            .position(|f| f.queue_flags.contains(vk::QueueFlags::GRAPHICS | vk::QueueFlags::COMPUTE))
            .ok_or_else(|| anyhow!("no graphics + compute queue"))? as u32;

        // What technique `stochastic` needs (Shutter refuses, naming it, if one is left off).
        let features = vk::PhysicalDeviceFeatures::default()
            .geometry_shader(true)
            .fragment_stores_and_atomics(true)
            .shader_int64(true);
        let features12 = vk::PhysicalDeviceVulkan12Features::default().shader_buffer_int64_atomics(true);
        let features13 =
            vk::PhysicalDeviceVulkan13Features::default().dynamic_rendering(true).synchronization2(true);
        let (mut enable12, mut enable13) = (features12, features13);
        let priorities = [1.0f32];
        let queues = [vk::DeviceQueueCreateInfo::default()
            .queue_family_index(queue_family)
            .queue_priorities(&priorities)];
        let info = vk::DeviceCreateInfo::default()
            .queue_create_infos(&queues)
            .enabled_features(&features)
            .push_next(&mut enable12)
            .push_next(&mut enable13);
        let device = unsafe { instance.create_device(physical, &info, None)? };
        let queue = unsafe { device.get_device_queue(queue_family, 0) };
        Ok(Engine {
            entry,
            instance,
            physical,
            device,
            queue,
            queue_family,
            features,
            features12,
            features13,
            validation,
            debug_utils: validation,
        })
    }

    /// A memory type of `bits` with `flags`.
    fn memory_type(&self, bits: u32, flags: vk::MemoryPropertyFlags) -> Result<u32> {
        let props = unsafe { self.instance.get_physical_device_memory_properties(self.physical) };
        (0..props.memory_type_count)
            .find(|&i| bits & (1 << i) != 0 && props.memory_types[i as usize].property_flags.contains(flags))
            .ok_or_else(|| anyhow!("no memory type with {flags:?}"))
    }

    /// The engine's target image, readback buffer, command buffer and fence.
    fn frame_resources(&self, width: u32, height: u32) -> Result<FrameResources> {
        let d = &self.device;
        let mut r = FrameResources { device: Some(d.clone()), ..FrameResources::default() };
        let image_info = vk::ImageCreateInfo::default()
            .image_type(vk::ImageType::TYPE_2D)
            .format(vk::Format::R32G32B32A32_SFLOAT)
            .extent(vk::Extent3D { width, height, depth: 1 })
            .mip_levels(1)
            .array_layers(1)
            .samples(vk::SampleCountFlags::TYPE_1)
            .tiling(vk::ImageTiling::OPTIMAL)
            .usage(vk::ImageUsageFlags::TRANSFER_DST | vk::ImageUsageFlags::TRANSFER_SRC)
            .initial_layout(vk::ImageLayout::UNDEFINED);
        unsafe {
            r.image = d.create_image(&image_info, None)?;
            let reqs = d.get_image_memory_requirements(r.image);
            let ty = self.memory_type(reqs.memory_type_bits, vk::MemoryPropertyFlags::DEVICE_LOCAL)?;
            r.image_memory = d.allocate_memory(
                &vk::MemoryAllocateInfo::default().allocation_size(reqs.size).memory_type_index(ty),
                None,
            )?;
            d.bind_image_memory(r.image, r.image_memory, 0)?;

            let bytes = width as u64 * height as u64 * 16;
            r.buffer = d.create_buffer(
                &vk::BufferCreateInfo::default().size(bytes).usage(vk::BufferUsageFlags::TRANSFER_DST),
                None,
            )?;
            let reqs = d.get_buffer_memory_requirements(r.buffer);
            let host = vk::MemoryPropertyFlags::HOST_VISIBLE | vk::MemoryPropertyFlags::HOST_COHERENT;
            let ty = self.memory_type(reqs.memory_type_bits, host)?;
            r.buffer_memory = d.allocate_memory(
                &vk::MemoryAllocateInfo::default().allocation_size(reqs.size).memory_type_index(ty),
                None,
            )?;
            d.bind_buffer_memory(r.buffer, r.buffer_memory, 0)?;

            r.pool = d.create_command_pool(
                &vk::CommandPoolCreateInfo::default().queue_family_index(self.queue_family),
                None,
            )?;
            r.cmd = d.allocate_command_buffers(
                &vk::CommandBufferAllocateInfo::default()
                    .command_pool(r.pool)
                    .level(vk::CommandBufferLevel::PRIMARY)
                    .command_buffer_count(1),
            )?[0];
            r.fence = d.create_fence(&vk::FenceCreateInfo::default(), None)?;
        }
        Ok(r)
    }
}

impl Drop for Engine {
    fn drop(&mut self) {
        unsafe {
            let _ = self.device.device_wait_idle();
            self.device.destroy_device(None);
            self.instance.destroy_instance(None);
        }
    }
}

/// The engine's per-frame objects (null until made; destroyed in `Drop`).
#[derive(Default)]
struct FrameResources {
    device: Option<ash::Device>,
    image: vk::Image,
    image_memory: vk::DeviceMemory,
    buffer: vk::Buffer,
    buffer_memory: vk::DeviceMemory,
    pool: vk::CommandPool,
    cmd: vk::CommandBuffer,
    fence: vk::Fence,
}

impl FrameResources {
    /// The engine's own commands after Shutter's: its image (in `TRANSFER_SRC_OPTIMAL`, as the frame
    /// left it for `Access::TransferRead`) into its buffer, then made visible to the host.
    fn record_readback(&self, d: &ash::Device, width: u32, height: u32) {
        let region = vk::BufferImageCopy::default()
            .image_subresource(
                vk::ImageSubresourceLayers::default().aspect_mask(vk::ImageAspectFlags::COLOR).layer_count(1),
            )
            .image_extent(vk::Extent3D { width, height, depth: 1 });
        let to_host = vk::MemoryBarrier2::default()
            .src_stage_mask(vk::PipelineStageFlags2::COPY)
            .src_access_mask(vk::AccessFlags2::TRANSFER_WRITE)
            .dst_stage_mask(vk::PipelineStageFlags2::HOST)
            .dst_access_mask(vk::AccessFlags2::HOST_READ);
        unsafe {
            d.cmd_copy_image_to_buffer(
                self.cmd,
                self.image,
                vk::ImageLayout::TRANSFER_SRC_OPTIMAL,
                self.buffer,
                &[region],
            );
            d.cmd_pipeline_barrier2(
                self.cmd,
                &vk::DependencyInfo::default().memory_barriers(std::slice::from_ref(&to_host)),
            );
        }
    }

    /// The buffer as an image (after the fence).
    fn read(&self, d: &ash::Device, width: u32, height: u32) -> Result<LinearImage> {
        let n = (width * height) as usize;
        let mut image = LinearImage::new(width, height);
        unsafe {
            let ptr = d.map_memory(self.buffer_memory, 0, vk::WHOLE_SIZE, vk::MemoryMapFlags::empty())?;
            let floats = std::slice::from_raw_parts(ptr as *const f32, n * 4);
            for (px, c) in image.pixels.iter_mut().zip(floats.chunks_exact(4)) {
                *px = [c[0], c[1], c[2], c[3]];
            }
            d.unmap_memory(self.buffer_memory);
        }
        Ok(image)
    }
}

impl Drop for FrameResources {
    fn drop(&mut self) {
        let Some(d) = &self.device else { return };
        unsafe {
            let _ = d.device_wait_idle();
            d.destroy_fence(self.fence, None);
            d.destroy_command_pool(self.pool, None);
            d.destroy_buffer(self.buffer, None);
            d.free_memory(self.buffer_memory, None);
            d.destroy_image(self.image, None);
            d.free_memory(self.image_memory, None);
        }
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    /// The engine's device as `ExternalDevice` claiming the given features enabled.
    fn lent(
        engine: &Engine,
        features: vk::PhysicalDeviceFeatures,
        features13: vk::PhysicalDeviceVulkan13Features<'static>,
    ) -> ExternalDevice {
        ExternalDevice {
            entry: engine.entry.clone(),
            instance: engine.instance.clone(),
            instance_api_version: vk::API_VERSION_1_3,
            physical_device: engine.physical,
            device: engine.device.clone(),
            queue: engine.queue,
            queue_family: engine.queue_family,
            features,
            features12: engine.features12,
            features13,
            device_extensions: Vec::new(),
            mesh_shader: false,
            task_shader: false,
            debug_utils: engine.debug_utils,
            validation_layer: engine.validation,
            ownership: Ownership::Borrowed,
        }
    }

    /// What Shutter needs and the engine did not enable is refused, named; a frame in flight blocks
    /// the next until retired; a token retires only its own frame.
    #[test]
    fn what_is_not_enabled_is_refused_and_frames_wait_for_retirement() {
        std::env::set_var("SHUTTER_VALIDATION", "1");
        let engine = Engine::new().expect("the engine's device");
        // SAFETY (all three): the engine's handles; they claim less than was enabled, never more.
        let e = unsafe {
            lent(&engine, engine.features, vk::PhysicalDeviceVulkan13Features::default()).into_device()
        }
        .err()
        .expect("refused")
        .to_string();
        assert!(e.contains("dynamicRendering") && e.contains("synchronization2"), "{e}");
        let no_gs = vk::PhysicalDeviceFeatures { geometry_shader: vk::FALSE, ..engine.features };
        let device =
            unsafe { lent(&engine, no_gs, engine.features13).into_device() }.expect("enough for Shutter");
        let scene = crate::embedding_scene().expect("scene");
        let mut renderer = Renderer::new(device).expect("renderer");
        let e = EmbeddedScene::prepare(
            &mut renderer,
            &scene,
            Technique::STOCHASTIC,
            &RenderSettings::from_scene(&scene),
        )
        .err()
        .expect("refused")
        .to_string();
        assert!(e.contains("geometryShader"), "{e}");
        drop(renderer);

        let device =
            unsafe { lent(&engine, engine.features, engine.features13).into_device() }.expect("device");
        // The engine did not enable maintenance4, so no pipeline may outlive its layout: each
        // prepare makes (and its drop destroys) its own instead of sharing the device's.
        assert!(!device.pipelines.reuses(), "pipelines kept without maintenance4");
        let mut renderer = Renderer::new(device.clone()).expect("renderer");
        let settings = RenderSettings::from_scene(&scene);
        let e = EmbeddedScene::prepare(&mut renderer, &scene, Technique::ACCUMULATION, &settings)
            .err()
            .expect("refused");
        assert!(e.to_string().contains("embeddable: stochastic"), "{e}");
        let mut prepared = EmbeddedScene::prepare(&mut renderer, &scene, Technique::STOCHASTIC, &settings)
            .expect("prepared");
        let frame = engine.frame_resources(scene.image.width, scene.image.height).expect("resources");
        let d = &engine.device;
        let target = FrameTarget {
            image: frame.image,
            format: vk::Format::R32G32B32A32_SFLOAT,
            width: scene.image.width,
            height: scene.image.height,
            before: Access::Nothing,
            after: Access::TransferRead,
        };
        unsafe { d.begin_command_buffer(frame.cmd, &vk::CommandBufferBeginInfo::default()).expect("begin") };
        // SAFETY: recording, never submitted: nothing executes, so retiring at once is sound.
        let token = unsafe { prepared.record(frame.cmd, &target) }.expect("recorded");
        assert!(prepared.frame_in_flight());
        let e = unsafe { prepared.record(frame.cmd, &target) }.expect_err("refused while in flight");
        assert!(e.to_string().contains("not retired"), "{e}");
        let wrong = FrameTarget { width: 8, ..target };
        prepared.retire(token).expect("its own token");
        let e = unsafe { prepared.record(frame.cmd, &wrong) }.expect_err("another size");
        assert!(e.to_string().contains("the scene renders"), "{e}");
        unsafe { d.end_command_buffer(frame.cmd).expect("end") };
        device.check_validation().expect("no validation message");
        drop(prepared);
        drop(renderer);
        drop(device);
    }
}
