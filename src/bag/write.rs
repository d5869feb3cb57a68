//! Results as MCAP with the `ros2msg` schemas and CDR messages that ROS 2 tools and Foxglove
//! decode: poses, paths and point clouds from SLAM, velocity commands and headings from the
//! navigator, keypoints as image annotations. Chunks are closed (flushed) after each call of
//! [`BagWriter::flush`], so a run that dies leaves every flushed message readable.

use std::collections::HashMap;
use std::fs::File;
use std::io::BufWriter;
use std::path::{Path, PathBuf};

use serde::Serialize;

use super::messages::{Header, Time};
use crate::error::{Error, Result};

const SEP: &str =
    "================================================================================\n";

const TIME: &str = "builtin_interfaces/Time\nint32 sec\nuint32 nanosec\n";
const HEADER: &str = "std_msgs/Header\nbuiltin_interfaces/Time stamp\nstring frame_id\n";
const POINT: &str = "geometry_msgs/Point\nfloat64 x\nfloat64 y\nfloat64 z\n";
const QUATERNION: &str =
    "geometry_msgs/Quaternion\nfloat64 x 0\nfloat64 y 0\nfloat64 z 0\nfloat64 w 1\n";
const POSE: &str = "geometry_msgs/Pose\nPoint position\nQuaternion orientation\n";
const POSE_STAMPED: &str = "geometry_msgs/PoseStamped\nstd_msgs/Header header\nPose pose\n";
const VECTOR3: &str = "geometry_msgs/Vector3\nfloat64 x\nfloat64 y\nfloat64 z\n";
const POINT_FIELD: &str = "sensor_msgs/PointField\nuint8 INT8=1\nuint8 UINT8=2\nuint8 INT16=3\nuint8 UINT16=4\nuint8 INT32=5\nuint8 UINT32=6\nuint8 FLOAT32=7\nuint8 FLOAT64=8\nstring name\nuint32 offset\nuint8 datatype\nuint32 count\n";
const POINT2: &str = "foxglove_msgs/Point2\nfloat64 x\nfloat64 y\n";
const COLOR: &str = "foxglove_msgs/Color\nfloat64 r\nfloat64 g\nfloat64 b\nfloat64 a\n";
const CIRCLE: &str = "foxglove_msgs/CircleAnnotation\nbuiltin_interfaces/Time timestamp\nfoxglove_msgs/Point2 position\nfloat64 diameter\nfloat64 thickness\nfoxglove_msgs/Color fill_color\nfoxglove_msgs/Color outline_color\n";
const POINTS: &str = "foxglove_msgs/PointsAnnotation\nbuiltin_interfaces/Time timestamp\nuint8 UNKNOWN=0\nuint8 POINTS=1\nuint8 LINE_LOOP=2\nuint8 LINE_STRIP=3\nuint8 LINE_LIST=4\nuint8 type\nfoxglove_msgs/Point2[] points\nfoxglove_msgs/Color outline_color\nfoxglove_msgs/Color[] outline_colors\nfoxglove_msgs/Color fill_color\nfloat64 thickness\n";
const TEXT: &str = "foxglove_msgs/TextAnnotation\nbuiltin_interfaces/Time timestamp\nfoxglove_msgs/Point2 position\nstring text\nfloat64 font_size\nfoxglove_msgs/Color text_color\nfoxglove_msgs/Color background_color\n";

/// A `ros2msg` schema: the main definition, then each one it uses after a separator line and
/// `MSG: ` (each constant above starts with its type's name, as `MSG:` wants).
fn build(main_body: &str, deps: &[&str]) -> String {
    let mut s = main_body.to_string();
    for dep in deps {
        s.push_str(SEP);
        s.push_str("MSG: ");
        s.push_str(dep);
    }
    s
}

const ROI: &str = "sensor_msgs/RegionOfInterest\nuint32 x_offset\nuint32 y_offset\nuint32 height\nuint32 width\nbool do_rectify\n";

/// The schema of `sensor_msgs/msg/Image`.
pub fn image_schema() -> String {
    build(
        "std_msgs/Header header\nuint32 height\nuint32 width\nstring encoding\nuint8 is_bigendian\nuint32 step\nuint8[] data\n",
        &[HEADER, TIME],
    )
}

/// The schema of `sensor_msgs/msg/CameraInfo`.
pub fn camera_info_schema() -> String {
    build(
        "std_msgs/Header header\nuint32 height\nuint32 width\nstring distortion_model\nfloat64[] d\nfloat64[9] k\nfloat64[9] r\nfloat64[12] p\nuint32 binning_x\nuint32 binning_y\nRegionOfInterest roi\n",
        &[HEADER, TIME, ROI],
    )
}

/// The schema of `geometry_msgs/msg/PoseStamped`.
pub fn pose_stamped_schema() -> String {
    build(body(POSE_STAMPED), &[HEADER, TIME, POSE, POINT, QUATERNION])
}

/// The schema of `nav_msgs/msg/Path`.
pub fn path_schema() -> String {
    build(
        "std_msgs/Header header\ngeometry_msgs/PoseStamped[] poses\n",
        &[HEADER, TIME, POSE_STAMPED, POSE, POINT, QUATERNION],
    )
}

/// The schema of `sensor_msgs/msg/PointCloud2`.
pub fn point_cloud2_schema() -> String {
    build(
        "std_msgs/Header header\nuint32 height\nuint32 width\nsensor_msgs/PointField[] fields\nbool is_bigendian\nuint32 point_step\nuint32 row_step\nuint8[] data\nbool is_dense\n",
        &[HEADER, TIME, POINT_FIELD],
    )
}

/// The schema of `geometry_msgs/msg/Twist`.
pub fn twist_schema() -> String {
    build("Vector3 linear\nVector3 angular\n", &[VECTOR3])
}

/// The schema of `std_msgs/msg/Float64`.
pub fn float64_schema() -> String {
    "float64 data\n".to_string()
}

/// The schema of `foxglove_msgs/msg/ImageAnnotations`.
pub fn image_annotations_schema() -> String {
    build(
        "foxglove_msgs/CircleAnnotation[] circles\nfoxglove_msgs/PointsAnnotation[] points\nfoxglove_msgs/TextAnnotation[] texts\n",
        &[CIRCLE, TIME, POINT2, COLOR, POINTS, TEXT],
    )
}

/// A definition without its name line.
fn body(def: &'static str) -> &'static str {
    def.split_once('\n').map_or(def, |(_, rest)| rest)
}

/// `geometry_msgs/msg/Pose` for writing.
#[derive(Clone, Copy, Debug, Serialize)]
pub struct PoseOut {
    /// Position x, y, z.
    pub position: [f64; 3],
    /// Orientation x, y, z, w.
    pub orientation: [f64; 4],
}

/// `geometry_msgs/msg/PoseStamped`.
#[derive(Clone, Debug, Serialize)]
pub struct PoseStamped {
    /// Stamp and frame.
    pub header: Header,
    /// The pose.
    pub pose: PoseOut,
}

/// `nav_msgs/msg/Path`.
#[derive(Clone, Debug, Serialize)]
pub struct PathOut {
    /// Stamp and frame.
    pub header: Header,
    /// The poses.
    pub poses: Vec<PoseStamped>,
}

/// `sensor_msgs/msg/PointField`.
#[derive(Clone, Debug, Serialize)]
pub struct PointField {
    /// Field name.
    pub name: String,
    /// Byte offset in a point.
    pub offset: u32,
    /// 7 = FLOAT32.
    pub datatype: u8,
    /// Elements.
    pub count: u32,
}

/// `sensor_msgs/msg/PointCloud2`.
#[derive(Clone, Debug, Serialize)]
pub struct PointCloud2 {
    /// Stamp and frame.
    pub header: Header,
    /// 1 for an unordered cloud.
    pub height: u32,
    /// Points.
    pub width: u32,
    /// x, y, z.
    pub fields: Vec<PointField>,
    /// Little-endian here.
    pub is_bigendian: bool,
    /// Bytes per point.
    pub point_step: u32,
    /// Bytes per row.
    pub row_step: u32,
    /// The points.
    #[serde(with = "serde_bytes")]
    pub data: Vec<u8>,
    /// No invalid points.
    pub is_dense: bool,
}

impl PointCloud2 {
    /// An unordered cloud of float32 x, y, z.
    pub fn xyz(header: Header, points: &[[f64; 3]]) -> Self {
        let data = points
            .iter()
            .flat_map(|p| p.iter().flat_map(|&v| (v as f32).to_le_bytes()))
            .collect();
        let field = |name: &str, offset| PointField {
            name: name.into(),
            offset,
            datatype: 7,
            count: 1,
        };
        Self {
            header,
            height: 1,
            width: points.len() as u32,
            fields: vec![field("x", 0), field("y", 4), field("z", 8)],
            is_bigendian: false,
            point_step: 12,
            row_step: 12 * points.len() as u32,
            data,
            is_dense: true,
        }
    }
}

/// `geometry_msgs/msg/Twist`.
#[derive(Clone, Copy, Debug, Serialize)]
pub struct TwistOut {
    /// Linear velocity x, y, z.
    pub linear: [f64; 3],
    /// Angular velocity x, y, z.
    pub angular: [f64; 3],
}

/// `foxglove_msgs/msg/Color`.
#[derive(Clone, Copy, Debug, Serialize)]
pub struct Color {
    /// Red.
    pub r: f64,
    /// Green.
    pub g: f64,
    /// Blue.
    pub b: f64,
    /// Alpha.
    pub a: f64,
}

/// `foxglove_msgs/msg/CircleAnnotation`.
#[derive(Clone, Debug, Serialize)]
pub struct CircleAnnotation {
    /// The image's stamp.
    pub timestamp: Time,
    /// Centre x, y (pixels).
    pub position: [f64; 2],
    /// Diameter (pixels).
    pub diameter: f64,
    /// Line width (pixels).
    pub thickness: f64,
    /// Fill.
    pub fill_color: Color,
    /// Outline.
    pub outline_color: Color,
}

/// `foxglove_msgs/msg/PointsAnnotation`.
#[derive(Clone, Debug, Serialize)]
pub struct PointsAnnotation {
    /// The image's stamp.
    pub timestamp: Time,
    /// 1 = POINTS.
    #[serde(rename = "type")]
    pub kind: u8,
    /// The points (pixels).
    pub points: Vec<[f64; 2]>,
    /// Their colour.
    pub outline_color: Color,
    /// Per-point colours (empty: all `outline_color`).
    pub outline_colors: Vec<Color>,
    /// Fill.
    pub fill_color: Color,
    /// Point size (pixels).
    pub thickness: f64,
}

/// `foxglove_msgs/msg/ImageAnnotations`.
#[derive(Clone, Debug, Serialize)]
pub struct ImageAnnotations {
    /// Circles.
    pub circles: Vec<CircleAnnotation>,
    /// Point sets.
    pub points: Vec<PointsAnnotation>,
    /// Texts (none written).
    pub texts: Vec<()>,
}

/// A header stamped `t` seconds in `frame`.
pub fn header(t: f64, frame: &str) -> Header {
    Header {
        stamp: Time::from_seconds(t),
        frame_id: frame.to_string(),
    }
}

/// An MCAP file being written.
pub struct BagWriter {
    path: PathBuf,
    writer: mcap::Writer<BufWriter<File>>,
    channels: HashMap<String, u16>,
    sequence: u32,
}

fn write_error(path: &Path, e: impl std::fmt::Display) -> Error {
    Error::Bag {
        path: path.to_path_buf(),
        reason: format!("cannot write MCAP: {e}"),
        source: None,
    }
}

impl BagWriter {
    /// Creates `path` (zstd chunks, the `ros2` profile).
    pub fn create(path: &Path) -> Result<Self> {
        let file = File::create(path).map_err(|source| Error::Io {
            path: path.to_path_buf(),
            source,
        })?;
        let writer = mcap::WriteOptions::new()
            .compression(Some(mcap::Compression::Zstd))
            .profile("ros2")
            .library(concat!("steernav ", env!("CARGO_PKG_VERSION")))
            .create(BufWriter::new(file))
            .map_err(|e| write_error(path, e))?;
        Ok(Self {
            path: path.to_path_buf(),
            writer,
            channels: HashMap::new(),
            sequence: 0,
        })
    }

    /// Declares `topic` carrying `kind` with its `ros2msg` schema.
    pub fn add_topic(&mut self, topic: &str, kind: &str, schema: &str) -> Result<()> {
        let path = self.path.clone();
        let schema_id = self
            .writer
            .add_schema(kind, "ros2msg", schema.as_bytes())
            .map_err(|e| write_error(&path, e))?;
        let channel = self
            .writer
            .add_channel(schema_id, topic, "cdr", &Default::default())
            .map_err(|e| write_error(&path, e))?;
        self.channels.insert(topic.to_string(), channel);
        Ok(())
    }

    /// Writes `message` (CDR, little-endian) on `topic` at `t` seconds.
    pub fn write<T: Serialize>(&mut self, topic: &str, t: f64, message: &T) -> Result<()> {
        let channel_id = *self
            .channels
            .get(topic)
            .ok_or_else(|| write_error(&self.path, format!("topic {topic} was not declared")))?;
        let mut data = vec![0u8, 1, 0, 0];
        data.extend(
            cdr_encoding::to_vec::<_, byteorder::LittleEndian>(message)
                .map_err(|e| write_error(&self.path, e))?,
        );
        let time = Time::from_seconds(t).nanoseconds().max(0) as u64;
        self.sequence = self.sequence.wrapping_add(1);
        self.writer
            .write_to_known_channel(
                &mcap::records::MessageHeader {
                    channel_id,
                    sequence: self.sequence,
                    log_time: time,
                    publish_time: time,
                },
                &data,
            )
            .map_err(|e| write_error(&self.path, e))
    }

    /// Closes the current chunk and flushes it to the file.
    pub fn flush(&mut self) -> Result<()> {
        self.writer.flush().map_err(|e| write_error(&self.path, e))
    }

    /// Writes the summary and closes the file.
    pub fn finish(mut self) -> Result<()> {
        self.writer
            .finish()
            .map_err(|e| write_error(&self.path, e))?;
        Ok(())
    }
}
