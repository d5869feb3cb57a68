//! Evaluation figures: repeatability and recall against rotation angle (or sequence image)
//! per detector, the paper's Fig. 4a–b, and mean matching accuracy against the threshold.

use std::path::Path;

use plotters::prelude::*;

use crate::error::Result;
use crate::eval::sweep::{curve, detectors, Row};
use crate::plot::prepare_figure;

const COLOURS: [RGBColor; 12] = [
    RGBColor(220, 30, 30),
    RGBColor(30, 90, 220),
    RGBColor(30, 160, 60),
    RGBColor(230, 140, 0),
    RGBColor(140, 60, 200),
    RGBColor(0, 170, 170),
    RGBColor(120, 120, 120),
    RGBColor(200, 80, 160),
    RGBColor(110, 80, 20),
    RGBColor(0, 0, 0),
    RGBColor(150, 190, 0),
    RGBColor(90, 160, 230),
];

/// Per detector, the mean over images of `metric` at each x, at tolerance `eps`.
fn curves(rows: &[Row], eps: f64, metric: fn(&Row) -> f64) -> Vec<(String, Vec<(f64, f64)>)> {
    detectors(rows)
        .into_iter()
        .map(|name| {
            let pts = curve(rows, &name, eps, metric, true);
            (name, pts)
        })
        .collect()
}

/// Draws repeatability (left) and recall (right) against the x column of the rows at `eps`
/// and writes a PNG.
pub fn metrics_figure(
    path: &Path,
    rows: &[Row],
    eps: f64,
    title: &str,
    x_label: &str,
) -> Result<()> {
    let err = prepare_figure(path)?;
    let (x0, x1) = rows
        .iter()
        .fold((f64::INFINITY, f64::NEG_INFINITY), |(a, b), r| {
            (a.min(r.angle), b.max(r.angle))
        });
    let (x0, x1) = if x0.is_finite() && x1 > x0 {
        (x0, x1)
    } else {
        (0.0, 1.0)
    };
    let root = BitMapBackend::new(path, (1400, 560)).into_drawing_area();
    root.fill(&WHITE).map_err(|e| err(e.to_string()))?;
    let root = root
        .titled(title, ("sans-serif", 22))
        .map_err(|e| err(e.to_string()))?;
    let panels = root.split_evenly((1, 2));
    type Metric = (&'static str, fn(&Row) -> f64);
    let metrics: [Metric; 2] = [
        ("repeatability (eq 11)", |r| r.repeatability),
        ("recall (eq 12)", |r| r.recall),
    ];
    for (area, (name, metric)) in panels.iter().zip(metrics) {
        let mut chart = ChartBuilder::on(area)
            .caption(format!("{name}, ε = {eps} px"), ("sans-serif", 18))
            .margin(12)
            .x_label_area_size(40)
            .y_label_area_size(50)
            .build_cartesian_2d(x0..x1, 0f64..1f64)
            .map_err(|e| err(e.to_string()))?;
        chart
            .configure_mesh()
            .x_desc(x_label)
            .y_desc(name)
            .draw()
            .map_err(|e| err(e.to_string()))?;
        for (i, (detector, pts)) in curves(rows, eps, metric).into_iter().enumerate() {
            let colour = COLOURS[i % COLOURS.len()];
            let width = if detector == "steernav" { 3 } else { 1 };
            chart
                .draw_series(LineSeries::new(pts.clone(), colour.stroke_width(width)))
                .map_err(|e| err(e.to_string()))?
                .label(detector)
                .legend(move |(x, y)| {
                    PathElement::new(vec![(x, y), (x + 18, y)], colour.stroke_width(2))
                });
            chart
                .draw_series(pts.into_iter().map(|p| Circle::new(p, 2, colour.filled())))
                .map_err(|e| err(e.to_string()))?;
        }
        chart
            .configure_series_labels()
            .position(SeriesLabelPosition::LowerLeft)
            .background_style(WHITE.mix(0.8))
            .border_style(BLACK)
            .draw()
            .map_err(|e| err(e.to_string()))?;
    }
    root.present().map_err(|e| err(e.to_string()))?;
    Ok(())
}

/// Draws mean matching accuracy against the pixel threshold (1 … 10 px), one curve per
/// detector, as HPatches reports it, and writes a PNG.
pub fn mma_figure(
    path: &Path,
    summaries: &[crate::eval::matching::MatchingSummary],
    title: &str,
) -> Result<()> {
    let err = prepare_figure(path)?;
    let root = BitMapBackend::new(path, (800, 560)).into_drawing_area();
    root.fill(&WHITE).map_err(|e| err(e.to_string()))?;
    let mut chart = ChartBuilder::on(&root)
        .caption(title, ("sans-serif", 20))
        .margin(12)
        .x_label_area_size(40)
        .y_label_area_size(50)
        .build_cartesian_2d(1f64..10f64, 0f64..1f64)
        .map_err(|e| err(e.to_string()))?;
    chart
        .configure_mesh()
        .x_desc("threshold (px)")
        .y_desc("mean matching accuracy")
        .draw()
        .map_err(|e| err(e.to_string()))?;
    for (i, s) in summaries.iter().enumerate() {
        let colour = COLOURS[i % COLOURS.len()];
        let width = if s.detector == "steernav" { 3 } else { 1 };
        let pts: Vec<(f64, f64)> = s
            .mma
            .iter()
            .enumerate()
            .map(|(t, &m)| ((t + 1) as f64, m))
            .collect();
        chart
            .draw_series(LineSeries::new(pts, colour.stroke_width(width)))
            .map_err(|e| err(e.to_string()))?
            .label(s.detector.clone())
            .legend(move |(x, y)| {
                PathElement::new(vec![(x, y), (x + 18, y)], colour.stroke_width(2))
            });
    }
    chart
        .configure_series_labels()
        .position(SeriesLabelPosition::LowerRight)
        .background_style(WHITE.mix(0.8))
        .border_style(BLACK)
        .draw()
        .map_err(|e| err(e.to_string()))?;
    root.present().map_err(|e| err(e.to_string()))?;
    Ok(())
}
