//! RAII buffers and samplers on gpu-allocator (images: `image.rs`), each with a debug name and its state at
//! rest for the barrier tracker (`tracker.rs`: barriers are derived, not written by hand). Dropping one retires it
//! to the graveyard of [`Gpu`]; it is destroyed once the GPU can no longer be using it.

use super::device::{Gpu, Retired};
use super::error::{vk_err, GpuError, GpuResult};
use super::tracker::Resting;
use ash::vk;
use gpu_allocator::vulkan::{Allocation, AllocationCreateDesc, AllocationScheme};
pub use gpu_allocator::MemoryLocation;
use std::sync::Arc;

/// A buffer and its memory.
pub struct Buffer {
    gpu: Arc<Gpu>,
    pub(super) raw: vk::Buffer,
    allocation: Option<Allocation>,
    pub size: u64,
    pub name: String,
    /// The state the last submitted recording left it in (`tracker.rs`).
    pub(super) resting: Arc<Resting>,
}

impl Buffer {
    /// Creates a buffer of `size` bytes (at least 4) in `location`.
    pub fn new(
        gpu: &Arc<Gpu>,
        name: &str,
        size: u64,
        usage: vk::BufferUsageFlags,
        location: MemoryLocation,
    ) -> GpuResult<Buffer> {
        let size = size.max(4);
        let info = vk::BufferCreateInfo::default()
            .size(size)
            .usage(usage)
            .sharing_mode(vk::SharingMode::EXCLUSIVE);
        let device = gpu.raw();
        // SAFETY: the device is live and `info` is a valid create info.
        let raw = unsafe { device.create_buffer(&info, None) }.map_err(vk_err("vkCreateBuffer"))?;
        // SAFETY: raw is a buffer of this device.
        let requirements = unsafe { device.get_buffer_memory_requirements(raw) };
        let allocation = gpu
            .allocator()
            .allocate(&AllocationCreateDesc {
                name,
                requirements,
                location,
                linear: true,
                allocation_scheme: AllocationScheme::GpuAllocatorManaged,
            })
            .map_err(|source| {
                // SAFETY: raw is unused and owned here.
                unsafe { device.destroy_buffer(raw, None) };
                GpuError::Allocation {
                    name: name.into(),
                    source,
                }
            })?;
        // SAFETY: the allocation was made for this buffer's requirements and is not bound yet.
        if let Err(e) =
            unsafe { device.bind_buffer_memory(raw, allocation.memory(), allocation.offset()) }
        {
            let _ = gpu.allocator().free(allocation);
            // SAFETY: raw is unused and owned here.
            unsafe { device.destroy_buffer(raw, None) };
            return Err(vk_err("vkBindBufferMemory")(e));
        }
        gpu.set_name(raw, name);
        Ok(Buffer {
            gpu: gpu.clone(),
            raw,
            allocation: Some(allocation),
            size,
            name: name.into(),
            resting: Resting::new(name),
        })
    }

    /// A device-local buffer of per-frame constants (uniform or storage), written from the
    /// command stream by [`Cmd::update_buffer`](super::Cmd::update_buffer).
    pub fn constants(
        gpu: &Arc<Gpu>,
        name: &str,
        size: u64,
        usage: vk::BufferUsageFlags,
    ) -> GpuResult<Buffer> {
        Self::new(
            gpu,
            name,
            size.next_multiple_of(4),
            usage | vk::BufferUsageFlags::TRANSFER_DST,
            MemoryLocation::GpuOnly,
        )
    }

    /// Copies `bytes` into a host-visible buffer at `offset`. The caller makes sure the GPU is
    /// not using the range (timeline waits); memory is coherent (gpu-allocator only hands out
    /// host-coherent memory for host-visible locations), so no flush is needed.
    pub fn write(&self, offset: u64, bytes: &[u8]) -> anyhow::Result<()> {
        let ptr = self.mapped_ptr()?;
        anyhow::ensure!(
            offset + bytes.len() as u64 <= self.size,
            "write of {} bytes at {offset} overflows buffer {} ({} bytes)",
            bytes.len(),
            self.name,
            self.size
        );
        // SAFETY: the mapping covers `size` bytes, the range was checked above, and `bytes`
        // cannot overlap GPU-mapped memory.
        unsafe {
            std::ptr::copy_nonoverlapping(bytes.as_ptr(), ptr.add(offset as usize), bytes.len())
        };
        Ok(())
    }

    /// Reads the whole host-visible buffer. The caller has waited for the GPU writes.
    pub fn read(&self) -> anyhow::Result<Vec<u8>> {
        let ptr = self.mapped_ptr()?;
        let mut out = vec![0u8; self.size as usize];
        // SAFETY: the mapping covers `size` bytes and stays mapped while self is alive.
        unsafe { std::ptr::copy_nonoverlapping(ptr, out.as_mut_ptr(), out.len()) };
        Ok(out)
    }

    /// Reads `out.len()` bytes at `offset` of the host-visible buffer into `out`. The caller has
    /// waited for the GPU writes.
    pub fn read_into(&self, offset: u64, out: &mut [u8]) -> anyhow::Result<()> {
        let ptr = self.mapped_ptr()?;
        anyhow::ensure!(
            offset + out.len() as u64 <= self.size,
            "read of {} bytes at {offset} overflows buffer {} ({} bytes)",
            out.len(),
            self.name,
            self.size
        );
        // SAFETY: the mapping covers `size` bytes, the range was checked above, and `out`
        // cannot overlap GPU-mapped memory.
        unsafe {
            std::ptr::copy_nonoverlapping(ptr.add(offset as usize), out.as_mut_ptr(), out.len())
        };
        Ok(())
    }

    fn mapped_ptr(&self) -> anyhow::Result<*mut u8> {
        self.allocation
            .as_ref()
            .and_then(Allocation::mapped_ptr)
            .map(|p| p.as_ptr().cast::<u8>())
            .ok_or_else(|| anyhow::anyhow!("buffer {} is not host-visible", self.name))
    }

    pub fn raw(&self) -> vk::Buffer {
        self.raw
    }
}

impl Drop for Buffer {
    fn drop(&mut self) {
        if let Some(a) = self.allocation.take() {
            self.gpu.retire(Retired::Buffer(self.raw, a));
        }
    }
}

/// Texture filtering.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub enum Filter {
    Nearest,
    Linear,
    /// Linear filtering with depth comparison (`sampler2DArrayShadow`): hardware PCF.
    LinearCompare,
}

/// A sampler.
pub struct Sampler {
    gpu: Arc<Gpu>,
    pub(super) raw: vk::Sampler,
}

impl Sampler {
    pub fn new(gpu: &Arc<Gpu>, name: &str, filter: Filter, repeat: bool) -> GpuResult<Sampler> {
        let f = match filter {
            Filter::Nearest => vk::Filter::NEAREST,
            _ => vk::Filter::LINEAR,
        };
        let mode = if repeat {
            vk::SamplerAddressMode::REPEAT
        } else {
            vk::SamplerAddressMode::CLAMP_TO_EDGE
        };
        let mut info = vk::SamplerCreateInfo::default()
            .mag_filter(f)
            .min_filter(f)
            .mipmap_mode(vk::SamplerMipmapMode::NEAREST)
            .address_mode_u(mode)
            .address_mode_v(mode)
            .address_mode_w(mode)
            .max_lod(0.0);
        if filter == Filter::LinearCompare {
            // Shadow maps have reversed depth (`plan/lighting.rs`): a point is lit where its depth
            // is at least the stored one, and beyond the map's border (depth 0, the far end).
            info = info
                .compare_enable(true)
                .compare_op(vk::CompareOp::GREATER_OR_EQUAL)
                .address_mode_u(vk::SamplerAddressMode::CLAMP_TO_BORDER)
                .address_mode_v(vk::SamplerAddressMode::CLAMP_TO_BORDER)
                .border_color(vk::BorderColor::FLOAT_TRANSPARENT_BLACK);
        }
        // SAFETY: the device is live and `info` is valid.
        let raw =
            unsafe { gpu.raw().create_sampler(&info, None) }.map_err(vk_err("vkCreateSampler"))?;
        gpu.set_name(raw, name);
        Ok(Sampler {
            gpu: gpu.clone(),
            raw,
        })
    }
}

impl Drop for Sampler {
    fn drop(&mut self) {
        self.gpu.retire(Retired::Sampler(self.raw));
    }
}
