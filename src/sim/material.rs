//! Fabric presets: density, stiffness, friction, thickness and the air's
//! coefficients of a named material, in the units of [`super::units`].
//!
//! # Where the figures come from
//!
//! Fabric mechanics are measured with the Kawabata Evaluation System
//! (KES-F: Kawabata, *The Standardization and Analysis of Hand Evaluation*,
//! 2nd ed., Textile Machinery Society of Japan, 1980; typical values for
//! shirting, suiting, denim and knits are tabulated in Kawabata & Niwa,
//! *Fabric performance in clothing and clothing manufacture*, J. Textile
//! Inst. 80(1), 19–50, 1989) or with FAST. drape converts their units:
//!
//! - **Bending rigidity** B (KES-FB2) is given in gf·cm²/cm;
//!   1 gf·cm²/cm = 9.807 × 10⁻⁵ N·m.
//! - **Tensile** (KES-FB1): EMT is the strain (%) at a load of 500 gf/cm
//!   = 490 N/m; drape's stretch stiffness is the secant k_s = 490 N/m / EMT.
//! - **Area density** W (g/m²) from the fabric's specification; the ranges
//!   are silk 30–80, cotton shirting 100–200, denim 300–450, garment
//!   leather 600–1200 g/m².
//! - **Thickness** T₀ (KES-FB3, at 0.5 gf/cm²).
//!
//! Rubber is not a fabric: its figures are natural rubber's (density
//! 930 kg/m³, Young's modulus E ≈ 1.5 MPa at small strain, Poisson's ratio
//! 0.5: Gent, *Engineering with Rubber*, 3rd ed., 2012) for a 1 mm sheet:
//! k_s = E t, B = E t³ / (12 (1 − ν²)). Leather's modulus and thickness are
//! those of a garment hide (E ≈ 10 MPa at small strain, 1.2 mm).
//!
//! Each figure below is a representative value inside the published range
//! for that kind of fabric, rounded to one or two significant figures: a
//! starting point, not a measurement of one cloth. The friction
//! coefficients are those of fabric on smooth hard surfaces (0.2–0.6), the
//! drag and lift those of a flat plate (C_d ≈ 1–1.2; lower for an open knit).

use serde::{Deserialize, Serialize};

use super::params::SolverParams;
use super::wind::Wind;

/// A named fabric.
#[derive(Clone, Copy, Debug, PartialEq, Eq, Hash, Serialize, Deserialize)]
#[serde(rename_all = "kebab-case")]
pub enum Material {
    /// Cotton shirting (broadcloth, poplin).
    Cotton,
    /// Silk (habotai, crêpe de Chine).
    Silk,
    /// Denim, 12–14 oz.
    Denim,
    /// Garment leather.
    Leather,
    /// Cotton single jersey, a stretchy knit.
    Jersey,
    /// A 1 mm natural rubber sheet.
    Rubber,
}

/// What a [`Material`] sets.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct MaterialProperties {
    /// σ, kg/m².
    pub density: f32,
    /// k_s, N/m.
    pub stretch_stiffness: f32,
    /// B, N·m.
    pub bend_stiffness: f32,
    /// μ against colliders.
    pub friction: f32,
    /// The fabric's thickness, metres (the distance kept from colliders).
    pub thickness: f32,
    /// C_d.
    pub drag: f32,
    /// C_l.
    pub lift: f32,
}

impl Material {
    /// Every preset, for menus.
    pub const ALL: [Material; 6] =
        [Material::Cotton, Material::Silk, Material::Denim, Material::Leather, Material::Jersey, Material::Rubber];

    /// The name used in scene files and menus.
    pub fn name(self) -> &'static str {
        match self {
            Material::Cotton => "cotton",
            Material::Silk => "silk",
            Material::Denim => "denim",
            Material::Leather => "leather",
            Material::Jersey => "jersey",
            Material::Rubber => "rubber",
        }
    }

    /// The preset of this name, if there is one.
    pub fn from_name(name: &str) -> Option<Self> {
        Self::ALL.into_iter().find(|m| m.name() == name)
    }

    /// The preset's figures (module docs for their sources).
    pub fn properties(self) -> MaterialProperties {
        // (W g/m², EMT % or k_s, B gf·cm²/cm or N·m, μ, T₀ mm, C_d, C_l)
        let kes = |w: f32, emt: f32, b: f32, mu: f32, t: f32, cd: f32| MaterialProperties {
            density: w * 1e-3,
            stretch_stiffness: 490.0 / (emt / 100.0),
            bend_stiffness: b * 9.807e-5,
            friction: mu,
            thickness: t * 1e-3,
            drag: cd,
            lift: 0.2,
        };
        match self {
            // W 130 g/m², EMT 4 %, B 0.08 gf·cm²/cm, T₀ 0.3 mm.
            Material::Cotton => kes(130.0, 4.0, 0.08, 0.4, 0.3, 1.0),
            // W 60 g/m², EMT 7 %, B 0.02 gf·cm²/cm, T₀ 0.15 mm.
            Material::Silk => kes(60.0, 7.0, 0.02, 0.25, 0.15, 1.0),
            // W 400 g/m², EMT 2 %, B 1.0 gf·cm²/cm, T₀ 0.8 mm.
            Material::Denim => kes(400.0, 2.0, 1.0, 0.5, 0.8, 1.1),
            // W 150 g/m², EMT 40 %, B 0.03 gf·cm²/cm, T₀ 0.6 mm; a knit lets
            // air through (C_d 0.8).
            Material::Jersey => kes(150.0, 40.0, 0.03, 0.4, 0.6, 0.8),
            // 1.2 mm hide, 0.8 kg/m², E ≈ 10 MPa: k_s = E t = 12 000 N/m,
            // B = E t³ / 12 = 1.4e-3 N·m.
            Material::Leather => MaterialProperties {
                density: 0.8,
                stretch_stiffness: 1.2e4,
                bend_stiffness: 1.4e-3,
                friction: 0.5,
                thickness: 1.2e-3,
                drag: 1.2,
                lift: 0.2,
            },
            // 1 mm natural rubber: σ = 0.93 kg/m², k_s = E t = 1500 N/m,
            // B = E t³ / (12 · 0.75) = 1.7e-4 N·m, μ ≈ 0.9 on dry surfaces.
            Material::Rubber => MaterialProperties {
                density: 0.93,
                stretch_stiffness: 1.5e3,
                bend_stiffness: 1.7e-4,
                friction: 0.9,
                thickness: 1.0e-3,
                drag: 1.2,
                lift: 0.2,
            },
        }
    }

    /// Switches `params` to this fabric, as the viewer's menu and
    /// `--material` do: [`Self::apply`], and gravity given as the seed's
    /// force per particle becomes the acceleration it gave (f_g/m), since
    /// particles no longer weigh m. A contact thickness larger than the
    /// fabric's is kept: contact is per particle, so a scene sizes it to its
    /// particle spacing (a 4 cm grid over a 0.3 m ball needs at least the
    /// 0.7 mm its flat triangles cut into the ball; silk is 0.15 mm thick).
    pub fn select(self, params: &mut SolverParams) {
        if params.gravity_acceleration.is_none() {
            params.gravity_acceleration = Some(match params.density {
                None => params.gravity / params.mass,
                Some(_) => glam::Vec3::new(0.0, -9.81, 0.0),
            });
        }
        let thickness = params.thickness;
        self.apply(params);
        params.thickness = params.thickness.max(thickness);
    }

    /// Sets the preset's density, stiffness, friction and thickness in
    /// `params`, and its drag and lift when the wind is "air".
    pub fn apply(self, params: &mut SolverParams) {
        let p = self.properties();
        params.density = Some(p.density);
        params.stretch_stiffness = Some(p.stretch_stiffness);
        params.bend_stiffness = Some(p.bend_stiffness);
        params.friction = p.friction;
        params.thickness = p.thickness;
        if let Wind::Air(air) = &mut params.wind {
            air.drag = p.drag;
            air.lift = p.lift;
        }
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn every_preset_is_valid_and_named_uniquely() {
        for m in Material::ALL {
            let mut params = SolverParams { wind: Wind::Air(Default::default()), ..SolverParams::default() };
            m.apply(&mut params);
            assert_eq!(params.validate(), Ok(()), "{}", m.name());
            assert_eq!(Material::from_name(m.name()), Some(m));
        }
        assert_eq!(Material::from_name("tweed"), None);
    }

    #[test]
    fn selecting_a_fabric_keeps_the_acceleration_of_gravity() {
        // The seed's 9.8 N on 0.2 kg is 49 m/s²; a fabric's particles weigh
        // σ × area, so the force becomes that acceleration.
        let mut params = SolverParams::default();
        Material::Silk.select(&mut params);
        assert_eq!(params.gravity_acceleration, Some(glam::Vec3::new(0.0, -49.0, 0.0)));
        assert_eq!(params.density, Some(Material::Silk.properties().density));
    }

    #[test]
    fn selecting_a_fabric_keeps_a_thicker_contact_distance() {
        // drape-denim's 8 mm (sized to its 4 cm spacing) stays; a scene with
        // a thinner one gets the fabric's 0.15 mm.
        let mut params = SolverParams { thickness: 0.008, ..SolverParams::default() };
        Material::Silk.select(&mut params);
        assert_eq!(params.thickness, 0.008);
        let mut params = SolverParams { thickness: 0.0, ..SolverParams::default() };
        Material::Silk.select(&mut params);
        assert_eq!(params.thickness, Material::Silk.properties().thickness);
    }

    #[test]
    fn kes_units_convert_as_documented() {
        // Cotton: 490 N/m at 4 % is 12 250 N/m; 0.08 gf·cm²/cm is 7.85e-6 N·m.
        let p = Material::Cotton.properties();
        assert!((p.stretch_stiffness - 12_250.0).abs() < 1.0);
        assert!((p.bend_stiffness - 7.8456e-6).abs() < 1e-9);
        assert!((p.density - 0.13).abs() < 1e-6);
        // Denim is stiffer and heavier than silk on every count.
        let (d, s) = (Material::Denim.properties(), Material::Silk.properties());
        assert!(d.density > s.density && d.bend_stiffness > 10.0 * s.bend_stiffness);
    }
}
