//! The barrier tracker (`src/gpu/tracker.rs`) on a device, under the validation layer: a
//! recording hands its resources' states back only when it is submitted, so one dropped half
//! way (an error mid-frame) leaves the next recording barriers that match what the GPU has.

use ispm::gpu::{vk, Access, Gpu, GpuOptions, Image, ImageDesc, QueueRole, ViewKind};
use std::sync::Arc;

fn gpu() -> Arc<Gpu> {
    Gpu::new(&GpuOptions {
        validation: true,
        ..Default::default()
    })
    .expect("a Vulkan 1.3 device with the validation layer")
}

fn image(gpu: &Arc<Gpu>) -> Image {
    Image::new(
        gpu,
        &ImageDesc {
            name: "tracked",
            format: vk::Format::R32G32B32A32_SFLOAT,
            width: 8,
            height: 8,
            layers: 1,
            usage: vk::ImageUsageFlags::STORAGE | vk::ImageUsageFlags::TRANSFER_SRC,
            view: ViewKind::D2,
        },
    )
    .expect("image")
}

#[test]
fn a_recording_dropped_unsubmitted_leaves_the_layout_the_gpu_has() {
    let gpu = gpu();
    let image = image(&gpu);
    {
        // Moves the image to GENERAL in a command buffer the GPU never sees.
        let rec = gpu
            .record(QueueRole::Graphics, "dropped", None)
            .expect("recording");
        rec.cmd().transition(&image, Access::ComputeStorageWrite);
    }
    // The image is still UNDEFINED on the GPU: the readback's barrier must say so, or the
    // validation layer reports a layout mismatch at submission.
    gpu.read_image(&image).expect("readback");
    gpu.wait_idle().expect("idle");
    let messages = gpu.validation_messages();
    assert!(messages.is_empty(), "validation: {messages:#?}");
}

#[test]
fn a_submitted_recording_hands_its_states_to_the_next() {
    let gpu = gpu();
    let image = image(&gpu);
    gpu.one_shot(QueueRole::Graphics, "to general", |cmd| {
        cmd.transition(&image, Access::ComputeStorageWrite);
    })
    .expect("submitted");
    // GENERAL now: read back from there (twice: the second finds it in TRANSFER_SRC).
    gpu.read_image(&image).expect("readback");
    gpu.read_image(&image).expect("readback again");
    gpu.wait_idle().expect("idle");
    let messages = gpu.validation_messages();
    assert!(messages.is_empty(), "validation: {messages:#?}");
}
