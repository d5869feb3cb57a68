//! Every WGSL file under shaders/ parses and validates with naga; no GPU needed.

#[test]
fn every_shader_validates_with_naga() {
    let dir = std::path::Path::new(env!("CARGO_MANIFEST_DIR")).join("shaders");
    let mut files = Vec::new();
    for entry in std::fs::read_dir(&dir).expect("shaders/ exists") {
        let path = entry.unwrap().path();
        if path.extension().is_some_and(|e| e == "wgsl") {
            let src = std::fs::read_to_string(&path).unwrap();
            let module = naga::front::wgsl::parse_str(&src)
                .unwrap_or_else(|e| panic!("{}: {}", path.display(), e.emit_to_string(&src)));
            naga::valid::Validator::new(
                naga::valid::ValidationFlags::all(),
                naga::valid::Capabilities::default(),
            )
            .validate(&module)
            .unwrap_or_else(|e| panic!("{}: {e:?}", path.display()));
            files.push((
                path.file_name().unwrap().to_string_lossy().into_owned(),
                src,
            ));
        }
    }
    // Each file is embedded by exactly one stage's driver, under its own name.
    let embedded: Vec<(&str, &str)> = [
        &steernav::low_level::harris::gpu::SHADERS[..],
        &steernav::low_level::filter_bank::gpu::SHADERS[..],
        &steernav::low_level::steered::gpu::SHADERS[..],
        &steernav::low_level::dnf::gpu::SHADERS[..],
        &steernav::low_level::gist::gpu::SHADERS[..],
    ]
    .concat();
    assert_eq!(embedded.len(), files.len());
    for (name, src) in &files {
        let found = embedded.iter().find(|(n, _)| n == name);
        assert_eq!(found.map(|(_, s)| *s), Some(src.as_str()), "{name}");
    }
}
