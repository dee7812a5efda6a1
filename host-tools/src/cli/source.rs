//! The arguments that name a model and the runs to apply it to, shared by
//! every subcommand that runs a model (`predict`, `eval`, `replay`).

use crate::data::fsio::{named, Named};
use crate::data::runfile::ReadOptions;
use crate::runner::ColumnMap;
use anyhow::Result;
use clap::Args;
use model_core::ValidModel;
use std::path::PathBuf;

/// `--model BLOB` or `--spec SPEC.toml`.
#[derive(Args)]
pub struct ModelSource {
    /// The model blob.
    #[arg(long, required_unless_present = "spec", conflicts_with = "spec")]
    pub model: Option<PathBuf>,
    /// Or a model spec (TOML), built in memory exactly as `model build` would.
    #[arg(long)]
    pub spec: Option<PathBuf>,
}

impl ModelSource {
    /// The validated model.
    pub fn load(&self) -> Result<ValidModel> {
        crate::data::blobfile::load(self.model.as_deref(), self.spec.as_deref())
    }

    /// The files read, with their flags, for [`crate::data::fsio::check_distinct`].
    pub fn paths(&self) -> Vec<Named<'_>> {
        let model = self.model.iter().map(|p| named("--model", p));
        model
            .chain(self.spec.iter().map(|p| named("--spec", p)))
            .collect()
    }
}

/// `--data` (repeatable), `--map`, `--skip-bad-rows`.
#[derive(Args)]
pub struct RunSource {
    /// A run file (CSV); give it several times for several runs (each
    /// restarts the model's state).
    #[arg(long, required = true)]
    pub data: Vec<PathBuf>,
    /// Read model name NAME from column COLUMN (repeatable): an input (T1=T5),
    /// or an output compared with a differently named column (dz_um=ch1_um).
    #[arg(long = "map", value_name = "NAME=COLUMN")]
    pub map: Vec<String>,
    /// Skip rows with unparsable cells instead of failing (they are counted and reported).
    #[arg(long)]
    pub skip_bad_rows: bool,
}

impl RunSource {
    /// The files read, with their flags, for [`crate::data::fsio::check_distinct`].
    pub fn paths(&self) -> Vec<Named<'_>> {
        self.data.iter().map(|p| named("--data", p)).collect()
    }

    /// The `--map` pairs.
    pub fn column_map(&self) -> Result<ColumnMap> {
        ColumnMap::parse(&self.map)
    }

    /// The reader's options for these runs, reading only the `needed` columns.
    pub fn read_options(&self, needed: Vec<String>) -> ReadOptions {
        ReadOptions {
            skip_bad_rows: self.skip_bad_rows,
            only: Some(needed),
        }
    }
}
