//! One vocabulary of resource accesses, and the one table that turns it into synchronization2
//! barriers. Passes never spell out stage masks: they say how they are about to use a resource
//! and [`Cmd::transition`](super::Cmd::transition) emits the barrier from the last access.

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
    /// Depth test without writes, while the image may also be sampled.
    DepthAttachmentRead,
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
    /// Uniform or storage buffer read by any shader stage: what [`Cmd::update_buffer`]
    /// (super::Cmd::update_buffer) leaves a per-frame constant buffer in.
    AnyShaderUniformRead,
    VertexInput,
    IndexInput,
    TransferSrc,
    TransferDst,
    /// Read by `vkCmdBlitImage` (the swapchain blit).
    BlitSrc,
    HostRead,
    HostWrite,
    Present,
    /// Released to another queue family ([`Cmd::release_buffer`](super::Cmd::release_buffer));
    /// the next use on the receiving queue must acquire it.
    Released,
}

/// The synchronization2 view of an [`Access`].
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub struct AccessInfo {
    pub stage: vk::PipelineStageFlags2,
    pub access: vk::AccessFlags2,
    pub layout: vk::ImageLayout,
}

impl Access {
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
            Access::DepthAttachmentRead => (
                S::EARLY_FRAGMENT_TESTS | S::LATE_FRAGMENT_TESTS,
                A::DEPTH_STENCIL_ATTACHMENT_READ,
                L::DEPTH_READ_ONLY_OPTIMAL,
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
            Access::HostWrite => (S::HOST, A::HOST_WRITE, L::GENERAL),
            Access::Present => (S::NONE, A::NONE, L::PRESENT_SRC_KHR),
            Access::Released => (S::NONE, A::NONE, L::UNDEFINED),
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

/// One half of a queue-family ownership transfer of a whole buffer (Vulkan spec §7.7.4): the
/// release, recorded on the source family's queue, or the acquire, recorded on the destination
/// family's queue after a semaphore wait on the release. Both halves name the same two families;
/// the release's destination masks and the acquire's source masks are ignored by the spec and
/// left empty here.
///
/// ```text
///   transfer queue (family T)               graphics queue (family G)
///   copy → photons  [TransferDst]
///   release T→G: src = TransferDst, dst = ∅ ──timeline──► acquire T→G: src = ∅, dst = VertexInput
/// ```
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub struct OwnershipBarrier {
    pub src_stage: vk::PipelineStageFlags2,
    pub src_access: vk::AccessFlags2,
    pub dst_stage: vk::PipelineStageFlags2,
    pub dst_access: vk::AccessFlags2,
    pub src_family: u32,
    pub dst_family: u32,
}

/// The release of a buffer whose last access on family `src` was `last`, handed to family `dst`:
/// the barrier to record (none when the families are equal: the timeline semaphore then orders
/// and makes visible everything before it) and the buffer's tracked access afterwards.
pub fn release(last: Access, src: u32, dst: u32) -> (Option<OwnershipBarrier>, Access) {
    if src == dst {
        return (None, Access::Nothing);
    }
    let f = last.info();
    let barrier = OwnershipBarrier {
        src_stage: f.stage,
        src_access: f.access,
        dst_stage: vk::PipelineStageFlags2::NONE,
        dst_access: vk::AccessFlags2::NONE,
        src_family: src,
        dst_family: dst,
    };
    (Some(barrier), Access::Released)
}

/// The acquire on family `dst` of a buffer handed over from family `src`, for the access `to`:
/// a barrier only when the families differ and the buffer was released (a buffer never released,
/// new or last used on `dst`, needs none), and the tracked access afterwards (`to`).
pub fn acquire(last: Access, src: u32, dst: u32, to: Access) -> (Option<OwnershipBarrier>, Access) {
    if src == dst || last != Access::Released {
        return (None, to);
    }
    let t = to.info();
    let barrier = OwnershipBarrier {
        src_stage: vk::PipelineStageFlags2::NONE,
        src_access: vk::AccessFlags2::NONE,
        dst_stage: t.stage,
        dst_access: t.access,
        src_family: src,
        dst_family: dst,
    };
    (Some(barrier), to)
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn every_access_has_a_consistent_stage_and_layout() {
        let all = [
            Access::Nothing,
            Access::ColorAttachmentWrite,
            Access::ColorAttachmentBlend,
            Access::DepthAttachmentWrite,
            Access::DepthAttachmentRead,
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
            Access::HostWrite,
            Access::Present,
            Access::Released,
        ];
        for a in all {
            let i = a.info();
            // An access with memory effects must name the stage that performs them.
            if !i.access.is_empty() {
                assert_ne!(i.stage, vk::PipelineStageFlags2::NONE, "{a:?}");
            }
        }
        assert!(Access::ComputeStorageWrite.writes());
        assert!(!Access::FragmentSampledRead.writes());
    }

    #[test]
    fn ownership_transfer_between_families_is_a_matching_release_and_acquire() {
        let (transfer, graphics) = (2, 0);
        // The photon map's upload: written by a copy on the transfer family, drawn as vertex
        // input on the graphics family.
        let (rel, state) = release(Access::TransferDst, transfer, graphics);
        let rel = rel.expect("families differ: a release barrier");
        assert_eq!(state, Access::Released);
        assert_eq!((rel.src_family, rel.dst_family), (transfer, graphics));
        assert_eq!(rel.src_stage, vk::PipelineStageFlags2::ALL_TRANSFER);
        assert_eq!(rel.src_access, vk::AccessFlags2::TRANSFER_WRITE);
        assert_eq!(rel.dst_stage, vk::PipelineStageFlags2::NONE);
        assert_eq!(rel.dst_access, vk::AccessFlags2::NONE);
        let (acq, state) = acquire(state, transfer, graphics, Access::VertexInput);
        let acq = acq.expect("released: an acquire barrier");
        assert_eq!(state, Access::VertexInput);
        // The spec's rule: both halves name the same pair of families.
        assert_eq!(
            (acq.src_family, acq.dst_family),
            (rel.src_family, rel.dst_family)
        );
        assert_eq!(acq.src_stage, vk::PipelineStageFlags2::NONE);
        assert_eq!(
            acq.dst_stage,
            vk::PipelineStageFlags2::VERTEX_ATTRIBUTE_INPUT
        );
        assert_eq!(acq.dst_access, vk::AccessFlags2::VERTEX_ATTRIBUTE_READ);
        // And back: the bounce map's readback releases the graphics family's compute write to
        // the transfer family.
        let (rel, state) = release(Access::ComputeStorageWrite, graphics, transfer);
        let rel = rel.expect("a release");
        assert!(rel
            .src_access
            .contains(vk::AccessFlags2::SHADER_STORAGE_WRITE));
        let (acq, _) = acquire(state, graphics, transfer, Access::TransferSrc);
        assert_eq!(
            acq.map(|a| (a.src_family, a.dst_family, a.dst_access)),
            Some((graphics, transfer, vk::AccessFlags2::TRANSFER_READ))
        );
    }

    #[test]
    fn one_family_or_an_unreleased_buffer_needs_no_ownership_barrier() {
        // One family (lavapipe, or a logical transfer queue): the semaphore is enough.
        let (rel, state) = release(Access::TransferDst, 0, 0);
        assert_eq!((rel, state), (None, Access::Nothing));
        assert_eq!(
            acquire(state, 0, 0, Access::VertexInput),
            (None, Access::VertexInput)
        );
        // A new buffer first used on the other family was never owned by anyone.
        assert_eq!(
            acquire(Access::Nothing, 2, 0, Access::VertexInput),
            (None, Access::VertexInput)
        );
    }
}
