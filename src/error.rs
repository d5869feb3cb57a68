//! The library's error type: every variant names the input at fault and the reason.

use std::path::PathBuf;

/// Everything that can go wrong in steernav's library code.
#[derive(Debug, thiserror::Error)]
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
        /// What the decoder said.
        reason: String,
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
    /// A configuration file could not be parsed.
    #[error("{path}: malformed config: {reason}")]
    ConfigFile {
        /// The config file.
        path: PathBuf,
        /// The parser's message.
        reason: String,
    },
    /// No GPU adapter, or the device could not be created.
    #[error("GPU unavailable: {0}")]
    NoGpu(String),
    /// The GPU device cannot hold the work (a limit of the device is exceeded).
    #[error("GPU limit exceeded: {0}")]
    GpuLimit(String),
    /// The GPU reported an error while running.
    #[error("GPU error: {0}")]
    Gpu(String),
}

impl Error {
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
