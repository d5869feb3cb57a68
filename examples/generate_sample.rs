//! Regenerates `assets/sample.png`, the bundled sample scene (seeded, 640×480):
//! `cargo run --release --example generate_sample`. With arguments it writes a scene of any
//! size instead, e.g. the 24 MP input of `benches/memory.sh`:
//! `cargo run --release --example generate_sample -- 6000 4000 /tmp/24mp.ppm`.
fn main() {
    let args: Vec<String> = std::env::args().skip(1).collect();
    let (width, height, path) = match args.as_slice() {
        [] => (640, 480, "assets/sample.png".to_string()),
        [w, h, path] => (
            w.parse().expect("WIDTH is a positive integer"),
            h.parse().expect("HEIGHT is a positive integer"),
            path.clone(),
        ),
        _ => {
            eprintln!("usage: generate_sample [WIDTH HEIGHT OUT]");
            std::process::exit(2);
        }
    };
    let frame = steernav::low_level::synth::textured_scene(width, height, 1);
    let img = image::RgbImage::from_raw(frame.width, frame.height, frame.rgb).expect("valid frame");
    img.save(&path).expect("the output path is writable");
    println!("wrote {path}");
}
