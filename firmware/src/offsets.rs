//! What the hub hands on after every sample: one offset per model output.
//! Shared by the real hub and the model-less shell, which therefore have
//! the same interface.

/// Most inputs a model can have (length of a full readings array; equals
/// model-core's channel capacity, asserted where model-core is linked).
pub const MAX_INPUTS: usize = 24;
/// Most outputs a model can have (length of [`Offsets::values`]).
pub const MAX_OUTPUTS: usize = 4;

/// The offsets the hub reports after a sample.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct Offsets {
    /// One value per model output, in the model's output order (the output
    /// unit, e.g. um). Entries past the model's output count, and all of
    /// them without a model, are zero. Always finite.
    pub values: [f64; MAX_OUTPUTS],
    /// Whether `values` were computed from this sample; `false` when they
    /// were held from an earlier sample or there is no model.
    pub fresh: bool,
}

impl Offsets {
    /// All zero: no compensation.
    pub const ZERO: Self = Self {
        values: [0.0; MAX_OUTPUTS],
        fresh: false,
    };
}
