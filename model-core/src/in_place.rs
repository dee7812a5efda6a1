//! Decoding a blob's body into a [`Model`] where it lies.
//!
//! serde's derived decoders build each value and return it, so a model (up
//! to 15 KiB: the 256-feature filter bank) passed by value through every
//! nested visitor, postcard's wrappers and the format versions' conversions:
//! on the hub, one decode took 114 KB of stack, more than the F446's RAM
//! leaves it (docs/firmware-cost.md, "Stack"). Here the model's fields are
//! decoded into their places: its lists element by element
//! (`wire::Into`), the filter bank's lists the same way, the smaller
//! parameter kinds (at most the BP net's 5 KiB) and the bounds by value.
//!
//! The wire format is postcard's for [`Model`]'s derived `Serialize`: a
//! struct is its fields in order, an enum a varint variant index and the
//! variant's value. Format versions 1 and 2 are the current model without
//! its last two fields, or its last one (blob.rs); those fields are then
//! `None`. The tests hold the decoder to the derived one, for every model
//! kind and version.

use core::fmt;
use core::marker::PhantomData;

use serde::de::{
    DeserializeSeed, Deserializer, EnumAccess, Error, SeqAccess, Unexpected, VariantAccess, Visitor,
};

use crate::fbank::FilterBank;
use crate::model::{Model, Params};
use crate::wire::Into as List;

/// The fields of [`Model`], in wire order.
const FIELDS: &[&str] = &[
    "inputs",
    "outputs",
    "dt_s",
    "params",
    "bounds",
    "five_point",
];
/// Fields of a format-1 body (no bounds, no five-point geometry).
pub(crate) const FIELDS_V1: usize = 4;
/// Fields of a format-2 body (no five-point geometry).
pub(crate) const FIELDS_V2: usize = 5;
/// Fields of the current format.
pub(crate) const FIELDS_NOW: usize = 6;

/// The variants of [`Params`], in wire order (the variant index).
const VARIANTS: &[&str] = &["Tf", "Linear", "Pcr", "Bp", "Arma", "Fbank"];

/// Why a body did not decode: postcard's error, or bytes after the model.
#[derive(Debug)]
pub(crate) struct Malformed;

/// Decodes `body`, a model of `fields` fields (`FIELDS_V1`, `FIELDS_V2` or
/// `FIELDS_NOW`) and nothing after it, into `place`. On error `place` holds
/// a partly decoded model.
pub(crate) fn model(body: &[u8], fields: usize, place: &mut Model) -> Result<(), Malformed> {
    let mut de = postcard::Deserializer::from_bytes(body);
    ModelSeed { place, fields }
        .deserialize(&mut de)
        .map_err(|_| Malformed)?;
    match de.finalize() {
        Ok([]) => Ok(()),
        _ => Err(Malformed),
    }
}

/// The next element of `seq`, decoded by `seed`; missing is an error.
fn next<'de, A: SeqAccess<'de>, S: DeserializeSeed<'de>>(
    seq: &mut A,
    seed: S,
    at: usize,
    expected: &dyn serde::de::Expected,
) -> Result<S::Value, A::Error> {
    seq.next_element_seed(seed)?
        .ok_or_else(|| A::Error::invalid_length(at, expected))
}

struct ModelSeed<'a> {
    place: &'a mut Model,
    fields: usize,
}

impl<'de> DeserializeSeed<'de> for ModelSeed<'_> {
    type Value = ();

    fn deserialize<D: Deserializer<'de>>(self, d: D) -> Result<(), D::Error> {
        let fields = FIELDS.get(..self.fields).unwrap_or(FIELDS);
        d.deserialize_struct("Model", fields, self)
    }
}

impl<'de> Visitor<'de> for ModelSeed<'_> {
    type Value = ();

    fn expecting(&self, f: &mut fmt::Formatter<'_>) -> fmt::Result {
        write!(f, "a model of {} fields", self.fields)
    }

    fn visit_seq<A: SeqAccess<'de>>(self, mut seq: A) -> Result<(), A::Error> {
        let (m, fields) = (self.place, self.fields);
        let want = &"the fields of a model";
        next(&mut seq, List(m.inputs.as_mut_view()), 0, want)?;
        next(&mut seq, List(m.outputs.as_mut_view()), 1, want)?;
        m.dt_s = next(&mut seq, PhantomData, 2, want)?;
        next(&mut seq, ParamsSeed(&mut m.params), 3, want)?;
        m.bounds = if fields > FIELDS_V1 {
            next(&mut seq, PhantomData, 4, want)?
        } else {
            None
        };
        m.five_point = if fields > FIELDS_V2 {
            next(&mut seq, PhantomData, 5, want)?
        } else {
            None
        };
        Ok(())
    }
}

/// [`Params`] into its place: the filter bank's lists in place, the other
/// kinds by value.
struct ParamsSeed<'a>(&'a mut Params);

impl<'de> DeserializeSeed<'de> for ParamsSeed<'_> {
    type Value = ();

    fn deserialize<D: Deserializer<'de>>(self, d: D) -> Result<(), D::Error> {
        d.deserialize_enum("Params", VARIANTS, self)
    }
}

impl<'de> Visitor<'de> for ParamsSeed<'_> {
    type Value = ();

    fn expecting(&self, f: &mut fmt::Formatter<'_>) -> fmt::Result {
        f.write_str("model parameters")
    }

    fn visit_enum<A: EnumAccess<'de>>(self, data: A) -> Result<(), A::Error> {
        let (index, value): (u32, _) = data.variant()?;
        let params = self.0;
        match index {
            0 => tf(value, params),
            1 => by_value(value, params, Params::Linear),
            2 => by_value(value, params, Params::Pcr),
            3 => by_value(value, params, Params::Bp),
            4 => by_value(value, params, Params::Arma),
            5 => fbank(value, params),
            _ => Err(A::Error::invalid_value(
                Unexpected::Unsigned(u64::from(index)),
                &"a model kind's variant index (0-5)",
            )),
        }
    }
}

// Each kind in its own frame (never inlined): the frames of the kinds not
// in the blob are not on the stack while one kind decodes.

/// What `tf` and `fbank` say if the variant they just set were not there
/// (it always is: the match only reaches into it).
const JUST_SET: &str = "the variant just set is missing";

/// A TF bank: its list of entries in place.
#[inline(never)]
fn tf<'de, A: VariantAccess<'de>>(value: A, params: &mut Params) -> Result<(), A::Error> {
    *params = Params::Tf(heapless::Vec::new());
    match params {
        Params::Tf(entries) => value.newtype_variant_seed(List(entries.as_mut_view())),
        _ => Err(A::Error::custom(JUST_SET)),
    }
}

/// A kind of a few KiB at most, decoded by value.
#[inline(never)]
fn by_value<'de, A: VariantAccess<'de>, T: serde::Deserialize<'de>>(
    value: A,
    params: &mut Params,
    wrap: fn(T) -> Params,
) -> Result<(), A::Error> {
    *params = wrap(value.newtype_variant()?);
    Ok(())
}

/// A filter bank: its two lists in place.
#[inline(never)]
fn fbank<'de, A: VariantAccess<'de>>(value: A, params: &mut Params) -> Result<(), A::Error> {
    *params = Params::Fbank(FilterBank {
        features: heapless::Vec::new(),
        outputs: heapless::Vec::new(),
    });
    match params {
        Params::Fbank(bank) => value.newtype_variant_seed(BankSeed(bank)),
        _ => Err(A::Error::custom(JUST_SET)),
    }
}

/// A [`FilterBank`] into its place: both lists element by element.
struct BankSeed<'a>(&'a mut FilterBank);

impl<'de> DeserializeSeed<'de> for BankSeed<'_> {
    type Value = ();

    fn deserialize<D: Deserializer<'de>>(self, d: D) -> Result<(), D::Error> {
        d.deserialize_struct("FilterBank", &["features", "outputs"], self)
    }
}

impl<'de> Visitor<'de> for BankSeed<'_> {
    type Value = ();

    fn expecting(&self, f: &mut fmt::Formatter<'_>) -> fmt::Result {
        f.write_str("a filter bank")
    }

    fn visit_seq<A: SeqAccess<'de>>(self, mut seq: A) -> Result<(), A::Error> {
        let bank = &mut *self.0;
        next(&mut seq, List(bank.features.as_mut_view()), 0, &"two lists")?;
        next(&mut seq, List(bank.outputs.as_mut_view()), 1, &"two lists")?;
        Ok(())
    }
}
