//! One vocabulary of resource accesses, and the one table that turns it into synchronization2
//! stages, accesses and layouts. Passes never spell out stage masks: they declare how they use
//! each resource (`uses.rs`) and the recording's tracker (`tracker.rs`) derives the barrier
//! from what came before.

use ash::vk;

/// How a pass uses a buffer or an image.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub enum Access {
    /// Not used yet (contents undefined).
    Nothing,
    ColorAttachmentWrite,
    /// Colour attachment read-modify-write (additive blending).
    ColorAttachmentBlend,
    DepthAttachmentWrite,
    /// Sampled or fetched by a fragment shader.
    FragmentSampledRead,
    /// Sampled or fetched by a compute shader.
    ComputeSampledRead,
    /// Storage image or buffer written (and maybe read) by a compute shader.
    ComputeStorageWrite,
    /// Storage image or buffer read by a compute shader.
    ComputeStorageRead,
    /// Storage buffer read by a vertex or fragment shader.
    GraphicsStorageRead,
    /// Storage buffer read by graphics and compute shaders alike (scene-wide data such as the
    /// material buffer).
    AnyShaderStorageRead,
    /// Uniform or storage buffer read by any shader stage: what
    /// [`Cmd::update_buffer`](super::Cmd::update_buffer) leaves a per-frame constant buffer in.
    AnyShaderUniformRead,
    VertexInput,
    IndexInput,
    TransferSrc,
    TransferDst,
    /// Read by `vkCmdBlitImage` (the swapchain blit).
    BlitSrc,
    HostRead,
}

/// The synchronization2 view of an [`Access`].
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub struct AccessInfo {
    pub stage: vk::PipelineStageFlags2,
    pub access: vk::AccessFlags2,
    pub layout: vk::ImageLayout,
}

impl Access {
    /// The usage an image needs for this access (none for the accesses of buffers only).
    pub fn image_usage(self) -> vk::ImageUsageFlags {
        use vk::ImageUsageFlags as U;
        match self {
            Access::ColorAttachmentWrite | Access::ColorAttachmentBlend => U::COLOR_ATTACHMENT,
            Access::DepthAttachmentWrite => U::DEPTH_STENCIL_ATTACHMENT,
            Access::FragmentSampledRead | Access::ComputeSampledRead => U::SAMPLED,
            Access::ComputeStorageWrite | Access::ComputeStorageRead => U::STORAGE,
            Access::TransferSrc | Access::BlitSrc => U::TRANSFER_SRC,
            Access::TransferDst => U::TRANSFER_DST,
            Access::Nothing
            | Access::GraphicsStorageRead
            | Access::AnyShaderStorageRead
            | Access::AnyShaderUniformRead
            | Access::VertexInput
            | Access::IndexInput
            | Access::HostRead => U::empty(),
        }
    }

    /// Every access, in declaration order (`Access as u32` indexes it).
    pub const ALL: [Access; 17] = [
        Access::Nothing,
        Access::ColorAttachmentWrite,
        Access::ColorAttachmentBlend,
        Access::DepthAttachmentWrite,
        Access::FragmentSampledRead,
        Access::ComputeSampledRead,
        Access::ComputeStorageWrite,
        Access::ComputeStorageRead,
        Access::GraphicsStorageRead,
        Access::AnyShaderStorageRead,
        Access::AnyShaderUniformRead,
        Access::VertexInput,
        Access::IndexInput,
        Access::TransferSrc,
        Access::TransferDst,
        Access::BlitSrc,
        Access::HostRead,
    ];

    /// The one table.
    pub fn info(self) -> AccessInfo {
        use vk::AccessFlags2 as A;
        use vk::ImageLayout as L;
        use vk::PipelineStageFlags2 as S;
        let (stage, access, layout) = match self {
            Access::Nothing => (S::NONE, A::NONE, L::UNDEFINED),
            Access::ColorAttachmentWrite => (
                S::COLOR_ATTACHMENT_OUTPUT,
                A::COLOR_ATTACHMENT_WRITE,
                L::COLOR_ATTACHMENT_OPTIMAL,
            ),
            Access::ColorAttachmentBlend => (
                S::COLOR_ATTACHMENT_OUTPUT,
                A::COLOR_ATTACHMENT_READ | A::COLOR_ATTACHMENT_WRITE,
                L::COLOR_ATTACHMENT_OPTIMAL,
            ),
            Access::DepthAttachmentWrite => (
                S::EARLY_FRAGMENT_TESTS | S::LATE_FRAGMENT_TESTS,
                A::DEPTH_STENCIL_ATTACHMENT_READ | A::DEPTH_STENCIL_ATTACHMENT_WRITE,
                L::DEPTH_ATTACHMENT_OPTIMAL,
            ),
            Access::FragmentSampledRead => (
                S::FRAGMENT_SHADER,
                A::SHADER_SAMPLED_READ,
                L::SHADER_READ_ONLY_OPTIMAL,
            ),
            Access::ComputeSampledRead => (
                S::COMPUTE_SHADER,
                A::SHADER_SAMPLED_READ,
                L::SHADER_READ_ONLY_OPTIMAL,
            ),
            Access::ComputeStorageWrite => (
                S::COMPUTE_SHADER,
                A::SHADER_STORAGE_READ | A::SHADER_STORAGE_WRITE,
                L::GENERAL,
            ),
            Access::ComputeStorageRead => (S::COMPUTE_SHADER, A::SHADER_STORAGE_READ, L::GENERAL),
            Access::GraphicsStorageRead => (
                S::VERTEX_SHADER | S::FRAGMENT_SHADER,
                A::SHADER_STORAGE_READ,
                L::GENERAL,
            ),
            Access::AnyShaderStorageRead => (
                S::VERTEX_SHADER | S::FRAGMENT_SHADER | S::COMPUTE_SHADER,
                A::SHADER_STORAGE_READ,
                L::GENERAL,
            ),
            Access::AnyShaderUniformRead => (
                S::VERTEX_SHADER | S::FRAGMENT_SHADER | S::COMPUTE_SHADER,
                A::UNIFORM_READ | A::SHADER_STORAGE_READ,
                L::GENERAL,
            ),
            Access::VertexInput => (
                S::VERTEX_ATTRIBUTE_INPUT,
                A::VERTEX_ATTRIBUTE_READ,
                L::UNDEFINED,
            ),
            Access::IndexInput => (S::INDEX_INPUT, A::INDEX_READ, L::UNDEFINED),
            Access::TransferSrc => (S::COPY, A::TRANSFER_READ, L::TRANSFER_SRC_OPTIMAL),
            // Every transfer stage: copies (COPY), and fill/update, which sync2 puts in the
            // clear commands' stage (CLEAR).
            Access::TransferDst => (S::ALL_TRANSFER, A::TRANSFER_WRITE, L::TRANSFER_DST_OPTIMAL),
            Access::BlitSrc => (S::BLIT, A::TRANSFER_READ, L::TRANSFER_SRC_OPTIMAL),
            Access::HostRead => (S::HOST, A::HOST_READ, L::GENERAL),
        };
        AccessInfo {
            stage,
            access,
            layout,
        }
    }

    /// Whether the access writes (a write needs a barrier even after the same access).
    pub fn writes(self) -> bool {
        let w = vk::AccessFlags2::SHADER_STORAGE_WRITE
            | vk::AccessFlags2::COLOR_ATTACHMENT_WRITE
            | vk::AccessFlags2::DEPTH_STENCIL_ATTACHMENT_WRITE
            | vk::AccessFlags2::TRANSFER_WRITE
            | vk::AccessFlags2::HOST_WRITE;
        self.info().access.intersects(w)
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn every_access_has_a_consistent_stage_and_all_lists_each_at_its_index() {
        for (i, a) in Access::ALL.into_iter().enumerate() {
            assert_eq!(a as usize, i, "{a:?}");
            let info = a.info();
            // An access with memory effects must name the stage that performs them.
            if !info.access.is_empty() {
                assert_ne!(info.stage, vk::PipelineStageFlags2::NONE, "{a:?}");
            }
        }
        assert!(Access::ComputeStorageWrite.writes());
        assert!(!Access::FragmentSampledRead.writes());
    }
}
