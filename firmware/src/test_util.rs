//! Helpers the unit tests of several modules share: building the small
//! models they run (model-core's fields are heapless types).

use model_core::{Name, ValidModel};

use crate::hub::Hub;

/// A model name (panics on a name too long: tests only).
pub fn name(s: &str) -> Name {
    Name::try_from(s).unwrap()
}

/// A heapless vector of `items` (panics past capacity: tests only).
pub fn vec<T: Clone, const N: usize>(items: &[T]) -> heapless::Vec<T, N> {
    heapless::Vec::from_slice(items).unwrap()
}

/// The hub a blob of `model` loads into; asserts it has the model.
pub fn hub(model: &ValidModel) -> Hub {
    let mut blob = [0u8; 4096];
    let n = model_core::encode(model, &mut blob).unwrap();
    let hub = Hub::load(&blob[..n]);
    assert!(hub.model().is_some());
    hub
}
