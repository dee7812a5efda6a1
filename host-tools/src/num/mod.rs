//! Shared numerics: least squares (dense and blocked QR), statistics and distributions, the seeded
//! random numbers, numbers as text ([`shown`]). Every job that needs one of these takes it from here,
//! never from a sibling job.

pub mod batch;
pub mod decomp;
pub mod distributions;
pub mod linalg;
pub mod lp3;
pub mod lsq;
pub mod progress;
pub mod rng;
pub mod shown;
pub mod stats;
pub mod tsqr;
