//! The viewer's overlay (egui; no Vulkan here: `gpu/overlay.rs` draws what this makes).
//!
//! ```text
//!  ┌ ispm ───────────────────────────────┐
//!  │ frame 16.7 ms (60 fps) · GPU 9.2 ms │  host frame interval, last retired frame's latency
//!  │ ▇▇▆▇▇▇▇█▇▇▆▇▇▇▇▇▇▇▇█▇▇▇▇▇▇▇▇▇▇▇▇▇▇▇ │  stacked GPU pass times per frame (last 240),
//!  │ ── host interval   ── cpu_trace     │  lines: host frame interval, CPU photon trace
//!  │ ■ eye_gbuffer 0.8 ■ direct 1.2 …    │  per-pass GPU ms (+ cpu_trace, frame)
//!  ├ Effects plan ───────────────────────┤
//!  │ ✔ shadow_maps — light 'key' …       │  passes run / skipped with the reason
//!  │ × translucent — no glass or mirror  │  (+ the plan's full text, collapsed)
//!  ├ Settings ───────────────────────────┤
//!  │ method [ispm▾] photons ━━●━━ …      │  method, photons, bounces, kernel radius,
//!  │ tonemap [pbr-neutral▾] exposure ━●━ │  subsample (new renderer); tonemap, exposure
//!  ├ Debug view ─────────────────────────┤
//!  │ ○ frame ○ eye G-buffer normals …    │  passes/debug_view.rs
//!  └ Tab hides · P screenshot · T trace ─┘
//! ```
//!
//! The settings that shape the renderer's buffers and pipelines (method, photons, bounces,
//! kernel radius, subsample) are applied by a new `Renderer` once no slider is being dragged;
//! tonemap and exposure go to the running one (`Renderer::set_display_transform`), the debug
//! view too (`Renderer::set_debug_view`).

use crate::config::settings::Tonemap;
use crate::config::settings::{Method, RenderSettings};
use crate::gpu::{OverlayFrame, Span};
use crate::passes::debug_view::DebugView;
use crate::plan::EffectsPlan;
use crate::render::stats::FrameStats;
use egui::{Color32, Pos2, Rect, Stroke, Vec2};
use std::collections::VecDeque;

/// Frames the graph shows.
const HISTORY: usize = 240;
/// Height of the graph in points.
const GRAPH_HEIGHT: f32 = 90.0;

/// One frame's times for the graph.
#[derive(Clone, Debug, Default)]
struct Sample {
    /// Host time since the previous frame began (ms).
    interval_ms: f64,
    /// GPU ms per pass (the frame's timestamp scopes, summed by name, in frame order).
    passes: Vec<(String, f64)>,
    cpu_trace_ms: f64,
    /// Host time from the frame's start to its last GPU pass's end (ms).
    latency_ms: f64,
    /// Frames in the image's mean (progressive accumulation while nothing moves).
    accumulated: u32,
}

/// What the overlay shows of the renderer this frame.
pub struct OverlayInput<'a> {
    pub plan: &'a EffectsPlan,
    /// The newest retired frame's GPU spans and stats.
    pub last: Option<&'a (Vec<Span>, FrameStats)>,
    pub interval_ms: f64,
    /// Whether the renderer has the photon part of the frame (views of it are possible).
    pub has_photons: bool,
    /// A trace capture running: frames left.
    pub tracing: Option<u32>,
    /// The last file the `P`/`T` keys wrote.
    pub last_written: Option<&'a str>,
}

/// What the user changed this frame.
#[derive(Clone, Debug, Default)]
pub struct Changes {
    /// A new renderer with these settings.
    pub rebuild: Option<RenderSettings>,
    /// New tonemap and exposure for the running renderer.
    pub display: Option<(Tonemap, f32)>,
    /// A new debug view (`Some(None)`: back to the frame).
    pub debug_view: Option<Option<DebugView>>,
}

/// The overlay's state: egui, its window input, the knobs and the times' history.
pub struct Overlay {
    ctx: egui::Context,
    input: egui_winit::State,
    /// Drawn (`Tab` toggles).
    pub shown: bool,
    history: VecDeque<Sample>,
    /// The settings the renderer runs with, and the ones being edited.
    applied: RenderSettings,
    edited: RenderSettings,
    debug_view: Option<DebugView>,
}

/// What the edits of `edited` over `applied` call for: a new renderer when a knob that shapes
/// it changed and nothing is being `dragging` (a slider in motion would make one per frame),
/// the display transform at once (which `applied` then takes).
fn settle(applied: &mut RenderSettings, edited: &RenderSettings, dragging: bool) -> Changes {
    let shape = |s: &RenderSettings| (s.method, s.photons, s.bounces, s.radius, s.subsample);
    let mut changes = Changes::default();
    if !dragging && shape(edited) != shape(applied) {
        changes.rebuild = Some(edited.clone());
    }
    if (edited.tonemap, edited.exposure_ev) != (applied.tonemap, applied.exposure_ev) {
        changes.display = Some((edited.tonemap, edited.exposure_ev));
        applied.tonemap = edited.tonemap;
        applied.exposure_ev = edited.exposure_ev;
    }
    changes
}

/// A stable colour per pass name.
fn pass_colour(name: &str) -> Color32 {
    let h = name.bytes().fold(2166136261u32, |h, b| {
        (h ^ u32::from(b)).wrapping_mul(16777619)
    });
    let hue = (h % 360) as f32 / 360.0;
    egui::ecolor::Hsva::new(hue, 0.65, 0.9, 1.0).into()
}

/// GPU ms per pass name of `spans`, in order of first appearance (outermost scopes only, so
/// nested scopes are not counted twice).
fn pass_times(spans: &[Span]) -> Vec<(String, f64)> {
    let min_depth = spans.iter().map(|s| s.depth).min().unwrap_or(0);
    let mut out: Vec<(String, f64)> = Vec::new();
    for s in spans.iter().filter(|s| s.is_gpu() && s.depth == min_depth) {
        match out.iter_mut().find(|(n, _)| *n == s.name) {
            Some((_, ms)) => *ms += s.ms(),
            None => out.push((s.name.clone(), s.ms())),
        }
    }
    out
}

impl Overlay {
    pub fn new(
        window: &winit::window::Window,
        settings: &RenderSettings,
        debug_view: Option<DebugView>,
        shown: bool,
    ) -> Self {
        let ctx = egui::Context::default();
        ctx.set_visuals(egui::Visuals::dark());
        let input = egui_winit::State::new(
            ctx.clone(),
            egui::ViewportId::ROOT,
            window,
            Some(window.scale_factor() as f32),
            None,
            None,
        );
        Self {
            ctx,
            input,
            shown,
            history: VecDeque::new(),
            applied: settings.clone(),
            edited: settings.clone(),
            debug_view,
        }
    }

    /// Passes a window event to egui; true when egui used it (the camera should not).
    pub fn on_window_event(
        &mut self,
        window: &winit::window::Window,
        event: &winit::event::WindowEvent,
    ) -> bool {
        if !self.shown {
            return false;
        }
        self.input.on_window_event(window, event).consumed
    }

    /// The debug view the overlay has selected.
    pub fn debug_view(&self) -> Option<DebugView> {
        self.debug_view
    }

    /// The renderer was rebuilt with `settings` (and shows `debug_view`).
    pub fn applied(&mut self, settings: &RenderSettings, debug_view: Option<DebugView>) {
        self.applied = settings.clone();
        self.edited = settings.clone();
        self.debug_view = debug_view;
    }

    /// Records the frame's times, and when shown lays the overlay out: egui's triangles for
    /// `gpu::OverlayPass`, and what the user changed.
    pub fn frame(
        &mut self,
        window: &winit::window::Window,
        input: &OverlayInput,
    ) -> (Option<OverlayFrame>, Changes) {
        let sample = Sample {
            interval_ms: input.interval_ms,
            passes: input.last.map(|(s, _)| pass_times(s)).unwrap_or_default(),
            cpu_trace_ms: input.last.map_or(0.0, |(_, st)| st.cpu_trace_ms),
            latency_ms: input.last.map_or(0.0, |(_, st)| st.frame_ms),
            accumulated: input.last.map_or(1, |(_, st)| st.accumulated_frames.max(1)),
        };
        if self.history.len() == HISTORY {
            self.history.pop_front();
        }
        self.history.push_back(sample);
        if !self.shown {
            return (None, Changes::default());
        }
        let raw = self.input.take_egui_input(window);
        let ctx = self.ctx.clone();
        let mut changes = Changes::default();
        let output = ctx.run(raw, |ctx| {
            egui::Window::new("ispm")
                .default_pos([8.0, 8.0])
                .default_width(340.0)
                .max_height(window.inner_size().height as f32 / ctx.pixels_per_point() - 16.0)
                .show(ctx, |ui| {
                    egui::ScrollArea::vertical()
                        .show(ui, |ui| self.contents_ui(ui, input, &mut changes));
                });
        });
        let debug_view = changes.debug_view;
        let dragging = self.ctx.is_using_pointer();
        let mut changes = settle(&mut self.applied, &self.edited, dragging);
        changes.debug_view = debug_view;
        self.input
            .handle_platform_output(window, output.platform_output);
        let primitives = self.ctx.tessellate(output.shapes, output.pixels_per_point);
        let frame = OverlayFrame {
            primitives,
            pixels_per_point: output.pixels_per_point,
            textures: output.textures_delta,
        };
        (Some(frame), changes)
    }

    fn contents_ui(&mut self, ui: &mut egui::Ui, input: &OverlayInput, changes: &mut Changes) {
        self.times_ui(ui);
        ui.separator();
        self.plan_ui(ui, input);
        ui.separator();
        self.settings_ui(ui);
        ui.separator();
        self.debug_ui(ui, input, changes);
        ui.separator();
        let mut keys = String::from("Tab hides · P screenshot + stats · T trace");
        if let Some(left) = input.tracing {
            keys = format!("tracing: {left} frames to go");
        }
        ui.small(keys);
        if let Some(path) = input.last_written {
            ui.small(format!("wrote {path}"));
        }
    }

    fn times_ui(&self, ui: &mut egui::Ui) {
        let Some(last) = self.history.back() else {
            return;
        };
        let gpu: f64 = last.passes.iter().map(|(_, ms)| ms).sum();
        let fps = if last.interval_ms > 0.0 {
            1000.0 / last.interval_ms
        } else {
            0.0
        };
        ui.label(format!(
            "frame {:.1} ms ({fps:.0} fps) · GPU {gpu:.2} ms · latency {:.1} ms",
            last.interval_ms, last.latency_ms
        ));
        // Progressive accumulation: how many still frames the image averages.
        ui.label(format!(
            "accumulated {} frame{} (resets when anything moves)",
            last.accumulated,
            if last.accumulated == 1 { "" } else { "s" }
        ));
        // The graph: stacked GPU pass times per frame; lines for the host interval and the
        // CPU trace.
        let width = ui.available_width().max(120.0);
        let (rect, _) =
            ui.allocate_exact_size(Vec2::new(width, GRAPH_HEIGHT), egui::Sense::hover());
        let painter = ui.painter_at(rect);
        painter.rect_filled(rect, 2.0, Color32::from_black_alpha(160));
        let top = self
            .history
            .iter()
            .map(|s| {
                let gpu: f64 = s.passes.iter().map(|(_, ms)| ms).sum();
                gpu.max(s.interval_ms).max(s.cpu_trace_ms)
            })
            .fold(1.0, f64::max);
        let scale = f64::from(GRAPH_HEIGHT) / top;
        let column = width / HISTORY as f32;
        let x0 = rect.right() - column * self.history.len() as f32;
        let y = |ms: f64| rect.bottom() - (ms * scale) as f32;
        let mut interval = Vec::new();
        let mut trace = Vec::new();
        for (i, s) in self.history.iter().enumerate() {
            let x = x0 + column * i as f32;
            let mut base = 0.0;
            for (name, ms) in &s.passes {
                let r = Rect::from_min_max(
                    Pos2::new(x, y(base + ms)),
                    Pos2::new(x + column.max(1.0), y(base)),
                );
                painter.rect_filled(r, 0.0, pass_colour(name));
                base += ms;
            }
            interval.push(Pos2::new(x + column * 0.5, y(s.interval_ms)));
            trace.push(Pos2::new(x + column * 0.5, y(s.cpu_trace_ms)));
        }
        painter.line(interval, Stroke::new(1.5, Color32::WHITE));
        painter.line(trace, Stroke::new(1.0, Color32::LIGHT_RED));
        painter.text(
            rect.left_top() + Vec2::new(4.0, 2.0),
            egui::Align2::LEFT_TOP,
            format!("{top:.1} ms"),
            egui::FontId::monospace(10.0),
            Color32::GRAY,
        );
        ui.horizontal_wrapped(|ui| {
            ui.colored_label(Color32::WHITE, "— host interval");
            ui.colored_label(
                Color32::LIGHT_RED,
                format!("— cpu_trace {:.2}", last.cpu_trace_ms),
            );
            for (name, ms) in &last.passes {
                ui.colored_label(pass_colour(name), format!("■ {name} {ms:.2}"));
            }
        });
    }

    fn plan_ui(&self, ui: &mut egui::Ui, input: &OverlayInput) {
        egui::CollapsingHeader::new("Effects plan: passes run / skipped")
            .default_open(true)
            .show(ui, |ui| {
                let stats = input.last.map(|(_, s)| s);
                let spans = input.last.map(|(s, _)| s.as_slice()).unwrap_or_default();
                for p in input.plan.passes() {
                    let ran = crate::render::stats::pass_ran(
                        p.name,
                        spans.iter().map(|s| s.name.as_str()),
                        stats.map_or(0.0, |s| s.cpu_trace_ms),
                    );
                    let reused = stats
                        .and_then(|s| s.passes_skipped.iter().find(|k| k.name == p.name.name()));
                    let (mark, colour, reason) = match (ran, reused) {
                        (true, _) => ("✔", Color32::LIGHT_GREEN, p.reason.clone()),
                        (false, Some(skip)) => ("×", Color32::GRAY, skip.reason.clone()),
                        (false, None) => ("×", Color32::GRAY, p.reason.clone()),
                    };
                    ui.colored_label(colour, format!("{mark} {} — {reason}", p.name));
                }
                if let Some(s) = stats {
                    for &l in &s.lights_retraced {
                        ui.colored_label(
                            Color32::LIGHT_GREEN,
                            format!("✔ light {l}: photons traced"),
                        );
                    }
                    for l in &s.lights_reused {
                        ui.colored_label(Color32::GRAY, format!("× {}", l.reason));
                    }
                }
                ui.collapsing("the plan's decisions", |ui| {
                    ui.monospace(input.plan.to_string());
                });
            });
    }

    fn settings_ui(&mut self, ui: &mut egui::Ui) {
        let s = &mut self.edited;
        egui::CollapsingHeader::new("Settings")
            .default_open(true)
            .show(ui, |ui| {
                egui::ComboBox::from_label("method")
                    .selected_text(format!("{:?}", s.method).to_lowercase())
                    .show_ui(ui, |ui| {
                        ui.selectable_value(&mut s.method, Method::Ispm, "ispm");
                        ui.selectable_value(&mut s.method, Method::Direct, "direct");
                    });
                ui.add(
                    egui::Slider::new(&mut s.photons, 1_000..=2_000_000)
                        .logarithmic(true)
                        .text("photons"),
                );
                ui.add(
                    egui::Slider::new(&mut s.bounces, 0..=crate::photon::trace::MAX_BOUNCES)
                        .logarithmic(true)
                        .text("bounces"),
                );
                let mut auto = s.radius.is_none();
                ui.horizontal(|ui| {
                    ui.checkbox(&mut auto, "kernel radius auto");
                    let mut r = s.radius.unwrap_or(0.05);
                    ui.add_enabled(
                        !auto,
                        egui::Slider::new(&mut r, 0.001..=2.0)
                            .logarithmic(true)
                            .text("m"),
                    );
                    s.radius = (!auto).then_some(r);
                });
                ui.add(egui::Slider::new(&mut s.subsample, 1..=8).text("subsample 1/N"));
                egui::ComboBox::from_label("tonemap")
                    .selected_text(format!("{:?}", s.tonemap))
                    .show_ui(ui, |ui| {
                        for t in [Tonemap::PbrNeutral, Tonemap::Aces, Tonemap::Linear] {
                            ui.selectable_value(&mut s.tonemap, t, format!("{t:?}"));
                        }
                    });
                ui.add(egui::Slider::new(&mut s.exposure_ev, -8.0..=8.0).text("exposure EV"));
            });
    }

    fn debug_ui(&mut self, ui: &mut egui::Ui, input: &OverlayInput, changes: &mut Changes) {
        let before = self.debug_view;
        egui::CollapsingHeader::new("Debug view")
            .default_open(true)
            .show(ui, |ui| {
                ui.radio_value(&mut self.debug_view, None, "the frame");
                for view in DebugView::ALL {
                    let possible = input.has_photons || !view.needs_photons();
                    ui.add_enabled_ui(possible, |ui| {
                        ui.radio_value(&mut self.debug_view, Some(view), view.label());
                    });
                }
            });
        if self.debug_view != before {
            changes.debug_view = Some(self.debug_view);
        }
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn shape_knobs_rebuild_once_released_and_display_knobs_apply_at_once() {
        let mut applied = RenderSettings::default();
        let mut edited = applied.clone();
        assert!(settle(&mut applied, &edited, false).rebuild.is_none());
        edited.photons = 5_000;
        // Dragged: not yet.
        assert!(settle(&mut applied, &edited, true).rebuild.is_none());
        let changes = settle(&mut applied, &edited, false);
        assert_eq!(changes.rebuild.map(|s| s.photons), Some(5_000));
        assert!(changes.display.is_none());

        let mut applied = RenderSettings::default();
        let mut edited = applied.clone();
        edited.exposure_ev = 1.5;
        edited.tonemap = Tonemap::Aces;
        let changes = settle(&mut applied, &edited, true);
        assert_eq!(changes.display, Some((Tonemap::Aces, 1.5)));
        assert!(changes.rebuild.is_none());
        // Applied: asked once.
        assert!(settle(&mut applied, &edited, false).display.is_none());
    }

    #[test]
    fn pass_times_sum_the_outermost_gpu_scopes_by_name_in_frame_order() {
        use crate::gpu::QueueRole;
        use crate::timing::Track;
        let span = |name: &str, depth, ms: u64| Span {
            name: name.into(),
            track: Track::Gpu {
                queue: 0,
                role: QueueRole::Graphics,
            },
            frame: Some(1),
            depth,
            begin_ns: 0,
            end_ns: ms * 1_000_000,
        };
        let spans = [
            span("shadow_maps", 0, 2),
            span("inner", 1, 1),
            span("direct", 0, 3),
            span("shadow_maps", 0, 4),
        ];
        assert_eq!(
            pass_times(&spans),
            vec![
                ("shadow_maps".to_string(), 6.0),
                ("direct".to_string(), 3.0)
            ]
        );
    }
}
