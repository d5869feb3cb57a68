//! What the tracker says about each frame and about its map: the frame report (with the CSV
//! row the CLI writes), its timings, and the landmarks of the map output.

use serde::Serialize;

use crate::slam::inverse_depth::Parametrisation;

/// Wall-clock split of one frame, milliseconds.
#[derive(Clone, Copy, Debug, Default, Serialize)]
pub struct SlamTimings {
    /// Keypoint detection (only on frames that need new landmarks).
    pub detection_ms: f64,
    /// Prediction of every landmark, active search, descriptor check and RANSAC.
    pub association_ms: f64,
    /// EKF prediction, updates and map management.
    pub filter_ms: f64,
    /// The whole frame.
    pub total_ms: f64,
}

/// What happened in one frame.
#[derive(Clone, Debug, Serialize)]
pub struct FrameReport {
    /// Timestamp, seconds.
    pub timestamp: f64,
    /// Camera position after the update.
    pub position: [f64; 3],
    /// Camera orientation (w, x, y, z), camera → world.
    pub orientation: [f64; 4],
    /// Covariance of the position.
    pub position_covariance: [[f64; 3]; 3],
    /// Landmarks predicted inside the image.
    pub predicted: usize,
    /// Matches found by the active search (before RANSAC).
    pub matched: usize,
    /// Matches dropped by the descriptor check.
    pub descriptor_rejected: usize,
    /// Low-innovation inliers of 1-point RANSAC.
    pub inliers: usize,
    /// High-innovation inliers rescued by the χ² gate.
    pub rescued: usize,
    /// Landmarks created.
    pub created: usize,
    /// Landmarks deleted.
    pub deleted: usize,
    /// Landmarks converted to Euclidean.
    pub converted: usize,
    /// Landmarks in the state after the frame.
    pub landmarks: usize,
    /// State dimension after the frame.
    pub state_dim: usize,
    /// Fewer than 3 landmarks supported the pose this frame.
    pub lost: bool,
    /// Tracking resumed here against the existing map after being lost for at least
    /// `lost_after` frames.
    pub relocalised: bool,
    /// The filter is waiting for enough parallax to start (the pose is the start pose).
    pub initialising: bool,
    /// The filter refused an update this frame (its innovation covariance was not positive
    /// definite); the refused observations did not count as support.
    pub update_rejected: bool,
    /// Timings.
    pub timings: SlamTimings,
}

impl FrameReport {
    /// Column names of [`FrameReport::csv_record`], in order.
    pub const CSV_HEADER: &'static [&'static str] = &[
        "timestamp",
        "predicted",
        "matched",
        "descriptor_rejected",
        "inliers",
        "rescued",
        "created",
        "deleted",
        "converted",
        "landmarks",
        "state_dim",
        "lost",
        "relocalised",
        "initialising",
        "update_rejected",
        "detection_ms",
        "association_ms",
        "filter_ms",
        "total_ms",
    ];

    /// The report as one CSV row (the pose is in the trajectory file): timestamp to the
    /// microsecond, counts, flags, timings to the microsecond.
    pub fn csv_record(&self) -> Vec<String> {
        let counts = [
            self.predicted,
            self.matched,
            self.descriptor_rejected,
            self.inliers,
            self.rescued,
            self.created,
            self.deleted,
            self.converted,
            self.landmarks,
            self.state_dim,
        ];
        let flags = [
            self.lost,
            self.relocalised,
            self.initialising,
            self.update_rejected,
        ];
        let t = &self.timings;
        let times = [t.detection_ms, t.association_ms, t.filter_ms, t.total_ms];
        std::iter::once(format!("{:.6}", self.timestamp))
            .chain(counts.iter().map(|c| c.to_string()))
            .chain(flags.iter().map(|f| f.to_string()))
            .chain(times.iter().map(|ms| format!("{ms:.3}")))
            .collect()
    }
}

/// A landmark of the map output.
#[derive(Clone, Debug, Serialize)]
pub struct MapPoint {
    /// Stable landmark id.
    pub id: u64,
    /// How it is held in the state.
    pub parametrisation: Parametrisation,
    /// Euclidean position, world frame.
    pub position: [f64; 3],
    /// 3×3 covariance of the position (first order for inverse-depth landmarks).
    pub covariance: [[f64; 3]; 3],
    /// Frames in which it was matched and used.
    pub observations: usize,
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn the_csv_row_has_one_value_per_column() {
        let report = FrameReport {
            timestamp: 1.5,
            position: [0.0; 3],
            orientation: [1.0, 0.0, 0.0, 0.0],
            position_covariance: [[0.0; 3]; 3],
            predicted: 1,
            matched: 2,
            descriptor_rejected: 3,
            inliers: 4,
            rescued: 5,
            created: 6,
            deleted: 7,
            converted: 8,
            landmarks: 9,
            state_dim: 10,
            lost: false,
            relocalised: true,
            initialising: false,
            update_rejected: true,
            timings: SlamTimings {
                detection_ms: 1.0,
                association_ms: 2.0,
                filter_ms: 3.0,
                total_ms: 6.0,
            },
        };
        let row = report.csv_record();
        assert_eq!(row.len(), FrameReport::CSV_HEADER.len());
        let at = |name: &str| {
            let i = FrameReport::CSV_HEADER
                .iter()
                .position(|c| *c == name)
                .unwrap();
            row[i].as_str()
        };
        assert_eq!(at("timestamp"), "1.500000");
        assert_eq!(at("rescued"), "5");
        assert_eq!(at("state_dim"), "10");
        assert_eq!(at("relocalised"), "true");
        assert_eq!(at("update_rejected"), "true");
        assert_eq!(at("total_ms"), "6.000");
    }
}
