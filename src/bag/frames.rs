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

/// The coordinate frame of the images on `topic` (the first message's `header.frame_id`).
pub fn frame_id(bag: &Bag, topic: &str) -> Result<String> {
    #[derive(serde::Deserialize)]
    struct Headed {
        header: super::messages::Header,
    }
    let message = bag.messages(&[topic.to_string()]).next().ok_or_else(|| {
        Error::input(
            bag.path.display().to_string(),
            format!("topic {topic} has no message"),
        )
    })??;
    Ok(message.decode::<Headed>(&bag.path)?.header.frame_id)
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

#[cfg(test)]
mod tests {
    use super::*;
    use crate::bag::BagMessage;

    /// A CDR-encoded `Image` (little-endian encapsulation), built field by field.
    fn image_message(
        encoding: &str,
        width: u32,
        height: u32,
        step: u32,
        data: Vec<u8>,
    ) -> BagMessage {
        let body = (
            (5i32, 500_000_000u32, "camera".to_string()),
            height,
            width,
            encoding.to_string(),
            0u8,
            step,
            serde_bytes::ByteBuf::from(data),
        );
        let mut bytes = vec![0, 1, 0, 0];
        bytes.extend(cdr_encoding::to_vec::<_, byteorder::LittleEndian>(&body).unwrap());
        BagMessage {
            topic: "/cam".into(),
            kind: IMAGE.into(),
            log_time: 7,
            data: bytes,
        }
    }

    #[test]
    fn raw_images_decode_with_their_step_and_channel_order() {
        // 2×2 bgr8 rows padded to 8 bytes.
        let data = vec![
            10, 20, 30, 40, 50, 60, 0, 0, 70, 80, 90, 100, 110, 120, 0, 0,
        ];
        let m = image_message("bgr8", 2, 2, 8, data);
        let f = decode_frame(Path::new("b.mcap"), &m, 1 << 20).unwrap();
        assert_eq!(f.timestamp, 5.5);
        assert_eq!(&f.frame.rgb[..6], &[30, 20, 10, 60, 50, 40]);
        assert_eq!(&f.frame.rgb[6..], &[90, 80, 70, 120, 110, 100]);
    }

    #[test]
    fn short_data_and_unknown_encodings_are_named() {
        let m = image_message("rgb8", 4, 4, 12, vec![0; 40]);
        let e = decode_frame(Path::new("b.mcap"), &m, 1 << 20)
            .unwrap_err()
            .to_string();
        assert!(
            e.contains("b.mcap: /cam at log time") && e.contains("height × step"),
            "{e}"
        );
        let m = image_message("yuv422", 2, 2, 4, vec![0; 8]);
        let e = decode_frame(Path::new("b.mcap"), &m, 1 << 20)
            .unwrap_err()
            .to_string();
        assert!(e.contains("\"yuv422\" is not supported"), "{e}");
        let m = image_message("mono8", 100, 100, 100, vec![0; 10_000]);
        let e = decode_frame(Path::new("b.mcap"), &m, 5000)
            .unwrap_err()
            .to_string();
        assert!(e.contains("--max-pixels"), "{e}");
        let mut m = image_message("mono8", 2, 2, 2, vec![0; 4]);
        m.data.truncate(12);
        let e = decode_frame(Path::new("b.mcap"), &m, 1 << 20)
            .unwrap_err()
            .to_string();
        assert!(e.contains("corrupt CDR message"), "{e}");
    }

    #[test]
    fn a_camera_without_focal_length_is_refused() {
        let info = CameraInfo {
            header: Default::default(),
            height: 480,
            width: 640,
            distortion_model: "plumb_bob".into(),
            d: vec![0.1, 0.0, 0.0, 0.0, 0.0],
            k: crate::bag::messages::Fixed([0.0, 0.0, 320.0, 0.0, 0.0, 240.0, 0.0, 0.0, 1.0]),
            r: crate::bag::messages::Fixed([0.0; 9]),
            p: crate::bag::messages::Fixed([0.0; 12]),
            binning_x: 0,
            binning_y: 0,
            roi: Default::default(),
        };
        let e = camera_from_info(&info, "b.mcap: /info")
            .unwrap_err()
            .to_string();
        assert!(e.contains("not positive"), "{e}");
        let mut good = info.clone();
        good.k.0[0] = 500.0;
        good.k.0[4] = 500.0;
        let c = camera_from_info(&good, "b.mcap: /info").unwrap();
        assert_eq!((c.fx, c.cx, c.k1, c.width), (500.0, 320.0, 0.1, 640));
    }
}
