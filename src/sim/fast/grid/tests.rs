use super::ops::{KIND_SHIFT, ROTATED};
use super::*;
use crate::sim::mesh::{Bar, Grid, Pins};
use crate::sim::mesh::{ClothMesh, GridShape};
use crate::sim::reference::ReferenceSolver;
use crate::sim::step::{Solver, Substep};

impl GridLayout {
    /// Scene particle at a location, if any.
    fn scene_index(&self) -> std::collections::HashMap<(u32, u32, u8), u32> {
        self.locations.iter().enumerate().map(|(i, l)| ((l.tile, l.slot, l.lane), i as u32)).collect()
    }

    /// The bars one sweep projects, as scene particle pairs, in an order
    /// equivalent to the sweep's: even tiles then odd ones, each followed
    /// by its seam bars to the next tile (the lanes of one operation are
    /// independent, so any lane order will do).
    fn projection_order(&self) -> Vec<(u32, u32)> {
        let at = self.scene_index();
        let mut order = Vec::new();
        let count = self.tiles.len() as u32;
        for t in (0..count).step_by(2).chain((1..count).step_by(2)) {
            for op in self.ops.iter() {
                let (sa, sb) = op.slots();
                for l in 0..LANES as u8 {
                    let lb = if op.rotated() { l + 1 } else { l };
                    if let (Some(&a), Some(&b)) = (at.get(&(t, sa as u32, l)), at.get(&(t, sb as u32, lb))) {
                        order.push((a, b));
                    }
                }
            }
            for s in &self.tiles[t as usize].seams {
                order.push((at[&(s.a.tile, s.a.slot, s.a.lane)], at[&(s.b.tile, s.b.slot, s.b.lane)]));
            }
        }
        order
    }
}

/// Which cells `(c, r)` of [`triangle_sheet`] take the other diagonal.
pub(crate) type Flip = fn(u32, u32) -> bool;
/// Every diagonal from top left to bottom right.
pub(crate) const DOWN: Flip = |_, _| false;
/// Every diagonal from top right to bottom left.
pub(crate) const UP: Flip = |_, _| true;
/// Alternating, as in a chequerboard (the bench's sheet).
pub(crate) const ALTERNATE: Flip = |c, r| (c + r) % 2 == 1;

/// A C × R sheet of two triangles a cell, numbered row by row, hung by
/// its first row; `flip` chooses each cell's diagonal.
pub(crate) fn triangle_sheet(columns: u32, rows: u32, flip: Flip) -> ClothMesh {
    let positions =
        (0..columns * rows).map(|i| Vec3::new((i % columns) as f32 * 0.1, -((i / columns) as f32) * 0.1, 0.0));
    let mut triangles = Vec::new();
    for r in 0..rows - 1 {
        for c in 0..columns - 1 {
            let i = r * columns + c;
            let (j, k, l) = (i + 1, i + columns, i + columns + 1);
            if flip(c, r) {
                triangles.extend([[i, k, j], [j, k, l]]);
            } else {
                triangles.extend([[i, k, l], [i, l, j]]);
            }
        }
    }
    let pinned: Vec<u64> = (0..u64::from(columns)).collect();
    ClothMesh::from_triangles(positions.collect(), triangles, &pinned, None).expect("a valid sheet")
}

/// `mesh` (from triangles) with its particles numbered anew: particle i
/// becomes `(i · 7919) mod n` (a permutation when n is not a multiple of
/// 7919, a prime), so neighbours are far apart in the numbering.
pub(crate) fn renumbered(mesh: &ClothMesh) -> ClothMesh {
    let n = mesh.positions().len() as u64;
    let new = |i: u32| ((u64::from(i) * 7919) % n) as u32;
    let mut positions = vec![Vec3::ZERO; n as usize];
    for (i, &p) in mesh.positions().iter().enumerate() {
        positions[new(i as u32) as usize] = p;
    }
    let triangles = mesh.triangles().iter().map(|t| t.map(new)).collect();
    let pinned: Vec<u64> =
        mesh.fixed().iter().enumerate().filter(|(_, f)| **f).map(|(i, _)| u64::from(new(i as u32))).collect();
    ClothMesh::from_triangles(positions, triangles, &pinned, None).expect("a valid sheet")
}

fn weights(mesh: &ClothMesh) -> Vec<f32> {
    mesh.fixed().iter().map(|&f| if f { 0.0 } else { 1.0 }).collect()
}

/// Integrate, relax and settle: a substep without contact.
fn step(layout: &mut GridLayout, s: &Substep) {
    crate::sim::step::run_substep(layout, s, crate::sim::step::Phases::default());
}

/// A plain substep: no force, no damping, rigid bars, `relaxations` passes.
fn substep(relaxations: u32) -> Substep<'static> {
    Substep {
        dt: 0.01,
        keep: 1.0,
        accel: Vec3::ZERO,
        gravity: Vec3::ZERO,
        first: None,
        relaxations,
        tolerance: 0.0,
        over_relaxation: 1.0,
        stretch_beta: 0.0,
        bend_beta: 0.0,
        shear_beta: 0.0,
        tether_slack: None,
    }
}

/// Deterministic jitter in [−amount, amount).
fn jittered(points: &[Vec3], amount: f32) -> Vec<Vec3> {
    let mut state = 12345u64;
    let mut next = || {
        state = state.wrapping_mul(6364136223846793005).wrapping_add(1442695040888963407);
        ((state >> 40) as f32 / (1u64 << 24) as f32 * 2.0 - 1.0) * amount
    };
    points.iter().map(|&p| p + Vec3::new(next(), next(), next())).collect()
}

fn shapes() -> Vec<(ClothMesh, &'static str)> {
    let g = |columns, rows, pins| Grid { columns, rows, spacing: 0.1, pins, ..Grid::default() };
    let grids = vec![
        (g(20, 30, Pins::TopRow), "the seed's 20 × 30, top row"),
        (g(30, 20, Pins::LeftColumn), "wide, pinned left: transposed"),
        (g(17, 23, Pins::Cells(vec![[3, 22], [16, 22]])), "pinned at the bottom: flipped; 17 columns pad lane 7"),
        (g(130, 12, Pins::TopCorners), "130 columns: three tiles and two seams"),
        (g(17, 17, Pins::None), "the narrowest grid with lanes (blocks of 3)"),
        (Grid { shear: false, ..g(24, 16, Pins::TopRow) }, "no diagonals"),
        (Grid { bend: false, ..g(24, 16, Pins::TopRow) }, "no bend bars"),
    ];
    let mut meshes: Vec<(ClothMesh, &'static str)> =
        grids.into_iter().map(|(grid, what)| (grid.build().expect("a valid grid"), what)).collect();
    // Triangle meshes numbered row by row (no grid shape given): knight's-
    // move bend bars; 130 columns make seams whose bars span two rows.
    meshes.push((triangle_sheet(24, 20, DOWN), "a triangulated sheet"));
    meshes.push((triangle_sheet(130, 14, UP), "a triangulated sheet of three tiles, other diagonals"));
    // Diagonals of both directions, and bend bars of five offsets, in a
    // pattern that repeats every two columns and rows: an operation's
    // lanes (8 columns apart) all find the same bar, or none.
    meshes.push((triangle_sheet(130, 15, ALTERNATE), "a chequerboard sheet of three tiles"));
    // The same in another numbering: the grid comes from the triangles.
    meshes.push((renumbered(&triangle_sheet(130, 15, ALTERNATE)), "the chequerboard sheet renumbered"));
    // A rest shape that is not even (every bar its own rest length: each
    // operation takes eight), in row order and renumbered.
    let bumpy = |mesh: &ClothMesh| {
        let positions = jittered(mesh.positions(), 0.01);
        let pinned: Vec<u64> = (0..mesh.fixed().len() as u64).filter(|&i| mesh.fixed()[i as usize]).collect();
        ClothMesh::from_triangles(positions, mesh.triangles().to_vec(), &pinned, None).expect("a valid sheet")
    };
    meshes.push((bumpy(&triangle_sheet(130, 15, ALTERNATE)), "a bumpy chequerboard sheet"));
    meshes.push((renumbered(&bumpy(&triangle_sheet(70, 12, DOWN))), "a bumpy sheet renumbered"));
    meshes
}

#[test]
fn every_bar_is_projected_once_per_sweep() {
    for (mesh, what) in shapes() {
        let layout = GridLayout::new(&mesh, mesh.positions(), mesh.positions(), &weights(&mesh), None).expect(what);
        // Bars between two fixed particles are visited too (as no-ops),
        // so that freeing a particle needs no new operation.
        let mut seen: Vec<(u32, u32)> =
            layout.projection_order().into_iter().map(|(a, b)| (a.min(b), a.max(b))).collect();
        seen.sort_unstable();
        let mut expected: Vec<(u32, u32)> = mesh.bars().iter().map(|b| (b.a.min(b.b), b.a.max(b.b))).collect();
        expected.sort_unstable();
        assert_eq!(seen, expected, "{what}");
    }
}

#[test]
fn a_sweep_equals_the_reference_loop_in_the_same_order() {
    // One sweep of the lanes from a jittered state against the plain
    // Gauss–Seidel loop over the same bars in the equivalent order. The
    // two differ only by rounding (the kernels compute the shares as
    // own·partner, the reference as w_a / (w_a + w_b)): a few ulps of
    // positions near 1 m. A bar missing, doubled or with the wrong rest
    // length or weight would move particles by millimetres.
    for (mesh, what) in shapes() {
        let fixed = mesh.fixed().to_vec();
        let start = jittered(mesh.positions(), 0.02);
        let start: Vec<Vec3> =
            start.iter().zip(mesh.positions()).zip(&fixed).map(|((&j, &p), &f)| if f { p } else { j }).collect();
        let mut layout = GridLayout::new(&mesh, &start, &start, &weights(&mesh), None).expect(what);
        let rest: std::collections::HashMap<(u32, u32), f32> =
            mesh.bars().iter().map(|b| ((b.a.min(b.b), b.a.max(b.b)), b.rest_length)).collect();
        let bars = layout
            .projection_order()
            .into_iter()
            .map(|(a, b)| Bar { a, b, rest_length: rest[&(a.min(b), a.max(b))], kind: crate::sim::BarKind::Structural })
            .collect::<Vec<_>>();
        let mut reference = ReferenceSolver::new(&start, &start, &weights(&mesh), &bars, None);
        reference.relax_once();
        step(&mut layout, &substep(1));
        let (mut got, mut previous) = (start.clone(), start.clone());
        layout.read(&mut got, &mut previous);
        let worst = got.iter().zip(&reference.positions).map(|(a, b)| a.distance(*b)).fold(0.0, f32::max);
        assert!(worst < 2e-6, "{what}: lanes and reference differ by {worst} m after one sweep");
        let moved = got.iter().zip(&start).map(|(a, b)| a.distance(*b)).fold(0.0, f32::max);
        assert!(moved > 1e-3, "{what}: the sweep moved nothing ({moved} m)");
    }
}

#[test]
fn overlapped_sweeps_are_bit_identical_to_sequential_ones() {
    // The seed's 30 rows with 7 and 20 sweeps (four in flight, a new one
    // starting whenever one finishes), and short cloths of 5 and 2 rows,
    // where a sweep finishes before the next can start three rows behind.
    // With sweeps one row apart instead of three, operations that share
    // particles run out of order and this test fails (a mutation run).
    // Two rows apart happens to keep this grid's order: the only class
    // that reaches two rows down (BV) comes last in a row.
    for (rows, sweeps) in [(30, 7), (30, 20), (5, 9), (2, 5)] {
        let mesh = Grid { columns: 20, rows, spacing: 0.1, ..Grid::default() }.build().unwrap();
        let start = jittered(mesh.positions(), 0.02);
        for compliance in [0.0, 1e-3] {
            let mut overlapped = GridLayout::new(&mesh, &start, &start, &weights(&mesh), None).unwrap();
            let mut sequential = overlapped.clone();
            let s = Substep {
                keep: 0.98,
                accel: Vec3::new(0.0, -1e-3, 0.0),
                stretch_beta: compliance,
                bend_beta: 10.0 * compliance,
                shear_beta: 3.0 * compliance,
                over_relaxation: 1.3,
                ..substep(sweeps)
            };
            step(&mut overlapped, &s);
            // The same substep with a tolerance too small to ever stop
            // early takes the one-sweep-at-a-time path.
            step(&mut sequential, &Substep { tolerance: 1e-30, ..s });
            let what = format!("{rows} rows, {sweeps} sweeps, compliance {compliance}");
            assert_eq!(bits(&overlapped), bits(&sequential), "{what}");
        }
    }
}

fn bits(l: &GridLayout) -> Vec<u32> {
    let n = l.locations.len();
    let (mut p, mut q) = (vec![Vec3::ZERO; n], vec![Vec3::ZERO; n]);
    l.read(&mut p, &mut q);
    p.iter().chain(&q).flat_map(|v| v.to_array().map(f32::to_bits)).collect::<Vec<_>>()
}

#[test]
fn orientation_puts_the_pins_where_the_sweep_starts() {
    let o = |columns, rows, pins| {
        let mesh = Grid { columns, rows, pins, ..Grid::default() }.build().unwrap();
        let o = Orientation::choose(mesh.grid().unwrap(), mesh.fixed()).unwrap();
        (o.transposed, o.flipped)
    };
    assert_eq!(o(20, 30, Pins::TopRow), (false, false));
    assert_eq!(o(20, 30, Pins::LeftColumn), (true, false));
    assert_eq!(o(20, 30, Pins::Cells((0..20).map(|c| [c, 29]).collect())), (false, true));
    // Too narrow one way: only the orientation with ≥ 9 columns is allowed.
    assert!(o(6, 30, Pins::LeftColumn).0);
    assert!(Orientation::choose(GridShape { columns: 16, rows: 16 }, &[false; 256]).is_none());
}

#[test]
fn seam_groups_are_independent_and_keep_each_rows_order() {
    // 300 columns: five tiles of 64, rounded to four (a multiple of four:
    // 19 200 particles are swept on threads), so three seams, with rows of
    // five seam bars (H, D, A and two BH) and a last row of three (no
    // diagonal leaves it).
    let mesh = Grid { columns: 300, rows: 64, spacing: 0.1, pins: Pins::TopRow, ..Grid::default() }.build().unwrap();
    let layout = GridLayout::new(&mesh, mesh.positions(), mesh.positions(), &weights(&mesh), None).unwrap();
    assert_eq!(layout.tiles.len(), 4);
    let at = layout.scene_index();
    let mut seams_seen = 0;
    for tile in &layout.tiles[..layout.tiles.len() - 1] {
        assert_eq!(*tile.seam_ends.last().unwrap() as usize, tile.seams.len());
        let mut start = 0;
        for &end in &tile.seam_ends {
            let group = &tile.seams[start..end as usize];
            assert!((1..=LANES).contains(&group.len()));
            // One kind and one rest length, and no particle twice.
            assert!(group.iter().all(|s| s.kind == group[0].kind && s.rest == group[0].rest));
            let mut ends: Vec<u32> = group
                .iter()
                .flat_map(|s| [at[&(s.a.tile, s.a.slot, s.a.lane)], at[&(s.b.tile, s.b.slot, s.b.lane)]])
                .collect();
            ends.sort_unstable();
            ends.dedup();
            assert_eq!(ends.len(), 2 * group.len(), "a group shares a particle");
            start = end as usize;
        }
        // Each row's bars come in the order they were built (H, D, A, BH, BH).
        let row = |s: &SeamBar| s.a.slot.min(s.b.slot) / layout.block as u32;
        for r in 0..64 {
            let kinds: Vec<(u8, u32)> =
                tile.seams.iter().filter(|s| row(s) == r).map(|s| (s.kind, s.rest.to_bits())).collect();
            let expected = if r == 63 { 3 } else { 5 };
            assert_eq!(kinds.len(), expected, "row {r}");
            assert_eq!(kinds[0].0, crate::sim::BarKind::Structural.index() as u8, "row {r} starts with H");
            assert!(kinds[kinds.len() - 2..].iter().all(|k| k.0 == crate::sim::BarKind::Bend.index() as u8));
        }
        seams_seen += tile.seams.len();
        // Eight rows a group: 318 seam bars in 40 groups (32 even and 32
        // odd rows, four eights each, five bars a row).
        assert_eq!(tile.seam_ends.len(), 40, "{} groups", tile.seam_ends.len());
    }
    assert_eq!(seams_seen, 3 * (63 * 5 + 3));
}

#[test]
fn every_orientation_gives_each_particle_its_own_cell() {
    // 5 × 3 cloth: each of the four orientations maps the 15 particles to
    // 15 distinct internal cells within the internal size.
    let shape = crate::sim::mesh::GridShape { columns: 5, rows: 3 };
    for (transposed, flipped) in [(false, false), (false, true), (true, false), (true, true)] {
        let o = Orientation { shape, transposed, flipped };
        let (columns, rows) = o.size();
        let cells: std::collections::HashSet<_> = (0..15).map(|i| o.cell(i)).collect();
        assert_eq!(cells.len(), 15);
        assert!(cells.iter().all(|&(c, r)| c < columns && r < rows), "transposed {transposed}, flipped {flipped}");
    }
}

#[test]
fn a_push_moves_each_particle_by_its_weight_as_the_reference_does_and_rows_read_the_same_bits() {
    // The push runs tile by tile, each slot finding its particles'
    // displacements through `Tile::scene`; the reference adds w_i Δ_i in
    // scene order. Both must give the same bits for every particle, in
    // every orientation and across tiles and padding: a lane reading
    // another particle's Δ, or a pinned one moved, differs by millimetres.
    for (mesh, what) in shapes() {
        let start = jittered(mesh.positions(), 0.02);
        let mut weights = weights(&mesh);
        let half = weights.len() / 3;
        weights[half] = 0.5;
        let mut layout = GridLayout::new(&mesh, &start, &start, &weights, None).expect(what);
        let mut reference = ReferenceSolver::new(&start, &start, &weights, mesh.bars(), None);
        let delta: Vec<Vec3> = (0..start.len()).map(|i| Vec3::new(1.0, -2.0, 0.5) * (1e-3 * (i % 97) as f32)).collect();
        layout.push(&delta);
        reference.push(&delta);
        let (mut got, mut previous) = (start.clone(), start.clone());
        layout.read(&mut got, &mut previous);
        let differs = got
            .iter()
            .zip(&reference.positions)
            .position(|(a, b)| a.to_array().map(f32::to_bits) != b.to_array().map(f32::to_bits));
        assert_eq!(differs, None, "{what}: the first particle whose push differs from the reference's");
        let moved = |i: usize| got[i].distance(start[i]);
        // Positions within a few metres: each coordinate of x + ½Δ − x is
        // off by an ulp (≤ 5e-7 m); a weight of 1 would move it 7 mm.
        let expected = (delta[half] * 0.5).length();
        assert!((moved(half) - expected).abs() < 1e-6, "{what}: weight ½ moved {} for {expected}", moved(half));
        let pinned = mesh.fixed().iter().position(|&f| f);
        assert!(pinned.is_none_or(|i| moved(i) == 0.0), "{what}: a pinned particle moved");
        // The rows are the same values, with 0 in the fourth column.
        let (mut rows, mut previous_rows) = (vec![[f32::NAN; 4]; start.len()], vec![[f32::NAN; 4]; start.len()]);
        layout.read_rows(&mut rows, &mut previous_rows);
        let as_rows = |p: &[Vec3]| p.iter().map(|v| v.extend(0.0).to_array().map(f32::to_bits)).collect::<Vec<_>>();
        assert_eq!(rows.iter().map(|r| r.map(f32::to_bits)).collect::<Vec<_>>(), as_rows(&got), "{what}");
        let previous_bits = previous_rows.iter().map(|r| r.map(f32::to_bits)).collect::<Vec<_>>();
        assert_eq!(previous_bits, as_rows(&previous), "{what}");
    }
}

#[test]
fn weights_back_to_0_and_1_return_to_the_shares_at_the_next_relaxation() {
    // Every free particle's weight to ½ (unequal masses: the general form),
    // then back to 1 (as a density turned off does). The layout returns to
    // the share form, checked once at the next relaxation rather than at
    // each of the 580 writes (each check was a pass over every slot: 5.4 s
    // for the 256 × 256 cloth), and moves the cloth with the bits of a
    // layout that never left it.
    let mesh = Grid { columns: 20, rows: 30, spacing: 0.1, pins: Pins::TopRow, ..Grid::default() }.build().unwrap();
    let start = jittered(mesh.positions(), 0.02);
    let w = weights(&mesh);
    let mut never = GridLayout::new(&mesh, &start, &start, &w, None).unwrap();
    let mut back = never.clone();
    let free: Vec<usize> = (0..w.len()).filter(|&i| w[i] > 0.0).collect();
    for &i in &free {
        back.set_inverse_mass(i, 0.5);
    }
    assert!(!back.uniform);
    for &i in &free {
        back.set_inverse_mass(i, 1.0);
    }
    assert!(!back.uniform && back.reshare, "checked at the next relaxation, not at every write");
    step(&mut back, &substep(4));
    step(&mut never, &substep(4));
    assert!(back.uniform && !back.reshare);
    assert_eq!(bits(&back), bits(&never));
}

#[test]
fn the_operations_know_the_slots_they_name() {
    // Slots 3 and 9 (the second rotated), kind 2 in the top bits of `a`:
    // one past the largest slot named is 10, the kind and rotation bits
    // not counted (with them the "slot" would be above 2³⁰).
    let op = |a: u32, b: u32| Op { a, b, rest: 1.0 };
    let ops = Ops::new(vec![op(3 | (2 << KIND_SHIFT), 9 | ROTATED), op(0, 1)]);
    assert_eq!(ops.slots(), 10);
    assert_eq!(ops.len(), 2);
    assert_eq!(Ops::new(Vec::new()).slots(), 0);
    // Every tile of a built layout has the slots its operations name.
    for (mesh, what) in shapes() {
        let layout = GridLayout::new(&mesh, mesh.positions(), mesh.positions(), &weights(&mesh), None).expect(what);
        assert!(layout.ops.slots() > 0, "{what}");
        assert!(layout.tiles.iter().all(|t| t.position.len() >= layout.ops.slots()), "{what}");
    }
}

#[test]
#[should_panic(expected = "a tile's columns are shorter than its operations need")]
fn a_sweep_refuses_a_tile_shorter_than_its_operations() {
    // The sweeps index a tile's slots without a bounds check once they have
    // checked the tile against the operations: a tile cut short must stop
    // the sweep there, not be read past its end.
    let mesh = triangle_sheet(70, 12, DOWN);
    let layout = GridLayout::new(&mesh, mesh.positions(), mesh.positions(), &weights(&mesh), None).unwrap();
    // The weights' form (the shares' form would also need the shares).
    let sweep = sweep::Sweep {
        uniform: false,
        ops: &layout.ops,
        tolerance: 0.0,
        betas: [0.0; KINDS],
        omega: 1.0,
        compliant: false,
    };
    let mut tiles = layout.tiles.clone();
    // Whole, the tiles pass the check (so the panic below is the cut's).
    sweep::sweep_tiles(&mut tiles, &sweep, false);
    let short = tiles[0].position.len() - 1;
    tiles[0].position.truncate(short);
    sweep::sweep_tiles(&mut tiles, &sweep, false);
}

#[test]
fn scene_rows_are_read_out_of_the_lanes_with_the_bits_of_each_particle_looked_up() {
    // Grids whose scene rows are whole rows of slots (no padding, not
    // transposed) are read row by row, the lanes transposed into the
    // scene's order; the others particle by particle. Both must give every
    // particle the bits of its location's lanes, x and x − d, in either
    // form (points, rows). A lane written to the wrong place in its row,
    // or a flipped grid's rows taken in scene order, differs by
    // centimetres.
    let g = |columns, rows, pins| Grid { columns, rows, spacing: 0.1, pins, ..Grid::default() };
    let bottom = |columns: u32, rows: u32| Pins::Cells(vec![[0, rows - 1], [columns - 1, rows - 1]]);
    let cases = [
        (g(64, 5, Pins::TopRow), true, "64 columns, one tile of blocks of 8"),
        (g(48, 7, bottom(48, 7)), true, "48 columns pinned at the bottom: flipped, blocks of 6"),
        (g(128, 128, Pins::TopCorners), true, "128 × 128: tiles on the pool"),
        (g(50, 6, Pins::TopRow), false, "50 columns: padding in lane 7"),
        (g(20, 64, Pins::LeftColumn), false, "pinned along the left: transposed"),
    ];
    for (grid, rows_whole, what) in cases {
        let mesh = grid.build().expect(what);
        let start = jittered(mesh.positions(), 0.02);
        let previous = jittered(&start, 0.01);
        let layout = GridLayout::new(&mesh, &start, &previous, &weights(&mesh), None).expect(what);
        assert_eq!(!layout.scene_rows.is_empty(), rows_whole, "{what}: read row by row");
        let n = start.len();
        let bits = |p: &[Vec3]| p.iter().map(|v| v.to_array().map(f32::to_bits)).collect::<Vec<_>>();
        let (mut x, mut x_prev) = (vec![Vec3::NAN; n], vec![Vec3::NAN; n]);
        layout.read(&mut x, &mut x_prev);
        let (mut by_location, mut by_location_prev) = (vec![Vec3::ZERO; n], vec![Vec3::ZERO; n]);
        layout.read_by_location(&mut by_location, &mut by_location_prev, |p| p);
        assert_eq!(bits(&x), bits(&by_location), "{what}: x");
        assert_eq!(bits(&x_prev), bits(&by_location_prev), "{what}: x − d");
        let (mut rows, mut rows_prev) = (vec![[f32::NAN; 4]; n], vec![[f32::NAN; 4]; n]);
        layout.read_rows(&mut rows, &mut rows_prev);
        let row_bits = |p: &[Vec3]| p.iter().map(|v| v.extend(0.0).to_array().map(f32::to_bits)).collect::<Vec<_>>();
        assert_eq!(rows.iter().map(|r| r.map(f32::to_bits)).collect::<Vec<_>>(), row_bits(&by_location), "{what}");
        assert_eq!(rows_prev.iter().map(|r| r.map(f32::to_bits)).collect::<Vec<_>>(), row_bits(&by_location_prev));
        // And the lanes hold what was written: x within an ulp of the start
        // (reading it back is not a copy of the scene arrays by accident).
        assert!(x.iter().zip(&start).all(|(a, b)| a.distance(*b) < 1e-5), "{what}");
    }
}

#[test]
fn the_self_collide_rows_in_lane_order_are_each_particles_lanes_and_go_back_to_it() {
    // The self-collide phase reads x, x_pred − d and w in lane order (whole
    // slots transposed, slots with padding lane by lane) and writes x back.
    // Each row must hold the lanes of the particle `lane_rows` names, and
    // a row written must land on that particle: a lane transposed to the
    // wrong row, or a padded slot's rows miscounted, moves particles by
    // centimetres.
    let g = |columns, rows, pins| Grid { columns, rows, spacing: 0.1, pins, ..Grid::default() };
    let cases = [
        (g(64, 5, Pins::TopRow), "64 columns: every slot whole"),
        (g(50, 6, Pins::TopRow), "50 columns: padding in lane 7"),
        (g(20, 64, Pins::LeftColumn), "pinned along the left: transposed, padded"),
        (g(130, 130, Pins::TopCorners), "130 × 130: tiles on the pool"),
    ];
    for (grid, what) in cases {
        let mesh = grid.build().expect(what);
        let start = jittered(mesh.positions(), 0.02);
        let previous = jittered(&start, 0.01);
        let mut layout = GridLayout::new(&mesh, &start, &previous, &weights(&mesh), None).expect(what);
        let n = start.len();
        // Predictions apart from the positions, so x0 is not x − d.
        for tile in &mut layout.tiles {
            for (q, p) in tile.predicted.iter_mut().zip(&tile.position) {
                *q = [p[0] + F32x8::splat(0.25), p[1], p[2] - F32x8::splat(0.5)];
            }
        }
        let mut rows = layout.lane_rows().to_vec();
        rows.sort_unstable();
        assert_eq!(rows, (0..n as u32).collect::<Vec<_>>(), "{what}: every particle once");
        let (mut x, mut x0, mut w) = (vec![Vec3::NAN; n], vec![Vec3::NAN; n], vec![f32::NAN; n]);
        layout.read_starts(&mut x, &mut x0, &mut w, n > 10_000);
        let bits = |v: Vec3| v.to_array().map(f32::to_bits);
        for (k, &i) in layout.lane_rows().iter().enumerate() {
            let loc = layout.locations[i as usize];
            let tile = &layout.tiles[loc.tile as usize];
            let (s, l) = (loc.slot as usize, loc.lane as usize);
            assert_eq!(
                bits(x[k]),
                bits(crate::sim::fast::kernel::lane(&tile.position[s], l)),
                "{what}: row {k}, particle {i}"
            );
            let lane = crate::sim::fast::kernel::lane;
            let x0_i = lane(&tile.predicted[s], l) - lane(&tile.displacement[s], l);
            assert_eq!(bits(x0[k]), bits(x0_i), "{what}: row {k}");
            assert_eq!(w[k].to_bits(), tile.weight[s].0[l].to_bits(), "{what}: row {k}");
        }
        // Each row moved by its own amount, written back, read in scene order.
        let moved: Vec<Vec3> = x.iter().enumerate().map(|(k, p)| *p + Vec3::new(k as f32 * 1e-3, 1.0, 0.0)).collect();
        layout.write_positions(&moved, n > 10_000);
        let (mut now, mut before) = (vec![Vec3::NAN; n], vec![Vec3::NAN; n]);
        layout.read(&mut now, &mut before);
        for (k, &i) in layout.lane_rows().iter().enumerate() {
            assert_eq!(bits(now[i as usize]), bits(moved[k]), "{what}: row {k} back to particle {i}");
        }
    }
}

#[test]
fn the_air_on_the_lanes_moves_each_particle_as_in_scene_order() {
    // 90 × 12: two tiles of eight lanes of 6 columns, 6 columns of padding.
    // 130 × 130: large enough for the thread pool (tiles in parallel).
    for (columns, rows) in [(90, 12), (130, 130)] {
        air_on_lanes_against_rows(columns, rows);
    }
}

fn air_on_lanes_against_rows(columns: u32, rows: u32) {
    use crate::sim::aero::{AeroStep, Aerodynamics};
    use crate::sim::step::Lanes;
    use crate::sim::wind::Air;
    // A grid hung by its top row. Positions and displacements are
    // multiples of 1/8192 m, so x − (x − d) is d exactly: the scene-order
    // form (rows, through the reference solver) and the lanes form (the
    // grid's tiles) see the same velocities and compute each triangle's
    // force with the same bits. They differ only in the order each
    // particle's ≤ 6 thirds are summed, a few ulp of the sum: 1e-5 of the
    // largest displacement, plus 2 ulp of a position for the push's own
    // rounding, bounds it; a triangle missed or counted twice moves a
    // particle by a sixth of its push or more.
    let mesh =
        Grid { columns, rows, spacing: 1.0 / 64.0, pins: Pins::TopRow, ..Grid::default() }.build().expect("valid grid");
    let n = mesh.particle_count();
    let x: Vec<Vec3> = mesh
        .positions()
        .iter()
        .enumerate()
        .map(|(i, p)| *p + Vec3::new(0.0, 0.0, ((i * 37) % 64) as f32 / 1024.0))
        .collect();
    let d = |i: usize| Vec3::new((i % 7) as f32, -((i % 5) as f32), (i % 3) as f32) / 8192.0;
    let previous: Vec<Vec3> = x.iter().enumerate().map(|(i, p)| *p - d(i)).collect();
    let w = weights(&mesh);
    let mut reference = ReferenceSolver::new(&x, &previous, &w, mesh.bars(), None);
    let mut layout = GridLayout::new(&mesh, &x, &previous, &w, None).expect("a grid");
    let masses = vec![0.001; n];
    let mut scene = Aerodynamics::new(&mesh, &masses, None);
    let mut lanes = Aerodynamics::new(&mesh, &masses, Some(&layout.places()));
    assert!(!scene.in_lanes() && lanes.in_lanes());
    assert!(lanes.aligned_share() > 0.7, "{} {}", lanes.aligned_share(), layout.describe());
    let air = Air { velocity: Vec3::new(5.0, 1.0, 3.0), gusts: 0.3, lift: 0.3, ..Air::default() };
    let step = AeroStep { air, time: 0.4, dt: 0.01, displacement_per_newton: 0.01 * 0.01 / 0.001, parallel: true };
    scene.compute(&reference, &step);
    scene.push(&mut reference);
    lanes.compute(&layout, &step);
    lanes.push(&mut layout);
    let read = |solver: &dyn Solver| {
        let (mut p, mut q) = (vec![Vec3::ZERO; n], vec![Vec3::ZERO; n]);
        solver.read(&mut p, &mut q);
        p
    };
    let (by_rows, by_lanes) = (read(&reference), read(&layout));
    let largest = by_rows.iter().zip(&x).map(|(p, x)| (*p - *x).length()).fold(0.0, f32::max);
    assert!(largest > 1e-4, "the air moved the cloth by {largest} m at most");
    for i in 0..n {
        let tolerance = 1e-5 * largest + 2.0 * f32::EPSILON * x[i].abs().max_element();
        let gap = (by_rows[i] - by_lanes[i]).abs().max_element();
        assert!(gap <= tolerance, "particle {i}: {} by rows, {} by lanes", by_rows[i], by_lanes[i]);
        if mesh.fixed()[i] {
            assert_eq!(by_lanes[i], x[i], "a pinned particle stays");
        }
    }
}
