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
