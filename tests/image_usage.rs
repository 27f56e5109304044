//! Image usage derived from the passes' declared uses (`src/gpu/image.rs`): a planned image is
//! made with its maker's own usage and every use the passes declared before
//! `Gpu::make_planned`, its descriptor bindings written once it is made; a use declared too
//! late, or an image nobody uses, is reported by name; each thread makes its own plan.

mod common;

use common::{assert_validation_clean, gpu};
use ispm::config::settings::{RenderSettings, Tonemap};
use ispm::gpu::{vk, Buffer, Gpu, Image, ImageDesc, MemoryLocation, QueueRole, ViewKind};
use ispm::passes::tonemap::TonemapPass;
use ispm::render::frame::Renderer;
use ispm::scene::bundled;
use std::sync::Arc;

type U = vk::ImageUsageFlags;

fn desc(name: &str, format: vk::Format, usage: U) -> ImageDesc<'_> {
    ImageDesc {
        name,
        format,
        width: 8,
        height: 4,
        layers: 1,
        usage,
        view: ViewKind::D2,
    }
}

const HDR: vk::Format = vk::Format::R32G32B32A32_SFLOAT;
const LDR: vk::Format = vk::Format::R8G8B8A8_UNORM;

/// A planned HDR image the tonemapping reads (copied into) and an LDR one it writes (read
/// back): `{name}.hdr`, `{name}.ldr`.
fn planned_pair(gpu: &Arc<Gpu>, name: &str) -> (Image, Image) {
    let hdr = Image::planned(gpu, &desc(&format!("{name}.hdr"), HDR, U::TRANSFER_DST));
    let ldr = Image::planned(gpu, &desc(&format!("{name}.ldr"), LDR, U::TRANSFER_SRC));
    (hdr, ldr)
}

/// Fills `hdr` with a ramp, tonemaps it into `ldr` with `pass` and reads `ldr` back.
fn tonemap(gpu: &Arc<Gpu>, pass: &TonemapPass, hdr: &Image, ldr: &mut Image) -> Vec<u8> {
    let texels: Vec<f32> = (0..8 * 4 * 4).map(|i| i as f32 / 64.0).collect();
    let bytes: &[u8] = bytemuck::cast_slice(&texels);
    let staging = Buffer::new(
        gpu,
        "ramp",
        bytes.len() as u64,
        vk::BufferUsageFlags::TRANSFER_SRC,
        MemoryLocation::CpuToGpu,
    )
    .expect("staging");
    staging.write(0, bytes).expect("write");
    gpu.one_shot(QueueRole::Graphics, "tonemap", |cmd| {
        cmd.copy_buffer_to_image(&staging, hdr);
        pass.record(cmd, hdr, Tonemap::Aces, 0.0, ldr);
    })
    .expect("submitted");
    gpu.read_image(ldr).expect("readback")
}

#[test]
fn planned_images_get_their_makers_usage_and_the_uses_their_passes_declare() {
    let gpu = gpu();
    // The makers' own uses: copied into, read back.
    let (hdr, mut ldr) = planned_pair(&gpu, "planned");
    let pass = TonemapPass::new(&gpu, &hdr, &ldr).expect("pass");
    assert!(!hdr.is_made() && !ldr.is_made());
    // The pass's declared uses (Sampled(hdr), Storage(ldr)) are in the usage already.
    assert_eq!(hdr.usage(), U::TRANSFER_DST | U::SAMPLED);
    assert_eq!(ldr.usage(), U::TRANSFER_SRC | U::STORAGE);
    assert_eq!(gpu.waiting_descriptor_writes(), 2);
    gpu.make_planned().expect("made");
    assert_eq!(gpu.waiting_descriptor_writes(), 0);
    assert!(hdr.is_made() && ldr.is_made());
    assert_eq!(hdr.usage(), U::TRANSFER_DST | U::SAMPLED);
    assert_eq!(ldr.usage(), U::TRANSFER_SRC | U::STORAGE);
    let planned = tonemap(&gpu, &pass, &hdr, &mut ldr);

    // The same pass over images made at once with every flag stated: its descriptor set is
    // written when it is made. The waiting writes of the planned pass must give the same.
    let hdr = Image::new(&gpu, &desc("made.hdr", HDR, U::TRANSFER_DST | U::SAMPLED)).unwrap();
    let mut ldr = Image::new(&gpu, &desc("made.ldr", LDR, U::TRANSFER_SRC | U::STORAGE)).unwrap();
    let pass = TonemapPass::new(&gpu, &hdr, &ldr).expect("pass");
    let made = tonemap(&gpu, &pass, &hdr, &mut ldr);
    assert_eq!(planned, made);
    // Colour, not only the alpha the tonemapping writes as 1 everywhere.
    let rgb = |p: &[u8]| p[..3] != [0, 0, 0];
    assert!(made.chunks(4).any(rgb), "the ramp tonemaps to some colour");
    gpu.wait_idle().expect("idle");
    assert_validation_clean(&gpu);
}

#[test]
#[should_panic(expected = "late.hdr is used as SampledImage but was made without SAMPLED")]
fn a_use_declared_after_its_image_is_made_names_the_image_and_the_use() {
    let gpu = gpu();
    let (hdr, ldr) = planned_pair(&gpu, "late");
    gpu.make_planned().expect("made");
    let _ = TonemapPass::new(&gpu, &hdr, &ldr);
}

#[test]
fn a_pass_dropped_before_its_images_are_made_leaves_no_write_behind() {
    let gpu = gpu();
    let (hdr, ldr) = planned_pair(&gpu, "dropped");
    // Its set's bindings of the two images wait; the pass (and its descriptor pool) goes first,
    // taking its waiting writes with it.
    let pass = TonemapPass::new(&gpu, &hdr, &ldr).expect("pass");
    assert_eq!(gpu.waiting_descriptor_writes(), 2);
    drop(pass);
    assert_eq!(gpu.waiting_descriptor_writes(), 0);
    gpu.make_planned().expect("made");
    // The usage it declared stays (the images were made for it).
    assert_eq!(hdr.usage(), U::TRANSFER_DST | U::SAMPLED);
    gpu.wait_idle().expect("idle");
    assert_validation_clean(&gpu);
}

#[test]
#[should_panic(expected = "barrier.ldr is used as ColorAttachmentWrite but was made without")]
fn a_command_using_an_image_in_a_way_it_was_not_made_for_names_the_image() {
    let gpu = gpu();
    let ldr = Image::new(&gpu, &desc("barrier.ldr", LDR, U::STORAGE)).expect("image");
    let _ = gpu.one_shot(QueueRole::Graphics, "wrong use", |cmd| {
        cmd.transition(&ldr, ispm::gpu::Access::ColorAttachmentWrite);
    });
}

#[test]
fn a_planned_image_no_pass_uses_is_an_error_naming_it_and_the_others_are_made() {
    let gpu = gpu();
    let unused = Image::planned(&gpu, &desc("nobody.uses.me", HDR, U::empty()));
    let (hdr, ldr) = planned_pair(&gpu, "beside");
    let _pass = TonemapPass::new(&gpu, &hdr, &ldr).expect("pass");
    let error = gpu.make_planned().expect_err("nothing to make it for");
    assert!(error.to_string().contains("nobody.uses.me"), "{error}");
    // The others are made and their bindings written; the unused one stays planned, and is
    // made once something declares a use of it.
    assert!(hdr.is_made() && ldr.is_made() && !unused.is_made());
    assert_eq!(gpu.waiting_descriptor_writes(), 0);
    unused.require(U::SAMPLED, "a late reader");
    gpu.make_planned().expect("made now");
    assert!(unused.is_made());
    gpu.wait_idle().expect("idle");
    assert_validation_clean(&gpu);
}

#[test]
fn each_thread_makes_only_the_images_it_planned() {
    let gpu = gpu();
    let (hdr, ldr) = planned_pair(&gpu, "mine");
    let _pass = TonemapPass::new(&gpu, &hdr, &ldr).expect("pass");
    // Another thread (another renderer being made on the same device) makes its own plan only:
    // these images' passes may not have declared every use yet.
    std::thread::scope(|s| {
        s.spawn(|| gpu.make_planned().expect("nothing of its own"));
    });
    assert!(!hdr.is_made() && !ldr.is_made());
    assert_eq!(gpu.waiting_descriptor_writes(), 2);
    gpu.make_planned().expect("made");
    assert!(hdr.is_made() && ldr.is_made());
    assert_eq!(gpu.waiting_descriptor_writes(), 0);
    gpu.wait_idle().expect("idle");
    assert_validation_clean(&gpu);
}

#[test]
fn the_frames_radiance_is_a_colour_attachment_only_where_the_scene_has_glass() {
    let gpu = gpu();
    let settings = RenderSettings {
        width: 32,
        height: 32,
        photons: 2_000,
        shadow_resolution: 64,
        ..Default::default()
    };
    let usage = |name| {
        let scene = bundled::resolve(Some(name)).expect("bundled");
        let mut renderer = Renderer::new(&gpu, &scene, settings.clone()).expect("renderer");
        assert!(renderer.radiance().is_made());
        // A frame, so that every descriptor binding that waited for its image is used.
        let frame = renderer.render().expect("frame");
        assert!(frame.hdr.iter().any(|&v| v > 0.0), "{name} renders black");
        renderer.radiance().usage()
    };
    // Written by the direct pass and the composite, read by the tonemapping, read back.
    let base = U::STORAGE | U::SAMPLED | U::TRANSFER_SRC;
    assert_eq!(usage("diffuse-box"), base);
    // The translucent pass draws the glass over it.
    assert_eq!(usage("glass-sphere"), base | U::COLOR_ATTACHMENT);
    assert_validation_clean(&gpu);
}
