//! Getting a simulation out: recorded frames, and files other tools read.
//!
//! - [`Recording`]: the frames of a run (positions, and for the viewer's
//!   timeline the previous positions that let it resume), bounded in
//!   memory.
//! - [`glb`]: one binary glTF 2.0 file, the cloth's triangle mesh and its
//!   motion as morph targets keyed in time (what Blender's importer and
//!   three.js play back).
//! - [`obj`]: one Wavefront OBJ per frame.
//! - [`Exporter`]: takes frames as a run makes them and writes whichever
//!   of the two its path asks for: `….glb`, or a path containing `{frame}`.
//!
//! ```
//! use drape::export::Exporter;
//! use drape::sim::{Grid, Simulation, SolverParams};
//!
//! let mut sim = Simulation::new(Grid::default().build()?, SolverParams::default())?;
//! let path = std::env::temp_dir().join("drape-doc-example.glb");
//! let mut export = Exporter::new(&path, sim.mesh().clone(), 11)?;
//! export.frame(&sim)?; // t = 0
//! for _ in 0..10 {
//!     sim.advance(5)?;
//!     export.frame(&sim)?; // every 5 steps, 0.25 s apart
//! }
//! let report = export.finish()?;
//! assert_eq!((report.frames, report.files), (11, 1));
//! assert!(std::fs::metadata(&path)?.len() > 11 * 600 * 24); // two Vec3 per particle per frame
//! # Ok::<(), Box<dyn std::error::Error>>(())
//! ```

pub mod glb;
pub mod obj;
mod recording;

use std::path::{Path, PathBuf};
use std::sync::Arc;

pub use recording::{Frame, Recording, RestoreError};

use crate::sim::{ClothMesh, Simulation};

/// The placeholder a path for one file per frame contains.
pub const FRAME_PLACEHOLDER: &str = "{frame}";

/// What can go wrong while exporting.
#[derive(Debug, thiserror::Error)]
pub enum ExportError {
    /// The path names neither format.
    #[error(
        "cannot tell what to write to '{0}': give a path ending in .glb (one animated glTF file) \
         or containing {{frame}} (one OBJ per frame, e.g. out/cloth_{{frame}}.obj)"
    )]
    UnknownFormat(PathBuf),
    /// glTF was asked of a mesh without triangles.
    #[error(
        "this mesh has bars but no triangles (an adjacency list), and glTF holds surfaces: \
         export it as OBJ lines instead, with a path containing {{frame}}"
    )]
    NoTriangles,
    /// No frame was recorded.
    #[error("nothing to export: no frame was recorded")]
    Empty,
    /// A frame's particle count is not the mesh's.
    #[error("a frame has {got} positions but the mesh has {expected} particles")]
    FrameSize {
        /// Particles in the mesh.
        expected: usize,
        /// Positions in the frame.
        got: usize,
    },
    /// The file would pass the 4 GiB a .glb can address.
    #[error(
        "the glTF file would hold {bytes} bytes, over the 4 GiB limit of a .glb; \
         export fewer frames (a larger --every) or one OBJ per frame"
    )]
    TooLarge {
        /// The binary chunk's size.
        bytes: u64,
    },
    /// A file could not be written. The I/O error is in the message, not
    /// also a [`std::error::Error::source`], so that a chain printed whole
    /// (`{:#}`) says it once.
    #[error("cannot write {path}: {reason}")]
    Io {
        /// The file.
        path: PathBuf,
        /// Why.
        reason: std::io::Error,
    },
    /// The directory an export goes in could not be made.
    #[error("cannot create the directory {path} for the export: {reason}")]
    Directory {
        /// The directory.
        path: PathBuf,
        /// Why.
        reason: std::io::Error,
    },
    /// The glTF crate refused the document (a bug in drape if it happens).
    #[error("cannot serialise the glTF document: {0}")]
    Gltf(String),
}

impl ExportError {
    pub(crate) fn io(path: &Path) -> impl FnOnce(std::io::Error) -> ExportError + '_ {
        move |reason| ExportError::Io { path: path.to_path_buf(), reason }
    }
}

/// The file format an export path asks for.
#[derive(Clone, Debug, PartialEq, Eq)]
pub enum ExportFormat {
    /// One binary glTF file, `path` ending in `.glb`.
    Glb(PathBuf),
    /// One OBJ per frame; the pattern contains [`FRAME_PLACEHOLDER`].
    ObjSequence(String),
}

impl ExportFormat {
    /// The format `path` names: a `{frame}` placeholder makes a sequence of
    /// OBJ files, a `.glb` extension one glTF file.
    pub fn from_path(path: &Path) -> Result<Self, ExportError> {
        let text = path.to_string_lossy();
        if text.contains(FRAME_PLACEHOLDER) {
            Ok(ExportFormat::ObjSequence(text.into_owned()))
        } else if path.extension().is_some_and(|e| e.eq_ignore_ascii_case("glb")) {
            Ok(ExportFormat::Glb(path.to_path_buf()))
        } else {
            Err(ExportError::UnknownFormat(path.to_path_buf()))
        }
    }
}

/// `pattern` with [`FRAME_PLACEHOLDER`] replaced by `index`, zero-padded to
/// `digits` (at least 4, so that files sort in frame order).
pub fn frame_path(pattern: &str, index: usize, digits: usize) -> PathBuf {
    PathBuf::from(pattern.replace(FRAME_PLACEHOLDER, &format!("{index:0width$}", width = digits.max(4))))
}

/// Decimal digits of the largest frame index among `frames` frames.
pub fn frame_digits(frames: usize) -> usize {
    frames.saturating_sub(1).max(1).to_string().len()
}

/// Creates the directory a file goes in, if the path has one.
pub fn create_parent(path: &Path) -> Result<(), ExportError> {
    match path.parent() {
        Some(dir) if !dir.as_os_str().is_empty() => {
            std::fs::create_dir_all(dir).map_err(|reason| ExportError::Directory { path: dir.to_path_buf(), reason })
        }
        _ => Ok(()),
    }
}

/// Writes frames as a run produces them: an OBJ file at once for each, or
/// all of them into one .glb when [`Exporter::finish`] is called (the
/// frames are kept in memory until then: 12 bytes per particle per frame).
pub struct Exporter {
    format: ExportFormat,
    recording: Recording,
    digits: usize,
    written: usize,
}

/// What an export wrote.
#[derive(Clone, Debug, PartialEq, Eq)]
pub struct ExportReport {
    /// Frames exported.
    pub frames: usize,
    /// Files written.
    pub files: usize,
    /// The first file (the only one for .glb).
    pub first: PathBuf,
}

impl Exporter {
    /// An exporter to `path` for `mesh`, which expects about
    /// `expected_frames` frames (it sets the width of OBJ frame numbers).
    ///
    /// Refuses a path that names no format, and glTF for a mesh without
    /// triangles, before any simulation is run.
    pub fn new(path: &Path, mesh: Arc<ClothMesh>, expected_frames: usize) -> Result<Self, ExportError> {
        let format = ExportFormat::from_path(path)?;
        if matches!(format, ExportFormat::Glb(_)) && mesh.triangles().is_empty() {
            return Err(ExportError::NoTriangles);
        }
        Ok(Exporter { format, recording: Recording::new(mesh), digits: frame_digits(expected_frames), written: 0 })
    }

    /// Takes the simulation's current positions as the next frame.
    pub fn frame(&mut self, sim: &Simulation) -> Result<(), ExportError> {
        match &self.format {
            ExportFormat::Glb(_) => {
                self.recording.record(sim);
            }
            ExportFormat::ObjSequence(pattern) => {
                let path = frame_path(pattern, self.written, self.digits);
                obj::write_file(&path, self.recording.mesh(), sim.positions(), sim.time())?;
            }
        }
        self.written += 1;
        Ok(())
    }

    /// Writes what is left to write (the .glb) and says what was written.
    pub fn finish(self) -> Result<ExportReport, ExportError> {
        match &self.format {
            ExportFormat::Glb(path) => {
                glb::write_file(path, &self.recording)?;
                Ok(ExportReport { frames: self.written, files: 1, first: path.clone() })
            }
            ExportFormat::ObjSequence(pattern) => {
                if self.written == 0 {
                    return Err(ExportError::Empty);
                }
                Ok(ExportReport {
                    frames: self.written,
                    files: self.written,
                    first: frame_path(pattern, 0, self.digits),
                })
            }
        }
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn the_path_names_the_format() {
        assert_eq!(ExportFormat::from_path(Path::new("a/b.GLB")).unwrap(), ExportFormat::Glb("a/b.GLB".into()));
        assert_eq!(
            ExportFormat::from_path(Path::new("out/c_{frame}.obj")).unwrap(),
            ExportFormat::ObjSequence("out/c_{frame}.obj".into())
        );
        for bad in ["cloth.gltf", "cloth.obj", "cloth"] {
            let e = ExportFormat::from_path(Path::new(bad)).unwrap_err();
            assert!(e.to_string().contains(".glb") && e.to_string().contains("{frame}"), "{e}");
        }
    }

    #[test]
    fn frame_numbers_are_padded_to_sort() {
        assert_eq!(frame_digits(1), 1);
        assert_eq!(frame_digits(10), 1);
        assert_eq!(frame_digits(11), 2);
        assert_eq!(frame_digits(100_001), 6);
        assert_eq!(frame_path("o/{frame}.obj", 7, frame_digits(11)), PathBuf::from("o/0007.obj"));
        assert_eq!(frame_path("{frame}.obj", 12, 6), PathBuf::from("000012.obj"));
    }

    #[test]
    fn a_directory_that_cannot_be_made_is_named_and_its_reason_said_once() {
        // The directory would be a file's child: no system can make it.
        let file = std::env::temp_dir().join(format!("drape-export-blocker-{}", std::process::id()));
        std::fs::write(&file, b"not a directory").unwrap();
        let e = create_parent(&file.join("sub").join("cloth.glb")).unwrap_err();
        let _ = std::fs::remove_file(&file);
        let ExportError::Directory { reason, .. } = &e else { panic!("not a directory error: {e:?}") };
        let reason = reason.to_string();
        // The chain as `main` prints it (anyhow's `{:#}`): the I/O error
        // once. With the error also given as the source it read twice
        // ("…: Not a directory (os error 20): Not a directory (os error 20)").
        let chain = format!("{:#}", anyhow::Error::from(e));
        assert_eq!(chain.matches(&reason).count(), 1, "{chain}");
        assert!(chain.contains("cannot create the directory") && chain.contains("sub"), "{chain}");
    }
}
