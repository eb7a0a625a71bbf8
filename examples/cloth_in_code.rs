//! Building cloth in code, without a scene file: the library as a user
//! embeds it.
//!
//! Two cloths:
//! 1. a grid (the builder the seed's Figure 1 describes), dropped onto a
//!    ball resting on the ground, in moving air, with friction;
//! 2. a mesh from arrays (four triangles of a square, one corner pinned),
//!    hanging under gravity.
//!
//! Each is stepped, and its positions and strain are read back.
//!
//! ```text
//! cargo run --release --example cloth_in_code
//! ```

use drape::sim::wind::Air;
use drape::sim::{ClothMesh, Collider, Grid, GridPlane, Pins, Pose, Shape, Simulation, SolverParams, Wind};
use glam::Vec3;

fn main() -> Result<(), Box<dyn std::error::Error>> {
    // 1. A 1 m square of 41 × 41 particles, lying flat 0.5 m above the ground.
    let mesh = Grid {
        columns: 41,
        rows: 41,
        spacing: 0.025,
        plane: GridPlane::Horizontal,
        origin: Some(Vec3::new(-0.5, 0.8, -0.5)),
        pins: Pins::None,
        ..Grid::default()
    }
    .build()?;
    let params = SolverParams {
        dt: 1.0 / 60.0,
        substeps: 4,
        relaxations: 10,
        damping: 0.01,
        // Physical units: 150 g/m² of fabric, gravity as an acceleration.
        density: Some(0.15),
        gravity_acceleration: Some(Vec3::new(0.0, -9.81, 0.0)),
        // 5 mm kept from colliders, Coulomb friction 0.4.
        thickness: 0.005,
        friction: 0.4,
        // Still air, which resists the cloth's motion by drag and lift.
        wind: Wind::Air(Air { velocity: Vec3::new(0.5, 0.0, 0.0), ..Air::default() }),
        ..SolverParams::default()
    };
    let colliders = vec![
        Collider::fixed(Shape::Plane { normal: Vec3::Y }, Pose::default()),
        Collider::fixed(
            Shape::Sphere { radius: 0.3 },
            Pose { translation: Vec3::new(0.0, 0.3, 0.0), ..Pose::default() },
        ),
    ];
    let mut sim = Simulation::new(mesh, params)?.with_colliders(colliders);
    // Three simulated seconds.
    sim.advance(180)?;
    let (lowest, highest) = drape::sim::mesh::bounds(sim.positions());
    let centre = sim.positions()[20 * 41 + 20];
    println!("grid on a ball, after {:.2} s:", sim.time());
    println!("  centre particle at {centre:.3} (the ball's top is y = 0.6 m, plus 5 mm)");
    println!("  lowest y {:.3} m, highest y {:.3} m", lowest.y, highest.y);
    println!("  strain: max {:.2} %, edges {:.2} %", 100.0 * sim.strain().max, 100.0 * sim.edge_strain().max);
    println!("  kinetic energy {:.2e} J", sim.kinetic_energy());

    // 2. A mesh from arrays: a 1 m square in the xy plane, split into four
    // triangles about its centre; corner 0 is pinned.
    let positions = vec![
        Vec3::new(0.0, 1.0, 0.0),
        Vec3::new(1.0, 1.0, 0.0),
        Vec3::new(1.0, 0.0, 0.0),
        Vec3::new(0.0, 0.0, 0.0),
        Vec3::new(0.5, 0.5, 0.0),
    ];
    let triangles = vec![[0, 1, 4], [1, 2, 4], [2, 3, 4], [3, 0, 4]];
    let mesh = ClothMesh::from_triangles(positions, triangles, &[0], None)?;
    let mut sim = Simulation::new(mesh, SolverParams { relaxations: 50, ..SolverParams::default() })?;
    sim.advance(400)?;
    println!("square of four triangles hanging from one corner, after {:.1} s:", sim.time());
    for (i, p) in sim.positions().iter().enumerate() {
        println!("  particle {i}: {p:.3}");
    }
    // The far corner, particle 2, hangs √2 m below the pin once the square
    // swings still along its diagonal.
    let drop = sim.positions()[0].y - sim.positions()[2].y;
    println!("  corner 2 hangs {drop:.3} m below the pin (the diagonal is {:.3} m)", 2f32.sqrt());
    println!("  strain: max {:.3} %", 100.0 * sim.strain().max);
    Ok(())
}
