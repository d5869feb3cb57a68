//! Camera topics of a bag as frames: `sensor_msgs/msg/Image` (mono8, mono16, rgb8, bgr8, rgba8,
//! bgra8) and `sensor_msgs/msg/CompressedImage` (JPEG, PNG), stamped with their header stamp,
//! and the camera from `sensor_msgs/msg/CameraInfo` (K and plumb_bob D).

use std::path::{Path, PathBuf};

use super::messages::{CameraInfo, CompressedImage, Image};
use super::{Bag, BagMessage, Topic};
use crate::error::{Error, Result};
use crate::image::Frame;
use crate::slam::camera::PinholeCamera;

/// The raw image type.
pub const IMAGE: &str = "sensor_msgs/msg/Image";
/// The compressed image type.
pub const COMPRESSED_IMAGE: &str = "sensor_msgs/msg/CompressedImage";
/// The calibration type.
pub const CAMERA_INFO: &str = "sensor_msgs/msg/CameraInfo";

/// One image message, decoded.
#[derive(Clone, Debug)]
pub struct BagFrame {
    /// Header stamp, seconds.
    pub timestamp: f64,
    /// The image.
    pub frame: Frame,
}

/// The image topic of a bag (`chosen`, or the only raw or compressed image topic).
pub fn image_topic(bag: &Bag, chosen: Option<&str>) -> Result<Topic> {
    bag.choose_topic(&[IMAGE, COMPRESSED_IMAGE], chosen, "--image-topic")
}

/// The camera of the first `CameraInfo` message on `chosen` (or on the only such topic).
pub fn camera(bag: &Bag, chosen: Option<&str>) -> Result<PinholeCamera> {
    let topic = bag.choose_topic(&[CAMERA_INFO], chosen, "--camera-info-topic")?;
    let message = bag
        .messages(std::slice::from_ref(&topic.name))
        .next()
        .ok_or_else(|| {
            Error::input(
                bag.path.display().to_string(),
                format!("topic {} has no message", topic.name),
            )
        })??;
    let info: CameraInfo = message.decode(&bag.path)?;
    camera_from_info(&info, &message.describe(&bag.path))
}

/// A [`PinholeCamera`] from K and the plumb_bob coefficients of a `CameraInfo`.
pub fn camera_from_info(info: &CameraInfo, what: &str) -> Result<PinholeCamera> {
    let k = &info.k.0;
    let bad = |reason: String| Error::input(what, reason);
    if !(k[0] > 0.0 && k[4] > 0.0) {
        return Err(bad(format!(
            "the CameraInfo's focal lengths K[0] = {}, K[4] = {} are not positive (an uncalibrated camera)",
            k[0], k[4]
        )));
    }
    let d = &info.d;
    let (k1, k2, p1, p2, k3) = match info.distortion_model.as_str() {
        "plumb_bob" | "rational_polynomial" if d.len() >= 5 => {
            if info.distortion_model == "rational_polynomial" && d[5..].iter().any(|&v| v != 0.0) {
                return Err(bad(
                    "rational_polynomial distortion with k4..k6 set is not supported (plumb_bob is)".into(),
                ));
            }
            (d[0], d[1], d[2], d[3], d[4])
        }
        "" | "plumb_bob" | "rational_polynomial" if d.iter().all(|&v| v == 0.0) => {
            (0.0, 0.0, 0.0, 0.0, 0.0)
        }
        model => {
            return Err(bad(format!(
                "distortion model {model:?} with {} coefficients is not supported (plumb_bob with 5 is)",
                d.len()
            )))
        }
    };
    let camera = PinholeCamera {
        fx: k[0],
        fy: k[4],
        cx: k[2],
        cy: k[5],
        width: info.width,
        height: info.height,
        k1,
        k2,
        p1,
        p2,
        k3,
    };
    camera.validate().map_err(|e| bad(e.to_string()))?;
    Ok(camera)
}

/// Decodes an image message (raw or compressed) into a frame of at most `max_pixels`.
pub fn decode_frame(bag: &Path, message: &BagMessage, max_pixels: u64) -> Result<BagFrame> {
    let what = message.describe(bag);
    match message.kind.as_str() {
        IMAGE => {
            let image: Image = message.decode(bag)?;
            let frame = raw_frame(&image, &what, max_pixels)?;
            Ok(BagFrame {
                timestamp: image.header.stamp.seconds(),
                frame,
            })
        }
        COMPRESSED_IMAGE => {
            let image: CompressedImage = message.decode(bag)?;
            let name = PathBuf::from(&what);
            let (width, height) = image::ImageReader::new(std::io::Cursor::new(&image.data))
                .with_guessed_format()
                .ok()
                .and_then(|r| r.into_dimensions().ok())
                .ok_or_else(|| {
                    Error::input(
                        &what,
                        format!(
                            "the {:?} CompressedImage is neither a readable JPEG nor PNG",
                            image.format
                        ),
                    )
                })?;
            check_pixels(&what, width, height, max_pixels)?;
            Ok(BagFrame {
                timestamp: image.header.stamp.seconds(),
                frame: Frame::decode(&name, &image.data)?,
            })
        }
        other => Err(Error::input(&what, format!("{other} is not an image type"))),
    }
}

fn check_pixels(what: &str, width: u32, height: u32, max_pixels: u64) -> Result<()> {
    crate::image::check_size(what, width, height)?;
    if width as u64 * height as u64 > max_pixels {
        return Err(Error::ImageSize {
            input: what.to_string(),
            width,
            height,
            reason: format!(
                "{} pixels exceed the limit of {max_pixels} (--max-pixels)",
                width as u64 * height as u64
            ),
        });
    }
    Ok(())
}

/// A frame from a raw `Image`, its data checked against height × step first.
fn raw_frame(image: &Image, what: &str, max_pixels: u64) -> Result<Frame> {
    let (w, h) = (image.width, image.height);
    check_pixels(what, w, h, max_pixels)?;
    let (channels, bytes) = match image.encoding.as_str() {
        "mono8" | "8UC1" => (1, 1),
        "mono16" | "16UC1" => (1, 2),
        "rgb8" | "bgr8" => (3, 1),
        "rgba8" | "bgra8" => (4, 1),
        other => {
            return Err(Error::input(
                what,
                format!(
                    "image encoding {other:?} is not supported (mono8, mono16, rgb8, bgr8, rgba8, bgra8 are)"
                ),
            ))
        }
    };
    let row = w as usize * channels * bytes;
    let step = image.step as usize;
    let needed = step
        .checked_mul(h as usize - 1)
        .and_then(|n| n.checked_add(row));
    if step < row || needed.is_none_or(|n| image.data.len() < n) {
        return Err(Error::input(
            what,
            format!(
                "{} bytes of data for {w}x{h} {} with step {step}: height × step needs {}, and step at least {row}",
                image.data.len(),
                image.encoding,
                step as u64 * h as u64
            ),
        ));
    }
    let bgr = image.encoding.starts_with("bgr");
    let mut rgb = Vec::with_capacity(3 * w as usize * h as usize);
    for y in 0..h as usize {
        let line = &image.data[y * step..y * step + row];
        match (channels, bytes) {
            (1, 1) => line.iter().for_each(|&v| rgb.extend_from_slice(&[v, v, v])),
            (1, _) => line.chunks_exact(2).for_each(|p| {
                let v = if image.is_bigendian != 0 {
                    u16::from_be_bytes([p[0], p[1]])
                } else {
                    u16::from_le_bytes([p[0], p[1]])
                };
                let v = (v >> 8) as u8;
                rgb.extend_from_slice(&[v, v, v]);
            }),
            _ => line.chunks_exact(channels).for_each(|p| {
                if bgr {
                    rgb.extend_from_slice(&[p[2], p[1], p[0]]);
                } else {
                    rgb.extend_from_slice(&p[..3]);
                }
            }),
        }
    }
    Frame::from_rgb(w, h, rgb)
}

/// Streams the frames of an image topic, in order; each item is a frame or the error of its
/// message (which a caller may skip, as it skips an unreadable file in a folder).
pub fn frames<'a>(
    bag: &'a Bag,
    topic: &str,
    max_pixels: u64,
) -> impl Iterator<Item = Result<BagFrame>> + 'a {
    bag.messages(&[topic.to_string()])
        .map(move |m| decode_frame(&bag.path, &m?, max_pixels))
}
