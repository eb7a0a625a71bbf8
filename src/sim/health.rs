//! Checks for a state that is finite but absurd: the simulation has not
//! blown up, yet what it shows is no longer cloth. Each check says what is
//! wrong and what to change, so the viewer and `drape run` can warn
//! instead of silently showing an exploded cloth.
//!
//! - **Stretch**: an edge longer than 11× its rest length (strain > 10);
//!   the relaxation passes cannot pull that back in a step.
//! - **Distance**: a particle more than 1 km from where the cloth started
//!   (its rest shape's bounding box).
//! - **Speed**: a particle that moved farther in the last step than 10 of
//!   the mesh's longest bars, |x_i − x_{i−1}| > 10 L_max: the step h is too
//!   long to resolve that motion (a collision or a bar is crossed in one
//!   step).

use super::Simulation;

/// Edge strain past which the cloth is not cloth any more.
pub const ABSURD_STRAIN: f32 = 10.0;
/// Metres from the rest shape's box past which a particle has run away.
pub const ABSURD_DISTANCE: f32 = 1000.0;
/// Bar lengths per step past which h cannot resolve a particle's motion.
pub const ABSURD_BARS_PER_STEP: f32 = 10.0;

/// What is absurd about a state.
#[derive(Clone, Debug, PartialEq, thiserror::Error)]
pub enum Absurdity {
    /// An edge stretched past [`ABSURD_STRAIN`].
    #[error(
        "the cloth is stretched to {:.0}× its length (edge strain {strain:.1}): it is not holding together; \
         try more relaxations, inextensible edges, a smaller dt or weaker forces", strain + 1.0
    )]
    Stretched {
        /// The largest edge strain.
        strain: f32,
    },
    /// A particle ran away.
    #[error(
        "particle {particle} is {distance:.0} m from where the cloth started: it has run away; \
         try a smaller dt, more damping or weaker forces"
    )]
    RunAway {
        /// The particle.
        particle: usize,
        /// Metres from the rest shape's bounding box.
        distance: f32,
    },
    /// A particle moved too far in one step.
    #[error(
        "particle {particle} moved {step:.2} m in one step ({speed:.0} m/s), more than {bars:.0} bar lengths: \
         h = {dt} s cannot resolve that; try a smaller dt or more substeps"
    )]
    TooFast {
        /// The particle.
        particle: usize,
        /// Metres moved in the last step.
        step: f32,
        /// m/s.
        speed: f32,
        /// The limit, in bar lengths.
        bars: f32,
        /// h, seconds.
        dt: f32,
    },
}

/// The first absurdity found in `sim`'s state (stretch, then distance, then
/// speed), if any. `edge_strain` is the edges' max strain, which the
/// caller usually has at hand ([`Simulation::edge_strain`]).
pub fn check(sim: &Simulation, edge_strain: f32) -> Option<Absurdity> {
    if edge_strain > ABSURD_STRAIN {
        return Some(Absurdity::Stretched { strain: edge_strain });
    }
    let positions = sim.positions();
    let (min, max) = sim.mesh().bounds();
    let (particle, distance) = farthest(positions.iter().map(|&p| (p - p.clamp(min, max)).length()));
    if distance > ABSURD_DISTANCE {
        return Some(Absurdity::RunAway { particle, distance });
    }
    let longest = sim.mesh().longest_bar();
    if longest > 0.0 && sim.steps() > 0 {
        // x − x_prev spans the last substep (h/n).
        let moved = positions.iter().zip(sim.previous_positions()).map(|(p, q)| p.distance(*q));
        let (particle, step) = farthest(moved);
        if step > ABSURD_BARS_PER_STEP * longest {
            let dt = sim.params().substep_dt();
            return Some(Absurdity::TooFast { particle, step, speed: step / dt, bars: ABSURD_BARS_PER_STEP, dt });
        }
    }
    None
}

/// The index and value of the largest of `values` (NaN never wins).
fn farthest(values: impl Iterator<Item = f32>) -> (usize, f32) {
    values.enumerate().fold((0, 0.0), |best, (i, v)| if v > best.1 { (i, v) } else { best })
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::sim::{Grid, GridPlane, Pins, SolverParams};

    /// A 3 × 3 horizontal grid of 1 m spacing at rest, h = 0.05 s.
    fn sim() -> Simulation {
        let mesh = Grid {
            columns: 3,
            rows: 3,
            spacing: 1.0,
            plane: GridPlane::Horizontal,
            pins: Pins::None,
            ..Grid::default()
        }
        .build()
        .unwrap();
        let mut sim = Simulation::new(mesh, SolverParams::default()).unwrap();
        sim.step().unwrap();
        sim
    }

    #[test]
    fn a_resting_cloth_is_fine_and_each_absurdity_is_named() {
        let mut s = sim();
        assert_eq!(check(&s, s.edge_strain().max), None);
        // An edge at 12× its length: strain 11 > 10.
        assert!(matches!(check(&s, 11.0), Some(Absurdity::Stretched { .. })));
        // Particle 4 put 2 km away (at rest there): run away, and the
        // message says from where and what to try.
        let mut far = s.positions().to_vec();
        far[4].y += 2000.0;
        s.set_state(&far, &far).unwrap();
        let e = check(&s, 0.0).unwrap();
        assert!(matches!(e, Absurdity::RunAway { particle: 4, .. }), "{e}");
        assert!(e.to_string().contains("smaller dt"), "{e}");
        // Particle 4 moving 25 m in one step: 10 bar lengths are 10 × √2 m
        // (the diagonals are the longest bars, 14.1 m); 25 m is beyond.
        let mut at = sim().positions().to_vec();
        let before = at.clone();
        at[4].y += 25.0;
        let mut s = sim();
        s.set_state(&at, &before).unwrap();
        let e = check(&s, 0.0).unwrap();
        assert!(matches!(e, Absurdity::TooFast { particle: 4, .. }), "{e}");
        assert!(e.to_string().contains("500 m/s"), "{e}");
        // 10 m in a step is within 14.1 m: no warning.
        at[4].y = before[4].y + 10.0;
        s.set_state(&at, &before).unwrap();
        assert_eq!(check(&s, 0.0), None);
    }
}
