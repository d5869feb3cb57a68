//! Machine-readable outputs: the keypoint JSON of the README, a CSV form, atomic file writes.

use std::io::Write;
use std::path::Path;

use serde::{Deserialize, Serialize};

use crate::error::{Error, Result};
use crate::features::Keypoint;

/// The keypoints of one image, serialised exactly as the keypoint JSON of the README.
#[derive(Clone, Debug, PartialEq, Serialize, Deserialize)]
pub struct ImageKeypoints {
    /// The image path as given.
    pub image: String,
    /// Width in pixels.
    pub width: u32,
    /// Height in pixels.
    pub height: u32,
    /// "gpu" or "cpu".
    pub backend: String,
    /// The keypoints, strongest first.
    pub keypoints: Vec<Keypoint>,
}

impl ImageKeypoints {
    /// The record of a detection on `frame`, read from `image`.
    pub fn new(
        image: &Path,
        frame: &crate::image::Frame,
        detection: crate::features::Detection,
    ) -> Self {
        Self {
            image: image.display().to_string(),
            width: frame.width,
            height: frame.height,
            backend: detection.backend.to_string(),
            keypoints: detection.keypoints,
        }
    }

    /// The JSON text (one line).
    pub fn to_json(&self) -> String {
        serde_json::to_string(self).expect("keypoints serialise")
    }

    /// The CSV text: a header and one row per keypoint.
    pub fn to_csv(&self) -> String {
        let mut s = String::from("x,y,scale,angle,response,h16,h32,h64,h128,h256\n");
        for k in &self.keypoints {
            let d = k.descriptor;
            s.push_str(&format!(
                "{},{},{},{},{},{},{},{},{},{}\n",
                k.x, k.y, k.scale, k.angle, k.response, d[0], d[1], d[2], d[3], d[4]
            ));
        }
        s
    }
}

/// Writes `bytes` to `path` through a temporary file in the same directory and a rename, so
/// a reader never sees a half-written file and an interrupted run leaves no torn output.
pub fn write_atomic(path: &Path, bytes: &[u8]) -> Result<()> {
    let io = |source| Error::Io {
        path: path.to_path_buf(),
        source,
    };
    if let Some(dir) = path.parent().filter(|d| !d.as_os_str().is_empty()) {
        std::fs::create_dir_all(dir).map_err(io)?;
    }
    let name = path
        .file_name()
        .map(|n| n.to_string_lossy().into_owned())
        .unwrap_or_default();
    let tmp = path.with_file_name(format!(".{name}.tmp{}", std::process::id()));
    let mut f = std::fs::File::create(&tmp).map_err(io)?;
    f.write_all(bytes).and_then(|_| f.sync_all()).map_err(io)?;
    drop(f);
    std::fs::rename(&tmp, path).map_err(io)
}
