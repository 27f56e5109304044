//! One-shot uploads and readbacks through host-visible staging buffers. For set-up (scene
//! geometry, textures) and for reading results in headless renders and tests; the per-frame
//! photon traffic has its own asynchronous path.

use super::access::Access;
use super::device::{Gpu, QueueRole};
use super::image::{Image, ImageDesc};
use super::resources::{Buffer, MemoryLocation};
use ash::vk;
use std::sync::Arc;

/// Bytes per texel of the formats the renderer reads back or uploads.
pub fn texel_size(format: vk::Format) -> anyhow::Result<u64> {
    Ok(match format {
        vk::Format::R8G8B8A8_UNORM | vk::Format::R8G8B8A8_SRGB | vk::Format::B8G8R8A8_UNORM => 4,
        vk::Format::R32_SFLOAT | vk::Format::D32_SFLOAT | vk::Format::R32_UINT => 4,
        vk::Format::R16G16B16A16_SFLOAT => 8,
        vk::Format::R32G32B32A32_SFLOAT => 16,
        other => anyhow::bail!("no texel size known for {other:?}"),
    })
}

impl Gpu {
    /// A device-local buffer holding `bytes`, ready for `then` (its first GPU access).
    pub fn upload_buffer(
        self: &Arc<Self>,
        name: &str,
        usage: vk::BufferUsageFlags,
        bytes: &[u8],
        then: Access,
    ) -> anyhow::Result<Buffer> {
        let staging = Buffer::new(
            self,
            &format!("{name}.staging"),
            bytes.len() as u64,
            vk::BufferUsageFlags::TRANSFER_SRC,
            MemoryLocation::CpuToGpu,
        )?;
        staging.write(0, bytes)?;
        let buffer = Buffer::new(
            self,
            name,
            bytes.len() as u64,
            usage | vk::BufferUsageFlags::TRANSFER_DST,
            MemoryLocation::GpuOnly,
        )?;
        self.one_shot(QueueRole::Graphics, &format!("upload {name}"), |cmd| {
            cmd.copy_buffer(&staging, &buffer);
            cmd.transition_buffer(&buffer, then);
        })?;
        Ok(buffer)
    }

    /// An image holding `bytes` (tightly packed texels of every layer), ready for `then`.
    pub fn upload_image(
        self: &Arc<Self>,
        desc: &ImageDesc,
        bytes: &[u8],
        then: Access,
    ) -> anyhow::Result<Image> {
        let expected = u64::from(desc.width)
            * u64::from(desc.height)
            * u64::from(desc.layers.max(1))
            * texel_size(desc.format)?;
        anyhow::ensure!(
            bytes.len() as u64 == expected,
            "image {}: {} bytes given, {expected} expected",
            desc.name,
            bytes.len()
        );
        let staging = Buffer::new(
            self,
            &format!("{}.staging", desc.name),
            expected,
            vk::BufferUsageFlags::TRANSFER_SRC,
            MemoryLocation::CpuToGpu,
        )?;
        staging.write(0, bytes)?;
        let mut desc = desc.clone();
        desc.usage |= vk::ImageUsageFlags::TRANSFER_DST;
        let image = Image::new(self, &desc)?;
        self.one_shot(
            QueueRole::Graphics,
            &format!("upload {}", desc.name),
            |cmd| {
                cmd.copy_buffer_to_image(&staging, &image);
                cmd.transition(&image, then);
            },
        )?;
        Ok(image)
    }

    /// Reads layer 0 of `image` back to the host (tightly packed rows, top row first). The
    /// image must have TRANSFER_SRC usage; it is left in [`Access::TransferSrc`].
    pub fn read_image(self: &Arc<Self>, image: &Image) -> anyhow::Result<Vec<u8>> {
        let size = u64::from(image.width) * u64::from(image.height) * texel_size(image.format)?;
        let staging = Buffer::new(
            self,
            &format!("{}.readback", image.name),
            size,
            vk::BufferUsageFlags::TRANSFER_DST,
            MemoryLocation::GpuToCpu,
        )?;
        self.one_shot(
            QueueRole::Graphics,
            &format!("read back {}", image.name),
            |cmd| {
                cmd.copy_image_to_buffer(image, &staging);
                cmd.transition_buffer(&staging, Access::HostRead);
            },
        )?;
        let mut bytes = staging.read()?;
        bytes.truncate(size as usize);
        Ok(bytes)
    }

    /// Reads a buffer back to the host (it must have TRANSFER_SRC usage).
    pub fn read_buffer(self: &Arc<Self>, buffer: &Buffer) -> anyhow::Result<Vec<u8>> {
        let staging = Buffer::new(
            self,
            &format!("{}.readback", buffer.name),
            buffer.size,
            vk::BufferUsageFlags::TRANSFER_DST,
            MemoryLocation::GpuToCpu,
        )?;
        self.one_shot(
            QueueRole::Graphics,
            &format!("read back {}", buffer.name),
            |cmd| {
                cmd.copy_buffer(buffer, &staging);
                cmd.transition_buffer(&staging, Access::HostRead);
            },
        )?;
        staging.read()
    }
}
