//! The planned images not made yet, and the descriptor writes that wait for them
//! (`gpu/image.rs` has the picture). The images are seen through [`PlannedImage`], so that the
//! device does not depend on the image module (which depends on it).
//!
//! A pass made while an image it binds is only planned writes the rest of its descriptor set
//! at once; the bindings of planned images wait here until [`Gpu::make_planned`] has made the
//! images with the usage every pass declared, then are written. Both lists hold their images
//! weakly: a planned image dropped before it is made is never made, and its waiting writes are
//! dropped with it; a descriptor layout dropped first forgets the writes into its pool.

use super::Gpu;
use crate::gpu::error::GpuResult;
use ash::vk;
use std::sync::{Arc, Weak};

/// What the device needs of a planned image: to make it, and its view once made.
pub(crate) trait PlannedImage: Send + Sync {
    fn make(&self) -> GpuResult<()>;
    /// Its full view, once made.
    fn made_view(&self) -> Option<vk::ImageView>;
}

/// The [`Gpu`]'s planned images and waiting writes.
#[derive(Default)]
pub(crate) struct Planned {
    images: Vec<Weak<dyn PlannedImage>>,
    writes: Vec<WaitingWrite>,
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
        self.planned().images.push(Arc::downgrade(image));
    }

    /// Keeps `write` until its image is made (it replaces a write still waiting for the same
    /// binding of the same set).
    pub(crate) fn defer_write(&self, write: WaitingWrite) {
        let mut planned = self.planned();
        planned
            .writes
            .retain(|w| (w.set, w.binding) != (write.set, write.binding));
        planned.writes.push(write);
    }

    /// Forgets a write waiting for `binding` of `set`: that binding was written since.
    pub(crate) fn forget_write(&self, set: vk::DescriptorSet, binding: u32) {
        let mut planned = self.planned();
        if !planned.writes.is_empty() {
            planned
                .writes
                .retain(|w| (w.set, w.binding) != (set, binding));
        }
    }

    /// Forgets every write waiting for a set of `pool` (its layout is being dropped).
    pub(crate) fn forget_writes(&self, pool: vk::DescriptorPool) {
        self.planned().writes.retain(|w| w.pool != pool);
    }

    /// Makes every planned image, each with its maker's usage and the uses the passes declared
    /// ([`crate::gpu::uses::writes`], [`crate::gpu::Image::require`]), then writes the descriptor
    /// bindings that waited for them. Call it once the passes that bind the planned images are
    /// made, before the first recording that uses them.
    pub fn make_planned(&self) -> GpuResult<()> {
        let images = std::mem::take(&mut self.planned().images);
        for image in images.iter().filter_map(Weak::upgrade) {
            image.make()?;
        }
        let mut ready = Vec::new();
        {
            let mut planned = self.planned();
            for w in std::mem::take(&mut planned.writes) {
                match w.image.upgrade().map(|i| i.made_view()) {
                    Some(Some(view)) => ready.push((w, view)),
                    Some(None) => planned.writes.push(w),
                    None => {}
                }
            }
        }
        let infos: Vec<_> = ready
            .iter()
            .map(|(w, view)| {
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
            .map(|((w, _), info)| {
                vk::WriteDescriptorSet::default()
                    .dst_set(w.set)
                    .dst_binding(w.binding)
                    .descriptor_type(w.ty)
                    .image_info(info)
            })
            .collect();
        // SAFETY: the sets belong to live pools (a dropped layout forgot its writes), the
        // samplers to the passes that own those sets, the views to images just made; no set
        // has been used by the GPU yet, since its bindings were incomplete until now.
        unsafe { self.raw().update_descriptor_sets(&writes, &[]) };
        Ok(())
    }
}
