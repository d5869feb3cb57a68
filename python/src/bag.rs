//! ROS 2 bags from Python: `BagReader(path, image_topic=None)` lists the topics, gives the
//! camera of its CameraInfo in `Slam`'s keywords, and iterates the image topic as
//! (stamp, (H, W, 3) uint8 image) pairs, streamed from the file.

use std::sync::Mutex;

use numpy::IntoPyArray;
use pyo3::exceptions::PyRuntimeError;
use pyo3::prelude::*;
use pyo3::types::PyDict;
use steernav_core::bag::frames::{self, BagFrame};
use steernav_core::bag::Bag;

use crate::convert::py_err;

type Frames = Box<dyn Iterator<Item = steernav_core::Result<BagFrame>> + Send>;

/// A ROS 2 bag (rosbag2 folder or .mcap file) read frame by frame.
#[pyclass(module = "steernav")]
pub struct BagReader {
    bag: Bag,
    topic: String,
    frames: Mutex<Frames>,
}

#[pymethods]
impl BagReader {
    /// Refused: an open file and a position in its message stream.
    fn __reduce__(&self) -> PyResult<()> {
        Err(crate::convert::unpicklable("BagReader", "it is an open file and a position in its message stream; pass the bag's path to the worker and open it there"))
    }

    /// `BagReader(path, image_topic=None, max_pixels=100_000_000)`: the bag and its image
    /// topic (the only Image or CompressedImage topic unless named).
    #[new]
    #[pyo3(signature = (path, image_topic = None, max_pixels = 100_000_000))]
    fn new(path: std::path::PathBuf, image_topic: Option<&str>, max_pixels: u64) -> PyResult<Self> {
        let bag = Bag::open(&path).map_err(py_err)?;
        let topic = frames::image_topic(&bag, image_topic).map_err(py_err)?.name;
        let bag_path = bag.path.clone();
        let stream: Frames = Box::new(
            bag.messages(std::slice::from_ref(&topic))
                .map(move |m| frames::decode_frame(&bag_path, &m?, max_pixels)),
        );
        Ok(Self {
            bag,
            topic,
            frames: Mutex::new(stream),
        })
    }

    /// Every topic as (name, message type).
    #[getter]
    fn topics(&self) -> Vec<(String, String)> {
        self.bag
            .topics
            .iter()
            .map(|t| (t.name.clone(), t.kind.clone()))
            .collect()
    }

    /// The image topic read.
    #[getter]
    fn image_topic(&self) -> String {
        self.topic.clone()
    }

    /// `camera(camera_info_topic=None)`: the first CameraInfo's camera as `Slam`'s keyword
    /// arguments: fx, fy, cx, cy, width, height, distortion (k1, k2, p1, p2, k3).
    #[pyo3(signature = (camera_info_topic = None))]
    fn camera<'py>(
        &self,
        py: Python<'py>,
        camera_info_topic: Option<&str>,
    ) -> PyResult<Bound<'py, PyDict>> {
        let c = frames::camera(&self.bag, camera_info_topic).map_err(py_err)?;
        let d = PyDict::new(py);
        d.set_item("fx", c.fx)?;
        d.set_item("fy", c.fy)?;
        d.set_item("cx", c.cx)?;
        d.set_item("cy", c.cy)?;
        d.set_item("width", c.width)?;
        d.set_item("height", c.height)?;
        d.set_item("distortion", (c.k1, c.k2, c.p1, c.p2, c.k3))?;
        Ok(d)
    }

    fn __iter__(slf: PyRef<'_, Self>) -> PyRef<'_, Self> {
        slf
    }

    /// The next (stamp seconds, image) of the image topic; a message that cannot be decoded
    /// raises with its topic and log time.
    fn __next__<'py>(&self, py: Python<'py>) -> PyResult<Option<(f64, Bound<'py, PyAny>)>> {
        let next = py.detach(|| {
            self.frames
                .lock()
                .map_err(|_| PyRuntimeError::new_err("the bag's stream was poisoned"))
                .map(|mut f| f.next())
        })?;
        let Some(item) = next else {
            return Ok(None);
        };
        let f = item.map_err(py_err)?;
        let (w, h) = (f.frame.width as usize, f.frame.height as usize);
        let array = numpy::ndarray::Array3::from_shape_vec((h, w, 3), f.frame.rgb)
            .map_err(|e| PyRuntimeError::new_err(e.to_string()))?;
        Ok(Some((f.timestamp, array.into_pyarray(py).into_any())))
    }
}
