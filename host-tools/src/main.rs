//! thermcomp
fn main() {}
