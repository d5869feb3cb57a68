//! Figures of a SLAM run (the paper's Fig. 4c–f), top view (x, z): the camera trajectory with
//! 3σ ellipses of its position covariance, the ground truth when there is one, and the map's
//! landmarks with their 3σ ellipses.

use std::path::Path;

use nalgebra::{Matrix2, SymmetricEigen};
use plotters::prelude::*;

use super::trajectory::Pose;
use crate::error::{Error, Result};
use crate::slam::tracker::MapPoint;

/// One estimated pose with its position covariance.
#[derive(Clone, Debug)]
pub struct EstimatedPose {
    /// The pose.
    pub pose: Pose,
    /// 3×3 position covariance.
    pub covariance: [[f64; 3]; 3],
}

fn top_view(c: &[[f64; 3]; 3]) -> Matrix2<f64> {
    Matrix2::new(c[0][0], c[0][2], c[2][0], c[2][2])
}

/// Points of the 3σ ellipse of a 2×2 covariance around (x, z).
fn ellipse(centre: (f64, f64), cov: &Matrix2<f64>) -> Vec<(f64, f64)> {
    let eig = SymmetricEigen::new(*cov);
    let axes: Vec<f64> = eig
        .eigenvalues
        .iter()
        .map(|&l| 3.0 * l.max(0.0).sqrt())
        .collect();
    (0..=48)
        .map(|i| {
            let t = i as f64 / 48.0 * std::f64::consts::TAU;
            let local = nalgebra::Vector2::new(axes[0] * t.cos(), axes[1] * t.sin());
            let p = eig.eigenvectors * local;
            (centre.0 + p.x, centre.1 + p.y)
        })
        .collect()
}

fn bounds(points: impl Iterator<Item = (f64, f64)>) -> ((f64, f64), (f64, f64)) {
    let (mut x0, mut x1, mut y0, mut y1) = (f64::MAX, f64::MIN, f64::MAX, f64::MIN);
    for (x, y) in points {
        if x.is_finite() && y.is_finite() {
            x0 = x0.min(x);
            x1 = x1.max(x);
            y0 = y0.min(y);
            y1 = y1.max(y);
        }
    }
    if x0 > x1 {
        return ((-1.0, 1.0), (-1.0, 1.0));
    }
    // Equal scales on both axes, with a margin.
    let span = (x1 - x0).max(y1 - y0).max(1e-3) * 0.55;
    let (cx, cy) = (0.5 * (x0 + x1), 0.5 * (y0 + y1));
    ((cx - span, cx + span), (cy - span, cy + span))
}

/// Draws the trajectory panel (left) and the map panel (right) to a PNG.
pub fn slam_figure(
    path: &Path,
    trajectory: &[EstimatedPose],
    ground_truth: Option<&[Pose]>,
    map: &[MapPoint],
) -> Result<()> {
    crate::plot::register_font();
    let draw_error = |e: String| Error::Io {
        path: path.to_path_buf(),
        source: std::io::Error::other(e),
    };
    let root = BitMapBackend::new(path, (1400, 700)).into_drawing_area();
    root.fill(&WHITE).map_err(|e| draw_error(e.to_string()))?;
    let panels = root.split_evenly((1, 2));
    let est: Vec<(f64, f64)> = trajectory
        .iter()
        .map(|p| (p.pose.position.x, p.pose.position.z))
        .collect();
    let truth: Vec<(f64, f64)> = ground_truth
        .unwrap_or(&[])
        .iter()
        .map(|p| (p.position.x, p.position.z))
        .collect();
    let step = (trajectory.len() / 25).max(1);

    // Trajectory with covariance ellipses (Fig. 4c–d).
    let (xr, yr) = bounds(est.iter().chain(truth.iter()).copied());
    let mut chart = ChartBuilder::on(&panels[0])
        .caption(
            "Camera trajectory, top view, 3σ ellipses",
            ("sans-serif", 22),
        )
        .margin(15)
        .x_label_area_size(40)
        .y_label_area_size(55)
        .build_cartesian_2d(xr.0..xr.1, yr.0..yr.1)
        .map_err(|e| draw_error(e.to_string()))?;
    chart
        .configure_mesh()
        .x_desc("x (m)")
        .y_desc("z (m)")
        .draw()
        .map_err(|e| draw_error(e.to_string()))?;
    if !truth.is_empty() {
        chart
            .draw_series(LineSeries::new(
                truth.clone(),
                RGBColor(120, 120, 120).stroke_width(2),
            ))
            .map_err(|e| draw_error(e.to_string()))?
            .label("ground truth (aligned)")
            .legend(|(x, y)| PathElement::new(vec![(x, y), (x + 20, y)], RGBColor(120, 120, 120)));
    }
    chart
        .draw_series(LineSeries::new(est.clone(), BLUE.stroke_width(2)))
        .map_err(|e| draw_error(e.to_string()))?
        .label("EKF estimate")
        .legend(|(x, y)| PathElement::new(vec![(x, y), (x + 20, y)], BLUE));
    for p in trajectory.iter().step_by(step) {
        let centre = (p.pose.position.x, p.pose.position.z);
        chart
            .draw_series(std::iter::once(PathElement::new(
                ellipse(centre, &top_view(&p.covariance)),
                RED.mix(0.8),
            )))
            .map_err(|e| draw_error(e.to_string()))?;
    }
    chart
        .configure_series_labels()
        .background_style(WHITE.mix(0.8))
        .border_style(BLACK)
        .draw()
        .map_err(|e| draw_error(e.to_string()))?;

    // Landmarks with covariance ellipses (Fig. 4e–f).
    let points: Vec<(f64, f64)> = map.iter().map(|m| (m.position[0], m.position[2])).collect();
    let (xr, yr) = bounds(points.iter().chain(est.iter()).copied());
    let mut chart = ChartBuilder::on(&panels[1])
        .caption(
            format!("Map: {} landmarks, top view, 3σ ellipses", map.len()),
            ("sans-serif", 22),
        )
        .margin(15)
        .x_label_area_size(40)
        .y_label_area_size(55)
        .build_cartesian_2d(xr.0..xr.1, yr.0..yr.1)
        .map_err(|e| draw_error(e.to_string()))?;
    chart
        .configure_mesh()
        .x_desc("x (m)")
        .y_desc("z (m)")
        .draw()
        .map_err(|e| draw_error(e.to_string()))?;
    chart
        .draw_series(LineSeries::new(est, BLUE.stroke_width(1)))
        .map_err(|e| draw_error(e.to_string()))?;
    for (m, &centre) in map.iter().zip(&points) {
        chart
            .draw_series(std::iter::once(PathElement::new(
                ellipse(centre, &top_view(&m.covariance)),
                RGBColor(30, 160, 60).mix(0.7),
            )))
            .map_err(|e| draw_error(e.to_string()))?;
    }
    chart
        .draw_series(points.iter().map(|&p| Circle::new(p, 2, BLACK.filled())))
        .map_err(|e| draw_error(e.to_string()))?;
    root.present().map_err(|e| draw_error(e.to_string()))?;
    Ok(())
}
