//! [`SceneWatcher`]: notices when the scene file being shown is saved, so
//! the viewer can reload it.
//!
//! The file's directory is watched rather than the file itself: editors
//! often save by writing a new file and renaming it over the old one, which
//! a watch on the old file would miss. Events for other files are ignored.

use std::path::{Path, PathBuf};
use std::sync::mpsc::{Receiver, channel};

use notify::{EventKind, RecursiveMode, Watcher};

/// Watches one scene file.
pub struct SceneWatcher {
    file: PathBuf,
    events: Receiver<notify::Result<notify::Event>>,
    // Kept alive: dropping it stops the watch.
    _watcher: notify::RecommendedWatcher,
}

impl std::fmt::Debug for SceneWatcher {
    fn fmt(&self, f: &mut std::fmt::Formatter<'_>) -> std::fmt::Result {
        f.debug_struct("SceneWatcher").field("file", &self.file).finish_non_exhaustive()
    }
}

impl SceneWatcher {
    /// Starts watching `file` (a scene file on disk).
    pub fn new(file: &Path) -> notify::Result<Self> {
        let file = std::fs::canonicalize(file)?;
        let dir = file.parent().unwrap_or(Path::new("/")).to_path_buf();
        let (sender, events) = channel();
        let mut watcher = notify::recommended_watcher(move |event| {
            // The viewer may be gone; nothing to tell then.
            let _ = sender.send(event);
        })?;
        watcher.watch(&dir, RecursiveMode::NonRecursive)?;
        Ok(SceneWatcher { file, events, _watcher: watcher })
    }

    /// The file watched.
    pub fn file(&self) -> &Path {
        &self.file
    }

    /// Whether the file was written, created or renamed into place since
    /// the last call; errors of the watch itself are returned as they come.
    pub fn changed(&self) -> Result<bool, notify::Error> {
        let mut changed = false;
        for event in self.events.try_iter() {
            let event = event?;
            let writes = matches!(event.kind, EventKind::Create(_) | EventKind::Modify(_));
            if writes && event.paths.iter().any(|p| p == &self.file) {
                changed = true;
            }
        }
        Ok(changed)
    }
}
