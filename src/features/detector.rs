//! The detector pipeline of section 2.2–2.3 behind one API, on either backend:
//! Harris candidates (GPU or CPU) → two-stage merge (CPU) → descriptors (CPU).

use std::sync::Arc;

use rayon::prelude::*;
use std::time::Instant;

use serde::{Deserialize, Serialize};

use super::config::{DescriptorKind, DetectorConfig};
use super::descriptor::describe;
use super::harris::plan::{descriptor_level, detection_scale, plane_blur, total_scale};
use super::harris::HarrisPlan;
use super::harris::{CpuHarris, CpuTimings};
use super::merge::merge;
use super::pyramid::Pyramid;
use super::steered::cpu::{describe_steered_blurred, describe_steered_twin_blurred};
use super::steered::gpu::{Plane, PlanePoint};
use super::steered::GpuSteered;
use super::{Candidate, Keypoint};
use crate::error::{Error, Result};
use crate::features::harris::gpu::PendingFrame;
use crate::features::harris::{GpuHarris, GpuTimings};
use crate::gpu::GpuContext;
use crate::image::Frame;

/// A frame and its detection, or why there is none.
type FrameResult = Result<(Frame, Detection)>;

/// Where the heavy image work runs.
#[derive(Clone, Copy, Debug, PartialEq, Eq, Serialize, Deserialize)]
#[serde(rename_all = "lowercase")]
pub enum Backend {
    /// A hardware GPU when one exists, else the CPU (a `log` warning says why).
    Auto,
    /// WGSL compute shaders through wgpu; an error when no adapter exists.
    Gpu,
    /// The rayon reference implementation.
    Cpu,
}

named_variants!(Backend { Auto => "auto", Gpu => "gpu", Cpu => "cpu" });

impl Backend {
    /// The one place a backend choice becomes a GPU context or the CPU, for every stage (the
    /// detector, GIST, the neural field, the benches, the Python bindings): `Cpu` gives
    /// `None`; `Gpu` the process-wide context ([`GpuContext::shared`]), an error when no
    /// adapter exists; `Auto` the shared context when its adapter is a hardware GPU, otherwise
    /// `None`, saying why in a `log` warning, once per process.
    pub fn resolve(self) -> Result<Option<Arc<GpuContext>>> {
        match self {
            Backend::Cpu => Ok(None),
            Backend::Gpu => GpuContext::shared().map(Some),
            Backend::Auto => match crate::gpu::context::auto_context() {
                Ok(ctx) => Ok(Some(ctx)),
                Err(reason) => {
                    static WARNED: std::sync::Once = std::sync::Once::new();
                    WARNED.call_once(|| log::warn!("{reason}; using the CPU backend"));
                    Ok(None)
                }
            },
        }
    }

    /// The backend a resolved context runs on: `Gpu` with one, `Cpu` without.
    pub fn of(context: Option<&Arc<GpuContext>>) -> Self {
        if context.is_some() {
            Backend::Gpu
        } else {
            Backend::Cpu
        }
    }
}

/// Wall-clock and GPU timings of one detection.
#[derive(Clone, Debug, Default, PartialEq)]
pub struct StageTimings {
    /// Harris stage including upload and readback (wall clock).
    pub harris_ms: f64,
    /// Two-stage merge.
    pub merge_ms: f64,
    /// Descriptors.
    pub descriptor_ms: f64,
    /// Per-stage GPU time from timestamp queries, when the GPU ran with them.
    pub gpu: Option<GpuTimings>,
    /// The CPU Harris stage's parts, when the CPU ran.
    pub cpu: Option<CpuTimings>,
}

/// The Harris stage's output for one frame.
#[derive(Clone, Debug)]
pub struct HarrisRun {
    /// Candidates, strongest first.
    pub candidates: Vec<Candidate>,
    /// The threshold finally applied.
    pub threshold: f32,
    /// Where it ran: [`Backend::Gpu`] or [`Backend::Cpu`].
    pub backend: Backend,
    /// GPU stage times (timestamp queries), when the GPU ran with them.
    pub gpu: Option<GpuTimings>,
    /// CPU stage times, when the CPU ran.
    pub cpu: Option<CpuTimings>,
}

/// The result of detecting on one frame.
#[derive(Clone, Debug)]
pub struct Detection {
    /// Keypoints, highest rank first (response weighted by the ranking normalisation).
    pub keypoints: Vec<Keypoint>,
    /// Number of Harris candidates that were merged.
    pub candidates: usize,
    /// The response threshold finally applied (raised when the candidate list overflowed).
    pub threshold: f32,
    /// Number of keypoints whose dominant scale is each detection scale.
    pub scale_histogram: Vec<usize>,
    /// Where it ran: [`Backend::Gpu`] or [`Backend::Cpu`].
    pub backend: Backend,
    /// The descriptor the keypoints carry.
    pub descriptor: DescriptorKind,
    /// Timings.
    pub timings: StageTimings,
}

/// A configured detector; create once, call [`Detector::detect`] on many frames.
pub struct Detector {
    plan: HarrisPlan,
    cpu: CpuHarris,
    gpu: Option<GpuHarris>,
    /// The steered descriptor's GPU twin, beside the GPU Harris stage.
    gpu_steered: Option<GpuSteered>,
    fallback: bool,
}

impl Detector {
    /// Validates the configuration and sets up the backend on the process-wide context
    /// ([`GpuContext::shared`]). `Auto` takes a hardware GPU only and otherwise runs on the CPU,
    /// saying why in a `log` warning; `Gpu` is an error when no adapter exists.
    pub fn new(config: &DetectorConfig, backend: Backend) -> Result<Self> {
        config.validate()?;
        let plan = HarrisPlan::new(config);
        let gpu = backend
            .resolve()?
            .map(|ctx| GpuHarris::new(ctx, plan.clone()));
        Ok(Self {
            cpu: CpuHarris::new(plan.clone()),
            gpu_steered: gpu.as_ref().map(|g| GpuSteered::new(g.context().clone())),
            plan,
            gpu,
            fallback: backend == Backend::Auto,
        })
    }

    /// A detector on a GPU context the caller owns (see [`GpuContext::from_device`]), for a
    /// program that shares one wgpu device between steernav and its own work. Frames too large
    /// for the device are an error, as with [`Backend::Gpu`].
    pub fn with_context(context: Arc<GpuContext>, config: &DetectorConfig) -> Result<Self> {
        config.validate()?;
        let plan = HarrisPlan::new(config);
        Ok(Self {
            cpu: CpuHarris::new(plan.clone()),
            gpu_steered: Some(GpuSteered::new(context.clone())),
            gpu: Some(GpuHarris::new(context, plan.clone())),
            plan,
            fallback: false,
        })
    }

    /// The plan (kernels, scales, orientations) this detector runs.
    pub fn plan(&self) -> &HarrisPlan {
        &self.plan
    }

    /// The configuration.
    pub fn config(&self) -> &DetectorConfig {
        &self.plan.config
    }

    /// [`Backend::Gpu`] or [`Backend::Cpu`]: where frames go by default.
    pub fn backend(&self) -> Backend {
        if self.gpu.is_some() {
            Backend::Gpu
        } else {
            Backend::Cpu
        }
    }

    /// The GPU stage, when this detector runs on the GPU.
    pub fn gpu(&self) -> Option<&GpuHarris> {
        self.gpu.as_ref()
    }

    /// The CPU stage (always available: it is the reference).
    pub fn cpu(&self) -> &CpuHarris {
        &self.cpu
    }

    /// Checks that frames of this size can be processed (GPU limits), allocating nothing.
    pub fn check_size(&self, width: u32, height: u32) -> Result<()> {
        crate::image::check_size("image", width, height)?;
        match &self.gpu {
            Some(g) => g.check_frame(width, height),
            None => Ok(()),
        }
    }

    /// Harris candidates of a frame, sorted strongest first, with the threshold used, the
    /// backend that ran and its stage timings.
    pub fn candidates(&self, frame: &Frame) -> Result<HarrisRun> {
        self.run_harris(frame).map(|(run, _)| run)
    }

    /// The Harris stage, and the CPU pyramid when the CPU ran it (the descriptors reuse it).
    fn run_harris<'f>(&self, frame: &'f Frame) -> Result<(HarrisRun, Option<Pyramid<'f>>)> {
        crate::image::check_size("image", frame.width, frame.height)?;
        if let Some(g) = &self.gpu {
            match g.candidates(&frame.gray, frame.width, frame.height) {
                Ok((candidates, threshold, gpu)) => {
                    let run = HarrisRun {
                        candidates,
                        threshold,
                        backend: Backend::Gpu,
                        gpu,
                        cpu: None,
                    };
                    return Ok((run, None));
                }
                Err(Error::GpuLimit(msg)) if self.fallback => {
                    log::warn!("{msg}; this image goes to the CPU backend");
                }
                Err(e) => return Err(e),
            }
        }
        let pyramid = self.pyramid(frame);
        Ok((self.cpu_candidates(&pyramid), Some(pyramid)))
    }

    /// Keypoints with descriptors of one frame.
    pub fn detect(&self, frame: &Frame) -> Result<Detection> {
        let t0 = Instant::now();
        let (run, pyramid) = self.run_harris(frame)?;
        self.complete(frame, run, t0, pyramid.as_ref())
    }

    /// The pyramid of a frame with the plan's kernels.
    fn pyramid<'f>(&self, frame: &'f Frame) -> Pyramid<'f> {
        let (w, h) = (frame.width as usize, frame.height as usize);
        Pyramid::new(&frame.gray, w, h, &self.plan.pyramid)
    }

    /// Detects on a stream of frames, in order, with two frames in flight on the GPU: the
    /// passes of the next frame run while this one's candidates are read back, merged and
    /// described, and nothing waits on the device between frames. On the CPU, as many frames
    /// run at once as rayon has threads. Each item carries a tag (an index, a path) and a
    /// frame or the error that stopped its decoding, which `done` receives unchanged, in
    /// order. Results are those of [`Self::detect`] frame by frame.
    pub fn detect_stream<T>(
        &self,
        items: impl IntoIterator<Item = (T, Result<Frame>)>,
        mut done: impl FnMut(T, Result<(Frame, Detection)>),
    ) {
        let Some(g) = &self.gpu else {
            // On the CPU, as many frames at once as there are threads: each frame's own
            // parallel passes leave cores idle in their serial parts (merge, sorting). The
            // next window is detected on another thread while `done` takes this one's
            // results here (writing a frame's JSON took the cores' time before).
            let window = rayon::current_num_threads().max(1);
            let mut items = items.into_iter();
            let mut finished: Option<(Vec<T>, Vec<FrameResult>)> = None;
            loop {
                let (tags, frames): (Vec<T>, Vec<Result<Frame>>) =
                    items.by_ref().take(window).unzip();
                let detected = std::thread::scope(|scope| {
                    let worker = (!frames.is_empty()).then(|| {
                        scope.spawn(|| {
                            frames
                                .into_par_iter()
                                .map(|frame| frame.and_then(|f| self.detect(&f).map(|d| (f, d))))
                                .collect::<Vec<FrameResult>>()
                        })
                    });
                    if let Some((tags, results)) = finished.take() {
                        for (tag, result) in tags.into_iter().zip(results) {
                            done(tag, result);
                        }
                    }
                    worker.map(|w| w.join().unwrap_or_else(|p| std::panic::resume_unwind(p)))
                });
                match detected {
                    Some(results) => finished = Some((tags, results)),
                    None => return,
                }
            }
        };
        type Waiting<T> = (T, Frame, Instant, Result<PendingFrame>);
        let complete = |(tag, frame, t0, pending): Waiting<T>| {
            let run = pending
                .and_then(|p| g.finish(p))
                .map(|(candidates, threshold, gpu)| HarrisRun {
                    candidates,
                    threshold,
                    backend: Backend::Gpu,
                    gpu,
                    cpu: None,
                });
            let result = match run {
                Err(Error::GpuLimit(msg)) if self.fallback => {
                    log::warn!("{msg}; this image goes to the CPU backend");
                    let pyramid = self.pyramid(&frame);
                    let run = self.cpu_candidates(&pyramid);
                    self.complete(&frame, run, t0, Some(&pyramid))
                }
                other => other.and_then(|run| self.complete(&frame, run, t0, None)),
            };
            (tag, result.map(|d| (frame, d)))
        };
        let mut waiting: Option<Waiting<T>> = None;
        for (tag, frame) in items {
            let frame = match frame {
                Ok(f) => f,
                Err(e) => {
                    if let Some(w) = waiting.take() {
                        let (t, r) = complete(w);
                        done(t, r);
                    }
                    done(tag, Err(e));
                    continue;
                }
            };
            let t0 = Instant::now();
            let pending = crate::image::check_size("image", frame.width, frame.height)
                .and_then(|_| g.submit(&frame.gray, frame.width, frame.height));
            if let Some(w) = waiting.take() {
                let (t, r) = complete(w);
                done(t, r);
            }
            waiting = Some((tag, frame, t0, pending));
        }
        if let Some(w) = waiting.take() {
            let (t, r) = complete(w);
            done(t, r);
        }
    }

    /// The CPU Harris stage on a frame's pyramid, as a [`HarrisRun`].
    fn cpu_candidates(&self, pyramid: &Pyramid) -> HarrisRun {
        let (candidates, threshold, cpu) = self.cpu.candidates_on(pyramid);
        HarrisRun {
            candidates,
            threshold,
            backend: Backend::Cpu,
            gpu: None,
            cpu: Some(cpu),
        }
    }

    /// Steered descriptors of `keypoints`, each read on its scale's pyramid level
    /// ([`descriptor_level`]), on the GPU when the candidates came from it; with `twin`, in
    /// the frames of both orientation peaks (`steered-twin`, on the CPU).
    fn describe_steered(
        &self,
        frame: &Frame,
        backend: Backend,
        keypoints: &mut [Keypoint],
        pyramid: Option<&Pyramid>,
        twin: bool,
    ) -> Result<()> {
        let built;
        let pyramid = match pyramid {
            Some(p) => p,
            None => {
                built = self.pyramid(frame);
                &built
            }
        };
        let top = pyramid.levels() as u32 - 1;
        let blur = self.plan.config.image_blur;
        let on_level = |k: &Keypoint| {
            let level = descriptor_level(detection_scale(k.scale, blur)).min(top);
            let f = (1u32 << level) as f32;
            (
                level,
                (k.x / f, k.y / f, k.scale / f),
                plane_blur(level, blur),
            )
        };
        match (&self.gpu_steered, backend) {
            (Some(g), Backend::Gpu) if !twin => {
                let planes: Vec<Plane> = (0..=top)
                    .map(|level| {
                        let (gray, lw, lh) = pyramid.level(level);
                        Plane {
                            gray,
                            width: lw as u32,
                            height: lh as u32,
                            prior_blur: plane_blur(level, blur),
                        }
                    })
                    .collect();
                let points: Vec<PlanePoint> = keypoints
                    .iter()
                    .map(|k| {
                        let (level, point, _) = on_level(k);
                        (level as usize, point)
                    })
                    .collect();
                let described = g.describe_planes(&planes, &points)?;
                for (k, d) in keypoints.iter_mut().zip(described) {
                    k.descriptor = d.values;
                }
            }
            _ => keypoints.par_iter_mut().for_each(|k| {
                let (level, point, blur) = on_level(k);
                let (plane, lw, lh) = pyramid.level(level);
                k.descriptor = if twin {
                    let (first, second) = describe_steered_twin_blurred(plane, lw, lh, point, blur);
                    let second = second.map_or_else(|| first.values.clone(), |s| s.values);
                    [first.values, second].concat()
                } else {
                    describe_steered_blurred(plane, lw, lh, point, blur).values
                };
            }),
        }
        Ok(())
    }

    /// Merge and descriptors after the Harris stage; `t0` is when the frame's Harris began.
    fn complete(
        &self,
        frame: &Frame,
        run: HarrisRun,
        t0: Instant,
        pyramid: Option<&Pyramid>,
    ) -> Result<Detection> {
        let HarrisRun {
            candidates,
            threshold,
            backend,
            gpu,
            cpu,
        } = run;
        let t1 = Instant::now();
        let clusters = merge(&candidates, &self.plan);
        let t2 = Instant::now();
        let mut scale_histogram = vec![0; self.plan.scales.len()];
        for c in &clusters {
            scale_histogram[c.scale_index] += 1;
        }
        let kind = self.plan.config.descriptor;
        let mut keypoints: Vec<Keypoint> = clusters
            .iter()
            .map(|c| Keypoint {
                x: c.x,
                y: c.y,
                scale: total_scale(
                    self.plan.scales[c.scale_index].sigma_d
                        * self.plan.config.scale_step.powf(c.scale_offset),
                    self.plan.config.image_blur,
                ),
                angle: self.plan.orientations[c.orientation_index],
                response: c.response,
                descriptor: Vec::new(),
            })
            .collect();
        // Descriptors on the backend that found the candidates; a steered descriptor is read
        // on the pyramid level where its window has a few pixels per cell.
        match kind {
            DescriptorKind::Steered | DescriptorKind::SteeredTwin => {
                let twin = kind == DescriptorKind::SteeredTwin;
                self.describe_steered(frame, backend, &mut keypoints, pyramid, twin)?;
            }
            DescriptorKind::Entropy => keypoints.par_iter_mut().for_each(|k| {
                k.descriptor = describe(frame, k.x, k.y).to_vec();
            }),
            DescriptorKind::None => {}
        }
        let t3 = Instant::now();
        let ms = |a: Instant, b: Instant| (b - a).as_secs_f64() * 1e3;
        Ok(Detection {
            keypoints,
            candidates: candidates.len(),
            threshold,
            scale_histogram,
            backend,
            descriptor: kind,
            timings: StageTimings {
                harris_ms: ms(t0, t1),
                merge_ms: ms(t1, t2),
                descriptor_ms: ms(t2, t3),
                gpu,
                cpu,
            },
        })
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn the_cpu_backend_resolves_to_no_context_and_results_name_it() {
        assert!(Backend::Cpu.resolve().unwrap().is_none());
        assert_eq!(Backend::of(None), Backend::Cpu);
        let detector = Detector::new(&DetectorConfig::default(), Backend::Cpu).unwrap();
        assert_eq!(detector.backend(), Backend::Cpu);
        let frame = crate::synth::textured_scene(96, 64, 2);
        assert_eq!(detector.detect(&frame).unwrap().backend.as_str(), "cpu");
    }
}
