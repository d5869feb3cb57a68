//! `steernav slam` on a folder with TUM RGB-D depth images (depth.txt): the map's depths
//! against them, frame by frame (DIR/depth_ratios.csv) and over the thirds of the run, to see
//! whether the map keeps one unit and whether it is the trajectory's.

use std::path::{Path, PathBuf};

use anyhow::Context;
use steernav::slam::data::depth::{depth_ratios, quartiles, DepthImage, DepthList};
use steernav::slam::{FrameReport, MapPoint};
use steernav::PinholeCamera;

/// Colour and depth frames pair within this many seconds, as TUM's associate.py pairs them.
const PAIRING: f64 = 0.02;

/// The running check of one sequence.
pub struct DepthCheck {
    list: DepthList,
    camera: PinholeCamera,
    csv: csv::Writer<std::fs::File>,
    path: PathBuf,
    /// The median ratio of every frame checked, in order.
    medians: Vec<f64>,
    /// Frames whose depth image was missing or unreadable.
    unread: usize,
}

impl DepthCheck {
    /// The check, when `sequence` has a depth.txt; its rows go to `out`/depth_ratios.csv.
    pub fn open(
        sequence: &Path,
        camera: &PinholeCamera,
        out: &Path,
    ) -> anyhow::Result<Option<Self>> {
        let Some(list) = DepthList::open(sequence)? else {
            return Ok(None);
        };
        let path = out.join("depth_ratios.csv");
        let mut csv = csv::Writer::from_path(&path)
            .with_context(|| format!("{}: cannot write", path.display()))?;
        csv.write_record([
            "timestamp",
            "landmarks",
            "ratio_q1",
            "ratio_median",
            "ratio_q3",
        ])
        .with_context(|| format!("{}: cannot write", path.display()))?;
        Ok(Some(Self {
            list,
            camera: camera.clone(),
            csv,
            path,
            medians: Vec::new(),
            unread: 0,
        }))
    }

    /// Checks the map after frame `r`; a frame without a depth image within 0.02 s, or with one
    /// that cannot be read (a warning says why), is left out.
    pub fn frame(&mut self, map: &[MapPoint], r: &FrameReport) -> anyhow::Result<()> {
        if r.lost || r.initialising {
            return Ok(());
        }
        let Some(image_path) = self.list.nearest(r.timestamp, PAIRING) else {
            self.unread += 1;
            return Ok(());
        };
        let depth = match DepthImage::load(image_path, (self.camera.width, self.camera.height)) {
            Ok(d) => d,
            Err(e) => {
                log::warn!("{e}; frame left out of the depth check");
                self.unread += 1;
                return Ok(());
            }
        };
        let mut ratios = depth_ratios(map, &r.position, &r.orientation, &self.camera, &depth);
        let Some([q1, median, q3]) = quartiles(&mut ratios) else {
            return Ok(());
        };
        self.medians.push(median);
        let row = [
            format!("{:.6}", r.timestamp),
            ratios.len().to_string(),
            format!("{q1:.4}"),
            format!("{median:.4}"),
            format!("{q3:.4}"),
        ];
        self.csv
            .write_record(&row)
            .and_then(|()| Ok(self.csv.flush()?))
            .with_context(|| format!("{}: cannot write", self.path.display()))
    }

    /// The summary line: the median ratio over each third of the frames checked, and times
    /// `scale` (the trajectory's Sim(3) scale, metres per map unit) when there is one.
    pub fn summary(&self, scale: Option<f64>) -> String {
        let n = self.medians.len();
        if n < 3 {
            return format!(
                "map depths against depth.txt: {n} frames checked ({} without a depth image)",
                self.unread
            );
        }
        let thirds: Vec<f64> = (0..3)
            .map(|i| {
                let mut part = self.medians[i * n / 3..(i + 1) * n / 3].to_vec();
                quartiles(&mut part).map_or(f64::NAN, |q| q[1])
            })
            .collect();
        let show = |v: &[f64]| {
            v.iter()
                .map(|x| format!("{x:.3}"))
                .collect::<Vec<_>>()
                .join(" / ")
        };
        let mut line = format!(
            "map depths against depth.txt ({n} frames, {}): estimate over truth {} map units per metre over the thirds of the run",
            self.path.display(),
            show(&thirds)
        );
        if let Some(s) = scale {
            let metric: Vec<f64> = thirds.iter().map(|t| t * s).collect();
            line += &format!(
                "; × the trajectory's scale {} (1 where the map's unit is the trajectory's)",
                show(&metric)
            );
        }
        line
    }
}
