//! [`MeshError`]: every reason a builder refuses what it is given, each
//! saying what was wrong and what is allowed.

use super::{MAX_BARS, MAX_PARTICLES};

/// Why a mesh could not be built.
#[derive(Clone, Debug, PartialEq, thiserror::Error)]
pub enum MeshError {
    /// The mesh has no particle.
    #[error("the mesh has no particles; give at least one")]
    Empty,
    /// More particles than [`MAX_PARTICLES`] (checked before allocating).
    #[error("{count} particles is too many: at most {MAX_PARTICLES} are allowed")]
    TooManyParticles {
        /// The requested count (may exceed what fits in memory).
        count: u128,
    },
    /// More bars than [`MAX_BARS`].
    #[error("{count} bars is too many: at most {MAX_BARS} are allowed")]
    TooManyBars {
        /// The requested count.
        count: u128,
    },
    /// A coordinate is NaN, infinite or beyond ±[`MAX_COORDINATE`](super::MAX_COORDINATE).
    #[error("{what} of particle {index} is {value}: coordinates must be finite and within ±1e6 m")]
    BadCoordinate {
        /// `position` or `velocity`.
        what: &'static str,
        /// The particle.
        index: usize,
        /// The value, formatted.
        value: String,
    },
    /// A per-particle list has the wrong length.
    #[error("{what} has {got} entries but the mesh has {expected} particles; give one per particle")]
    WrongLength {
        /// Which list.
        what: &'static str,
        /// Its length.
        got: usize,
        /// The number of particles.
        expected: usize,
    },
    /// An index names a particle that does not exist.
    #[error("{what} refers to particle {index}, but the particles are numbered 0 to {last}")]
    IndexOutOfRange {
        /// Where the index was found.
        what: String,
        /// The bad index.
        index: u64,
        /// The largest valid index.
        last: usize,
    },
    /// A bar joins a particle to itself.
    #[error("a bar joins particle {particle} to itself; a bar needs two different particles")]
    SelfBar {
        /// The particle.
        particle: u32,
    },
    /// A bar too short for f32 to resolve its stretch (zero length among
    /// them): shorter than [`MIN_BAR_LENGTH`](super::MIN_BAR_LENGTH) or than [`MIN_BAR_RATIO`](super::MIN_BAR_RATIO) of
    /// the mesh's largest coordinate magnitude.
    #[error(
        "the bar between particles {a} and {b} is {length:.3e} m long: bars must be at least {minimum:.3e} m \
         (1 µm, and 1e-4 of the mesh's largest coordinate) for f32 to resolve their stretch; \
         use a coarser spacing, or a mesh nearer the origin"
    )]
    ShortBar {
        /// First particle.
        a: u32,
        /// Second particle.
        b: u32,
        /// Its rest length, metres.
        length: f32,
        /// The shortest allowed for this mesh, metres.
        minimum: f32,
    },
    /// The same bar is given twice.
    #[error("the bar between particles {a} and {b} is given twice; list each bar once per end at most")]
    DuplicateBar {
        /// First particle.
        a: u32,
        /// Second particle.
        b: u32,
    },
    /// A triangle repeats a vertex.
    #[error("triangle {index} repeats a vertex ({vertices:?}); a triangle needs three different vertices")]
    DegenerateTriangle {
        /// The triangle's position in the list.
        index: usize,
        /// Its vertices.
        vertices: [u32; 3],
    },
    /// A grid dimension or spacing is unusable.
    #[error("grid {what}")]
    BadGrid {
        /// What is wrong and what is allowed.
        what: String,
    },
}
