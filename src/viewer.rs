//! `ispm view`: the frame in a window (winit 0.30's `ApplicationHandler`).
//!
//! ```text
//!  resumed ──► window, Gpu (with the display's surface extensions), Swapchain, Renderer
//!  keys, mouse, wheel ──► FlyCamera (camera_control.rs)      --frames N ──► scripted_pose(k)
//!  RedrawRequested ──► Renderer::set_camera ──► Renderer::submit_frame ──► Swapchain::present
//!                                                 (frames in flight)   (blit scaled, present)
//!  Resized / out of date ──► Swapchain::recreate      minimised (0×0) ──► no frame
//!  Esc, close ──► exit                                --frames N ──► screenshot of frame N, exit
//! ```
//!
//! Keys: `W` `A` `S` `D` fly in the view's plane, `Q` `E` down and up; hold the right mouse
//! button to look around; the wheel changes the fly speed; `F` frames the scene; `C` steps
//! through the file's cameras; `Esc` quits. With `--frames N` the camera follows the scripted
//! path instead, frame k (1 … N) at [`scripted_pose`]`(start, bounds, k)`, so the screenshot is
//! the pose `ispm render --camera-path-frame N` renders.
//!
//! An animated scene (glTF animations, `--orbit-lights`) is posed before each frame
//! (`Renderer::set_pose`) at the wall-clock time since the first frame; with `--frames N` time
//! advances by [`FRAME_STEP_SECONDS`] per frame instead, so a scripted run renders the same
//! frames on any machine.
//!
//! The renderer draws at the size the viewer started with; the present blit scales its image
//! to the window, so a resize costs a swapchain, not a renderer. A camera move costs no photon
//! trace (`Renderer::set_camera`).

use crate::camera_control::{scripted_pose, FlyCamera, MoveKeys};
use crate::frame::{RenderSettings, Renderer};
use crate::gpu::{Gpu, GpuOptions, Presented, Swapchain};
use crate::scene::{Aabb, Scene, FRAME_STEP_SECONDS};
use raw_window_handle::HasDisplayHandle;
use std::path::PathBuf;
use std::sync::Arc;
use std::time::Instant;
use winit::application::ApplicationHandler;
use winit::dpi::{PhysicalPosition, PhysicalSize};
use winit::event::{ElementState, KeyEvent, MouseButton, MouseScrollDelta, WindowEvent};
use winit::event_loop::{ActiveEventLoop, EventLoop};
use winit::keyboard::{Key, KeyCode, NamedKey, PhysicalKey};
use winit::window::{Window, WindowId};

/// Wheel pixels (touchpads) per notch of fly speed.
const PIXELS_PER_NOTCH: f64 = 50.0;
/// The longest time step a frame flies (a stalled frame does not throw the camera far).
const MAX_FLY_STEP_S: f32 = 0.1;

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
    /// The scene's bounds (framing, fly speed, the scripted path's pivot).
    bounds: Aabb,
    settings: ViewSettings,
    state: Option<State>,
    report: ViewReport,
    error: Option<anyhow::Error>,
    input: Input,
    /// When the first frame began (the animation's clock).
    started: Option<Instant>,
}

/// The interactive camera and the input that drives it.
struct Input {
    fly: FlyCamera,
    keys: MoveKeys,
    /// Held: the cursor turns the view.
    right_button: bool,
    /// The cursor's last position while the right button is held.
    cursor: Option<PhysicalPosition<f64>>,
    /// When the last frame flew (its time step).
    last_step: Option<Instant>,
    /// Which of the file's cameras `C` showed last (`None`: not one of them).
    camera_index: Option<usize>,
}

/// Opens the window and runs until closed (or `frames` are done).
pub fn run(scene: Scene, settings: ViewSettings) -> anyhow::Result<ViewReport> {
    let event_loop = EventLoop::new()
        .map_err(|e| anyhow::anyhow!("cannot open a window (no display? try xvfb-run): {e}"))?;
    let bounds = scene.bounds();
    let input = Input {
        fly: FlyCamera::new(scene.camera, bounds),
        keys: MoveKeys::default(),
        right_button: false,
        cursor: None,
        last_step: None,
        camera_index: scene.cameras.iter().position(|c| *c == scene.camera),
    };
    let mut viewer = Viewer {
        scene,
        bounds,
        settings,
        state: None,
        report: ViewReport::default(),
        error: None,
        input,
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
            self.input.last_step = None; // no flying through a minimised stretch
            return Ok(()); // minimised: nothing to show, nothing to render
        }
        if self.scene.is_animated() {
            state.renderer.set_pose(&self.scene.pose_at(t))?;
        }
        let camera = if self.settings.frames.is_some() {
            // The scripted path: this frame's number, 1 … N.
            scripted_pose(&self.scene.camera, &self.bounds, self.report.frames + 1)
        } else {
            let now = Instant::now();
            let dt = self
                .input
                .last_step
                .map_or(0.0, |t| now.duration_since(t).as_secs_f32());
            self.input.last_step = Some(now);
            self.input.fly.fly(&self.input.keys, dt.min(MAX_FLY_STEP_S));
            self.input.fly.camera()
        };
        state.renderer.set_camera(camera)?;
        state.renderer.submit_frame()?;
        let display = state.renderer.display();
        if state.swapchain.present(display, None)? == Presented::OutOfDate {
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

    /// A key other than Esc: movement keys by position (`KeyCode`, so WASD is WASD on every
    /// layout), `F` and `C` by the letter they type.
    fn key(&mut self, event: &KeyEvent) {
        let pressed = event.state == ElementState::Pressed;
        let keys = &mut self.input.keys;
        match event.physical_key {
            PhysicalKey::Code(KeyCode::KeyW) => keys.forward = pressed,
            PhysicalKey::Code(KeyCode::KeyS) => keys.back = pressed,
            PhysicalKey::Code(KeyCode::KeyA) => keys.left = pressed,
            PhysicalKey::Code(KeyCode::KeyD) => keys.right = pressed,
            PhysicalKey::Code(KeyCode::KeyE) => keys.up = pressed,
            PhysicalKey::Code(KeyCode::KeyQ) => keys.down = pressed,
            _ => {}
        }
        if !pressed || event.repeat {
            return;
        }
        let Key::Character(c) = &event.logical_key else {
            return;
        };
        match c.to_lowercase().as_str() {
            "f" => {
                let render = &self.settings.render;
                self.input
                    .fly
                    .frame_scene(render.width as f32 / render.height as f32);
            }
            "c" => self.next_camera(),
            _ => {}
        }
    }

    /// `C`: the file's next camera (or the scene's own camera when the file has none).
    fn next_camera(&mut self) {
        let cameras = &self.scene.cameras;
        if cameras.is_empty() {
            self.input.fly.jump_to(self.scene.camera);
            return;
        }
        let next = self
            .input
            .camera_index
            .map_or(0, |i| (i + 1) % cameras.len());
        self.input.camera_index = Some(next);
        self.input.fly.jump_to(cameras[next]);
        log::info!("camera {next} of the file's {}", cameras.len());
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
            WindowEvent::KeyboardInput { event, .. } => self.key(&event),
            WindowEvent::MouseInput {
                state,
                button: MouseButton::Right,
                ..
            } => {
                self.input.right_button = state == ElementState::Pressed;
                self.input.cursor = None;
            }
            WindowEvent::CursorMoved { position, .. } if self.input.right_button => {
                if let Some(from) = self.input.cursor {
                    let (dx, dy) = (position.x - from.x, position.y - from.y);
                    self.input.fly.look(dx as f32, dy as f32);
                }
                self.input.cursor = Some(position);
            }
            WindowEvent::MouseWheel { delta, .. } => {
                let notches = match delta {
                    MouseScrollDelta::LineDelta(_, y) => f64::from(y),
                    MouseScrollDelta::PixelDelta(p) => p.y / PIXELS_PER_NOTCH,
                };
                self.input.fly.scroll(notches as f32);
            }
            WindowEvent::Focused(false) => {
                // Keys released while another window had the focus never arrive.
                self.input.keys = MoveKeys::default();
                self.input.right_button = false;
                self.input.cursor = None;
            }
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
