//! The TOML schema of a scene file: every table and key as written (the
//! README lists them with units, ranges and defaults). [`super::translate`]
//! turns a parsed file into sim types.

use serde::{Deserialize, Serialize};

use super::colliders::ColliderTable;
use crate::sim::{GridPlane, SolverKind, SolverParams, Start};

/// A scene file as written. See the README for every key.
#[derive(Clone, Debug, Default, Deserialize, Serialize)]
#[serde(deny_unknown_fields)]
pub struct SceneFile {
    /// Title; defaults to the file name.
    pub name: Option<String>,
    /// What the scene shows.
    #[serde(default)]
    pub description: String,
    /// `[solver]`.
    #[serde(default)]
    pub solver: SolverTable,
    /// `[wind]`.
    #[serde(default)]
    pub wind: WindTable,
    /// `[material]`.
    pub material: Option<MaterialTable>,
    /// `[grid]`.
    pub grid: Option<GridTable>,
    /// `[mesh]`.
    pub mesh: Option<MeshTable>,
    /// `[obj]`.
    pub obj: Option<ObjTable>,
    /// `[camera]`.
    #[serde(default)]
    pub camera: CameraTable,
    /// `[[collider]]`: any number.
    #[serde(default, rename = "collider")]
    pub colliders: Vec<ColliderTable>,
    /// `[viewer]`.
    #[serde(default)]
    pub viewer: ViewerTable,
}

/// `[viewer]`: how the viewer shows the scene.
#[derive(Clone, Debug, Default, Deserialize, Serialize)]
#[serde(deny_unknown_fields)]
pub struct ViewerTable {
    /// `"auto"` (default), `"real-time"` or `"step-per-frame"`.
    #[serde(default)]
    pub time: super::Playback,
}

/// `[solver]`: every key optional, defaulting to the seed's value.
#[derive(Clone, Debug, Deserialize, Serialize)]
#[serde(deny_unknown_fields, default)]
pub struct SolverTable {
    /// Relaxation passes per step.
    pub relaxations: u32,
    /// δ.
    pub damping: f32,
    /// h, seconds.
    pub dt: f32,
    /// m, kilograms (default 0.2); exclusive with `density`.
    pub mass: Option<f32>,
    /// f_g, newtons (default [0, −9.8, 0]); exclusive with `g`.
    pub gravity: Option<[f32; 3]>,
    /// σ, kg/m².
    pub density: Option<f32>,
    /// g, m/s².
    pub g: Option<[f32; 3]>,
    /// k_s, N/m; exclusive with `stretch_compliance`.
    pub stretch_stiffness: Option<f32>,
    /// B, N·m; exclusive with `bend_compliance`.
    pub bend_stiffness: Option<f32>,
    /// `fast` (default) or `reference`.
    pub method: SolverKind,
    /// Relative strain below which relaxation stops early (0: off).
    pub tolerance: f32,
    /// Substeps per step.
    pub substeps: u32,
    /// XPBD compliance of structural bars, m/N (default 0).
    pub stretch_compliance: Option<f32>,
    /// XPBD compliance of bend bars, m/N (default 0).
    pub bend_compliance: Option<f32>,
    /// XPBD compliance of shear bars (a grid's diagonals), m/N (default:
    /// the structural bars').
    pub shear_compliance: Option<f32>,
    /// ω, over-relaxation.
    pub over_relaxation: f32,
    /// Tethers on with this slack; absent is off.
    pub tether_slack: Option<f32>,
    /// `euler` or `second-order`.
    pub start: Start,
    /// Metres kept from collider surfaces (default 0.01, or the material's).
    pub thickness: Option<f32>,
    /// Coulomb coefficient of colliders that give none (default 0.3, or the
    /// material's).
    pub friction: Option<f32>,
    /// Keep the cloth from passing through itself.
    pub self_collision: bool,
    /// Put every edge back to its rest length each substep (global Newton).
    pub inextensible: bool,
    /// Most Newton iterations per substep (default 3).
    pub newton_iterations: u32,
    /// Edge strain that ends the iterations (default 0.008).
    pub newton_tolerance: f32,
    /// Edge passes after each Newton iteration (default 48).
    pub newton_smoothing: u32,
    /// Passes per coarse level of a grid before the relaxation (0: off).
    pub coarse_passes: u32,
}

impl Default for SolverTable {
    fn default() -> Self {
        let p = SolverParams::default();
        Self {
            relaxations: p.relaxations,
            damping: p.damping,
            dt: p.dt,
            mass: None,
            gravity: None,
            density: None,
            g: None,
            stretch_stiffness: None,
            bend_stiffness: None,
            method: SolverKind::default(),
            tolerance: p.tolerance,
            substeps: p.substeps,
            stretch_compliance: None,
            bend_compliance: None,
            shear_compliance: None,
            over_relaxation: p.over_relaxation,
            tether_slack: p.tether_slack,
            start: p.start,
            thickness: None,
            friction: None,
            self_collision: p.self_collision,
            inextensible: p.inextensible,
            newton_iterations: p.newton_iterations,
            newton_tolerance: p.newton_tolerance,
            newton_smoothing: p.newton_smoothing,
            coarse_passes: p.coarse_passes,
        }
    }
}

/// The `model` key of `[wind]`.
#[derive(Clone, Copy, Debug, Default, PartialEq, Eq, Deserialize, Serialize)]
#[serde(rename_all = "kebab-case")]
pub enum WindModel {
    /// No wind.
    #[default]
    None,
    /// The seed's equation 4.
    Seed,
    /// A constant force.
    Constant,
    /// Moving air: drag and lift on triangles.
    Air,
}

/// `[wind]`.
#[derive(Clone, Debug, Default, Deserialize, Serialize)]
#[serde(deny_unknown_fields)]
pub struct WindTable {
    /// Which model.
    #[serde(default)]
    pub model: WindModel,
    /// For `seed`: multiplies equation 4 (default 1).
    pub scale: Option<f32>,
    /// For `constant`: the force, newtons.
    pub vector: Option<[f32; 3]>,
    /// For `air`: the mean wind, m/s (default still air).
    pub velocity: Option<[f32; 3]>,
    /// For `air`: turbulence, a share of the mean speed (default 0).
    pub gusts: Option<f32>,
    /// For `air`: metres and seconds of the turbulence's features (default 1).
    pub gust_scale: Option<f32>,
    /// For `air`: ρ, kg/m³ (default 1.2).
    pub density: Option<f32>,
    /// For `air`: C_d (default 1, or the material's).
    pub drag: Option<f32>,
    /// For `air`: C_l (default 0.2, or the material's).
    pub lift: Option<f32>,
}

impl WindTable {
    /// The names of the `air` keys given.
    pub(super) fn air_keys(&self) -> Vec<&'static str> {
        let given = [
            ("velocity", self.velocity.is_some()),
            ("gusts", self.gusts.is_some()),
            ("gust_scale", self.gust_scale.is_some()),
            ("density", self.density.is_some()),
            ("drag", self.drag.is_some()),
            ("lift", self.lift.is_some()),
        ];
        given.into_iter().filter(|g| g.1).map(|g| g.0).collect()
    }
}

/// `[material]`.
#[derive(Clone, Debug, Deserialize, Serialize)]
#[serde(deny_unknown_fields)]
pub struct MaterialTable {
    /// A preset's name: `cotton`, `silk`, `denim`, `leather`, `jersey` or
    /// `rubber`.
    pub preset: String,
}

/// `pinned` in `[grid]`: a named pattern or a list of `[column, row]`.
#[derive(Clone, Debug, Deserialize, Serialize)]
#[serde(
    untagged,
    expecting = "a pin pattern (\"top-row\", \"top-corners\", \"left-column\" or \"none\") or a list of \
                 [column, row] pairs, e.g. [[0, 0], [19, 0]]"
)]
pub enum PinsValue {
    /// `"top-row"`, `"top-corners"`, `"left-column"` or `"none"`.
    Pattern(String),
    /// `[[column, row], ...]`.
    Cells(Vec<[u32; 2]>),
}

/// `[grid]`.
#[derive(Clone, Debug, Deserialize, Serialize)]
#[serde(deny_unknown_fields)]
pub struct GridTable {
    /// Particles per row.
    pub columns: u32,
    /// Rows.
    pub rows: u32,
    /// Neighbour distance, metres.
    pub spacing: f32,
    /// Fixed particles (default `top-row`).
    pub pinned: Option<PinsValue>,
    /// `vertical` (default) or `horizontal`.
    #[serde(default)]
    pub plane: GridPlane,
    /// Position of particle (0, 0).
    pub origin: Option<[f32; 3]>,
    /// Diagonal bars (default true).
    pub shear: Option<bool>,
    /// Two-away bend bars (default true).
    pub bend: Option<bool>,
}

/// `[mesh]`: the seed's generic form.
#[derive(Clone, Debug, Deserialize, Serialize)]
#[serde(deny_unknown_fields)]
pub struct MeshTable {
    /// Particle positions, metres.
    pub positions: Vec<[f32; 3]>,
    /// Indices of the fixed particles.
    #[serde(default)]
    pub fixed: Vec<u64>,
    /// `adjacency[i]` lists the particles that `i` is barred to.
    pub adjacency: Vec<Vec<u64>>,
    /// Initial velocities v₀, m/s, one per particle.
    pub velocities: Option<Vec<[f32; 3]>>,
}

/// `[obj]`: a triangle mesh from a Wavefront OBJ file.
#[derive(Clone, Debug, Deserialize, Serialize)]
#[serde(deny_unknown_fields)]
pub struct ObjTable {
    /// The OBJ file, relative to the scene file.
    pub path: String,
    /// Indices of the vertices to fix (0-based, in file order).
    #[serde(default)]
    pub pinned: Vec<u64>,
    /// Multiplies every coordinate (default 1).
    pub scale: Option<f32>,
    /// Added to every coordinate after scaling, metres (default 0).
    pub offset: Option<[f32; 3]>,
}

/// `[camera]`.
#[derive(Clone, Debug, Default, Deserialize, Serialize)]
#[serde(deny_unknown_fields)]
pub struct CameraTable {
    /// Degrees about the vertical axis.
    pub yaw: Option<f32>,
    /// Degrees of elevation.
    pub pitch: Option<f32>,
    /// Metres from the target.
    pub distance: Option<f32>,
    /// The point looked at.
    pub target: Option<[f32; 3]>,
}
