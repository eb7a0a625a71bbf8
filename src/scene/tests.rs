use super::*;
use crate::sim::{BarKind, Wind};
use glam::Vec3;

#[test]
fn every_bundled_scene_loads() {
    for b in BUNDLED {
        let scene = load(b.name).unwrap_or_else(|e| panic!("{e}"));
        assert!(!scene.description.is_empty(), "{} has no description", b.name);
        scene.simulation().unwrap_or_else(|e| panic!("{}: {e}", b.name));
    }
}

#[test]
fn seed_scene_is_the_reports_experiment() {
    let s = load("seed").unwrap();
    assert_eq!((s.params.relaxations, s.params.damping, s.params.dt, s.params.mass), (20, 0.02, 0.05, 0.2));
    assert_eq!(s.params.wind, Wind::Seed { scale: 1.0 });
    assert_eq!(s.mesh.particle_count(), 600);
    let grid = s.mesh.grid().unwrap();
    assert_eq!((grid.columns, grid.rows), (20, 30));
    assert_eq!(s.mesh.fixed().iter().filter(|&&f| f).count(), 20);
}

#[test]
fn obj_scene_has_bend_bars_and_pins() {
    let s = load("tablecloth").unwrap();
    assert_eq!(s.mesh.particle_count(), 1801);
    assert_eq!(s.mesh.triangles().len(), 3456);
    assert!(s.mesh.bars().iter().any(|b| b.kind == BarKind::Bend));
    assert_eq!(s.mesh.fixed().iter().filter(|&&f| f).count(), 217);
}

fn err(text: &str) -> String {
    parse(text, &Origin::Text).expect_err("should fail").to_string()
}

const GRID: &str = "[grid]\ncolumns = 3\nrows = 3\nspacing = 1.0\n";

#[test]
fn minimal_grid_scene_uses_seed_defaults() {
    let s = parse(GRID, &Origin::Text).unwrap();
    assert_eq!(s.params, crate::sim::SolverParams::default());
    assert_eq!(s.mesh.particle_count(), 9);
}

#[test]
fn errors_name_the_key_and_the_allowed_range() {
    let e = err(&format!("[solver]\ndt = -1.0\n{GRID}"));
    assert!(e.contains("solver.dt") && e.contains("1e-6 <= dt <= 1"), "{e}");
    let e = err(&format!("[solver]\ndamping = 1.0\n{GRID}"));
    assert!(e.contains("solver.damping") && e.contains("0 <= damping < 1"), "{e}");
    let e = err(&format!("[solver]\nmass = 0.0\n{GRID}"));
    assert!(e.contains("solver.mass"), "{e}");
    let e = err(&format!("[solver]\nrelaxation = 3\n{GRID}"));
    assert!(e.contains("unknown field") && e.contains("line 2"), "{e}");
    let e = err(&format!("[solver]\ndt = nan\n{GRID}"));
    assert!(e.contains("solver.dt"), "{e}");
    let e = err(&format!("[wind]\nmodel = \"constant\"\n{GRID}"));
    assert!(e.contains("wind.vector"), "{e}");
    let e = err(&format!("[wind]\nmodel = \"seed\"\nscale = inf\n{GRID}"));
    assert!(e.contains("wind.scale"), "{e}");
    let e = err("[solver]\ndt = 0.1\n");
    assert!(e.contains("exactly one"), "{e}");
    let e = err(&format!("{GRID}[obj]\npath = \"x.obj\"\n"));
    assert!(e.contains("exactly one"), "{e}");
    let e = err("[grid]\ncolumns = 0\nrows = 3\nspacing = 1.0\n");
    assert!(e.contains("[grid]") && e.contains("at least 1"), "{e}");
    let e = err("[grid]\ncolumns = 100000\nrows = 100000\nspacing = 1.0\n");
    assert!(e.contains("too many"), "{e}");
    let e = err("[grid]\ncolumns = 3\nrows = 3\nspacing = 1.0\npinned = \"top\"\n");
    assert!(e.contains("grid.pinned"), "{e}");
    let e = err("[grid]\ncolumns = 3\nrows = 3\nspacing = 1.0\npinned = [[3, 0]]\n");
    assert!(e.contains("outside the grid"), "{e}");
    // A flat list of indices (as [mesh] `fixed` and [obj] `pinned` take) is
    // neither form: the message names both instead of serde's "did not match
    // any variant of untagged enum PinsValue".
    let e = err("[grid]\ncolumns = 3\nrows = 3\nspacing = 1.0\npinned = [1]\n");
    assert!(e.contains("a pin pattern") && e.contains("[column, row] pairs") && !e.contains("untagged"), "{e}");
    let e = err(&format!("[solver]\ninextensible = true\nnewton_iterations = 0\n{GRID}"));
    assert!(e.contains("solver.newton_iterations") && e.contains("from 1 to 100"), "{e}");
    let e = err(&format!("[solver]\nnewton_tolerance = 0.0\n{GRID}"));
    assert!(e.contains("solver.newton_tolerance") && e.contains("0 < newton_tolerance < 1"), "{e}");
    let e = err(&format!("[solver]\nnewton_smoothing = 5000\n{GRID}"));
    assert!(e.contains("solver.newton_smoothing"), "{e}");
    let e = err(&format!("[solver]\ncoarse_passes = 101\n{GRID}"));
    assert!(e.contains("solver.coarse_passes") && e.contains("from 0 to 100"), "{e}");
    let e =
        err("[solver]\ncoarse_passes = 2\n[mesh]\npositions = [[0.0,0.0,0.0],[1.0,0.0,0.0]]\nadjacency = [[1],[]]\n");
    assert!(e.contains("solver.coarse_passes") && e.contains("needs a [grid]"), "{e}");
    let e = err(&format!("[solver]\ninextensible = \"yes\"\n{GRID}"));
    assert!(e.contains("inextensible"), "{e}");
}

#[test]
fn mesh_table_errors() {
    let mesh = |body: &str| err(&format!("[mesh]\n{body}\n"));
    let e = mesh("positions = [[0.0,0.0,0.0],[1.0,0.0,0.0]]\nadjacency = [[2],[]]");
    assert!(e.contains("[mesh]") && e.contains("particle 2") && e.contains("0 to 1"), "{e}");
    let e = mesh("positions = [[0.0,0.0,0.0],[1.0,0.0,0.0]]\nadjacency = [[0],[]]");
    assert!(e.contains("itself"), "{e}");
    let e = mesh("positions = [[0.0,0.0,0.0],[0.0,0.0,0.0]]\nadjacency = [[1],[]]");
    assert!(e.contains("0.000e0 m long") && e.contains("at least 1.000e-6 m"), "{e}");
    let e = mesh("positions = [[0.0,0.0,0.0],[1.0,0.0,0.0]]\nadjacency = [[1, 1],[]]");
    assert!(e.contains("twice"), "{e}");
    let e = mesh("positions = []\nadjacency = []");
    assert!(e.contains("no particles"), "{e}");
    let e = mesh("positions = [[0.0,nan,0.0]]\nadjacency = [[]]");
    assert!(e.contains("finite"), "{e}");
    let e = mesh("positions = [[0.0,0.0,0.0]]\nadjacency = [[-1]]");
    assert!(e.contains("line"), "{e}");
}

#[test]
fn obj_errors() {
    let e = err("[obj]\npath = \"/definitely/not/here.obj\"\n");
    assert!(e.contains("[obj] path /definitely/not/here.obj"), "{e}");
    let e = parse("[obj]\npath = \"../meshes/nothing.obj\"\n", &Origin::Bundled("x")).unwrap_err().to_string();
    assert!(e.contains("not a bundled mesh"), "{e}");
}

#[test]
fn obj_text_parses_faces_as_triangles() {
    let (p, t) = obj::parse_obj("v 0 0 0\nv 1 0 0\nv 1 1 0\nv 0 1 0\nf 1 2 3 4\n").unwrap();
    assert_eq!(p.len(), 4);
    assert_eq!(t.len(), 2);
    assert!(obj::parse_obj("# nothing\n").is_err());
    // An OBJ file that cannot be read names the scene's [obj] table.
    let e = err("[obj]\npath = \"x\"\n");
    assert!(e.contains("[obj]"), "{e}");
    // A face naming vertices that do not exist is an error that says so.
    let bad = obj::parse_obj("v 0 0 0\nf 1 2 3\n").unwrap_err();
    assert!(bad.contains("the file has 1"), "{bad}");
    assert!(obj::parse_obj("v 0 0 0\nv 1 0 0\nv 0 1 0\nf 0 1 2\n").unwrap_err().contains("counts from 1"));
    assert!(obj::parse_obj("v 0 zero 0\n").unwrap_err().contains("line 1: 'zero'"));
}

#[test]
fn obj_vertices_keep_the_files_numbering() {
    // The faces use vertex 4 first and vertex 1 last; two objects share
    // vertex 3; negative indices count back from the last vertex read; `v/t/n`
    // forms name the vertex first. A loader numbering vertices by first use
    // per object (as tobj does) would give [3, 4, 2] for the first face and
    // split vertex 3 in two.
    let text = "v 0 0 0\nv 1 0 0\nv 0 1 0\nv 1 1 0\nvt 0 0\nvn 0 0 1\n\
                o a\nf 4/1/1 3//1 2\no b\nf -2 -1 1\n";
    let (p, t) = obj::parse_obj(text).unwrap();
    assert_eq!(p, vec![Vec3::ZERO, Vec3::X, Vec3::Y, Vec3::new(1.0, 1.0, 0.0)]);
    assert_eq!(t, vec![[3, 2, 1], [2, 3, 0]]);
}

#[test]
fn unknown_scene_lists_the_bundled_ones() {
    let e = load("no-such-scene").unwrap_err().to_string();
    assert!(e.contains("seed") && e.contains("flag"), "{e}");
}

#[test]
fn colliders_are_read_with_their_shapes_motions_and_frictions() {
    let text = format!(
        "{GRID}[solver]\nthickness = 0.02\nfriction = 0.4\n\
         [[collider]]\nshape = \"plane\"\nnormal = [0.0, 2.0, 0.0]\n\
         [[collider]]\nshape = \"capsule\"\nstart = [-1.0, 1.0, 0.0]\nend = [1.0, 1.0, 0.0]\nradius = 0.05\nfriction = 0.9\n\
         [[collider]]\nshape = \"box\"\ncenter = [0.0, 0.5, 0.0]\nhalf_extents = [0.5, 0.1, 0.5]\nrotation = [0.0, 30.0, 0.0]\nvelocity = [0.2, 0.0, 0.0]\n\
         [[collider]]\nshape = \"sphere\"\ncenter = [0.0, 2.0, 0.0]\nradius = 0.3\nloop = true\n\
         [[collider.keyframes]]\ntime = 0.0\n[[collider.keyframes]]\ntime = 2.0\ncenter = [0.0, 1.0, 0.0]\n"
    );
    let s = parse(&text, &Origin::Text).unwrap();
    assert_eq!((s.params.thickness, s.params.friction), (0.02, 0.4));
    assert_eq!(s.colliders.len(), 4);
    // The normal is normalised; the capsule's pose sits at its midpoint.
    assert!(matches!(s.colliders[0].shape, crate::sim::Shape::Plane { normal } if normal == glam::Vec3::Y));
    assert_eq!(s.colliders[1].pose.translation, glam::Vec3::new(0.0, 1.0, 0.0));
    assert_eq!(s.colliders[1].friction, Some(0.9));
    // The box moves at 0.2 m/s: 0.2 m along x after 1 s.
    assert!((s.colliders[2].pose_at(1.0).translation.x - 0.2).abs() < 1e-6);
    // The sphere is keyframed: half way down after 1 s, and again after 3 s (looped).
    for t in [1.0, 3.0] {
        assert!((s.colliders[3].pose_at(t).translation.y - 1.5).abs() < 1e-6, "t = {t}");
    }
    let sim = s.simulation().unwrap();
    assert_eq!(sim.colliders().len(), 4);
}

#[test]
fn bad_colliders_name_the_collider_and_the_key() {
    let cases = [
        ("[[collider]]\nshape = \"sphere\"\ncenter = [0.0, 0.0, 0.0]\n", "collider[0].radius"),
        (
            "[[collider]]\nshape = \"box\"\ncenter = [0.0, 0.0, 0.0]\nhalf_extents = [1.0, 0.0, 1.0]\n",
            "collider[0].half_extents",
        ),
        (
            "[[collider]]\nshape = \"sphere\"\ncenter = [0.0, 0.0, 0.0]\nradius = 1.0\nvelocity = [1.0, 0.0, 0.0]\n[[collider.keyframes]]\ntime = 0.0\n",
            "collider[0].keyframes",
        ),
        (
            "[[collider]]\nshape = \"plane\"\n[[collider]]\nshape = \"sphere\"\ncenter = [0.0, 0.0, 0.0]\nradius = 1.0\n[[collider.keyframes]]\ntime = 1.0\n[[collider.keyframes]]\ntime = 0.5\n",
            "collider[1].keyframes[1].time",
        ),
        (
            "[[collider]]\nshape = \"capsule\"\nstart = [0.0, 0.0, 0.0]\nend = [1.0, 0.0, 0.0]\nradius = inf\n",
            "collider[0].radius",
        ),
        ("[[collider]]\nshape = \"mesh\"\n", "collider[0].path"),
        ("[[collider]]\nshape = \"plane\"\nloop = true\n", "collider[0].loop"),
    ];
    for (collider, key) in cases {
        let e = err(&format!("{GRID}{collider}"));
        assert!(e.contains(key), "{key} not in: {e}");
    }
}
