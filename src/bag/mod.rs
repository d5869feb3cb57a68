//! ROS 2 bags (MCAP storage, the default since ROS 2 Iron) read without a ROS installation: a
//! rosbag2 folder (`metadata.yaml` beside its `.mcap` files) or a single `.mcap` file. Topics
//! come from the files' summaries (or, for a file without one, from a pass over its records);
//! messages are streamed in file order, so memory stays bounded by the largest chunk, whatever
//! the bag's size. Chunks compressed with zstd or lz4 are read.
//!
//! [`messages`] holds the ROS 2 message types and their CDR decoding, [`frames`] turns image
//! topics into [`crate::Frame`]s and a camera, [`laser`] laser and odometry topics into the
//! replay's scans.

pub mod frames;
pub mod laser;
pub mod messages;
pub mod odometry;
pub mod write;

use std::io::{BufReader, Read, Seek};
use std::path::{Path, PathBuf};

use crate::error::{Error, Result};

/// Largest record (a chunk, or a message outside chunks) read: 1 GiB. A length field past it
/// is taken for corruption, not allocated.
pub const MAX_RECORD: usize = 1 << 30;

/// One topic of a bag.
#[derive(Clone, Debug, PartialEq, Eq)]
pub struct Topic {
    /// Topic name (`/camera/image_raw`).
    pub name: String,
    /// Message type (`sensor_msgs/msg/Image`).
    pub kind: String,
    /// Message encoding (`cdr` for ROS 2).
    pub encoding: String,
    /// Messages on it, from the files' summaries (`None` when a file has none).
    pub messages: Option<u64>,
}

/// One message read from a bag.
#[derive(Clone, Debug)]
pub struct BagMessage {
    /// The topic it was published on.
    pub topic: String,
    /// Its message type.
    pub kind: String,
    /// When it was recorded, nanoseconds.
    pub log_time: u64,
    /// The serialised message.
    pub data: Vec<u8>,
}

impl BagMessage {
    /// Names the message in errors: `bag.mcap: /scan at log time 12.345000000 s`.
    pub fn describe(&self, bag: &Path) -> String {
        format!(
            "{}: {} at log time {}.{:09} s",
            bag.display(),
            self.topic,
            self.log_time / 1_000_000_000,
            self.log_time % 1_000_000_000
        )
    }

    /// Decodes the message as `T` (CDR), errors naming the bag, topic and log time.
    pub fn decode<T: serde::de::DeserializeOwned>(&self, bag: &Path) -> Result<T> {
        messages::decode(&self.data, &self.describe(bag))
    }
}

/// An opened bag: its files and topics.
#[derive(Clone, Debug)]
pub struct Bag {
    /// What the user gave (the folder or the file), for messages.
    pub path: PathBuf,
    /// The `.mcap` files, in order.
    pub files: Vec<PathBuf>,
    /// Every topic, sorted by name.
    pub topics: Vec<Topic>,
}

/// Whether `path` is a bag: a `.mcap` file, or a folder holding `metadata.yaml` or `.mcap`
/// files.
pub fn is_bag(path: &Path) -> bool {
    if path.is_dir() {
        path.join("metadata.yaml").is_file() || !mcap_files(path).unwrap_or_default().is_empty()
    } else {
        path.extension()
            .is_some_and(|e| e.eq_ignore_ascii_case("mcap"))
    }
}

/// The `.mcap` files of a folder, sorted by name (rosbag2 numbers its splits `_0`, `_1`, …).
fn mcap_files(dir: &Path) -> std::io::Result<Vec<PathBuf>> {
    let mut files: Vec<PathBuf> = std::fs::read_dir(dir)?
        .filter_map(|e| e.ok().map(|e| e.path()))
        .filter(|p| p.is_file() && p.extension().is_some_and(|e| e == "mcap"))
        .collect();
    files.sort_by(|a, b| natural_key(a).cmp(&natural_key(b)).then_with(|| a.cmp(b)));
    Ok(files)
}

/// Sorts `bag_2.mcap` before `bag_10.mcap`: the name's trailing number, then the name.
fn natural_key(p: &Path) -> (String, u64) {
    let stem = p
        .file_stem()
        .map(|s| s.to_string_lossy().into_owned())
        .unwrap_or_default();
    let digits = stem.len() - stem.trim_end_matches(|c: char| c.is_ascii_digit()).len();
    let (head, tail) = stem.split_at(stem.len() - digits);
    (head.to_string(), tail.parse().unwrap_or(0))
}

fn io_error(path: &Path, source: std::io::Error) -> Error {
    Error::Io {
        path: path.to_path_buf(),
        source,
    }
}

fn mcap_error(path: &Path, e: mcap::McapError) -> Error {
    Error::Bag {
        path: path.to_path_buf(),
        reason: format!("unreadable MCAP: {e}"),
        source: Some(Box::new(e)),
    }
}

/// The channels of one file, from its summary section when it has one.
fn summary_topics(path: &Path) -> Result<Option<Vec<Topic>>> {
    use mcap::sans_io::summary_reader::{SummaryReadEvent, SummaryReader, SummaryReaderOptions};
    let mut file = crate::error::open_input(path)?;
    let size = file.metadata().map_err(|e| io_error(path, e))?.len();
    let mut reader = SummaryReader::new_with_options(
        SummaryReaderOptions::default()
            .with_file_size(size)
            .with_record_length_limit(MAX_RECORD),
    );
    while let Some(event) = reader.next_event() {
        match event.map_err(|e| mcap_error(path, e))? {
            SummaryReadEvent::ReadRequest(need) => {
                let n = file
                    .read(reader.insert(need))
                    .map_err(|e| io_error(path, e))?;
                reader.notify_read(n);
            }
            SummaryReadEvent::SeekRequest(to) => {
                let at = file.seek(to).map_err(|e| io_error(path, e))?;
                reader.notify_seeked(at);
            }
        }
    }
    Ok(reader.finish().map(|s| {
        let counts = s.stats.map(|st| st.channel_message_counts);
        s.channels
            .iter()
            .map(|(id, c)| Topic {
                messages: counts.as_ref().map(|m| m.get(id).copied().unwrap_or(0)),
                ..topic_of(c)
            })
            .collect()
    }))
}

fn topic_of(c: &mcap::Channel) -> Topic {
    Topic {
        messages: None,
        name: c.topic.clone(),
        kind: c
            .schema
            .as_ref()
            .map(|s| s.name.clone())
            .unwrap_or_default(),
        encoding: c.message_encoding.clone(),
    }
}

/// Checks the MCAP magic at the start, so a foreign file is refused by name at once.
fn check_magic(path: &Path) -> Result<()> {
    let mut head = [0u8; 8];
    let mut file = crate::error::open_input(path)?;
    let n = file.read(&mut head).map_err(|e| io_error(path, e))?;
    if n < 8 || head != *mcap::MAGIC {
        return Err(Error::Bag {
            path: path.to_path_buf(),
            reason: "not an MCAP file (its first bytes are not the MCAP magic)".into(),
            source: None,
        });
    }
    Ok(())
}

impl Bag {
    /// Opens a rosbag2 folder or an `.mcap` file and lists its topics.
    pub fn open(path: &Path) -> Result<Self> {
        let files = if path.is_dir() {
            let files = mcap_files(path).map_err(|e| io_error(path, e))?;
            if files.is_empty() {
                return Err(Error::input(
                    path.display().to_string(),
                    "a bag folder without .mcap files (only the MCAP storage is read; a .db3 bag converts with `ros2 bag convert`)",
                ));
            }
            files
        } else {
            vec![path.to_path_buf()]
        };
        let mut topics: Vec<Topic> = Vec::new();
        for file in &files {
            check_magic(file)?;
            let found = match summary_topics(file) {
                Ok(Some(t)) => t,
                // No summary (a recording cut short): the channels come from a pass over
                // the records, which also reports a truncated file by name.
                Ok(None) | Err(_) => linear_topics(file)?,
            };
            for t in found {
                match topics
                    .iter_mut()
                    .find(|o| o.name == t.name && o.kind == t.kind)
                {
                    Some(o) => o.messages = o.messages.zip(t.messages).map(|(a, b)| a + b),
                    None => topics.push(t),
                }
            }
        }
        topics.sort_by(|a, b| a.name.cmp(&b.name).then_with(|| a.kind.cmp(&b.kind)));
        Ok(Self {
            path: path.to_path_buf(),
            files,
            topics,
        })
    }

    /// The topics of type `kind` (several types: any of them).
    pub fn topics_of(&self, kinds: &[&str]) -> Vec<&Topic> {
        self.topics
            .iter()
            .filter(|t| kinds.contains(&t.kind.as_str()))
            .collect()
    }

    /// The one topic of one of `kinds`, or the one named `chosen` (`flag` names the option
    /// that chooses, for the error when there are several or none).
    pub fn choose_topic(&self, kinds: &[&str], chosen: Option<&str>, flag: &str) -> Result<Topic> {
        let listing = || {
            self.topics
                .iter()
                .map(|t| format!("{} ({})", t.name, t.kind))
                .collect::<Vec<_>>()
                .join(", ")
        };
        let name = self.path.display().to_string();
        if let Some(chosen) = chosen {
            let topic = self
                .topics
                .iter()
                .find(|t| t.name == chosen)
                .ok_or_else(|| {
                    Error::input(
                        &name,
                        format!("has no topic {chosen} ({flag}); its topics: {}", listing()),
                    )
                })?;
            if !kinds.contains(&topic.kind.as_str()) {
                return Err(Error::input(
                    &name,
                    format!(
                        "topic {chosen} ({flag}) carries {}, not {}",
                        topic.kind,
                        kinds.join(" or ")
                    ),
                ));
            }
            return Ok(topic.clone());
        }
        match self.topics_of(kinds).as_slice() {
            [one] => Ok((*one).clone()),
            [] => Err(Error::input(
                &name,
                format!(
                    "has no {} topic; its topics: {}",
                    kinds.join(" or "),
                    listing()
                ),
            )),
            many => Err(Error::input(
                &name,
                format!(
                    "has {} {} topics ({}): choose one with {flag}",
                    many.len(),
                    kinds.join(" or "),
                    many.iter()
                        .map(|t| t.name.as_str())
                        .collect::<Vec<_>>()
                        .join(", ")
                ),
            )),
        }
    }

    /// Messages on `topic`, when every file's summary counts them.
    pub fn message_count(&self, topic: &str) -> Option<u64> {
        self.topics
            .iter()
            .find(|t| t.name == topic)
            .and_then(|t| t.messages)
    }

    /// Streams the messages of `topics` in file order (within a file, the order they were
    /// written, which rosbag2 keeps in log-time order). The stream owns what it reads, so it
    /// outlives the `Bag` and can move to another thread.
    pub fn messages(
        &self,
        topics: &[String],
    ) -> impl Iterator<Item = Result<BagMessage>> + Send + 'static {
        let topics: Vec<String> = topics.to_vec();
        self.files.clone().into_iter().flat_map(move |file| {
            let topics = topics.clone();
            let (reader, failed) = match crate::error::open_input(&file) {
                Ok(f) => (
                    Some(mcap::io::MessageReader::new_with_options(
                        BufReader::new(f),
                        mcap::sans_io::LinearReaderOptions::default()
                            .with_record_length_limit(MAX_RECORD),
                    )),
                    None,
                ),
                Err(e) => (None, Some(Err(e))),
            };
            failed.into_iter().chain(
                reader
                    .into_iter()
                    .flatten()
                    .filter_map(move |m| match m {
                        Err(e) => Some(Err(mcap_error(&file, e))),
                        Ok(m) if topics.contains(&m.channel.topic) => Some(Ok(BagMessage {
                            topic: m.channel.topic.clone(),
                            kind: topic_of(&m.channel).kind,
                            log_time: m.log_time,
                            data: m.data.into_owned(),
                        })),
                        Ok(_) => None,
                    })
                    .scan(false, |failed, m| {
                        // The reader yields nothing after its first error; stop there.
                        if *failed {
                            return None;
                        }
                        *failed = m.is_err();
                        Some(m)
                    }),
            )
        })
    }
}

/// The channels of a file without a summary, from a pass over its records.
fn linear_topics(path: &Path) -> Result<Vec<Topic>> {
    let file = crate::error::open_input(path)?;
    let mut reader = mcap::io::MessageReader::new_with_options(
        BufReader::new(file),
        mcap::sans_io::LinearReaderOptions::default().with_record_length_limit(MAX_RECORD),
    );
    let mut topics = Vec::new();
    for m in reader.by_ref() {
        let m = match m {
            Ok(m) => m,
            // A recording cut short: its complete messages are still readable, and the
            // stream reports the fault when it reaches it.
            Err(e) if !topics.is_empty() => {
                log::warn!("{}: {e}; reading the messages before it", path.display());
                break;
            }
            Err(e) => return Err(mcap_error(path, e)),
        };
        let t = topic_of(&m.channel);
        if !topics.contains(&t) {
            topics.push(t);
        }
    }
    Ok(topics)
}
