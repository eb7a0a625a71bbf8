//! Wind: the seed's equation 4, a constant force, or moving air.
//!
//! The first three models are one force on every particle alike ("none",
//! "seed", "constant"). [`Wind::Air`] is a velocity field instead: the force
//! then depends on each triangle's orientation and motion and is computed by
//! the aerodynamics phase ([`super::aero`]).
//!
//! The seed's wind is one force applied to every particle:
//!
//! ```text
//! f_w(t) = ( 5 + 2·sin(t/2),  6 + 6·sin(t/2),  −2 + sin(t/2) )      (4)
//! ```
//!
//! where t is a time in milliseconds. The seed reads the wall clock ("since
//! the day's start"); drape uses the *simulated* time, t = 1000·(steps·h),
//! so that a run is reproducible. With h = 50 ms the sine advances 25 radians
//! a step, so the wind the cloth feels is an irregular gust sequence rather
//! than a smooth oscillation, as in the seed.

use glam::Vec3;
use serde::{Deserialize, Serialize};

use super::params::{ParamError, check_force};

/// Largest accepted magnitude of [`Wind::Seed`]'s `scale`.
pub const MAX_WIND_SCALE: f32 = 1e4;

/// The wind model: a force in newtons on every free particle, or moving air.
#[derive(Clone, Copy, Debug, Default, PartialEq, Serialize, Deserialize)]
#[serde(tag = "model", rename_all = "kebab-case")]
pub enum Wind {
    /// No wind; the solver skips the wind evaluation entirely.
    #[default]
    None,
    /// The seed's equation 4 evaluated at the simulated time, times `scale`.
    Seed {
        /// Multiplies the seed's force. Dimensionless, range ±1e4, default 1.
        scale: f32,
    },
    /// The same force at all times.
    Constant {
        /// The force in newtons; finite components within ±1e9.
        force: Vec3,
    },
    /// Moving air: drag and lift on every triangle ([`super::aero`]).
    Air(Air),
}

/// Largest accepted mean air speed, m/s.
pub const MAX_AIR_SPEED: f32 = 1000.0;

/// Moving air: a mean velocity with smooth, deterministic turbulence, and
/// the coefficients of drag and lift on the cloth's triangles.
#[derive(Clone, Copy, Debug, PartialEq, Serialize, Deserialize)]
#[serde(default)]
pub struct Air {
    /// V: the mean wind velocity, m/s; finite, each component within ±1000.
    /// Default (0, 0, 0) (still air, which still resists motion).
    pub velocity: Vec3,
    /// g_t: the turbulence's RMS speed per component as a share of |V|.
    /// Dimensionless, range `0 ..= 10`, default 0 (steady).
    pub gusts: f32,
    /// ℓ = τ: the size of the turbulence's features, in metres and seconds.
    /// Range `0.01 ..= 1000`, default 1.
    pub gust_scale: f32,
    /// ρ: the air's density, kg/m³. Range `0 ..= 1000`, default 1.2 (air at
    /// 20 °C; water is 1000).
    pub density: f32,
    /// C_d: the drag coefficient of a flat plate face-on. Range `0 ..= 10`,
    /// default 1.0 (a flat plate is 1.1–1.3; NvCloth's samples use 0.4–1).
    pub drag: f32,
    /// C_l: the lift coefficient. Range `0 ..= 10`, default 0.2.
    pub lift: f32,
}

impl Default for Air {
    fn default() -> Self {
        Self { velocity: Vec3::ZERO, gusts: 0.0, gust_scale: 1.0, density: 1.2, drag: 1.0, lift: 0.2 }
    }
}

impl Air {
    /// Checks every number against its documented range.
    pub fn validate(&self) -> Result<(), ParamError> {
        let v = self.velocity;
        if !(v.is_finite() && v.abs().max_element() <= MAX_AIR_SPEED) {
            let value = format!("[{}, {}, {}]", v.x, v.y, v.z);
            return Err(ParamError::new("wind.velocity", value, "m/s, finite components within ±1000"));
        }
        let checks: [(&'static str, f32, f32, f32, &'static str); 5] = [
            ("wind.gusts", self.gusts, 0.0, 10.0, "0 <= gusts <= 10 (a share of the mean speed)"),
            ("wind.gust_scale", self.gust_scale, 0.01, 1000.0, "metres and seconds, 0.01 <= gust_scale <= 1000"),
            ("wind.density", self.density, 0.0, 1000.0, "kg/m³, 0 <= density <= 1000 (air is 1.2)"),
            ("wind.drag", self.drag, 0.0, 10.0, "0 <= drag <= 10"),
            ("wind.lift", self.lift, 0.0, 10.0, "0 <= lift <= 10"),
        ];
        for (name, value, low, high, allowed) in checks {
            if !(low..=high).contains(&value) {
                return Err(ParamError::new(name, value, allowed));
            }
        }
        Ok(())
    }
}

impl Wind {
    /// The force on every particle alike at simulated time `time` (seconds
    /// since the start); zero for [`Wind::Air`], whose force is per triangle.
    pub fn force(&self, time: f64) -> Vec3 {
        match *self {
            Wind::None | Wind::Air(_) => Vec3::ZERO,
            Wind::Seed { scale } => seed_wind(time) * scale,
            Wind::Constant { force } => force,
        }
    }

    /// True when the model never produces a force on every particle alike,
    /// so the solver can skip it ([`Wind::Air`] acts per triangle instead).
    pub fn is_none(&self) -> bool {
        match *self {
            Wind::None | Wind::Air(_) => true,
            Wind::Seed { scale } => scale == 0.0,
            Wind::Constant { force } => force == Vec3::ZERO,
        }
    }

    /// Checks the model's numbers against their documented ranges.
    pub fn validate(&self) -> Result<(), ParamError> {
        match *self {
            Wind::None => Ok(()),
            Wind::Seed { scale } => {
                if scale.is_finite() && scale.abs() <= MAX_WIND_SCALE {
                    Ok(())
                } else {
                    Err(ParamError::new("wind.scale", scale, "a finite number within ±10000"))
                }
            }
            Wind::Constant { force } => check_force("wind.vector", force),
            Wind::Air(air) => air.validate(),
        }
    }

    /// The air, when the model is [`Wind::Air`].
    pub fn air(&self) -> Option<&Air> {
        match self {
            Wind::Air(air) => Some(air),
            _ => None,
        }
    }
}

/// Equation 4 at simulated time `time` seconds (t = 1000·time milliseconds).
pub fn seed_wind(time: f64) -> Vec3 {
    let t_ms = time * 1000.0;
    // Evaluated in f64: t reaches 1e8 ms in a day of simulated time, where an
    // f32 argument would have lost all of the sine's phase.
    let s = (t_ms / 2.0).sin() as f32;
    Vec3::new(5.0 + 2.0 * s, 6.0 + 6.0 * s, -2.0 + s)
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn seed_wind_at_zero_is_the_constant_part() {
        assert_eq!(seed_wind(0.0), Vec3::new(5.0, 6.0, -2.0));
    }

    #[test]
    fn seed_wind_uses_milliseconds() {
        // t = π ms → sin(π/2) = 1 → (7, 12, −1).
        let w = seed_wind(std::f64::consts::PI / 1000.0);
        assert!((w - Vec3::new(7.0, 12.0, -1.0)).abs().max_element() < 1e-5, "{w}");
        // t = 3π ms → sin(3π/2) = −1 → (3, 0, −3).
        let w = seed_wind(3.0 * std::f64::consts::PI / 1000.0);
        assert!((w - Vec3::new(3.0, 0.0, -3.0)).abs().max_element() < 1e-5, "{w}");
    }

    #[test]
    fn scale_multiplies_and_none_is_zero() {
        let t = 0.123;
        assert_eq!(Wind::Seed { scale: 2.0 }.force(t), 2.0 * seed_wind(t));
        assert_eq!(Wind::None.force(t), Vec3::ZERO);
        assert!(Wind::None.is_none() && Wind::Seed { scale: 0.0 }.is_none());
        assert!(!Wind::Seed { scale: 1.0 }.is_none());
    }
}
