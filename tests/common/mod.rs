//! Shared by the GPU tests: one headless device per test binary, and the
//! golden-image comparison.
//!
//! # Tolerance
//!
//! A pixel *differs* when any of its red, green or blue channels is more
//! than [`PIXEL_THRESHOLD`] (8 of 255) away from the golden image; a test
//! fails when more than [`MAX_DIFFERING_SHARE`] (0.4 %) of the pixels differ.
//!
//! Why: the goldens are made on Mesa's software rasterisers, which other
//! machines (CI, a colleague's laptop) have in other versions. Measured
//! here, lavapipe (Vulkan) against llvmpipe (GL) differ by 1 level of 255 in
//! smooth shading, and by up to 59 levels on a handful of pixels where MSAA
//! covers an edge or a thin bar differently (17 pixels of 49 152 at most,
//! 0.03 %). The threshold absorbs the first with room for a few levels of
//! rounding change; the share absorbs the second ten times over.
//!
//! What must fail, tried by breaking the code on purpose: the cloth's front
//! colour 10 % darker in linear light (10 levels in sRGB) fails every scene
//! that shows the front (2–6 % of pixels differ); the camera turned by one
//! degree fails every scene (0.7–8 %); the surface not drawn fails every
//! scene that has one (3–20 %).

#![allow(dead_code)]

use std::path::PathBuf;
use std::sync::OnceLock;

use drape::render::{AdapterPreference, Gpu};
use image::{Rgba, RgbaImage};

/// Largest per-channel difference (of 255) that still counts as the same pixel.
pub const PIXEL_THRESHOLD: u8 = 8;
/// Largest share of differing pixels a test accepts (0.4 %).
pub const MAX_DIFFERING_SHARE: f64 = 0.004;

/// The device shared by every test of a binary: the software adapter first,
/// so images match across machines that have Mesa.
pub fn gpu() -> &'static Gpu {
    static GPU: OnceLock<Result<Gpu, String>> = OnceLock::new();
    let result = GPU.get_or_init(|| {
        let _ = env_logger::builder().is_test(true).try_init();
        Gpu::headless(AdapterPreference::Software).map_err(|e| e.to_string())
    });
    match result {
        Ok(gpu) => gpu,
        Err(e) => panic!("these tests render images and need a wgpu adapter, and none could be opened:\n{e}"),
    }
}

fn golden_dir() -> PathBuf {
    PathBuf::from(env!("CARGO_MANIFEST_DIR")).join("tests").join("golden")
}

/// How two images differ under the tolerance.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct Difference {
    /// Pixels whose largest channel difference exceeds [`PIXEL_THRESHOLD`].
    pub differing: usize,
    /// All pixels.
    pub total: usize,
    /// The largest channel difference anywhere.
    pub largest: u8,
}

impl Difference {
    /// Share of differing pixels.
    pub fn share(&self) -> f64 {
        self.differing as f64 / self.total.max(1) as f64
    }

    /// Whether the images count as the same.
    pub fn within_tolerance(&self) -> bool {
        self.share() <= MAX_DIFFERING_SHARE
    }
}

fn pixel_delta(a: &Rgba<u8>, b: &Rgba<u8>) -> u8 {
    (0..3).map(|c| a[c].abs_diff(b[c])).max().unwrap_or(0)
}

/// Compares two images of the same size.
pub fn compare(actual: &RgbaImage, golden: &RgbaImage) -> Difference {
    let mut d = Difference { differing: 0, total: (actual.width() * actual.height()) as usize, largest: 0 };
    for (a, g) in actual.pixels().zip(golden.pixels()) {
        let delta = pixel_delta(a, g);
        d.largest = d.largest.max(delta);
        if delta > PIXEL_THRESHOLD {
            d.differing += 1;
        }
    }
    d
}

/// The golden image faded to grey, with differing pixels in red (brighter
/// for larger differences).
pub fn difference_image(actual: &RgbaImage, golden: &RgbaImage) -> RgbaImage {
    RgbaImage::from_fn(actual.width(), actual.height(), |x, y| {
        let (a, g) = (actual.get_pixel(x, y), golden.get_pixel(x, y));
        let delta = pixel_delta(a, g);
        if delta > PIXEL_THRESHOLD {
            Rgba([128u8.saturating_add(delta / 2), 0, 0, 255])
        } else {
            let luma = (u32::from(g[0]) * 3 + u32::from(g[1]) * 6 + u32::from(g[2])) / 10;
            let faded = (180 + luma * 75 / 255) as u8;
            Rgba([faded, faded, faded, 255])
        }
    })
}

/// Compares `actual` with `tests/golden/<name>.png`.
///
/// With `UPDATE_GOLDEN=1` it writes the golden image instead. On a mismatch
/// it writes `<name>.actual.png` and `<name>.diff.png` beside the golden
/// one (both git-ignored) and fails naming them.
pub fn assert_golden(name: &str, actual: &RgbaImage) {
    let dir = golden_dir();
    let path = dir.join(format!("{name}.png"));
    if std::env::var("UPDATE_GOLDEN").is_ok_and(|v| v == "1") {
        std::fs::create_dir_all(&dir).unwrap();
        drape::render::write_png(&path, actual).unwrap();
        eprintln!("wrote {}", path.display());
        return;
    }
    let golden = match image::open(&path) {
        Ok(img) => img.to_rgba8(),
        Err(e) => panic!(
            "cannot read the golden image {} ({e}); run `UPDATE_GOLDEN=1 cargo test` to create it, then look at it",
            path.display()
        ),
    };
    let actual_path = dir.join(format!("{name}.actual.png"));
    let diff_path = dir.join(format!("{name}.diff.png"));
    if golden.dimensions() != actual.dimensions() {
        actual.save(&actual_path).unwrap();
        panic!(
            "{name}: the image is {:?} but the golden image {} is {:?}; the actual image is in {}",
            actual.dimensions(),
            path.display(),
            golden.dimensions(),
            actual_path.display()
        );
    }
    let d = compare(actual, &golden);
    // Shown with `--nocapture`: how close a passing image came.
    eprintln!("{name}: {} pixels differ (largest difference {})", d.differing, d.largest);
    if d.within_tolerance() {
        // Leftovers of an earlier failure would mislead.
        let _ = std::fs::remove_file(&actual_path);
        let _ = std::fs::remove_file(&diff_path);
        return;
    }
    actual.save(&actual_path).unwrap();
    difference_image(actual, &golden).save(&diff_path).unwrap();
    panic!(
        "{name}: {} of {} pixels ({:.2} %, allowed {:.2} %) differ from {} by more than {PIXEL_THRESHOLD}/255 \
         (largest difference {}).\n  actual image: {}\n  differences (red): {}\n\
         If the change is intended, look at the actual image and run `UPDATE_GOLDEN=1 cargo test`.",
        d.differing,
        d.total,
        d.share() * 100.0,
        MAX_DIFFERING_SHARE * 100.0,
        path.display(),
        d.largest,
        actual_path.display(),
        diff_path.display()
    );
}
