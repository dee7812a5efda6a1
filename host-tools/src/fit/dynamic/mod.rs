//! What the dynamic trainers (`arx`, `tf`, `gain`) share, one concept per
//! module, so that each trainer imports from here and never from another
//! trainer: the options, the order structures a search tries, the time
//! grid, the search split, forward input selection, the simulation fit they
//! rank by, and the TF bank they export.

pub mod bank;
pub mod grid;
pub mod options;
pub mod orders;
pub mod select;
pub mod sim_fit;
pub mod split;
