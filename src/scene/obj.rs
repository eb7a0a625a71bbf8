//! OBJ text to vertices and triangles, numbered as the file numbers them.
//!
//! Only what cloth needs is read: `v x y z [w]` (w ignored) and `f` faces of
//! three or more vertices, each written `i`, `i/t`, `i//n` or `i/t/n` with a
//! 1-based index or a negative one (relative to the vertices read so far),
//! triangulated as fans (a b c d → a b c, a c d). Everything else (normals,
//! texture coordinates, objects, groups, materials, lines, points, comments)
//! is skipped.
//!
//! Vertices keep the file's order and one numbering across objects, as the
//! format defines it, so `[obj] pinned` indices are the ones a modelling tool
//! shows (0-based), and objects that share vertices stay joined. A general
//! OBJ loader (tobj, used before) numbers each object's vertices in the order
//! its faces first use them, which is neither.

use glam::Vec3;

use crate::sim::mesh::MAX_PARTICLES;

/// The vertices (file order) and triangles of OBJ text; the error names the
/// line and what is wrong with it.
pub fn parse_obj(text: &str) -> Result<(Vec<Vec3>, Vec<[u32; 3]>), String> {
    let mut positions: Vec<Vec3> = Vec::new();
    // Faces as read: absolute 0-based indices, checked against the vertex
    // count at the end (a face may come before a vertex it names).
    let mut triangles: Vec<[i64; 3]> = Vec::new();
    let mut face: Vec<i64> = Vec::new();
    for (number, line) in text.lines().enumerate() {
        let line_number = number + 1;
        let mut words = line.split_whitespace();
        match words.next() {
            Some("v") => {
                let mut c = [0.0f32; 3];
                for (k, value) in c.iter_mut().enumerate() {
                    let word = words
                        .next()
                        .ok_or_else(|| format!("line {line_number}: a vertex needs x, y and z, it has {k}"))?;
                    *value = word
                        .parse::<f32>()
                        .ok()
                        .filter(|v| v.is_finite())
                        .ok_or_else(|| format!("line {line_number}: '{word}' is not a finite number"))?;
                }
                if positions.len() == MAX_PARTICLES {
                    return Err(format!("more than {MAX_PARTICLES} vertices"));
                }
                positions.push(Vec3::from_array(c));
            }
            Some("f") => {
                face.clear();
                for word in words {
                    let index = word.split('/').next().unwrap_or_default();
                    let i: i64 =
                        index.parse().map_err(|_| format!("line {line_number}: '{word}' is not a vertex reference"))?;
                    face.push(match i {
                        0 => return Err(format!("line {line_number}: vertex 0 does not exist (OBJ counts from 1)")),
                        i if i > 0 => i - 1,
                        i => positions.len() as i64 + i,
                    });
                }
                if face.len() < 3 {
                    return Err(format!(
                        "line {line_number}: a face needs three vertices or more, it has {}",
                        face.len()
                    ));
                }
                for k in 1..face.len() - 1 {
                    triangles.push([face[0], face[k], face[k + 1]]);
                }
            }
            _ => {}
        }
    }
    if positions.is_empty() {
        return Err("it has no vertices".to_string());
    }
    let count = positions.len() as i64;
    let triangles = triangles
        .into_iter()
        .map(|t| {
            if t.iter().all(|&i| (0..count).contains(&i)) {
                Ok(t.map(|i| i as u32))
            } else {
                Err(format!("a face names vertices {:?} (1-based); the file has {count}", t.map(|i| i + 1)))
            }
        })
        .collect::<Result<Vec<_>, _>>()?;
    Ok((positions, triangles))
}
