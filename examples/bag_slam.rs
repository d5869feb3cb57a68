//! SLAM fed from a ROS 2 bag, as a robot program replaying a recording does: the camera from
//! the bag's CameraInfo, then one Image message at a time, stamped by its header. With no
//! argument the example first records the synthetic drive into `bag_slam.mcap` (in the
//! system's temporary folder) with the library's own MCAP writer:
//! `cargo run --release --example bag_slam [BAG]`.
use std::path::PathBuf;

use steernav::bag::frames::{self, CAMERA_INFO, IMAGE};
use steernav::bag::messages::{CameraInfo, Fixed, Header, Image, RegionOfInterest, Time};
use steernav::bag::write::{camera_info_schema, image_schema, BagWriter};
use steernav::bag::Bag;
use steernav::slam::data::synthetic::{SyntheticConfig, SyntheticMotion, SyntheticSequence};
use steernav::{Backend, Detector, DetectorConfig, Slam, SlamConfig};

/// Records 20 frames of the synthetic drive as rgb8 images with their CameraInfo.
fn record(path: &std::path::Path) -> Result<(), steernav::Error> {
    let rig = SyntheticSequence::new(SyntheticConfig {
        frames: 20,
        ..SyntheticConfig::for_motion(SyntheticMotion::Drive)
    })?;
    let mut bag = BagWriter::create(path)?;
    bag.add_topic("/camera/image_raw", IMAGE, &image_schema())?;
    bag.add_topic("/camera/camera_info", CAMERA_INFO, &camera_info_schema())?;
    let c = &rig.camera;
    for (k, pose) in rig.poses.iter().enumerate() {
        let t = pose.timestamp;
        let header = Header {
            stamp: Time::from_seconds(t),
            frame_id: "camera".into(),
        };
        if k == 0 {
            let info = CameraInfo {
                header: header.clone(),
                height: c.height,
                width: c.width,
                distortion_model: "plumb_bob".into(),
                d: vec![c.k1, c.k2, c.p1, c.p2, c.k3],
                k: Fixed([c.fx, 0.0, c.cx, 0.0, c.fy, c.cy, 0.0, 0.0, 1.0]),
                r: Fixed([1.0, 0.0, 0.0, 0.0, 1.0, 0.0, 0.0, 0.0, 1.0]),
                p: Fixed([
                    c.fx, 0.0, c.cx, 0.0, 0.0, c.fy, c.cy, 0.0, 0.0, 0.0, 1.0, 0.0,
                ]),
                binning_x: 0,
                binning_y: 0,
                roi: RegionOfInterest::default(),
            };
            bag.write("/camera/camera_info", t, &info)?;
        }
        let frame = rig.render(k);
        let image = Image {
            header,
            height: frame.height,
            width: frame.width,
            encoding: "rgb8".into(),
            is_bigendian: 0,
            step: 3 * frame.width,
            data: frame.rgb.clone(),
        };
        bag.write("/camera/image_raw", t, &image)?;
    }
    bag.finish()
}

fn main() -> Result<(), steernav::Error> {
    let path = match std::env::args_os().nth(1) {
        Some(p) => PathBuf::from(p),
        None => {
            let p = std::env::temp_dir().join("bag_slam.mcap");
            record(&p)?;
            println!("recorded {}", p.display());
            p
        }
    };
    let bag = Bag::open(&path)?;
    let topic = frames::image_topic(&bag, None)?;
    let camera = frames::camera(&bag, None)?;
    let detector = Detector::new(&DetectorConfig::tracking(), Backend::Cpu)?;
    let mut slam = Slam::new(camera, SlamConfig::default())?;
    for (k, item) in frames::frames(&bag, &topic.name, 100_000_000).enumerate() {
        let image = item?;
        let report = slam.process(&image.frame, image.timestamp, None, &detector)?;
        let [x, y, z] = report.position;
        println!(
            "frame {k:2} at {:.3} s: position ({x:6.2}, {y:6.2}, {z:6.2}), {} matched{}",
            image.timestamp,
            report.matched,
            if report.lost { ", lost" } else { "" }
        );
    }
    println!(
        "{} landmarks in the map, from {}",
        slam.map().len(),
        topic.name
    );
    Ok(())
}
