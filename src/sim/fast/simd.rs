//! Which SIMD level the lane kernels run at, chosen once per process.
//!
//! By default the best the CPU has: AVX-512 (F + VL, with AVX2 and FMA),
//! else AVX2 + FMA, else the portable build (SSE2 on x86-64, whatever the
//! target has elsewhere). The environment variable `DRAPE_SIMD` forces a
//! level, so that the AVX2 path can be measured on an AVX-512 host and the
//! portable path anywhere:
//!
//! ```text
//! DRAPE_SIMD=avx512 | avx2 | portable
//! ```
//!
//! A level the CPU lacks falls back to the best it has, and an unknown value
//! to the default; [`note`] says so (`drape run` prints it).
//!
//! At the AVX-512 level, the kernels the compiler vectorises (`dispatch!`:
//! the grid's sweeps, the coloured path's collide phase, self-collision's
//! search; the grid's particle phases, its collide phase among them, take
//! their AVX2 build at every width) take 512-bit vectors or stay at 256 bits
//! ([`VectorWidth`]): 512 on AMD (Zen 4 runs a 512-bit instruction as two
//! 256-bit halves at full clock, and the 512-bit build of the 256 × 256
//! grid's step was 4 % quicker there), 256 on Intel, whose cores shut a
//! vector port while 512-bit instructions are in flight (and older ones
//! lower their clock): on an Emerald Rapids Xeon the 512-bit build made
//! the 256 × 256 grid's step 29–38 % longer on one thread (the 256-bit
//! build 23–27 % quicker). LLVM tunes its own Intel
//! targets the same way (`prefer-256-bit`). The environment variable
//! `DRAPE_SIMD_WIDTH` forces one:
//!
//! ```text
//! DRAPE_SIMD_WIDTH=512 | 256
//! ```
//!
//! The coloured path's octets are written for 256-bit registers at both
//! levels (AVX-512 gives them 32 of them), and the two widths compute the
//! same bits. The kernels are
//! the same source at every level (the `dispatch!` macro): only the instructions
//! the compiler may use differ, so every level computes the same bits
//! (the tests check AVX2 against portable), with one exception: the bar
//! projection fuses its multiply-adds where the level has FMA, on the grid
//! (`dispatch!` with `body::<fused>`) and on the coloured path alike
//! ([`PORTABLE_FUSED`]). AVX2 and AVX-512 then give the same bits; a
//! portable build for a target without FMA (x86-64's baseline) rounds
//! those multiply-adds twice, and its last bits differ (a test bounds by
//! how much).

use std::sync::OnceLock;
use std::sync::atomic::{AtomicU8, Ordering};

/// A SIMD level of the lane kernels, in increasing order.
#[derive(Clone, Copy, Debug, PartialEq, Eq, PartialOrd, Ord)]
pub enum SimdLevel {
    /// The target's baseline (SSE2 on x86-64).
    Portable,
    /// AVX2 + FMA: 8-wide.
    Avx2,
    /// AVX-512 F + VL (with AVX2 and FMA): 16-wide registers available.
    Avx512,
}

impl SimdLevel {
    /// Every level, in increasing order.
    pub const ALL: [SimdLevel; 3] = [SimdLevel::Portable, SimdLevel::Avx2, SimdLevel::Avx512];

    /// The name `DRAPE_SIMD` takes.
    pub fn name(self) -> &'static str {
        match self {
            SimdLevel::Avx512 => "avx512",
            SimdLevel::Avx2 => "avx2",
            SimdLevel::Portable => "portable",
        }
    }

    /// How the solver's description names it.
    pub fn label(self) -> &'static str {
        match self {
            SimdLevel::Avx512 => "AVX-512",
            SimdLevel::Avx2 => "AVX2",
            SimdLevel::Portable => "portable SIMD",
        }
    }

    /// The best level this CPU runs.
    pub fn best_available() -> SimdLevel {
        #[cfg(target_arch = "x86_64")]
        {
            let avx2 = std::arch::is_x86_feature_detected!("avx2") && std::arch::is_x86_feature_detected!("fma");
            let avx512 = avx2
                && std::arch::is_x86_feature_detected!("avx512f")
                && std::arch::is_x86_feature_detected!("avx512vl");
            if avx512 {
                return SimdLevel::Avx512;
            }
            if avx2 {
                return SimdLevel::Avx2;
            }
        }
        SimdLevel::Portable
    }
}

/// The widest vectors the AVX-512 level's compiled kernels use (module
/// docs). Below AVX-512 it is 256 bits whatever this says.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub enum VectorWidth {
    /// The AVX2 + FMA build of each `dispatch!` kernel.
    Bits256,
    /// The AVX-512 F + VL build, free to use 512-bit vectors.
    Bits512,
}

impl VectorWidth {
    /// The value `DRAPE_SIMD_WIDTH` takes.
    pub fn name(self) -> &'static str {
        match self {
            VectorWidth::Bits256 => "256",
            VectorWidth::Bits512 => "512",
        }
    }

    /// The width for this CPU: 256 bits on an Intel CPU, else 512.
    pub fn for_this_cpu() -> VectorWidth {
        if cpu_is_intel() { VectorWidth::Bits256 } else { VectorWidth::Bits512 }
    }
}

/// Whether the CPU's vendor string is Intel's (`GenuineIntel`).
fn cpu_is_intel() -> bool {
    #[cfg(target_arch = "x86_64")]
    {
        let id = std::arch::x86_64::__cpuid(0);
        let vendor = [id.ebx, id.edx, id.ecx].map(u32::to_le_bytes).concat();
        vendor == b"GenuineIntel"
    }
    #[cfg(not(target_arch = "x86_64"))]
    false
}

/// The width `DRAPE_SIMD_WIDTH` asks for on a CPU whose default is
/// `default`, and a note when the request is not a width.
pub fn choose_width(request: Option<&str>, default: VectorWidth) -> (VectorWidth, Option<String>) {
    let Some(text) = request.map(str::trim).filter(|t| !t.is_empty()) else { return (default, None) };
    match text {
        "256" => (VectorWidth::Bits256, None),
        "512" => (VectorWidth::Bits512, None),
        _ => {
            let note = format!("DRAPE_SIMD_WIDTH={text} is not a width (512 or 256): using {}", default.name());
            (default, Some(note))
        }
    }
}

/// The level `DRAPE_SIMD` asks for on a CPU whose best is `best`, and a
/// note when the request could not be honoured.
pub fn choose(request: Option<&str>, best: SimdLevel) -> (SimdLevel, Option<String>) {
    let Some(text) = request.map(str::trim).filter(|t| !t.is_empty()) else { return (best, None) };
    let asked = match text.to_ascii_lowercase().as_str() {
        "avx512" | "avx-512" => SimdLevel::Avx512,
        "avx2" => SimdLevel::Avx2,
        "portable" | "none" | "scalar" => SimdLevel::Portable,
        _ => {
            let note = format!("DRAPE_SIMD={text} is not a level (avx512, avx2 or portable): using {}", best.name());
            return (best, Some(note));
        }
    };
    if asked > best {
        let note = format!("DRAPE_SIMD={text}, but this CPU's best is {}: using it", best.name());
        return (best, Some(note));
    }
    (asked, None)
}

/// The level, the note, and `DRAPE_SIMD` as read (once).
fn chosen() -> &'static (SimdLevel, Option<String>, Option<String>) {
    static CHOSEN: OnceLock<(SimdLevel, Option<String>, Option<String>)> = OnceLock::new();
    CHOSEN.get_or_init(|| {
        let request = std::env::var("DRAPE_SIMD").ok().map(|v| v.trim().to_string()).filter(|v| !v.is_empty());
        let (level, note) = choose(request.as_deref(), SimdLevel::best_available());
        (level, note, request)
    })
}

/// The width, the note, and `DRAPE_SIMD_WIDTH` as read (once).
fn chosen_width() -> &'static (VectorWidth, Option<String>, Option<String>) {
    static CHOSEN: OnceLock<(VectorWidth, Option<String>, Option<String>)> = OnceLock::new();
    CHOSEN.get_or_init(|| {
        let request = std::env::var("DRAPE_SIMD_WIDTH").ok().map(|v| v.trim().to_string()).filter(|v| !v.is_empty());
        let (width, note) = choose_width(request.as_deref(), VectorWidth::for_this_cpu());
        (width, note, request)
    })
}

/// A width set by [`force_width`]: 0 when none is, 1 for 256 bits, 2 for
/// 512.
static FORCED_WIDTH: AtomicU8 = AtomicU8::new(0);

/// The widest vectors of the AVX-512 level's compiled kernels: the one
/// [`force_width`] set last, else the one `DRAPE_SIMD_WIDTH` asked for,
/// else [`VectorWidth::for_this_cpu`].
pub fn width() -> VectorWidth {
    match FORCED_WIDTH.load(Ordering::Relaxed) {
        1 => VectorWidth::Bits256,
        2 => VectorWidth::Bits512,
        _ => chosen_width().0,
    }
}

/// Runs the AVX-512 level's compiled kernels at `width` from now on, in
/// every thread of this process (as [`force`] for the level: for comparing
/// both in one process; the same bits either way).
pub fn force_width(width: VectorWidth) {
    FORCED_WIDTH.store(if width == VectorWidth::Bits256 { 1 } else { 2 }, Ordering::Relaxed);
}

/// A level set by [`force`]: 0 when none is, else 1 + the level's
/// discriminant (its place in [`SimdLevel::ALL`]).
static FORCED: AtomicU8 = AtomicU8::new(0);

/// The level the kernels run at: the one [`force`] set last, else the one
/// `DRAPE_SIMD` asked for (read once), else the best the CPU has.
pub fn level() -> SimdLevel {
    match FORCED.load(Ordering::Relaxed) {
        0 => chosen().0,
        forced => SimdLevel::ALL[usize::from(forced - 1)],
    }
}

/// Runs the kernels at `requested` from now on, in every thread of this
/// process, down to what the CPU has ([`SimdLevel::best_available`]: a
/// level the CPU lacks is never used); returns the level in force.
///
/// For comparing levels inside one process (`benches/ratios.rs` alternates
/// them window by window, so that a busy host's noise falls on each).
/// Safe between any two steps: no layout depends on the level, and AVX2
/// and AVX-512 compute the same bits; the portable level differs in the
/// last bits where its target has no FMA ([`PORTABLE_FUSED`]).
pub fn force(requested: SimdLevel) -> SimdLevel {
    let level = requested.min(SimdLevel::best_available());
    FORCED.store(1 + level as u8, Ordering::Relaxed);
    level
}

/// Why the level is not the one `DRAPE_SIMD` asked for, if it is not
/// (else why the width is not the one `DRAPE_SIMD_WIDTH` asked for).
pub fn note() -> Option<&'static str> {
    chosen().1.as_deref().or(chosen_width().1.as_deref())
}

/// The level and where it came from, as `drape run` prints it.
pub fn describe() -> String {
    let (chosen_level, note, request) = chosen();
    let level = level();
    if level != *chosen_level {
        return format!("{} (forced in this process; {} before)", level.name(), chosen_level.name());
    }
    let why = match (note, request) {
        (Some(note), _) => note.clone(),
        (None, Some(request)) => format!("DRAPE_SIMD={request}"),
        (None, None) => "the best this CPU has; DRAPE_SIMD=avx512|avx2|portable forces one".to_string(),
    };
    if level < SimdLevel::Avx512 {
        return format!("{} ({why})", level.name());
    }
    let (chosen_width, width_note, width_request) = chosen_width();
    let width = width();
    let width_why = match (width_note, width_request) {
        _ if width != *chosen_width => "forced in this process".to_string(),
        (Some(note), _) => note.clone(),
        (None, Some(request)) => format!("DRAPE_SIMD_WIDTH={request}"),
        (None, None) if width == VectorWidth::Bits256 => {
            "an Intel CPU's; DRAPE_SIMD_WIDTH=512|256 forces one".to_string()
        }
        (None, None) => "this CPU's; DRAPE_SIMD_WIDTH=512|256 forces one".to_string(),
    };
    format!("{} ({why}), {}-bit vectors ({width_why})", level.name(), width.name())
}

/// Whether the portable level fuses the projection's multiply-adds (the
/// six moves x ± c d, the sum d·d and ℓ² − (L − μ) ℓ of a bar's
/// projection, each rounded once as at the AVX2 and AVX-512 levels): where
/// the target's baseline has a fused multiply-add instruction (aarch64;
/// x86-64 built with `-C target-feature=+fma`), so `f32::mul_add` is one
/// instruction and the portable level gives the FMA levels' bits. On
/// x86-64's baseline it would be a call out of line a lane, so there the
/// portable level rounds them twice.
pub const PORTABLE_FUSED: bool = cfg!(any(target_feature = "fma", target_arch = "aarch64"));

/// Defines `fn $name(args) -> ret` that runs `$body(args)` (an
/// `#[inline(always)]` function) compiled for the chosen [`level`]: the
/// `best` targets (multiversion picks the best the CPU has among them) at
/// AVX-512 with 512-bit vectors ([`width`]), AVX2 and FMA alone at AVX2 or
/// at AVX-512 with 256-bit vectors, or the portable baseline.
///
/// With `= $body::<fused>`, `$body` takes a `const FUSED: bool`: `true` at
/// the AVX2 and AVX-512 levels (both have FMA), [`PORTABLE_FUSED`] at the
/// portable one.
macro_rules! dispatch {
    (
        $(#[$meta:meta])*
        $vis:vis fn $name:ident($($arg:ident : $ty:ty),* $(,)?) $(-> $ret:ty)?
            = $body:ident::<fused>, best = [$($target:literal),+]
    ) => {
        $crate::sim::fast::simd::dispatch! {
            @levels $(#[$meta])* $vis fn $name($($arg: $ty),*) $(-> $ret)?
                = [$body::<true>] [$body::<{ $crate::sim::fast::simd::PORTABLE_FUSED }>], best = [$($target),+]
        }
    };
    (
        $(#[$meta:meta])*
        $vis:vis fn $name:ident($($arg:ident : $ty:ty),* $(,)?) $(-> $ret:ty)?
            = $body:ident, best = [$($target:literal),+]
    ) => {
        $crate::sim::fast::simd::dispatch! {
            @levels $(#[$meta])* $vis fn $name($($arg: $ty),*) $(-> $ret)? = [$body] [$body], best = [$($target),+]
        }
    };
    (
        @levels $(#[$meta:meta])*
        $vis:vis fn $name:ident($($arg:ident : $ty:ty),*) $(-> $ret:ty)?
            = [$($fast:tt)+] [$($portable:tt)+], best = [$($target:literal),+]
    ) => {
        $(#[$meta])*
        $vis fn $name($($arg: $ty),*) $(-> $ret)? {
            #[multiversion::multiversion(targets($($target),+))]
            fn best($($arg: $ty),*) $(-> $ret)? {
                $($fast)+($($arg),*)
            }
            #[multiversion::multiversion(targets("x86_64+avx2+fma"))]
            fn avx2($($arg: $ty),*) $(-> $ret)? {
                $($fast)+($($arg),*)
            }
            match $crate::sim::fast::simd::level() {
                $crate::sim::fast::simd::SimdLevel::Avx512 => match $crate::sim::fast::simd::width() {
                    $crate::sim::fast::simd::VectorWidth::Bits512 => best($($arg),*),
                    $crate::sim::fast::simd::VectorWidth::Bits256 => avx2($($arg),*),
                },
                $crate::sim::fast::simd::SimdLevel::Avx2 => avx2($($arg),*),
                $crate::sim::fast::simd::SimdLevel::Portable => $($portable)+($($arg),*),
            }
        }
    };
}
pub(crate) use dispatch;

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn the_request_is_honoured_down_to_what_the_cpu_has() {
        use SimdLevel::*;
        assert_eq!(choose(None, Avx512), (Avx512, None));
        assert_eq!(choose(Some(""), Avx2), (Avx2, None));
        assert_eq!(choose(Some("avx2"), Avx512), (Avx2, None));
        assert_eq!(choose(Some(" Portable "), Avx2), (Portable, None));
        let (level, note) = choose(Some("avx512"), Avx2);
        assert_eq!(level, Avx2);
        assert!(note.unwrap().contains("best is avx2"));
        let (level, note) = choose(Some("sse9"), Avx2);
        assert_eq!(level, Avx2);
        assert!(note.unwrap().contains("not a level"));
    }

    #[test]
    fn the_width_request_is_honoured_and_a_wrong_one_says_so() {
        use VectorWidth::*;
        assert_eq!(choose_width(None, Bits256), (Bits256, None));
        assert_eq!(choose_width(Some(" 512 "), Bits256), (Bits512, None));
        assert_eq!(choose_width(Some("256"), Bits512), (Bits256, None));
        let (width, note) = choose_width(Some("1024"), Bits512);
        assert_eq!(width, Bits512);
        assert!(note.unwrap().contains("not a width (512 or 256)"));
    }

    #[test]
    #[cfg(all(target_arch = "x86_64", target_os = "linux"))]
    fn the_vendor_is_read_as_the_kernel_reads_it() {
        // `cpuid` leaf 0 spells the vendor in ebx, edx, ecx; Linux prints
        // the same twelve bytes as `vendor_id` in /proc/cpuinfo.
        let Ok(cpuinfo) = std::fs::read_to_string("/proc/cpuinfo") else { return };
        let vendor =
            cpuinfo.lines().find_map(|l| l.strip_prefix("vendor_id")).map(|v| v.trim_start_matches([' ', '\t', ':']));
        let Some(vendor) = vendor else { return };
        assert_eq!(cpu_is_intel(), vendor.trim() == "GenuineIntel", "vendor_id {vendor}");
        let expected = if vendor.trim() == "GenuineIntel" { VectorWidth::Bits256 } else { VectorWidth::Bits512 };
        assert_eq!(VectorWidth::for_this_cpu(), expected);
    }

    #[test]
    fn a_forced_level_is_capped_at_what_the_cpu_has_and_can_be_undone() {
        // The level is the process's, and other tests run beside this one:
        // it forces only AVX2 and AVX-512, which compute the same bits (a
        // test comparing two runs cannot see the switch), only where the
        // level in force is one of them, and puts that one back.
        let before = level();
        if before < SimdLevel::Avx2 {
            eprintln!("the level in force is {before:?}: not switched under the other tests");
            return;
        }
        let best = SimdLevel::best_available();
        for requested in [SimdLevel::Avx2, SimdLevel::Avx512, SimdLevel::Avx2] {
            let got = force(requested);
            assert_eq!(got, requested.min(best), "asked for {requested:?} on a CPU whose best is {best:?}");
            assert_eq!(level(), got);
            assert!(describe().starts_with(got.name()), "{}", describe());
        }
        assert_eq!(force(before), before);
        assert_eq!(level(), before);
    }
}
