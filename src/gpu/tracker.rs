//! Barrier tracking: what the GPU last did to each buffer and image, and the barrier its next use
//! needs.
//!
//! A resource keeps only its state *at rest*: the state the last submitted recording left it
//! in. A recording checks a resource's state out when it first touches it, carries it forward
//! use by use in its own [`Tracker`], and hands it back when it is submitted
//! ([`Tracker::commit`]). A recording dropped unsubmitted (an error half way through a frame)
//! hands nothing back, so the states at rest always describe the work that reached the GPU.
//!
//! ```text
//!   resource at rest ──first use──► Tracker of the recording ──submit──► resource at rest
//!                                     use: State × Access → (barrier?, State)
//! ```
//!
//! The rule ([`State::next`]): a use waits for the last write (and, when it writes or changes
//! the image layout, for every read since); a read that an earlier barrier already made the
//! write visible to needs nothing. Queue-family ownership follows the same path: the family
//! that last used a resource is part of its state, a release hands it to another family, and
//! the first use on that family acquires it (Vulkan spec §7.7.4), so no pass pairs the halves
//! by hand.

use super::access::Access;
use ash::vk;
use std::sync::atomic::{AtomicU64, Ordering};
use std::sync::{Arc, Mutex};

/// What the barriers need to know of a resource's past.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub struct State {
    /// The image layout (buffers: always `UNDEFINED`).
    pub layout: vk::ImageLayout,
    /// The source half a later barrier must wait for: the last write's stages and accesses (a
    /// layout transition or an acquire counts as a write at its barrier's destination stages,
    /// with nothing left to make available). `None`: nothing written since the resource was
    /// made.
    write: Option<(vk::PipelineStageFlags2, vk::AccessFlags2)>,
    /// The reads ordered after the last write, one bit per [`Access`] (`Access as u32`): a
    /// read in this set needs no barrier.
    readers: u64,
    /// Their stages: a write (or a layout change) waits for all of them.
    reader_stages: vk::PipelineStageFlags2,
    /// The queue family that last used the resource, if any.
    pub family: Option<u32>,
    /// Released by `family` to this family, which must acquire it before use.
    pub released_to: Option<u32>,
}

impl Default for State {
    fn default() -> Self {
        State {
            layout: vk::ImageLayout::UNDEFINED,
            write: None,
            readers: 0,
            reader_stages: vk::PipelineStageFlags2::NONE,
            family: None,
            released_to: None,
        }
    }
}

/// One barrier derived by [`State::next`] or [`State::release`]: its two halves, the layouts
/// (images only), and the queue families of an ownership transfer (`None`: not a transfer).
///
/// An ownership transfer of a buffer is two barriers naming the same two families: the
/// release, recorded on the source family's queue, and the acquire, recorded on the
/// destination family's queue in a submission that waits on the release's semaphore. The
/// spec ignores the release's destination access mask and the acquire's source access mask
/// (left empty); the stage masks still order: the release's destination stages are left empty
/// (the semaphore signal follows it), the acquire's source stages are all commands.
///
/// ```text
///   transfer queue (family T)               graphics queue (family G)
///   copy → photons  [TransferDst]
///   release T→G: src = TransferDst, dst = ∅ ──timeline──► acquire T→G: src = all, dst = VertexInput
/// ```
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub struct Barrier {
    pub src_stage: vk::PipelineStageFlags2,
    pub src_access: vk::AccessFlags2,
    pub dst_stage: vk::PipelineStageFlags2,
    pub dst_access: vk::AccessFlags2,
    pub old_layout: vk::ImageLayout,
    pub new_layout: vk::ImageLayout,
    pub families: Option<(u32, u32)>,
}

fn bit(access: Access) -> u64 {
    1 << (access as u32)
}

/// The write half of `access`: what a later barrier must make available (its reads need
/// nothing made available).
fn writes_of(access: vk::AccessFlags2) -> vk::AccessFlags2 {
    access
        & (vk::AccessFlags2::SHADER_STORAGE_WRITE
            | vk::AccessFlags2::COLOR_ATTACHMENT_WRITE
            | vk::AccessFlags2::DEPTH_STENCIL_ATTACHMENT_WRITE
            | vk::AccessFlags2::TRANSFER_WRITE
            | vk::AccessFlags2::HOST_WRITE)
}

impl State {
    /// The barrier (if any) that makes `to`, on queue family `family`, wait for what came
    /// before, and the state after it. `image`: whether the resource has a layout.
    ///
    /// # Panics
    /// In debug builds, when the resource is used on a family that does not own it: released
    /// to another family, or last used by another family and never released (its contents
    /// are undefined there; the frame script must hand it over with a release).
    pub fn next(&mut self, to: Access, family: u32, image: bool) -> Option<Barrier> {
        let t = to.info();
        // A use without a stage (Nothing) orders nothing: it is not a use to track.
        debug_assert!(
            !t.stage.is_empty(),
            "{to:?} is not a use a barrier can wait for"
        );
        let new_layout = if image {
            t.layout
        } else {
            vk::ImageLayout::UNDEFINED
        };
        if let Some(dst) = self.released_to {
            debug_assert!(!image, "only buffers change queue family");
            debug_assert_eq!(
                dst, family,
                "used on queue family {family} while released to {dst}"
            );
            let src = self
                .family
                .expect("a released resource names the family that released it");
            // The acquire: the release already waited for the past and made it available.
            let reads = !to.writes();
            *self = State {
                layout: new_layout,
                write: Some((t.stage, writes_of(t.access))),
                readers: if reads { bit(to) } else { 0 },
                reader_stages: if reads {
                    t.stage
                } else {
                    vk::PipelineStageFlags2::NONE
                },
                family: Some(family),
                released_to: None,
            };
            return Some(Barrier {
                // Every earlier command of this queue, so the acquire also chains through the
                // semaphore wait of an earlier submission on it.
                src_stage: vk::PipelineStageFlags2::ALL_COMMANDS,
                src_access: vk::AccessFlags2::NONE,
                dst_stage: t.stage,
                dst_access: t.access,
                old_layout: new_layout,
                new_layout,
                families: Some((src, family)),
            });
        }
        debug_assert!(
            self.family.is_none_or(|f| f == family),
            "used on queue family {family} after family {:?} without a release",
            self.family
        );
        self.family = Some(family);
        let layout_change = image && self.layout != new_layout;
        let readers = self.reader_stages;
        let (write_stage, write_access) = self
            .write
            .unwrap_or((vk::PipelineStageFlags2::NONE, vk::AccessFlags2::NONE));
        let src_stage = write_stage | readers;
        let needed = layout_change
            || (to.writes() && !src_stage.is_empty())
            || (self.write.is_some() && self.readers & bit(to) == 0);
        let barrier = needed.then_some(Barrier {
            src_stage,
            src_access: write_access,
            dst_stage: t.stage,
            dst_access: t.access,
            old_layout: self.layout,
            new_layout,
            families: None,
        });
        if to.writes() {
            self.write = Some((t.stage, writes_of(t.access)));
            self.readers = 0;
            self.reader_stages = vk::PipelineStageFlags2::NONE;
        } else if layout_change {
            // The transition is a write ordered before `to`'s stages: later reads elsewhere
            // chain on those stages.
            self.write = Some((t.stage, vk::AccessFlags2::NONE));
            self.readers = bit(to);
            self.reader_stages = t.stage;
        } else {
            self.readers |= bit(to);
            self.reader_stages |= t.stage;
        }
        self.layout = new_layout;
        barrier
    }

    /// The release of the resource by `family` to `to` (a different family): the barrier to
    /// record on `family`'s queue, or `None` when there is nothing to hand over (the families
    /// are the same, the resource was never used, or another family holds it).
    pub fn release(&mut self, family: u32, to: u32) -> Option<Barrier> {
        if family == to || self.family != Some(family) || self.released_to.is_some() {
            return None;
        }
        let (write_stage, write_access) = self
            .write
            .unwrap_or((vk::PipelineStageFlags2::NONE, vk::AccessFlags2::NONE));
        self.released_to = Some(to);
        Some(Barrier {
            src_stage: write_stage | self.reader_stages,
            src_access: write_access,
            dst_stage: vk::PipelineStageFlags2::NONE,
            dst_access: vk::AccessFlags2::NONE,
            old_layout: self.layout,
            new_layout: self.layout,
            families: Some((family, to)),
        })
    }
}

/// A resource's state at rest, shared between the resource and the recording that has it
/// checked out.
pub struct Resting {
    pub name: String,
    cell: Mutex<(State, Option<u64>)>,
}

impl Resting {
    pub fn new(name: &str) -> Arc<Resting> {
        Arc::new(Resting {
            name: name.into(),
            cell: Mutex::new((State::default(), None)),
        })
    }

    fn lock(&self) -> std::sync::MutexGuard<'_, (State, Option<u64>)> {
        self.cell.lock().unwrap_or_else(|e| e.into_inner())
    }

    /// The state at rest.
    #[cfg(test)]
    pub fn state(&self) -> State {
        self.lock().0
    }
}

static NEXT_RECORDING: AtomicU64 = AtomicU64::new(1);

/// The states of the resources one recording has touched, in first-touch order.
pub struct Tracker {
    id: u64,
    entries: Vec<(Arc<Resting>, State)>,
}

impl Default for Tracker {
    fn default() -> Self {
        Tracker {
            id: NEXT_RECORDING.fetch_add(1, Ordering::Relaxed),
            entries: Vec::new(),
        }
    }
}

impl Tracker {
    /// This recording's state of `resource`, checked out on first touch.
    ///
    /// # Panics
    /// In debug builds, when another unsubmitted recording holds `resource`: its state at
    /// rest would be stale (record and submit one recording before touching the resource in
    /// the next).
    pub fn state(&mut self, resource: &Arc<Resting>) -> &mut State {
        let i = match self
            .entries
            .iter()
            .position(|(r, _)| Arc::ptr_eq(r, resource))
        {
            Some(i) => i,
            None => {
                let mut cell = resource.lock();
                debug_assert!(
                    cell.1.is_none(),
                    "{} is used by two recordings at once: submit the first before the second \
                     touches it",
                    resource.name
                );
                cell.1 = Some(self.id);
                let state = cell.0;
                drop(cell);
                self.entries.push((resource.clone(), state));
                self.entries.len() - 1
            }
        };
        &mut self.entries[i].1
    }

    /// Hands every touched resource's state back as its state at rest (the recording was
    /// submitted).
    pub fn commit(&mut self) {
        for (resource, state) in self.entries.drain(..) {
            *resource.lock() = (state, None);
        }
    }
}

impl Drop for Tracker {
    fn drop(&mut self) {
        // Not submitted: the states at rest stand; only the check-outs end.
        for (resource, _) in self.entries.drain(..) {
            resource.lock().1 = None;
        }
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use vk::PipelineStageFlags2 as S;

    const G: u32 = 0;
    const T: u32 = 1;

    #[test]
    fn a_first_read_of_a_new_buffer_needs_no_barrier_and_a_write_after_it_waits_for_it() {
        let mut s = State::default();
        assert_eq!(s.next(Access::ComputeStorageRead, G, false), None);
        let b = s.next(Access::ComputeStorageWrite, G, false).expect("WAR");
        assert_eq!(b.src_stage, S::COMPUTE_SHADER);
        assert_eq!(b.src_access, vk::AccessFlags2::NONE);
    }

    #[test]
    fn a_read_waits_for_the_write_once_per_reader_and_the_next_write_waits_for_every_reader() {
        let mut s = State::default();
        assert_eq!(s.next(Access::TransferDst, G, false), None);
        let b = s.next(Access::GraphicsStorageRead, G, false).expect("RAW");
        assert_eq!(
            (b.src_stage, b.src_access),
            (S::ALL_TRANSFER, vk::AccessFlags2::TRANSFER_WRITE)
        );
        assert_eq!(s.next(Access::GraphicsStorageRead, G, false), None);
        let c = s
            .next(Access::ComputeStorageRead, G, false)
            .expect("RAW, other stage");
        assert!(c.dst_stage.contains(S::COMPUTE_SHADER));
        let w = s.next(Access::TransferDst, G, false).expect("WAR");
        assert!(w
            .src_stage
            .contains(S::VERTEX_SHADER | S::FRAGMENT_SHADER | S::COMPUTE_SHADER));
    }

    #[test]
    fn writes_always_wait_for_writes() {
        let mut s = State::default();
        s.next(Access::ComputeStorageWrite, G, false);
        let b = s.next(Access::ComputeStorageWrite, G, false).expect("WAW");
        assert_eq!(b.src_access, vk::AccessFlags2::SHADER_STORAGE_WRITE);
    }

    #[test]
    fn image_layouts_change_once_and_later_readers_chain_on_the_transition() {
        let mut s = State::default();
        let b = s
            .next(Access::ColorAttachmentWrite, G, true)
            .expect("layout");
        assert_eq!(b.old_layout, vk::ImageLayout::UNDEFINED);
        let r = s
            .next(Access::FragmentSampledRead, G, true)
            .expect("layout");
        assert_eq!(r.new_layout, vk::ImageLayout::SHADER_READ_ONLY_OPTIMAL);
        assert_eq!(s.next(Access::FragmentSampledRead, G, true), None);
        let c = s
            .next(Access::ComputeSampledRead, G, true)
            .expect("other stage");
        assert!(c.src_stage.contains(S::FRAGMENT_SHADER));
        assert_eq!(c.old_layout, c.new_layout);
    }

    #[test]
    fn a_release_hands_over_to_the_other_family_and_its_first_use_acquires() {
        let mut s = State::default();
        s.next(Access::ComputeStorageWrite, G, false);
        let r = s.release(G, T).expect("release");
        assert_eq!(r.families, Some((G, T)));
        assert_eq!(r.src_stage, S::COMPUTE_SHADER);
        // A second release, or one by a family that does not hold it, does nothing.
        assert_eq!(s.release(G, T), None);
        let a = s.next(Access::TransferSrc, T, false).expect("acquire");
        assert_eq!(a.families, Some((G, T)));
        assert_eq!(a.src_stage, S::ALL_COMMANDS);
        assert_eq!(s.family, Some(T));
        assert_eq!(s.next(Access::TransferSrc, T, false), None);
    }

    /// The photon buffer's round trip over frames on a GPU whose transfer queue is a family of
    /// its own (`photon_frame`: box A releases whatever the graphics queue holds, the upload
    /// writes and hands back, box D draws), with a frame in between that has no photons
    /// (box A releases, nothing is uploaded or drawn).
    #[test]
    fn the_photon_buffer_goes_round_between_families_also_across_a_frame_without_photons() {
        let mut s = State::default();
        let upload = |s: &mut State| {
            let acquire = s.next(Access::TransferDst, T, false);
            let release = s.release(T, G).expect("upload hands back");
            (acquire, release)
        };
        let draw = |s: &mut State| s.next(Access::GraphicsStorageRead, G, false);
        // Frame 1: never used before, so nothing to release or acquire.
        assert_eq!(s.release(G, T), None);
        let (acquire, _) = upload(&mut s);
        assert_eq!(acquire, None);
        assert_eq!(draw(&mut s).and_then(|b| b.families), Some((T, G)));
        // Frame 2, no photons: box A still hands the buffer over; nothing else touches it.
        assert!(s.release(G, T).is_some());
        // Frame 3: already handed over, box A does nothing; the upload acquires it.
        assert_eq!(s.release(G, T), None);
        let (acquire, release) = upload(&mut s);
        assert_eq!(acquire.and_then(|b| b.families), Some((G, T)));
        assert_eq!(release.families, Some((T, G)));
        assert_eq!(draw(&mut s).and_then(|b| b.families), Some((T, G)));
    }

    #[test]
    fn a_write_waits_for_every_read_since_the_last_write_however_many_kinds() {
        let mut s = State::default();
        s.next(Access::ComputeStorageWrite, G, false);
        s.next(Access::VertexInput, G, false);
        s.next(Access::ComputeStorageRead, G, false);
        s.next(Access::TransferSrc, G, false);
        let w = s.next(Access::ComputeStorageWrite, G, false).expect("WAR");
        assert!(w
            .src_stage
            .contains(S::VERTEX_ATTRIBUTE_INPUT | S::COMPUTE_SHADER | S::COPY));
        // Only the write is made available, not the reads.
        assert_eq!(w.src_access, vk::AccessFlags2::SHADER_STORAGE_WRITE);
    }

    #[test]
    fn a_release_within_one_family_or_of_an_unused_buffer_is_nothing() {
        let mut s = State::default();
        assert_eq!(s.release(G, T), None);
        s.next(Access::TransferDst, G, false);
        assert_eq!(s.release(G, G), None);
        assert_eq!(s.released_to, None);
    }

    #[test]
    fn a_recording_dropped_unsubmitted_leaves_the_state_at_rest() {
        let resource = Resting::new("r");
        {
            let mut t = Tracker::default();
            t.state(&resource)
                .next(Access::ComputeStorageWrite, G, false);
        }
        assert_eq!(resource.state(), State::default());
        let mut t = Tracker::default();
        t.state(&resource)
            .next(Access::ComputeStorageWrite, G, false);
        t.commit();
        assert_eq!(resource.state().family, Some(G));
        // Checked in again: another recording may take it.
        Tracker::default().state(&resource);
    }

    #[test]
    #[cfg(debug_assertions)]
    #[should_panic(expected = "two recordings at once")]
    fn two_recordings_may_not_hold_one_resource() {
        let resource = Resting::new("r");
        let mut a = Tracker::default();
        a.state(&resource);
        Tracker::default().state(&resource);
    }
}
