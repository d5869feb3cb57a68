//! What every figure shares: the bundled DejaVu Sans (so no system fonts are needed) and the
//! preparation of a figure's file. The figures themselves live with their stages
//! (`eval::figure`, `slam::data::figure`, `nav::sim::figure`).

use std::path::Path;
use std::sync::Once;

use plotters::style::FontStyle;

use crate::error::{Error, Result};

static FONT: Once = Once::new();

/// Registers the bundled font once per process.
pub(crate) fn register_font() {
    FONT.call_once(|| {
        let bytes: &'static [u8] = include_bytes!("../assets/fonts/DejaVuSans.ttf");
        // The font is bundled and valid; a failure here would only lose the labels.
        let _ = plotters::style::register_font("sans-serif", FontStyle::Normal, bytes);
    });
}

/// Registers the font and creates the figure's folder; the closure turns a drawing error into
/// one naming the file.
pub(crate) fn prepare_figure(path: &Path) -> Result<impl Fn(String) -> Error + '_> {
    register_font();
    if let Some(dir) = path.parent().filter(|d| !d.as_os_str().is_empty()) {
        std::fs::create_dir_all(dir).map_err(|source| Error::Io {
            path: dir.to_path_buf(),
            source,
        })?;
    }
    Ok(move |e: String| Error::Io {
        path: path.to_path_buf(),
        source: std::io::Error::other(e),
    })
}
