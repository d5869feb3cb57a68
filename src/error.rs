//! The library's error type: every variant names the input at fault and the reason, and
//! keeps the error it came from as its `source()` where there is one.

use std::path::PathBuf;

/// An underlying error kept as the source of one of ours.
pub type BoxError = Box<dyn std::error::Error + Send + Sync + 'static>;

/// What is wrong in a settings file, and where: the line, the table and the key.
#[derive(Debug, thiserror::Error)]
#[error("{}{message}", self.location())]
pub struct ConfigError {
    /// 1-based line of the offending text, when the parser knows it.
    pub line: Option<usize>,
    /// The table (`detector`, `slam`, …) the key is in.
    pub table: Option<String>,
    /// The key at fault.
    pub key: Option<String>,
    /// What is wrong with it.
    pub message: String,
    /// The parser's or the validator's own error.
    #[source]
    pub source: Option<BoxError>,
}

impl ConfigError {
    /// Locates a TOML parser error in `text` (line, table, key) and keeps it as the source.
    pub fn from_toml(text: &str, e: toml::de::Error) -> Self {
        let (line, table, key) = match e.span() {
            Some(span) => locate(text, span.start),
            None => (None, None, None),
        };
        Self {
            line,
            table,
            key,
            message: e.message().trim().to_string(),
            source: Some(Box::new(e)),
        }
    }

    /// A value that parsed but broke its rule ([`Error::Config`] from a `validate`).
    pub fn invalid(table: &str, e: Error) -> Self {
        let key = match &e {
            Error::Config { field, .. } => Some(field.to_string()),
            _ => None,
        };
        Self {
            line: None,
            table: Some(table.to_string()),
            key,
            message: e.to_string(),
            source: Some(Box::new(e)),
        }
    }

    fn location(&self) -> String {
        let mut at = String::new();
        if let Some(line) = self.line {
            at.push_str(&format!("line {line}: "));
        }
        match (&self.table, &self.key) {
            (Some(t), Some(k)) => at.push_str(&format!("[{t}] {k}: ")),
            (Some(t), None) => at.push_str(&format!("[{t}]: ")),
            (None, Some(k)) => at.push_str(&format!("{k}: ")),
            (None, None) => {}
        }
        at
    }
}

/// Line, enclosing table and key of the byte `offset` of a TOML text.
fn locate(text: &str, offset: usize) -> (Option<usize>, Option<String>, Option<String>) {
    let mut end = offset.min(text.len());
    while !text.is_char_boundary(end) {
        end -= 1;
    }
    let before = &text[..end];
    let line_no = before.matches('\n').count() + 1;
    let line = text.lines().nth(line_no - 1).unwrap_or("").trim();
    let key = line
        .split_once('=')
        .map(|(k, _)| k.trim().to_string())
        .filter(|k| !k.is_empty() && !k.starts_with('['));
    let table = before.lines().rev().find_map(|l| {
        let l = l.trim();
        l.strip_prefix('[')
            .and_then(|rest| rest.trim_start_matches('[').split(']').next())
            .map(|t| t.trim().to_string())
    });
    (Some(line_no), table, key)
}

/// Everything that can go wrong in steernav's library code. New variants may come: match with
/// a catch-all arm.
#[derive(Debug, thiserror::Error)]
#[non_exhaustive]
pub enum Error {
    /// A file could not be read or written.
    #[error("{path}: {source}")]
    Io {
        /// The file concerned.
        path: PathBuf,
        /// The underlying I/O error.
        source: std::io::Error,
    },
    /// An image file could not be decoded (empty, truncated, unknown format …).
    #[error("{path}: cannot decode image: {reason}")]
    Decode {
        /// The image file.
        path: PathBuf,
        /// What is wrong.
        reason: String,
        /// The decoder's own error, when it gave one.
        #[source]
        source: Option<BoxError>,
    },
    /// A ROS 2 bag's container cannot be read (not MCAP, truncated, corrupt): the messages
    /// before the fault may have been read; none after it are.
    #[error("{path}: {reason}")]
    Bag {
        /// The `.mcap` file.
        path: PathBuf,
        /// What is wrong.
        reason: String,
        /// The MCAP reader's own error, when it gave one.
        #[source]
        source: Option<BoxError>,
    },
    /// A text or data file (trajectory, frame list, calibration, laser log, homography,
    /// a helper's output) is malformed; the reason names the line where there is one.
    #[error("{path}: {reason}")]
    Parse {
        /// The file concerned.
        path: PathBuf,
        /// What is wrong, and where.
        reason: String,
    },
    /// An image has a size the detector cannot process.
    #[error("{input}: image is {width}x{height}: {reason}")]
    ImageSize {
        /// A name for the image (its path, or "image" for in-memory data).
        input: String,
        /// Width in pixels.
        width: u32,
        /// Height in pixels.
        height: u32,
        /// Why the size is refused.
        reason: String,
    },
    /// A configuration value is out of range or not finite.
    #[error("invalid configuration: {field} = {value}: {reason}")]
    Config {
        /// The offending field, as named in the TOML config and on the CLI.
        field: &'static str,
        /// Its value, printed.
        value: String,
        /// The valid range or rule.
        reason: String,
    },
    /// A configuration file could not be parsed, or holds a value out of range.
    #[error("{path}: malformed config: {source}")]
    ConfigFile {
        /// The config file.
        path: PathBuf,
        /// Where in it, and what.
        #[source]
        source: Box<ConfigError>,
    },
    /// No GPU adapter, or the device could not be created.
    #[error("GPU unavailable: {reason}")]
    NoGpu {
        /// What was asked for and failed.
        reason: String,
        /// wgpu's own error, when it gave one.
        #[source]
        source: Option<BoxError>,
    },
    /// Bad input at run time — a timestamp, a laser scan, a frame the mode needs — as opposed
    /// to a bad setting ([`Error::Config`]).
    #[error("{input}: {reason}")]
    Input {
        /// What was given, with its value where that helps (`scan.ranges[3] = NaN`).
        input: String,
        /// Why it was refused.
        reason: String,
    },
    /// The GPU device cannot hold the work (a limit of the device is exceeded).
    #[error("GPU limit exceeded: {0}")]
    GpuLimit(String),
    /// The GPU reported an error while running.
    #[error("GPU error: {operation}")]
    Gpu {
        /// What was being done.
        operation: String,
        /// wgpu's own error, when it gave one.
        #[source]
        source: Option<BoxError>,
    },
}

impl Error {
    /// An [`Error::Input`].
    pub fn input(input: impl Into<String>, reason: impl Into<String>) -> Self {
        Error::Input {
            input: input.into(),
            reason: reason.into(),
        }
    }

    /// A [`Error::ConfigFile`] for `path` from a message with no further location.
    pub fn config_file(path: impl Into<PathBuf>, message: impl Into<String>) -> Self {
        Error::ConfigFile {
            path: path.into(),
            source: Box::new(ConfigError {
                line: None,
                table: None,
                key: None,
                message: message.into(),
                source: None,
            }),
        }
    }

    /// A [`Error::Config`] for `field` holding `value`, with the rule it breaks.
    pub fn config(field: &'static str, value: impl ToString, reason: impl Into<String>) -> Self {
        Error::Config {
            field,
            value: value.to_string(),
            reason: reason.into(),
        }
    }
}

/// Shorthand for results of this crate.
pub type Result<T, E = Error> = std::result::Result<T, E>;

/// Opens an input file for reading, refusing what is not a regular file (after links): a FIFO
/// would block until a writer comes, a device such as `/dev/zero` would never end.
pub(crate) fn open_input(path: &std::path::Path) -> Result<std::fs::File> {
    let io = |source| Error::Io {
        path: path.to_path_buf(),
        source,
    };
    let meta = std::fs::metadata(path).map_err(io)?;
    if !meta.is_file() {
        return Err(io(std::io::Error::new(
            std::io::ErrorKind::InvalidInput,
            if meta.is_dir() {
                "is a directory, not a file"
            } else {
                "is not a regular file (a FIFO or a device would block or never end)"
            },
        )));
    }
    std::fs::File::open(path).map_err(io)
}

/// [`open_input`], read to the end as UTF-8 text.
pub(crate) fn read_input(path: &std::path::Path) -> Result<String> {
    use std::io::Read;
    let mut text = String::new();
    open_input(path)?
        .read_to_string(&mut text)
        .map_err(|source| Error::Io {
            path: path.to_path_buf(),
            source,
        })?;
    Ok(text)
}
