//! What the hub hands on after every sample: one offset per model output.
//! Shared by the real hub and the model-less shell, which therefore have
//! the same interface.

/// Most inputs a model can have (length of a full readings array; equals
/// model-core's channel capacity, asserted where model-core is linked).
pub const MAX_INPUTS: usize = 32;
/// Most outputs a model can have (length of [`Offsets::values`]).
pub const MAX_OUTPUTS: usize = 4;

/// Position fed to a positional model's position input, mm: the reference
/// position `P0` of the slopes the hub sends (model-core's `position`).
pub const POSITION_REFERENCE_MM: f64 = 0.0;

/// The offsets the hub reports after a sample.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct Offsets {
    /// One value per model output, in the model's output order (the output
    /// unit, e.g. um). Entries past the model's output count, and all of
    /// them without a model, are zero. Always finite.
    pub values: [f64; MAX_OUTPUTS],
    /// Thermal slope of each positional output, um per mm of travel (a
    /// CNC's position-dependent temperature compensation applies
    /// `value + slope x (P - 0)`; model-core's `position` module); zero for
    /// the other outputs. Always finite. A positional output's value is the
    /// thermal offset at the reference position 0 mm, which is zero
    /// (`Hub::positional` says which outputs are positional).
    pub slopes: [f64; MAX_OUTPUTS],
    /// Whether `values` were computed from this sample; `false` when they
    /// were held from an earlier sample or there is no model.
    pub fresh: bool,
}

impl Offsets {
    /// All zero: no compensation.
    pub const ZERO: Self = Self {
        values: [0.0; MAX_OUTPUTS],
        slopes: [0.0; MAX_OUTPUTS],
        fresh: false,
    };
}
