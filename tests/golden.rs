//! Golden images: every bundled scene rendered headless after a fixed
//! number of steps, at a fixed size, from the scene's own camera, through
//! the same code as `drape render`; and the whole viewer window, panel
//! included, drawn offscreen. The tolerance is documented in `common`.
//!
//! The images depend on the solver's numbers as well as on the renderer
//! (the fast solver gives the same bits on any thread count, so they are
//! reproducible): after a deliberate change to a scene, the solver or the
//! renderer, look at the `.actual.png` images and run
//! `UPDATE_GOLDEN=1 cargo test`.
#![cfg(feature = "viewer")]

mod common;

use drape::render::{self, OffscreenTarget, Renderer, ViewOptions};
use drape::scene;

/// Golden images are small: enough to see the cloth, quick on a CPU.
const SIZE: (u32, u32) = (256, 192);

/// Runs `steps` of a bundled scene and renders it as `drape render` does.
fn render_scene(name: &str, steps: u64, bars: bool) -> image::RgbaImage {
    let gpu = common::gpu();
    let scene = scene::load(name).unwrap();
    let mut sim = scene.simulation().unwrap();
    sim.advance(steps).unwrap();
    let options =
        if bars { ViewOptions::bars_view().adapted_to(&scene.mesh) } else { ViewOptions::for_mesh(&scene.mesh) };
    let camera = render::start_camera(&scene.camera, &sim, SIZE.0 as f32 / SIZE.1 as f32);
    let mut renderer = Renderer::new(gpu, OffscreenTarget::FORMAT);
    drape::app::snapshot(gpu, &mut renderer, &sim, &camera, &options, SIZE).unwrap()
}

#[test]
fn seed() {
    common::assert_golden("seed", &render_scene("seed", 40, false));
}

#[test]
fn seed_bars() {
    common::assert_golden("seed-bars", &render_scene("seed", 40, true));
}

#[test]
fn flag() {
    common::assert_golden("flag", &render_scene("flag", 150, false));
}

#[test]
fn hammock() {
    common::assert_golden("hammock", &render_scene("hammock", 120, false));
}

#[test]
fn chain() {
    // No triangles: drawn as bars and particles.
    common::assert_golden("chain", &render_scene("chain", 100, false));
}

#[test]
fn tablecloth() {
    common::assert_golden("tablecloth", &render_scene("tablecloth", 150, false));
}

#[test]
fn large() {
    // 65 536 particles: few steps keep the test quick.
    common::assert_golden("large", &render_scene("large", 3, false));
}
