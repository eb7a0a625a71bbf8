//! Wavefront OBJ: one file per frame.
//!
//! Each file lists the particles as vertices `v x y z` in scene order
//! (metres, written with the shortest decimal that reads back as the same
//! f32), then for a triangle mesh a texture coordinate `vt u v` from the
//! rest shape ([`texture_coordinates`]) and a normal `vn` per vertex and the
//! faces `f a/a/a b/b/b c/c/c`; a mesh without triangles (an adjacency
//! list) has its structural bars as lines `l a b` instead. Indices are
//! 1-based, as OBJ wants.

use std::io::{BufWriter, Write};
use std::path::Path;

use glam::Vec3;

use super::{ExportError, create_parent};
use crate::sim::BarKind;
use crate::sim::ClothMesh;
use crate::sim::mesh::surface::{texture_coordinates, vertex_normals};

/// Writes the cloth at `positions` (simulated time `time`, seconds) as an
/// OBJ file at `path`, creating its directory if needed.
pub fn write_file(path: &Path, mesh: &ClothMesh, positions: &[Vec3], time: f64) -> Result<(), ExportError> {
    if positions.len() != mesh.particle_count() {
        return Err(ExportError::FrameSize { expected: mesh.particle_count(), got: positions.len() });
    }
    create_parent(path)?;
    let file = std::fs::File::create(path).map_err(ExportError::io(path))?;
    let mut w = BufWriter::new(file);
    write(&mut w, mesh, positions, time).and_then(|()| w.flush()).map_err(ExportError::io(path))
}

/// Writes the OBJ text to `w`.
pub fn write(w: &mut impl Write, mesh: &ClothMesh, positions: &[Vec3], time: f64) -> std::io::Result<()> {
    writeln!(w, "# drape cloth, t = {time} s, {} particles", positions.len())?;
    for p in positions {
        writeln!(w, "v {} {} {}", p.x, p.y, p.z)?;
    }
    let triangles = mesh.triangles();
    if triangles.is_empty() {
        for bar in mesh.bars().iter().filter(|b| b.kind == BarKind::Structural) {
            writeln!(w, "l {} {}", bar.a + 1, bar.b + 1)?;
        }
        return Ok(());
    }
    for uv in texture_coordinates(mesh) {
        writeln!(w, "vt {} {}", uv.x, uv.y)?;
    }
    let mut normals = Vec::new();
    vertex_normals(positions, triangles, &mut normals);
    for n in &normals {
        writeln!(w, "vn {} {} {}", n.x, n.y, n.z)?;
    }
    for t in triangles {
        let [a, b, c] = t.map(|i| i + 1);
        writeln!(w, "f {a}/{a}/{a} {b}/{b}/{b} {c}/{c}/{c}")?;
    }
    Ok(())
}
