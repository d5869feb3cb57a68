//! One wgpu device, created and owned by the application, shared by the detector and GIST:
//! the application hands it to steernav with `GpuContext::from_device`, and each stage
//! compiles its own pipelines on it the first time it runs:
//! `cargo run --release --example shared_device`.
use std::sync::Arc;

use steernav::nav::gist::{GistConfig, GpuGist};
use steernav::GpuContext;
use steernav::{Detector, DetectorConfig};

fn main() -> Result<(), Box<dyn std::error::Error>> {
    // The application's own device (a renderer or another compute job would use it too).
    let instance = wgpu::Instance::new(wgpu::InstanceDescriptor::new_without_display_handle());
    let adapter = match pollster::block_on(instance.request_adapter(&Default::default())) {
        Ok(adapter) => adapter,
        Err(e) => {
            println!("no GPU adapter here ({e}); nothing to share");
            return Ok(());
        }
    };
    let (device, queue) = pollster::block_on(adapter.request_device(&wgpu::DeviceDescriptor {
        label: Some("application"),
        required_limits: adapter.limits(),
        ..Default::default()
    }))?;
    let context = Arc::new(GpuContext::from_device(device, queue, adapter.get_info()));

    let frame = steernav::low_level::synth::textured_scene(320, 240, 5);
    let detector = Detector::with_context(Arc::clone(&context), &DetectorConfig::default())?;
    let found = detector.detect(&frame)?;
    let mut gist = GpuGist::new(Arc::clone(&context), GistConfig::default())?;
    let descriptor = gist.describe_batch(std::slice::from_ref(&frame))?;
    println!(
        "on {}: {} keypoints ({} backend) and a GIST of {} values, one device",
        context.info.name,
        found.keypoints.len(),
        found.backend,
        descriptor[0].len()
    );
    Ok(())
}
