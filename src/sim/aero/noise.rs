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

    /// v_air(x, t), reusing the lattice values of the cell last visited.
    #[inline]
    pub(super) fn at(&self, x: Vec3, cell: &mut Cell) -> Vec3 {
        if self.steady {
            return self.mean;
        }
        let q = (x - self.shift) / self.scale + self.drift;
        self.mean + value_noise(q, cell) * self.amplitude
    }
}

/// ⌊v⌋, exactly as `f32::floor` (which the x86-64 baseline build calls
/// out of line): through the integer conversion while |v| < 2²³, above
/// which every f32 is an integer already.
#[inline]
fn floor(v: f32) -> f32 {
    if v.abs() < 8_388_608.0 {
        let t = v as i32 as f32;
        if t > v { t - 1.0 } else { t }
    } else {
        v
    }
}

/// The lattice values at the eight corners of the noise cell last
/// visited: gusts are far larger than the particle spacing, so neighbouring
/// particles mostly share a cell and its hashes are computed once.
#[derive(Clone, Copy, Debug, Default)]
pub(super) struct Cell {
    key: Option<[i32; 3]>,
    corners: [Vec3; 8],
}

impl Cell {
    /// The lattice values at the corners of the cell `key`, hashed only when
    /// it is not the cell last visited.
    fn corners_of(&mut self, key: [i32; 3]) -> &[Vec3; 8] {
        if self.key != Some(key) {
            let [ix, iy, iz] = key;
            for (k, corner) in self.corners.iter_mut().enumerate() {
                let k = k as i32;
                *corner = lattice(ix + (k & 1), iy + ((k >> 1) & 1), iz + (k >> 2));
            }
            self.key = Some(key);
        }
        &self.corners
    }
}

/// Value noise, each component in ±1: hashed lattice values in [−1, 1]³,
/// quintic interpolation (C² across cells, so the air's velocity and its
/// gradient are smooth). One octave: a second at half the size costs as
/// much again, and the flag's own flutter gives the finer detail.
fn value_noise(q: Vec3, cell: &mut Cell) -> Vec3 {
    let floor = Vec3::new(floor(q.x), floor(q.y), floor(q.z));
    let f = q - floor;
    let fade = f * f * f * (f * (f * 6.0 - 15.0) + 10.0);
    let key = [floor.x as i32, floor.y as i32, floor.z as i32];
    let c = cell.corners_of(key);
    let lerp = |a: Vec3, b: Vec3, t: f32| a + (b - a) * t;
    let x00 = lerp(c[0], c[1], fade.x);
    let x10 = lerp(c[2], c[3], fade.x);
    let x01 = lerp(c[4], c[5], fade.x);
    let x11 = lerp(c[6], c[7], fade.x);
    lerp(lerp(x00, x10, fade.y), lerp(x01, x11, fade.y), fade.z)
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
    fn the_floor_is_f32s_floor() {
        for v in
            [0.0f32, -0.0, 0.5, -0.5, 1.0, -1.0, 2.999_999_8, -2.999_999_8, 8_388_607.5, -8_388_607.5, 1e9, -1e9, 3e38]
        {
            assert_eq!(floor(v), v.floor(), "{v}");
        }
        assert!(floor(f32::NAN).is_nan());
        assert_eq!(floor(f32::INFINITY), f32::INFINITY);
        assert_eq!(floor(f32::NEG_INFINITY), f32::NEG_INFINITY);
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
