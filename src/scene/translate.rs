//! A scene file's translation into sim types: the parameters checked and
//! derived (a material preset under the keys given beside it), the cloth's
//! mesh from `[grid]`, `[mesh]` or `[obj]`, the colliders and the camera
//! hint. Every key that is wrong is reported by name, with what is allowed.

use std::path::{Path, PathBuf};
use std::sync::Arc;

use glam::Vec3;

use super::colliders;
use super::file::{CameraTable, GridTable, MeshTable, ObjTable, PinsValue, SceneFile, WindModel};
use super::obj::parse_obj;
use super::{CameraHint, Origin, Scene, SceneErrorKind, bundled};
use crate::sim::{Air, ClothMesh, Grid, Material, ParamError, Pins, SolverParams, Wind, units};

fn invalid(key: &str, message: impl Into<String>) -> SceneErrorKind {
    SceneErrorKind::Invalid { key: key.to_string(), message: message.into() }
}

fn vec3(v: [f32; 3]) -> Vec3 {
    Vec3::from_array(v)
}

/// Parses `text` and builds the scene it describes.
pub(super) fn build(text: &str, origin: &Origin) -> Result<Scene, SceneErrorKind> {
    let file: SceneFile = toml::from_str(text).map_err(|e| SceneErrorKind::Syntax(e.to_string()))?;
    let params = solver_params(&file)?;
    let sources = [file.grid.is_some(), file.mesh.is_some(), file.obj.is_some()];
    let mesh = match (&file.grid, &file.mesh, &file.obj) {
        (Some(g), None, None) => grid_mesh(g)?,
        (None, Some(m), None) => adjacency_mesh(m)?,
        (None, None, Some(o)) => obj_mesh(o, origin)?,
        _ => {
            let found = sources.iter().filter(|&&s| s).count();
            return Err(invalid(
                "scene",
                format!("found {found} of [grid], [mesh] and [obj]; a scene needs exactly one"),
            ));
        }
    };
    units::check_surface(&params, &mesh).map_err(param_error)?;
    if params.coarse_passes > 0 && mesh.grid().is_none() {
        return Err(invalid(
            "solver.coarse_passes",
            format!(
                "{} needs a [grid]: the coarse levels are the grid's rows and columns taken 2, 4, 8, … apart; for \
                 [obj] and [mesh] cloths use inextensible = true or tether_slack",
                params.coarse_passes
            ),
        ));
    }
    let read = |path: &str| -> Result<(Vec<Vec3>, Vec<[u32; 3]>), SceneErrorKind> {
        let (display, text) = obj_text(path, origin)?;
        parse_obj(&text).map_err(|message| SceneErrorKind::Obj { path: display, message })
    };
    let colliders = colliders::build(&file.colliders, &read)?;
    let camera = camera_hint(&file.camera)?;
    let name = file.name.clone().unwrap_or_else(|| match origin {
        Origin::File(p) => p.file_stem().map(|s| s.to_string_lossy().into_owned()).unwrap_or_default(),
        Origin::Bundled(n) => (*n).to_string(),
        Origin::Text => "untitled".to_string(),
    });
    Ok(Scene {
        name,
        description: file.description.clone(),
        source: origin.display(),
        mesh: Arc::new(mesh),
        params,
        solver: file.solver.method,
        camera,
        colliders,
        playback: file.viewer.time,
    })
}

fn solver_params(file: &SceneFile) -> Result<SolverParams, SceneErrorKind> {
    let s = &file.solver;
    let w = &file.wind;
    if w.model != WindModel::Air
        && let Some(key) = w.air_keys().first()
    {
        return Err(invalid(&format!("wind.{key}"), "applies to model = \"air\""));
    }
    let wind = match w.model {
        WindModel::None => {
            if w.scale.is_some() || w.vector.is_some() {
                return Err(invalid("wind", "scale and vector need model = \"seed\" or \"constant\""));
            }
            Wind::None
        }
        WindModel::Air => {
            if w.scale.is_some() || w.vector.is_some() {
                let key = if w.scale.is_some() { "wind.scale" } else { "wind.vector" };
                return Err(invalid(key, "applies to \"seed\" or \"constant\"; moving air takes velocity (m/s)"));
            }
            let d = Air::default();
            Wind::Air(Air {
                velocity: w.velocity.map_or(d.velocity, vec3),
                gusts: w.gusts.unwrap_or(d.gusts),
                gust_scale: w.gust_scale.unwrap_or(d.gust_scale),
                density: w.density.unwrap_or(d.density),
                drag: w.drag.unwrap_or(d.drag),
                lift: w.lift.unwrap_or(d.lift),
            })
        }
        WindModel::Seed => {
            if w.vector.is_some() {
                return Err(invalid("wind.vector", "applies to model = \"constant\"; the seed's wind takes scale"));
            }
            Wind::Seed { scale: w.scale.unwrap_or(1.0) }
        }
        WindModel::Constant => {
            if w.scale.is_some() {
                return Err(invalid("wind.scale", "applies to model = \"seed\"; a constant wind takes vector"));
            }
            let Some(v) = w.vector else {
                return Err(invalid("wind.vector", "model = \"constant\" needs vector = [x, y, z] in newtons"));
            };
            Wind::Constant { force: vec3(v) }
        }
    };
    for (a, b, given) in [
        ("mass", "density", s.mass.is_some() && s.density.is_some()),
        ("gravity", "g", s.gravity.is_some() && s.g.is_some()),
        ("stretch_compliance", "stretch_stiffness", s.stretch_compliance.is_some() && s.stretch_stiffness.is_some()),
        ("bend_compliance", "bend_stiffness", s.bend_compliance.is_some() && s.bend_stiffness.is_some()),
    ] {
        if given {
            return Err(invalid(
                &format!("solver.{b}"),
                format!("solver.{a} and solver.{b} are both given; give one (they say the same thing two ways)"),
            ));
        }
    }
    let d = SolverParams::default();
    let mut params = SolverParams {
        relaxations: s.relaxations,
        damping: s.damping,
        dt: s.dt,
        mass: s.mass.unwrap_or(d.mass),
        gravity: s.gravity.map_or(d.gravity, vec3),
        wind,
        tolerance: s.tolerance,
        substeps: s.substeps,
        stretch_compliance: s.stretch_compliance.unwrap_or(d.stretch_compliance),
        bend_compliance: s.bend_compliance.unwrap_or(d.bend_compliance),
        shear_compliance: s.shear_compliance,
        over_relaxation: s.over_relaxation,
        tether_slack: s.tether_slack,
        start: s.start,
        thickness: d.thickness,
        friction: d.friction,
        self_collision: s.self_collision,
        density: None,
        gravity_acceleration: s.g.map(vec3),
        stretch_stiffness: None,
        bend_stiffness: None,
        inextensible: s.inextensible,
        newton_iterations: s.newton_iterations,
        newton_tolerance: s.newton_tolerance,
        newton_smoothing: s.newton_smoothing,
        coarse_passes: s.coarse_passes,
    };
    if let Some(table) = &file.material {
        let Some(material) = Material::from_name(&table.preset) else {
            let names: Vec<&str> = Material::ALL.iter().map(|m| m.name()).collect();
            return Err(invalid(
                "material.preset",
                format!("\"{}\" is not a material; use one of {}", table.preset, names.join(", ")),
            ));
        };
        material.apply(&mut params);
        // A preset's mass is per area: a `mass` beside it replaces it.
        if s.mass.is_some() {
            params.density = None;
        }
        if s.stretch_compliance.is_some() {
            params.stretch_stiffness = None;
        }
        if s.bend_compliance.is_some() {
            params.bend_stiffness = None;
        }
    }
    // Keys given override the preset.
    params.density = s.density.or(params.density);
    // A mass per area falls at g unless the scene says otherwise (the
    // seed's force per particle would be absurd for particles of any size).
    if params.density.is_some() && s.gravity.is_none() && s.g.is_none() {
        params.gravity_acceleration = Some(Vec3::new(0.0, -9.81, 0.0));
    }
    params.stretch_stiffness = s.stretch_stiffness.or(params.stretch_stiffness);
    params.bend_stiffness = s.bend_stiffness.or(params.bend_stiffness);
    params.thickness = s.thickness.unwrap_or(params.thickness);
    params.friction = s.friction.unwrap_or(params.friction);
    if let Wind::Air(air) = &mut params.wind {
        air.drag = w.drag.unwrap_or(air.drag);
        air.lift = w.lift.unwrap_or(air.lift);
    }
    params.validate().map_err(param_error)?;
    Ok(params)
}

/// A parameter error as a scene error: `wind.*` names are keys already,
/// the others live in `[solver]`.
fn param_error(e: ParamError) -> SceneErrorKind {
    let key = if e.name.starts_with("wind.") { e.name.to_string() } else { format!("solver.{}", e.name) };
    invalid(&key, format!("{} is not allowed: {}", e.value, e.allowed))
}

fn grid_mesh(g: &GridTable) -> Result<ClothMesh, SceneErrorKind> {
    let pins = match &g.pinned {
        None => Pins::TopRow,
        Some(PinsValue::Cells(cells)) => Pins::Cells(cells.clone()),
        Some(PinsValue::Pattern(p)) => match p.as_str() {
            "top-row" => Pins::TopRow,
            "top-corners" => Pins::TopCorners,
            "left-column" => Pins::LeftColumn,
            "none" => Pins::None,
            other => {
                return Err(invalid(
                    "grid.pinned",
                    format!(
                        "\"{other}\" is not a pin pattern; use \"top-row\", \"top-corners\", \"left-column\", \
                         \"none\" or a list of [column, row]"
                    ),
                ));
            }
        },
    };
    let grid = Grid {
        columns: g.columns,
        rows: g.rows,
        spacing: g.spacing,
        plane: g.plane,
        origin: g.origin.map(vec3),
        pins,
        shear: g.shear.unwrap_or(true),
        bend: g.bend.unwrap_or(true),
    };
    grid.build().map_err(|error| SceneErrorKind::Mesh { table: "grid", error })
}

fn adjacency_mesh(m: &MeshTable) -> Result<ClothMesh, SceneErrorKind> {
    let positions = m.positions.iter().copied().map(vec3).collect();
    let velocities = m.velocities.as_ref().map(|v| v.iter().copied().map(vec3).collect());
    ClothMesh::from_adjacency(positions, &m.fixed, &m.adjacency, velocities)
        .map_err(|error| SceneErrorKind::Mesh { table: "mesh", error })
}

/// Largest OBJ file read, bytes: a bound on memory for untrusted input.
pub const MAX_OBJ_BYTES: u64 = 256 << 20;

/// The text of the OBJ file `path` names: relative to the scene file, a
/// bundled mesh for a bundled scene. Returns the path as resolved and the text.
fn obj_text(path: &str, origin: &Origin) -> Result<(String, String), SceneErrorKind> {
    match origin {
        Origin::Bundled(_) => {
            let Some(text) = bundled::mesh(path) else {
                return Err(SceneErrorKind::Obj { path: path.to_string(), message: "not a bundled mesh".into() });
            };
            Ok((path.to_string(), text.to_string()))
        }
        Origin::File(scene_path) => read_obj(&scene_path.parent().unwrap_or(Path::new(".")).join(path)),
        Origin::Text => read_obj(&PathBuf::from(path)),
    }
}

fn obj_mesh(o: &ObjTable, origin: &Origin) -> Result<ClothMesh, SceneErrorKind> {
    let (display, text) = obj_text(&o.path, origin)?;
    let obj_error = |message: String| SceneErrorKind::Obj { path: display.clone(), message };
    let (positions, triangles) = parse_obj(&text).map_err(obj_error)?;
    let scale = o.scale.unwrap_or(1.0);
    if !(scale.is_finite() && scale > 0.0) {
        return Err(invalid("obj.scale", format!("{scale} is not allowed: a positive finite number")));
    }
    let offset = vec3(o.offset.unwrap_or([0.0; 3]));
    let positions = positions.into_iter().map(|p| p * scale + offset).collect();
    ClothMesh::from_triangles(positions, triangles, &o.pinned, None)
        .map_err(|error| SceneErrorKind::Mesh { table: "obj", error })
}

fn read_obj(path: &Path) -> Result<(String, String), SceneErrorKind> {
    let display = path.display().to_string();
    let err = |message: String| SceneErrorKind::Obj { path: display.clone(), message };
    let size = std::fs::metadata(path).map_err(|e| err(e.to_string()))?.len();
    if size > MAX_OBJ_BYTES {
        return Err(err(format!("{size} bytes is too large; at most {MAX_OBJ_BYTES} are read")));
    }
    let text = std::fs::read_to_string(path).map_err(|e| err(e.to_string()))?;
    Ok((display, text))
}

fn camera_hint(c: &CameraTable) -> Result<CameraHint, SceneErrorKind> {
    let d = CameraHint::default();
    let finite = |key: &str, v: f32| if v.is_finite() { Ok(v) } else { Err(invalid(key, "must be a finite number")) };
    let yaw = finite("camera.yaw", c.yaw.unwrap_or(d.yaw_degrees))?;
    let pitch = finite("camera.pitch", c.pitch.unwrap_or(d.pitch_degrees))?;
    if !(-89.0..=89.0).contains(&pitch) {
        return Err(invalid("camera.pitch", format!("{pitch} is not allowed: degrees from -89 to 89")));
    }
    if let Some(dist) = c.distance
        && !(dist.is_finite() && dist > 0.0)
    {
        return Err(invalid("camera.distance", format!("{dist} is not allowed: a positive number of metres")));
    }
    let target = c.target.map(vec3);
    if target.is_some_and(|t| !t.is_finite()) {
        return Err(invalid("camera.target", "must be three finite numbers"));
    }
    Ok(CameraHint { yaw_degrees: yaw, pitch_degrees: pitch, distance: c.distance, target })
}
