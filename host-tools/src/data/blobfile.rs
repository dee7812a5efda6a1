//! Reading and writing blob files, with the file named in every error.

use anyhow::{anyhow, Result};
use model_core::ValidModel;
use std::path::Path;

/// Reads and validates a blob; returns the model and the raw bytes.
pub fn read(path: &Path) -> Result<(ValidModel, Vec<u8>)> {
    let bytes = crate::data::fsio::read_capped(path, model_core::blob::MAX_BLOB_LEN as u64)?;
    let model = model_core::decode(&bytes).map_err(|e| anyhow!("{}: {e}", path.display()))?;
    Ok((model, bytes))
}

/// Encodes a validated model and writes it; returns the bytes written.
pub fn write(model: &ValidModel, path: &Path) -> Result<Vec<u8>> {
    let bytes = encode(model)?;
    crate::data::fsio::write_bytes_atomic(path, &bytes)?;
    Ok(bytes)
}

/// The model's blob bytes.
pub fn encode(model: &ValidModel) -> Result<Vec<u8>> {
    model_core::blob::encode_to_vec(model).map_err(|e| anyhow!("cannot encode the model: {e}"))
}

/// The model named by `--model BLOB` or `--spec SPEC.toml` (one of them).
/// A spec goes through the blob encoder and decoder, so it runs exactly as
/// its flashed blob would.
pub fn load(model: Option<&Path>, spec: Option<&Path>) -> Result<ValidModel> {
    match (model, spec) {
        (Some(path), None) => Ok(read(path)?.0),
        (None, Some(path)) => {
            let built = crate::data::spec::load(path)?;
            let bytes = model_core::blob::encode_to_vec(&built)
                .map_err(|e| anyhow!("{}: cannot encode the model: {e}", path.display()))?;
            model_core::decode(&bytes).map_err(|e| anyhow!("{}: {e}", path.display()))
        }
        _ => Err(anyhow!("give exactly one of --model and --spec")),
    }
}
