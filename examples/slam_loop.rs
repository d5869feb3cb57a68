//! A SLAM frame loop as a robot program runs it: one frame at a time from a camera (here the
//! synthetic drive, rendered in memory), its pose and covariance read back after each frame:
//! `cargo run --release --example slam_loop`.
use steernav::slam::data::synthetic::{SyntheticConfig, SyntheticMotion, SyntheticSequence};
use steernav::{Backend, Detector, DetectorConfig, Slam, SlamConfig};

fn main() -> Result<(), steernav::Error> {
    let camera_rig = SyntheticSequence::new(SyntheticConfig {
        frames: 20,
        ..SyntheticConfig::for_motion(SyntheticMotion::Drive)
    })?;
    let detector = Detector::new(&DetectorConfig::tracking(), Backend::Cpu)?;
    let mut slam = Slam::new(camera_rig.camera.clone(), SlamConfig::default())?;
    for k in 0..camera_rig.poses.len() {
        let frame = camera_rig.render(k);
        let report = slam.process(&frame, camera_rig.poses[k].timestamp, None, &detector)?;
        let [x, y, z] = report.position;
        let sigma = report.position_covariance[2][2].sqrt();
        println!(
            "frame {k:2}: position ({x:6.2}, {y:6.2}, {z:6.2}) ±{sigma:.2} along z, {} matched{}",
            report.matched,
            if report.lost { ", lost" } else { "" }
        );
    }
    println!("{} landmarks in the map", slam.map().len());
    Ok(())
}
