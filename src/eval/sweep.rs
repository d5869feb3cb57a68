//! Rotation sweeps and homography sequences: every detector (steernav and the peers) runs on
//! both views, is cut to the same number of strongest keypoints, and is judged by the same
//! repeatability (eq 11) and recall (eq 12) code. One [`Row`] per detector, image, angle and ε.

use std::path::{Path, PathBuf};

use super::homography::{self, from_affine, Homography};
use super::matching::{judge_pair, PairMatching};
use super::overlap::{common_region, REGION_SIGMAS};
use super::peers::PeerRunner;
use super::recall::{recall, Descriptors, KeypointSet};
use super::repeatability::repeatability;
use crate::error::{Error, Result};
use crate::features::Detector;
use crate::image::Frame;

/// One line of the evaluation CSV.
#[derive(Clone, Debug, PartialEq)]
pub struct Row {
    /// "steernav" or a peer's name.
    pub detector: String,
    /// The source image (or sequence/imageN for homography sequences).
    pub image: String,
    /// Rotation in degrees (for sequences: the index N of imgN).
    pub angle: f64,
    /// Tolerance ε in pixels.
    pub eps: f64,
    /// Eq 11, in 0..1.
    pub repeatability: f64,
    /// Eq 12, in 0..1.
    pub recall: f64,
    /// Mean number of keypoints of the two views inside the common region.
    pub count: f64,
}

/// The CSV header (exactly).
pub const CSV_HEADER: &str = "detector,image,angle,eps,repeatability,recall,count";

/// Settings of an evaluation.
#[derive(Clone, Debug)]
pub struct EvalOptions {
    /// Tolerances ε (px); the summary uses 2.
    pub eps: Vec<f64>,
    /// Keypoints compared per view (the strongest).
    pub max_keypoints: usize,
    /// Points closer than this to an image border are left out of the common region.
    pub margin: f64,
    /// Points whose region (a disc of this many times their scale) reaches past either view's
    /// border are left out of the common region too
    /// ([`super::overlap::inside_both_views`]); 0 judges centres only.
    pub region_sigmas: f64,
    /// Lowe's ratio for the recall's nearest-neighbour matching.
    pub ratio: f64,
}

impl Default for EvalOptions {
    fn default() -> Self {
        Self {
            eps: vec![1.5, 2.0, 3.0],
            max_keypoints: 500,
            margin: 10.0,
            region_sigmas: REGION_SIGMAS,
            ratio: 0.8,
        }
    }
}

/// The keypoints of a steernav detection as an evaluation set.
pub fn steernav_set(detector: &Detector, frame: &Frame) -> Result<KeypointSet> {
    let d = detector.detect(frame)?;
    let values = d.keypoints.iter().map(|k| k.descriptor.to_vec()).collect();
    Ok(KeypointSet {
        points: d
            .keypoints
            .iter()
            .map(|k| (k.x as f64, k.y as f64))
            .collect(),
        descriptors: match detector.config().descriptor.frames() {
            1 => Descriptors::Float(values),
            frames => Descriptors::Framed(values, frames),
        },
        scales: d.keypoints.iter().map(|k| k.scale as f64).collect(),
    })
}

#[allow(clippy::too_many_arguments)]
fn judge(
    rows: &mut Vec<Row>,
    detector: &str,
    image: &str,
    angle: f64,
    a: &KeypointSet,
    sa: (u32, u32),
    b: &KeypointSet,
    sb: (u32, u32),
    h: &Homography,
    opts: &EvalOptions,
) {
    let (a, b) = common_region(
        &a.top(opts.max_keypoints),
        sa,
        &b.top(opts.max_keypoints),
        sb,
        h,
        opts.region_sigmas,
    );
    for &eps in &opts.eps {
        let r = repeatability(&a.points, sa, &b.points, sb, h, eps, opts.margin);
        let rc = recall(&a, sa, &b, sb, h, eps, opts.margin, opts.ratio);
        rows.push(Row {
            detector: detector.to_string(),
            image: image.to_string(),
            angle,
            eps,
            repeatability: r.ratio,
            recall: rc.recall,
            count: (r.count1 + r.count2) as f64 / 2.0,
        });
    }
}

/// Parses `start:stop:step` (degrees, stop exclusive) or a comma-separated list.
pub fn parse_angles(spec: &str) -> std::result::Result<Vec<f64>, String> {
    let bad = |why: &str| format!("--angles {spec}: {why}");
    let parts: Vec<&str> = spec.split(':').collect();
    let values: Vec<f64> = if parts.len() == 3 {
        let v: Vec<f64> = parts
            .iter()
            .map(|p| p.trim().parse::<f64>().map_err(|e| bad(&e.to_string())))
            .collect::<std::result::Result<_, _>>()?;
        if !v.iter().all(|x| x.is_finite()) || v[2] <= 0.0 || v[1] < v[0] {
            return Err(bad(
                "expected start:stop:step with step > 0 and stop ≥ start",
            ));
        }
        let n = ((v[1] - v[0]) / v[2]).ceil() as usize;
        if n > 10_000 {
            return Err(bad("more than 10000 angles"));
        }
        (0..n)
            .map(|i| v[0] + i as f64 * v[2])
            .filter(|a| *a < v[1])
            .collect()
    } else {
        spec.split(',')
            .map(|p| p.trim().parse::<f64>().map_err(|e| bad(&e.to_string())))
            .collect::<std::result::Result<_, _>>()?
    };
    if values.is_empty() || values.iter().any(|v| !v.is_finite()) {
        return Err(bad("no finite angle"));
    }
    // Beyond ten turns an angle only loses precision (1e308° has no meaningful sine).
    if let Some(v) = values.iter().find(|v| v.abs() > 3600.0) {
        return Err(bad(&format!("{v}° is outside ±3600°")));
    }
    Ok(values)
}

/// Canvas size holding a `w`×`h` image rotated by `degrees` without cropping.
pub fn expanded_canvas(w: u32, h: u32, degrees: f64) -> (u32, u32) {
    let a = degrees.to_radians();
    let (c, s) = (a.cos().abs(), a.sin().abs());
    let cw = (w as f64 * c + h as f64 * s - 1e-6).ceil().max(1.0) as u32;
    let ch = (w as f64 * s + h as f64 * c - 1e-6).ceil().max(1.0) as u32;
    (cw, ch)
}

/// Rotates each image about its centre onto an expanded canvas for every angle, runs every
/// detector on both views and judges them. `peers` is the runner and the peer names to run.
pub fn rotation_sweep(
    images: &[PathBuf],
    angles: &[f64],
    steernav: Option<&Detector>,
    peers: Option<(&PeerRunner, &[String])>,
    opts: &EvalOptions,
    progress: &(dyn Fn(u64) + Sync),
) -> Result<Vec<Row>> {
    let mut rows = Vec::new();
    let tmp = tempfile::tempdir().map_err(|source| Error::Io {
        path: std::env::temp_dir(),
        source,
    })?;
    for (n, path) in images.iter().enumerate() {
        let frame = Frame::load(path)?;
        let name = path.display().to_string();
        let size = (frame.width, frame.height);
        let mut views: Vec<(f64, Frame, Homography, PathBuf)> = Vec::new();
        for (k, &angle) in angles.iter().enumerate() {
            let (cw, ch) = expanded_canvas(frame.width, frame.height, angle);
            let (rotated, map) = crate::synth::rotate(&frame, angle.to_radians() as f32, cw, ch);
            let file = tmp.path().join(format!("{n}_{k}.png"));
            if peers.is_some() {
                super::generate::write_png(&file, &rotated)?;
            }
            views.push((angle, rotated, from_affine(&map), file));
        }
        if let Some(det) = steernav {
            let a = steernav_set(det, &frame)?;
            for (angle, rotated, h, _) in &views {
                let b = steernav_set(det, rotated)?;
                judge(
                    &mut rows,
                    "steernav",
                    &name,
                    *angle,
                    &a,
                    size,
                    &b,
                    (rotated.width, rotated.height),
                    h,
                    opts,
                );
                progress(1);
            }
        }
        if let Some((runner, names)) = peers {
            let original = tmp.path().join(format!("{n}_source.png"));
            super::generate::write_png(&original, &frame)?;
            let mut files = vec![original.clone()];
            files.extend(views.iter().map(|v| v.3.clone()));
            let found = runner.detect(names, &files)?;
            for peer in names {
                let Some(a) = found.get(&(original.display().to_string(), peer.clone())) else {
                    continue;
                };
                for (angle, rotated, h, file) in &views {
                    if let Some(b) = found.get(&(file.display().to_string(), peer.clone())) {
                        judge(
                            &mut rows,
                            peer,
                            &name,
                            *angle,
                            a,
                            size,
                            b,
                            (rotated.width, rotated.height),
                            h,
                            opts,
                        );
                    }
                }
            }
            progress(angles.len() as u64);
        }
    }
    Ok(rows)
}

/// One view of a sequence beside img1: its index N, its file and the map H1toN.
pub type SequenceView = (usize, PathBuf, Homography);

/// The images of an Oxford-layout sequence: img1..img6 (.ppm, .pgm or .png) and H1to2p..H1to6p.
pub fn sequence_files(dir: &Path) -> Result<(PathBuf, Vec<SequenceView>)> {
    let find = |k: usize| {
        ["ppm", "pgm", "png", "jpg"]
            .iter()
            .map(|ext| dir.join(format!("img{k}.{ext}")))
            .find(|p| p.exists())
    };
    let first = find(1).ok_or_else(|| Error::Io {
        path: dir.join("img1.ppm"),
        source: std::io::Error::new(
            std::io::ErrorKind::NotFound,
            "no img1.{ppm,pgm,png,jpg}: not an Oxford-layout sequence",
        ),
    })?;
    let mut others = Vec::new();
    for k in 2..=6 {
        if let (Some(img), true) = (find(k), dir.join(format!("H1to{k}p")).exists()) {
            others.push((k, img, homography::load(&dir.join(format!("H1to{k}p")))?));
        }
    }
    if others.is_empty() {
        return Err(Error::Io {
            path: dir.join("H1to2p"),
            source: std::io::Error::new(std::io::ErrorKind::NotFound, "no imgN with its H1toNp"),
        });
    }
    Ok((first, others))
}

/// Judges every detector on an Oxford-layout sequence (img1 against each imgN): the
/// repeatability and recall rows, and the matching accuracy of each pair.
pub fn homography_sequence(
    dir: &Path,
    steernav: Option<&Detector>,
    peers: Option<(&PeerRunner, &[String])>,
    opts: &EvalOptions,
) -> Result<(Vec<Row>, Vec<PairMatching>)> {
    let (first, others) = sequence_files(dir)?;
    let seq = dir.file_name().map_or_else(
        || dir.display().to_string(),
        |n| n.to_string_lossy().into_owned(),
    );
    let f1 = Frame::load(&first)?;
    let s1 = (f1.width, f1.height);
    let frames: Vec<Frame> = others
        .iter()
        .map(|(_, p, _)| Frame::load(p))
        .collect::<Result<_>>()?;
    let mut rows = Vec::new();
    let mut matching = Vec::new();
    let mut judge_matching =
        |name: &str, k: usize, a: &KeypointSet, b: &KeypointSet, s2: (u32, u32), h| {
            let (a, b) = (a.top(opts.max_keypoints), b.top(opts.max_keypoints));
            let image = format!("{seq}/img{k}");
            let settings = (opts.ratio, opts.margin, opts.region_sigmas);
            matching.push(judge_pair(name, &image, &a, s1, &b, s2, h, settings));
        };
    if let Some(det) = steernav {
        let a = steernav_set(det, &f1)?;
        for ((k, _, h), f) in others.iter().zip(&frames) {
            let b = steernav_set(det, f)?;
            judge_matching("steernav", *k, &a, &b, (f.width, f.height), h);
            judge(
                &mut rows,
                "steernav",
                &format!("{seq}/img{k}"),
                *k as f64,
                &a,
                s1,
                &b,
                (f.width, f.height),
                h,
                opts,
            );
        }
    }
    if let Some((runner, names)) = peers {
        let mut files = vec![first.clone()];
        files.extend(others.iter().map(|o| o.1.clone()));
        let found = runner.detect(names, &files)?;
        for peer in names {
            let Some(a) = found.get(&(first.display().to_string(), peer.clone())) else {
                continue;
            };
            for ((k, p, h), f) in others.iter().zip(&frames) {
                if let Some(b) = found.get(&(p.display().to_string(), peer.clone())) {
                    judge_matching(peer, *k, a, b, (f.width, f.height), h);
                    judge(
                        &mut rows,
                        peer,
                        &format!("{seq}/img{k}"),
                        *k as f64,
                        a,
                        s1,
                        b,
                        (f.width, f.height),
                        h,
                        opts,
                    );
                }
            }
        }
    }
    Ok((rows, matching))
}

/// The rows as CSV text with [`CSV_HEADER`].
pub fn to_csv(rows: &[Row]) -> String {
    let header = CSV_HEADER.split(',').map(String::from).collect::<Vec<_>>();
    let rows = rows.iter().map(|r| {
        vec![
            r.detector.clone(),
            r.image.clone(),
            r.angle.to_string(),
            r.eps.to_string(),
            format!("{:.4}", r.repeatability),
            format!("{:.4}", r.recall),
            format!("{:.1}", r.count),
        ]
    });
    crate::output::csv_text(std::iter::once(header).chain(rows))
}

/// One detector's summary at one ε over the non-identity views.
#[derive(Clone, Debug, PartialEq)]
pub struct Summary {
    /// Detector name.
    pub detector: String,
    /// Mean repeatability over all images and non-zero angles (or all sequence images).
    pub mean_repeatability: f64,
    /// Minimum over angles of the repeatability averaged over images.
    pub min_repeatability: f64,
    /// The angle (or image index) of that minimum.
    pub worst_angle: f64,
    /// Mean recall.
    pub mean_recall: f64,
    /// Mean keypoint count beside the figures.
    pub mean_count: f64,
}

/// Detector names in first-seen order.
pub fn detectors(rows: &[Row]) -> Vec<String> {
    let mut names: Vec<String> = Vec::new();
    for r in rows {
        if !names.contains(&r.detector) {
            names.push(r.detector.clone());
        }
    }
    names
}

/// For one detector at tolerance `eps`: `metric` averaged over images at each angle (or
/// sequence image), in increasing angle order; angle 0 is left out unless `with_zero`.
pub fn curve(
    rows: &[Row],
    detector: &str,
    eps: f64,
    metric: fn(&Row) -> f64,
    with_zero: bool,
) -> Vec<(f64, f64)> {
    let mine: Vec<&Row> = rows
        .iter()
        .filter(|r| {
            r.detector == detector
                && (r.eps - eps).abs() < 1e-9
                && (with_zero || r.angle.rem_euclid(360.0) != 0.0)
        })
        .collect();
    let mut xs: Vec<f64> = mine.iter().map(|r| r.angle).collect();
    xs.sort_by(f64::total_cmp);
    xs.dedup();
    xs.into_iter()
        .map(|x| {
            let v: Vec<f64> = mine
                .iter()
                .filter(|r| r.angle == x)
                .map(|r| metric(r))
                .collect();
            (x, v.iter().sum::<f64>() / v.len() as f64)
        })
        .collect()
}

/// Summaries at `eps`, leaving out angle 0 (the identical view), in first-seen detector order.
pub fn summarize(rows: &[Row], eps: f64) -> Vec<Summary> {
    detectors(rows)
        .into_iter()
        .map(|name| {
            let mine: Vec<&Row> = rows
                .iter()
                .filter(|r| {
                    r.detector == name
                        && (r.eps - eps).abs() < 1e-9
                        && r.angle.rem_euclid(360.0) != 0.0
                })
                .collect();
            let n = mine.len().max(1) as f64;
            let (worst_angle, worst) = curve(rows, &name, eps, |r| r.repeatability, false)
                .into_iter()
                .fold((f64::NAN, f64::INFINITY), |best, (a, m)| {
                    if m < best.1 {
                        (a, m)
                    } else {
                        best
                    }
                });
            Summary {
                detector: name,
                mean_repeatability: mine.iter().map(|r| r.repeatability).sum::<f64>() / n,
                min_repeatability: if worst.is_finite() { worst } else { 0.0 },
                worst_angle,
                mean_recall: mine.iter().map(|r| r.recall).sum::<f64>() / n,
                mean_count: mine.iter().map(|r| r.count).sum::<f64>() / n,
            }
        })
        .collect()
}

/// The summary as an aligned text table.
pub fn summary_table(summaries: &[Summary], eps: f64, x_name: &str) -> String {
    let mut s = format!(
        "{:<10} {:>10} {:>10} {:>8} {:>10} {:>10}   (ε = {eps} px, angle 0 left out)\n",
        "detector", "mean rep.", "min rep.", x_name, "recall", "count"
    );
    for m in summaries {
        s.push_str(&format!(
            "{:<10} {:>10.3} {:>10.3} {:>8} {:>10.3} {:>10.1}\n",
            m.detector,
            m.mean_repeatability,
            m.min_repeatability,
            m.worst_angle,
            m.mean_recall,
            m.mean_count
        ));
    }
    s
}
