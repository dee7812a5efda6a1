//! Helpers the unit tests of several modules share: building the small
//! models they run (model-core's fields are heapless types).

use model_core::tf::TfEntry;
use model_core::{Channel, Model, Name, Params, Reference, ValidModel};

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
    let hub = Hub::load(&blob(model));
    assert!(hub.model().is_some());
    hub
}

/// The blob of `model`.
pub fn blob(model: &ValidModel) -> std::vec::Vec<u8> {
    let mut buf = std::vec![0u8; model_core::blob::MAX_BLOB_LEN];
    let n = model_core::encode(model, &mut buf).unwrap();
    buf.truncate(n);
    buf
}

/// A blob of `m` framed as `encode` frames one, without validating `m`
/// first (what a faulty writer could send).
pub fn unvalidated_blob(m: &model_core::Model) -> std::vec::Vec<u8> {
    use model_core::blob::{crc32, FORMAT_VERSION, MAGIC, MAX_BLOB_LEN};
    let mut body = std::vec![0u8; MAX_BLOB_LEN];
    let n = postcard::to_slice(m, &mut body).unwrap().len();
    let mut out = std::vec::Vec::from(MAGIC);
    out.extend_from_slice(&FORMAT_VERSION.to_le_bytes());
    out.extend_from_slice(&[m.kind().code(), 0]);
    out.extend_from_slice(&u32::try_from(n).unwrap().to_le_bytes());
    out.extend_from_slice(&body[..n]);
    let crc = crc32(&out);
    out.extend_from_slice(&crc.to_le_bytes());
    out
}

/// A first-order lag on `input`'s rise since the first sample (seed 004's
/// form), 0.5 y(k) = 0.1 u(k) + 0.4 y(k-1), identified at `dt_s`.
pub fn first_order_tf(input: &str, dt_s: f64) -> ValidModel {
    Model {
        inputs: vec(&[Channel {
            name: name(input),
            reference: Reference::First,
        }]),
        outputs: vec(&[name("dz_um")]),
        dt_s,
        params: Params::Tf(vec(&[TfEntry {
            output: 0,
            input: 0,
            a: vec(&[0.1]),
            b: vec(&[0.5, -0.4]),
        }])),
        bounds: None,
        five_point: None,
    }
    .validate()
    .unwrap()
}
