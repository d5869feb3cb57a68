//! Small helpers for buffers, bind groups and readback shared by every GPU stage.

use wgpu::util::DeviceExt;

use crate::error::{Error, Result};

/// A storage buffer of `bytes` bytes (at least 4), readable by copies.
pub fn storage(device: &wgpu::Device, label: &str, bytes: u64) -> wgpu::Buffer {
    device.create_buffer(&wgpu::BufferDescriptor {
        label: Some(label),
        size: bytes.max(4).next_multiple_of(4),
        usage: wgpu::BufferUsages::STORAGE
            | wgpu::BufferUsages::COPY_SRC
            | wgpu::BufferUsages::COPY_DST,
        mapped_at_creation: false,
    })
}

/// A read-only storage buffer initialised with `data`.
pub fn storage_init<T: bytemuck::Pod>(
    device: &wgpu::Device,
    label: &str,
    data: &[T],
) -> wgpu::Buffer {
    let bytes: &[u8] = bytemuck::cast_slice(data);
    let padded;
    let contents = if bytes.is_empty() {
        padded = [0u8; 4];
        &padded[..]
    } else {
        bytes
    };
    device.create_buffer_init(&wgpu::util::BufferInitDescriptor {
        label: Some(label),
        contents,
        usage: wgpu::BufferUsages::STORAGE | wgpu::BufferUsages::COPY_DST,
    })
}

/// A uniform buffer initialised with `value`.
pub fn uniform<T: bytemuck::Pod>(device: &wgpu::Device, label: &str, value: &T) -> wgpu::Buffer {
    device.create_buffer_init(&wgpu::util::BufferInitDescriptor {
        label: Some(label),
        contents: bytemuck::bytes_of(value),
        usage: wgpu::BufferUsages::UNIFORM | wgpu::BufferUsages::COPY_DST,
    })
}

/// A MAP_READ staging buffer.
pub fn staging(device: &wgpu::Device, label: &str, bytes: u64) -> wgpu::Buffer {
    device.create_buffer(&wgpu::BufferDescriptor {
        label: Some(label),
        size: bytes.max(4).next_multiple_of(4),
        usage: wgpu::BufferUsages::MAP_READ | wgpu::BufferUsages::COPY_DST,
        mapped_at_creation: false,
    })
}

/// A bind group for group 0 of `pipeline`, binding `buffers[i]` at binding i.
pub fn bind(
    device: &wgpu::Device,
    pipeline: &wgpu::ComputePipeline,
    buffers: &[&wgpu::Buffer],
) -> wgpu::BindGroup {
    let entries: Vec<wgpu::BindGroupEntry> = buffers
        .iter()
        .enumerate()
        .map(|(i, b)| wgpu::BindGroupEntry {
            binding: i as u32,
            resource: b.as_entire_binding(),
        })
        .collect();
    device.create_bind_group(&wgpu::BindGroupDescriptor {
        label: None,
        layout: &pipeline.get_bind_group_layout(0),
        entries: &entries,
    })
}

/// A bind group for group 0 of `pipeline` with each buffer at its given binding number (for
/// entry points that use only some bindings of a shared shader module).
pub fn bind_at(
    device: &wgpu::Device,
    pipeline: &wgpu::ComputePipeline,
    entries: &[(u32, &wgpu::Buffer)],
) -> wgpu::BindGroup {
    let entries: Vec<wgpu::BindGroupEntry> = entries
        .iter()
        .map(|(binding, buffer)| wgpu::BindGroupEntry {
            binding: *binding,
            resource: buffer.as_entire_binding(),
        })
        .collect();
    device.create_bind_group(&wgpu::BindGroupDescriptor {
        label: None,
        layout: &pipeline.get_bind_group_layout(0),
        entries: &entries,
    })
}

/// Maps the first `bytes` bytes of a staging buffer (after the submission that filled it),
/// copies them out and unmaps.
pub fn read_staging(device: &wgpu::Device, buffer: &wgpu::Buffer, bytes: u64) -> Result<Vec<u8>> {
    read_staging_after(device, buffer, bytes, None)
}

/// Longest wait for a readback's mapping callback once the device is idle.
const MAP_CALLBACK_TIMEOUT: std::time::Duration = std::time::Duration::from_secs(10);

/// [`read_staging`] waiting only for `submission` (the latest when `None`): work submitted
/// after it, such as the next frame, keeps running.
pub fn read_staging_after(
    device: &wgpu::Device,
    buffer: &wgpu::Buffer,
    bytes: u64,
    submission: Option<wgpu::SubmissionIndex>,
) -> Result<Vec<u8>> {
    if bytes == 0 {
        return Ok(Vec::new());
    }
    let slice = buffer.slice(..bytes);
    let (tx, rx) = std::sync::mpsc::channel();
    slice.map_async(wgpu::MapMode::Read, move |r| {
        let _ = tx.send(r);
    });
    let wait = |submission_index| {
        device
            .poll(wgpu::PollType::Wait {
                submission_index,
                timeout: None,
            })
            .map_err(|e| gpu_error("waiting for the device", e))
    };
    wait(submission)?;
    // The mapping completes once every submission that uses the buffer has run, which may be
    // a later one than `submission`; then wait for all of them. Blocking on the channel
    // alone would hang whenever no other thread polls the device; and with the device idle
    // the callback may still be on its way from another thread's poll, which runs callbacks
    // after it returns the device. So poll again between short waits, for a bounded time.
    let mapped = match rx.try_recv() {
        Ok(mapped) => mapped,
        Err(_) => {
            let mut waited = std::time::Duration::ZERO;
            let slice_of_wait = std::time::Duration::from_millis(5);
            loop {
                wait(None)?;
                match rx.recv_timeout(slice_of_wait) {
                    Ok(mapped) => break mapped,
                    Err(e) if waited >= MAP_CALLBACK_TIMEOUT => {
                        return Err(gpu_error(
                            "the readback was still not mapped with the device idle",
                            e,
                        ))
                    }
                    Err(_) => waited += slice_of_wait,
                }
            }
        }
    };
    mapped.map_err(|e| gpu_error("mapping the readback buffer", e))?;
    let data = slice
        .get_mapped_range()
        .map_err(|e| gpu_error("reading the mapped range", e))?
        .to_vec();
    buffer.unmap();
    Ok(data)
}

/// Reads a whole storage buffer back (tests and inspection; the detector reads back only its
/// candidate list).
pub fn read_storage(
    device: &wgpu::Device,
    queue: &wgpu::Queue,
    buffer: &wgpu::Buffer,
) -> Result<Vec<f32>> {
    let stage = staging(device, "inspect", buffer.size());
    let mut enc = device.create_command_encoder(&Default::default());
    enc.copy_buffer_to_buffer(buffer, 0, &stage, 0, None);
    queue.submit([enc.finish()]);
    let bytes = read_staging(device, &stage, buffer.size())?;
    Ok(bytemuck::pod_collect_to_vec(&bytes))
}

/// Workgroups of 16×16 covering a `width`×`height` plane.
pub fn groups_2d(width: u32, height: u32) -> (u32, u32) {
    (width.div_ceil(16), height.div_ceil(16))
}

/// An [`Error::Gpu`] for `operation`, keeping wgpu's error as its source.
pub fn gpu_error(operation: &str, source: impl std::error::Error + Send + Sync + 'static) -> Error {
    Error::Gpu {
        operation: format!("{operation}: {source}"),
        source: Some(Box::new(source)),
    }
}
