//! Every WGSL module the renderer builds parses and validates with naga,
//! the compiler inside wgpu: a typo, a type error or a bad binding fails
//! here, on any machine, without a GPU.
#![cfg(feature = "viewer")]

use drape::render::shaders;

#[test]
fn every_shader_module_parses_and_validates() {
    let modules = shaders::modules();
    assert_eq!(modules.len(), shaders::FILES.len());
    for (name, source) in modules {
        let module = match naga::front::wgsl::parse_str(&source) {
            Ok(m) => m,
            Err(e) => panic!("{name} does not parse:\n{}", e.emit_to_string_with_path(&source, name)),
        };
        let mut validator =
            naga::valid::Validator::new(naga::valid::ValidationFlags::all(), naga::valid::Capabilities::empty());
        if let Err(e) = validator.validate(&module) {
            panic!("{name} does not validate:\n{}", e.emit_to_string_with_path(&source, name));
        }
        assert!(!module.entry_points.is_empty(), "{name} has no entry point");
    }
}

#[test]
fn every_file_in_the_shaders_directory_is_built() {
    let dir = std::path::Path::new(env!("CARGO_MANIFEST_DIR")).join("shaders");
    let mut on_disk: Vec<String> = std::fs::read_dir(&dir)
        .unwrap()
        .map(|e| e.unwrap().file_name().to_string_lossy().into_owned())
        .filter(|n| n.ends_with(".wgsl") && n != "common.wgsl")
        .collect();
    on_disk.sort();
    let mut built: Vec<String> = shaders::FILES.iter().map(|f| f.name.to_string()).collect();
    built.sort();
    assert_eq!(on_disk, built, "a shader in shaders/ is not in render::shaders::FILES (or the reverse)");
}
