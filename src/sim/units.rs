//! Physical units: particle masses from an area density, bar compliances
//! from stretch and bend stiffness, so that a cloth behaves the same at any
//! resolution.
//!
//! # Mass
//!
//! Each triangle of area A_t gives a third of its mass σ A_t to each of its
//! corners (a lumped mass matrix):
//!
//! ```text
//! m_i = σ · A_i,    A_i = Σ_{t ∋ i} A_t / 3,    Σ_i m_i = σ · A
//! ```
//!
//! A vertex in no triangle gets the mean of the others' areas. The
//! solvers weigh particles by `w_i = m̄ / m_i` with m̄ the mean particle mass
//! (the scene's "m" in equation 1 becomes m̄).
//!
//! # Stretch stiffness
//!
//! k_s (N/m) is the membrane stiffness, Young's modulus times thickness: a
//! strip of width W and length ℓ pulled by F stretches by F ℓ / (k_s W). A
//! bar of stiffness k_e (N/m, its XPBD compliance α = 1/k_e) stretched by a
//! strain ε stores ½ k_e (ε L_e)². drape gives every structural bar the same
//! compliance, chosen so that stretching the cloth by ε in every direction of
//! its plane stores what a sheet with Poisson's ratio 0 stores,
//! ½ k_s (ε_xx² + ε_yy²) A = k_s ε² A:
//!
//! ```text
//! Σ_e ½ (1/α) ε² L_e² = k_s ε² A      ⇒      α_s = Σ_e L_e² / (2 k_s A)
//! ```
//!
//! On a grid of spacing s with N particles, Σ L_e² and A both grow as N s²,
//! so α_s (and each bar's stiffness) is the same at every resolution: a
//! strip twice as fine has twice the bars in series and twice in parallel.
//! Along one axis, with the sides free to narrow, a bar lattice is softer
//! than the calibration says: the seed's grid (axis bars and both
//! diagonals, each k_s/3) pulls with k_s/2 per unit strain and width
//! (C₁₁ = 2k_s/3, C₁₂ = k_s/3, E = C₁₁ − C₁₂²/C₁₁), a grid with one
//! diagonal per cell with 2k_s/3. Derivation: sum ½ k_e (L_e n_e·ε·n_e)²
//! over the bars of one cell (the Cauchy–Born rule).
//!
//! # Bend stiffness
//!
//! B (N·m) is the flexural rigidity: a sheet bent to curvature κ stores
//! ½ B κ² per unit area in each direction it bends. Bend bars join
//! particles two apart; bending the hinge between them by θ shortens a bar
//! of length L by L(1 − cos(θ/2)) ≈ L θ²/8, and at curvature κ the hinge
//! angle is θ = κ L/2, so the bar shortens by κ² L³/32 and stores
//! ½ (1/α) κ⁴ L⁶/1024 — to fourth order in κ where the sheet stores the
//! second. No constant stiffness makes the two agree at every curvature, so
//! drape makes them agree at a reference curvature κ₀ =
//! [`REFERENCE_CURVATURE`] (a fold of radius 2 cm, the scale of the folds
//! of draped fabric), bending in every direction at once (B κ₀² A):
//!
//! ```text
//! Σ_b (1/α) κ₀⁴ L_b⁶ / 2048 = B κ₀² A      ⇒      α_b = κ₀² Σ_b L_b⁶ / (2048 B A)
//! ```
//!
//! Σ L_b⁶ grows as N s⁶ and A as N s², so α_b ∝ s⁴, and the energy of a
//! curvature κ summed over the bars, B κ⁴ A / κ₀², does not depend on s:
//! the same bend stiffness means the same at every resolution, softer than
//! a sheet's below κ₀ and stiffer above it. Bend bars of an OBJ mesh join the
//! far corners of two triangles sharing an edge; the same formula treats
//! them as a hinge in their middle, which is exact for a regular mesh.

use glam::Vec3;

use super::mesh::{BarKind, ClothMesh};
use super::params::{ParamError, SolverParams};

/// κ₀: the curvature at which a bend bar's energy equals the sheet's, 1/m
/// (a fold of radius 2 cm).
pub const REFERENCE_CURVATURE: f32 = 50.0;

/// The area of triangle `t`, m².
pub fn triangle_area(positions: &[Vec3], t: [u32; 3]) -> f32 {
    let [a, b, c] = t.map(|i| positions[i as usize]);
    0.5 * (b - a).cross(c - a).length()
}

/// Each particle's share of the cloth's area, m²: a third of the area of
/// every triangle it is a corner of (a vertex in no triangle: 0).
pub fn vertex_areas(positions: &[Vec3], triangles: &[[u32; 3]]) -> Vec<f32> {
    let mut areas = vec![0.0f32; positions.len()];
    for &t in triangles {
        let third = triangle_area(positions, t) / 3.0;
        for i in t {
            areas[i as usize] += third;
        }
    }
    areas
}

/// Refuses what needs triangles on a mesh that has none (a `[mesh]`
/// adjacency list): the "air" wind, a density, a stretch or bend
/// stiffness. The error names the parameter as `SolverParams::validate`
/// does.
pub fn check_surface(params: &SolverParams, mesh: &ClothMesh) -> Result<(), ParamError> {
    if !mesh.triangles().is_empty() {
        return Ok(());
    }
    let checks: [(&'static str, Option<String>, &'static str); 4] = [
        (
            "wind.model",
            params.wind.air().map(|_| "\"air\"".to_string()),
            "the air pushes on triangles and this mesh has no triangles (a [mesh] adjacency list has bars only): \
             use a [grid] or an [obj], or the \"seed\" or \"constant\" wind",
        ),
        (
            "density",
            params.density.map(|v| v.to_string()),
            "a density is a mass per area and this mesh has no triangles (a [mesh] adjacency list has bars only): \
             use a [grid] or an [obj], or mass",
        ),
        (
            "stretch_stiffness",
            params.stretch_stiffness.map(|v| v.to_string()),
            "a stiffness in N/m is per width of cloth and this mesh has no triangles (a [mesh] adjacency list has \
             bars only): use a [grid] or an [obj], or stretch_compliance",
        ),
        (
            "bend_stiffness",
            params.bend_stiffness.map(|v| v.to_string()),
            "a bend stiffness is per width of cloth and this mesh has no triangles (a [mesh] adjacency list has \
             bars only): use a [grid] or an [obj], or bend_compliance",
        ),
    ];
    match checks.into_iter().find_map(|(name, value, allowed)| value.map(|v| (name, v, allowed))) {
        Some((name, value, allowed)) => Err(ParamError::new(name, value, allowed)),
        None => Ok(()),
    }
}

/// The cloth's rest area A, m²: the sum of its triangles' areas; an error
/// naming `key` when the mesh has none (an adjacency list has no area).
pub fn rest_area(mesh: &ClothMesh, key: &'static str, value: f32) -> Result<f32, ParamError> {
    let area: f64 = mesh.triangles().iter().map(|&t| f64::from(triangle_area(mesh.positions(), t))).sum();
    if mesh.triangles().is_empty() || area.is_nan() || area <= 0.0 {
        return Err(ParamError::new(
            key,
            value,
            "only on a mesh with triangles of non-zero area (a [grid] or an [obj]); a [mesh] adjacency list has \
             bars but no area",
        ));
    }
    Ok(area as f32)
}

/// m_i = σ A_i for every particle, kg (a vertex in no triangle gets the mean
/// area). An error when the mesh has no triangles.
pub fn particle_masses(mesh: &ClothMesh, density: f32) -> Result<Vec<f32>, ParamError> {
    rest_area(mesh, "density", density)?;
    let mut areas = vertex_areas(mesh.positions(), mesh.triangles());
    let covered: Vec<f32> = areas.iter().copied().filter(|&a| a > 0.0).collect();
    let mean = covered.iter().sum::<f32>() / covered.len().max(1) as f32;
    for a in &mut areas {
        if *a <= 0.0 {
            *a = mean;
        }
    }
    Ok(areas.into_iter().map(|a| density * a).collect())
}

/// α_s = Σ L_e² / (2 k_s A) over the structural bars, m/N.
pub fn stretch_compliance(mesh: &ClothMesh, stiffness: f32) -> Result<f32, ParamError> {
    let area = rest_area(mesh, "stretch_stiffness", stiffness)?;
    // The diagonals (shear bars) count: they share the load of a stretch.
    let sum = sum_of_powers(mesh, BarKind::Structural, 2) + sum_of_powers(mesh, BarKind::Shear, 2);
    Ok((sum / (2.0 * f64::from(stiffness) * f64::from(area))) as f32)
}

/// α_b = κ₀² Σ L_b⁶ / (2048 B A) over the bend bars, m/N (0 when the mesh
/// has no bend bars: nothing to set).
pub fn bend_compliance(mesh: &ClothMesh, stiffness: f32) -> Result<f32, ParamError> {
    let area = rest_area(mesh, "bend_stiffness", stiffness)?;
    let sum = sum_of_powers(mesh, BarKind::Bend, 6);
    let k0 = f64::from(REFERENCE_CURVATURE);
    Ok((k0 * k0 * sum / (2048.0 * f64::from(stiffness) * f64::from(area))) as f32)
}

/// Σ L^p over the bars of one kind, in f64 (L⁶ of a 1 mm bar is 1e-18).
fn sum_of_powers(mesh: &ClothMesh, kind: BarKind, p: i32) -> f64 {
    mesh.bars().iter().filter(|b| b.kind == kind).map(|b| f64::from(b.rest_length).powi(p)).sum()
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::sim::{Grid, GridPlane, Pins};

    fn grid(n: u32, spacing: f32) -> ClothMesh {
        Grid { columns: n, rows: n, spacing, plane: GridPlane::Horizontal, pins: Pins::None, ..Grid::default() }
            .build()
            .unwrap()
    }

    #[test]
    fn masses_sum_to_density_times_area_at_any_resolution() {
        // A 1 m square at 11 and 31 particles a side: σ = 0.2 kg/m² → 0.2 kg.
        for n in [11, 31] {
            let m = particle_masses(&grid(n, 1.0 / (n - 1) as f32), 0.2).unwrap();
            let total: f32 = m.iter().sum();
            assert!((total - 0.2).abs() < 1e-5, "{n}: {total}");
            // An interior particle of the one-diagonal triangulation touches
            // 6 triangles of s²/2: a third of them is s².
            let s = 1.0 / (n - 1) as f32;
            let centre = (n / 2 * n + n / 2) as usize;
            assert!((m[centre] - 0.2 * s * s).abs() < 1e-6 * 0.2, "{}", m[centre]);
        }
    }

    #[test]
    fn stretch_compliance_is_the_same_at_every_resolution_and_matches_the_derivation() {
        // The seed's grid: per particle, two axis bars (s) and two diagonals
        // (s√2): Σ L² = 6 s² per particle in the interior, A = s² per
        // particle, so α = 6 / (2 k) = 3/k; edges lose some bars and some
        // area, so a finite grid is a little below.
        let k = 300.0;
        let coarse = stretch_compliance(&grid(11, 0.1), k).unwrap();
        let fine = stretch_compliance(&grid(41, 0.025), k).unwrap();
        assert!((fine - 3.0 / k).abs() < 0.05 * 3.0 / k, "{fine} against {}", 3.0 / k);
        assert!((coarse - fine).abs() < 0.12 * fine, "{coarse} vs {fine}");
    }

    #[test]
    fn bend_compliance_scales_as_the_fourth_power_of_the_spacing() {
        // α_b ∝ s⁴ (module docs): halving the spacing divides it by 16,
        // up to the edges' share (the grids are 21 and 41 a side).
        let b = 1e-5;
        let coarse = bend_compliance(&grid(21, 0.05), b).unwrap();
        let fine = bend_compliance(&grid(41, 0.025), b).unwrap();
        let ratio = coarse / fine;
        assert!((ratio - 16.0).abs() < 0.1 * 16.0, "{ratio}");
    }

    #[test]
    fn an_adjacency_mesh_has_no_area() {
        let mesh = ClothMesh::from_adjacency(
            vec![Vec3::ZERO, Vec3::X, Vec3::Y],
            &[0],
            &[vec![1, 2], vec![0, 2], vec![0, 1]],
            None,
        )
        .unwrap();
        let e = particle_masses(&mesh, 0.2).unwrap_err();
        assert_eq!(e.name, "density");
        assert!(e.to_string().contains("adjacency"), "{e}");
        assert_eq!(stretch_compliance(&mesh, 100.0).unwrap_err().name, "stretch_stiffness");
    }
}
