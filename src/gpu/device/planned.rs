//! The planned images not made yet, and the descriptor writes that wait for them
//! (`gpu/image.rs` has the picture). The images are seen through [`PlannedImage`], so that the
//! device does not depend on the image module (which depends on it).
//!
//! A pass made while an image it binds is only planned writes the rest of its descriptor set
//! at once; the bindings of planned images wait here until [`Gpu::make_planned`] has made the
//! images with the usage every pass declared, then are written. Both lists hold their images
//! weakly: a planned image dropped before it is made is never made, and its waiting writes are
//! dropped with it; a descriptor layout dropped first forgets the writes into its pool.
//!
//! Entries are kept per thread: `make_planned` makes what its own thread planned, so two
//! renderers made at once on one device (tests on parallel threads) do not make each other's
//! images before their passes have declared their uses.

use super::Gpu;
use crate::gpu::error::GpuResult;
use ash::vk;
use std::sync::{Arc, Weak};
use std::thread::ThreadId;

/// What the device needs of a planned image: to make it, and its view once made.
pub(crate) trait PlannedImage: Send + Sync {
    fn make(&self) -> GpuResult<()>;
    /// Its full view, once made.
    fn made_view(&self) -> Option<vk::ImageView>;
}

/// The [`Gpu`]'s planned images and waiting writes.
#[derive(Default)]
pub(crate) struct Planned {
    images: Vec<(ThreadId, Weak<dyn PlannedImage>)>,
    writes: Vec<(ThreadId, WaitingWrite)>,
}

/// One image binding of a descriptor set, waiting for its image to be made.
pub(crate) struct WaitingWrite {
    /// The pool the set came from (forgotten when its layout is dropped).
    pub pool: vk::DescriptorPool,
    pub set: vk::DescriptorSet,
    pub binding: u32,
    pub ty: vk::DescriptorType,
    pub image: Weak<dyn PlannedImage>,
    pub sampler: vk::Sampler,
    pub layout: vk::ImageLayout,
}

impl Gpu {
    fn planned(&self) -> std::sync::MutexGuard<'_, Planned> {
        self.planned.lock().unwrap_or_else(|e| e.into_inner())
    }

    /// Puts `image` on the list [`Gpu::make_planned`] makes.
    pub(crate) fn plan_image(&self, image: &Arc<dyn PlannedImage>) {
        let here = std::thread::current().id();
        self.planned().images.push((here, Arc::downgrade(image)));
    }

    /// Keeps `write` until its image is made (it replaces a write still waiting for the same
    /// binding of the same set).
    pub(crate) fn defer_write(&self, write: WaitingWrite) {
        let mut planned = self.planned();
        planned
            .writes
            .retain(|(_, w)| (w.set, w.binding) != (write.set, write.binding));
        planned.writes.push((std::thread::current().id(), write));
    }

    /// Forgets a write waiting for `binding` of `set`: that binding was written since.
    pub(crate) fn forget_write(&self, set: vk::DescriptorSet, binding: u32) {
        let mut planned = self.planned();
        if !planned.writes.is_empty() {
            planned
                .writes
                .retain(|(_, w)| (w.set, w.binding) != (set, binding));
        }
    }

    /// How many descriptor bindings wait for their images, on any thread (tests, `planned.rs`'
    /// bookkeeping).
    pub fn waiting_descriptor_writes(&self) -> usize {
        self.planned().writes.len()
    }

    /// Forgets every write waiting for a set of `pool` (its layout is being dropped).
    pub(crate) fn forget_writes(&self, pool: vk::DescriptorPool) {
        self.planned().writes.retain(|(_, w)| w.pool != pool);
    }

    /// Makes every image planned on this thread, each with its maker's usage and the uses the
    /// passes declared ([`crate::gpu::uses::writes`], [`crate::gpu::Image::require`]), then
    /// writes the descriptor bindings that waited for them. Call it once the passes that bind
    /// the planned images are made, before the first recording that uses them. When an image
    /// fails to be made (out of memory), the others are still made and their bindings written,
    /// and the first error is returned; the failed image stays planned.
    ///
    /// The sets written must not be in use by the GPU, and the samplers their waiting writes
    /// name must still live: both hold for sets a pass allocated and has not used yet (a set
    /// with a waiting binding cannot have been used: it was incomplete), whose samplers the
    /// pass owns beside the set's layout (dropping the layout forgets its writes).
    pub fn make_planned(&self) -> GpuResult<()> {
        let here = std::thread::current().id();
        let mine: Vec<_> = {
            let mut planned = self.planned();
            let (mine, others) = std::mem::take(&mut planned.images)
                .into_iter()
                .partition(|(thread, _)| *thread == here);
            planned.images = others;
            mine
        };
        let mut first_error = None;
        for (thread, image) in mine {
            let Some(cell) = image.upgrade() else {
                continue;
            };
            if let Err(e) = cell.make() {
                self.planned().images.push((thread, image));
                first_error.get_or_insert(e);
            }
        }
        let mut ready = Vec::new();
        {
            let mut planned = self.planned();
            for (thread, w) in std::mem::take(&mut planned.writes) {
                if thread != here {
                    planned.writes.push((thread, w));
                    continue;
                }
                // Kept alive (`_image`) until the writes below are done.
                let Some(image) = w.image.upgrade() else {
                    continue;
                };
                match image.made_view() {
                    Some(view) => ready.push((w, view, image)),
                    None => planned.writes.push((thread, w)),
                }
            }
        }
        let infos: Vec<_> = ready
            .iter()
            .map(|(w, view, _image)| {
                [vk::DescriptorImageInfo {
                    sampler: w.sampler,
                    image_view: *view,
                    image_layout: w.layout,
                }]
            })
            .collect();
        let writes: Vec<_> = ready
            .iter()
            .zip(&infos)
            .map(|((w, _, _), info)| {
                vk::WriteDescriptorSet::default()
                    .dst_set(w.set)
                    .dst_binding(w.binding)
                    .descriptor_type(w.ty)
                    .image_info(info)
            })
            .collect();
        // SAFETY: the sets belong to live pools (a dropped layout forgot its writes); the
        // samplers live and the sets are unused by the GPU (the caller's obligations above);
        // the views are of images made and still alive (upgraded above).
        unsafe { self.raw().update_descriptor_sets(&writes, &[]) };
        first_error.map_or(Ok(()), Err)
    }
}
