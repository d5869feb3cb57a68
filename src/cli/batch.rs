//! `steernav batch`: detection over a directory tree: images decoded on CPU threads while the detector
//! (GPU or CPU) works, one JSON per image written atomically, a summary CSV, re-runs skip what
//! is done, unreadable files are reported and skipped without stopping the batch.

use std::path::{Path, PathBuf};
use std::process::ExitCode;
use std::sync::atomic::{AtomicUsize, Ordering};
use std::sync::mpsc::sync_channel;

use steernav::error::{Error, Result};
use steernav::features::Detector;
use steernav::image::Frame;
use steernav::low_level::shard::Shard;
use steernav::output::{write_atomic, ImageKeypoints};

use clap::Args;

use crate::args::DetectorArgs;

/// File extensions the batch picks up (case-insensitive).
pub const IMAGE_EXTENSIONS: [&str; 9] = [
    "png", "jpg", "jpeg", "ppm", "pgm", "pnm", "tif", "tiff", "bmp",
];

/// Whether a path looks like an image the batch should process.
pub fn is_image(path: &Path) -> bool {
    path.extension()
        .and_then(|e| e.to_str())
        .is_some_and(|e| IMAGE_EXTENSIONS.contains(&e.to_ascii_lowercase().as_str()))
}

/// Every image under `dir`, recursively, sorted by path, leaving out the tree under `output`
/// (a batch writing into its own input must not take its drawn PNGs for inputs on a re-run).
/// Entries that cannot be read (a dangling symlink, a folder without permission) are named in
/// a warning, not dropped in silence.
pub fn list_images(dir: &Path, output: &Path) -> Result<Vec<PathBuf>> {
    if !dir.is_dir() {
        return Err(Error::Io {
            path: dir.to_path_buf(),
            source: std::io::Error::new(std::io::ErrorKind::NotFound, "not a directory"),
        });
    }
    let output = output.canonicalize().ok();
    if output.is_some() && output == dir.canonicalize().ok() {
        // The walk leaves the output folder out, so the input would be left out whole.
        return Err(Error::Io {
            path: dir.to_path_buf(),
            source: std::io::Error::new(
                std::io::ErrorKind::InvalidInput,
                "is both the input and the output folder: give --out a folder of its own",
            ),
        });
    }
    let mut out = Vec::new();
    let walk = walkdir::WalkDir::new(dir)
        .follow_links(true)
        .into_iter()
        .filter_entry(|e| {
            output.is_none() || e.path().canonicalize().ok().as_deref() != output.as_deref()
        });
    for entry in walk {
        match entry {
            Ok(e) if e.file_type().is_file() && is_image(e.path()) => out.push(e.into_path()),
            Ok(_) => {}
            Err(e) => {
                let path = e
                    .path()
                    .map_or_else(|| dir.display().to_string(), |p| p.display().to_string());
                let reason = e
                    .io_error()
                    .map_or_else(|| e.to_string(), |io| io.to_string());
                log::warn!("{path}: skipped: {reason}");
            }
        }
    }
    out.sort();
    Ok(out)
}

/// What happened to one image.
#[derive(Clone, Debug, PartialEq)]
pub enum Outcome {
    /// Detected now.
    Done {
        /// Image size.
        width: u32,
        /// Image size.
        height: u32,
        /// Keypoints written.
        keypoints: usize,
        /// Harris candidates before the merge.
        candidates: usize,
        /// Backend that ran.
        backend: steernav::Backend,
        /// Wall-clock time of the detection.
        ms: f64,
        /// Why the file looks damaged though it decoded (a truncated JPEG), if it does.
        damaged: Option<String>,
    },
    /// Its output existed and `force` was off; the figures come from that output.
    Skipped {
        /// Width, height, keypoint count and backend read back from the existing JSON.
        previous: Option<(u32, u32, usize, String)>,
    },
    /// It could not be read, decoded or processed.
    Failed(String),
}

/// One row of the summary.
#[derive(Clone, Debug, PartialEq)]
pub struct Entry {
    /// The input image.
    pub image: PathBuf,
    /// Its JSON output.
    pub output: PathBuf,
    /// What happened.
    pub outcome: Outcome,
}

/// Options of a batch run.
#[derive(Clone, Debug)]
pub struct BatchOptions {
    /// Directory searched recursively for images.
    pub input: PathBuf,
    /// Directory receiving one JSON per image (mirroring the input tree) and `summary.csv`.
    pub output: PathBuf,
    /// Redo images whose output already exists.
    pub force: bool,
    /// Also write a PNG with the keypoints drawn next to each JSON.
    pub draw: bool,
    /// Show a progress bar on stderr.
    pub progress: bool,
    /// Largest image accepted, pixels (see [`steernav::image::DEFAULT_MAX_PIXELS`]).
    pub max_pixels: u64,
    /// Only the images of this shard of the tree (a job array's share).
    pub shard: Option<Shard>,
}

fn output_path(opts: &BatchOptions, image: &Path) -> PathBuf {
    let rel = image.strip_prefix(&opts.input).unwrap_or(image);
    let mut name = rel.as_os_str().to_owned();
    name.push(".json");
    opts.output.join(name)
}

/// Runs the batch; returns every entry (in input order). Failures of single images are in the
/// entries, not errors; an error means the batch itself could not run (e.g. no input dir).
pub fn run_tree(detector: &Detector, opts: &BatchOptions) -> Result<Vec<Entry>> {
    let mut images = list_images(&opts.input, &opts.output)?;
    if let Some(shard) = opts.shard {
        images.retain(|image| shard.contains(image.strip_prefix(&opts.input).unwrap_or(image)));
    }
    std::fs::create_dir_all(&opts.output).map_err(|source| Error::Io {
        path: opts.output.clone(),
        source,
    })?;
    let _locks = lock_output(opts)?;
    let bar = if opts.progress {
        indicatif::ProgressBar::new(images.len() as u64)
    } else {
        indicatif::ProgressBar::hidden()
    };
    bar.set_style(
        indicatif::ProgressStyle::with_template(
            "{bar:40} {pos}/{len} images  {per_sec}  ETA {eta}  {msg}",
        )
        .expect("valid template"),
    );
    let mut entries: Vec<Option<Entry>> = vec![None; images.len()];
    let todo: Vec<usize> = (0..images.len())
        .filter(|&i| {
            let out = output_path(opts, &images[i]);
            // Done means the JSON exists, and the picture too when --draw asks for one.
            let done = out.exists() && (!opts.draw || out.with_extension("png").exists());
            if !opts.force && done {
                entries[i] = Some(Entry {
                    image: images[i].clone(),
                    outcome: Outcome::Skipped {
                        previous: previous_figures(&out),
                    },
                    output: out,
                });
                bar.inc(1);
                false
            } else {
                true
            }
        })
        .collect();
    let decoders = std::thread::available_parallelism().map_or(1, |n| n.get().div_ceil(2));
    let next = AtomicUsize::new(0);
    let (tx, rx) = sync_channel::<(usize, Result<Frame>)>(4);
    std::thread::scope(|scope| {
        for _ in 0..decoders {
            let tx = tx.clone();
            let (next, todo, images) = (&next, &todo, &images);
            scope.spawn(move || loop {
                let k = next.fetch_add(1, Ordering::Relaxed);
                let Some(&i) = todo.get(k) else { break };
                if tx
                    .send((i, Frame::load_limited(&images[i], opts.max_pixels)))
                    .is_err()
                {
                    break;
                }
            });
        }
        drop(tx);
        // Two frames in flight on the GPU: the next image's passes run while this one's
        // keypoints are merged, described and written.
        detector.detect_stream(rx, |i, result| {
            let image = images[i].clone();
            let output = output_path(opts, &image);
            let outcome = match result
                .map_err(|e| name_input(e, &image))
                .and_then(|(frame, d)| write_outputs(detector, opts, &image, &output, &frame, d))
            {
                Ok(o) => o,
                Err(e) => {
                    bar.suspend(|| eprintln!("error: {e}"));
                    Outcome::Failed(e.to_string())
                }
            };
            bar.inc(1);
            entries[i] = Some(Entry {
                image,
                output,
                outcome,
            });
        });
    });
    bar.finish_and_clear();
    let entries: Vec<Entry> = entries
        .into_iter()
        .map(|e| e.expect("every image has an entry"))
        .collect();
    match opts.shard {
        None => write_atomic(&opts.output.join("summary.csv"), &summary_csv(&entries))?,
        Some(shard) => merge_summary(opts, shard, &entries)?,
    }
    Ok(entries)
}

/// The kernel's locks that keep two batches from redoing each other's work in one output
/// folder (a killed batch releases them): a whole-tree batch holds the folder's lock alone;
/// a shard shares it with the other shards and holds its own shard's lock alone, so the
/// shards of a job array write into one folder at once, but never beside a whole-tree batch
/// or a second copy of the same shard.
fn lock_output(opts: &BatchOptions) -> Result<Vec<std::fs::File>> {
    let open = |name: String| {
        let path = opts.output.join(name);
        std::fs::File::create(&path).map_err(|source| Error::Io { path, source })
    };
    let refused = |e: std::fs::TryLockError, who: &str| Error::Io {
        path: opts.output.clone(),
        source: match e {
            std::fs::TryLockError::WouldBlock => std::io::Error::new(
                std::io::ErrorKind::WouldBlock,
                format!("{who} is writing into this folder"),
            ),
            std::fs::TryLockError::Error(io) => io,
        },
    };
    let folder = open(".steernav-batch.lock".into())?;
    let Some(shard) = opts.shard else {
        folder
            .try_lock()
            .map_err(|e| refused(e, "another steernav batch"))?;
        return Ok(vec![folder]);
    };
    folder
        .try_lock_shared()
        .map_err(|e| refused(e, "a steernav batch of the whole tree (no --shard)"))?;
    let own = open(format!(
        ".steernav-batch-{}-of-{}.lock",
        shard.index, shard.count
    ))?;
    own.try_lock()
        .map_err(|e| refused(e, &format!("another steernav batch of shard {shard}")))?;
    Ok(vec![folder, own])
}

/// A shard's rows merged into the folder's `summary.csv` under a lock the shards take in
/// turn: the rows of the images in this shard are replaced by this run's, every other row is
/// kept, so once every shard has run the summary holds one row per image of the tree,
/// whatever order the shards finished in.
fn merge_summary(opts: &BatchOptions, shard: Shard, entries: &[Entry]) -> Result<()> {
    let summary = opts.output.join("summary.csv");
    let lock_path = opts.output.join(".steernav-summary.lock");
    let lock = std::fs::File::create(&lock_path).map_err(|source| Error::Io {
        path: lock_path.clone(),
        source,
    })?;
    lock.lock().map_err(|source| Error::Io {
        path: lock_path,
        source,
    })?;
    // Byte records: an image's name is kept exactly as the file system has it.
    let mut rows: Vec<csv::ByteRecord> = Vec::new();
    if let Ok(text) = std::fs::read(&summary) {
        for record in csv::Reader::from_reader(&text[..]).byte_records() {
            let record = record.map_err(|e| summary_error(&summary, e))?;
            let image = steernav::output::path_from_bytes(record.get(0).unwrap_or_default());
            // This run has the rows of its own shard; the other shards' rows stay.
            if !shard.contains(image.strip_prefix(&opts.input).unwrap_or(&image)) {
                rows.push(record);
            }
        }
    }
    let ours = summary_csv(entries);
    let mut reader = csv::Reader::from_reader(&ours[..]);
    let header = reader
        .byte_headers()
        .map_err(|e| summary_error(&summary, e))?
        .clone();
    for record in reader.byte_records() {
        rows.push(record.map_err(|e| summary_error(&summary, e))?);
    }
    rows.sort_by(|a, b| a.get(0).cmp(&b.get(0)));
    let bytes = steernav::output::csv_bytes(std::iter::once(&header).chain(rows.iter()));
    write_atomic(&summary, &bytes)
}

fn summary_error(summary: &Path, e: csv::Error) -> Error {
    Error::Parse {
        path: summary.to_path_buf(),
        reason: format!("cannot merge this shard's rows into it: {e}"),
    }
}

/// The figures of an earlier run's JSON, so a re-run's summary keeps its rows whole.
pub(crate) fn previous_figures(json: &Path) -> Option<(u32, u32, usize, String)> {
    let text = std::fs::read_to_string(json).ok()?;
    let record: ImageKeypoints = serde_json::from_str(&text).ok()?;
    Some((
        record.width,
        record.height,
        record.keypoints.len(),
        record.backend,
    ))
}

/// A size error names the image it came from.
pub fn name_input(e: Error, image: &Path) -> Error {
    match e {
        Error::ImageSize {
            width,
            height,
            reason,
            ..
        } => Error::ImageSize {
            input: image.display().to_string(),
            width,
            height,
            reason,
        },
        other => other,
    }
}

/// Writes an image's JSON (and picture) and returns its summary row.
fn write_outputs(
    detector: &Detector,
    opts: &BatchOptions,
    image: &Path,
    output: &Path,
    frame: &Frame,
    d: steernav::Detection,
) -> Result<Outcome> {
    let t = &d.timings;
    let ms = t.harris_ms + t.merge_ms + t.descriptor_ms;
    let (candidates, backend) = (d.candidates, d.backend);
    let record = ImageKeypoints::new(image, frame, d);
    write_atomic(output, record.to_json().as_bytes())?;
    if opts.draw {
        let scales: Vec<f32> = detector.plan().scales.iter().map(|s| s.sigma_d).collect();
        crate::draw::write_png(
            &output.with_extension("png"),
            frame,
            &record.keypoints,
            &scales,
        )?;
    }
    Ok(Outcome::Done {
        width: frame.width,
        height: frame.height,
        keypoints: record.keypoints.len(),
        candidates,
        backend,
        ms,
        damaged: steernav::image::truncation(image),
    })
}

/// The summary CSV: one row per image, the image named by its path's own bytes (a name that is
/// not UTF-8 stays that name).
pub fn summary_csv(entries: &[Entry]) -> Vec<u8> {
    let header = "image,status,width,height,keypoints,candidates,backend,ms,error"
        .split(',')
        .map(|f| f.as_bytes().to_vec())
        .collect::<Vec<_>>();
    let rows = entries.iter().map(|e| {
        let fields: Vec<String> = match &e.outcome {
            Outcome::Done {
                width,
                height,
                keypoints,
                candidates,
                backend,
                ms,
                damaged,
            } => vec![
                if damaged.is_some() { "damaged" } else { "done" }.into(),
                width.to_string(),
                height.to_string(),
                keypoints.to_string(),
                candidates.to_string(),
                backend.to_string(),
                format!("{ms:.2}"),
                damaged.clone().unwrap_or_default(),
            ],
            Outcome::Skipped { previous } => {
                let mut row = vec!["skipped".to_string()];
                if let Some((width, height, keypoints, backend)) = previous {
                    row.extend([
                        width.to_string(),
                        height.to_string(),
                        keypoints.to_string(),
                        String::new(),
                        backend.clone(),
                    ]);
                }
                row.resize(8, String::new());
                row
            }
            Outcome::Failed(msg) => {
                let mut row = vec!["failed".to_string()];
                row.resize(7, String::new());
                row.push(msg.clone());
                row
            }
        };
        std::iter::once(steernav::output::path_bytes(&e.image))
            .chain(fields.into_iter().map(String::into_bytes))
            .collect::<Vec<_>>()
    });
    steernav::output::csv_bytes(std::iter::once(header).chain(rows))
}

#[derive(Args)]
pub struct BatchCmd {
    /// Directory searched recursively for images, or a ROS 2 bag (rosbag2 folder or .mcap
    /// file): every message of its image topic, each record named by topic and header stamp.
    input: PathBuf,
    /// The bag's image topic, when it has several.
    #[arg(long, value_name = "TOPIC")]
    image_topic: Option<String>,
    /// With a bag: also write the keypoints as foxglove_msgs/msg/ImageAnnotations on
    /// /steernav/keypoints, stamped like the images (see `detect --mcap`).
    #[arg(long, value_name = "FILE")]
    mcap: Option<PathBuf>,
    /// Output directory: one <image>.json per image (mirroring the input tree) and summary.csv.
    #[arg(long, value_name = "DIR")]
    out: PathBuf,
    #[command(flatten)]
    detector: DetectorArgs,
    /// Redo images whose JSON already exists (by default a re-run skips them).
    #[arg(long)]
    force: bool,
    /// Also write a PNG with the keypoints next to each JSON.
    #[arg(long)]
    draw: bool,
    /// Process only shard K of N (0 ≤ K < N) of the tree: the images whose path relative to
    /// the input hashes to K (FNV-1a, the same on every machine). The N jobs of a job array
    /// (`--shard $SLURM_ARRAY_TASK_ID/N`) given the same tree split it with no overlap and no
    /// gap, and a re-run of one shard redoes nothing. Shards may share one --out at the same
    /// time: each merges its rows into summary.csv under a lock when it ends, so after the
    /// last one the summary has one row per image of the tree.
    #[arg(long, value_name = "K/N")]
    shard: Option<Shard>,
}

pub fn run(cmd: BatchCmd) -> anyhow::Result<ExitCode> {
    let detector = cmd.detector.detector()?;
    if steernav::bag::is_bag(&cmd.input) {
        if cmd.draw {
            anyhow::bail!(
                "--draw is for image files; open a bag's --mcap annotations in Foxglove instead"
            );
        }
        if cmd.shard.is_some() {
            anyhow::bail!(
                "--shard splits a directory of images; a bag is read in one pass (split it into \
                 several bags, one per job, with `ros2 bag convert` or by time range)"
            );
        }
        std::fs::create_dir_all(&cmd.out)
            .map_err(|e| anyhow::anyhow!("{}: cannot create: {e}", cmd.out.display()))?;
        let (entries, broken) = crate::detect_bag::detect_bag(
            &detector,
            &crate::detect_bag::BagRun {
                path: &cmd.input,
                topic: cmd.image_topic.as_deref(),
                out: Some(&cmd.out),
                csv: false,
                mcap: cmd.mcap.as_deref(),
                max_pixels: cmd.detector.max_pixels,
                skip_done: !cmd.force,
            },
        )?;
        write_atomic(&cmd.out.join("summary.csv"), &summary_csv(&entries))?;
        return crate::detect_bag::finish(&cmd.input, &entries, broken);
    }
    if cmd.image_topic.is_some() || cmd.mcap.is_some() {
        anyhow::bail!("--image-topic and --mcap apply to a ROS 2 bag input only");
    }
    let opts = BatchOptions {
        input: cmd.input,
        output: cmd.out,
        force: cmd.force,
        draw: cmd.draw,
        progress: true,
        max_pixels: cmd.detector.max_pixels,
        shard: cmd.shard,
    };
    let entries = run_tree(&detector, &opts)?;
    let count = |f: fn(&Outcome) -> bool| entries.iter().filter(|e| f(&e.outcome)).count();
    let done = count(|o| matches!(o, Outcome::Done { damaged: None, .. }));
    let damaged = count(|o| {
        matches!(
            o,
            Outcome::Done {
                damaged: Some(_),
                ..
            }
        )
    });
    let skipped = count(|o| matches!(o, Outcome::Skipped { .. }));
    let failed = count(|o| matches!(o, Outcome::Failed(_)));
    let share = opts
        .shard
        .map_or_else(String::new, |s| format!("shard {s}: "));
    eprintln!(
        "{share}{done} detected, {skipped} skipped (already done; --force redoes them), {failed} failed{}; summary in {}",
        if damaged > 0 {
            format!(", {damaged} damaged (detected on a truncated file)")
        } else {
            String::new()
        },
        opts.output.join("summary.csv").display()
    );
    Ok(if failed > 0 {
        ExitCode::FAILURE
    } else {
        ExitCode::SUCCESS
    })
}
