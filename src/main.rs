//! The `shellsim` command line.
fn main() {}
