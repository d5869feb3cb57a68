//! Image sequences for `steernav slam`: the TUM RGB-D layout (rgb.txt + rgb/ +
//! groundtruth.txt), the EuRoC layout (cam0/data.csv + cam0/data/ + cam0/sensor.yaml), the
//! KITTI odometry layout (image_0/ or image_l/ + calib.txt + times.txt + poses.txt), and a
//! plain folder of frames sorted by name with timestamps from a frame rate.

use std::path::{Path, PathBuf};

use crate::error::{Error, Result};
use crate::slam::camera::PinholeCamera;

/// One frame of a sequence.
#[derive(Clone, Debug, PartialEq)]
pub struct SequenceFrame {
    /// Seconds.
    pub timestamp: f64,
    /// Image file.
    pub path: PathBuf,
}

/// An opened sequence.
#[derive(Clone, Debug)]
pub struct Sequence {
    /// "tum", "euroc", "kitti" or "folder".
    pub layout: &'static str,
    /// Frames whose file exists, in time order.
    pub frames: Vec<SequenceFrame>,
    /// Listed frames whose file is missing (skipped, reported).
    pub missing: Vec<PathBuf>,
    /// A ground-truth trajectory found beside the frames (TUM format, or KITTI poses.txt).
    pub ground_truth: Option<PathBuf>,
    /// KITTI: the time of every row of `times.txt` (or of every frame number up to the last,
    /// at the frame rate), which is also the time of the same row of `poses.txt`: frame
    /// `000042.png` is row 42 whatever frames are missing. Empty for the other layouts.
    pub row_times: Vec<f64>,
    /// A calibration found beside the frames (EuRoC sensor.yaml, KITTI calib.txt, calib.toml
    /// beside a TUM rgb.txt).
    pub calibration: Option<PathBuf>,
}

impl Sequence {
    /// The times of the ground truth's rows, for [`read_ground_truth`]: a KITTI `poses.txt`
    /// row belongs to the frame of its number ([`Sequence::row_times`]); other layouts pair
    /// by timestamp, and get the frames' times.
    pub fn ground_truth_times(&self) -> Vec<f64> {
        if self.row_times.is_empty() {
            self.frames.iter().map(|f| f.timestamp).collect()
        } else {
            self.row_times.clone()
        }
    }

    /// The camera the frames were taken with: from `calibration` when given, else from the
    /// sequence's own file ([`Sequence::calibration`]). The format follows the extension — a
    /// KITTI `calib.txt` (row P0; the image size from the first frame), a EuRoC `sensor.yaml`,
    /// or TOML with a `[camera]` table — and the frames must be the calibration's size, which
    /// is checked here, before any frame is processed.
    pub fn camera(&self, calibration: Option<&Path>) -> Result<PinholeCamera> {
        let first = &self
            .frames
            .first()
            .ok_or_else(|| Error::input("sequence", "has no frames"))?
            .path;
        let path = calibration.or(self.calibration.as_deref()).ok_or_else(|| {
            Error::input(
                first.parent().unwrap_or(first).display().to_string(),
                "no calibration beside the frames, and none given",
            )
        })?;
        let (width, height) = image::image_dimensions(first).map_err(|e| Error::Decode {
            path: first.clone(),
            reason: "cannot read the image size".into(),
            source: Some(Box::new(e)),
        })?;
        let camera = if path.extension().is_some_and(|e| e == "txt") {
            super::kitti::read_calibration(path, width, height)?
        } else {
            PinholeCamera::load(path)?
        };
        if (width, height) != (camera.width, camera.height) {
            return Err(Error::ImageSize {
                input: first.display().to_string(),
                width,
                height,
                reason: format!(
                    "the calibration {} is for {}x{}",
                    path.display(),
                    camera.width,
                    camera.height
                ),
            });
        }
        Ok(camera)
    }
}

const IMAGE_EXTENSIONS: [&str; 7] = ["png", "jpg", "jpeg", "pgm", "ppm", "bmp", "tif"];

/// Frame rate of a KITTI sequence without times.txt.
pub const KITTI_FPS: f64 = 10.0;
/// Frame rate of a plain folder of frames.
pub const FOLDER_FPS: f64 = 30.0;

/// Opens a sequence, recognising its layout; `fps` gives a plain folder (default
/// [`FOLDER_FPS`]) or a KITTI folder without times.txt (default [`KITTI_FPS`]) its timestamps.
pub fn open(dir: &Path, fps: Option<f64>) -> Result<Sequence> {
    if !dir.is_dir() {
        return Err(Error::Io {
            path: dir.to_path_buf(),
            source: std::io::Error::new(std::io::ErrorKind::NotFound, "not a directory"),
        });
    }
    // A given rate is checked even where the layout brings its own timestamps, and a warning
    // says it is not used there.
    if let Some(f) = fps {
        checked_fps(f)?;
    }
    let ignored = |stamps: &Path| {
        if fps.is_some() {
            log::warn!(
                "{}: the frame rate given is not used: the timestamps come from {}",
                dir.display(),
                stamps.display()
            );
        }
    };
    let first_existing = |names: &[&str]| names.iter().map(|n| dir.join(n)).find(|p| p.is_file());
    let ground_truth = first_existing(&["groundtruth.txt", "groundtruth_tum.txt"]);
    let mut sequence = if dir.join("rgb.txt").is_file() {
        let list = dir.join("rgb.txt");
        ignored(&list);
        let frames = parse_list(&list, dir, |fields| {
            let t: f64 = fields.first()?.parse().ok()?;
            Some((t, fields.get(1)?.to_string()))
        })?;
        Sequence {
            layout: "tum",
            frames,
            missing: Vec::new(),
            ground_truth,
            row_times: Vec::new(),
            // `slam-synth` writes its calibration here.
            calibration: Some(dir.join("calib.toml")).filter(|p| p.is_file()),
        }
    } else if let Some(cam) = ["cam0", "mav0/cam0", "."]
        .iter()
        .map(|c| dir.join(c))
        .find(|c| c.join("data.csv").is_file())
    {
        let list = cam.join("data.csv");
        ignored(&list);
        let data = cam.join("data");
        let frames = parse_list(&list, &data, |fields| {
            let ns: f64 = fields.first()?.parse().ok()?;
            Some((ns * 1e-9, fields.get(1)?.to_string()))
        })?;
        Sequence {
            layout: "euroc",
            frames,
            missing: Vec::new(),
            ground_truth,
            row_times: Vec::new(),
            calibration: Some(cam.join("sensor.yaml")).filter(|p| p.is_file()),
        }
    } else if let Some(images) = ["image_0", "image_l"]
        .iter()
        .map(|d| dir.join(d))
        .find(|d| d.is_dir())
    {
        let (numbers, files): (Vec<usize>, Vec<PathBuf>) =
            kitti_numbered(image_files(&images)?)?.into_iter().unzip();
        let rows = numbers.iter().max().map_or(0, |&n| n + 1);
        let times_path = dir.join("times.txt");
        let row_times: Vec<f64> = if times_path.is_file() {
            ignored(&times_path);
            let times = super::kitti::read_times(&times_path)?;
            if times.len() < rows {
                let last = numbers
                    .iter()
                    .position(|&n| n + 1 == rows)
                    .expect("the last");
                return Err(Error::Parse {
                    path: times_path,
                    reason: format!(
                        "{} timestamps, but frame {} is number {}",
                        times.len(),
                        files[last].display(),
                        rows - 1
                    ),
                });
            }
            times[..rows].to_vec()
        } else {
            let fps = checked_fps(fps.unwrap_or(KITTI_FPS))?;
            (0..rows).map(|i| i as f64 / fps).collect()
        };
        let timestamps: Vec<f64> = numbers.iter().map(|&n| row_times[n]).collect();
        let calib = dir.join("calib.txt");
        if !calib.is_file() {
            return Err(Error::Io {
                path: calib,
                source: std::io::Error::new(
                    std::io::ErrorKind::NotFound,
                    "a KITTI sequence needs its calib.txt beside the image folder",
                ),
            });
        }
        Sequence {
            layout: "kitti",
            frames: files
                .into_iter()
                .zip(timestamps)
                .map(|(path, timestamp)| SequenceFrame { timestamp, path })
                .collect(),
            missing: Vec::new(),
            ground_truth: Some(dir.join("poses.txt")).filter(|p| p.is_file()),
            row_times,
            calibration: Some(calib),
        }
    } else {
        let fps = checked_fps(fps.unwrap_or(FOLDER_FPS))?;
        let files = image_files(dir)?;
        Sequence {
            layout: "folder",
            frames: files
                .into_iter()
                .enumerate()
                .map(|(i, path)| SequenceFrame {
                    timestamp: i as f64 / fps,
                    path,
                })
                .collect(),
            missing: Vec::new(),
            ground_truth,
            row_times: Vec::new(),
            calibration: None,
        }
    };
    let (present, missing): (Vec<_>, Vec<_>) =
        sequence.frames.drain(..).partition(|f| f.path.is_file());
    sequence.frames = present;
    sequence.missing = missing.into_iter().map(|f| f.path).collect();
    if sequence.frames.is_empty() {
        return Err(Error::Parse {
            path: dir.to_path_buf(),
            reason: format!(
                "no frames found ({} layout{})",
                sequence.layout,
                if sequence.missing.is_empty() {
                    String::new()
                } else {
                    format!(", {} listed files missing", sequence.missing.len())
                }
            ),
        });
    }
    Ok(sequence)
}

/// `fps` if it is a frame rate in [1e-5, 1e6] per second, else a configuration error naming it.
pub fn checked_fps(fps: f64) -> Result<f64> {
    // Below a frame a day or above a million a second, 1/fps and i/fps stop meaning frames
    // (1e-320 makes every step infinite): a typo, not a rate.
    if !(fps.is_finite() && (1e-5..=1e6).contains(&fps)) {
        // In exponent form: a refused rate is tiny or huge, and `Display` would write out
        // every digit of 1e-320.
        return Err(Error::config(
            "fps",
            format!("{fps:e}"),
            "must be a rate in [1e-5, 1e6] frames per second",
        ));
    }
    Ok(fps)
}

/// Largest KITTI frame number read from a file name: beyond it (a stray file) the row table
/// would grow without bound, so the files are numbered by position instead.
const MAX_KITTI_FRAME: usize = 10_000_000;

/// Each KITTI image with its frame number, the file stem (`000042.png` is 42), in number
/// order; two files with one number are refused. When a stem is not a number, the files are
/// numbered by their position in name order instead (with a warning).
fn kitti_numbered(files: Vec<PathBuf>) -> Result<Vec<(usize, PathBuf)>> {
    let number = |f: &PathBuf| f.file_stem()?.to_str()?.parse::<usize>().ok();
    let parsed: Option<Vec<usize>> = files.iter().map(number).collect();
    let Some(numbers) = parsed.filter(|n| n.iter().all(|&k| k <= MAX_KITTI_FRAME)) else {
        log::warn!("KITTI images not all named by frame number (000042.png): numbered by position");
        return Ok(files.into_iter().enumerate().collect());
    };
    let mut numbered: Vec<(usize, PathBuf)> = numbers.into_iter().zip(files).collect();
    numbered.sort();
    if let Some(pair) = numbered.windows(2).find(|p| p[0].0 == p[1].0) {
        return Err(Error::Parse {
            path: pair[1].1.clone(),
            reason: format!("frame number {} is also {}", pair[1].0, pair[0].1.display()),
        });
    }
    Ok(numbered)
}

/// Image files of a folder, sorted by name.
fn image_files(dir: &Path) -> Result<Vec<PathBuf>> {
    let mut files: Vec<PathBuf> = std::fs::read_dir(dir)
        .map_err(|source| Error::Io {
            path: dir.to_path_buf(),
            source,
        })?
        .filter_map(|e| e.ok().map(|e| e.path()))
        .filter(|p| {
            p.is_file()
                && p.extension()
                    .and_then(|e| e.to_str())
                    .is_some_and(|e| IMAGE_EXTENSIONS.contains(&e.to_ascii_lowercase().as_str()))
        })
        .collect();
    files.sort();
    Ok(files)
}

/// Reads a frame list (comments with `#`, fields split by commas or spaces); timestamps must
/// increase strictly.
fn parse_list(
    list: &Path,
    base: &Path,
    parse: impl Fn(&[&str]) -> Option<(f64, String)>,
) -> Result<Vec<SequenceFrame>> {
    let text = crate::error::read_input(list)?;
    let mut frames: Vec<SequenceFrame> = Vec::new();
    for (i, line) in text.lines().enumerate() {
        let line = line.trim();
        if line.is_empty() || line.starts_with('#') {
            continue;
        }
        let fields: Vec<&str> = line
            .split(|c: char| c == ',' || c.is_whitespace())
            .filter(|s| !s.is_empty())
            .collect();
        let bad = |reason: String| Error::Parse {
            path: list.to_path_buf(),
            reason: format!("line {}: {reason}", i + 1),
        };
        let (t, name) = parse(&fields)
            .ok_or_else(|| bad(format!("expected `timestamp filename`, got {line:?}")))?;
        if !t.is_finite() {
            return Err(bad(format!("timestamp {t} is not finite")));
        }
        if let Some(prev) = frames.last() {
            if t <= prev.timestamp {
                return Err(bad(format!(
                    "timestamps out of order: {t} after {}",
                    prev.timestamp
                )));
            }
        }
        frames.push(SequenceFrame {
            timestamp: t,
            path: base.join(name),
        });
    }
    Ok(frames)
}

/// Reads ground truth: KITTI pose rows (row i at `frame_times[i]`), a TUM file, or EuRoC's
/// state_groundtruth_estimate0/data.csv (timestamp ns, position, quaternion w x y z, …).
pub fn read_ground_truth(path: &Path, frame_times: &[f64]) -> Result<Vec<super::trajectory::Pose>> {
    if super::kitti::looks_like_poses(path) {
        return super::kitti::read_poses(path, frame_times);
    }
    if path.extension().is_some_and(|e| e == "csv") {
        let frames_like = crate::error::read_input(path)?;
        let mut poses = Vec::new();
        for (i, line) in frames_like.lines().enumerate() {
            let line = line.trim();
            if line.is_empty() || line.starts_with('#') {
                continue;
            }
            let v: Vec<f64> = line
                .split(',')
                .map(|s| s.trim().parse::<f64>())
                .collect::<std::result::Result<_, _>>()
                .map_err(|e| Error::Parse {
                    path: path.to_path_buf(),
                    reason: format!("line {}: {e}", i + 1),
                })?;
            if v.len() < 8 {
                return Err(Error::Parse {
                    path: path.to_path_buf(),
                    reason: format!("line {}: expected at least 8 values", i + 1),
                });
            }
            let pose = super::trajectory::checked_pose(
                v[0] * 1e-9,
                [v[1], v[2], v[3]],
                [v[4], v[5], v[6], v[7]],
                poses.last(),
            )
            .map_err(|reason| Error::Parse {
                path: path.to_path_buf(),
                reason: format!("line {}: {reason}", i + 1),
            })?;
            poses.push(pose);
        }
        return Ok(poses);
    }
    super::trajectory::read_tum(path)
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn tum_layout_reports_missing_frames_and_refuses_disorder() {
        let dir = tempfile::tempdir().unwrap();
        std::fs::create_dir(dir.path().join("rgb")).unwrap();
        std::fs::write(dir.path().join("rgb/a.png"), b"x").unwrap();
        std::fs::write(
            dir.path().join("rgb.txt"),
            "# header\n1.0 rgb/a.png\n1.1 rgb/b.png\n",
        )
        .unwrap();
        let seq = open(dir.path(), None).unwrap();
        assert_eq!(seq.layout, "tum");
        assert_eq!(seq.frames.len(), 1);
        assert_eq!(seq.missing.len(), 1);
        assert_eq!(seq.calibration, None);
        // slam-synth's calib.toml beside rgb.txt is found.
        std::fs::write(dir.path().join("calib.toml"), "").unwrap();
        let seq = open(dir.path(), None).unwrap();
        assert_eq!(seq.calibration, Some(dir.path().join("calib.toml")));
        std::fs::write(dir.path().join("rgb.txt"), "1.0 rgb/a.png\n0.9 rgb/a.png\n").unwrap();
        let message = open(dir.path(), None).unwrap_err().to_string();
        assert!(
            message.contains("line 2") && message.contains("out of order"),
            "{message}"
        );
    }

    #[test]
    fn kitti_layout_reads_times_calibration_and_poses() {
        let dir = tempfile::tempdir().unwrap();
        std::fs::create_dir(dir.path().join("image_0")).unwrap();
        for name in ["000000.png", "000001.png", "000002.png"] {
            std::fs::write(dir.path().join("image_0").join(name), b"x").unwrap();
        }
        let message = open(dir.path(), None).unwrap_err().to_string();
        assert!(message.contains("calib.txt"), "{message}");
        std::fs::write(
            dir.path().join("calib.txt"),
            "P0: 700 0 600 0 0 700 180 0 0 0 1 0\n",
        )
        .unwrap();
        let seq = open(dir.path(), None).unwrap();
        assert_eq!(seq.layout, "kitti");
        assert!(
            (seq.frames[2].timestamp - 0.2).abs() < 1e-12,
            "10 frames/s by default"
        );
        assert!(seq.ground_truth.is_none());
        std::fs::write(dir.path().join("times.txt"), "0.0\n0.05\n").unwrap();
        let message = open(dir.path(), None).unwrap_err().to_string();
        assert!(
            message.contains("2 timestamps, but frame") && message.contains("number 2"),
            "{message}"
        );
        std::fs::write(dir.path().join("times.txt"), "0.0\n0.05\n0.11\n").unwrap();
        let seq = open(dir.path(), None).unwrap();
        assert_eq!(seq.frames[2].timestamp, 0.11);
        let row = "1 0 0 0 0 1 0 0 0 0 1 0.5";
        std::fs::write(dir.path().join("poses.txt"), format!("{row}\n{row}\n")).unwrap();
        let seq = open(dir.path(), None).unwrap();
        let times: Vec<f64> = seq.frames.iter().map(|f| f.timestamp).collect();
        let message = read_ground_truth(seq.ground_truth.as_ref().unwrap(), &times)
            .unwrap_err()
            .to_string();
        assert!(
            message.contains("poses.txt") && message.contains("2 pose rows for 3 frames"),
            "{message}"
        );
    }

    #[test]
    fn kitti_frames_take_the_row_of_their_file_number() {
        let dir = tempfile::tempdir().unwrap();
        let images = dir.path().join("image_0");
        std::fs::create_dir(&images).unwrap();
        // Frame 2 is missing and a directory takes the name of frame 3: frame 4 is still row 4.
        for name in ["000000.png", "000001.png", "000004.png"] {
            std::fs::write(images.join(name), b"x").unwrap();
        }
        std::fs::create_dir(images.join("000003.png")).unwrap();
        std::fs::write(
            dir.path().join("calib.txt"),
            "P0: 700 0 600 0 0 700 180 0 0 0 1 0
",
        )
        .unwrap();
        std::fs::write(
            dir.path().join("times.txt"),
            "0.0
0.1
0.2
0.3
0.4
0.5
",
        )
        .unwrap();
        let rows: String = (0..6)
            .map(|i| {
                format!(
                    "1 0 0 {i} 0 1 0 0 0 0 1 0
"
                )
            })
            .collect();
        std::fs::write(dir.path().join("poses.txt"), rows).unwrap();
        let seq = open(dir.path(), None).unwrap();
        let times: Vec<f64> = seq.frames.iter().map(|f| f.timestamp).collect();
        assert_eq!(times, [0.0, 0.1, 0.4]);
        let truth = read_ground_truth(
            seq.ground_truth.as_ref().unwrap(),
            &seq.ground_truth_times(),
        )
        .unwrap();
        let at = |t: f64| truth.iter().find(|p| p.timestamp == t).unwrap().position.x;
        assert_eq!(at(0.4), 4.0);
        // Without times.txt the frame rate numbers them the same way.
        std::fs::remove_file(dir.path().join("times.txt")).unwrap();
        let seq = open(dir.path(), None).unwrap();
        assert!((seq.frames[2].timestamp - 0.4).abs() < 1e-12);
        // Two files with one number are refused, naming both.
        std::fs::write(images.join("4.png"), b"x").unwrap();
        let message = open(dir.path(), None).unwrap_err().to_string();
        assert!(
            message.contains("frame number 4") && message.contains("000004.png"),
            "{message}"
        );
    }

    #[test]
    fn folder_layout_sorts_by_name() {
        let dir = tempfile::tempdir().unwrap();
        for name in ["b.png", "a.png", "notes.txt"] {
            std::fs::write(dir.path().join(name), b"x").unwrap();
        }
        let seq = open(dir.path(), Some(10.0)).unwrap();
        assert_eq!(seq.layout, "folder");
        assert_eq!(seq.frames.len(), 2);
        assert!(seq.frames[0].path.ends_with("a.png"));
        assert!((seq.frames[1].timestamp - 0.1).abs() < 1e-12);
        assert!(open(&dir.path().join("none"), Some(10.0)).is_err());
    }

    #[test]
    fn euroc_ground_truth_is_checked_like_every_trajectory() {
        let dir = tempfile::tempdir().unwrap();
        let csv = dir.path().join("data.csv");
        let good = "1000000000,1,2,3,1,0,0,0\n2000000000,1,2,3,0,0,0,2\n";
        std::fs::write(&csv, good).unwrap();
        let poses = read_ground_truth(&csv, &[]).unwrap();
        assert_eq!(poses.len(), 2);
        assert!((poses[1].orientation.norm() - 1.0).abs() < 1e-12);
        for (text, reason) in [
            ("1000000000,1,2,3,0,0,0,0\n", "line 1: zero quaternion"),
            (
                "1000000000,1,NaN,3,1,0,0,0\n",
                "line 1: non-finite value NaN",
            ),
            (
                "2000000000,1,2,3,1,0,0,0\n1000000000,1,2,3,1,0,0,0\n",
                "line 2: timestamp 1 is not after the previous one (2)",
            ),
        ] {
            std::fs::write(&csv, text).unwrap();
            let e = read_ground_truth(&csv, &[]).unwrap_err().to_string();
            assert!(e.contains("data.csv") && e.contains(reason), "{e}");
        }
    }
}
