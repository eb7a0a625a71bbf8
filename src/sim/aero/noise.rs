//! The air's velocity: the mean wind plus gusts of smooth value noise.
//!
//! The air's velocity is the mean wind V plus gusts:
//!
//! ```text
//! v_air(x, t) = V + g_t |V| N((x − V t)/ℓ + c t/τ)
//! ```
//!
//! N is smooth value noise (a hashed lattice, quintic interpolation, one
//! octave; each component scaled to unit RMS), deterministic (the same
//! scene gives the same run), carried along by the mean wind (Taylor's
//! frozen turbulence: a gust travels down a flag at the wind's speed, so
//! the flag ripples along its length) and changing on the time scale τ on
//! its own (the drift c, a fixed unit vector); ℓ = τ = `gust_scale`.

use glam::Vec3;

use super::super::wind::Air;
use super::PointLanes;
#[cfg(test)]
use crate::sim::fast::kernel::F32x8;
use crate::sim::fast::kernel::{LANES, Point, Real};
use crate::sim::fast::rows::Rows;
#[cfg(target_arch = "x86_64")]
use crate::sim::fast::simd::{self, SimdLevel};
use crate::sim::fast::wide_lanes::Wide;

/// RMS of one component of the noise before scaling, measured
/// by `noise_has_unit_rms_per_component` over 200 000 samples.
const NOISE_RMS: f32 = 0.401;
/// The pattern's own drift through the noise, per τ (a fixed unit vector,
/// not along any lattice axis).
const DRIFT: Vec3 = Vec3::new(0.267, 0.534, 0.802);

/// v_air(x, t), m/s (module docs).
pub fn air_velocity(air: &Air, x: Vec3, time: f32) -> Vec3 {
    Field::new(air, time).at(x, &mut Cell::default())
}

/// v_air(·, t) at one time: what does not depend on x computed once per
/// substep, not per particle (the same operations in the same order, so
/// the same bits).
#[derive(Clone, Copy, Debug)]
pub(super) struct Field {
    /// V, m/s.
    mean: Vec3,
    /// V t, metres.
    shift: Vec3,
    /// ℓ, metres.
    scale: f32,
    /// c t/τ: the pattern's own drift.
    drift: Vec3,
    /// g_t |V| / RMS of the noise, m/s.
    amplitude: f32,
    /// No gusts (or no wind): the air is V everywhere.
    steady: bool,
}

impl Field {
    pub(super) fn new(air: &Air, time: f32) -> Self {
        let speed = air.velocity.length();
        let scale = air.gust_scale;
        Self {
            mean: air.velocity,
            shift: air.velocity * time,
            scale,
            drift: DRIFT * (time / scale),
            amplitude: air.gusts * speed / NOISE_RMS,
            steady: air.gusts == 0.0 || speed == 0.0,
        }
    }

    /// v_air(x, t), reusing the lattice values of the cells last visited.
    #[inline]
    pub(super) fn at(&self, x: Vec3, cell: &mut Cell) -> Vec3 {
        if self.steady {
            return self.mean;
        }
        let q = (x - self.shift) / self.scale + self.drift;
        self.mean + value_noise(q, cell) * self.amplitude
    }
}

impl Field {
    /// v_air at eight points in lanes, and how many of the first lanes lie
    /// in lane 0's cell of the noise: those k lanes have the bits of
    /// [`Self::at`], the others are to be dropped (their points go in the
    /// next group). `None` when lane 0's cell is not a cell (a NaN). The
    /// cell's lattice values are shared by the lanes, as the cache shares
    /// them between neighbouring particles.
    #[inline(always)]
    pub(super) fn at_lanes<T: Rows>(&self, x: Point<T>, cell: &mut Cell) -> Option<(Point<T>, usize)> {
        if self.steady {
            return Some((self.mean_lanes(), LANES));
        }
        let (q, floor) = self.lattice_point(x);
        // A lane is in lane 0's cell when its floors equal lane 0's (NaN
        // never does; −0 and 0 are one cell, and each lane keeps its own
        // floor in t).
        let first = [floor[0].first(), floor[1].first(), floor[2].first()];
        let shared = in_cell(&floor, first).trailing_ones() as usize;
        if shared == 0 {
            return None;
        }
        let c = cell.corners_of(first.map(|f| f as i32));
        Some((self.blend(&splat_corners(c), q, floor), shared))
    }

    /// V in every lane.
    #[inline(always)]
    fn mean_lanes<T: Real>(&self) -> Point<T> {
        [T::splat(self.mean.x), T::splat(self.mean.y), T::splat(self.mean.z)]
    }

    /// The points' coordinates q in the lattice of the noise, and their
    /// floors (the cells).
    #[inline(always)]
    fn lattice_point<T: Real>(&self, x: Point<T>) -> (Point<T>, Point<T>) {
        let (shift, drift, scale) = (self.shift.to_array(), self.drift.to_array(), T::splat(self.scale));
        let q: Point<T> = [
            (x[0] - T::splat(shift[0])) / scale + T::splat(drift[0]),
            (x[1] - T::splat(shift[1])) / scale + T::splat(drift[1]),
            (x[2] - T::splat(shift[2])) / scale + T::splat(drift[2]),
        ];
        (q, [q[0].floor(), q[1].floor(), q[2].floor()])
    }

    /// V + amplitude · N at lattice points q in cells `floor`, from each
    /// lane's corner values.
    #[inline(always)]
    fn blend<T: Real>(&self, corners: &[Point<T>; 8], q: Point<T>, floor: Point<T>) -> Point<T> {
        let t = [fade(q[0] - floor[0]), fade(q[1] - floor[1]), fade(q[2] - floor[2])];
        let noise = interpolate_lanes(corners, t);
        let (mean, amplitude) = (self.mean_lanes::<T>(), T::splat(self.amplitude));
        [mean[0] + noise[0] * amplitude, mean[1] + noise[1] * amplitude, mean[2] + noise[2] * amplitude]
    }

    /// v_air at eight points in lanes, whichever cells of the noise they
    /// fall in: each lane blends the lattice values of its own cell, which
    /// `held` keeps from the last points it was given. Only the lanes whose
    /// cell changed take new values (one cell's values taken by every lane
    /// in it, cell after cell), then one interpolation serves all eight.
    /// Each lane has the bits of [`Self::at`]; a lane whose point is not a
    /// point (a NaN) is NaN. For points a solver's lanes hold (a slot:
    /// eight particles a block of columns apart), which span several cells
    /// where neighbours in scene order mostly share one
    /// ([`Self::at_lanes`]); slot after slot along a block's row, a lane
    /// stays in its cell for many slots.
    #[inline(always)]
    pub(super) fn at_held_lanes<T: Rows>(&self, x: Point<T>, held: &mut LaneCells<T>, cell: &mut Cell) -> Point<T> {
        if self.steady {
            return self.mean_lanes();
        }
        let (q, floor) = self.lattice_point(x);
        let all = (1u32 << LANES) - 1;
        // A NaN floor equals nothing: a lost lane is looked at every time.
        let kept = floor[0].equal_bits(held.floor[0])
            & floor[1].equal_bits(held.floor[1])
            & floor[2].equal_bits(held.floor[2]);
        if kept != all {
            let floors = [floor[0].to_values(), floor[1].to_values(), floor[2].to_values()];
            let mut left = all & !kept;
            while left != 0 {
                let l = left.trailing_zeros() as usize;
                let f = [floors[0][l], floors[1][l], floors[2][l]];
                let same = in_cell(&floor, f);
                left &= !same & !(1 << l);
                if same == 0 {
                    // A NaN, which no cell takes: the lane keeps whatever it
                    // held, and its NaN offsets make it NaN.
                    continue;
                }
                // The floors are whole numbers: the sum of their distances
                // to the cell's is 0 in the cell and at least 1 elsewhere
                // (NaN for a NaN). A kept lane in this cell takes the
                // values it holds.
                let off = (floor[0] - T::splat(f[0])).abs()
                    + (floor[1] - T::splat(f[1])).abs()
                    + (floor[2] - T::splat(f[2])).abs();
                let half = T::splat(0.5);
                let values = cell.corners_of([f[0] as i32, f[1] as i32, f[2] as i32]);
                for (lanes, c) in held.corners.iter_mut().zip(values) {
                    for k in 0..3 {
                        lanes[k] = T::if_greater(half, off, T::splat(c[k]), lanes[k]);
                    }
                }
            }
            held.floor = floor;
        }
        self.blend(&held.corners, q, floor)
    }
}

/// Each lane's cell of the noise (its floors) and that cell's lattice
/// values at its eight corners, held from one call of
/// [`Field::at_held_lanes`] to the next. Empty at first (NaN floors,
/// which no lane's floor equals).
pub(super) struct LaneCells<T> {
    floor: Point<T>,
    corners: [Point<T>; 8],
}

impl<T: Real> Default for LaneCells<T> {
    fn default() -> Self {
        let nan = T::splat(f32::NAN);
        Self { floor: [nan; 3], corners: [[nan; 3]; 8] }
    }
}

/// Bit l set where lane l's cell (its floors) is the cell `f`.
#[inline(always)]
fn in_cell<T: Rows>(floor: &Point<T>, f: [f32; 3]) -> u32 {
    floor[0].equal_bits(T::splat(f[0])) & floor[1].equal_bits(T::splat(f[1])) & floor[2].equal_bits(T::splat(f[2]))
}

/// u_i = v_air(x_i) − (x_i − x_prev_i)/`dt` for each particle into
/// `relative`, eight at a time where they share a cell of the noise (the
/// bits of one at a time in every case); positions and velocities in and
/// out as `[x, y, z, 0]` rows (with AVX2 one load a row and a transpose of
/// eight rows, [`Rows`]).
#[allow(unsafe_code)]
pub(super) fn relative_air(field: &Field, dt: f32, x: &[[f32; 4]], x_prev: &[[f32; 4]], relative: &mut [[f32; 4]]) {
    #[cfg(target_arch = "x86_64")]
    if simd::level() >= SimdLevel::Avx2 {
        // SAFETY: the level is AVX2 or above only when the CPU reports AVX2
        // and FMA, the features `avx2::relative_air` is compiled for.
        unsafe { avx2::relative_air(field, dt, x, x_prev, relative) };
        return;
    }
    // Without AVX2: the `wide` crate's vectors (NEON, SSE).
    relative_in::<Wide>(field, dt, x, x_prev, relative);
}

/// [`relative_air`] in AVX registers.
#[cfg(target_arch = "x86_64")]
mod avx2 {
    use super::{Field, PointLanes, relative_in, relative_lanes_in};
    use crate::sim::fast::avx::Avx;

    #[target_feature(enable = "avx2,fma")]
    pub(super) fn relative_air(field: &Field, dt: f32, x: &[[f32; 4]], x_prev: &[[f32; 4]], relative: &mut [[f32; 4]]) {
        relative_in::<Avx>(field, dt, x, x_prev, relative);
    }

    #[target_feature(enable = "avx2,fma")]
    pub(super) fn relative_lanes(
        field: &Field,
        dt: f32,
        x: &[PointLanes],
        d: &[PointLanes],
        relative: &mut [PointLanes],
    ) {
        relative_lanes_in::<Avx>(field, dt, x, d, relative);
    }
}

/// [`relative_air`] on points in lanes ([`PointLanes`], eight places an
/// element, as a solver's lanes hold them): u = v_air(x) − d/`dt`, with d
/// = x − x_prev the displacement the solver keeps. Eight places at a time
/// whichever cells of the noise they fall in ([`Field::at_held_lanes`]); no
/// transposes in or out.
#[allow(unsafe_code)]
pub(super) fn relative_lanes(field: &Field, dt: f32, x: &[PointLanes], d: &[PointLanes], relative: &mut [PointLanes]) {
    #[cfg(target_arch = "x86_64")]
    if simd::level() >= SimdLevel::Avx2 {
        // SAFETY: the level is AVX2 or above only when the CPU reports AVX2
        // and FMA, the features `avx2::relative_lanes` is compiled for.
        unsafe { avx2::relative_lanes(field, dt, x, d, relative) };
        return;
    }
    relative_lanes_in::<Wide>(field, dt, x, d, relative);
}

/// [`relative_lanes`] on lanes of type `T`.
#[inline(always)]
fn relative_lanes_in<T: Rows>(field: &Field, dt: f32, x: &[PointLanes], d: &[PointLanes], relative: &mut [PointLanes]) {
    let (mut cell, mut held) = (Cell::default(), LaneCells::default());
    let dt = T::splat(dt);
    for ((u, x), d) in relative.iter_mut().zip(x).zip(d) {
        let x = [T::from_values(x[0]), T::from_values(x[1]), T::from_values(x[2])];
        let d = [T::from_values(d[0]), T::from_values(d[1]), T::from_values(d[2])];
        let air = field.at_held_lanes(x, &mut held, &mut cell);
        u[0] = (air[0] - d[0] / dt).to_values();
        u[1] = (air[1] - d[1] / dt).to_values();
        u[2] = (air[2] - d[2] / dt).to_values();
    }
}

/// [`relative_air`] on lanes of type `T`.
#[inline(always)]
fn relative_in<T: Rows>(field: &Field, dt: f32, x: &[[f32; 4]], x_prev: &[[f32; 4]], relative: &mut [[f32; 4]]) {
    let mut cell = Cell::default();
    let one_at_a_time = |u: &mut [[f32; 4]], x: &[[f32; 4]], x_prev: &[[f32; 4]], cell: &mut Cell| {
        for ((u, x), x_prev) in u.iter_mut().zip(x).zip(x_prev) {
            let (x, x_prev) = (Vec3::new(x[0], x[1], x[2]), Vec3::new(x_prev[0], x_prev[1], x_prev[2]));
            *u = (field.at(x, cell) - (x - x_prev) / dt).extend(0.0).to_array();
        }
    };
    // Eight particles from `next`: the first k in one noise cell take the
    // lanes' values, and the next group starts at the first particle of the
    // next cell (so a group across a cell's edge costs two groups, not eight
    // particles one at a time).
    let mut next = 0;
    while next + LANES <= relative.len() {
        let index: [usize; LANES] = std::array::from_fn(|l| next + l);
        let [px, py, pz, _] = T::gather(x, &index);
        let Some((air, shared)) = field.at_lanes([px, py, pz], &mut cell) else {
            one_at_a_time(&mut relative[next..next + 1], &x[next..], &x_prev[next..], &mut cell);
            next += 1;
            continue;
        };
        let [qx, qy, qz, _] = T::gather(x_prev, &index);
        let dt = T::splat(dt);
        let velocity = [(px - qx) / dt, (py - qy) / dt, (pz - qz) / dt];
        let zero = T::splat(0.0);
        let rows = T::to_rows([air[0] - velocity[0], air[1] - velocity[1], air[2] - velocity[2], zero]);
        // A whole group as a fixed-size copy (register stores); a copy of
        // `shared` rows is a call to `memmove`.
        if shared == LANES {
            relative[next..next + LANES].copy_from_slice(&rows);
        } else {
            relative[next..next + shared].copy_from_slice(&rows[..shared]);
        }
        next += shared;
    }
    one_at_a_time(&mut relative[next..], &x[next..], &x_prev[next..], &mut cell);
}

/// a + (b − a) t: for `f32` coordinates or lanes of them.
#[inline(always)]
fn lerp<T: Real>(a: T, b: T, t: T) -> T {
    a + (b - a) * t
}

/// The quintic fade 6f⁵ − 15f⁴ + 10f³ as f·f·f·(f·(f·6 − 15) + 10).
#[inline(always)]
fn fade<T: Real>(f: T) -> T {
    f * f * f * (f * (f * T::splat(6.0) - T::splat(15.0)) + T::splat(10.0))
}

/// The lattice values at the eight corners of the last few noise cells
/// visited: gusts are far larger than the particle spacing, so neighbouring
/// particles mostly share a cell and its hashes are computed once. Eight
/// cells, each in the entry its key picks: a row of particles crosses a few
/// cells and the next row starts in the first of them again (with one
/// cell, a 256 × 256 cloth hashed ~40 cells for every 8 rows it visited).
#[derive(Clone, Copy, Debug, Default)]
pub(super) struct Cell {
    entries: [(Option<[i32; 3]>, [Vec3; 8]); 8],
}

impl Cell {
    /// The lattice values at the corners of the cell `key`, hashed only when
    /// its entry holds another cell. Inlined: called out of line, the key
    /// went through memory as three 4-byte stores and an 8-byte load, which
    /// the CPU cannot forward (a stall on every call).
    #[inline(always)]
    fn corners_of(&mut self, key: [i32; 3]) -> &[Vec3; 8] {
        let [ix, iy, iz] = key;
        let entry = ix.wrapping_add(iy.wrapping_mul(3)).wrapping_add(iz.wrapping_mul(5)) & 7;
        let (held, corners) = &mut self.entries[entry as usize];
        // Compared coordinate by coordinate with the key's registers: as
        // `*held != Some(key)` the key went to the stack as three 4-byte
        // stores and came back as an 8-byte load (the same stall as above).
        if held.is_none_or(|[hx, hy, hz]| (hx ^ ix) | (hy ^ iy) | (hz ^ iz) != 0) {
            *held = Some(key);
            hash_corners(key, corners);
        }
        corners
    }
}

/// The lattice values at the eight corners of the cell `key`.
#[inline(never)]
fn hash_corners([ix, iy, iz]: [i32; 3], corners: &mut [Vec3; 8]) {
    for (k, corner) in corners.iter_mut().enumerate() {
        let k = k as i32;
        *corner = lattice(ix.wrapping_add(k & 1), iy.wrapping_add((k >> 1) & 1), iz.wrapping_add(k >> 2));
    }
}

/// Value noise, each component in ±1: hashed lattice values in [−1, 1]³,
/// quintic interpolation (C² across cells, so the air's velocity and its
/// gradient are smooth). One octave: a second at half the size costs as
/// much again, and the flag's own flutter gives the finer detail.
#[inline(always)]
fn value_noise(q: Vec3, cell: &mut Cell) -> Vec3 {
    let floor = Vec3::new(Real::floor(q.x), Real::floor(q.y), Real::floor(q.z));
    let f = q - floor;
    let t = Vec3::new(fade(f.x), fade(f.y), fade(f.z));
    let key = [floor.x as i32, floor.y as i32, floor.z as i32];
    Vec3::from_array(interpolate(cell.corners_of(key), t.to_array()))
}

/// The corners' values `c` (x fastest, then y, then z) blended at the faded
/// offsets `t`, component by component: for one point (`f32`) or for lanes
/// of points in one cell, the same operations in the same order.
#[inline(always)]
fn interpolate<T: Real>(c: &[Vec3; 8], t: Point<T>) -> Point<T> {
    interpolate_lanes(&splat_corners(c), t)
}

/// One cell's corner values in every lane (`from_fn`: an array's `map`
/// was left out of line).
#[inline(always)]
fn splat_corners<T: Real>(c: &[Vec3; 8]) -> [Point<T>; 8] {
    std::array::from_fn(|i| [T::splat(c[i].x), T::splat(c[i].y), T::splat(c[i].z)])
}

/// [`interpolate`] with each lane's own corner values (lanes in several
/// cells: [`Field::at_held_lanes`]); the same operations in the same order.
#[inline(always)]
fn interpolate_lanes<T: Real>(c: &[Point<T>; 8], t: Point<T>) -> Point<T> {
    [interpolate_axis(c, t, 0), interpolate_axis(c, t, 1), interpolate_axis(c, t, 2)]
}

/// Component `k` of [`interpolate_lanes`]. A function, not a closure: a
/// closure left out of line lacks the AVX features of the lanes' caller,
/// and its lanes became calls (the air step 40 % slower).
#[inline(always)]
fn interpolate_axis<T: Real>(c: &[Point<T>; 8], t: Point<T>, k: usize) -> T {
    let x00 = lerp(c[0][k], c[1][k], t[0]);
    let x10 = lerp(c[2][k], c[3][k], t[0]);
    let x01 = lerp(c[4][k], c[5][k], t[0]);
    let x11 = lerp(c[6][k], c[7][k], t[0]);
    lerp(lerp(x00, x10, t[1]), lerp(x01, x11, t[1]), t[2])
}

/// Three values in [−1, 1] from a lattice point (a 32-bit integer hash,
/// the finaliser of MurmurHash3, ten bits per value).
fn lattice(x: i32, y: i32, z: i32) -> Vec3 {
    let mut h = (x as u32).wrapping_mul(0x8da6_b343)
        ^ (y as u32).wrapping_mul(0xd816_3841)
        ^ (z as u32).wrapping_mul(0xcb1a_b31f);
    h ^= h >> 16;
    h = h.wrapping_mul(0x85eb_ca6b);
    h ^= h >> 13;
    h = h.wrapping_mul(0xc2b2_ae35);
    h ^= h >> 16;
    let unit = |bits: u32| (bits & 1023) as f32 / 511.5 - 1.0;
    Vec3::new(unit(h), unit(h >> 10), unit(h >> 20))
}

#[cfg(test)]
mod tests {
    use super::*;

    fn air() -> Air {
        Air { velocity: Vec3::new(8.0, 0.0, 0.0), gusts: 0.0, lift: 0.0, ..Air::default() }
    }

    #[test]
    fn noise_has_unit_rms_per_component_and_is_smooth_and_deterministic() {
        let mut sum = Vec3::ZERO;
        let count = 200_000;
        for k in 0..count {
            let q = Vec3::new(k as f32 * 0.173, (k % 997) as f32 * 0.311, (k % 313) as f32 * 0.129);
            let v = value_noise(q, &mut Cell::default()) / NOISE_RMS;
            sum += v * v;
        }
        let rms = (sum / count as f32).map(f32::sqrt);
        assert!((rms - Vec3::ONE).abs().max_element() < 0.08, "{rms}");
        // Smooth: a step of 1e-3 cells changes it by far less than its size.
        let q = Vec3::new(3.3, -1.7, 8.2);
        let noise = |q: Vec3| value_noise(q, &mut Cell::default());
        assert!((noise(q) - noise(q + Vec3::splat(1e-3))).length() < 0.02);
        assert_eq!(noise(q), noise(q));
        // The cell cache gives the same values as a fresh evaluation.
        let mut cell = Cell::default();
        for k in 0..100 {
            let p = q + Vec3::new(k as f32 * 0.031, 0.0, k as f32 * 0.017);
            assert_eq!(value_noise(p, &mut cell), noise(p));
        }
    }

    #[test]
    fn lanes_give_each_particle_the_bits_of_one_at_a_time() {
        // 203 particles along a 2.03 m line in 8 m/s air with 30 % gusts of
        // 1 m, at t = 0.37 s, one of them lost (NaN): groups of eight take
        // the lanes up to a cell's edge (or the lost particle), the next
        // group starting there; the lost one and the last few go one at a
        // time. Every particle gets the bits of the one-particle form.
        let a = Air { gusts: 0.3, ..air() };
        let field = Field::new(&a, 0.37);
        let mut x: Vec<Vec3> = (0..203).map(|k| Vec3::new(k as f32 * 0.01, 0.3 + k as f32 * 1e-3, -0.2)).collect();
        x[100].y = f32::NAN;
        let x_prev: Vec<Vec3> = x.iter().map(|p| *p - Vec3::new(0.001, -0.002, 0.0005)).collect();
        let rows = |p: &[Vec3]| p.iter().map(|p| p.extend(0.0).to_array()).collect::<Vec<_>>();
        let mut relative = vec![[f32::NAN; 4]; x.len()];
        relative_air(&field, 0.01, &rows(&x), &rows(&x_prev), &mut relative);
        let bits = |v: Vec3| v.extend(0.0).to_array().map(f32::to_bits);
        for k in (0..x.len()).filter(|&k| k != 100) {
            let alone = field.at(x[k], &mut Cell::default()) - (x[k] - x_prev[k]) / 0.01;
            assert_eq!(relative[k].map(f32::to_bits), bits(alone), "particle {k}");
        }
        assert!(relative[100][..3].iter().all(|u| u.is_nan()), "the lost particle's air is unknown");
        // The portable lanes give the level's bits (AVX2 loads and
        // transposes where the CPU has it).
        let mut portable = vec![[f32::NAN; 4]; x.len()];
        relative_in::<Wide>(&field, 0.01, &rows(&x), &rows(&x_prev), &mut portable);
        let bits_but_lost = |u: &[[f32; 4]]| {
            u.iter().enumerate().filter(|&(k, _)| k != 100).map(|(_, u)| u.map(f32::to_bits)).collect::<Vec<_>>()
        };
        assert_eq!(bits_but_lost(&portable), bits_but_lost(&relative));
        // Both ways were taken: most groups of eight share a cell, some
        // cross an edge. (Counted with the portable lanes; the equal mask
        // at every level the CPU has is checked by `Rows`'s own test.)
        let lanes = |group: &[Vec3]| {
            let at = [0, 1, 2].map(|k| F32x8(std::array::from_fn(|l| group[l][k])));
            field.at_lanes(at, &mut Cell::default()).is_some_and(|(_, shared)| shared == LANES)
        };
        let shared = x.chunks_exact(LANES).filter(|g| lanes(g)).count();
        assert!((20..25).contains(&shared), "{shared} of 25 groups in lanes");
        // Steady air: the mean in every lane.
        let steady = Field::new(&air(), 0.37);
        let at = [F32x8::splat(1.0), F32x8::splat(2.0), F32x8::splat(3.0)];
        assert_eq!(steady.at_lanes(at, &mut Cell::default()).map(|(v, k)| (v[0].0, k)), Some(([8.0; LANES], LANES)));
    }

    #[test]
    fn lanes_in_several_cells_give_each_place_the_bits_of_one_at_a_time() {
        // Six slots of eight lanes 16 cm apart (as a grid's lanes hold a
        // row: eight particles a block of columns apart), in 8 m/s air with
        // 30 % gusts of 1 m at t = 0.37 s: 1.12 m across, most slots reach
        // into two or three cells of the noise. Slot 3 has a lost particle
        // (NaN) in lane 5; slot 5 lies within 7 mm, in one cell.
        let a = Air { gusts: 0.3, ..air() };
        let field = Field::new(&a, 0.37);
        let point = |e: usize, l: usize| {
            let spacing = if e == 5 { 0.001 } else { 0.16 };
            Vec3::new(0.05 + e as f32 * 0.23 + l as f32 * spacing, 0.3 - e as f32 * 0.4, -0.2 + l as f32 * 0.01)
        };
        let d = |e: usize, l: usize| Vec3::new(0.001 * l as f32, -0.002, 0.0005 * e as f32);
        let lanes = |f: &dyn Fn(usize, usize) -> Vec3, e: usize| -> PointLanes {
            [0, 1, 2].map(|k| std::array::from_fn(|l| f(e, l)[k]))
        };
        let mut x: Vec<PointLanes> = (0..6).map(|e| lanes(&point, e)).collect();
        x[3][1][5] = f32::NAN;
        let displacement: Vec<PointLanes> = (0..6).map(|e| lanes(&d, e)).collect();
        let mut relative = vec![[[f32::NAN; LANES]; 3]; 6];
        relative_lanes(&field, 0.01, &x, &displacement, &mut relative);
        for e in 0..6 {
            for l in 0..LANES {
                let at = Vec3::new(x[e][0][l], x[e][1][l], x[e][2][l]);
                let u = Vec3::new(relative[e][0][l], relative[e][1][l], relative[e][2][l]);
                if (e, l) == (3, 5) {
                    assert!(u.is_nan(), "the lost particle's air is unknown");
                    continue;
                }
                let alone = field.at(at, &mut Cell::default()) - d(e, l) / 0.01;
                assert_eq!(u.to_array().map(f32::to_bits), alone.to_array().map(f32::to_bits), "slot {e}, lane {l}");
            }
        }
        // The portable lanes give the level's bits.
        let mut portable = vec![[[f32::NAN; LANES]; 3]; 6];
        relative_lanes_in::<Wide>(&field, 0.01, &x, &displacement, &mut portable);
        let bits = |r: &[PointLanes]| r.iter().flatten().flatten().map(|v| v.to_bits()).collect::<Vec<_>>();
        assert_eq!(bits(&portable), bits(&relative));
        // Every way was taken: slots across cells, and one in a single cell;
        // from one slot to the next, lanes that keep their cell (the values
        // held) and lanes that change it (new values), besides the lost lane
        // and the one after it.
        let cell_of = |e: usize, l: usize| {
            ((point(e, l) - field.shift) / field.scale + field.drift).floor().as_ivec3().to_array()
        };
        let cells = |e: usize| {
            let mut cells: Vec<[i32; 3]> = (0..LANES).filter(|&l| (e, l) != (3, 5)).map(|l| cell_of(e, l)).collect();
            cells.sort();
            cells.dedup();
            cells.len()
        };
        assert!((0..6).filter(|&e| cells(e) > 1).count() >= 3, "{:?}", (0..6).map(cells).collect::<Vec<_>>());
        assert_eq!(cells(5), 1);
        let kept =
            (1..6).flat_map(|e| (0..LANES).map(move |l| (e, l))).filter(|&(e, l)| cell_of(e, l) == cell_of(e - 1, l));
        let kept = kept.count();
        assert!((5..35).contains(&kept), "{kept} of 40 lanes kept their cell from the slot before");
    }

    #[test]
    fn gusts_vary_the_air_along_the_wind_and_average_to_the_mean() {
        let a = Air { gusts: 0.3, gust_scale: 1.5, ..air() };
        // 2000 points 1.5 m apart on a plane: about 2000 independent gusts.
        let samples: Vec<Vec3> = (0..2000)
            .map(|k| air_velocity(&a, Vec3::new((k % 50) as f32 * 1.5, 0.3, (k / 50) as f32 * 1.5), 0.0))
            .collect();
        let mean = samples.iter().sum::<Vec3>() / samples.len() as f32;
        let spread = (samples.iter().map(|v| (*v - mean).length_squared()).sum::<f32>() / 2000.0).sqrt();
        // 3 components of RMS 0.3 · 8 = 2.4 m/s: about 4.2 m/s together; the
        // mean of ~2000 gusts is within 4.2/√2000 ≈ 0.1 m/s of V, say 0.4.
        assert!((mean - a.velocity).length() < 0.4, "{mean}");
        assert!((2.5..6.0).contains(&spread), "{spread}");
        // Steady air is the mean everywhere.
        assert_eq!(air_velocity(&air(), Vec3::new(1.0, 2.0, 3.0), 4.0), air().velocity);
    }
}
