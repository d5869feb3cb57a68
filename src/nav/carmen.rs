//! CARMEN log reading: the `FLASER` lines of a (possibly gzipped) log, with the corrected pose
//! of each scan. `FLASER n r1 … rn x y θ odom_x odom_y odom_θ timestamp host logger_timestamp`;
//! ranges in metres over a 180° field of view, beam i at bearing −π/2 + i·π/(n−1).

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

/// Reads every FLASER scan of a log file (gzip detected by its magic bytes).
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

/// Parses the FLASER lines of a log; other lines are skipped, malformed FLASER lines are errors
/// naming the line.
pub fn parse(path: &Path, reader: impl BufRead) -> Result<Vec<Scan>> {
    let mut scans = Vec::new();
    for (no, line) in reader.lines().enumerate() {
        let line = line.map_err(|source| Error::Io {
            path: path.to_path_buf(),
            source,
        })?;
        let mut it = line.split_whitespace();
        if it.next() != Some("FLASER") {
            continue;
        }
        let bad = |why: String| Error::Parse {
            path: path.to_path_buf(),
            reason: format!("line {}: {why}", no + 1),
        };
        let fields: Vec<&str> = it.collect();
        let n: usize = fields
            .first()
            .and_then(|v| v.parse().ok())
            .ok_or_else(|| bad("missing beam count".into()))?;
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
        let num = |s: &str| {
            s.parse::<f64>()
                .map_err(|_| bad(format!("'{s}' is not a number")))
        };
        let ranges = fields[1..=n]
            .iter()
            .map(|s| num(s).map(|v| v as f32))
            .collect::<Result<Vec<_>>>()?;
        let (x, y, theta) = (
            num(fields[n + 1])?,
            num(fields[n + 2])?,
            num(fields[n + 3])?,
        );
        let time = num(fields[n + 7])?;
        if ![x, y, theta, time].iter().all(|v| v.is_finite()) {
            return Err(bad("non-finite pose or time".into()));
        }
        if let Some(i) = ranges.iter().position(|r| r.is_nan()) {
            return Err(bad(format!("range {} of {n} is NaN", i + 1)));
        }
        let bearings = (0..n)
            .map(|i| {
                (-std::f64::consts::FRAC_PI_2 + i as f64 * std::f64::consts::PI / (n - 1) as f64)
                    as f32
            })
            .collect();
        scans.push(Scan {
            ranges,
            bearings,
            angle_increment: std::f32::consts::PI / (n - 1) as f32,
            x,
            y,
            theta,
            time,
        });
    }
    Ok(scans)
}
