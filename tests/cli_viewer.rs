//! The viewer's commands as a user runs them: `drape render` writes a PNG of
//! the size asked for, bad arguments end in one message and exit status 2,
//! `drape adapters` lists what wgpu sees, and the viewer without a display
//! says what to do instead of panicking.
#![cfg(feature = "viewer")]

use std::path::PathBuf;
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

fn text(bytes: &[u8]) -> String {
    String::from_utf8_lossy(bytes).into_owned()
}

#[test]
fn render_writes_a_png_of_the_requested_size() {
    let out = scratch("render_png").join("chain.png");
    let o = drape(&[
        "render",
        "--scene",
        "chain",
        "--steps",
        "5",
        "--size",
        "96x64",
        "--view",
        "bars",
        "--camera",
        "10,-5",
        "--out",
        out.to_str().unwrap(),
    ]);
    assert!(o.status.success(), "{}", text(&o.stderr));
    assert!(text(&o.stdout).contains("Hanging chain: 5 steps"), "{}", text(&o.stdout));
    let image = image::open(&out).unwrap().to_rgba8();
    assert_eq!(image.dimensions(), (96, 64));
    let mut colours: Vec<[u8; 4]> = image.pixels().map(|p| p.0).collect();
    colours.sort_unstable();
    colours.dedup();
    assert!(colours.len() > 50, "a picture, not a flat fill: {} colours", colours.len());
}

#[test]
fn render_rejects_bad_arguments_with_status_2() {
    for (args, needle) in [
        (&["render", "--size", "0x10"][..], "--size"),
        (&["render", "--size", "wide"][..], "--size"),
        (&["render", "--camera", "10"][..], "--camera"),
        (&["render", "--camera", "1,2,-3"][..], "--camera"),
        (&["render", "--scene", "no-such-scene"][..], "no-such-scene"),
    ] {
        let o = drape(args);
        assert_eq!(o.status.code(), Some(2), "{args:?}: {}", text(&o.stderr));
        assert!(text(&o.stderr).contains(needle), "{args:?}: {}", text(&o.stderr));
        assert!(!text(&o.stderr).contains("panicked"), "{args:?}");
    }
}

#[test]
fn adapters_lists_the_adapters_and_the_choices() {
    let o = drape(&["adapters"]);
    assert!(o.status.success(), "{}", text(&o.stderr));
    let listing = text(&o.stdout);
    assert!(listing.contains("[0]") && listing.contains("backend"), "{listing}");
    assert!(listing.contains("the viewer and `drape render` use:"), "{listing}");
}

#[test]
fn the_viewer_without_a_display_says_what_to_do() {
    let o = Command::new(env!("CARGO_BIN_EXE_drape"))
        .env_remove("DISPLAY")
        .env_remove("WAYLAND_DISPLAY")
        .env_remove("WAYLAND_SOCKET")
        .output()
        .expect("the drape binary runs");
    assert_eq!(o.status.code(), Some(2), "{}", text(&o.stderr));
    let message = text(&o.stderr);
    assert!(message.contains("cannot open a window") && message.contains("drape render"), "{message}");
    assert!(!message.contains("panicked"), "{message}");
}
