//! The classic detectors (AGAST, BRISK, CenSurE, ORB, SIFT, FAST, KAZE, AKAZE, SURF where
//! available, and Harris via goodFeaturesToTrack) run by OpenCV from a pinned Python wheel:
//! `tools/setup-peers.sh` creates `.venv-peers` with it and `tools/peers.py` prints their
//! keypoints and descriptors as JSON lines. Only detection happens there; steernav computes
//! every metric itself, so all rows are judged alike.
//!
//! Why Python and not the `opencv` crate: the wheel is a fixed, prebuilt OpenCV (4.10.0 with
//! contrib, for StarDetector) that installs in seconds on any machine with Python, needs no
//! system OpenCV or libclang, and keeps the crate's build free of a heavy optional dependency.

use std::collections::HashMap;
use std::path::{Path, PathBuf};
use std::process::Command;

use serde::Deserialize;

use super::recall::{Descriptors, KeypointSet};
use crate::error::{Error, Result};

/// Every peer the script knows, in table order.
pub const ALL_PEERS: [&str; 10] = [
    "agast", "brisk", "censure", "orb", "sift", "surf", "fast", "kaze", "akaze", "harris",
];

/// Runs `tools/peers.py` with a Python that has OpenCV.
#[derive(Clone, Debug)]
pub struct PeerRunner {
    python: PathBuf,
    script: PathBuf,
}

/// What the installed OpenCV offers.
#[derive(Clone, Debug, Deserialize)]
pub struct Availability {
    /// Peers that run.
    pub available: Vec<String>,
    /// Peers this OpenCV build lacks (SURF is non-free and absent from the wheels).
    pub missing: Vec<String>,
    /// OpenCV's version.
    pub opencv: String,
}

#[derive(Deserialize)]
struct PeerOutput {
    image: String,
    detector: String,
    keypoints: Vec<[f64; 5]>,
    norm: String,
    descriptors: Vec<Vec<f64>>,
}

impl PeerRunner {
    /// Finds the interpreter: `python` if given, else `$STEERNAV_PYTHON`, else the virtual
    /// environment `tools/setup-peers.sh` creates (`.venv-peers/bin/python` in the source tree).
    pub fn locate(python: Option<&Path>) -> Result<Self> {
        let root = Path::new(env!("CARGO_MANIFEST_DIR"));
        let python = python
            .map(Path::to_path_buf)
            .or_else(|| std::env::var_os("STEERNAV_PYTHON").map(PathBuf::from))
            .unwrap_or_else(|| root.join(".venv-peers/bin/python"));
        let script = std::env::var_os("STEERNAV_PEERS_SCRIPT")
            .map(PathBuf::from)
            .unwrap_or_else(|| root.join("tools/peers.py"));
        if !python.exists() {
            return Err(Error::Io {
                path: python,
                source: std::io::Error::new(
                    std::io::ErrorKind::NotFound,
                    "no Python with OpenCV here: run `bash tools/setup-peers.sh` (or pass --python)",
                ),
            });
        }
        Ok(Self { python, script })
    }

    fn run(&self, args: &[&std::ffi::OsStr]) -> Result<String> {
        let out = Command::new(&self.python)
            .arg(&self.script)
            .args(args)
            .output()
            .map_err(|source| Error::Io {
                path: self.python.clone(),
                source,
            })?;
        if !out.status.success() {
            return Err(Error::Parse {
                path: self.script.clone(),
                reason: format!(
                    "peer detectors failed: {}",
                    String::from_utf8_lossy(&out.stderr).trim()
                ),
            });
        }
        String::from_utf8(out.stdout).map_err(|e| Error::Parse {
            path: self.script.clone(),
            reason: e.to_string(),
        })
    }

    /// Which peers the installed OpenCV has.
    pub fn availability(&self) -> Result<Availability> {
        let text = self.run(&["list".as_ref()])?;
        serde_json::from_str(text.trim()).map_err(|e| Error::Parse {
            path: self.script.clone(),
            reason: e.to_string(),
        })
    }

    /// Runs `detectors` on every image; keyed by (image path as given, detector).
    pub fn detect(
        &self,
        detectors: &[String],
        images: &[PathBuf],
    ) -> Result<HashMap<(String, String), KeypointSet>> {
        if detectors.is_empty() || images.is_empty() {
            return Ok(HashMap::new());
        }
        let list = detectors.join(",");
        let mut args: Vec<&std::ffi::OsStr> = vec![list.as_ref()];
        args.extend(images.iter().map(|p| p.as_os_str()));
        let text = self.run(&args)?;
        let mut out = HashMap::new();
        for line in text.lines().filter(|l| !l.trim().is_empty()) {
            let p: PeerOutput = serde_json::from_str(line).map_err(|e| Error::Parse {
                path: self.script.clone(),
                reason: e.to_string(),
            })?;
            let points = p.keypoints.iter().map(|k| (k[0], k[1])).collect();
            let descriptors = if p.norm == "hamming" {
                Descriptors::Binary(
                    p.descriptors
                        .iter()
                        .map(|d| d.iter().map(|&v| v as u8).collect())
                        .collect(),
                )
            } else {
                Descriptors::Float(
                    p.descriptors
                        .iter()
                        .map(|d| d.iter().map(|&v| v as f32).collect())
                        .collect(),
                )
            };
            out.insert(
                (p.image, p.detector),
                KeypointSet {
                    points,
                    descriptors,
                    // OpenCV's size is a diameter.
                    scales: p.keypoints.iter().map(|k| k[3] / 2.0).collect(),
                },
            );
        }
        Ok(out)
    }
}
