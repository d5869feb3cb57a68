//! Images as the detector sees them: a planar `f32` luminance plane for the filters and the
//! 8-bit RGB pixels for the colour descriptor (section 2.3). Loading names the file on failure.

use std::path::Path;

use rayon::prelude::*;

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
        let mut frame = Self {
            width: 0,
            height: 0,
            gray: Vec::new(),
            rgb: Vec::new(),
        };
        frame.set_rgb_owned(width, height, rgb)?;
        Ok(frame)
    }

    /// Refills this frame from interleaved RGB bytes, reusing its buffers: a camera loop (or
    /// the Python bindings) converting frame after frame of one size allocates nothing.
    pub fn set_rgb(&mut self, width: u32, height: u32, rgb: &[u8]) -> Result<()> {
        let mut bytes = std::mem::take(&mut self.rgb);
        bytes.clear();
        bytes.extend_from_slice(rgb);
        self.set_rgb_owned(width, height, bytes)
    }

    fn set_rgb_owned(&mut self, width: u32, height: u32, rgb: Vec<u8>) -> Result<()> {
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
        self.gray.resize(n, 0.0);
        // Row blocks on all cores: converting a caller's buffer is part of every call from a
        // camera loop or the Python bindings, not a one-off decode.
        const BLOCK: usize = 16 * 1024;
        self.gray
            .par_chunks_mut(BLOCK)
            .zip(rgb.par_chunks(3 * BLOCK))
            .for_each(|(out, px)| {
                for (g, p) in out.iter_mut().zip(px.chunks_exact(3)) {
                    *g = (0.299 * p[0] as f32 + 0.587 * p[1] as f32 + 0.114 * p[2] as f32) / 255.0;
                }
            });
        self.width = width;
        self.height = height;
        self.rgb = rgb;
        Ok(())
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

    /// Builds a frame from interleaved RGB floats in [0, 1] (the luminance keeps their full
    /// precision; the RGB bytes, used by the colour descriptor, are rounded).
    pub fn from_rgb_f32(width: u32, height: u32, rgb: &[f32]) -> Result<Self> {
        check_size("image", width, height)?;
        let n = width as usize * height as usize;
        let bad = |reason: String| Error::ImageSize {
            input: "image".into(),
            width,
            height,
            reason,
        };
        if rgb.len() != 3 * n {
            return Err(bad(format!(
                "expected {} RGB values, got {}",
                3 * n,
                rgb.len()
            )));
        }
        if let Some(i) = rgb.iter().position(|v| !v.is_finite()) {
            return Err(bad(format!("value {i} is not finite")));
        }
        let gray = rgb
            .chunks_exact(3)
            .map(|p| 0.299 * p[0] + 0.587 * p[1] + 0.114 * p[2])
            .collect();
        let rgb = rgb
            .iter()
            .map(|&v| (v.clamp(0.0, 1.0) * 255.0).round() as u8)
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

    /// Loads and decodes an image file of at most [`DEFAULT_MAX_PIXELS`]; errors name the file.
    pub fn load(path: &Path) -> Result<Self> {
        Self::load_limited(path, DEFAULT_MAX_PIXELS)
    }

    /// Loads and decodes an image file of at most `max_pixels` pixels. The format comes from
    /// the first bytes (or the extension) and the size from the header, both before anything
    /// else is read, so a huge or foreign file costs a few bytes, not its length; errors name
    /// the file, the size and the limit.
    pub fn load_limited(path: &Path, max_pixels: u64) -> Result<Self> {
        use std::io::{BufReader, Read, Seek};
        let io = |source| Error::Io {
            path: path.to_path_buf(),
            source,
        };
        let decode_err = |reason: String| decode_error(path, reason);
        let image_err = |e: image::ImageError| image_error(path, e);
        let mut file = crate::error::open_input(path)?;
        let mut head = Vec::with_capacity(64);
        (&mut file).take(64).read_to_end(&mut head).map_err(io)?;
        if head.is_empty() {
            return Err(decode_err("file is empty".into()));
        }
        let format = image::guess_format(&head)
            .or_else(|_| image::ImageFormat::from_path(path))
            .map_err(image_err)?;
        let file_len = file.metadata().map_err(io)?.len();
        file.rewind().map_err(io)?;
        let mut reader = image::ImageReader::with_format(BufReader::new(file), format);
        let (width, height) = reader.into_dimensions().map_err(image_err)?;
        let name = path.display().to_string();
        check_size(&name, width, height)?;
        if width as u64 * height as u64 > max_pixels {
            return Err(Error::ImageSize {
                input: name,
                width,
                height,
                reason: format!(
                    "{} pixels exceed the limit of {max_pixels} (--max-pixels)",
                    width as u64 * height as u64
                ),
            });
        }
        reader = image::ImageReader::with_format(
            BufReader::new(crate::error::open_input(path)?),
            format,
        );
        let limits = decode_limits(width, height, file_len);
        let max_alloc = limits.max_alloc;
        reader.limits(limits);
        let img = reader.decode().map_err(|e| match e {
            // The decoder's own words give neither the size nor the limit.
            image::ImageError::Limits(_) => Error::Decode {
                path: path.to_path_buf(),
                reason: format!(
                    "{e}: the header says {width}x{height}, and decoding that may allocate at most {} bytes",
                    max_alloc.unwrap_or(0)
                ),
                source: Some(Box::new(e)),
            },
            other => image_err(other),
        })?;
        if format == image::ImageFormat::Jpeg {
            if let Some(reason) = truncation(path) {
                log::warn!("{name}: {reason}");
            }
        }
        Self::named(&name, &img)
    }

    /// The frame of a decoded image, errors naming `name`.
    fn named(name: &str, img: &image::DynamicImage) -> Result<Self> {
        check_size(name, img.width(), img.height())?;
        Self::from_dynamic(img).map_err(|e| match e {
            Error::ImageSize {
                width,
                height,
                reason,
                ..
            } => Error::ImageSize {
                input: name.to_string(),
                width,
                height,
                reason,
            },
            other => other,
        })
    }

    /// Decodes an image held in memory; `path` is only used to name it in errors and to guess
    /// the format when the bytes do not reveal it.
    pub fn decode(path: &Path, bytes: &[u8]) -> Result<Self> {
        let decode_err = |reason: String| decode_error(path, reason);
        let image_err = |e: image::ImageError| image_error(path, e);
        if bytes.is_empty() {
            return Err(decode_err("file is empty".into()));
        }
        let format = image::guess_format(bytes)
            .or_else(|_| image::ImageFormat::from_path(path))
            .map_err(image_err)?;
        let mut reader = image::ImageReader::with_format(std::io::Cursor::new(bytes), format);
        reader.limits({
            let mut l = image::Limits::default();
            l.max_image_width = Some(MAX_SIDE);
            l.max_image_height = Some(MAX_SIDE);
            l
        });
        let img = reader.decode().map_err(image_err)?;
        Self::named(&path.display().to_string(), &img)
    }

    /// Number of pixels.
    pub fn pixels(&self) -> usize {
        self.width as usize * self.height as usize
    }
}

/// Pixel budget of [`Frame::load`]: about 100 megapixels.
pub const DEFAULT_MAX_PIXELS: u64 = 100_000_000;

/// Decoder limits for an image whose header says `width`×`height`, in a file of `file_len`
/// bytes: sides as declared, and allocations bounded by what such an image needs (16-bit RGBA
/// at most) plus six times the file's own length, what the PNG decoder counts for metadata
/// (an XMP or ICC chunk: each doubling of its chunk buffer counted anew, then its text): a
/// header that lies cannot make the decoder allocate more, and a small image with large
/// metadata still decodes.
fn decode_limits(width: u32, height: u32, file_len: u64) -> image::Limits {
    let mut l = image::Limits::default();
    l.max_image_width = Some(width);
    l.max_image_height = Some(height);
    l.max_alloc = Some((width as u64 * height as u64 * 8).max(1 << 20) + 6 * file_len);
    l
}

/// Why an image file looks incomplete, if it does. A JPEG cut short still decodes (the missing
/// part comes out grey) without an error from the decoder, so its end is checked here: the
/// end-of-image marker must lie in its last 64 KiB (a 0xFF 0xD9 pair cannot occur inside the
/// entropy-coded data, where 0xFF is always followed by 0x00).
pub fn truncation(path: &Path) -> Option<String> {
    use std::io::{Read, Seek, SeekFrom};
    let mut file = std::fs::File::open(path).ok()?;
    let mut head = [0u8; 3];
    file.read_exact(&mut head).ok()?;
    if head != [0xFF, 0xD8, 0xFF] {
        return None;
    }
    let len = file.metadata().ok()?.len();
    let tail_len = len.min(64 * 1024);
    file.seek(SeekFrom::Start(len - tail_len)).ok()?;
    let mut tail = Vec::with_capacity(tail_len as usize);
    file.take(tail_len).read_to_end(&mut tail).ok()?;
    let complete = tail.windows(2).any(|w| w == [0xFF, 0xD9]);
    (!complete).then(|| {
        "the JPEG ends without its end-of-image marker: the file is truncated, and the missing part decodes as grey".to_string()
    })
}

/// An [`Error::Decode`] of `path` with a reason of ours.
fn decode_error(path: &Path, reason: String) -> Error {
    Error::Decode {
        path: path.to_path_buf(),
        reason,
        source: None,
    }
}

/// An [`Error::Decode`] of `path` keeping the decoder's error as its source.
fn image_error(path: &Path, e: image::ImageError) -> Error {
    Error::Decode {
        path: path.to_path_buf(),
        reason: e.to_string(),
        source: Some(Box::new(e)),
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
