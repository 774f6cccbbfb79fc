//! Training curves as PNG (plotters, with the DejaVu Sans font embedded so no system fonts are
//! needed): mean return and success rate against env interactions and against wall-clock.

use std::path::Path;
use std::sync::Once;

use plotters::prelude::*;
use plotters::style::{FontStyle, register_font};

use crate::RlError;
use crate::runner::IterationLog;

/// File name of the curves figure in a run directory.
pub const CURVES_FILE: &str = "training_curves.png";

fn register_fonts() {
    static ONCE: Once = Once::new();
    ONCE.call_once(|| {
        register_font("sans-serif", FontStyle::Normal, dejavu::sans::regular())
            .unwrap_or_else(|_| panic!("the bundled DejaVu Sans font is a valid TrueType font"));
    });
}

/// One panel: `(x, y)` points with labels.
struct Panel<'a> {
    title: &'a str,
    x_label: &'a str,
    y_label: &'a str,
    points: Vec<(f64, f64)>,
}

fn draw_panel(
    area: &DrawingArea<BitMapBackend<'_>, plotters::coord::Shift>,
    p: &Panel<'_>,
) -> Result<(), String> {
    let (x0, x1) = p
        .points
        .iter()
        .fold((f64::MAX, f64::MIN), |(a, b), &(x, _)| (a.min(x), b.max(x)));
    let (y0, y1) = p
        .points
        .iter()
        .fold((f64::MAX, f64::MIN), |(a, b), &(_, y)| (a.min(y), b.max(y)));
    let (x0, x1) = if p.points.is_empty() {
        (0.0, 1.0)
    } else {
        (x0, x1.max(x0 + 1e-9))
    };
    let pad = ((y1 - y0).abs() * 0.05).max(1e-3);
    let (y0, y1) = if p.points.is_empty() {
        (0.0, 1.0)
    } else {
        (y0 - pad, y1 + pad)
    };
    let mut chart = ChartBuilder::on(area)
        .caption(p.title, ("sans-serif", 20))
        .margin(12)
        .x_label_area_size(40)
        .y_label_area_size(60)
        .build_cartesian_2d(x0..x1, y0..y1)
        .map_err(|e| e.to_string())?;
    chart
        .configure_mesh()
        .x_desc(p.x_label)
        .y_desc(p.y_label)
        .x_labels(6)
        .y_labels(6)
        .x_label_formatter(&|v| {
            if v.abs() >= 1e4 {
                format!("{v:.2e}")
            } else {
                format!("{v:.0}")
            }
        })
        .draw()
        .map_err(|e| e.to_string())?;
    chart
        .draw_series(LineSeries::new(
            p.points.iter().copied(),
            BLUE.stroke_width(2),
        ))
        .map_err(|e| e.to_string())?;
    Ok(())
}

/// Writes `training_curves.png` into `dir`: mean return (and success rate, if the task reports
/// one) against env interactions and against wall-clock seconds.
pub fn write_training_curves(
    dir: &Path,
    history: &[IterationLog],
    with_success: bool,
) -> Result<(), RlError> {
    register_fonts();
    let path = dir.join(CURVES_FILE);
    let rows = if with_success { 2 } else { 1 };
    let series = |f: &dyn Fn(&IterationLog) -> Option<f32>, by_time: bool| -> Vec<(f64, f64)> {
        history
            .iter()
            .filter_map(|h| {
                let x = if by_time {
                    h.wall_time
                } else {
                    h.env_steps as f64
                };
                f(h).map(|y| (x, f64::from(y)))
            })
            .collect()
    };
    let mut panels = vec![
        Panel {
            title: "mean return",
            x_label: "env interactions",
            y_label: "return",
            points: series(&|h| h.mean_return, false),
        },
        Panel {
            title: "mean return",
            x_label: "wall-clock (s)",
            y_label: "return",
            points: series(&|h| h.mean_return, true),
        },
    ];
    if with_success {
        panels.push(Panel {
            title: "success rate",
            x_label: "env interactions",
            y_label: "success",
            points: series(&|h| h.success_rate, false),
        });
        panels.push(Panel {
            title: "success rate",
            x_label: "wall-clock (s)",
            y_label: "success",
            points: series(&|h| h.success_rate, true),
        });
    }
    let result = (|| -> Result<(), String> {
        let root = BitMapBackend::new(&path, (1200, 420 * rows)).into_drawing_area();
        root.fill(&WHITE).map_err(|e| e.to_string())?;
        for (area, panel) in root.split_evenly((rows as usize, 2)).iter().zip(&panels) {
            draw_panel(area, panel)?;
        }
        root.present().map_err(|e| e.to_string())
    })();
    result.map_err(|message| RlError::Plot { path, message })
}
