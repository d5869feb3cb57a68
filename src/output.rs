//! Machine-readable outputs: the keypoint JSON of the README as a type, its CSV form, CSV text
//! through the `csv` crate, and atomic file writes (tempfile). Kept in the library, not the CLI:
//! the record is the contract outside tools and the Python bindings rely on.

use std::io::Write;
use std::path::{Path, PathBuf};

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
    /// The descriptor's name: "steered", "steered-twin", "entropy" or "none".
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
///
/// What is at `path` is respected: a symbolic link is written through (its target is
/// replaced, the link stays); a device, a FIFO or anything else that is not a regular file is
/// written to directly, never replaced; a directory is refused. The new file gets the mode a
/// plain create would give it (0666 less the umask), or the mode of the file it replaces.
pub fn write_atomic(path: &Path, bytes: &[u8]) -> Result<()> {
    let io = |source| Error::Io {
        path: path.to_path_buf(),
        source,
    };
    let target = resolve_link(path).map_err(io)?;
    if let Ok(meta) = std::fs::metadata(&target) {
        if meta.is_dir() {
            return Err(io(std::io::Error::new(
                std::io::ErrorKind::IsADirectory,
                "is a directory",
            )));
        }
        if !meta.is_file() {
            // A device or a FIFO: the bytes go to it, and it stays what it is.
            let mut f = std::fs::OpenOptions::new()
                .write(true)
                .open(&target)
                .map_err(io)?;
            return f.write_all(bytes).and_then(|_| f.flush()).map_err(io);
        }
    }
    let dir = match target.parent().filter(|d| !d.as_os_str().is_empty()) {
        Some(dir) => {
            std::fs::create_dir_all(dir).map_err(io)?;
            dir
        }
        None => Path::new("."),
    };
    // A uniquely named file beside the target, renamed over it once complete: a reader sees
    // the old file or the new one, never half of one, and two writers never share a file.
    let mut builder = tempfile::Builder::new();
    let replaced = std::fs::metadata(&target).ok().map(|m| m.permissions());
    #[cfg(unix)]
    {
        use std::os::unix::fs::PermissionsExt;
        // Created with 0666 the umask applies, as for any new file.
        builder.permissions(std::fs::Permissions::from_mode(0o666));
    }
    let mut tmp = builder.tempfile_in(dir).map_err(io)?;
    if let Some(mode) = replaced {
        tmp.as_file().set_permissions(mode).map_err(io)?;
    }
    tmp.write_all(bytes)
        .and_then(|_| tmp.as_file().sync_all())
        .map_err(io)?;
    tmp.persist(&target).map_err(|e| io(e.error))?;
    Ok(())
}

/// Where writing to `path` lands: the file its chain of symbolic links ends at (a dangling
/// link's target, to be created), or `path` itself.
fn resolve_link(path: &Path) -> std::io::Result<std::path::PathBuf> {
    let mut current = path.to_path_buf();
    // A bounded walk: a loop of links is an error, as the kernel's own resolution says.
    for _ in 0..40 {
        match std::fs::symlink_metadata(&current) {
            Ok(meta) if meta.file_type().is_symlink() => {
                let next = std::fs::read_link(&current)?;
                current = match current.parent() {
                    Some(dir) if next.is_relative() => dir.join(next),
                    _ => next,
                };
            }
            _ => return Ok(current),
        }
    }
    Err(std::io::Error::other("too many levels of symbolic links"))
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
    String::from_utf8(csv_bytes(records)).expect("CSV of UTF-8 fields is UTF-8")
}

/// [`csv_text`] for fields that need not be UTF-8 (file names as the file system has them).
pub fn csv_bytes<R, F>(records: impl IntoIterator<Item = R>) -> Vec<u8>
where
    R: IntoIterator<Item = F>,
    F: AsRef<[u8]>,
{
    let mut w = csv::Writer::from_writer(Vec::new());
    for record in records {
        w.write_record(record)
            .expect("writing CSV to memory cannot fail");
    }
    w.into_inner().expect("flushing CSV to memory cannot fail")
}

/// A path's bytes as the file system has them (on Unix a name need not be UTF-8; elsewhere
/// its lossy UTF-8 form), for a CSV field that must name the file exactly.
pub fn path_bytes(path: &Path) -> Vec<u8> {
    #[cfg(unix)]
    {
        use std::os::unix::ffi::OsStrExt;
        path.as_os_str().as_bytes().to_vec()
    }
    #[cfg(not(unix))]
    {
        path.to_string_lossy().into_owned().into_bytes()
    }
}

/// The path a [`path_bytes`] field names.
pub fn path_from_bytes(bytes: &[u8]) -> PathBuf {
    #[cfg(unix)]
    {
        use std::os::unix::ffi::OsStrExt;
        PathBuf::from(std::ffi::OsStr::from_bytes(bytes))
    }
    #[cfg(not(unix))]
    {
        PathBuf::from(String::from_utf8_lossy(bytes).into_owned())
    }
}

#[cfg(all(test, unix))]
mod write_tests {
    use super::*;
    use std::os::unix::fs::{FileTypeExt, PermissionsExt};

    #[test]
    fn links_are_written_through_devices_kept_and_modes_those_of_a_plain_create() {
        let dir = tempfile::tempdir().unwrap();
        // A new file: 0666 less the umask, like File::create (compared with one).
        let plain = dir.path().join("plain");
        std::fs::File::create(&plain).unwrap();
        let new = dir.path().join("new.json");
        write_atomic(&new, b"1").unwrap();
        let mode = |p: &Path| std::fs::metadata(p).unwrap().permissions().mode() & 0o777;
        assert_eq!(mode(&new), mode(&plain));
        // A replaced file keeps its mode.
        std::fs::set_permissions(&new, std::fs::Permissions::from_mode(0o640)).unwrap();
        write_atomic(&new, b"2").unwrap();
        assert_eq!(
            (mode(&new), std::fs::read(&new).unwrap()),
            (0o640, b"2".to_vec())
        );
        // A link is written through: the link stays, its target changes.
        let link = dir.path().join("link.json");
        std::os::unix::fs::symlink("new.json", &link).unwrap();
        write_atomic(&link, b"3").unwrap();
        assert!(std::fs::symlink_metadata(&link)
            .unwrap()
            .file_type()
            .is_symlink());
        assert_eq!(std::fs::read(&new).unwrap(), b"3");
        // A device is written to, never replaced; a full one is an error naming the path.
        write_atomic(Path::new("/dev/null"), b"4").unwrap();
        assert!(std::fs::metadata("/dev/null")
            .unwrap()
            .file_type()
            .is_char_device());
        let e = write_atomic(Path::new("/dev/full"), b"5")
            .unwrap_err()
            .to_string();
        assert!(e.contains("/dev/full"), "{e}");
        assert!(!std::fs::metadata("/dev/full").unwrap().is_file());
        // A directory is refused.
        assert!(write_atomic(dir.path(), b"6").is_err());
    }
}
