//! Regenerates `assets/sample.png`, the bundled sample scene (seeded, 640×480):
//! `cargo run --release --example generate_sample`.
fn main() {
    let frame = steernav::synth::textured_scene(640, 480, 1);
    let img = image::RgbImage::from_raw(frame.width, frame.height, frame.rgb).expect("valid frame");
    img.save("assets/sample.png").expect("assets/ is writable");
    println!("wrote assets/sample.png");
}
