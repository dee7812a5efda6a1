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

/// Largest deflection-centre distance accepted, mm: no spindle is 5 m long,
/// so a larger value is a unit mistake (µm for mm).
pub const MAX_L_DEFL_MM: f64 = 5000.0;
