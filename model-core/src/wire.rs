//! Decoding of the blob's lists with one serde visitor per element type
//! for every capacity.
//!
//! `heapless::Vec<T, N>`'s own `Deserialize` is generic over `N`, so each
//! capacity the models use (eight for `f64` alone) gets its own copy of the
//! visitor in the firmware. Filling the capacity-erased `VecView` instead
//! leaves one copy per element type: 1.4 KB less flash on the hub
//! (docs/benchmarks.md). The wire format (postcard: length, then the
//! elements) is the same, and a list longer than the capacity is refused
//! the same way.

use core::fmt;

use heapless::vec::VecView;
use serde::de::{Deserialize, DeserializeSeed, Deserializer, Error, SeqAccess, Visitor};

/// For `#[serde(deserialize_with = "crate::wire::list")]` on a
/// `heapless::Vec<T, N>` field.
pub(crate) fn list<'de, D: Deserializer<'de>, T: Deserialize<'de>, const N: usize>(
    d: D,
) -> Result<heapless::Vec<T, N>, D::Error> {
    let mut out = heapless::Vec::new();
    d.deserialize_seq(Fill(out.as_mut_view()))?;
    Ok(out)
}

/// The list decoded into an existing vector, replacing its contents (the
/// in-place decoder's lists: `crate::in_place`).
pub(crate) struct Into<'a, T>(pub(crate) &'a mut VecView<T>);

impl<'de, T: Deserialize<'de>> DeserializeSeed<'de> for Into<'_, T> {
    type Value = ();

    fn deserialize<D: Deserializer<'de>>(self, d: D) -> Result<(), D::Error> {
        self.0.clear();
        d.deserialize_seq(Fill(self.0))
    }
}

/// Pushes every element into the vector; too many is an error.
struct Fill<'a, T>(&'a mut VecView<T>);

impl<'de, T: Deserialize<'de>> Visitor<'de> for Fill<'_, T> {
    type Value = ();

    fn expecting(&self, f: &mut fmt::Formatter<'_>) -> fmt::Result {
        f.write_str("a list")
    }

    fn visit_seq<A: SeqAccess<'de>>(self, mut seq: A) -> Result<(), A::Error> {
        while let Some(v) = seq.next_element::<T>()? {
            if self.0.push(v).is_err() {
                return Err(A::Error::invalid_length(
                    self.0.len() + 1,
                    &"no more elements than the model kind holds",
                ));
            }
        }
        Ok(())
    }
}
