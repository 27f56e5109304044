//! [`Cmd`]'s transfers: copies between buffers and images, fills, command-stream updates,
//! and the blit onto a swapchain image. Each makes its resources ready first (`Cmd::barriers`).

use super::{Cmd, Resource};
use crate::gpu::access::Access;
use crate::gpu::image::{aspect_of, Image};
use crate::gpu::resources::Buffer;
use ash::vk;
use std::ops::Range;

impl Cmd<'_> {
    /// Copies the first layer of `image` into `buffer` (tightly packed rows).
    pub fn copy_image_to_buffer(&self, image: &Image, buffer: &Buffer) {
        self.barriers(&[
            (Resource::Image(image), Access::TransferSrc),
            (Resource::Buffer(buffer), Access::TransferDst),
        ]);
        let region = vk::BufferImageCopy::default()
            .image_subresource(vk::ImageSubresourceLayers {
                aspect_mask: aspect_of(image.format),
                mip_level: 0,
                base_array_layer: 0,
                layer_count: 1,
            })
            .image_extent(vk::Extent3D {
                width: image.width,
                height: image.height,
                depth: 1,
            });
        // SAFETY: recording state; the image is in TRANSFER_SRC_OPTIMAL (transitioned above);
        // the buffer is large enough (checked by the caller that sized it).
        unsafe {
            self.device().cmd_copy_image_to_buffer(
                self.raw,
                image.raw(),
                vk::ImageLayout::TRANSFER_SRC_OPTIMAL,
                buffer.raw,
                &[region],
            )
        };
    }

    /// Copies `buffer` (tightly packed rows, layer after layer) into every layer of `image`.
    pub fn copy_buffer_to_image(&self, buffer: &Buffer, image: &Image) {
        let region = vk::BufferImageCopy::default()
            .image_subresource(Self::layers(image, image.layers))
            .image_extent(vk::Extent3D {
                width: image.width,
                height: image.height,
                depth: 1,
            });
        // The buffer holds the whole image (checked by the caller that sized it).
        self.copy_to_image(buffer, image, region);
    }

    /// Copies one texel, at `offset` of `buffer`, into texel (`x`, `y`) of the first layer of
    /// `image` (the value check's injected bad values, `passes/value_check.rs`).
    pub fn copy_buffer_to_texel(
        &self,
        buffer: &Buffer,
        offset: u64,
        image: &Image,
        (x, y): (u32, u32),
    ) {
        assert!(
            x < image.width && y < image.height && offset < buffer.size,
            "copy_buffer_to_texel: ({x}, {y}) outside {} ({}x{}) or {offset} outside {}",
            image.name,
            image.width,
            image.height,
            buffer.name
        );
        let region = vk::BufferImageCopy::default()
            .buffer_offset(offset)
            .image_subresource(Self::layers(image, 1))
            .image_offset(vk::Offset3D {
                x: x as i32,
                y: y as i32,
                z: 0,
            })
            .image_extent(vk::Extent3D {
                width: 1,
                height: 1,
                depth: 1,
            });
        self.copy_to_image(buffer, image, region);
    }

    /// The first `count` layers of `image`'s only mip level.
    fn layers(image: &Image, count: u32) -> vk::ImageSubresourceLayers {
        vk::ImageSubresourceLayers {
            aspect_mask: aspect_of(image.format),
            mip_level: 0,
            base_array_layer: 0,
            layer_count: count,
        }
    }

    /// Transitions `buffer` and `image` and records the copy of `region` between them.
    fn copy_to_image(&self, buffer: &Buffer, image: &Image, region: vk::BufferImageCopy) {
        self.barriers(&[
            (Resource::Image(image), Access::TransferDst),
            (Resource::Buffer(buffer), Access::TransferSrc),
        ]);
        // SAFETY: recording state; the image is in TRANSFER_DST_OPTIMAL (transitioned above);
        // the region lies inside the image and the buffer (the public callers' checks).
        unsafe {
            self.device().cmd_copy_buffer_to_image(
                self.raw,
                buffer.raw,
                image.raw(),
                vk::ImageLayout::TRANSFER_DST_OPTIMAL,
                &[region],
            )
        };
    }

    /// Copies all of `src` into the start of `dst`.
    pub fn copy_buffer(&self, src: &Buffer, dst: &Buffer) {
        self.barriers(&[
            (Resource::Buffer(src), Access::TransferSrc),
            (Resource::Buffer(dst), Access::TransferDst),
        ]);
        let region = vk::BufferCopy {
            src_offset: 0,
            dst_offset: 0,
            size: src.size.min(dst.size),
        };
        // SAFETY: recording state; both buffers are live and the region fits both.
        unsafe {
            self.device()
                .cmd_copy_buffer(self.raw, src.raw(), dst.raw, &[region])
        };
    }

    /// Copies each byte range `r` of `src` to `dst`, starting at `at` there, for every
    /// `(r, at)` of `regions` (empty ranges are left out; each must lie in both buffers).
    pub fn copy_buffer_regions(&self, src: &Buffer, dst: &Buffer, regions: &[(Range<u64>, u64)]) {
        let regions: Vec<vk::BufferCopy> = regions
            .iter()
            .filter(|(r, _)| r.end > r.start)
            .map(|(r, at)| {
                assert!(
                    r.end <= src.size && at + (r.end - r.start) <= dst.size,
                    "copy of {r:?} from {} ({} bytes) to {at} of {} ({} bytes) overflows",
                    src.name,
                    src.size,
                    dst.name,
                    dst.size
                );
                vk::BufferCopy {
                    src_offset: r.start,
                    dst_offset: *at,
                    size: r.end - r.start,
                }
            })
            .collect();
        if regions.is_empty() {
            return;
        }
        self.barriers(&[
            (Resource::Buffer(src), Access::TransferSrc),
            (Resource::Buffer(dst), Access::TransferDst),
        ]);
        // SAFETY: recording state; both buffers are live and every region lies in both
        // (asserted above).
        unsafe {
            self.device()
                .cmd_copy_buffer(self.raw, src.raw(), dst.raw, &regions)
        };
    }

    /// Fills `buffer` with the 32-bit `value`.
    pub fn fill_buffer(&self, buffer: &Buffer, value: u32) {
        self.transition_buffer(buffer, Access::TransferDst);
        // SAFETY: recording state; the buffer is live with TRANSFER_DST usage and its size is
        // a multiple of 4 (Buffer::new rounds up to at least 4; WHOLE_SIZE rounds down).
        unsafe {
            self.device()
                .cmd_fill_buffer(self.raw, buffer.raw, 0, vk::WHOLE_SIZE, value)
        };
    }

    /// Writes `bytes` at `offset` of `buffer` from the command stream (`vkCmdUpdateBuffer`, in
    /// chunks of 64 KiB), then makes them visible to every shader stage. Per-frame constants
    /// travel this way so the host never writes memory an earlier frame in flight still reads.
    pub fn update_buffer(&self, buffer: &Buffer, offset: u64, bytes: &[u8]) {
        if bytes.is_empty() {
            return;
        }
        assert!(
            offset % 4 == 0 && bytes.len() % 4 == 0 && offset + bytes.len() as u64 <= buffer.size,
            "update_buffer: {} bytes at {offset} of {} ({} bytes)",
            bytes.len(),
            buffer.name,
            buffer.size
        );
        self.transition_buffer(buffer, Access::TransferDst);
        for (i, chunk) in bytes.chunks(65536).enumerate() {
            // SAFETY: recording state, outside a render pass; the buffer is live with
            // TRANSFER_DST usage; offset and size are multiples of 4, the chunk is ≤ 65536 bytes
            // and fits the buffer (asserted above).
            unsafe {
                self.device().cmd_update_buffer(
                    self.raw,
                    buffer.raw,
                    offset + i as u64 * 65536,
                    chunk,
                )
            };
        }
        self.transition_buffer(buffer, Access::AnyShaderUniformRead);
    }

    /// Blits all of `src` (in [`Access::BlitSrc`]) onto the swapchain image `dst` of `extent`,
    /// scaled with a linear filter, leaving `dst` ready to present (`then_present`) or in
    /// TRANSFER_DST_OPTIMAL for the overlay to draw on (`overlay.rs`). The submission waits for
    /// the image's acquisition at the transfer stages.
    pub(in crate::gpu) fn blit_to_swapchain(
        &self,
        src: &Image,
        dst: vk::Image,
        extent: vk::Extent2D,
        then_present: bool,
    ) {
        let range = vk::ImageSubresourceRange {
            aspect_mask: vk::ImageAspectFlags::COLOR,
            base_mip_level: 0,
            level_count: 1,
            base_array_layer: 0,
            layer_count: 1,
        };
        let to_dst = vk::ImageMemoryBarrier2::default()
            .src_stage_mask(vk::PipelineStageFlags2::ALL_TRANSFER)
            .src_access_mask(vk::AccessFlags2::NONE)
            .dst_stage_mask(vk::PipelineStageFlags2::BLIT)
            .dst_access_mask(vk::AccessFlags2::TRANSFER_WRITE)
            .old_layout(vk::ImageLayout::UNDEFINED)
            .new_layout(vk::ImageLayout::TRANSFER_DST_OPTIMAL)
            .src_queue_family_index(vk::QUEUE_FAMILY_IGNORED)
            .dst_queue_family_index(vk::QUEUE_FAMILY_IGNORED)
            .image(dst)
            .subresource_range(range);
        let barriers = [to_dst];
        let dep = vk::DependencyInfo::default().image_memory_barriers(&barriers);
        // SAFETY: recording state; `dst` is an acquired swapchain image whose acquisition the
        // submission waits for at ALL_TRANSFER (chained by this barrier's source scope).
        unsafe { self.device().cmd_pipeline_barrier2(self.raw, &dep) };
        let e = src.extent();
        let corner = |w: u32, h: u32| {
            [
                vk::Offset3D { x: 0, y: 0, z: 0 },
                vk::Offset3D {
                    x: w as i32,
                    y: h as i32,
                    z: 1,
                },
            ]
        };
        let layers = vk::ImageSubresourceLayers {
            aspect_mask: vk::ImageAspectFlags::COLOR,
            mip_level: 0,
            base_array_layer: 0,
            layer_count: 1,
        };
        let region = vk::ImageBlit {
            src_subresource: layers,
            src_offsets: corner(e.width, e.height),
            dst_subresource: layers,
            dst_offsets: corner(extent.width, extent.height),
        };
        // SAFETY: recording state; `src` is in TRANSFER_SRC_OPTIMAL (BlitSrc), `dst` in
        // TRANSFER_DST_OPTIMAL; both regions lie inside their images; both formats support
        // linear blits (8-bit UNORM colour formats).
        unsafe {
            self.device().cmd_blit_image(
                self.raw,
                src.raw(),
                vk::ImageLayout::TRANSFER_SRC_OPTIMAL,
                dst,
                vk::ImageLayout::TRANSFER_DST_OPTIMAL,
                &[region],
                vk::Filter::LINEAR,
            )
        };
        if !then_present {
            return;
        }
        let to_present = vk::ImageMemoryBarrier2::default()
            .src_stage_mask(vk::PipelineStageFlags2::BLIT)
            .src_access_mask(vk::AccessFlags2::TRANSFER_WRITE)
            .dst_stage_mask(vk::PipelineStageFlags2::NONE)
            .dst_access_mask(vk::AccessFlags2::NONE)
            .old_layout(vk::ImageLayout::TRANSFER_DST_OPTIMAL)
            .new_layout(vk::ImageLayout::PRESENT_SRC_KHR)
            .src_queue_family_index(vk::QUEUE_FAMILY_IGNORED)
            .dst_queue_family_index(vk::QUEUE_FAMILY_IGNORED)
            .image(dst)
            .subresource_range(range);
        let barriers = [to_present];
        let dep = vk::DependencyInfo::default().image_memory_barriers(&barriers);
        // SAFETY: recording state; the image was just written by the blit above.
        unsafe { self.device().cmd_pipeline_barrier2(self.raw, &dep) };
    }
}
