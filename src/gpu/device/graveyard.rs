//! Deferred destruction (module docs of [`crate::gpu::device`], "Lifetimes"): a [`Retired`]
//! object waits in the [`Gpu`]'s graveyard, tagged with every queue's last submitted timeline
//! value, until [`Gpu::collect_garbage`] sees them complete; dropping the `Gpu` destroys what
//! is left, then the device.

use super::{Gpu, Queue};
use ash::vk;
use gpu_allocator::vulkan::Allocation;
use std::mem::ManuallyDrop;

/// A Vulkan object whose destruction waits for the GPU.
pub(in crate::gpu) enum Retired {
    Buffer(vk::Buffer, Allocation),
    Image(vk::Image, Allocation, Vec<vk::ImageView>),
    Sampler(vk::Sampler),
    Pipeline(vk::Pipeline, vk::PipelineLayout),
    DescriptorPool(vk::DescriptorPool),
    DescriptorSetLayout(vk::DescriptorSetLayout),
    CommandPool(vk::CommandPool),
    QueryPool(vk::QueryPool),
}

impl Gpu {
    /// Hands `object` to the graveyard; it is destroyed once every queue has finished the work
    /// submitted so far.
    pub(in crate::gpu) fn retire(&self, object: Retired) {
        let marks = self.queues.iter().map(Queue::last_submitted).collect();
        if let Ok(mut g) = self.graveyard.lock() {
            g.push((marks, object));
        }
    }

    /// Destroys retired objects whose last possible use has completed.
    pub fn collect_garbage(&self) {
        let done: Vec<u64> = (0..self.queues.len()).map(|q| self.completed(q)).collect();
        let ready: Vec<Retired> = {
            let Ok(mut g) = self.graveyard.lock() else {
                return;
            };
            let (ready, waiting): (Vec<_>, Vec<_>) = std::mem::take(&mut *g)
                .into_iter()
                .partition(|(marks, _)| marks.iter().zip(&done).all(|(m, d)| d >= m));
            *g = waiting;
            ready.into_iter().map(|(_, o)| o).collect()
        };
        for object in ready {
            self.destroy(object);
        }
    }

    fn destroy(&self, object: Retired) {
        let d = &self.device;
        // SAFETY: (every arm) the object belongs to this device and the GPU has finished every
        // submission that could use it (collect_garbage checked the timelines, or Drop waited
        // for the device to go idle).
        unsafe {
            match object {
                Retired::Buffer(b, a) => {
                    let _ = self.allocator().free(a);
                    d.destroy_buffer(b, None);
                }
                Retired::Image(i, a, views) => {
                    for v in views {
                        d.destroy_image_view(v, None);
                    }
                    let _ = self.allocator().free(a);
                    d.destroy_image(i, None);
                }
                Retired::Sampler(s) => d.destroy_sampler(s, None),
                Retired::Pipeline(p, l) => {
                    d.destroy_pipeline(p, None);
                    d.destroy_pipeline_layout(l, None);
                }
                Retired::DescriptorPool(p) => d.destroy_descriptor_pool(p, None),
                Retired::DescriptorSetLayout(l) => d.destroy_descriptor_set_layout(l, None),
                Retired::CommandPool(p) => d.destroy_command_pool(p, None),
                Retired::QueryPool(p) => d.destroy_query_pool(p, None),
            }
        }
    }
}

impl Drop for Gpu {
    fn drop(&mut self) {
        let _ = self.wait_idle();
        let all: Vec<_> = self
            .graveyard
            .get_mut()
            .map(std::mem::take)
            .unwrap_or_default();
        for (_, object) in all {
            self.destroy(object);
        }
        // SAFETY: the device is idle and every resource was destroyed above (resources hold
        // an Arc<Gpu>, so none outlive it). The allocator is dropped before the device; the
        // instance (the `instance` field) is destroyed after this body, when fields drop.
        unsafe {
            ManuallyDrop::drop(&mut self.allocator);
            for q in &self.queues {
                self.device.destroy_semaphore(q.timeline, None);
            }
            self.device.destroy_device(None);
        }
    }
}
