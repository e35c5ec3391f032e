//! The one integration-test binary.

mod core;
mod eval;
mod serve;
