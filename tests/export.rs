//! `drape run --export`: the files read back by other programs' readers
//! (the `gltf` crate for .glb, `tobj` for OBJ) hold the run's frames.
//!
//! Each test runs the seed's scene for 23 steps with a frame every 10, so
//! the frames are steps 0, 10, 20 and 23 (the last step is always
//! exported), at t = 0, 0.5, 1.0 and 1.15 s.

use std::path::{Path, PathBuf};
use std::process::{Command, Output};

fn drape(args: &[&str]) -> Output {
    Command::new(env!("CARGO_BIN_EXE_drape")).args(args).output().expect("the drape binary runs")
}

fn scratch(name: &str) -> PathBuf {
    let dir = PathBuf::from(env!("CARGO_TARGET_TMPDIR")).join(name);
    let _ = std::fs::remove_dir_all(&dir);
    std::fs::create_dir_all(&dir).unwrap();
    dir
}

fn path(p: &Path) -> &str {
    p.to_str().unwrap()
}

/// Runs the seed's scene for 23 steps at 5 relaxations, exporting every 10
/// steps to `export` and writing the end state to `out`.
fn run_seed(export: &Path, out: &Path) {
    let o = drape(&[
        "run",
        "--steps",
        "23",
        "--relaxations",
        "5",
        "--every",
        "10",
        "--export",
        path(export),
        "--out",
        path(out),
        "-q",
    ]);
    let stderr = String::from_utf8_lossy(&o.stderr);
    assert!(o.status.success(), "{stderr}");
    assert!(String::from_utf8_lossy(&o.stdout).contains("exported 4 frames"));
}

/// `--out`'s positions.
fn state_positions(out: &Path) -> Vec<[f32; 3]> {
    let state: serde_json::Value = serde_json::from_str(&std::fs::read_to_string(out).unwrap()).unwrap();
    state["positions"]
        .as_array()
        .unwrap()
        .iter()
        .map(|p| {
            let v: Vec<f32> = p.as_array().unwrap().iter().map(|x| x.as_f64().unwrap() as f32).collect();
            [v[0], v[1], v[2]]
        })
        .collect()
}

/// The seed's scene stepped by the library to `steps`, for comparison.
fn library_positions(steps: u64) -> Vec<glam::Vec3> {
    let scene = drape::scene::load("seed").unwrap();
    let params = drape::sim::SolverParams { relaxations: 5, ..scene.params.clone() };
    let mut sim = drape::sim::Simulation::with_solver((*scene.mesh).clone(), params, scene.solver).unwrap();
    sim.advance(steps).unwrap();
    sim.positions().to_vec()
}

#[test]
fn glb_holds_the_mesh_and_every_frame() {
    let dir = scratch("export_glb");
    let (glb, out) = (dir.join("nested/cloth.glb"), dir.join("state.json"));
    run_seed(&glb, &out);
    let bytes = std::fs::read(&glb).unwrap();
    // Parsing validates the document (indices in range, accessor types).
    let gltf = gltf::Gltf::from_slice(&bytes).expect("a valid glTF 2.0 binary");
    let blob = gltf.blob.clone().expect("a binary chunk");
    let buffers = |_: gltf::Buffer| Some(&blob[..]);

    let mesh = gltf.meshes().next().expect("one mesh");
    let primitive = mesh.primitives().next().expect("one primitive");
    let reader = primitive.reader(buffers);
    let base: Vec<[f32; 3]> = reader.read_positions().unwrap().collect();
    let normals: Vec<[f32; 3]> = reader.read_normals().unwrap().collect();
    let uvs: Vec<[f32; 2]> = reader.read_tex_coords(0).unwrap().into_f32().collect();
    let indices: Vec<u32> = reader.read_indices().unwrap().into_u32().collect();
    // The seed's 20 × 30 grid: 600 vertices, 2 triangles per cell of 19 × 29.
    assert_eq!((base.len(), normals.len(), uvs.len()), (600, 600, 600));
    assert_eq!(indices.len(), 3 * 2 * 19 * 29);
    assert_eq!((uvs[0], uvs[599]), ([0.0, 0.0], [1.0, 1.0]));

    let targets: Vec<Vec<[f32; 3]>> = reader.read_morph_targets().map(|(p, _, _)| p.unwrap().collect()).collect();
    assert_eq!(targets.len(), 4, "one morph target per exported frame");
    let frame = |k: usize| -> Vec<glam::Vec3> {
        base.iter().zip(&targets[k]).map(|(b, d)| glam::Vec3::from(*b) + glam::Vec3::from(*d)).collect()
    };
    // Base + Δ_k rounds twice in f32: within 2 ulp of 16 m, 4e-6 m.
    let close = |a: &[glam::Vec3], b: &[glam::Vec3], what: &str| {
        let worst = a.iter().zip(b).map(|(a, b)| a.distance(*b)).fold(0.0, f32::max);
        assert!(worst < 4e-6, "{what}: {worst} m apart");
    };
    let last: Vec<glam::Vec3> = state_positions(&out).into_iter().map(glam::Vec3::from).collect();
    close(&frame(3), &last, "last frame against --out");
    close(&frame(1), &library_positions(10), "frame 1 against step 10");
    // Frame 0 is the base itself: the pinned top row has not moved.
    assert!(targets[0].iter().all(|d| *d == [0.0; 3]));

    let animation = gltf.animations().next().expect("an animation");
    let channel = animation.channels().next().unwrap();
    assert_eq!(channel.target().property(), gltf::animation::Property::MorphTargetWeights);
    let reader = channel.reader(buffers);
    let times: Vec<f32> = reader.read_inputs().unwrap().collect();
    let expected = [0.0, 0.5, 1.0, 1.15];
    assert!(times.iter().zip(expected).all(|(t, e)| (t - e).abs() < 1e-5), "{times:?}");
    let Some(gltf::animation::util::ReadOutputs::MorphTargetWeights(weights)) = reader.read_outputs() else {
        panic!("the animation keys the morph weights")
    };
    let weights: Vec<f32> = weights.into_f32().collect();
    // At key k the weights are e_k: the surface is exactly frame k.
    assert_eq!(weights.len(), 16);
    for k in 0..4 {
        for j in 0..4 {
            assert_eq!(weights[4 * k + j], if j == k { 1.0 } else { 0.0 });
        }
    }
}

#[test]
fn obj_sequence_writes_one_file_per_frame() {
    let dir = scratch("export_obj");
    let out = dir.join("state.json");
    run_seed(&dir.join("frames/cloth_{frame}.obj"), &out);
    let mut names: Vec<String> = std::fs::read_dir(dir.join("frames"))
        .unwrap()
        .map(|e| e.unwrap().file_name().to_string_lossy().into_owned())
        .collect();
    names.sort();
    assert_eq!(names, ["cloth_0000.obj", "cloth_0001.obj", "cloth_0002.obj", "cloth_0003.obj"]);
    let scene = drape::scene::load("seed").unwrap();
    let triangles: Vec<usize> = scene.mesh.triangles().iter().flatten().map(|&i| i as usize).collect();
    let read = |name: &str| -> (tobj::Mesh, Vec<[f32; 3]>) {
        let file = dir.join("frames").join(name);
        let (models, _) = tobj::load_obj(&file, &tobj::LoadOptions::default()).unwrap();
        assert_eq!(models.len(), 1);
        // tobj numbers vertices in the order faces first use them, so the
        // scene order is read from the `v` lines themselves.
        let vertices = std::fs::read_to_string(&file)
            .unwrap()
            .lines()
            .filter_map(|l| l.strip_prefix("v "))
            .map(|l| {
                let v: Vec<f32> = l.split(' ').map(|x| x.parse().unwrap()).collect();
                [v[0], v[1], v[2]]
            })
            .collect();
        (models.into_iter().next().unwrap().mesh, vertices)
    };
    // Every face corner of tobj's mesh is the scene's particle at that corner.
    let faces_match = |mesh: &tobj::Mesh, positions: &[[f32; 3]]| {
        assert_eq!(mesh.indices.len(), triangles.len());
        for (&k, &i) in mesh.indices.iter().zip(&triangles) {
            let k = k as usize;
            assert_eq!(mesh.positions[3 * k..3 * k + 3], positions[i], "corner of particle {i}");
        }
    };
    let (last, vertices) = read("cloth_0003.obj");
    assert_eq!((vertices.len(), last.positions.len()), (600, 3 * 600));
    assert_eq!(last.indices.len(), 3 * 2 * 19 * 29);
    assert_eq!((last.normals.len(), last.texcoords.len()), (3 * 600, 2 * 600));
    // Vertices in scene order, written as the shortest decimal of each f32:
    // bit for bit the positions `--out` holds.
    let state = state_positions(&out);
    assert_eq!(vertices, state);
    faces_match(&last, &state);
    let (first, vertices) = read("cloth_0001.obj");
    let step10: Vec<[f32; 3]> = library_positions(10).iter().map(|p| p.to_array()).collect();
    assert_eq!(vertices, step10);
    faces_match(&first, &step10);
}

#[test]
fn a_mesh_without_triangles_exports_lines_and_refuses_gltf() {
    let dir = scratch("export_chain");
    // The chain is an adjacency list: 21 particles, 20 bars.
    let glb = dir.join("chain.glb");
    let o = drape(&["run", "--scene", "chain", "--steps", "5", "--export", path(&glb)]);
    let stderr = String::from_utf8_lossy(&o.stderr);
    assert_eq!(o.status.code(), Some(2), "{stderr}");
    assert!(stderr.contains("no triangles") && stderr.contains("{frame}"), "{stderr}");
    assert!(!glb.exists(), "refused before writing anything");

    let pattern = dir.join("chain_{frame}.obj");
    let o = drape(&["run", "--scene", "chain", "--steps", "5", "--every", "5", "--export", path(&pattern), "-q"]);
    assert!(o.status.success(), "{}", String::from_utf8_lossy(&o.stderr));
    let text = std::fs::read_to_string(dir.join("chain_0001.obj")).unwrap();
    assert_eq!(text.lines().filter(|l| l.starts_with("v ")).count(), 21);
    assert_eq!(text.lines().filter(|l| l.starts_with("l ")).count(), 20);
    assert_eq!(text.lines().filter(|l| l.starts_with("f ")).count(), 0);
    assert!(!dir.join("chain_0002.obj").exists(), "steps 0 and 5 only");
}
