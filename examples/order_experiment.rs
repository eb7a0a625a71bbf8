// Temporary experiment: how relaxation order affects strain on the seed scene.
use drape::sim::reference::ReferenceSolver;
use drape::sim::{Bar, Simulation, SolverKind};

fn run(order: &[Bar], name: &str) {
    let scene = drape::scene::load("seed").unwrap();
    let sim = Simulation::with_solver(scene.mesh.clone(), scene.params.clone(), SolverKind::Reference).unwrap();
    let mut s = ReferenceSolver {
        positions: sim.positions().to_vec(),
        previous: sim.positions().to_vec(),
        inverse_mass: sim.fixed().iter().map(|&f| if f { 0.0 } else { 5.0 }).collect(),
        bars: order.to_vec(),
    };
    let p = &scene.params;
    let mut maxs = 0.0f32;
    let mut rmss = 0.0f32;
    let n = 2000;
    for k in 0..n {
        let t = k as f64 * p.dt as f64;
        let f = p.gravity + p.wind.force(t);
        let first = if k == 0 { Some(scene.mesh.velocities()) } else { None };
        s.step(p.dt, p.damping, p.displacement_of(f), first, p.relaxations, 0.0);
        if k >= n / 2 {
            let st = drape::sim::metrics::strain(&s.positions, &s.bars);
            maxs = maxs.max(st.max);
            rmss += st.rms / (n / 2) as f32;
        }
    }
    println!("{name:40} max strain over 2nd half {maxs:.4}  mean rms {rmss:.4}");
}

fn main() {
    let scene = drape::scene::load("seed").unwrap();
    let sim = Simulation::with_solver(scene.mesh.clone(), scene.params.clone(), SolverKind::Reference).unwrap();
    let bars = sim.bars().to_vec();
    let cols = 20u32;
    let cr = |i: u32| (i % cols, i / cols);
    let class = |b: &Bar| {
        let (ca, ra) = cr(b.a);
        let (cb, rb) = cr(b.b);
        (cb as i32 - ca as i32, rb as i32 - ra as i32)
    };
    run(&bars, "creation order");
    let mut rev = bars.clone();
    rev.reverse();
    run(&rev, "reverse creation order");
    let classes = [(1, 0), (0, 1), (1, 1), (-1, 1), (2, 0), (0, 2)];
    // class-major, rows top-down, H/BH coloured within a row
    let mut o = Vec::new();
    for cl in classes {
        let mut v: Vec<Bar> = bars.iter().filter(|b| class(b) == cl).copied().collect();
        v.sort_by_key(|b| {
            let (c, r) = cr(b.a);
            let colour = if cl.1 == 0 { (c % (2 * cl.0 as u32)) / cl.0 as u32 } else { 0 };
            (colour, r, c)
        });
        o.extend(v);
    }
    run(&o, "class-major, top-down rows");
    // class-major, rows coloured (even/odd), bands of 4 rows as lanes
    let mut o = Vec::new();
    let hb = 4u32;
    for cl in classes {
        let mut v: Vec<Bar> = bars.iter().filter(|b| class(b) == cl).copied().collect();
        v.sort_by_key(|b| {
            let (c, r) = cr(b.a);
            let rho = r % hb;
            let cross = (rho + cl.1 as u32) >= hb;
            let colour =
                if cl.1 == 0 { (c % (2 * cl.0 as u32)) / cl.0 as u32 } else { (rho % (2 * cl.1 as u32)) / cl.1 as u32 };
            (cross, colour, rho, c, r / hb)
        });
        o.extend(v);
    }
    run(&o, "row-band lanes (current)");
    // column-block lanes: slots by row top-down; cross-block bars after each class
    let wb = 3u32;
    let mut o = Vec::new();
    for cl in classes {
        let mut v: Vec<Bar> = bars.iter().filter(|b| class(b) == cl).copied().collect();
        v.sort_by_key(|b| {
            let (ca, r) = cr(b.a);
            let (cb, _) = cr(b.b);
            let cross = ca / wb != cb / wb;
            let k = ca % wb;
            let colour = if cl.1 == 0 { (k % (2 * cl.0 as u32)) / cl.0 as u32 } else { 0 };
            (cross, colour, r, k, ca / wb)
        });
        o.extend(v);
    }
    run(&o, "column-block lanes, rows top-down");

    // column-block lanes, row-major: for each row, each class, each k, each lane
    let mut o = Vec::new();
    for r in 0..30u32 {
        for cl in classes {
            for k in 0..wb {
                for lane in 0..8u32 {
                    let c = lane * wb + k;
                    if let Some(b) = bars.iter().find(|b| class(b) == cl && cr(b.a) == (c, r)) {
                        o.push(*b);
                    }
                }
            }
        }
    }
    assert_eq!(o.len(), bars.len());
    run(&o, "column-block lanes, row-major classes");
    // same, but bars crossing blocks deferred to the end of each row
    let mut o2 = Vec::new();
    for r in 0..30u32 {
        let row: Vec<Bar> = o.iter().filter(|b| cr(b.a).1 == r).copied().collect();
        let (inb, cross): (Vec<Bar>, Vec<Bar>) = row.iter().partition(|b| cr(b.a).0 / wb == cr(b.b).0 / wb);
        o2.extend(inb);
        o2.extend(cross);
    }
    run(&o2, "column-block lanes, row-major, cross last");
}
