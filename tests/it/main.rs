//! The one integration-test binary.

mod belief;
mod core;
mod cost;
mod docs;
mod envserver;
mod eval;
mod faults;
mod forecast;
mod inspect;
mod layers;
mod picture;
mod play;
mod providers;
mod report;
mod run_v0;
mod serve;
mod support;
mod vision;
