//! Machine-readable outputs: the keypoint JSON of the README as a type, its CSV form, CSV text
//! through the `csv` crate, and atomic file writes (tempfile). Kept in the library, not the CLI:
//! the record is the contract outside tools and the Python bindings rely on.

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
    /// The descriptor's name: "steered" or "entropy".
    pub descriptor: String,
    /// Values per descriptor.
    pub descriptor_length: usize,
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
            descriptor: detection.descriptor.as_str().to_string(),
            descriptor_length: detection.descriptor.length(),
            keypoints: detection.keypoints,
        }
    }

    /// The JSON text (one line).
    pub fn to_json(&self) -> String {
        serde_json::to_string(self).expect("keypoints serialise")
    }

    /// The CSV text: a header and one row per keypoint.
    pub fn to_csv(&self) -> String {
        let header = ["x", "y", "scale", "angle", "response"]
            .into_iter()
            .map(String::from)
            .chain(descriptor_columns(&self.descriptor, self.descriptor_length));
        let rows = self.keypoints.iter().map(|k| {
            [k.x, k.y, k.scale, k.angle, k.response]
                .into_iter()
                .chain(k.descriptor.iter().copied())
                .map(|v| v.to_string())
                .collect::<Vec<_>>()
        });
        csv_text(std::iter::once(header.collect()).chain(rows))
    }
}

/// Writes `bytes` to `path` through a temporary file in the same directory and a rename, so
/// a reader never sees a half-written file and an interrupted run leaves no torn output.
pub fn write_atomic(path: &Path, bytes: &[u8]) -> Result<()> {
    let io = |source| Error::Io {
        path: path.to_path_buf(),
        source,
    };
    let dir = match path.parent().filter(|d| !d.as_os_str().is_empty()) {
        Some(dir) => {
            std::fs::create_dir_all(dir).map_err(io)?;
            dir
        }
        None => Path::new("."),
    };
    // A uniquely named file beside the target, renamed over it once complete: a reader sees
    // the old file or the new one, never half of one, and two writers never share a file.
    let mut tmp = tempfile::NamedTempFile::new_in(dir).map_err(io)?;
    tmp.write_all(bytes)
        .and_then(|_| tmp.as_file().sync_all())
        .map_err(io)?;
    tmp.persist(path).map_err(|e| io(e.error))?;
    Ok(())
}

/// The keypoint CSV's descriptor columns: the entropy at 16 … 256 colours, or d0, d1, … .
fn descriptor_columns(name: &str, len: usize) -> Vec<String> {
    if name == "entropy" {
        ["h16", "h32", "h64", "h128", "h256"]
            .map(String::from)
            .to_vec()
    } else {
        (0..len).map(|i| format!("d{i}")).collect()
    }
}

/// Records as CSV text, quoted where a field needs it (by the `csv` crate, so that paths with
/// commas or quotes survive a round trip through any CSV reader).
pub fn csv_text<R, F>(records: impl IntoIterator<Item = R>) -> String
where
    R: IntoIterator<Item = F>,
    F: AsRef<[u8]>,
{
    let mut w = csv::Writer::from_writer(Vec::new());
    for record in records {
        w.write_record(record)
            .expect("writing CSV to memory cannot fail");
    }
    let bytes = w.into_inner().expect("flushing CSV to memory cannot fail");
    String::from_utf8(bytes).expect("CSV of UTF-8 fields is UTF-8")
}
