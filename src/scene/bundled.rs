//! Scenes and meshes compiled into the binary, so `drape run --scene seed`
//! works from any directory. The files live in `assets/`.

/// A scene shipped with drape.
#[derive(Clone, Copy, Debug)]
pub struct BundledScene {
    /// The name it is loaded by (its file stem).
    pub name: &'static str,
    /// The TOML text.
    pub text: &'static str,
}

macro_rules! scene {
    ($name:literal) => {
        BundledScene { name: $name, text: include_str!(concat!("../../assets/scenes/", $name, ".toml")) }
    };
}

/// Every bundled scene, the seed's first.
pub const BUNDLED: &[BundledScene] = &[
    scene!("seed"),
    scene!("seed-inextensible"),
    scene!("seed-inextensible-fast"),
    scene!("flag"),
    scene!("flag-seed"),
    scene!("hammock"),
    scene!("chain"),
    scene!("tablecloth"),
    scene!("large"),
    scene!("large-inextensible"),
    scene!("drape-sphere"),
    scene!("table"),
    scene!("slope"),
    scene!("slope-steep"),
    scene!("carried"),
    scene!("pile"),
    scene!("two-sheets"),
    scene!("drape-sphere-self"),
    scene!("falling-sheet"),
    scene!("drape-silk"),
    scene!("drape-denim"),
];

/// Bundled OBJ meshes by file name.
const MESHES: &[(&str, &str)] = &[
    ("tablecloth.obj", include_str!("../../assets/meshes/tablecloth.obj")),
    ("strip.obj", include_str!("../../assets/meshes/strip.obj")),
    ("two-sheets.obj", include_str!("../../assets/meshes/two-sheets.obj")),
];

/// The bundled scene called `name`.
pub fn find(name: &str) -> Option<&'static BundledScene> {
    BUNDLED.iter().find(|b| b.name == name)
}

/// The bundled mesh a bundled scene's `[obj] path` names (by its file name).
pub(super) fn mesh(path: &str) -> Option<&'static str> {
    let file = path.rsplit(['/', '\\']).next()?;
    MESHES.iter().find(|(name, _)| *name == file).map(|(_, text)| *text)
}
