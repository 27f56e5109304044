//! The narrow error type of the Vulkan layer. Everything above `gpu/` uses `anyhow` and adds
//! context; these variants are the cases a caller may want to tell apart.

use ash::vk;

#[derive(Debug, thiserror::Error)]
pub enum GpuError {
    #[error(
        "no Vulkan loader found ({0}); install libvulkan1 (and mesa-vulkan-drivers for lavapipe)"
    )]
    Loader(String),
    #[error("no Vulkan device supports ispm's requirements: {0}")]
    NoSuitableDevice(String),
    #[error("device index {index} is out of range: {count} Vulkan device(s) found")]
    DeviceIndex { index: usize, count: usize },
    #[error(
        "the Khronos validation layer was requested but is not installed \
         (Debian/Ubuntu: apt-get install vulkan-validationlayers)"
    )]
    ValidationLayerMissing,
    #[error("the device cannot time GPU work: {0}")]
    NoTimestamps(&'static str),
    #[error("the GPU ran out of memory while {0}")]
    OutOfMemory(String),
    #[error("the device was lost while {0}")]
    DeviceLost(String),
    #[error("the surface is out of date")]
    SurfaceOutOfDate,
    #[error("Vulkan call {call} failed: {result}")]
    Vk {
        call: &'static str,
        result: vk::Result,
    },
    #[error("memory allocation for {name} failed: {source}")]
    Allocation {
        name: String,
        source: gpu_allocator::AllocationError,
    },
    #[error("image {0} has no usage: no pass declared a use of it")]
    UnusedImage(String),
}

pub type GpuResult<T> = Result<T, GpuError>;

/// Maps a raw `vk::Result` from `call` into the variant a caller can act on.
pub fn vk_err(call: &'static str) -> impl Fn(vk::Result) -> GpuError {
    move |result| match result {
        vk::Result::ERROR_OUT_OF_DEVICE_MEMORY | vk::Result::ERROR_OUT_OF_HOST_MEMORY => {
            GpuError::OutOfMemory(call.to_string())
        }
        vk::Result::ERROR_DEVICE_LOST => GpuError::DeviceLost(call.to_string()),
        vk::Result::ERROR_OUT_OF_DATE_KHR => GpuError::SurfaceOutOfDate,
        result => GpuError::Vk { call, result },
    }
}
