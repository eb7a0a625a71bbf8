//! Loading a scene file and exporting its motion: what `drape run --export`
//! does, in a dozen lines of library calls.
//!
//! ```text
//! cargo run --release --example scene_to_gltf -- [SCENE] [STEPS] [OUT.glb]
//! ```
//!
//! SCENE is a bundled scene's name (`drape scenes` lists them) or a TOML
//! file; default `drape-sphere`, 240 steps, `drape-sphere.glb`. Every 4th
//! step becomes a frame of the glTF animation; the same frames also go to
//! one OBJ each beside it (`drape-sphere_frames/0000.obj`, …).

use std::path::PathBuf;

use drape::export::Exporter;

fn main() -> Result<(), Box<dyn std::error::Error>> {
    let mut args = std::env::args().skip(1);
    let name = args.next().unwrap_or_else(|| "drape-sphere".to_string());
    let steps: u64 = match args.next() {
        Some(s) => s.parse().map_err(|e| format!("STEPS must be a whole number, not '{s}': {e}"))?,
        None => 240,
    };
    let out = PathBuf::from(args.next().unwrap_or_else(|| format!("{name}.glb")));
    let every = 4;

    let scene = drape::scene::load(&name)?;
    let mut sim = scene.simulation()?;
    let frames = drape::headless::frame_count(steps, every) as usize;
    let mut glb = Exporter::new(&out, sim.mesh().clone(), frames)?;
    let pattern = out.with_extension("").display().to_string() + "_frames/{frame}.obj";
    let mut obj = Exporter::new(pattern.as_ref(), sim.mesh().clone(), frames)?;
    glb.frame(&sim)?;
    obj.frame(&sim)?;
    let mut done = 0;
    while done < steps {
        let n = every.min(steps - done);
        sim.advance(n)?;
        done += n;
        glb.frame(&sim)?;
        obj.frame(&sim)?;
    }
    let glb = glb.finish()?;
    let obj = obj.finish()?;
    println!("{}: {} steps, {:.2} s simulated", scene.name, sim.steps(), sim.time());
    println!("  {} frames → {}", glb.frames, glb.first.display());
    println!("  {} OBJ files, the first {}", obj.files, obj.first.display());
    println!("  final max edge strain {:.2} %", 100.0 * sim.edge_strain().max);
    Ok(())
}
