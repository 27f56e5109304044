//! The sweep's plots, SVG by `plotters` (its SVG backend only: text is written as SVG `<text>`
//! and laid out by plotters' built-in estimate, so no font library is involved):
//!
//! - `pareto.svg`: relMSE (log) against frame time, every configuration, the Pareto front
//!   joined and marked, the photon-gather baseline in its own colour;
//! - `stages.svg`: per configuration a horizontal bar of its stage medians stacked (GPU passes
//!   and the CPU trace; the overlapped frame runs them side by side, so the bar can be longer
//!   than the frame period, which is marked with a tick);
//! - `knobs.svg`: relMSE (whole and indirect) against each knob the grid varies, one panel per
//!   knob, every configuration a point and the best one at each value joined.

use super::results::Record;
use crate::config::settings::Method;
use crate::output::write_atomically;
use anyhow::{anyhow, Context, Result};
use plotters::prelude::*;
use plotters::style::text_anchor::{HPos, Pos, VPos};
use std::io::Write;
use std::path::Path;

const PALETTE: [RGBColor; 10] = [
    RGBColor(78, 121, 167),
    RGBColor(242, 142, 43),
    RGBColor(225, 87, 89),
    RGBColor(118, 183, 178),
    RGBColor(89, 161, 79),
    RGBColor(237, 201, 72),
    RGBColor(176, 122, 161),
    RGBColor(255, 157, 167),
    RGBColor(156, 117, 95),
    RGBColor(186, 176, 172),
];

fn save(path: &Path, svg: &str) -> Result<()> {
    write_atomically(path, |f| {
        f.write_all(svg.as_bytes())
            .with_context(|| format!("{}: cannot write", path.display()))
    })
}

fn plot_err(e: impl std::fmt::Display) -> anyhow::Error {
    anyhow!("plot: {e}")
}

/// A log axis range covering `values` (positive), widened by a margin.
fn log_range(values: impl Iterator<Item = f64>) -> std::ops::Range<f64> {
    let (lo, hi) = values
        .filter(|v| v.is_finite() && *v > 0.0)
        .fold((f64::INFINITY, 0.0f64), |(lo, hi), v| {
            (lo.min(v), hi.max(v))
        });
    if hi <= 0.0 {
        return 1e-4..1.0;
    }
    (lo / 1.5)..(hi * 1.5)
}

/// Writes the three SVGs for `records` (one scene and size) into `dir`.
pub fn write_all(dir: &Path, title: &str, records: &[&Record]) -> Result<()> {
    save(&dir.join("pareto.svg"), &pareto(title, records)?)?;
    save(&dir.join("stages.svg"), &stages(title, records)?)?;
    save(&dir.join("knobs.svg"), &knobs(title, records)?)?;
    Ok(())
}

/// `pareto.svg` (module docs).
pub fn pareto(title: &str, records: &[&Record]) -> Result<String> {
    let mut svg = String::new();
    {
        let root = SVGBackend::with_string(&mut svg, (760, 500)).into_drawing_area();
        root.fill(&WHITE).map_err(plot_err)?;
        let t_max = records
            .iter()
            .map(|r| r.measurement.frame_ms)
            .fold(1e-3, f64::max);
        let mut chart = ChartBuilder::on(&root)
            .caption(format!("{title}: error vs frame time"), ("sans-serif", 18))
            .margin(12)
            .x_label_area_size(40)
            .y_label_area_size(70)
            .build_cartesian_2d(
                (t_max / 1e3..t_max * 1.5).log_scale(),
                log_range(records.iter().map(|r| r.measurement.rel_mse)).log_scale(),
            )
            .map_err(plot_err)?;
        chart
            .configure_mesh()
            .x_desc("frame time (ms)")
            .y_desc("relMSE (whole image)")
            .draw()
            .map_err(plot_err)?;
        let point = |r: &Record| {
            (
                r.measurement.frame_ms.max(1e-6),
                r.measurement.rel_mse.max(1e-9),
            )
        };
        for (method, colour, name) in [
            (Method::Ispm, PALETTE[0], "ISPM configuration"),
            (Method::PhotonGather, PALETTE[4], "photon-gather (CPU)"),
        ] {
            let points: Vec<(f64, f64)> = records
                .iter()
                .filter(|r| r.config.method == method)
                .map(|r| point(r))
                .collect();
            if points.is_empty() {
                continue;
            }
            chart
                .draw_series(points.iter().map(|&p| Circle::new(p, 3, colour.filled())))
                .map_err(plot_err)?
                .label(name)
                .legend(move |(x, y)| Circle::new((x, y), 3, colour.filled()));
        }
        let mut front: Vec<(f64, f64)> = records
            .iter()
            .filter(|r| r.pareto)
            .map(|r| point(r))
            .collect();
        front.sort_by(|a, b| a.0.total_cmp(&b.0));
        chart
            .draw_series(LineSeries::new(
                front.iter().copied(),
                PALETTE[2].stroke_width(2),
            ))
            .map_err(plot_err)?
            .label("Pareto front")
            .legend(|(x, y)| PathElement::new(vec![(x - 8, y), (x + 8, y)], PALETTE[2]));
        chart
            .draw_series(
                front
                    .iter()
                    .map(|&p| Circle::new(p, 6, PALETTE[2].stroke_width(2))),
            )
            .map_err(plot_err)?;
        chart
            .configure_series_labels()
            .background_style(WHITE.mix(0.9))
            .border_style(BLACK)
            .draw()
            .map_err(plot_err)?;
        root.present().map_err(plot_err)?;
    }
    Ok(svg)
}

/// `stages.svg` (module docs).
pub fn stages(title: &str, records: &[&Record]) -> Result<String> {
    let mut names: Vec<&str> = records
        .iter()
        .flat_map(|r| r.measurement.stages.keys().map(String::as_str))
        .collect();
    names.sort_unstable();
    names.dedup();
    let n = records.len().max(1);
    let mut svg = String::new();
    {
        let height = 120 + 22 * n as u32;
        let root = SVGBackend::with_string(&mut svg, (900, height)).into_drawing_area();
        root.fill(&WHITE).map_err(plot_err)?;
        let longest = records
            .iter()
            .map(|r| {
                let m = &r.measurement;
                m.stages.values().sum::<f64>().max(m.frame_ms)
            })
            .fold(1e-3, f64::max);
        let labels: Vec<String> = records.iter().map(|r| r.label.clone()).collect();
        let mut chart = ChartBuilder::on(&root)
            .caption(
                format!("{title}: stage medians per configuration (| = frame period)"),
                ("sans-serif", 16),
            )
            .margin(12)
            .x_label_area_size(36)
            .y_label_area_size(250)
            .build_cartesian_2d(0.0..longest * 1.05, 0.0..n as f64)
            .map_err(plot_err)?;
        // The configuration names are drawn beside their bars (an axis's labels sit at
        // positions plotters chooses, not at the bars' centres).
        chart
            .configure_mesh()
            .disable_y_mesh()
            .y_label_formatter(&|_| String::new())
            .x_desc("ms")
            .draw()
            .map_err(plot_err)?;
        let label_style = TextStyle::from(("sans-serif", 11).into_font())
            .pos(Pos::new(HPos::Right, VPos::Center));
        for (i, label) in labels.iter().enumerate() {
            let (x, y) = chart.backend_coord(&(0.0, i as f64 + 0.5));
            root.draw(&Text::new(label.clone(), (x - 6, y), label_style.clone()))
                .map_err(plot_err)?;
        }
        for (k, name) in names.iter().enumerate() {
            let colour = PALETTE[k % PALETTE.len()];
            let bars: Vec<Rectangle<(f64, f64)>> = records
                .iter()
                .enumerate()
                .filter_map(|(i, r)| {
                    let ms = *r.measurement.stages.get(*name)?;
                    let start: f64 = names[..k]
                        .iter()
                        .filter_map(|s| r.measurement.stages.get(*s))
                        .sum();
                    let y = i as f64;
                    Some(Rectangle::new(
                        [(start, y + 0.15), (start + ms, y + 0.85)],
                        colour.filled(),
                    ))
                })
                .collect();
            chart
                .draw_series(bars)
                .map_err(plot_err)?
                .label(*name)
                .legend(move |(x, y)| {
                    Rectangle::new([(x - 6, y - 5), (x + 6, y + 5)], colour.filled())
                });
        }
        chart
            .draw_series(records.iter().enumerate().map(|(i, r)| {
                let t = r.measurement.frame_ms;
                PathElement::new(
                    vec![(t, i as f64 + 0.05), (t, i as f64 + 0.95)],
                    BLACK.stroke_width(2),
                )
            }))
            .map_err(plot_err)?;
        chart
            .configure_series_labels()
            .position(SeriesLabelPosition::LowerRight)
            .background_style(WHITE.mix(0.9))
            .border_style(BLACK)
            .draw()
            .map_err(plot_err)?;
        root.present().map_err(plot_err)?;
    }
    Ok(svg)
}

/// A knob's name and its value in a record, as a number and as text.
type Knob = (&'static str, fn(&Record) -> (f64, String));

const KNOBS: [Knob; 7] = [
    ("photons", |r| {
        (r.config.photons as f64, r.config.photons.to_string())
    }),
    ("bounces", |r| {
        (f64::from(r.config.bounces), r.config.bounces.to_string())
    }),
    ("radius scale", |r| {
        (
            f64::from(r.config.radius_scale),
            r.config.radius_scale.to_string(),
        )
    }),
    ("subsample", |r| {
        (
            f64::from(r.config.subsample),
            r.config.subsample.to_string(),
        )
    }),
    ("caustic share", |r| {
        (
            f64::from(r.config.caustic_share),
            r.config.caustic_share.to_string(),
        )
    }),
    ("accumulated frames", |r| {
        (
            f64::from(r.config.accumulate),
            r.config.accumulate.to_string(),
        )
    }),
    ("upsample", |r| {
        match (r.config.subsample, r.config.upsample) {
            (1, _) => (0.0, "none".into()),
            (_, crate::config::settings::Upsample::Joint) => (1.0, "joint".into()),
            (_, crate::config::settings::Upsample::Bilinear) => (2.0, "bilinear".into()),
        }
    }),
];

/// `knobs.svg` (module docs).
pub fn knobs(title: &str, records: &[&Record]) -> Result<String> {
    let varied: Vec<(&str, Vec<(f64, String)>)> = KNOBS
        .iter()
        .filter_map(|(name, value)| {
            let mut values: Vec<(f64, String)> = records.iter().map(|r| value(r)).collect();
            values.sort_by(|a, b| a.0.total_cmp(&b.0));
            values.dedup_by(|a, b| a.0 == b.0);
            (values.len() > 1).then_some((*name, values))
        })
        .collect();
    let panels = varied.len().max(1);
    let columns = panels.min(3);
    let rows = panels.div_ceil(columns);
    let mut svg = String::new();
    {
        let root =
            SVGBackend::with_string(&mut svg, (380 * columns as u32, 40 + 300 * rows as u32))
                .into_drawing_area();
        root.fill(&WHITE).map_err(plot_err)?;
        let root = root
            .titled(&format!("{title}: error vs each knob"), ("sans-serif", 18))
            .map_err(plot_err)?;
        let areas = root.split_evenly((rows, columns));
        let y_range = log_range(
            records
                .iter()
                .flat_map(|r| [r.measurement.rel_mse, r.measurement.rel_mse_indirect]),
        );
        for ((name, values), area) in varied.iter().zip(&areas) {
            let knob = KNOBS
                .iter()
                .find(|k| k.0 == *name)
                .map(|k| k.1)
                .expect("listed knob");
            let index = |r: &Record| {
                let v = knob(r).0;
                values.iter().position(|x| x.0 == v).unwrap_or(0) as f64
            };
            let mut chart = ChartBuilder::on(area)
                .margin(10)
                .x_label_area_size(34)
                .y_label_area_size(60)
                .build_cartesian_2d(-0.5..values.len() as f64 - 0.5, y_range.clone().log_scale())
                .map_err(plot_err)?;
            chart
                .configure_mesh()
                .x_labels(values.len())
                .x_label_formatter(&|x| {
                    let i = x.round();
                    if (x - i).abs() < 1e-6 && i >= 0.0 {
                        values
                            .get(i as usize)
                            .map(|v| v.1.clone())
                            .unwrap_or_default()
                    } else {
                        String::new()
                    }
                })
                .x_desc(*name)
                .y_desc("relMSE")
                .draw()
                .map_err(plot_err)?;
            for (colour, label, error) in [
                (
                    PALETTE[0],
                    "whole",
                    (|r: &Record| r.measurement.rel_mse) as fn(&Record) -> f64,
                ),
                (PALETTE[1], "indirect", |r: &Record| {
                    r.measurement.rel_mse_indirect
                }),
            ] {
                chart
                    .draw_series(
                        records.iter().map(|r| {
                            Circle::new((index(r), error(r).max(1e-9)), 2, colour.filled())
                        }),
                    )
                    .map_err(plot_err)?
                    .label(label)
                    .legend(move |(x, y)| Circle::new((x, y), 3, colour.filled()));
                let best: Vec<(f64, f64)> = (0..values.len())
                    .filter_map(|i| {
                        records
                            .iter()
                            .filter(|r| index(r) == i as f64)
                            .map(|r| error(r))
                            .min_by(f64::total_cmp)
                            .map(|e| (i as f64, e.max(1e-9)))
                    })
                    .collect();
                chart
                    .draw_series(LineSeries::new(best, colour.stroke_width(1)))
                    .map_err(plot_err)?;
            }
            chart
                .configure_series_labels()
                .background_style(WHITE.mix(0.9))
                .border_style(BLACK)
                .draw()
                .map_err(plot_err)?;
        }
        if varied.is_empty() {
            areas[0]
                .draw(&Text::new(
                    "the grid varies no knob",
                    (20, 20),
                    ("sans-serif", 14),
                ))
                .map_err(plot_err)?;
        }
        root.present().map_err(plot_err)?;
    }
    Ok(svg)
}
