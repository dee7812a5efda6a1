//! The model hub without a model (`--no-default-features`): the same API as
//! the real hub (`hub.rs`, feature `model`) but no model-core, so every sample
//! gives zero offsets. It exists so that the shell builds without the model
//! path and `scripts/firmware-size.sh` can measure what that path costs.

/// Most inputs a model can have (length of a full readings array).
pub const MAX_INPUTS: usize = 24;
/// Most outputs a model can have (length of [`Offsets::values`]).
pub const MAX_OUTPUTS: usize = 4;

/// The offsets the hub reports after a sample.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct Offsets {
    /// One value per model output; always zero here.
    pub values: [f64; MAX_OUTPUTS],
    /// Whether `values` were computed from this sample; always `false` here.
    pub fresh: bool,
}

impl Offsets {
    /// All zero: no compensation.
    pub const ZERO: Self = Self {
        values: [0.0; MAX_OUTPUTS],
        fresh: false,
    };
}

/// A hub that never has a model.
#[derive(Clone, Copy, Debug, Default)]
pub struct Hub;

impl Hub {
    /// Ignores the slot: this build cannot run models.
    pub fn load(_slot: &[u8]) -> Self {
        Self
    }

    /// Readings [`Hub::on_sample`] expects: none.
    pub fn input_count(&self) -> usize {
        0
    }

    /// Zero offsets, whatever the readings.
    pub fn on_sample(&mut self, _readings: &[f64]) -> Offsets {
        Offsets::ZERO
    }
}
