//! The WGSL sources, compiled into the binary from the top-level `shaders/`
//! directory. Each module is `common.wgsl` (the uniform block and helpers)
//! followed by its own file; [`modules`] is what both the renderer and the
//! shader-validation test compile.

/// The uniform block, sRGB output and the strain ramp, shared by every module.
pub const COMMON: &str = include_str!("../../shaders/common.wgsl");

/// One shader module: its name and its own source (without [`COMMON`]).
#[derive(Clone, Copy, Debug)]
pub struct ShaderFile {
    /// The file's name in `shaders/`.
    pub name: &'static str,
    /// Its text.
    pub text: &'static str,
}

/// The lit cloth surface, its shadow and the wireframe.
pub const SURFACE: ShaderFile = ShaderFile { name: "surface.wgsl", text: include_str!("../../shaders/surface.wgsl") };
/// The sky gradient and the ground grid.
pub const BACKDROP: ShaderFile =
    ShaderFile { name: "backdrop.wgsl", text: include_str!("../../shaders/backdrop.wgsl") };
/// Bars as screen-space ribbons.
pub const LINES: ShaderFile = ShaderFile { name: "lines.wgsl", text: include_str!("../../shaders/lines.wgsl") };
/// Particles as dots.
pub const POINTS: ShaderFile = ShaderFile { name: "points.wgsl", text: include_str!("../../shaders/points.wgsl") };

/// Colliders and their shadows.
pub const COLLIDERS: ShaderFile =
    ShaderFile { name: "colliders.wgsl", text: include_str!("../../shaders/colliders.wgsl") };

/// Every module the renderer builds.
pub const FILES: [ShaderFile; 5] = [SURFACE, BACKDROP, LINES, POINTS, COLLIDERS];

impl ShaderFile {
    /// The complete module source: [`COMMON`] then this file.
    pub fn source(&self) -> String {
        format!("{COMMON}\n{}", self.text)
    }
}

/// Every module's name and complete source.
pub fn modules() -> Vec<(&'static str, String)> {
    FILES.iter().map(|f| (f.name, f.source())).collect()
}
