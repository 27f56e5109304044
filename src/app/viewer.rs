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
//! through the file's cameras; `Tab` shows or hides the overlay (`overlay.rs`: times, effects
//! plan, settings, debug views); `P` writes a screenshot of the frame (PNG, the renderer's
//! image with its debug view, without the overlay) and its stats JSON beside it; `T` records
//! a Chrome trace of the next [`TRACE_FRAMES`] frames; `Esc` quits. `P` and `T` write into
//! `--shots DIR` (default: the current directory) as `ispm-<unix seconds>-<n>.png|.json` and
//! `ispm-<unix seconds>-<n>.trace.json`.
//!
//! ```text
//!  frame k:  presses of frame k (--press, tests) ─► trace capture starts (T)
//!            ─► set_pose, set_camera, submit_frame ─► overlay UI (egui) ─► present(blit + overlay)
//!            ─► knob changes: display transform / debug view now, new Renderer if its shape changed
//!            ─► screenshot (P: finish() = wait + read back) ─► trace ends after 30 frames (drain, write)
//! ``` With `--frames N` the camera follows the scripted
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

use crate::app::camera_control::{scripted_pose, FlyCamera, MoveKeys};
use crate::app::overlay::{Changes, Overlay, OverlayInput};
use crate::config::settings::RenderSettings;
use crate::gpu::{Gpu, GpuOptions, OverlayPass, Presented, Swapchain};
use crate::passes::debug_view::DebugView;
use crate::render::frame::Renderer;
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

/// Frames a `T` trace records.
pub const TRACE_FRAMES: u32 = 30;

/// A key the viewer acts on, pressed by the user or by `--press` (tests).
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub enum ViewKey {
    /// `P`: screenshot and stats.
    Screenshot,
    /// `T`: trace the next frames.
    Trace,
    /// `Tab`: show or hide the overlay.
    ToggleOverlay,
}

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
    /// Start with the overlay shown.
    pub overlay: bool,
    /// Start with this debug view.
    pub debug_view: Option<DebugView>,
    /// Where `P` and `T` write (`None`: the current directory).
    pub shots: Option<PathBuf>,
    /// Keys pressed at the start of frame N (1-based): tests simulate `P`, `T` and `Tab`.
    pub presses: Vec<(u32, ViewKey)>,
}

/// What a finished `ispm view` run reports.
#[derive(Debug, Default)]
pub struct ViewReport {
    pub frames: u32,
    /// Swapchains made after the first (resizes, out-of-date presents).
    pub recreated: u32,
    pub validation_messages: Vec<String>,
    /// Files `P` and `T` wrote.
    pub written: Vec<PathBuf>,
    /// Frames the overlay was drawn in, and the most vertices it drew in one.
    pub overlay_frames: u32,
    pub overlay_vertices: usize,
}

struct State {
    // Field order is drop order: the overlay's pass and the swapchain (and its surface) before
    // the window.
    renderer: Renderer,
    overlay_pass: OverlayPass,
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
    overlay: Option<Overlay>,
    /// Keys to act on at the next frame.
    pending: Vec<ViewKey>,
    /// A trace capture running: frames still to record.
    tracing: Option<u32>,
    /// Files `P`/`T` wrote so far (their names' counter).
    shots_written: u32,
    /// When the last frame began (the overlay's frame interval).
    last_frame: Option<Instant>,
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
        overlay: None,
        pending: Vec::new(),
        tracing: None,
        shots_written: 0,
        last_frame: None,
    };
    event_loop.run_app(&mut viewer)?;
    if let Some(e) = viewer.error {
        return Err(e);
    }
    if viewer.tracing.is_some() {
        // Closed mid-trace: the capture ends unwritten.
        let _ = crate::timing::finish_capture();
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
        let mut renderer = Renderer::new(&gpu, &self.scene, self.settings.render.clone())?;
        renderer.set_debug_view(self.settings.debug_view)?;
        let overlay_pass = OverlayPass::new(&gpu, swapchain.format)?;
        self.overlay = Some(Overlay::new(
            &window,
            &self.settings.render,
            self.settings.debug_view,
            self.settings.overlay,
        ));
        window.request_redraw();
        self.state = Some(State {
            renderer,
            overlay_pass,
            swapchain,
            gpu,
            window,
        });
        Ok(())
    }

    /// Where `P` and `T` write their `n`th file of this run (`ext`: "png", "json",
    /// "trace.json").
    fn shot_path(&self, n: u32, ext: &str) -> PathBuf {
        let secs = std::time::SystemTime::now()
            .duration_since(std::time::UNIX_EPOCH)
            .map_or(0, |d| d.as_secs());
        let dir = self
            .settings
            .shots
            .clone()
            .unwrap_or_else(|| PathBuf::from("."));
        dir.join(format!("ispm-{secs}-{n:03}.{ext}"))
    }

    /// `P`: waits for the frames in flight, writes the last one's image (PNG) and its stats
    /// (JSON) beside it.
    fn screenshot(&mut self) -> anyhow::Result<()> {
        self.shots_written += 1;
        let png = self.shot_path(self.shots_written, "png");
        let json = png.with_extension("json");
        let Some(state) = &mut self.state else {
            return Ok(());
        };
        let frame = state.renderer.finish()?;
        let stats = crate::render::stats::frame_json(
            &self.scene,
            &frame,
            state.renderer.triangles(),
            state.renderer.settings().bounces,
            state.gpu.validation_message_count(),
        );
        crate::output::write_png(&png, frame.width, frame.height, &frame.ldr)?;
        crate::output::write_atomically(&json, |f| {
            serde_json::to_writer_pretty(f, &stats)
                .map_err(|e| anyhow::anyhow!("{}: cannot write JSON: {e}", json.display()))
        })?;
        eprintln!("wrote {} and {}", png.display(), json.display());
        self.report.written.extend([png, json]);
        Ok(())
    }

    /// The end of a `T` trace: waits for the traced frames (their GPU spans join the capture
    /// as they retire) and writes the Chrome trace.
    fn finish_trace(&mut self) -> anyhow::Result<()> {
        self.tracing = None;
        if let Some(state) = &mut self.state {
            state.renderer.drain()?;
        }
        let capture = crate::timing::finish_capture();
        self.shots_written += 1;
        let path = self.shot_path(self.shots_written, "trace.json");
        capture.write_chrome(&path)?;
        eprintln!("wrote {} ({TRACE_FRAMES} frames)", path.display());
        self.report.written.push(path);
        Ok(())
    }

    /// Acts on the keys of this frame (before it is issued).
    fn keys_before_frame(&mut self) {
        let frame = self.report.frames + 1;
        let scripted = self
            .settings
            .presses
            .iter()
            .filter(|(at, _)| *at == frame)
            .map(|(_, k)| *k);
        let keys: Vec<ViewKey> = self.pending.drain(..).chain(scripted).collect();
        for key in keys {
            match key {
                ViewKey::ToggleOverlay => {
                    if let Some(o) = &mut self.overlay {
                        o.shown = !o.shown;
                    }
                }
                ViewKey::Trace if self.tracing.is_none() && !crate::timing::capturing() => {
                    crate::timing::start_capture();
                    self.tracing = Some(TRACE_FRAMES);
                }
                ViewKey::Trace => log::warn!("T: a trace is already being recorded"),
                // After the frame (it shows the frame just rendered).
                ViewKey::Screenshot => self.pending.push(key),
            }
        }
    }

    /// Applies what the overlay's knobs changed.
    fn apply(&mut self, changes: Changes) -> anyhow::Result<()> {
        let Some(state) = &mut self.state else {
            return Ok(());
        };
        if let Some((tonemap, exposure)) = changes.display {
            state.renderer.set_display_transform(tonemap, exposure);
            self.settings.render.tonemap = tonemap;
            self.settings.render.exposure_ev = exposure;
        }
        if let Some(view) = changes.debug_view {
            state.renderer.set_debug_view(view)?;
        }
        if let Some(settings) = changes.rebuild {
            if self.tracing.is_some() {
                return Ok(()); // not in the middle of a trace: applied after it
            }
            let view = state.renderer.debug_view();
            let camera = *state.renderer.camera();
            log::info!("new renderer for the overlay's settings");
            let mut renderer = Renderer::new(&state.gpu, &self.scene, settings.clone())?;
            renderer.set_camera(camera)?;
            // A view of the photon part goes when the new settings have none.
            let view = view.filter(|v| renderer.set_debug_view(Some(*v)).is_ok());
            state.renderer = renderer;
            self.settings.render = settings.clone();
            if let Some(o) = &mut self.overlay {
                o.applied(&settings, view);
            }
        }
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
        self.keys_before_frame();
        let t = self.animation_time();
        let now = Instant::now();
        let interval_ms = self
            .last_frame
            .replace(now)
            .map_or(0.0, |t| now.duration_since(t).as_secs_f64() * 1e3);
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
        let mut changes = Changes::default();
        let overlay_frame = match &mut self.overlay {
            Some(overlay) => {
                let last_written = self.report.written.last().and_then(|p| p.to_str());
                let input = OverlayInput {
                    plan: state.renderer.plan(),
                    last: state.renderer.last_frame_times(),
                    interval_ms,
                    has_photons: state.renderer.photons().is_some(),
                    tracing: self.tracing,
                    last_written,
                };
                let (frame, c) = overlay.frame(&state.window, &input);
                changes = c;
                frame
            }
            None => None,
        };
        if let Some(f) = &overlay_frame {
            self.report.overlay_frames += 1;
            let vertices = f
                .primitives
                .iter()
                .map(|p| match &p.primitive {
                    egui::epaint::Primitive::Mesh(m) => m.vertices.len(),
                    egui::epaint::Primitive::Callback(_) => 0,
                })
                .sum::<usize>();
            self.report.overlay_vertices = self.report.overlay_vertices.max(vertices);
        }
        let display = state.renderer.display();
        let overlay = overlay_frame.as_ref().map(|f| (&mut state.overlay_pass, f));
        if state.swapchain.present(display, overlay)? == Presented::OutOfDate {
            state.swapchain.recreate((size.width, size.height))?;
            self.report.recreated += 1;
        }
        self.report.frames += 1;
        if self.pending.contains(&ViewKey::Screenshot) {
            self.pending.retain(|k| *k != ViewKey::Screenshot);
            self.screenshot()?;
        }
        if let Some(left) = self.tracing {
            if left <= 1 {
                self.finish_trace()?;
            } else {
                self.tracing = Some(left - 1);
            }
        }
        self.apply(changes)?;
        let Some(state) = &mut self.state else {
            return Ok(());
        };
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
            "p" => self.pending.push(ViewKey::Screenshot),
            "t" => self.pending.push(ViewKey::Trace),
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
        if let WindowEvent::KeyboardInput {
            event:
                KeyEvent {
                    logical_key: Key::Named(NamedKey::Tab),
                    state: ElementState::Pressed,
                    repeat: false,
                    ..
                },
            ..
        } = event
        {
            // Ours, not egui's (which moves its keyboard focus with Tab).
            self.pending.push(ViewKey::ToggleOverlay);
            return;
        }
        let used_by_overlay = match (&mut self.overlay, &self.state) {
            (Some(overlay), Some(state)) => overlay.on_window_event(&state.window, &event),
            _ => false,
        };
        let input_event = matches!(
            event,
            WindowEvent::KeyboardInput { .. }
                | WindowEvent::MouseInput { .. }
                | WindowEvent::CursorMoved { .. }
                | WindowEvent::MouseWheel { .. }
        );
        if used_by_overlay && input_event {
            return;
        }
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
