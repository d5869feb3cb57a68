//! Depth images in the TUM RGB-D form (16-bit PNG, 5000 per metre, 0 = none, listed in
//! depth.txt), and the check of the map's depths against them: how the inverse depths of
//! eqs 13–19 converge, in the map's own unit, seen from each frame (issue 25). A monocular map
//! has its own unit; what the check shows is whether that unit stays one unit, landmark
//! generation after generation, and whether it is the trajectory's.

use std::io::BufRead;
use std::path::{Path, PathBuf};

use nalgebra::{UnitQuaternion, Vector2, Vector3};

use crate::error::{Error, Result};
use crate::slam::camera::PinholeCamera;
use crate::slam::MapPoint;

/// TUM RGB-D's depth scale: a pixel value of 5000 is one metre.
pub const TUM_DEPTH_SCALE: f64 = 5000.0;

/// Writes `metres` (row by row, `width`×`height`) as a TUM depth image; values that are not
/// finite and positive, or beyond what 16 bits hold (13.1 m), become 0 (no depth).
pub fn write_depth_png(path: &Path, width: u32, height: u32, metres: &[f32]) -> Result<()> {
    let pixels: Vec<u16> = metres
        .iter()
        .map(|&m| {
            let v = (m as f64 * TUM_DEPTH_SCALE).round();
            if v.is_finite() && v >= 1.0 && v <= u16::MAX as f64 {
                v as u16
            } else {
                0
            }
        })
        .collect();
    let image = image::ImageBuffer::<image::Luma<u16>, _>::from_raw(width, height, pixels)
        .ok_or_else(|| Error::Input {
            input: path.display().to_string(),
            reason: format!("{} depths for a {width}x{height} image", metres.len()),
        })?;
    image.save(path).map_err(|e| Error::Io {
        path: path.to_path_buf(),
        source: std::io::Error::other(e.to_string()),
    })
}

/// One depth image, metres per pixel (0 where there is none).
#[derive(Clone, Debug)]
pub struct DepthImage {
    /// Width, pixels.
    pub width: u32,
    /// Height, pixels.
    pub height: u32,
    values: Vec<u16>,
}

impl DepthImage {
    /// Reads a 16-bit grayscale PNG registered to a camera of `width`×`height`; another size is
    /// refused from the file's header, before anything is decoded, and any other kind of
    /// image by name.
    pub fn load(path: &Path, (width, height): (u32, u32)) -> Result<Self> {
        let header = image::image_dimensions(path).map_err(|e| Error::Decode {
            path: path.to_path_buf(),
            reason: e.to_string(),
            source: None,
        })?;
        if header != (width, height) {
            return Err(Error::ImageSize {
                input: path.display().to_string(),
                width: header.0,
                height: header.1,
                reason: format!("the camera's images are {width}x{height}"),
            });
        }
        let decoded = image::open(path).map_err(|e| Error::Decode {
            path: path.to_path_buf(),
            reason: e.to_string(),
            source: None,
        })?;
        let image::DynamicImage::ImageLuma16(buffer) = decoded else {
            return Err(Error::Decode {
                path: path.to_path_buf(),
                reason: format!(
                    "a depth image must be 16-bit grayscale (TUM RGB-D: 5000 per metre), not {:?}",
                    decoded.color()
                ),
                source: None,
            });
        };
        Ok(Self {
            width: buffer.width(),
            height: buffer.height(),
            values: buffer.into_raw(),
        })
    }

    /// The depth at the pixel nearest `pixel`, metres; `None` outside the image or where the
    /// image has none.
    pub fn at(&self, pixel: &Vector2<f64>) -> Option<f64> {
        let (x, y) = (pixel.x.round(), pixel.y.round());
        if !(0.0..self.width as f64).contains(&x) || !(0.0..self.height as f64).contains(&y) {
            return None;
        }
        let v = self.values[y as usize * self.width as usize + x as usize];
        (v > 0).then(|| v as f64 / TUM_DEPTH_SCALE)
    }
}

/// The depth images of a sequence by timestamp (a TUM RGB-D depth.txt).
#[derive(Clone, Debug)]
pub struct DepthList {
    entries: Vec<(f64, PathBuf)>,
}

impl DepthList {
    /// The folder's depth.txt (`timestamp path` per line, `#` comments), or `None` when it
    /// has none. A malformed line is an error naming the file and the line.
    pub fn open(dir: &Path) -> Result<Option<Self>> {
        let path = dir.join("depth.txt");
        if !path.is_file() {
            return Ok(None);
        }
        let file = crate::error::open_input(&path)?;
        let mut entries = Vec::new();
        for (i, line) in std::io::BufReader::new(file).lines().enumerate() {
            let line = line.map_err(|source| Error::Io {
                path: path.clone(),
                source,
            })?;
            let text = line.trim();
            if text.is_empty() || text.starts_with('#') {
                continue;
            }
            let bad = |reason: String| Error::Parse {
                path: path.clone(),
                reason: format!("line {}: {reason}", i + 1),
            };
            let mut parts = text.split_whitespace();
            let (Some(t), Some(name), None) = (parts.next(), parts.next(), parts.next()) else {
                return Err(bad("expected `timestamp filename`".into()));
            };
            let t: f64 = t
                .parse()
                .ok()
                .filter(|t: &f64| t.is_finite())
                .ok_or_else(|| bad(format!("timestamp {t:?} is not a number")))?;
            entries.push((t, dir.join(name)));
        }
        entries.sort_by(|a, b| a.0.total_cmp(&b.0));
        Ok(Some(Self { entries }))
    }

    /// Number of depth images listed.
    pub fn len(&self) -> usize {
        self.entries.len()
    }

    /// Whether none is listed.
    pub fn is_empty(&self) -> bool {
        self.entries.is_empty()
    }

    /// The image taken nearest `t`, when one is within `tolerance` seconds (TUM's
    /// associate.py pairs colour and depth at 0.02 s).
    pub fn nearest(&self, t: f64, tolerance: f64) -> Option<&Path> {
        let i = self.entries.partition_point(|e| e.0 < t);
        [i.checked_sub(1), Some(i)]
            .into_iter()
            .flatten()
            .filter_map(|j| self.entries.get(j))
            .filter(|e| (e.0 - t).abs() <= tolerance)
            .min_by(|a, b| (a.0 - t).abs().total_cmp(&(b.0 - t).abs()))
            .map(|e| e.1.as_path())
    }
}

/// For each landmark of `map` inside the image of the camera at `position` and `orientation`
/// (w, x, y, z; camera to world), its depth in the map over the depth the image has at its
/// pixel. In a consistent map these ratios are all the map's unit (map units per metre); a
/// landmark hidden behind another surface reads the nearer surface, so their median is what
/// to look at.
pub fn depth_ratios(
    map: &[MapPoint],
    position: &[f64; 3],
    orientation: &[f64; 4],
    camera: &PinholeCamera,
    depth: &DepthImage,
) -> Vec<f64> {
    let [w, x, y, z] = *orientation;
    let to_camera =
        UnitQuaternion::from_quaternion(nalgebra::Quaternion::new(w, x, y, z)).inverse();
    let origin = Vector3::from(*position);
    map.iter()
        .filter_map(|m| {
            let h = to_camera * (Vector3::from(m.position) - origin);
            let pixel = camera.project(&h)?;
            let truth = depth.at(&pixel)?;
            Some(h.z / truth)
        })
        .collect()
}

/// The median and quartiles of `values` (sorted in place); `None` when empty.
pub fn quartiles(values: &mut [f64]) -> Option<[f64; 3]> {
    if values.is_empty() {
        return None;
    }
    values.sort_by(f64::total_cmp);
    let at = |q: f64| values[((values.len() - 1) as f64 * q).round() as usize];
    Some([at(0.25), at(0.5), at(0.75)])
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::slam::inverse_depth::Parametrisation;

    #[test]
    fn a_depth_image_round_trips_at_the_tum_scale_with_no_depth_as_zero() {
        let dir = tempfile::tempdir().unwrap();
        let path = dir.path().join("d.png");
        write_depth_png(&path, 3, 2, &[1.0, 2.5, 0.0, f32::NAN, 20.0, 0.00005]).unwrap();
        let image = DepthImage::load(&path, (3, 2)).unwrap();
        assert_eq!((image.width, image.height), (3, 2));
        assert_eq!(image.at(&Vector2::new(0.0, 0.0)), Some(1.0));
        assert_eq!(image.at(&Vector2::new(1.2, -0.3)), Some(2.5));
        for (x, y) in [(2.0, 0.0), (0.0, 1.0), (1.0, 1.0), (2.0, 1.0), (3.0, 0.0)] {
            assert_eq!(image.at(&Vector2::new(x, y)), None, "({x}, {y})");
        }
        // An 8-bit image is refused, naming what a depth image must be.
        let grey = dir.path().join("g.png");
        image::GrayImage::new(2, 2).save(&grey).unwrap();
        let e = DepthImage::load(&grey, (2, 2)).unwrap_err().to_string();
        assert!(e.contains("g.png") && e.contains("16-bit"), "{e}");
        // Another size than the camera's is refused from the header.
        let e = DepthImage::load(&path, (640, 480)).unwrap_err().to_string();
        assert!(e.contains("d.png") && e.contains("640x480"), "{e}");
    }

    #[test]
    fn depth_lists_pair_frames_by_time_and_name_bad_lines() {
        let dir = tempfile::tempdir().unwrap();
        assert!(DepthList::open(dir.path()).unwrap().is_none());
        let list = dir.path().join("depth.txt");
        std::fs::write(&list, "# t file\n0.10 depth/a.png\n0.20 depth/b.png\n").unwrap();
        let depths = DepthList::open(dir.path()).unwrap().unwrap();
        assert_eq!(depths.len(), 2);
        assert_eq!(
            depths.nearest(0.19, 0.02),
            Some(dir.path().join("depth/b.png").as_path())
        );
        assert_eq!(depths.nearest(0.15, 0.02), None);
        std::fs::write(&list, "0.1 depth/a.png\nsoon depth/b.png\n").unwrap();
        let e = DepthList::open(dir.path()).unwrap_err().to_string();
        assert!(e.contains("depth.txt") && e.contains("line 2"), "{e}");
    }

    #[test]
    fn a_map_at_half_the_true_scale_reads_a_ratio_of_one_half() {
        let camera = PinholeCamera::ideal(100.0, 100.0, 49.5, 49.5, 100, 100);
        let dir = tempfile::tempdir().unwrap();
        let path = dir.path().join("d.png");
        // A wall 4 m in front of the camera, which looks along +z from the origin.
        write_depth_png(&path, 100, 100, &vec![4.0; 100 * 100]).unwrap();
        let depth = DepthImage::load(&path, (100, 100)).unwrap();
        let point = |x: f64, y: f64, z: f64| MapPoint {
            id: 0,
            parametrisation: Parametrisation::Euclidean,
            position: [x, y, z],
            covariance: [[0.0; 3]; 3],
            observations: 1,
        };
        // The map's wall is 2 units away; a point behind the camera is not in view.
        let map = [
            point(0.0, 0.0, 2.0),
            point(0.5, -0.3, 2.0),
            point(0.0, 0.0, -2.0),
        ];
        let mut ratios = depth_ratios(&map, &[0.0; 3], &[1.0, 0.0, 0.0, 0.0], &camera, &depth);
        assert_eq!(ratios.len(), 2);
        let [_, median, _] = quartiles(&mut ratios).unwrap();
        assert!((median - 0.5).abs() < 1e-12, "{median}");
    }
}
