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
use steernav::Keypoint;

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

pub fn run(cmd: &DetectCmd, path: &Path) -> anyhow::Result<ExitCode> {
    if cmd.csv && cmd.out.is_none() {
        bail!("a bag with --csv needs --out DIR (one CSV per image message)");
    }
    if cmd.draw {
        bail!("--draw is for image files; open a bag's --mcap annotations in Foxglove instead");
    }
    let bag = Bag::open(path)?;
    let topic = bag_frames::image_topic(&bag, cmd.image_topic.as_deref())?;
    let detector = cmd.detector.detector()?;
    let mut mcap = match &cmd.mcap {
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
    let max_pixels = cmd.detector.max_pixels;
    let names = [topic.name.clone()];
    // A broken container ends the stream; what was read before is processed and written.
    let mut broken = None;
    let items = bag.messages(&names).map_while(|m| match m {
        Ok(m) => {
            let decoded = bag_frames::decode_frame(&bag.path, &m, max_pixels);
            let stamp = decoded.as_ref().map_or(f64::NAN, |f| f.timestamp);
            let label = m.describe(&bag.path);
            Some((
                (tag(&bag.path, &topic.name, stamp), label),
                decoded.map(|f| f.frame),
            ))
        }
        Err(e) => {
            broken = Some(e);
            None
        }
    });
    let (mut failed, mut done) = (0usize, 0usize);
    let mut stdout_failed = None;
    let mut fatal: Option<anyhow::Error> = None;
    detector.detect_stream(items, |(tag, label), result| {
        if stdout_failed.is_some() || fatal.is_some() {
            return;
        }
        let (frame, d) = match result {
            Ok(r) => r,
            Err(e) => {
                eprintln!("error: {label}: {e}; image skipped");
                failed += 1;
                return;
            }
        };
        eprintln!("{}", summary_line(&tag.label, &d, &detector));
        let record = ImageKeypoints::new(&tag.label, &frame, d);
        let write_out = || -> anyhow::Result<()> {
            let (text, ext) = if cmd.csv {
                (record.to_csv(), "csv")
            } else {
                (record.to_json(), "json")
            };
            match &cmd.out {
                Some(dir) => {
                    write_atomic(&dir.join(format!("{}.{ext}", tag.name)), text.as_bytes())?
                }
                None => println!("{}", text.trim_end()),
            }
            Ok(())
        };
        if let Err(e) = write_out() {
            if e.is::<StdoutFailed>() {
                stdout_failed = Some(e);
            } else {
                eprintln!("error: {}", crate::error_chain(&e));
                failed += 1;
            }
            return;
        }
        if let Some(w) = &mut mcap {
            let written = w
                .write(
                    KEYPOINTS_TOPIC,
                    tag.stamp,
                    &annotations(tag.stamp, &record.keypoints),
                )
                .and_then(|_| w.flush());
            if let Err(e) = written {
                fatal = Some(e.into());
                return;
            }
        }
        done += 1;
    });
    if let Some(e) = stdout_failed.or(fatal) {
        return Err(e);
    }
    if let Some(w) = mcap {
        w.finish()?;
    }
    eprintln!(
        "{}: {done} images of {} detected, {failed} failed",
        bag.path.display(),
        topic.name
    );
    if let Some(e) = broken {
        return Err(anyhow::Error::new(e).context(format!(
            "{}: stopped after {done} images; their records are written",
            bag.path.display()
        )));
    }
    Ok(if failed > 0 {
        ExitCode::FAILURE
    } else {
        ExitCode::SUCCESS
    })
}
