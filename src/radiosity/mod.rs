//! The whole radiosity job on top of the three models: the full form-factor matrix
//! ([`matrix`]), the solution B = E + ρ F B ([`solve`]), pictures of it ([`render`]) and
//! one model's solution against the float one's ([`compare`]); [`job`] ties them together
//! for `shellsim radiosity`.
//!
//! **Invariant:** every output (matrix, summary, CSV, JSON, PNG) depends only on the inputs
//! and the seed, not on the thread count: rows are computed in parallel and collected in
//! source order, every sum is taken in a fixed order, wall-clock time is printed only.

pub mod compare;
pub mod job;
pub mod matrix;
pub mod render;
pub mod sample;
pub mod solve;
