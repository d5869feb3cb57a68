//! Images as the detector sees them: a planar `f32` luminance plane for the filters and the
//! 8-bit RGB pixels for the colour descriptor (section 2.3). Loading names the file on failure.

use std::path::Path;

use crate::error::{Error, Result};

/// Largest side accepted by the loaders; larger images are refused with a clear error rather
/// than exhausting memory (a 20000x20000 RGB image would need ~1.6 GB of f32 planes per stage).
pub const MAX_SIDE: u32 = 16384;

/// An image ready for detection: luminance in [0, 1] plus the original RGB bytes.
#[derive(Clone, Debug)]
pub struct Frame {
    /// Width in pixels.
    pub width: u32,
    /// Height in pixels.
    pub height: u32,
    /// Row-major luminance, `width * height` values in [0, 1] (Rec. 601 weights).
    pub gray: Vec<f32>,
    /// Row-major RGB, `3 * width * height` bytes; grey inputs have the channel replicated.
    pub rgb: Vec<u8>,
}

impl Frame {
    /// Builds a frame from interleaved RGB bytes, checking the size.
    pub fn from_rgb(width: u32, height: u32, rgb: Vec<u8>) -> Result<Self> {
        check_size("image", width, height)?;
        let n = width as usize * height as usize;
        if rgb.len() != 3 * n {
            return Err(Error::ImageSize {
                input: "image".into(),
                width,
                height,
                reason: format!("expected {} RGB bytes, got {}", 3 * n, rgb.len()),
            });
        }
        let gray = rgb
            .chunks_exact(3)
            .map(|p| (0.299 * p[0] as f32 + 0.587 * p[1] as f32 + 0.114 * p[2] as f32) / 255.0)
            .collect();
        Ok(Self {
            width,
            height,
            gray,
            rgb,
        })
    }

    /// Builds a frame from a luminance plane in [0, 1]; the RGB bytes replicate it.
    pub fn from_gray(width: u32, height: u32, gray: Vec<f32>) -> Result<Self> {
        check_size("image", width, height)?;
        if gray.len() != width as usize * height as usize {
            return Err(Error::ImageSize {
                input: "image".into(),
                width,
                height,
                reason: format!("expected {} values, got {}", width * height, gray.len()),
            });
        }
        if let Some(i) = gray.iter().position(|v| !v.is_finite()) {
            return Err(Error::ImageSize {
                input: "image".into(),
                width,
                height,
                reason: format!("pixel {i} is not finite"),
            });
        }
        let rgb = gray
            .iter()
            .flat_map(|&v| {
                let b = (v.clamp(0.0, 1.0) * 255.0).round() as u8;
                [b, b, b]
            })
            .collect();
        Ok(Self {
            width,
            height,
            gray,
            rgb,
        })
    }

    /// Converts a decoded `image` crate image (any pixel type).
    pub fn from_dynamic(img: &image::DynamicImage) -> Result<Self> {
        let rgb = img.to_rgb8();
        Self::from_rgb(rgb.width(), rgb.height(), rgb.into_raw())
    }

    /// Loads and decodes an image file; errors name the file.
    pub fn load(path: &Path) -> Result<Self> {
        let bytes = std::fs::read(path).map_err(|source| Error::Io {
            path: path.to_path_buf(),
            source,
        })?;
        Self::decode(path, &bytes)
    }

    /// Decodes an image held in memory; `path` is only used to name it in errors and to guess
    /// the format when the bytes do not reveal it.
    pub fn decode(path: &Path, bytes: &[u8]) -> Result<Self> {
        let decode_err = |reason: String| Error::Decode {
            path: path.to_path_buf(),
            reason,
        };
        if bytes.is_empty() {
            return Err(decode_err("file is empty".into()));
        }
        let format = image::guess_format(bytes)
            .or_else(|_| image::ImageFormat::from_path(path))
            .map_err(|e| decode_err(e.to_string()))?;
        let mut reader = image::ImageReader::with_format(std::io::Cursor::new(bytes), format);
        reader.limits({
            let mut l = image::Limits::default();
            l.max_image_width = Some(MAX_SIDE);
            l.max_image_height = Some(MAX_SIDE);
            l
        });
        let img = reader.decode().map_err(|e| decode_err(e.to_string()))?;
        let name = path.display().to_string();
        check_size(&name, img.width(), img.height())?;
        Self::from_dynamic(&img).map_err(|e| match e {
            Error::ImageSize {
                width,
                height,
                reason,
                ..
            } => Error::ImageSize {
                input: name,
                width,
                height,
                reason,
            },
            other => other,
        })
    }

    /// Number of pixels.
    pub fn pixels(&self) -> usize {
        self.width as usize * self.height as usize
    }
}

/// Refuses empty images and images beyond [`MAX_SIDE`].
pub fn check_size(input: &str, width: u32, height: u32) -> Result<()> {
    let reason = if width == 0 || height == 0 {
        Some("the image is empty".to_string())
    } else if width > MAX_SIDE || height > MAX_SIDE {
        Some(format!("a side exceeds the maximum of {MAX_SIDE} pixels"))
    } else {
        None
    };
    match reason {
        Some(reason) => Err(Error::ImageSize {
            input: input.into(),
            width,
            height,
            reason,
        }),
        None => Ok(()),
    }
}
