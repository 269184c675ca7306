//! shellsim's integration tests in one binary (matklad's "one test binary": one link instead of
//! one per file). `cargo test --release --test it MODULE::` runs one file's tests, e.g.
//! `cargo test --release --test it golden::`; `common` holds the helpers they share.

#[macro_use]
mod common;

mod architecture;
mod bad_input;
mod convergence;
mod enclosure;
mod experiments;
mod explore;
mod fixed_model;
mod fixed_props;
mod fuzz;
mod golden;
mod grid_vs_brute;
mod layout;
mod machine;
mod obj;
mod partition;
mod radiosity;
mod robust;
mod rtl;
mod scale;
mod size;
mod stability;
mod vcd;
mod watchdog;
mod watertight;
