//! The data a job works on, and where it comes from: run files and their
//! time grids, datasets (inputs and targets on calibration and held-out
//! rows), model specs, blob files and the file-system rules every command
//! keeps (never overwrite an input, write atomically).

pub mod blobfile;
pub mod cells;
pub mod dataset;
pub mod fsio;
pub mod rawcells;
pub mod runfile;
pub mod source;
pub mod spec;
pub mod spikes;
