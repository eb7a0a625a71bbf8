//! Scene files: TOML that describes a cloth and how to simulate it.
//!
//! A scene has a `[solver]` table (h, δ, m, relaxations, gravity), a `[wind]`
//! table, and exactly one of `[grid]` (the seed's rectangle), `[mesh]` (the
//! seed's particle list and adjacency list) or `[obj]` (a Wavefront OBJ
//! triangle mesh, path relative to the scene file). An optional `[camera]`
//! table suggests a view, and any number of `[[collider]]` tables give what
//! the cloth can touch. Every key is documented in the README; unknown keys
//! are errors, so a typo never passes silently.
//!
//! Scenes are named by path (`assets/scenes/seed.toml`) or, for the scenes
//! bundled into the binary, by name (`seed`): see [`load`] and [`BUNDLED`].

mod bundled;
pub mod colliders;
mod file;
mod obj;
mod translate;

use std::path::{Path, PathBuf};
use std::sync::Arc;

pub use bundled::{BUNDLED, BundledScene};
pub use file::SceneFile;
pub use obj::parse_obj;

use crate::sim::{ClothMesh, Collider, MeshError, SimError, Simulation, SolverKind, SolverParams};

/// A suggested view of the scene for the viewer and `drape render`.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct CameraHint {
    /// Rotation about the vertical axis, degrees; 0 looks along −z.
    pub yaw_degrees: f32,
    /// Elevation, degrees; positive looks down on the cloth.
    pub pitch_degrees: f32,
    /// Distance from the target in metres, for a 16:10 view (narrower views
    /// move back to keep the same width); `None` fits the cloth in view.
    pub distance: Option<f32>,
    /// The point looked at; `None` is the centre of the cloth's initial bounds.
    pub target: Option<glam::Vec3>,
}

impl Default for CameraHint {
    fn default() -> Self {
        Self { yaw_degrees: 20.0, pitch_degrees: 15.0, distance: None, target: None }
    }
}

/// How the viewer advances time in a scene (`[viewer] time`).
#[derive(Clone, Copy, Debug, Default, PartialEq, Eq, serde::Deserialize, serde::Serialize)]
#[serde(rename_all = "kebab-case")]
pub enum Playback {
    /// Real time where the solver can hold it, else a step per frame: the
    /// viewer times a few steps when it loads the scene. The default.
    #[default]
    Auto,
    /// Simulated time follows the clock.
    RealTime,
    /// One step of h per displayed frame, as the seed's program did.
    StepPerFrame,
}

/// A loaded, validated scene: ready to become a [`Simulation`].
#[derive(Clone, Debug)]
pub struct Scene {
    /// A short title.
    pub name: String,
    /// One or two sentences on what the scene shows.
    pub description: String,
    /// Where it came from: a path, or `bundled:<name>`.
    pub source: String,
    /// The cloth.
    pub mesh: Arc<ClothMesh>,
    /// The scene's solver parameters (the viewer's Reset returns to these).
    pub params: SolverParams,
    /// The scene's choice of solver.
    pub solver: SolverKind,
    /// The suggested view.
    pub camera: CameraHint,
    /// What the cloth can touch.
    pub colliders: Vec<Collider>,
    /// How the viewer advances time.
    pub playback: Playback,
}

impl Scene {
    /// A fresh simulation of this scene with its own parameters, solver and
    /// colliders.
    pub fn simulation(&self) -> Result<Simulation, SimError> {
        Ok(Simulation::with_solver(self.mesh.clone(), self.params.clone(), self.solver)?
            .with_colliders(self.colliders.clone()))
    }
}

/// What is wrong with a scene, and where.
#[derive(Debug, thiserror::Error)]
#[error("{source_name}: {kind}")]
pub struct SceneError {
    /// The file path, or `bundled:<name>`.
    pub source_name: String,
    /// What went wrong.
    pub kind: SceneErrorKind,
}

/// The kinds of [`SceneError`].
#[derive(Debug, thiserror::Error)]
pub enum SceneErrorKind {
    /// The file could not be read (the I/O error in the message only, not
    /// also as its source, so that a chain printed whole says it once).
    #[error("cannot read it: {0}")]
    Io(std::io::Error),
    /// The TOML is malformed or has a key of the wrong type or name; the
    /// message gives the line and column.
    #[error("{0}")]
    Syntax(String),
    /// A key has a value outside what it allows.
    #[error("{key}: {message}")]
    Invalid {
        /// The key, as `table.key`.
        key: String,
        /// What is wrong and what is allowed.
        message: String,
    },
    /// The cloth described cannot be built.
    #[error("[{table}]: {error}")]
    Mesh {
        /// `grid`, `mesh` or `obj`.
        table: &'static str,
        /// Why.
        error: MeshError,
    },
    /// The OBJ file could not be read or parsed.
    #[error("[obj] path {path}: {message}")]
    Obj {
        /// The path as resolved.
        path: String,
        /// Why.
        message: String,
    },
    /// The name is neither a file nor a bundled scene.
    #[error("no such file, and no bundled scene of that name (bundled scenes: {available})")]
    NotFound {
        /// The bundled names, comma-separated.
        available: String,
    },
}

impl SceneError {
    fn new(source_name: impl Into<String>, kind: SceneErrorKind) -> Self {
        Self { source_name: source_name.into(), kind }
    }
}

/// Loads a scene named by path or by bundled name.
///
/// A name without a path separator or `.toml` extension that matches a
/// bundled scene loads that scene; anything else is read as a file.
pub fn load(name_or_path: &str) -> Result<Scene, SceneError> {
    let looks_like_path = name_or_path.contains(['/', '\\']) || name_or_path.ends_with(".toml");
    if !looks_like_path && let Some(b) = bundled::find(name_or_path) {
        return parse(b.text, &Origin::Bundled(b.name));
    }
    let path = Path::new(name_or_path);
    if !looks_like_path && !path.exists() {
        let available = BUNDLED.iter().map(|b| b.name).collect::<Vec<_>>().join(", ");
        return Err(SceneError::new(name_or_path, SceneErrorKind::NotFound { available }));
    }
    load_file(path)
}

/// Loads a scene file; an `[obj]` path is resolved relative to it.
pub fn load_file(path: &Path) -> Result<Scene, SceneError> {
    let text = std::fs::read_to_string(path)
        .map_err(|e| SceneError::new(path.display().to_string(), SceneErrorKind::Io(e)))?;
    parse(&text, &Origin::File(path.to_path_buf()))
}

/// Where a scene's text came from, which decides how `[obj] path` resolves.
#[derive(Clone, Debug)]
pub enum Origin {
    /// A file on disk: OBJ paths are relative to its directory.
    File(PathBuf),
    /// A scene bundled into the binary: OBJ paths name bundled meshes.
    Bundled(&'static str),
    /// Text with no file (tests, the fuzzer): OBJ paths are relative to the
    /// working directory.
    Text,
}

impl Origin {
    fn display(&self) -> String {
        match self {
            Origin::File(p) => p.display().to_string(),
            Origin::Bundled(name) => format!("bundled:{name}"),
            Origin::Text => "<scene text>".to_string(),
        }
    }
}

/// Parses and validates scene text.
pub fn parse(text: &str, origin: &Origin) -> Result<Scene, SceneError> {
    translate::build(text, origin).map_err(|kind| SceneError::new(origin.display(), kind))
}

#[cfg(test)]
mod tests;
