//! One TOML file for every command: each stage's settings sit in their own table
//! (`[detector]`, `[slam]`, `[gist]`, `[nav]`, `[replay]`, `[synthetic]`), so a robot keeps one
//! file, and each command reads the tables it needs. Unknown tables and unknown keys are
//! refused, naming the file, the table and the key.

use std::path::Path;

use serde::de::DeserializeOwned;

use crate::error::{Error, Result};
use crate::features::DetectorConfig;
use crate::nav::gist::GistConfig;
use crate::nav::replay::ReplayConfig;
use crate::nav::sim::episode::NavConfig;
use crate::slam::config::SlamConfig;
use crate::slam::synthetic::SyntheticConfig;

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
    pub nav: NavConfig,
    /// `[replay]`: the neural field driven by a laser log (nav-replay).
    pub replay: ReplayConfig,
    /// `[synthetic]`: the generated SLAM sequence (slam-synth).
    pub synthetic: SyntheticConfig,
    present: Vec<String>,
}

/// The tables a settings file may hold.
pub const TABLES: [&str; 6] = ["detector", "slam", "gist", "nav", "replay", "synthetic"];

impl Settings {
    /// Parses a settings file's text; errors name the table and the key.
    pub fn from_toml_str(text: &str) -> std::result::Result<Self, String> {
        let table: toml::Table = toml::from_str(text).map_err(|e| e.to_string())?;
        let mut settings = Settings::default();
        for (name, value) in table {
            settings.present.push(name.clone());
            match name.as_str() {
                "detector" => settings.detector = section(&name, value)?,
                "slam" => settings.slam = section(&name, value)?,
                "gist" => settings.gist = section(&name, value)?,
                "nav" => settings.nav = section(&name, value)?,
                "replay" => settings.replay = section(&name, value)?,
                "synthetic" => settings.synthetic = section(&name, value)?,
                other => {
                    return Err(format!(
                        "unknown {} `{other}`: settings go in the tables [{}]",
                        if value.is_table() { "table" } else { "key" },
                        TABLES.join("], [")
                    ))
                }
            }
        }
        settings
            .detector
            .validate()
            .map_err(|e| format!("[detector]: {e}"))?;
        Ok(settings)
    }

    /// Whether the file had this table (a command may start from its own preset otherwise).
    pub fn has(&self, table: &str) -> bool {
        self.present.iter().any(|t| t == table)
    }

    /// Reads and parses a settings file.
    pub fn load(path: &Path) -> Result<Self> {
        let text = std::fs::read_to_string(path).map_err(|source| Error::Io {
            path: path.to_path_buf(),
            source,
        })?;
        Self::from_toml_str(&text).map_err(|reason| Error::ConfigFile {
            path: path.to_path_buf(),
            reason,
        })
    }

    /// [`Settings::load`] when a file is given, the defaults otherwise.
    pub fn load_or_default(path: Option<&Path>) -> Result<Self> {
        path.map_or_else(|| Ok(Self::default()), Self::load)
    }
}

fn section<T: DeserializeOwned>(name: &str, value: toml::Value) -> std::result::Result<T, String> {
    match value {
        toml::Value::Table(table) => table
            .try_into::<T>()
            .map_err(|e| format!("[{name}]: {}", e.to_string().trim_end())),
        other => Err(format!(
            "`{name}` must be a table ([{name}]), found a {}",
            other.type_str()
        )),
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn one_file_holds_every_table_and_errors_name_table_and_key() {
        let s = Settings::from_toml_str(
            "[detector]\norientations = 8\n[slam]\nmax_landmarks = 40\n[gist]\nblocks = 2\n",
        )
        .unwrap();
        assert_eq!(s.detector.orientations, 8);
        assert_eq!(s.slam.max_landmarks, 40);
        assert_eq!(s.gist.blocks, 2);
        assert_eq!(s.nav, NavConfig::default());
        assert!(s.has("slam") && !s.has("nav"));
        let e = Settings::from_toml_str("[slam]\nmax_landmarkz = 4\n").unwrap_err();
        assert!(e.contains("[slam]") && e.contains("max_landmarkz"), "{e}");
        let e = Settings::from_toml_str("[detectr]\n").unwrap_err();
        assert!(e.contains("detectr") && e.contains("[detector]"), "{e}");
        let e = Settings::from_toml_str("orientations = 8\n").unwrap_err();
        assert!(e.contains("unknown key `orientations`"), "{e}");
        let e = Settings::from_toml_str("[detector]\nscales = 0\n").unwrap_err();
        assert!(e.contains("[detector]") && e.contains("scales"), "{e}");
    }
}
