//! A model slot: a blob decoded and validated where the model lies.
//!
//! The hub keeps its model in a static and loads blobs at boot and on
//! upload. A [`ValidModel`] returned by value passes through the stack
//! (17 KiB with the 256-feature filter bank, several times over in serde's
//! derived decoders), so the hub loads into a slot instead:
//! [`ModelSlot::load`] decodes into the slot's own storage (`in_place`),
//! runs [`Model::validate`]'s checks there, and only then hands the model
//! out ([`ModelSlot::model`]). After a refused blob the slot gives the
//! error until the next good load; its storage is never read as a model.

use crate::blob::{self, BlobError};
use crate::model::{Derived, Model, ValidModel};

/// See the module docs. Two slots are equal, and print alike, when their
/// [`ModelSlot::model`]s are: the storage behind a refused blob is not part
/// of the slot's value.
#[derive(Clone)]
pub struct ModelSlot {
    /// The storage; a valid model only while `error` is `None`.
    valid: ValidModel,
    /// Why the last load gave no model.
    error: Option<BlobError>,
}

impl PartialEq for ModelSlot {
    fn eq(&self, other: &Self) -> bool {
        self.model() == other.model()
    }
}

impl core::fmt::Debug for ModelSlot {
    fn fmt(&self, f: &mut core::fmt::Formatter<'_>) -> core::fmt::Result {
        f.debug_tuple("ModelSlot").field(&self.model()).finish()
    }
}

impl Default for ModelSlot {
    fn default() -> Self {
        Self::new()
    }
}

impl ModelSlot {
    /// A slot without a model: [`ModelSlot::model`] gives
    /// [`BlobError::TooShort`], what an empty blob gives.
    pub fn new() -> Self {
        Self {
            valid: ValidModel {
                model: Model::placeholder(),
                derived: Derived::None,
                tip: None,
            },
            error: Some(BlobError::TooShort),
        }
    }

    /// Loads the blob `bytes` ([`blob::decode`]'s checks, in place).
    pub fn load(&mut self, bytes: &[u8]) -> Result<(), BlobError> {
        self.load_split(&[], bytes)
    }

    /// Loads the blob `head ++ tail` ([`blob::decode_split`]'s checks, in
    /// place); on error the slot holds no model.
    pub fn load_split(&mut self, head: &[u8], tail: &[u8]) -> Result<(), BlobError> {
        let loaded = self.fill(head, tail);
        self.error = loaded.err();
        loaded
    }

    /// Decodes into the storage and validates it there.
    fn fill(&mut self, head: &[u8], tail: &[u8]) -> Result<(), BlobError> {
        blob::decode_into(head, tail, &mut self.valid.model)?;
        let (derived, tip) = self.valid.model.check()?;
        self.valid.derived = derived;
        self.valid.tip = tip;
        Ok(())
    }

    /// The model, or why the last load gave none.
    pub fn model(&self) -> Result<&ValidModel, BlobError> {
        match self.error {
            None => Ok(&self.valid),
            Some(e) => Err(e),
        }
    }
}
