//! The model hub without a model (`--no-default-features`): the same API as
//! the real hub (`hub.rs`, feature `model`) but no model-core, so every sample
//! gives zero offsets. It exists so that the shell builds without the model
//! path and `scripts/firmware-size.sh` can measure what that path costs.

pub use crate::offsets::{Offsets, MAX_INPUTS, MAX_OUTPUTS};

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
