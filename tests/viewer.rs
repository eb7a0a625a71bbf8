//! The viewer driven offscreen with synthetic input, exactly as the window
//! drives it: mouse drags grab particles and orbit, keys pause and step,
//! the panel is drawn (a golden image of the whole window), a blow-up shows
//! its message, F12 writes a PNG.
#![cfg(feature = "viewer")]

mod common;

use std::time::Duration;

use drape::app::clock::TickingClock;
use drape::app::{Frame, Viewer, ViewerSettings, WindowRequest};
use drape::render::OffscreenTarget;
use drape::scene;
use drape::ui::{TimeMode, UiCommand};
use egui::{Event, Key, Modifiers, PointerButton, Pos2, pos2, vec2};
use glam::Vec3;

/// The window size the tests use, in points (= pixels: scale factor 1).
const WINDOW: (u32, u32) = (800, 860);

/// A viewer whose clock ticks 1 ms per reading, so its timings (and the
/// stats the panel prints) are the same on every run.
fn viewer(scene_name: &str, screenshots: &std::path::Path) -> Viewer {
    viewer_for(scene_name, screenshots, OffscreenTarget::FORMAT)
}

/// A viewer drawing into targets of `format`, as a window's surface may be.
fn viewer_for(scene_name: &str, screenshots: &std::path::Path, format: wgpu::TextureFormat) -> Viewer {
    let settings = ViewerSettings {
        predictable_ui: true,
        clock: Box::new(TickingClock { next: Duration::ZERO, tick: Duration::from_millis(1) }),
        screenshot_dir: screenshots.to_path_buf(),
        export_dir: screenshots.join("exports"),
        adapter_label: Some("test adapter".into()),
    };
    Viewer::new(common::gpu().clone(), scene::load(scene_name).unwrap(), format, settings).unwrap()
}

/// Feeds one frame of input events (at frame number `n`, 60 per second).
fn frame(viewer: &mut Viewer, n: u32, events: Vec<Event>) -> Frame {
    let input = egui::RawInput {
        screen_rect: Some(egui::Rect::from_min_size(Pos2::ZERO, vec2(WINDOW.0 as f32, WINDOW.1 as f32))),
        time: Some(f64::from(n) / 60.0),
        predicted_dt: 1.0 / 60.0,
        focused: true,
        events,
        ..Default::default()
    };
    let frame = viewer.run_frame(input);
    viewer.skip_draw(&frame.ui);
    frame
}

fn press(pos: Pos2, button: PointerButton, pressed: bool, modifiers: Modifiers) -> Event {
    Event::PointerButton { pos, button, pressed, modifiers }
}

fn key(key: Key) -> Event {
    Event::Key { key, physical_key: None, pressed: true, repeat: false, modifiers: Modifiers::NONE }
}

fn temp_dir(name: &str) -> std::path::PathBuf {
    let dir = std::env::temp_dir().join(format!("drape-test-{name}-{}", std::process::id()));
    let _ = std::fs::remove_dir_all(&dir);
    dir
}

#[test]
fn window_frame_with_the_panel() {
    let mut v = viewer("seed", &temp_dir("panel"));
    for n in 0..30 {
        frame(&mut v, n, vec![]);
    }
    let last = frame(&mut v, 30, vec![]);
    let image = v.render_image(WINDOW, &last.ui).unwrap();
    v.skip_draw(&last.ui);
    common::assert_golden("window-seed", &image);
}

#[test]
fn dragging_the_cloth_pulls_a_particle_and_releases_it() {
    let mut v = viewer("seed", &temp_dir("grab"));
    v.apply(UiCommand::TogglePause);
    frame(&mut v, 0, vec![]);
    // The middle of the bottom row: free, and in front.
    let particle = 29 * 20 + 10;
    let at = v.particle_on_screen(particle).unwrap();
    let start = v.simulation().positions()[particle];
    frame(&mut v, 1, vec![Event::PointerMoved(at), press(at, PointerButton::Primary, true, Modifiers::NONE)]);
    assert!(!v.simulation().fixed()[particle], "a held particle stays free");
    assert_eq!(v.simulation().holds().len(), 1, "and is held");
    v.apply(UiCommand::TogglePause); // run while holding
    for n in 2..12 {
        frame(&mut v, n, vec![Event::PointerMoved(at + vec2(8.0 * (n - 1) as f32, 0.0))]);
    }
    let held = v.simulation().positions()[particle];
    assert!(held.x > start.x + 0.5, "dragged right on screen, moved +x in the world: {start} → {held}");
    let end = at + vec2(80.0, 0.0);
    frame(&mut v, 12, vec![press(end, PointerButton::Primary, false, Modifiers::NONE)]);
    assert!(!v.simulation().fixed()[particle] && v.simulation().holds().is_empty(), "released: free, not held");
    // The camera did not move: the drag went to the cloth, not to orbiting.
    let camera = *v.camera();
    frame(&mut v, 13, vec![]);
    assert_eq!(*v.camera(), camera);
}

#[test]
fn dragging_empty_space_orbits_and_the_wheel_zooms() {
    let mut v = viewer("seed", &temp_dir("orbit"));
    frame(&mut v, 0, vec![]);
    let before = *v.camera();
    let sky = pos2(20.0, 20.0);
    frame(&mut v, 1, vec![Event::PointerMoved(sky), press(sky, PointerButton::Primary, true, Modifiers::NONE)]);
    frame(&mut v, 2, vec![Event::PointerMoved(sky + vec2(50.0, 30.0))]);
    frame(&mut v, 3, vec![press(sky + vec2(50.0, 30.0), PointerButton::Primary, false, Modifiers::NONE)]);
    let after = *v.camera();
    assert!(after.yaw < before.yaw, "dragging right turns the camera left about the cloth");
    assert!(after.pitch > before.pitch, "dragging down looks from higher up");
    assert_eq!(after.target, before.target);
    let wheel = Event::MouseWheel {
        unit: egui::MouseWheelUnit::Point,
        delta: vec2(0.0, 100.0),
        phase: egui::TouchPhase::Move,
        source: egui::MouseWheelSource::Unknown,
        modifiers: Modifiers::NONE,
    };
    for n in 4..20 {
        let events = if n == 4 { vec![Event::PointerMoved(sky), wheel.clone()] } else { vec![] };
        frame(&mut v, n, events);
    }
    assert!(v.camera().distance < after.distance * 0.95, "the wheel zooms in");
    // Right-drag pans: the target moves, the angles do not.
    let panned = *v.camera();
    frame(&mut v, 20, vec![press(sky, PointerButton::Secondary, true, Modifiers::NONE)]);
    frame(&mut v, 21, vec![Event::PointerMoved(sky + vec2(40.0, 0.0))]);
    frame(&mut v, 22, vec![press(sky + vec2(40.0, 0.0), PointerButton::Secondary, false, Modifiers::NONE)]);
    assert_ne!(v.camera().target, panned.target);
    assert_eq!((v.camera().yaw, v.camera().pitch), (panned.yaw, panned.pitch));
}

#[test]
fn ctrl_click_pins_and_unpins() {
    let mut v = viewer("seed", &temp_dir("pin"));
    v.apply(UiCommand::TogglePause);
    frame(&mut v, 0, vec![]);
    let particle = 15 * 20 + 5;
    let at = v.particle_on_screen(particle).unwrap();
    let click = |pressed| press(at, PointerButton::Primary, pressed, Modifiers::CTRL);
    let ctrl = Event::ModifiersChanged(Modifiers::CTRL);
    // Hovering shows which particle a click takes, before the click.
    frame(&mut v, 1, vec![ctrl.clone(), Event::PointerMoved(at)]);
    assert_eq!(v.hovered_particle(), Some(particle));
    // Every particle of the cloth, clicked where it is drawn, is the one
    // picked (not a neighbour): the seed's 600, seen from the scene's view.
    for i in 0..v.simulation().positions().len() {
        if let Some(p) = v.particle_on_screen(i) {
            frame(&mut v, 1, vec![Event::PointerMoved(p)]);
            assert_eq!(v.hovered_particle(), Some(i), "particle {i} at {p:?}");
        }
    }
    frame(&mut v, 1, vec![Event::PointerMoved(at), click(true)]);
    frame(&mut v, 2, vec![click(false)]);
    assert!(v.simulation().fixed()[particle]);
    frame(&mut v, 3, vec![click(true)]);
    frame(&mut v, 4, vec![click(false)]);
    assert!(!v.simulation().fixed()[particle]);
}

#[test]
fn keys_pause_step_reset_and_quit() {
    let mut v = viewer("flag", &temp_dir("keys"));
    v.apply(UiCommand::SetTimeMode(TimeMode::StepPerFrame));
    frame(&mut v, 0, vec![]);
    frame(&mut v, 1, vec![]);
    assert_eq!(v.simulation().steps(), 2, "one step per frame");
    frame(&mut v, 2, vec![key(Key::Space)]);
    assert!(v.paused());
    let steps = v.simulation().steps();
    frame(&mut v, 3, vec![]);
    assert_eq!(v.simulation().steps(), steps, "paused");
    frame(&mut v, 4, vec![key(Key::S)]);
    assert_eq!(v.simulation().steps(), steps + 1, "S takes one step");
    frame(&mut v, 5, vec![key(Key::R)]);
    assert_eq!(v.simulation().steps(), 0);
    assert_eq!(v.simulation().positions(), v.scene().mesh.positions());
    let quit = frame(&mut v, 6, vec![key(Key::Escape)]);
    assert_eq!(quit.requests, vec![WindowRequest::Quit]);
}

#[test]
fn parameter_changes_apply_at_once_and_scene_values_come_back() {
    let mut v = viewer("seed", &temp_dir("params"));
    let params = v.simulation().params().clone();
    v.apply(UiCommand::SetParams(drape::sim::SolverParams { relaxations: 77, damping: 0.1, ..params.clone() }));
    assert_eq!(v.simulation().params().relaxations, 77);
    v.apply(UiCommand::Reset);
    assert_eq!(v.simulation().params().relaxations, 77, "reset keeps the parameters");
    // An invalid value is refused with a notice, and nothing changes.
    v.apply(UiCommand::SetParams(drape::sim::SolverParams { dt: -1.0, ..params.clone() }));
    assert_eq!(v.simulation().params().relaxations, 77);
    assert!(v.toasts().iter().any(|t| t.error && t.text.contains("dt")), "{:?}", v.toasts());
    v.apply(UiCommand::RestoreSceneParams);
    assert_eq!(v.simulation().params(), &params);
}

#[test]
fn loading_scenes_switches_mesh_and_view() {
    let mut v = viewer("seed", &temp_dir("load"));
    frame(&mut v, 0, vec![]);
    v.apply(UiCommand::LoadScene("chain".into()));
    assert_eq!(v.simulation().positions().len(), 21);
    assert!(v.view_options().structural_bars && !v.view_options().surface, "a bar-only mesh is shown as bars");
    v.apply(UiCommand::LoadScene("no-such-scene".into()));
    assert_eq!(v.simulation().positions().len(), 21, "a failed load keeps the scene");
    assert!(v.toasts().iter().any(|t| t.error && t.text.contains("no-such-scene")));
    // A frame of the chain draws (bars and particles, no triangles).
    let f = frame(&mut v, 1, vec![]);
    let image = v.render_image((320, 200), &f.ui).unwrap();
    v.skip_draw(&f.ui);
    assert_eq!(image.dimensions(), (320, 200));
}

#[test]
fn a_blow_up_stops_the_simulation_and_says_so() {
    let mut v = viewer("seed", &temp_dir("boom"));
    frame(&mut v, 0, vec![]);
    // No physical setting diverges the reference solver within a test's
    // time; a particle thrown to the edge of f32 does (bar lengths overflow).
    let far = Vec3::splat(3e38);
    v.simulation_mut().move_particle(599, far).unwrap();
    frame(&mut v, 1, vec![]);
    assert!(v.simulation().diverged().is_some());
    let steps = v.simulation().steps();
    for n in 2..5 {
        frame(&mut v, n, vec![key(Key::Space)]);
    }
    assert_eq!(v.simulation().steps(), steps, "stopped: neither frames nor Space step it");
    assert!(v.simulation().positions().iter().all(|p| p.is_finite() || *p == far));
    // Let the message's fade-in finish.
    for n in 5..20 {
        frame(&mut v, n, vec![]);
    }
    let f = frame(&mut v, 20, vec![]);
    let image = v.render_image(WINDOW, &f.ui).unwrap();
    // The message is in the 3-D view: keep only that part of the window.
    let view = v.viewport();
    let image = image::imageops::crop_imm(&image, 0, 0, view.width as u32, WINDOW.1 / 2 + 100).to_image();
    v.skip_draw(&f.ui);
    common::assert_golden("window-blow-up", &image);
    v.apply(UiCommand::Reset);
    assert!(v.simulation().diverged().is_none());
}

#[test]
fn f12_saves_a_screenshot_and_says_where() {
    let dir = temp_dir("f12");
    // Windows on Linux usually get BGRA surfaces; the screenshot must be
    // drawn in the same format the viewer's pipelines were made for.
    let format = wgpu::TextureFormat::Bgra8Unorm;
    let mut v = viewer_for("hammock", &dir, format);
    frame(&mut v, 0, vec![]);
    let f = frame(&mut v, 1, vec![key(Key::F12)]);
    let target = OffscreenTarget::with_format(&common::gpu().device, WINDOW.0, WINDOW.1, format).unwrap();
    v.draw(&target.view, WINDOW, &f.ui);
    let files: Vec<_> = std::fs::read_dir(&dir).unwrap().map(|e| e.unwrap().path()).collect();
    assert_eq!(files.len(), 1, "{files:?}");
    let shot = image::open(&files[0]).unwrap().to_rgba8();
    assert_eq!(shot.dimensions(), WINDOW);
    // Red and blue in the right places: the sky (top-left) is bluish grey.
    let sky = shot.get_pixel(10, 10);
    assert!(sky[2] > sky[0], "BGRA read back as RGBA: {sky:?}");
    assert!(v.toasts().iter().any(|t| !t.error && t.text.contains("saved")));
    let _ = std::fs::remove_dir_all(&dir);
}

#[test]
fn an_image_larger_than_the_device_allows_is_an_error_not_a_panic() {
    let device = &common::gpu().device;
    let limits = device.limits();
    let side = limits.max_texture_dimension_2d;
    // One pixel wider than the largest texture.
    let e = OffscreenTarget::new(device, side + 1, 1).unwrap_err();
    assert!(matches!(e, drape::render::ReadbackError::TooLarge { .. }), "{e}");
    assert!(e.to_string().contains("at most"), "{e}");
    // Within the side but beyond the largest readback buffer, where the
    // device's buffer limit is small enough to reach (rows are padded to
    // 256 bytes: a 64-pixel row takes exactly 256).
    let rows = limits.max_buffer_size / 256 + 1;
    if rows <= u64::from(side) {
        let e = OffscreenTarget::new(device, 64, rows as u32).unwrap_err();
        assert!(matches!(e, drape::render::ReadbackError::TooLarge { .. }), "{e}");
    }
    // A small image is accepted.
    assert!(OffscreenTarget::new(device, 64, 64).is_ok());
}

#[test]
fn shift_dragging_a_collider_moves_it_and_the_cloth_feels_it() {
    // The drape-sphere scene: Shift+drag the ball sideways on screen. The
    // ball follows the cursor in the plane facing the camera, so it moves
    // to the right in the view; the cloth lying on it is dragged along by
    // contact and friction, so its centre moves the same way.
    let mut v = viewer("drape-sphere", &temp_dir("collider-drag"));
    for n in 0..60 {
        frame(&mut v, n, vec![]);
    }
    let ball = v.simulation().collider_poses()[1].translation;
    let right = v.camera().backward().cross(Vec3::Y).normalize() * -1.0;
    let cloth = |v: &Viewer| v.simulation().positions()[20 * 41 + 20];
    let cloth_before = cloth(&v);
    // Aim at the ball's side facing the camera, below the cloth's top.
    // A point inside the ball, towards the camera and below the cloth on
    // its top: the ray through it meets the ball.
    let at = v.point_on_screen(ball + v.camera().backward() * 0.2 + Vec3::new(0.0, -0.15, 0.0)).unwrap();
    let shift = Modifiers::SHIFT;
    let held = Event::ModifiersChanged(shift);
    frame(&mut v, 60, vec![held, Event::PointerMoved(at), press(at, PointerButton::Primary, true, shift)]);
    let camera_before = v.camera().yaw;
    for n in 61..80 {
        frame(&mut v, n, vec![Event::PointerMoved(at + vec2(4.0 * (n - 60) as f32, 0.0))]);
    }
    frame(&mut v, 80, vec![press(at + vec2(80.0, 0.0), PointerButton::Primary, false, shift)]);
    let moved = v.simulation().collider_poses()[1].translation - ball;
    assert!(moved.dot(right) > 0.1, "the ball moved {moved} (camera right is {right})");
    assert!(moved.y.abs() < 0.05, "it moved in the plane facing the camera: {moved}");
    assert_eq!(v.camera().yaw, camera_before, "the drag went to the ball, not to orbiting");
    for n in 81..120 {
        frame(&mut v, n, vec![]);
    }
    let carried = cloth(&v) - cloth_before;
    assert!(carried.dot(right) > 0.05, "the cloth on the ball went along: {carried}");
}

#[test]
fn the_camera_never_orbits_below_the_ground() {
    let mut v = viewer("drape-sphere", &temp_dir("below-ground"));
    frame(&mut v, 0, vec![]);
    // Far away from the cloth: left-drag upwards tilts the view up, which
    // would bring the eye below the floor.
    let at = pos2(40.0, 820.0);
    frame(&mut v, 1, vec![Event::PointerMoved(at), press(at, PointerButton::Primary, true, Modifiers::NONE)]);
    for n in 2..40 {
        frame(&mut v, n, vec![Event::PointerMoved(at + vec2(0.0, -20.0 * (n - 1) as f32))]);
    }
    let eye = v.camera().eye();
    assert!(eye.y > 0.0, "the eye went below the ground: {eye}");
}

#[test]
fn the_timeline_scrubs_plays_back_resumes_and_exports() {
    let dir = temp_dir("timeline");
    let mut v = viewer("seed", &dir);
    // Ten frames of one step each: frames at steps 0 to 10.
    for n in 0..10 {
        frame(&mut v, n, vec![]);
    }
    assert_eq!((v.timeline().recording().len(), v.timeline().cursor()), (11, None));
    // Three presses of Left in one frame: three frames back, paused there,
    // the simulation itself in that frame's state.
    frame(&mut v, 10, vec![key(Key::ArrowLeft), key(Key::ArrowLeft), key(Key::ArrowLeft)]);
    assert!(v.paused());
    assert_eq!(v.timeline().cursor(), Some(7));
    assert_eq!(v.simulation().steps(), 7);
    assert_eq!(v.simulation().positions(), v.timeline().recording().get(7).unwrap().positions);
    // Playback at real time from there: the test clock moves 1 ms per
    // reading, far less than a step of 50 ms, so P starts at frame 7 and a
    // frame later it is still there; nothing is simulated meanwhile.
    frame(&mut v, 11, vec![key(Key::P)]);
    assert!(v.timeline().playing());
    frame(&mut v, 12, vec![]);
    assert_eq!((v.timeline().cursor(), v.simulation().steps()), (Some(7), 7));
    assert_eq!(v.timeline().recording().len(), 11);
    v.apply(UiCommand::PlayRecording(false));
    // Scrub to frame 4, then run: the simulation goes on from step 4 and
    // the frames after it are dropped (with a notice).
    v.apply(UiCommand::ScrubTo(4));
    assert_eq!(v.simulation().steps(), 4);
    frame(&mut v, 13, vec![key(Key::Space)]);
    assert!(!v.paused());
    assert_eq!(v.simulation().steps(), 5, "one step on from step 4");
    let steps: Vec<u64> = v.timeline().recording().frames().iter().map(|f| f.step).collect();
    assert_eq!(steps, [0, 1, 2, 3, 4, 5]);
    assert!(v.toasts().iter().any(|t| t.text.contains("6 later frames were dropped")), "{:?}", v.toasts());
    // Export writes the six frames as a .glb into the export directory.
    v.apply(UiCommand::ExportRecording);
    let exported: Vec<_> = std::fs::read_dir(dir.join("exports")).unwrap().map(|e| e.unwrap().path()).collect();
    assert_eq!(exported.len(), 1);
    let gltf = gltf::Gltf::open(&exported[0]).unwrap();
    let primitive = gltf.meshes().next().unwrap().primitives().next().unwrap();
    assert_eq!(primitive.morph_targets().count(), 6);
    // Reset starts a new recording.
    v.apply(UiCommand::Reset);
    assert_eq!(v.timeline().recording().len(), 1);
}

#[test]
fn scenes_open_in_real_time_when_the_solver_can_hold_it() {
    // The seed's scene asks for a step per frame, as the seed's program did.
    let v = viewer("seed", &temp_dir("mode-seed"));
    assert_mode(&v, TimeMode::StepPerFrame, "the scene's choice");
    // The flag leaves it to the viewer, which times its steps with the test
    // clock (1 ms a reading, so 1 ms a step) against h = 0.01 s: 10 % of
    // real time, within the half that real time may take.
    let v = viewer("flag", &temp_dir("mode-flag"));
    assert_mode(&v, TimeMode::RealTime, "the solver needs 10.0 %");
    // The same 1 ms steps of h = 1 ms would take all of it: a step per frame.
    let text = "[solver]\ndt = 0.001\n[grid]\ncolumns = 4\nrows = 4\nspacing = 0.1\n";
    let scene = scene::parse(text, &scene::Origin::Text).unwrap();
    let settings = ViewerSettings {
        predictable_ui: true,
        clock: Box::new(TickingClock { next: Duration::ZERO, tick: Duration::from_millis(1) }),
        ..ViewerSettings::default()
    };
    let v = Viewer::new(common::gpu().clone(), scene, OffscreenTarget::FORMAT, settings).unwrap();
    assert_mode(&v, TimeMode::StepPerFrame, "would need 100 % of the CPU");
}

fn assert_mode(v: &Viewer, mode: TimeMode, why: &str) {
    assert_eq!(v.time_mode(), mode);
    assert!(v.time_reason().contains(why), "{}", v.time_reason());
}

#[test]
fn saving_the_scene_file_reloads_it_and_keeps_the_camera() {
    let dir = temp_dir("watch");
    std::fs::create_dir_all(&dir).unwrap();
    let file = dir.join("cloth.toml");
    let grid = |columns: u32| format!("[grid]\ncolumns = {columns}\nrows = 4\nspacing = 0.1\n");
    std::fs::write(&file, grid(4)).unwrap();
    let settings = ViewerSettings {
        predictable_ui: true,
        clock: Box::new(TickingClock { next: Duration::ZERO, tick: Duration::from_millis(1) }),
        screenshot_dir: dir.clone(),
        ..ViewerSettings::default()
    };
    let scene = scene::load(file.to_str().unwrap()).unwrap();
    let mut v = Viewer::new(common::gpu().clone(), scene, OffscreenTarget::FORMAT, settings).unwrap();
    frame(&mut v, 0, vec![]);
    // Orbit away from the scene's view, then save the file with 6 columns.
    let sky = pos2(20.0, 20.0);
    frame(&mut v, 1, vec![Event::PointerMoved(sky), press(sky, PointerButton::Primary, true, Modifiers::NONE)]);
    frame(&mut v, 2, vec![Event::PointerMoved(sky + vec2(60.0, 0.0))]);
    frame(&mut v, 3, vec![press(sky + vec2(60.0, 0.0), PointerButton::Primary, false, Modifiers::NONE)]);
    let camera = *v.camera();
    std::fs::write(&file, grid(6)).unwrap();
    // The watch reports within milliseconds; allow 5 s on a loaded machine.
    let mut n = 4;
    let start = std::time::Instant::now();
    while v.simulation().positions().len() != 24 && start.elapsed() < Duration::from_secs(5) {
        std::thread::sleep(Duration::from_millis(20));
        frame(&mut v, n, vec![]);
        n += 1;
    }
    assert_eq!(v.simulation().positions().len(), 24, "6 × 4 after the save");
    assert_eq!(*v.camera(), camera, "the camera stays where the user put it");
    assert!(v.toasts().iter().any(|t| t.text.contains("reloaded")), "{:?}", v.toasts());
    // A save that breaks the file keeps the scene and says what is wrong.
    std::fs::write(&file, "[grid]\ncolumns = 0\nrows = 4\nspacing = 0.1\n").unwrap();
    let start = std::time::Instant::now();
    while !v.toasts().iter().any(|t| t.error) && start.elapsed() < Duration::from_secs(5) {
        std::thread::sleep(Duration::from_millis(20));
        frame(&mut v, n, vec![]);
        n += 1;
    }
    assert!(v.toasts().iter().any(|t| t.error && t.text.contains("columns")), "{:?}", v.toasts());
    assert_eq!(v.simulation().positions().len(), 24);
}
