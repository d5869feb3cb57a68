//! CARMEN log reading: the laser lines of a (possibly gzipped) log, with the corrected pose of
//! each scan.
//!
//! - `FLASER n r1 … rn x y θ odom_x odom_y odom_θ timestamp host logger_timestamp`: ranges in
//!   metres over a 180° field of view, beam i at bearing −π/2 + i·π/(n−1).
//! - `ROBOTLASER1 type start_angle fov resolution max_range accuracy remission_mode n r1 … rn
//!   m e1 … em laser_x laser_y laser_θ robot_x robot_y robot_θ tv rv forward_safety
//!   side_safety turn_axis timestamp host logger_timestamp`: beam i at start_angle +
//!   i·resolution, so scanners of 270° or 360° keep their geometry; the pose is the laser's.
//!
//! A log with ROBOTLASER1 lines is read from those only (loggers write FLASER copies of the
//! same scans beside them). A reading that is NaN, infinite, zero or negative is no reading at
//! all (scanners report a missing return so): the beam is dropped from its scan, which keeps
//! its `angle_increment`, so the other beams' weight does not change.

use std::io::{BufRead, BufReader, Read};
use std::path::Path;

use crate::error::{Error, Result};

/// One laser scan with the robot's pose.
#[derive(Clone, Debug, PartialEq)]
pub struct Scan {
    /// Ranges (m), right to left.
    pub ranges: Vec<f32>,
    /// Bearing of each beam in the robot frame (rad, 0 ahead, positive to the left).
    pub bearings: Vec<f32>,
    /// Angle between neighbouring beams of the scanner (rad); beams discarded from a scan
    /// leave it unchanged.
    pub angle_increment: f32,
    /// Corrected pose: x (m).
    pub x: f64,
    /// Corrected pose: y (m).
    pub y: f64,
    /// Corrected pose: heading (rad).
    pub theta: f64,
    /// Timestamp (s).
    pub time: f64,
}

/// Reads the front-laser scans of a log file (see [`parse`]; gzip detected by its magic bytes).
pub fn read_log(path: &Path) -> Result<Vec<Scan>> {
    let io = |source| Error::Io {
        path: path.to_path_buf(),
        source,
    };
    let mut file = crate::error::open_input(path)?;
    let mut magic = [0u8; 2];
    let gz = file.read(&mut magic).map_err(io)? == 2 && magic == [0x1f, 0x8b];
    let file = crate::error::open_input(path)?;
    let reader: Box<dyn BufRead> = if gz {
        Box::new(BufReader::new(flate2::read::MultiGzDecoder::new(file)))
    } else {
        Box::new(BufReader::new(file))
    };
    parse(path, reader)
}

/// Longest line read from a log: a ROBOTLASER1 line of a 100,000-beam scanner holds well
/// under 2 MB; past this the input is not a log (a stream without line breaks).
const MAX_LINE_BYTES: usize = 16 << 20;

/// Parses the laser lines of a log (see the module docs); other lines are skipped, whatever
/// bytes they hold (a comment in Latin-1), malformed laser lines are errors naming the line.
/// A log without FLASER or ROBOTLASER1 lines is an error that says what it holds instead.
pub fn parse(path: &Path, mut reader: impl BufRead) -> Result<Vec<Scan>> {
    let (mut flaser, mut robotlaser) = (Vec::new(), Vec::new());
    let mut rear = 0usize;
    let mut bytes = Vec::new();
    for no in 0.. {
        bytes.clear();
        let read = (&mut reader)
            .take(MAX_LINE_BYTES as u64 + 1)
            .read_until(b'\n', &mut bytes)
            .map_err(|source| Error::Io {
                path: path.to_path_buf(),
                source,
            })?;
        if read == 0 {
            break;
        }
        if bytes.len() > MAX_LINE_BYTES {
            return Err(Error::Parse {
                path: path.to_path_buf(),
                reason: format!("line {}: longer than {MAX_LINE_BYTES} bytes", no + 1),
            });
        }
        // Laser lines are ASCII; other lines are skipped, so their bytes need not be UTF-8.
        let line = String::from_utf8_lossy(&bytes);
        let mut it = line.split_whitespace();
        let kind = it.next();
        if matches!(kind, Some("RLASER" | "RAWLASER2" | "RAWLASER4")) {
            rear += 1;
        }
        if !matches!(kind, Some("FLASER" | "ROBOTLASER1")) {
            continue;
        }
        let bad = |why: String| Error::Parse {
            path: path.to_path_buf(),
            reason: format!("line {}: {why}", no + 1),
        };
        let fields: Vec<&str> = it.collect();
        if kind == Some("FLASER") {
            flaser.push(flaser_scan(&fields, &bad)?);
        } else {
            robotlaser.push(robotlaser_scan(&fields, &bad)?);
        }
    }
    if flaser.is_empty() && robotlaser.is_empty() {
        let holds = if rear > 0 {
            format!(
                "{rear} rear-laser or raw-laser lines (RLASER, RAWLASER2, RAWLASER4), which are not read"
            )
        } else {
            "none".to_string()
        };
        return Err(Error::Parse {
            path: path.to_path_buf(),
            reason: format!(
                "no front-laser scan: the replay reads FLASER and ROBOTLASER1 lines, and this log has {holds}"
            ),
        });
    }
    Ok(if robotlaser.is_empty() {
        flaser
    } else {
        robotlaser
    })
}

fn number(s: &str, bad: &dyn Fn(String) -> Error) -> Result<f64> {
    s.parse::<f64>()
        .map_err(|_| bad(format!("'{s}' is not a number")))
}

/// A count field, bounded by the fields the line really has.
fn count(s: Option<&&str>, what: &str, bad: &dyn Fn(String) -> Error) -> Result<usize> {
    s.and_then(|v| v.parse().ok())
        .ok_or_else(|| bad(format!("missing {what}")))
}

/// The scan of `ranges` at `bearings`, readings that are no reading dropped, the pose checked.
fn scan(
    ranges: Vec<f32>,
    bearings: Vec<f32>,
    angle_increment: f32,
    (x, y, theta): (f64, f64, f64),
    time: f64,
    bad: &dyn Fn(String) -> Error,
) -> Result<Scan> {
    if ![x, y, theta, time].iter().all(|v| v.is_finite()) {
        return Err(bad("non-finite pose or time".into()));
    }
    let (ranges, bearings) = ranges
        .into_iter()
        .zip(bearings)
        .filter(|(r, _)| r.is_finite() && *r > 0.0)
        .unzip();
    Ok(Scan {
        ranges,
        bearings,
        angle_increment,
        x,
        y,
        theta,
        time,
    })
}

fn flaser_scan(fields: &[&str], bad: &dyn Fn(String) -> Error) -> Result<Scan> {
    let n = count(fields.first(), "beam count", bad)?;
    // `n r1 … rn x y θ odom_x odom_y odom_θ ipc_time host logger_time`: exactly n + 10
    // fields, so a count one off is caught instead of shifting every field after it.
    if n < 2 || n.checked_add(10) != Some(fields.len()) {
        return Err(bad(format!(
            "a FLASER line with {} beams has {} fields after the keyword, found {}",
            n,
            n.saturating_add(10),
            fields.len()
        )));
    }
    let ranges = fields[1..=n]
        .iter()
        .map(|s| number(s, bad).map(|v| v as f32))
        .collect::<Result<Vec<_>>>()?;
    let pose = (
        number(fields[n + 1], bad)?,
        number(fields[n + 2], bad)?,
        number(fields[n + 3], bad)?,
    );
    let step = std::f64::consts::PI / (n - 1) as f64;
    let bearings = (0..n)
        .map(|i| (-std::f64::consts::FRAC_PI_2 + i as f64 * step) as f32)
        .collect();
    scan(
        ranges,
        bearings,
        step as f32,
        pose,
        number(fields[n + 7], bad)?,
        bad,
    )
}

fn robotlaser_scan(fields: &[&str], bad: &dyn Fn(String) -> Error) -> Result<Scan> {
    // type start fov resolution max_range accuracy remission_mode n …
    let n = count(fields.get(7), "beam count", bad)?;
    let m = count(fields.get(8 + n), "remission count", bad)?;
    // … n ranges, m, m remissions, 6 poses, tv rv fsd ssd turn_axis, time host logger_time.
    let expected = n
        .checked_add(m)
        .and_then(|v| v.checked_add(8 + 1 + 6 + 5 + 3));
    if n < 2 || expected != Some(fields.len()) {
        return Err(bad(format!(
            "a ROBOTLASER1 line with {n} beams and {m} remissions has {} fields after the keyword, found {}",
            expected.map_or_else(|| "too many".into(), |e| e.to_string()),
            fields.len()
        )));
    }
    let start = number(fields[1], bad)?;
    let fov = number(fields[2], bad)?;
    let resolution = number(fields[3], bad)?;
    if !(start.is_finite()
        && resolution.is_finite()
        && resolution > 0.0
        && fov.is_finite()
        && fov > 0.0
        && fov <= std::f64::consts::TAU + 1e-3)
    {
        return Err(bad(format!(
            "start angle {start}, field of view {fov} and resolution {resolution} (rad) must be finite, with 0 < field of view ≤ 2π and resolution > 0"
        )));
    }
    let ranges = fields[8..8 + n]
        .iter()
        .map(|s| number(s, bad).map(|v| v as f32))
        .collect::<Result<Vec<_>>>()?;
    let poses = 9 + n + m;
    let pose = (
        number(fields[poses], bad)?,
        number(fields[poses + 1], bad)?,
        number(fields[poses + 2], bad)?,
    );
    let bearings = (0..n)
        .map(|i| {
            let b = start + i as f64 * resolution;
            b.sin().atan2(b.cos()) as f32
        })
        .collect();
    let time = number(fields[poses + 11], bad)?;
    scan(ranges, bearings, resolution as f32, pose, time, bad)
}
