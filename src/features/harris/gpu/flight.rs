//! The frames in flight of the GPU Harris stage: [`FLIGHT_SLOTS`] double-buffered slots a
//! frame is submitted on and later finished from, the slot kept for synchronous runs, and the
//! frame's one readback (the candidate count and strongest response, the timestamps and the
//! first candidates in one buffer, mapped once).

use super::{FrameResources, GpuHarris, GpuTimings, Stats};
use crate::error::{Error, Result};
use crate::features::harris::plan::Tile;
use crate::features::{raised_threshold, sort_candidates, Candidate};
use crate::gpu::util::read_staging_after;

/// Frames that may be in flight at once (double-buffered resources).
pub const FLIGHT_SLOTS: usize = 2;
/// The resources' slot for synchronous runs, apart from the in-flight ones.
pub(super) const SYNC_SLOT: usize = FLIGHT_SLOTS;

/// A frame submitted with [`GpuHarris::submit`], to be read with [`GpuHarris::finish`].
#[must_use = "a submitted frame holds its slot until it is finished"]
pub struct PendingFrame {
    slot: usize,
    tile: Tile,
    work: Pending,
}

pub(super) type HarrisResult = (Vec<Candidate>, f32, Option<GpuTimings>);

enum Pending {
    Submitted(wgpu::SubmissionIndex),
    Done(HarrisResult),
}

/// What one tile's run found.
pub(super) struct TileRun {
    pub(super) candidates: Vec<Candidate>,
    /// The tile's strongest response.
    pub(super) strongest: f32,
    /// The threshold the tile ended at.
    pub(super) threshold: f32,
    /// The highest threshold at which the tile held more than `candidate_capacity`
    /// candidates (−∞ when it never did): the frame's final threshold lies above it.
    pub(super) overflowed_at: f32,
    pub(super) timings: Option<GpuTimings>,
}

impl GpuHarris {
    /// One tile (or the whole frame) through every pass and its readback, on the slot kept
    /// for synchronous runs.
    pub(super) fn run_tile(&self, gray: &[f32], tile: &Tile) -> Result<TileRun> {
        // Without it, a second thread's frame could be uploaded and submitted on the same
        // resources between this one's submission and its readback: this thread would read
        // the other frame's candidates, or wait for ever on a readback whose mapping waits for
        // the other submission while that thread waits for `frames` (one detector shared by
        // four Python threads hung about once in 15–60 runs).
        let _serial = self.sync_slot.lock().unwrap_or_else(|e| e.into_inner());
        let (submission, slot) = self.submit_tile(gray, tile, SYNC_SLOT)?;
        self.finish_tile(tile, slot, submission)
    }

    /// Uploads a tile and submits every pass and the copy into the readback, without waiting.
    fn submit_tile(
        &self,
        gray: &[f32],
        tile: &Tile,
        slot: usize,
    ) -> Result<(wgpu::SubmissionIndex, usize)> {
        let (width, height) = tile.size;
        let mut frames = self.frames.lock().unwrap_or_else(|e| e.into_inner());
        let f = self.select_frame(&mut frames, width, height, slot)?;
        let device = &self.ctx.device;
        self.upload(f, gray);
        let config = &self.plan.config;
        self.set_threshold(f, config.threshold, config.relative_threshold, tile);
        let mut enc = device.create_command_encoder(&Default::default());
        self.encode_responses(&mut enc, f, self.plan.scales.len() - 1, false);
        self.encode_nms(&mut enc, f);
        if let Some((set, resolve)) = &f.queries {
            enc.resolve_query_set(set, 0..8 * self.plan.scales.len() as u32, resolve, 0);
            let l = &f.layout;
            enc.copy_buffer_to_buffer(resolve, 0, &f.readback, l.timestamps_at, None);
        }
        Ok((self.ctx.queue.submit([enc.finish()]), slot))
    }

    /// Waits for a submitted tile, maps its readback once, and re-runs the suppression with a
    /// raised threshold while more than `candidate_capacity` candidates survive (the
    /// responses are still in place: the slot is not reused before this returns).
    fn finish_tile(
        &self,
        tile: &Tile,
        slot: usize,
        submission: wgpu::SubmissionIndex,
    ) -> Result<TileRun> {
        let (width, height) = tile.size;
        let mut frames = self.frames.lock().unwrap_or_else(|e| e.into_inner());
        let f = self.select_frame(&mut frames, width, height, slot)?;
        let device = &self.ctx.device;
        let queue = &self.ctx.queue;
        let config = &self.plan.config;
        let mut back = read_back(device, f, submission)?;
        let strongest = back.strongest;
        let timings = f.queries.as_ref().map(|_| self.timings(&back.timestamps));
        let mut threshold = config.effective_threshold(strongest);
        let capacity = config.candidate_capacity;
        let mut overflowed_at = f32::NEG_INFINITY;
        while back.count > capacity {
            overflowed_at = threshold;
            threshold = raised_threshold(threshold);
            self.set_threshold(f, threshold, 0.0, tile);
            let mut enc = device.create_command_encoder(&Default::default());
            self.encode_nms(&mut enc, f);
            back = read_back(device, f, queue.submit([enc.finish()]))?;
        }
        let mut candidates = back.candidates;
        let held = f.layout.candidates;
        if back.count as u64 > held {
            let bytes = (back.count as u64 - held) * 16;
            let mut enc = device.create_command_encoder(&Default::default());
            enc.copy_buffer_to_buffer(&f.candidates, held * 16, &f.candidate_staging, 0, bytes);
            let raw = read_staging_after(
                device,
                &f.candidate_staging,
                bytes,
                Some(queue.submit([enc.finish()])),
            )?;
            candidates.extend(bytemuck::pod_collect_to_vec::<u8, Candidate>(&raw));
        }
        Ok(TileRun {
            candidates,
            strongest,
            threshold,
            overflowed_at,
            timings,
        })
    }

    /// Submits a frame's passes on one of [`FLIGHT_SLOTS`] double-buffered slots and returns
    /// at once; [`Self::finish`] reads the candidates. With two frames submitted, the GPU works
    /// on the second while the caller reads and merges the first. A frame that needs tiles
    /// runs synchronously here and `finish` only hands its result over.
    pub fn submit(&self, gray: &[f32], width: u32, height: u32) -> Result<PendingFrame> {
        let tiles = self.tiles(width, height)?;
        let slot = {
            let mut busy = self.busy.lock().unwrap_or_else(|e| e.into_inner());
            let free = (0..FLIGHT_SLOTS).find(|&s| !busy[s]).ok_or_else(|| Error::Gpu {
                operation: format!(
                    "submitting a frame: {FLIGHT_SLOTS} frames are already in flight; finish one first"
                ),
                source: None,
            })?;
            busy[free] = true;
            free
        };
        let release = |r: Result<PendingFrame>| {
            if r.is_err() {
                self.busy.lock().unwrap_or_else(|e| e.into_inner())[slot] = false;
            }
            r
        };
        if let [tile] = tiles[..] {
            release(
                self.submit_tile(gray, &tile, slot)
                    .map(|(submission, slot)| PendingFrame {
                        slot,
                        tile,
                        work: Pending::Submitted(submission),
                    }),
            )
        } else {
            let done = self.run_tiles(gray, width, &tiles);
            release(done.map(|result| PendingFrame {
                slot,
                tile: tiles[0],
                work: Pending::Done(result),
            }))
        }
    }

    /// The candidates of a submitted frame, as [`Self::candidates`] gives them.
    pub fn finish(
        &self,
        pending: PendingFrame,
    ) -> Result<(Vec<Candidate>, f32, Option<GpuTimings>)> {
        let PendingFrame { slot, tile, work } = pending;
        let result = match work {
            Pending::Done(result) => Ok(result),
            Pending::Submitted(submission) => {
                self.finish_tile(&tile, slot, submission).map(|run| {
                    let mut list = run.candidates;
                    sort_candidates(&mut list);
                    (list, run.threshold, run.timings)
                })
            }
        };
        self.busy.lock().unwrap_or_else(|e| e.into_inner())[slot] = false;
        result
    }
}

/// Candidates copied into the readback with the count: enough for a 1920×1080 frame at the
/// defaults (about 30,000), 512 KiB.
pub(super) const READBACK_CANDIDATES: u64 = 32_768;

/// Where each part lies in a frame's readback buffer.
#[derive(Clone, Copy, Debug)]
pub(super) struct ReadbackLayout {
    pub(super) timestamps_at: u64,
    pub(super) timestamp_bytes: u64,
    pub(super) candidates_at: u64,
    /// Candidates the readback holds.
    pub(super) candidates: u64,
}

impl ReadbackLayout {
    pub(super) fn new(timestamp_bytes: u64, candidates: u64) -> Self {
        Self {
            timestamps_at: 16,
            timestamp_bytes,
            candidates_at: 16 + timestamp_bytes,
            candidates,
        }
    }

    pub(super) fn size(&self) -> u64 {
        self.candidates_at + self.candidates * 16
    }
}

/// What one map of a frame's readback gives.
struct Readback {
    count: usize,
    strongest: f32,
    timestamps: Vec<u8>,
    /// The first min(count, layout.candidates) candidates.
    candidates: Vec<Candidate>,
}

/// Maps the readback once `submission` has run.
fn read_back(
    device: &wgpu::Device,
    f: &FrameResources,
    submission: wgpu::SubmissionIndex,
) -> Result<Readback> {
    let l = &f.layout;
    let raw = read_staging_after(device, &f.readback, l.size(), Some(submission))?;
    let stats: Stats = bytemuck::pod_read_unaligned(&raw[..8]);
    let count = stats.count as usize;
    let held = (count as u64).min(l.candidates) as usize;
    let at = l.candidates_at as usize;
    Ok(Readback {
        count,
        strongest: f32::from_bits(stats.peak_bits),
        timestamps: raw[l.timestamps_at as usize..(l.timestamps_at + l.timestamp_bytes) as usize]
            .to_vec(),
        candidates: bytemuck::pod_collect_to_vec(&raw[at..at + held * 16]),
    })
}
