//! Bad input gives a clear error naming the input and the reason, never a panic.

mod common;

use std::path::Path;

use steernav::{Backend, Detector, DetectorConfig, Error, Frame};

#[test]
fn missing_empty_and_truncated_files_are_named() {
    let dir = tempfile::tempdir().unwrap();
    let missing = dir.path().join("nope.png");
    let e = Frame::load(&missing).unwrap_err().to_string();
    assert!(e.contains("nope.png"), "{e}");

    let empty = dir.path().join("empty.png");
    std::fs::write(&empty, b"").unwrap();
    let e = Frame::load(&empty).unwrap_err().to_string();
    assert!(e.contains("empty.png") && e.contains("empty"), "{e}");

    let full =
        std::fs::read(Path::new(env!("CARGO_MANIFEST_DIR")).join("assets/sample.png")).unwrap();
    let truncated = dir.path().join("truncated.png");
    std::fs::write(&truncated, &full[..full.len() / 3]).unwrap();
    let e = Frame::load(&truncated).unwrap_err();
    assert!(matches!(e, Error::Decode { .. }), "{e}");
    assert!(e.to_string().contains("truncated.png"), "{e}");

    let garbage = dir.path().join("garbage.jpg");
    std::fs::write(&garbage, b"this is not an image at all").unwrap();
    assert!(Frame::load(&garbage)
        .unwrap_err()
        .to_string()
        .contains("garbage.jpg"));
}

#[test]
fn zero_and_one_pixel_images() {
    let e = Frame::from_rgb(0, 0, vec![]).unwrap_err().to_string();
    assert!(e.contains("0x0") && e.contains("empty"), "{e}");
    // A 0x0 PNG on disk is refused by name too.
    let dir = tempfile::tempdir().unwrap();
    let p = dir.path().join("zero.png");
    let img = image::RgbImage::new(0, 0);
    if img.save(&p).is_ok() {
        let e = Frame::load(&p).unwrap_err().to_string();
        assert!(e.contains("zero.png"), "{e}");
    }
    let one = Frame::from_rgb(1, 1, vec![10, 20, 30]).unwrap();
    for backend in [Backend::Cpu, Backend::Auto] {
        let det = Detector::new(&DetectorConfig::default(), backend).unwrap();
        let d = det.detect(&one).unwrap();
        assert!(d.keypoints.is_empty());
    }
    let nan = Frame::from_gray(2, 2, vec![0.0, f32::NAN, 0.0, 0.0])
        .unwrap_err()
        .to_string();
    assert!(nan.contains("not finite"), "{nan}");
}

#[test]
fn one_pixel_image_on_the_gpu() {
    if common::gpu().is_none() {
        return;
    }
    let det = Detector::new(&DetectorConfig::default(), Backend::Gpu).unwrap();
    for (w, h) in [(1, 1), (3, 2), (17, 5)] {
        let f = Frame::from_rgb(w, h, vec![99; (3 * w * h) as usize]).unwrap();
        assert!(det.detect(&f).unwrap().keypoints.is_empty());
    }
}

#[test]
fn huge_request_on_the_gpu_names_the_device_limit() {
    if common::gpu().is_none() {
        return;
    }
    let det = Detector::new(&DetectorConfig::default(), Backend::Gpu).unwrap();
    let e = det.check_size(20000, 20000).unwrap_err().to_string();
    assert!(e.contains("20000x20000"), "{e}");
    let gpu = det.gpu().unwrap();
    let e = gpu.check_fits(20000, 20000).unwrap_err().to_string();
    assert!(
        e.contains("max_storage_buffer_binding_size") && e.contains("20000x20000"),
        "{e}"
    );
}

#[test]
fn non_finite_and_out_of_range_config_values_are_refused() {
    for text in [
        "basis_sigma = nan",
        "[detector]\ngamma = inf",
        "threshold = -1.0",
        "orientations = 0",
        "scales = 99",
        "scale_step = 1.0",
        "harris_k = nan",
        "rank_normalization = -1.0",
        "rank_normalization = nan",
        "max_keypoints = 0",
        "image_blur = nan",
        "image_blur = 7.5",
    ] {
        let e = DetectorConfig::from_toml_str(text).unwrap_err().to_string();
        let field = text
            .trim_start_matches("[detector]\n")
            .split(' ')
            .next()
            .unwrap();
        assert!(e.contains(field), "{text}: {e}");
    }
    assert!(DetectorConfig::from_toml_str("orientations = \"eight\"").is_err());
    assert!(DetectorConfig::from_toml_str("no_such_field = 1").is_err());
    let ok = DetectorConfig::from_toml_str("[detector]\norientations = 16\n").unwrap();
    assert_eq!(ok.orientations, 16);
    let cfg = DetectorConfig {
        sigma0: f32::NAN,
        ..Default::default()
    };
    assert!(matches!(
        Detector::new(&cfg, Backend::Cpu),
        Err(Error::Config {
            field: "sigma0",
            ..
        })
    ));
}

#[test]
fn float_settings_that_would_explode_the_work_are_refused_naming_the_key() {
    for (key, value) in [
        ("basis_sigma", 1e30f32),
        ("basis_sigma", 1e6),
        ("sigma0", 1e6),
        ("truncate", 1e4),
        ("merge_radius", 1e9),
        ("gamma", 1e5),
    ] {
        let mut config = DetectorConfig::default();
        match key {
            "basis_sigma" => config.basis_sigma = value,
            "sigma0" => config.sigma0 = value,
            "truncate" => config.truncate = value,
            "merge_radius" => config.merge_radius = value,
            _ => config.gamma = value,
        }
        let message = Detector::new(&config, Backend::Cpu)
            .err()
            .map(|e| e.to_string())
            .unwrap_or_default();
        assert!(message.contains(key), "{key} = {value}: {message:?}");
    }
    let config = DetectorConfig {
        scale_step: 1e3,
        ..DetectorConfig::default()
    };
    assert!(Detector::new(&config, Backend::Cpu).is_err());
}

#[test]
fn flaser_lines_with_a_wrong_or_absurd_beam_count_name_the_line() {
    let ranges = ["1.5"; 4].join(" ");
    let good = format!("FLASER 4 {ranges} 0 0 0 0 0 0 12.5 host 12.5");
    let path = Path::new("log.clf");
    let scans = steernav::nav::carmen::parse(path, good.as_bytes()).unwrap();
    assert_eq!(scans.len(), 1);
    for bad in [
        format!("FLASER 3 {ranges} 0 0 0 0 0 0 12.5 host 12.5"),
        format!("FLASER 18446744073709551615 {ranges} 0 0 0 0 0 0 12.5 host 12.5"),
    ] {
        let text = format!("{good}\n{bad}\n");
        let message = steernav::nav::carmen::parse(path, text.as_bytes())
            .unwrap_err()
            .to_string();
        assert!(
            message.contains("log.clf") && message.contains("line 2"),
            "{message}"
        );
    }
}

#[test]
fn rotation_angles_beyond_ten_turns_are_refused() {
    let message = steernav::eval::sweep::parse_angles("1e308").unwrap_err();
    assert!(
        message.contains("1e308") && message.contains("3600"),
        "{message}"
    );
    assert!(steernav::eval::sweep::parse_angles("0:360:15").is_ok());
}

/// A small PNG whose header claims 12000×9000 pixels.
/// One PNG chunk: length, type, data and CRC.
fn chunk(kind: &[u8], data: &[u8]) -> Vec<u8> {
    fn crc32(bytes: &[u8]) -> u32 {
        let mut crc = 0xffff_ffffu32;
        for &b in bytes {
            crc ^= b as u32;
            for _ in 0..8 {
                crc = if crc & 1 == 1 {
                    (crc >> 1) ^ 0xedb8_8320
                } else {
                    crc >> 1
                };
            }
        }
        !crc
    }
    let mut out = (data.len() as u32).to_be_bytes().to_vec();
    out.extend_from_slice(kind);
    out.extend_from_slice(data);
    let mut crc_input = kind.to_vec();
    crc_input.extend_from_slice(data);
    out.extend_from_slice(&crc32(&crc_input).to_be_bytes());
    out
}

fn png_claiming(width: u32, height: u32) -> Vec<u8> {
    let mut ihdr = width.to_be_bytes().to_vec();
    ihdr.extend_from_slice(&height.to_be_bytes());
    ihdr.extend_from_slice(&[8, 2, 0, 0, 0]);
    let mut png = b"\x89PNG\r\n\x1a\n".to_vec();
    png.extend(chunk(b"IHDR", &ihdr));
    png.extend(chunk(
        b"IDAT",
        &[0x78, 0x9c, 0x03, 0x00, 0x00, 0x00, 0x00, 0x01],
    ));
    png.extend(chunk(b"IEND", &[]));
    png
}

#[test]
fn images_beyond_the_pixel_budget_are_refused_from_their_header() {
    let dir = tempfile::tempdir().unwrap();
    let big = dir.path().join("big.png");
    std::fs::write(&big, png_claiming(12000, 9000)).unwrap();
    let message = Frame::load(&big).unwrap_err().to_string();
    assert!(
        message.contains("big.png")
            && message.contains("12000x9000")
            && message.contains("108000000 pixels")
            && message.contains("100000000"),
        "{message}"
    );
    let sample = Path::new(env!("CARGO_MANIFEST_DIR")).join("assets/sample.png");
    let message = Frame::load_limited(&sample, 1000).unwrap_err().to_string();
    assert!(
        message.contains("307200 pixels exceed the limit of 1000"),
        "{message}"
    );
    // A file that is no image is refused from its first bytes, whatever its length.
    let fake = dir.path().join("fake.png");
    let file = std::fs::File::create(&fake).unwrap();
    file.set_len(1 << 30).unwrap();
    let message = Frame::load(&fake).unwrap_err().to_string();
    assert!(message.contains("fake.png"), "{message}");
}

#[test]
fn a_small_image_with_large_metadata_decodes() {
    // 160×120 with a 2 MB XMP packet (an iTXt chunk after IHDR): metadata is bounded by the
    // file's length, not by the pixel budget.
    let mut png = Vec::new();
    image::RgbImage::from_pixel(160, 120, image::Rgb([90, 120, 30]))
        .write_to(&mut std::io::Cursor::new(&mut png), image::ImageFormat::Png)
        .unwrap();
    let mut itxt = b"XML:com.adobe.xmp\0\0\0\0\0".to_vec();
    itxt.extend(std::iter::repeat_n(b'x', 2 << 20));
    let ihdr_end = 8 + 25;
    let mut with_xmp = png[..ihdr_end].to_vec();
    with_xmp.extend(chunk(b"iTXt", &itxt));
    with_xmp.extend_from_slice(&png[ihdr_end..]);
    let dir = tempfile::tempdir().unwrap();
    let path = dir.path().join("xmp.png");
    std::fs::write(&path, &with_xmp).unwrap();
    let frame = Frame::load(&path).unwrap();
    assert_eq!((frame.width, frame.height), (160, 120));
}

#[test]
fn config_errors_name_the_real_key() {
    let cases = [
        ("[detector]\norientatons = 8\n", "orientatons"),
        ("[detector]\norientations = \"eight\"\n", "orientations"),
        ("[detector]\nbasis = \"third\"\n", "third"),
        ("[detecter]\norientations = 8\n", "detecter"),
        ("scales = 3\n[detector]\norientations = 8\n", "scales"),
        ("orientatons = 8\n", "orientatons"),
    ];
    for (text, culprit) in cases {
        let message = DetectorConfig::from_toml_str(text).unwrap_err().to_string();
        assert!(message.contains(culprit), "{text:?}: {message}");
        assert!(
            !message.contains("unknown field `detector`"),
            "{text:?}: {message}"
        );
    }
    let ok = DetectorConfig::from_toml_str("[detector]\norientations = 8\n").unwrap();
    assert_eq!(ok.orientations, 8);
    let bare = DetectorConfig::from_toml_str("scales = 3\n").unwrap();
    assert_eq!(bare.scales, 3);
}

#[test]
fn auto_never_takes_a_software_adapter() {
    // In CI the only adapter is lavapipe: `auto` must run on the CPU there.
    let detector = Detector::new(&DetectorConfig::default(), Backend::Auto).unwrap();
    match steernav::GpuContext::shared() {
        Ok(ctx) if ctx.auto_refusal().is_some() => assert_eq!(detector.backend(), Backend::Cpu),
        Ok(_) => assert_eq!(detector.backend(), Backend::Gpu),
        Err(_) => assert_eq!(detector.backend(), Backend::Cpu),
    }
}

/// Every setting that sizes work or memory has a bound: the values a careless or hostile file
/// gives are refused by name before anything is allocated or run.
#[test]
fn settings_that_would_blow_up_work_or_memory_are_refused() {
    use steernav::nav::sim::episode::EpisodeConfig;
    use steernav::slam::data::synthetic::{SyntheticConfig, SyntheticSequence};
    let many = format!("[{}]", vec!["8"; 200_000].join(", "));
    let cases = [
        (
            "[slam.map]\ngrid = [100000, 100000]\n".to_string(),
            "slam.map.grid",
        ),
        (
            "[slam.start]\ncorner_grid = [0, 4]\n".to_string(),
            "slam.start.corner_grid",
        ),
        ("[slam.klt]\nlevels = 1000\n".to_string(), "slam.klt.levels"),
        (
            "[slam.refine]\nkeyframes = 8\nfixed = 8\n".to_string(),
            "slam.refine.fixed",
        ),
        (
            format!("[gist]\norientations_per_scale = {many}\n"),
            "orientations_per_scale",
        ),
        (
            "[nav.controller]\nfield_steps = 1000000000\n".to_string(),
            "field_steps",
        ),
        (
            "[synthetic]\ntexels_per_metre = 1e30\n".to_string(),
            "texels_per_metre",
        ),
        ("[synthetic]\nk1 = nan\n".to_string(), "k1"),
        ("[synthetic]\nclutter = 100000\n".to_string(), "clutter"),
        ("[synthetic]\nexposure = 1.0\n".to_string(), "exposure"),
        ("[synthetic]\nnoise = 1e9\n".to_string(), "noise"),
        // Two rooms need the walk: their doors go where its route crosses the wall.
        ("[synthetic]\nrooms = 2\n".to_string(), "rooms"),
    ];
    for (text, key) in cases {
        let s = steernav::Settings::from_toml_str(&text).unwrap();
        let refused = [
            s.slam.validate().err(),
            s.gist.validate().err(),
            EpisodeConfig::validate(&s.nav).err(),
            SyntheticSequence::new(SyntheticConfig {
                frames: 1,
                ..s.synthetic.clone()
            })
            .err(),
        ];
        let messages: Vec<String> = refused.iter().flatten().map(|e| e.to_string()).collect();
        assert!(
            messages.iter().any(|m| m.contains(key)),
            "{text:?}: {messages:?}"
        );
    }
}
