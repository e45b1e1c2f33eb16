//! Buffers with their gpu-allocator allocations, RAII.

use ash::vk;
use gpu_allocator::vulkan::{Allocation, AllocationCreateDesc, AllocationScheme};
use gpu_allocator::MemoryLocation;

use super::Device;
use crate::error::{Error, Result, VkContext};

/// A buffer and its memory. Freed on drop (safe: nothing is ever in flight, see `context.rs`).
pub struct Buffer {
    pub raw: vk::Buffer,
    pub size: u64,
    allocation: Option<Allocation>,
    device: Device,
}

impl Buffer {
    pub fn new(
        device: &Device,
        name: &str,
        size: u64,
        usage: vk::BufferUsageFlags,
        location: MemoryLocation,
    ) -> Result<Buffer> {
        let info = vk::BufferCreateInfo::default()
            .size(size.max(4))
            .usage(usage)
            .sharing_mode(vk::SharingMode::EXCLUSIVE);
        let raw = unsafe { device.raw.create_buffer(&info, None) }.vk("vkCreateBuffer")?;
        let reqs = unsafe { device.raw.get_buffer_memory_requirements(raw) };
        let allocation = match allocate(device, name, reqs, location, true) {
            Ok(a) => a,
            Err(e) => {
                unsafe { device.raw.destroy_buffer(raw, None) };
                return Err(e.into());
            }
        };
        let buffer = Buffer { raw, size, allocation: Some(allocation), device: device.clone() };
        let a = buffer.allocation.as_ref().expect("just set");
        unsafe { device.raw.bind_buffer_memory(raw, a.memory(), a.offset()) }.vk("vkBindBufferMemory")?;
        device.set_name(raw, name);
        Ok(buffer)
    }

    /// A host-visible buffer filled with `data`.
    pub fn with_data<T: bytemuck::Pod>(
        device: &Device,
        name: &str,
        usage: vk::BufferUsageFlags,
        data: &[T],
    ) -> Result<Buffer> {
        let bytes = std::mem::size_of_val(data) as u64;
        let mut b = Buffer::new(device, name, bytes, usage, MemoryLocation::CpuToGpu)?;
        b.write(data)?;
        Ok(b)
    }

    /// Copies `data` into a host-visible buffer.
    pub fn write<T: bytemuck::Pod>(&mut self, data: &[T]) -> Result<()> {
        let bytes: &[u8] = bytemuck::cast_slice(data);
        let slice = self.mapped_mut()?;
        if bytes.len() > slice.len() {
            return Err(Error::Unsupported(format!(
                "write of {} bytes into a {}-byte buffer",
                bytes.len(),
                slice.len()
            )));
        }
        slice[..bytes.len()].copy_from_slice(bytes);
        Ok(())
    }

    /// The first `n` `u32`s of a host-visible buffer (counters the GPU wrote; read after the graph
    /// that wrote them declared the host read).
    pub fn read_u32s(&self, n: usize) -> Result<Vec<u32>> {
        let bytes = self.mapped()?;
        if bytes.len() < 4 * n {
            return Err(Error::Unsupported(format!("read of {n} u32 from a {}-byte buffer", bytes.len())));
        }
        Ok(bytes[..4 * n].chunks_exact(4).map(|c| u32::from_ne_bytes([c[0], c[1], c[2], c[3]])).collect())
    }

    fn mapped_mut(&mut self) -> Result<&mut [u8]> {
        self.allocation
            .as_mut()
            .and_then(|a| a.mapped_slice_mut())
            .ok_or_else(|| Error::Unsupported("buffer is not host-visible".into()))
    }

    /// Host-visible contents.
    pub fn mapped(&self) -> Result<&[u8]> {
        self.allocation
            .as_ref()
            .and_then(|a| a.mapped_slice())
            .ok_or_else(|| Error::Unsupported("buffer is not host-visible".into()))
    }
}

impl Drop for Buffer {
    fn drop(&mut self) {
        free(&self.device, self.allocation.take());
        unsafe { self.device.raw.destroy_buffer(self.raw, None) };
    }
}

/// Allocates memory for a buffer or image (`linear`: buffers and linear-tiled images) with
/// gpu-allocator; the caller binds it and destroys its handle if this fails.
pub(crate) fn allocate(
    device: &Device,
    name: &str,
    requirements: vk::MemoryRequirements,
    location: MemoryLocation,
    linear: bool,
) -> std::result::Result<Allocation, gpu_allocator::AllocationError> {
    device.allocator.lock().expect("allocator poisoned").allocate(&AllocationCreateDesc {
        name,
        requirements,
        location,
        linear,
        allocation_scheme: AllocationScheme::GpuAllocatorManaged,
    })
}

/// Returns an allocation to the allocator (from a wrapper's `Drop`).
pub(crate) fn free(device: &Device, allocation: Option<Allocation>) {
    if let Some(a) = allocation {
        if let Ok(mut alloc) = device.allocator.lock() {
            let _ = alloc.free(a);
        }
    }
}
