//! The ROS 2 messages steernav reads from bags, as serde types for their CDR encoding (the
//! field order and types of the `.msg` definitions; CDR has no field names). Decoded with
//! `cdr-encoding` after the 4-byte encapsulation header that ROS 2 puts before every message.

use serde::de::{DeserializeOwned, SeqAccess, Visitor};
use serde::{Deserialize, Deserializer, Serialize};

use crate::error::{Error, Result};

/// `builtin_interfaces/msg/Time`.
#[derive(Clone, Copy, Debug, Default, PartialEq, Deserialize, Serialize)]
pub struct Time {
    /// Seconds.
    pub sec: i32,
    /// Nanoseconds within the second.
    pub nanosec: u32,
}

impl Time {
    /// Seconds as a float: the nanosecond count divided once, so that a stamp written from a
    /// decimal time (5.833333 s) reads back as the same double as the decimal parsed.
    pub fn seconds(&self) -> f64 {
        self.nanoseconds() as f64 / 1e9
    }

    /// Nanoseconds since the epoch.
    pub fn nanoseconds(&self) -> i64 {
        self.sec as i64 * 1_000_000_000 + self.nanosec as i64
    }

    /// The stamp of `t` seconds, to the nearest nanosecond (saturating at the i32 range).
    pub fn from_seconds(t: f64) -> Self {
        let ns = (t * 1e9).round() as i64;
        let sec = ns.div_euclid(1_000_000_000);
        Self {
            sec: sec.clamp(i32::MIN as i64, i32::MAX as i64) as i32,
            nanosec: ns.rem_euclid(1_000_000_000) as u32,
        }
    }
}

/// `std_msgs/msg/Header`.
#[derive(Clone, Debug, Default, PartialEq, Deserialize, Serialize)]
pub struct Header {
    /// Acquisition time.
    pub stamp: Time,
    /// Coordinate frame.
    pub frame_id: String,
}

/// `sensor_msgs/msg/Image`.
#[derive(Clone, Debug, PartialEq, Deserialize, Serialize)]
pub struct Image {
    /// Stamp and frame.
    pub header: Header,
    /// Rows.
    pub height: u32,
    /// Columns.
    pub width: u32,
    /// Pixel encoding (`mono8`, `rgb8`, …).
    pub encoding: String,
    /// Whether multi-byte samples are big-endian.
    pub is_bigendian: u8,
    /// Bytes per row.
    pub step: u32,
    /// `step × height` bytes.
    #[serde(with = "serde_bytes")]
    pub data: Vec<u8>,
}

/// `sensor_msgs/msg/CompressedImage`.
#[derive(Clone, Debug, PartialEq, Deserialize, Serialize)]
pub struct CompressedImage {
    /// Stamp and frame.
    pub header: Header,
    /// `jpeg`, `png` (possibly with the original encoding before it: `rgb8; jpeg compressed bgr8`).
    pub format: String,
    /// The compressed bytes.
    #[serde(with = "serde_bytes")]
    pub data: Vec<u8>,
}

/// `sensor_msgs/msg/RegionOfInterest`.
#[derive(Clone, Debug, Default, PartialEq, Deserialize, Serialize)]
pub struct RegionOfInterest {
    /// Left column.
    pub x_offset: u32,
    /// Top row.
    pub y_offset: u32,
    /// Rows.
    pub height: u32,
    /// Columns.
    pub width: u32,
    /// Whether the region is to be rectified.
    pub do_rectify: bool,
}

/// `sensor_msgs/msg/CameraInfo`.
#[derive(Clone, Debug, PartialEq, Deserialize, Serialize)]
pub struct CameraInfo {
    /// Stamp and frame.
    pub header: Header,
    /// Rows of the calibrated image.
    pub height: u32,
    /// Columns of the calibrated image.
    pub width: u32,
    /// `plumb_bob`, `rational_polynomial`, `equidistant`, or empty.
    pub distortion_model: String,
    /// Distortion coefficients (plumb_bob: k1, k2, t1, t2, k3).
    pub d: Vec<f64>,
    /// Intrinsic matrix, row-major.
    pub k: Fixed<9>,
    /// Rectification rotation, row-major.
    pub r: Fixed<9>,
    /// Projection matrix, row-major 3×4.
    pub p: Fixed<12>,
    /// Horizontal binning.
    pub binning_x: u32,
    /// Vertical binning.
    pub binning_y: u32,
    /// Region of interest.
    pub roi: RegionOfInterest,
}

/// `sensor_msgs/msg/LaserScan`.
#[derive(Clone, Debug, PartialEq, Deserialize)]
pub struct LaserScan {
    /// Stamp (of the first beam) and frame.
    pub header: Header,
    /// Angle of the first beam, radians.
    pub angle_min: f32,
    /// Angle of the last beam, radians.
    pub angle_max: f32,
    /// Angle between beams, radians.
    pub angle_increment: f32,
    /// Seconds between beams.
    pub time_increment: f32,
    /// Seconds between scans.
    pub scan_time: f32,
    /// Shortest valid range, metres.
    pub range_min: f32,
    /// Longest valid range, metres.
    pub range_max: f32,
    /// Ranges, metres.
    pub ranges: Vec<f32>,
    /// Intensities (device units).
    pub intensities: Vec<f32>,
}

/// `geometry_msgs/msg/Point`.
#[derive(Clone, Copy, Debug, Default, PartialEq, Deserialize)]
pub struct Point {
    /// x, metres.
    pub x: f64,
    /// y, metres.
    pub y: f64,
    /// z, metres.
    pub z: f64,
}

/// `geometry_msgs/msg/Quaternion`.
#[derive(Clone, Copy, Debug, Default, PartialEq, Deserialize)]
pub struct Quaternion {
    /// x.
    pub x: f64,
    /// y.
    pub y: f64,
    /// z.
    pub z: f64,
    /// w.
    pub w: f64,
}

/// `geometry_msgs/msg/Pose`.
#[derive(Clone, Copy, Debug, Default, PartialEq, Deserialize)]
pub struct Pose {
    /// Position.
    pub position: Point,
    /// Orientation.
    pub orientation: Quaternion,
}

/// `geometry_msgs/msg/PoseWithCovariance`.
#[derive(Clone, Debug, PartialEq, Deserialize)]
pub struct PoseWithCovariance {
    /// The pose.
    pub pose: Pose,
    /// 6×6 covariance, row-major.
    pub covariance: Fixed<36>,
}

/// `geometry_msgs/msg/Vector3`.
#[derive(Clone, Copy, Debug, Default, PartialEq, Deserialize)]
pub struct Vector3 {
    /// x.
    pub x: f64,
    /// y.
    pub y: f64,
    /// z.
    pub z: f64,
}

/// `geometry_msgs/msg/Twist`.
#[derive(Clone, Copy, Debug, Default, PartialEq, Deserialize)]
pub struct Twist {
    /// Linear velocity.
    pub linear: Vector3,
    /// Angular velocity.
    pub angular: Vector3,
}

/// `geometry_msgs/msg/TwistWithCovariance`.
#[derive(Clone, Debug, PartialEq, Deserialize)]
pub struct TwistWithCovariance {
    /// The twist.
    pub twist: Twist,
    /// 6×6 covariance, row-major.
    pub covariance: Fixed<36>,
}

/// `nav_msgs/msg/Odometry`.
#[derive(Clone, Debug, PartialEq, Deserialize)]
pub struct Odometry {
    /// Stamp and the frame of the pose.
    pub header: Header,
    /// Frame of the twist.
    pub child_frame_id: String,
    /// Pose in `header.frame_id`.
    pub pose: PoseWithCovariance,
    /// Twist in `child_frame_id`.
    pub twist: TwistWithCovariance,
}

/// A fixed-length `float64[N]` (CDR writes no length for it). serde's own arrays stop at 32.
#[derive(Clone, Debug, PartialEq)]
pub struct Fixed<const N: usize>(pub [f64; N]);

impl<const N: usize> Serialize for Fixed<N> {
    fn serialize<S: serde::Serializer>(
        &self,
        serializer: S,
    ) -> std::result::Result<S::Ok, S::Error> {
        use serde::ser::SerializeTuple;
        let mut t = serializer.serialize_tuple(N)?;
        for v in &self.0 {
            t.serialize_element(v)?;
        }
        t.end()
    }
}

impl<'de, const N: usize> Deserialize<'de> for Fixed<N> {
    fn deserialize<D: Deserializer<'de>>(deserializer: D) -> std::result::Result<Self, D::Error> {
        struct Values<const N: usize>;
        impl<'de, const N: usize> Visitor<'de> for Values<N> {
            type Value = Fixed<N>;
            fn expecting(&self, f: &mut std::fmt::Formatter) -> std::fmt::Result {
                write!(f, "{N} float64 values")
            }
            fn visit_seq<A: SeqAccess<'de>>(
                self,
                mut seq: A,
            ) -> std::result::Result<Fixed<N>, A::Error> {
                let mut out = [0.0; N];
                for (i, slot) in out.iter_mut().enumerate() {
                    *slot = seq
                        .next_element()?
                        .ok_or_else(|| serde::de::Error::invalid_length(i, &self))?;
                }
                Ok(Fixed(out))
            }
        }
        deserializer.deserialize_tuple(N, Values::<N>)
    }
}

/// Decodes one CDR-encoded ROS 2 message: the encapsulation header (0x00 0x00 big-endian CDR,
/// 0x00 0x01 little-endian), then the body; `what` names the message in errors.
pub fn decode<T: DeserializeOwned>(data: &[u8], what: &str) -> Result<T> {
    let bad = |reason: String| Error::input(what, reason);
    if data.len() < 4 {
        return Err(bad(format!(
            "{} bytes, shorter than the 4-byte CDR encapsulation header",
            data.len()
        )));
    }
    let body = &data[4..];
    let decoded = match (data[0], data[1]) {
        (0, 1) => cdr_encoding::from_bytes::<T, byteorder::LittleEndian>(body),
        (0, 0) => cdr_encoding::from_bytes::<T, byteorder::BigEndian>(body),
        (a, b) => {
            return Err(bad(format!(
                "encapsulation {a:#04x} {b:#04x} is not plain CDR (0x00 0x00 or 0x00 0x01)"
            )))
        }
    };
    decoded
        .map(|(value, _)| value)
        .map_err(|e| bad(format!("corrupt CDR message: {e}")))
}
