//! Figures of one episode: the world from above with the trajectory (the paper's Fig. 6) and
//! the field's activity over time (Fig. 5a).

use std::path::Path;

use plotters::prelude::*;

use super::episode::Episode;
use super::world::{Shape, World};
use crate::error::{Error, Result};

/// Draws the episode to a PNG: world and trajectory on the left, u(φ, t) on the right.
pub fn episode_figure(path: &Path, world: &World, episode: &Episode, title: &str) -> Result<()> {
    crate::plot::register_font();
    let err = |e: String| Error::Io {
        path: path.to_path_buf(),
        source: std::io::Error::other(e),
    };
    let root = BitMapBackend::new(path, (1400, 650)).into_drawing_area();
    root.fill(&WHITE).map_err(|e| err(e.to_string()))?;
    let panels = root.split_evenly((1, 2));
    let mut chart = ChartBuilder::on(&panels[0])
        .caption(
            format!("{title}: {:?} after {:.1} s", episode.outcome, episode.time),
            ("sans-serif", 22),
        )
        .margin(15)
        .x_label_area_size(35)
        .y_label_area_size(45)
        .build_cartesian_2d(0f32..world.size[0], 0f32..world.size[1])
        .map_err(|e| err(e.to_string()))?;
    chart
        .configure_mesh()
        .x_desc("x (m)")
        .y_desc("y (m)")
        .draw()
        .map_err(|e| err(e.to_string()))?;
    for (i, o) in world.obstacles.iter().enumerate() {
        let colour = if world.lidar_sees(i) {
            RGBColor(90, 90, 90)
        } else {
            RGBColor(240, 150, 30)
        };
        let outline: Vec<(f32, f32)> = match &o.shape {
            Shape::Circle { center, radius } => (0..=40)
                .map(|k| {
                    let a = k as f32 / 40.0 * std::f32::consts::TAU;
                    (center[0] + radius * a.cos(), center[1] + radius * a.sin())
                })
                .collect(),
            Shape::Polygon { points } => points.iter().map(|p| (p[0], p[1])).collect(),
        };
        chart
            .draw_series(std::iter::once(Polygon::new(outline, colour.filled())))
            .map_err(|e| err(e.to_string()))?;
    }
    let trail: Vec<(f32, f32)> = episode.trajectory.iter().map(|p| (p[0], p[1])).collect();
    chart
        .draw_series(LineSeries::new(trail, BLUE.stroke_width(2)))
        .map_err(|e| err(e.to_string()))?
        .label("trajectory")
        .legend(|(x, y)| PathElement::new(vec![(x, y), (x + 20, y)], BLUE));
    chart
        .draw_series([
            Circle::new((world.start[0], world.start[1]), 6, GREEN.filled()),
            Circle::new((world.goal[0], world.goal[1]), 6, RED.filled()),
        ])
        .map_err(|e| err(e.to_string()))?;
    chart
        .draw_series(std::iter::once(Circle::new((0.0, 0.0), 0, WHITE)))
        .map_err(|e| err(e.to_string()))?
        .label("grey: LIDAR sees it · orange: below the scan plane")
        .legend(|(x, y)| {
            Rectangle::new(
                [(x, y - 4), (x + 16, y + 4)],
                RGBColor(240, 150, 30).filled(),
            )
        });
    chart
        .configure_series_labels()
        .position(SeriesLabelPosition::UpperLeft)
        .background_style(WHITE.mix(0.85))
        .border_style(BLACK)
        .draw()
        .map_err(|e| err(e.to_string()))?;

    // Field activity: time along x, heading along y, colour = activation.
    let steps = episode.field.len().max(1);
    let n = episode.field.first().map_or(1, |f| f.len());
    let (lo, hi) = episode
        .field
        .iter()
        .flatten()
        .fold((f32::MAX, f32::MIN), |(a, b), &v| (a.min(v), b.max(v)));
    let mut chart = ChartBuilder::on(&panels[1])
        .caption("Field activity u(φ, t) (world heading)", ("sans-serif", 22))
        .margin(15)
        .x_label_area_size(35)
        .y_label_area_size(45)
        .build_cartesian_2d(0f32..episode.time.max(1e-3), 0f32..360f32)
        .map_err(|e| err(e.to_string()))?;
    chart
        .configure_mesh()
        .x_desc("t (s)")
        .y_desc("heading (°)")
        .draw()
        .map_err(|e| err(e.to_string()))?;
    let dt = episode.time.max(1e-3) / steps as f32;
    let dh = 360.0 / n as f32;
    chart
        .draw_series(episode.field.iter().enumerate().flat_map(|(t, f)| {
            f.iter().enumerate().map(move |(i, &v)| {
                let k = if hi > lo { (v - lo) / (hi - lo) } else { 0.5 };
                let c = RGBColor(
                    (255.0 * k) as u8,
                    (80.0 * (1.0 - k)) as u8,
                    (255.0 * (1.0 - k)) as u8,
                );
                Rectangle::new(
                    [
                        (t as f32 * dt, i as f32 * dh),
                        ((t + 1) as f32 * dt, (i + 1) as f32 * dh),
                    ],
                    c.filled(),
                )
            })
        }))
        .map_err(|e| err(e.to_string()))?;
    root.present().map_err(|e| err(e.to_string()))?;
    Ok(())
}

/// The `nav-eval` figure: success and collision rates of LIDAR alone and of fusion, on worlds
/// with LIDAR-invisible obstacles and on the same worlds with every obstacle visible
/// (Figs. 5b–d in spirit).
pub fn comparison_figure(
    path: &Path,
    hidden: &super::evaluate::Comparison,
    visible: &super::evaluate::Comparison,
) -> Result<()> {
    crate::plot::register_font();
    let err = |e: String| Error::Io {
        path: path.to_path_buf(),
        source: std::io::Error::other(e),
    };
    let root = BitMapBackend::new(path, (1000, 520)).into_drawing_area();
    root.fill(&WHITE).map_err(|e| err(e.to_string()))?;
    let panels = root.split_evenly((1, 2));
    for (panel, (title, c)) in panels.iter().zip([
        ("With LIDAR-invisible obstacles", hidden),
        ("Every obstacle visible", visible),
    ]) {
        let mut chart = ChartBuilder::on(panel)
            .caption(
                format!("{title} ({} worlds)", c.laser.episodes),
                ("sans-serif", 20),
            )
            .margin(15)
            .x_label_area_size(35)
            .y_label_area_size(45)
            .build_cartesian_2d(0f32..4f32, 0f32..100f32)
            .map_err(|e| err(e.to_string()))?;
        chart
            .configure_mesh()
            .disable_x_mesh()
            .x_labels(0)
            .y_desc("% of episodes")
            .draw()
            .map_err(|e| err(e.to_string()))?;
        let rate = |s: &super::evaluate::ModeSummary| {
            (
                100.0 * s.success_rate as f32,
                100.0 * s.collisions as f32 / s.episodes.max(1) as f32,
            )
        };
        let (ls, lc) = rate(&c.laser);
        let (fs, fc) = rate(&c.fusion);
        let bars = [
            (0.2, ls, RGBColor(120, 120, 120), "laser: success"),
            (1.0, fs, RGBColor(30, 90, 220), "fusion: success"),
            (2.2, lc, RGBColor(200, 120, 120), "laser: collisions"),
            (3.0, fc, RGBColor(220, 40, 40), "fusion: collisions"),
        ];
        for (x, h, colour, label) in bars {
            chart
                .draw_series(std::iter::once(Rectangle::new(
                    [(x, 0.0), (x + 0.7, h)],
                    colour.filled(),
                )))
                .map_err(|e| err(e.to_string()))?
                .label(format!("{label} {h:.1}%"))
                .legend(move |(x, y)| {
                    Rectangle::new([(x, y - 4), (x + 14, y + 4)], colour.filled())
                });
        }
        chart
            .configure_series_labels()
            .position(SeriesLabelPosition::UpperRight)
            .background_style(WHITE.mix(0.85))
            .border_style(BLACK)
            .draw()
            .map_err(|e| err(e.to_string()))?;
    }
    root.present().map_err(|e| err(e.to_string()))?;
    Ok(())
}
