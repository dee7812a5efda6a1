//! Capacities of a model: fixed sizes, so a model fits in static memory on
//! the hub and every per-kind module sizes its `heapless` vectors from one
//! place (no module imports the model module for them).

/// Input channels a model may read (temperatures, speed, power, position...):
/// 32, the most sensors a trainer may select from (a hub's bitmasks of
/// inputs are `u32`, so this is also the ceiling).
pub const MAX_CHANNELS: usize = 32;
/// Outputs a model may produce (dx, dy, dz and one spare).
pub const MAX_OUTPUTS: usize = 4;
/// Bytes in a column name (`ambient_c`, `T16`, `dz_um` fit easily).
pub const NAME_LEN: usize = 24;

/// A run-file column name.
pub type Name = heapless::String<NAME_LEN>;

/// Largest magnitude of any number a model holds (coefficients,
/// transfer-function polynomials, references, scales, envelopes,
/// half-widths): 1e12. No thermal model needs more (a kelvin buying 1e12
/// um is a million metres), so a larger number is a broken fit or a
/// corrupted blob; without the bound a product such as 1e300 x 1e300
/// overflows to infinity on the hub. The host's model spec is held to the
/// same bound.
pub const MAX_MAGNITUDE: f64 = 1e12;

/// Finite and at most [`MAX_MAGNITUDE`] in magnitude.
pub fn bounded(v: f64) -> bool {
    v.is_finite() && v.abs() <= MAX_MAGNITUDE
}

/// Largest deflection-centre distance accepted, mm: no spindle is 5 m long,
/// so a larger value is a unit mistake (µm for mm).
pub const MAX_L_DEFL_MM: f64 = 5000.0;
