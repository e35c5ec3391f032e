//! `negotiator`: a benchmark of whether a policy (a language model, or a
//! scripted baseline) can read another road user's hidden intent from its
//! motion and drive accordingly.
//!
//! Layout: [`sim`] (physics), [`scenario`] (the three worlds and their
//! parameters), [`observation`] (public view, text renderer and parser),
//! [`action`] (the action and its protective parser), [`policy`] (baselines),
//! [`episode`] (the environment loop), [`grading`] (reward, correctness,
//! diagnostics), [`baselines`] and [`validate`] (reference table and
//! invariants), [`stats`].

pub mod action;
pub mod baselines;
pub mod cli;
pub mod episode;
pub mod eval;
pub mod export;
pub mod grading;
pub mod llm;
pub mod observation;
pub mod policy;
pub mod report;
pub mod rng;
pub mod scenario;
pub mod serve;
pub mod sim;
pub mod stats;
pub mod validate;
