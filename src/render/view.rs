//! What to draw: [`ViewOptions`], and the strain colour ramp shared by the
//! shaders and the legend.

use crate::sim::ClothMesh;

/// More fixed particles than this are not marked by default.
pub const MAX_MARKED_PINS: usize = 40;
/// More particles than this are not drawn as dots by default.
pub const MAX_DOTTED_PARTICLES: usize = 200;

/// Which layers the renderer draws and how.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct ViewOptions {
    /// The lit cloth surface (needs triangles).
    pub surface: bool,
    /// Structural bars as lines.
    pub structural_bars: bool,
    /// Bend bars as lines.
    pub bend_bars: bool,
    /// Every particle as a dot.
    pub particles: bool,
    /// Fixed particles as red dots even when `particles` is off.
    pub pins: bool,
    /// Colour the surface and the bars by strain instead of by side or kind.
    pub strain_colours: bool,
    /// Triangle edges over the surface.
    pub wireframe: bool,
    /// The ground grid and the cloth's shadow on it.
    pub ground: bool,
    /// The colliders (a ground plane collider is drawn as the ground).
    pub colliders: bool,
    /// The strain at the red end of the ramp (0.1 = 10 % longer or shorter
    /// than at rest).
    pub strain_scale: f32,
    /// Width of a structural bar, in points (bend bars are thinner).
    pub bar_width: f32,
    /// Radius of a particle dot, in points.
    pub particle_radius: f32,
}

impl Default for ViewOptions {
    fn default() -> Self {
        Self::surface_view()
    }
}

impl ViewOptions {
    /// The lit surface with pins marked.
    pub fn surface_view() -> Self {
        Self {
            surface: true,
            structural_bars: false,
            bend_bars: false,
            particles: false,
            pins: true,
            strain_colours: false,
            wireframe: false,
            ground: true,
            colliders: true,
            strain_scale: 0.1,
            bar_width: 2.0,
            particle_radius: 2.5,
        }
    }

    /// Structural bars coloured by strain, with the particles.
    pub fn bars_view() -> Self {
        Self { surface: false, structural_bars: true, particles: true, strain_colours: true, ..Self::surface_view() }
    }

    /// The surface view for a mesh with triangles, the bars view otherwise
    /// (a mesh of particles and bars alone has nothing else to show); see
    /// [`Self::adapted_to`].
    pub fn for_mesh(mesh: &ClothMesh) -> Self {
        let base = if mesh.triangles().is_empty() { Self::bars_view() } else { Self::surface_view() };
        base.adapted_to(mesh)
    }

    /// These options with dots only where they help: pins are marked unless
    /// so many that the dots would hide the cloth (a whole pinned row, a
    /// pinned table top), and particles are shown only on small meshes.
    pub fn adapted_to(self, mesh: &ClothMesh) -> Self {
        let pins = mesh.fixed().iter().filter(|&&f| f).count();
        Self {
            pins: self.pins && pins <= MAX_MARKED_PINS,
            particles: self.particles && mesh.particle_count() <= MAX_DOTTED_PARTICLES,
            ..self
        }
    }
}

/// The strain ramp, sRGB, from no strain to [`ViewOptions::strain_scale`]:
/// blue (at rest) through pale yellow to dark red (stretched or squashed).
pub const STRAIN_RAMP_SRGB: [[u8; 3]; 5] =
    [[0x31, 0x36, 0x95], [0x74, 0xad, 0xd1], [0xff, 0xff, 0xbf], [0xf4, 0x6d, 0x43], [0xa5, 0x00, 0x26]];

/// One sRGB channel (0–255) to linear light (0–1).
pub fn srgb_to_linear(c: u8) -> f32 {
    let c = f32::from(c) / 255.0;
    if c <= 0.04045 { c / 12.92 } else { ((c + 0.055) / 1.055).powf(2.4) }
}

/// One linear channel (0–1) to sRGB (0–255).
pub fn linear_to_srgb(c: f32) -> u8 {
    let c = c.clamp(0.0, 1.0);
    let s = if c <= 0.003_130_8 { c * 12.92 } else { 1.055 * c.powf(1.0 / 2.4) - 0.055 };
    (s * 255.0).round() as u8
}

/// The ramp's stops in linear RGB, as the shaders get them.
pub fn strain_ramp_linear() -> [[f32; 4]; 5] {
    STRAIN_RAMP_SRGB.map(|[r, g, b]| [srgb_to_linear(r), srgb_to_linear(g), srgb_to_linear(b), 1.0])
}

/// The sRGB colour the shaders give `strain` on a ramp ending at `scale`
/// (the same interpolation, in linear light), for legends.
pub fn strain_colour_srgb(strain: f32, scale: f32) -> [u8; 3] {
    let ramp = strain_ramp_linear();
    let t = (strain / scale.max(1e-9)).clamp(0.0, 1.0) * 4.0;
    let i = (t.floor() as usize).min(3);
    let f = t - i as f32;
    let mix = |k: usize| ramp[i][k] + (ramp[i + 1][k] - ramp[i][k]) * f;
    [linear_to_srgb(mix(0)), linear_to_srgb(mix(1)), linear_to_srgb(mix(2))]
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn ramp_ends_are_its_first_and_last_stops_and_srgb_round_trips() {
        assert_eq!(strain_colour_srgb(0.0, 0.1), STRAIN_RAMP_SRGB[0]);
        assert_eq!(strain_colour_srgb(0.5, 0.1), STRAIN_RAMP_SRGB[4]);
        assert_eq!(strain_colour_srgb(0.05, 0.1), STRAIN_RAMP_SRGB[2]);
        for c in [0u8, 1, 10, 100, 200, 255] {
            assert_eq!(linear_to_srgb(srgb_to_linear(c)), c);
        }
    }
}
