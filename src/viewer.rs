//! `ispm view`: the frame in a window (winit 0.30's `ApplicationHandler`).
//!
//! ```text
//!  resumed ──► window, Gpu (with the display's surface extensions), Swapchain, Renderer
//!  RedrawRequested ──► Renderer::submit_frame ──► Swapchain::present(tonemapped image)
//!                         (frames in flight)       (acquire, blit scaled to the window, present)
//!  Resized / out of date ──► Swapchain::recreate      minimised (0×0) ──► no frame
//!  Esc, close ──► exit                                --frames N ──► screenshot of frame N, exit
//! ```
//!
//! An animated scene (glTF animations, `--orbit-lights`) is posed before each frame
//! (`Renderer::set_pose`) at the wall-clock time since the first frame; with `--frames N` time
//! advances by [`FRAME_STEP_SECONDS`] per frame instead, so a scripted run renders the same
//! frames on any machine.
//!
//! The renderer draws at the size the viewer started with; the present blit scales its image
//! to the window, so a resize costs a swapchain, not a renderer.

use crate::frame::{RenderSettings, Renderer};
use crate::gpu::{Gpu, GpuOptions, Presented, Swapchain};
use crate::scene::{Scene, FRAME_STEP_SECONDS};
use raw_window_handle::HasDisplayHandle;
use std::path::PathBuf;
use std::sync::Arc;
use std::time::Instant;
use winit::application::ApplicationHandler;
use winit::dpi::PhysicalSize;
use winit::event::{ElementState, KeyEvent, WindowEvent};
use winit::event_loop::{ActiveEventLoop, EventLoop};
use winit::keyboard::{Key, NamedKey};
use winit::window::{Window, WindowId};

/// What `ispm view` was asked to do.
#[derive(Clone, Debug)]
pub struct ViewSettings {
    pub render: RenderSettings,
    pub device_index: Option<usize>,
    /// Render this many frames, then write [`Self::screenshot`] and exit (the viewer's smoke
    /// test); `None`: run until closed.
    pub frames: Option<u32>,
    pub screenshot: Option<PathBuf>,
    /// Ask the window system for this size after this many frames (tests drive a resize).
    pub resize_at: Option<(u32, (u32, u32))>,
}

/// What a finished `ispm view` run reports.
#[derive(Debug, Default)]
pub struct ViewReport {
    pub frames: u32,
    /// Swapchains made after the first (resizes, out-of-date presents).
    pub recreated: u32,
    pub validation_messages: Vec<String>,
}

struct State {
    // Field order is drop order: the swapchain (and its surface) before the window.
    renderer: Renderer,
    swapchain: Swapchain,
    gpu: Arc<Gpu>,
    window: Arc<Window>,
}

struct Viewer {
    scene: Scene,
    settings: ViewSettings,
    state: Option<State>,
    report: ViewReport,
    error: Option<anyhow::Error>,
    /// When the first frame began (the animation's clock).
    started: Option<Instant>,
}

/// Opens the window and runs until closed (or `frames` are done).
pub fn run(scene: Scene, settings: ViewSettings) -> anyhow::Result<ViewReport> {
    let event_loop = EventLoop::new()
        .map_err(|e| anyhow::anyhow!("cannot open a window (no display? try xvfb-run): {e}"))?;
    let mut viewer = Viewer {
        scene,
        settings,
        state: None,
        report: ViewReport::default(),
        error: None,
        started: None,
    };
    event_loop.run_app(&mut viewer)?;
    if let Some(e) = viewer.error {
        return Err(e);
    }
    if let Some(state) = &viewer.state {
        viewer.report.validation_messages = state.gpu.validation_messages();
    }
    Ok(viewer.report)
}

impl Viewer {
    fn start(&mut self, event_loop: &ActiveEventLoop) -> anyhow::Result<()> {
        let (w, h) = (self.settings.render.width, self.settings.render.height);
        let attributes = Window::default_attributes()
            .with_title("ispm")
            .with_inner_size(PhysicalSize::new(w, h));
        let window = Arc::new(event_loop.create_window(attributes)?);
        let display = window
            .display_handle()
            .map_err(|e| anyhow::anyhow!("no display handle: {e}"))?
            .as_raw();
        let gpu = Gpu::new(&GpuOptions {
            device_index: self.settings.device_index,
            display: Some(display),
            ..Default::default()
        })?;
        let size = window.inner_size();
        let swapchain = Swapchain::new(&gpu, window.as_ref(), (size.width, size.height))?;
        let renderer = Renderer::new(&gpu, &self.scene, self.settings.render.clone())?;
        window.request_redraw();
        self.state = Some(State {
            renderer,
            swapchain,
            gpu,
            window,
        });
        Ok(())
    }

    /// Seconds into the scene's motion for the next frame.
    fn animation_time(&mut self) -> f32 {
        let started = *self.started.get_or_insert_with(Instant::now);
        match self.settings.frames {
            Some(_) => self.report.frames as f32 * FRAME_STEP_SECONDS,
            None => started.elapsed().as_secs_f32(),
        }
    }

    /// One frame: render, present, and the scripted steps of `--frames`.
    fn frame(&mut self, event_loop: &ActiveEventLoop) -> anyhow::Result<()> {
        let t = self.animation_time();
        let Some(state) = &mut self.state else {
            return Ok(());
        };
        let size = state.window.inner_size();
        if size.width == 0 || size.height == 0 {
            return Ok(()); // minimised: nothing to show, nothing to render
        }
        if self.scene.is_animated() {
            state.renderer.set_pose(&self.scene.pose_at(t))?;
        }
        state.renderer.submit_frame()?;
        let display = state.renderer.display();
        if state.swapchain.present(display)? == Presented::OutOfDate {
            state.swapchain.recreate((size.width, size.height))?;
            self.report.recreated += 1;
        }
        self.report.frames += 1;
        if let Some((at, (w, h))) = self.settings.resize_at {
            if self.report.frames == at {
                let _ = state.window.request_inner_size(PhysicalSize::new(w, h));
            }
        }
        if self.settings.frames == Some(self.report.frames) {
            let frame = state.renderer.finish()?;
            if let Some(path) = &self.settings.screenshot {
                crate::output::write_png(path, frame.width, frame.height, &frame.ldr)?;
            }
            event_loop.exit();
        }
        Ok(())
    }

    fn fail(&mut self, event_loop: &ActiveEventLoop, e: anyhow::Error) {
        self.error.get_or_insert(e);
        event_loop.exit();
    }
}

impl ApplicationHandler for Viewer {
    fn resumed(&mut self, event_loop: &ActiveEventLoop) {
        if self.state.is_none() {
            if let Err(e) = self.start(event_loop) {
                self.fail(event_loop, e);
            }
        }
    }

    fn window_event(&mut self, event_loop: &ActiveEventLoop, _: WindowId, event: WindowEvent) {
        match event {
            WindowEvent::CloseRequested => event_loop.exit(),
            WindowEvent::KeyboardInput {
                event:
                    KeyEvent {
                        logical_key: Key::Named(NamedKey::Escape),
                        state: ElementState::Pressed,
                        ..
                    },
                ..
            } => event_loop.exit(),
            WindowEvent::Resized(size) if size.width > 0 && size.height > 0 => {
                if let Some(state) = &mut self.state {
                    if let Err(e) = state.swapchain.recreate((size.width, size.height)) {
                        self.fail(event_loop, e);
                        return;
                    }
                    self.report.recreated += 1;
                }
            }
            WindowEvent::RedrawRequested => {
                if let Err(e) = self.frame(event_loop) {
                    self.fail(event_loop, e);
                }
            }
            _ => {}
        }
    }

    fn about_to_wait(&mut self, _: &ActiveEventLoop) {
        if let Some(state) = &self.state {
            state.window.request_redraw();
        }
    }
}
