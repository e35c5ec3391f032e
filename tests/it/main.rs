//! The one integration-test binary.

mod core;
mod eval;
mod report;
mod serve;
