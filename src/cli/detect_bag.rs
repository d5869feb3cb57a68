//! `steernav detect BAG`: keypoints of every image message of a ROS 2 bag's camera topic, one
//! record per message named by topic and header stamp, and optionally the keypoints as
//! Foxglove image annotations in an MCAP file.

use std::path::{Path, PathBuf};

use std::process::ExitCode;

use anyhow::bail;
use steernav::bag::frames as bag_frames;
use steernav::bag::messages::Time;
use steernav::bag::write::{
    self, BagWriter, CircleAnnotation, Color, ImageAnnotations, PointsAnnotation,
};
use steernav::bag::Bag;
use steernav::output::{write_atomic, ImageKeypoints};
use steernav::{Detector, Keypoint};

use crate::batch::{previous_figures, Entry, Outcome};
use crate::detect::{summary_line, DetectCmd};
use crate::StdoutFailed;

const KEYPOINTS_TOPIC: &str = "/steernav/keypoints";

/// What names one image message: where it came from and its stamp.
struct Tag {
    /// `bag:/topic@sec.nanosec`, the record's `image` field.
    label: PathBuf,
    /// `topic_sec.nanosec`, the output file's stem.
    name: String,
    stamp: f64,
}

fn tag(bag: &Path, topic: &str, stamp: f64) -> Tag {
    let t = Time::from_seconds(stamp);
    let stamp_text = format!("{}.{:09}", t.sec, t.nanosec);
    let topic_name: String = topic
        .trim_start_matches('/')
        .chars()
        .map(|c| if c.is_ascii_alphanumeric() { c } else { '_' })
        .collect();
    Tag {
        label: PathBuf::from(format!("{}:{topic}@{stamp_text}", bag.display())),
        name: format!("{topic_name}_{stamp_text}"),
        stamp,
    }
}

/// The keypoints of one image as annotations: a point each, and a circle of radius 3σ_D.
pub(crate) fn annotations(stamp: f64, keypoints: &[Keypoint]) -> ImageAnnotations {
    let timestamp = Time::from_seconds(stamp);
    let green = Color {
        r: 0.1,
        g: 0.9,
        b: 0.2,
        a: 1.0,
    };
    let clear = Color {
        r: 0.0,
        g: 0.0,
        b: 0.0,
        a: 0.0,
    };
    ImageAnnotations {
        circles: keypoints
            .iter()
            .map(|k| CircleAnnotation {
                timestamp,
                position: [k.x as f64, k.y as f64],
                diameter: 6.0 * k.scale as f64,
                thickness: 1.0,
                fill_color: clear,
                outline_color: green,
            })
            .collect(),
        points: vec![PointsAnnotation {
            timestamp,
            kind: 1,
            points: keypoints.iter().map(|k| [k.x as f64, k.y as f64]).collect(),
            outline_color: green,
            outline_colors: Vec::new(),
            fill_color: green,
            thickness: 3.0,
        }],
        texts: Vec::new(),
    }
}

/// One detection run over a bag's image topic.
pub(crate) struct BagRun<'a> {
    /// The bag (folder or .mcap).
    pub path: &'a Path,
    /// `--image-topic`.
    pub topic: Option<&'a str>,
    /// Where the records go (`None`: stdout, JSON lines).
    pub out: Option<&'a Path>,
    /// CSV records instead of JSON.
    pub csv: bool,
    /// `--mcap`: the annotations file.
    pub mcap: Option<&'a Path>,
    /// `--max-pixels`.
    pub max_pixels: u64,
    /// Leave out images whose record exists (batch re-runs).
    pub skip_done: bool,
}

/// The outcome of every image message, and the bag's own fault if it ended the stream (the
/// images before it are processed and written).
pub(crate) type BagOutcome = (Vec<Entry>, Option<steernav::Error>);

pub(crate) fn detect_bag(detector: &Detector, run: &BagRun) -> anyhow::Result<BagOutcome> {
    let bag = Bag::open(run.path)?;
    let topic = bag_frames::image_topic(&bag, run.topic)?;
    let mut mcap = match run.mcap {
        Some(file) => {
            let mut w = BagWriter::create(file)?;
            w.add_topic(
                KEYPOINTS_TOPIC,
                "foxglove_msgs/msg/ImageAnnotations",
                &write::image_annotations_schema(),
            )?;
            Some(w)
        }
        None => None,
    };
    let ext = if run.csv { "csv" } else { "json" };
    let output = |tag: &Tag| run.out.map(|dir| dir.join(format!("{}.{ext}", tag.name)));
    let names = [topic.name.clone()];
    let mut broken = None;
    let mut entries = Vec::new();
    let items = bag.messages(&names).map_while(|m| match m {
        Ok(m) => {
            let decoded = bag_frames::decode_frame(&bag.path, &m, run.max_pixels);
            let stamp = decoded.as_ref().map_or(f64::NAN, |f| f.timestamp);
            Some((tag(&bag.path, &topic.name, stamp), decoded.map(|f| f.frame)))
        }
        Err(e) => {
            broken = Some(e);
            None
        }
    });
    // Images already done (batch re-runs) are not detected again.
    let items = items.filter_map(|(tag, frame)| {
        let done = output(&tag).filter(|o| run.skip_done && frame.is_ok() && o.exists());
        match done {
            Some(o) => {
                entries.push(Entry {
                    image: tag.label,
                    outcome: Outcome::Skipped {
                        previous: previous_figures(&o),
                    },
                    output: o,
                });
                None
            }
            None => Some((tag, frame)),
        }
    });
    let mut stdout_failed = None;
    let mut fatal: Option<anyhow::Error> = None;
    let mut outcomes = Vec::new();
    detector.detect_stream(items, |tag, result| {
        if stdout_failed.is_some() || fatal.is_some() {
            return;
        }
        let target = output(&tag).unwrap_or_default();
        let entry = |outcome| Entry {
            image: tag.label.clone(),
            output: target.clone(),
            outcome,
        };
        let (frame, d) = match result {
            Ok(r) => r,
            Err(e) => {
                eprintln!("error: {e}; image skipped");
                outcomes.push(entry(Outcome::Failed(e.to_string())));
                return;
            }
        };
        eprintln!("{}", summary_line(&tag.label, &d, detector));
        let t = &d.timings;
        let ms = t.harris_ms + t.merge_ms + t.descriptor_ms;
        let (candidates, backend) = (d.candidates, d.backend);
        let record = ImageKeypoints::new(&tag.label, &frame, d);
        let written = || -> anyhow::Result<()> {
            let text = if run.csv {
                record.to_csv()
            } else {
                record.to_json()
            };
            match run.out {
                Some(_) => write_atomic(&target, text.as_bytes())?,
                None => println!("{}", text.trim_end()),
            }
            Ok(())
        };
        if let Err(e) = written() {
            if e.is::<StdoutFailed>() {
                stdout_failed = Some(e);
            } else {
                eprintln!("error: {}", crate::error_chain(&e));
                outcomes.push(entry(Outcome::Failed(crate::error_chain(&e))));
            }
            return;
        }
        if let Some(w) = &mut mcap {
            let stamped = annotations(tag.stamp, &record.keypoints);
            if let Err(e) = w
                .write(KEYPOINTS_TOPIC, tag.stamp, &stamped)
                .and_then(|_| w.flush())
            {
                fatal = Some(e.into());
                return;
            }
        }
        outcomes.push(entry(Outcome::Done {
            width: frame.width,
            height: frame.height,
            keypoints: record.keypoints.len(),
            candidates,
            backend,
            ms,
            damaged: None,
        }));
    });
    if let Some(e) = stdout_failed.or(fatal) {
        return Err(e);
    }
    if let Some(w) = mcap {
        w.finish()?;
    }
    entries.extend(outcomes);
    Ok((entries, broken))
}

pub fn run(cmd: &DetectCmd, path: &Path) -> anyhow::Result<ExitCode> {
    if cmd.csv && cmd.out.is_none() {
        bail!("a bag with --csv needs --out DIR (one CSV per image message)");
    }
    if cmd.draw {
        bail!("--draw is for image files; open a bag's --mcap annotations in Foxglove instead");
    }
    let detector = cmd.detector.detector()?;
    let (entries, broken) = detect_bag(
        &detector,
        &BagRun {
            path,
            topic: cmd.image_topic.as_deref(),
            out: cmd.out.as_deref(),
            csv: cmd.csv,
            mcap: cmd.mcap.as_deref(),
            max_pixels: cmd.detector.max_pixels,
            skip_done: false,
        },
    )?;
    finish(path, &entries, broken)
}

/// Reports the counts, then the bag's fault if it had one; the exit code counts failures.
pub(crate) fn finish(
    path: &Path,
    entries: &[Entry],
    broken: Option<steernav::Error>,
) -> anyhow::Result<ExitCode> {
    let count = |f: fn(&Outcome) -> bool| entries.iter().filter(|e| f(&e.outcome)).count();
    let failed = count(|o| matches!(o, Outcome::Failed(_)));
    let skipped = count(|o| matches!(o, Outcome::Skipped { .. }));
    let done = entries.len() - failed;
    eprintln!(
        "{}: {} images detected, {skipped} skipped (already done; --force redoes them), {failed} failed",
        path.display(),
        done - skipped
    );
    if let Some(e) = broken {
        return Err(anyhow::Error::new(e).context(format!(
            "{}: stopped after {done} images; their records are written",
            path.display()
        )));
    }
    Ok(if failed > 0 {
        ExitCode::FAILURE
    } else {
        ExitCode::SUCCESS
    })
}
