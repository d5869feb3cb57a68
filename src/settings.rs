//! One TOML file for every command: each stage's settings sit in their own table
//! (`[detector]`, `[slam]`, `[gist]`, `[nav]`, `[replay]`, `[synthetic]`), so a robot keeps one
//! file, and each command reads the tables it needs. Unknown tables and unknown keys are
//! refused, naming the file, the table and the key.

use std::path::Path;

use serde::Deserialize;

use crate::error::{ConfigError, Error, Result};
use crate::features::DetectorConfig;
use crate::nav::gist::GistConfig;
use crate::nav::replay::ReplayConfig;
use crate::nav::sim::episode::EpisodeConfig;
use crate::slam::config::SlamConfig;
use crate::slam::data::synthetic::SyntheticConfig;

/// Every table of a settings file, each at its documented defaults when absent.
#[derive(Clone, Debug, Default, PartialEq)]
pub struct Settings {
    /// `[detector]`: the keypoint detector (detect, batch, eval, slam, bench).
    pub detector: DetectorConfig,
    /// `[slam]`: the EKF SLAM (slam).
    pub slam: SlamConfig,
    /// `[gist]`: the GIST descriptor (gist).
    pub gist: GistConfig,
    /// `[nav]`: the simulated navigation episodes (nav, nav-eval, nav-sweep).
    pub nav: EpisodeConfig,
    /// `[replay]`: the neural field driven by a laser log (nav-replay).
    pub replay: ReplayConfig,
    /// `[synthetic]`: the generated SLAM sequence (slam-synth).
    pub synthetic: SyntheticConfig,
    present: Vec<String>,
    /// The `[detector]` table as written, for [`Settings::detector_over`].
    detector_table: Option<toml::Table>,
}

/// The file as serde reads it, so that parser errors keep their position in the text.
#[derive(Deserialize, Default)]
#[serde(default, deny_unknown_fields)]
struct SettingsFile {
    detector: DetectorConfig,
    slam: SlamConfig,
    gist: GistConfig,
    nav: EpisodeConfig,
    replay: ReplayConfig,
    synthetic: SyntheticConfig,
}

impl Settings {
    /// Parses a settings file's text; errors give the line, the table and the key.
    pub fn from_toml_str(text: &str) -> std::result::Result<Self, ConfigError> {
        let file: SettingsFile =
            toml::from_str(text).map_err(|e| ConfigError::from_toml(text, e))?;
        // Parsed again untyped only to learn which tables the file names (a typed field cannot
        // tell an absent table from one at its defaults); the text is a few lines.
        let tables: toml::Table =
            toml::from_str(text).map_err(|e| ConfigError::from_toml(text, e))?;
        file.detector
            .validate()
            .map_err(|e| ConfigError::invalid("detector", e))?;
        Ok(Settings {
            detector: file.detector,
            slam: file.slam,
            gist: file.gist,
            nav: file.nav,
            replay: file.replay,
            synthetic: file.synthetic,
            detector_table: tables.get("detector").and_then(|t| t.as_table()).cloned(),
            present: tables.keys().cloned().collect(),
        })
    }

    /// The file's `[detector]` keys over `base` instead of over the library defaults: a
    /// command with its own preset (slam's tracking preset) keeps what the file leaves out.
    pub fn detector_over(&self, base: DetectorConfig) -> Result<DetectorConfig> {
        match &self.detector_table {
            Some(table) => base.overlaid(table),
            None => Ok(base),
        }
    }

    /// Whether the file had this table (a command may start from its own preset otherwise).
    pub fn has(&self, table: &str) -> bool {
        self.present.iter().any(|t| t == table)
    }

    /// Reads and parses a settings file.
    pub fn load(path: &Path) -> Result<Self> {
        let text = crate::error::read_input(path)?;
        Self::from_toml_str(&text).map_err(|source| Error::ConfigFile {
            path: path.to_path_buf(),
            source: Box::new(source),
        })
    }

    /// [`Settings::load`] when a file is given, the defaults otherwise.
    pub fn load_or_default(path: Option<&Path>) -> Result<Self> {
        path.map_or_else(|| Ok(Self::default()), Self::load)
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn one_file_holds_every_table_and_errors_name_table_and_key() {
        let s = Settings::from_toml_str(
            "[detector]\norientations = 8\n[slam.map]\nmax_landmarks = 40\n[gist]\nblocks = 2\n",
        )
        .unwrap();
        assert_eq!(s.detector.orientations, 8);
        assert_eq!(s.slam.map.max_landmarks, 40);
        assert_eq!(s.gist.blocks, 2);
        assert_eq!(s.nav, EpisodeConfig::default());
        assert!(s.has("slam") && !s.has("nav"));
        let e = Settings::from_toml_str("[slam]\nmax_landmarkz = 4\n").unwrap_err();
        assert_eq!(e.line, Some(2));
        assert_eq!(e.table.as_deref(), Some("slam"));
        assert_eq!(e.key.as_deref(), Some("max_landmarkz"));
        let text = e.to_string();
        assert!(
            text.starts_with("line 2: [slam] max_landmarkz: unknown field"),
            "{text}"
        );
        // A key of the old flat [slam] table names where it went, with its line.
        let e = Settings::from_toml_str("[slam]\n\nmax_landmarks = 4\n").unwrap_err();
        assert_eq!(e.line, Some(3));
        let text = e.to_string();
        assert!(text.contains("moved to `slam.map.max_landmarks`"), "{text}");
        let s = Settings::from_toml_str("[nav]\nmax_time = 5\n[nav.controller]\nturn_gain = 3\n")
            .unwrap();
        assert_eq!((s.nav.max_time, s.nav.controller.turn_gain), (5.0, 3.0));
        let text = Settings::from_toml_str("[nav]\nturn_gain = 3\n")
            .unwrap_err()
            .to_string();
        assert!(
            text.contains("moved to `nav.controller.turn_gain`"),
            "{text}"
        );
        // A command's own preset keeps what the file's [detector] leaves out.
        let s = Settings::from_toml_str("[detector]\nmax_keypoints = 77\n").unwrap();
        let over = s.detector_over(DetectorConfig::tracking()).unwrap();
        assert_eq!(over.max_keypoints, 77);
        assert_eq!(over.scales, DetectorConfig::tracking().scales);
        assert_eq!(
            Settings::default()
                .detector_over(DetectorConfig::tracking())
                .unwrap(),
            DetectorConfig::tracking()
        );
        let e = Settings::from_toml_str("[detectr]\n")
            .unwrap_err()
            .to_string();
        assert!(e.contains("detectr") && e.contains("`detector`"), "{e}");
        let e = Settings::from_toml_str("orientations = 8\n")
            .unwrap_err()
            .to_string();
        assert!(e.contains("unknown field `orientations`"), "{e}");
        let e = Settings::from_toml_str("[detector]\nscales = 0\n").unwrap_err();
        assert_eq!(e.key.as_deref(), Some("scales"));
        assert!(std::error::Error::source(&e).is_some());
    }
}
