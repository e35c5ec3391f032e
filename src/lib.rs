//! `negotiator`: a benchmark of whether a policy (a language model, or a
//! scripted baseline) can read another road user's hidden intent from its
//! motion and drive accordingly.
//!
//! Layout, one line per module (the crate-private ones, in plain type, are
//! documented with `cargo doc --document-private-items`):
//! - `sim`: physics (kinematic bodies, controller limits);
//! - [`scenario`]: the three worlds, their tiers and TOML parameters;
//! - [`observation`]: the public view, its text renderer and parser;
//! - [`action`]: the action and its protective parser;
//! - [`policy`]: the scripted baselines, and a scripted policy's reply to
//!   a scene text as a model would give it;
//! - [`instructions`]: the system prompt every front end gives a player;
//! - [`episode`]: the environment loop;
//! - [`features`]: the observation as a fixed-length vector and the discrete
//!   action set, for policies that do not read text (env-server's
//!   `features` view, the learned adversary);
//! - `probe`: which probes a run adds to every answer;
//! - `belief`: the belief probe and the belief metrics;
//! - [`forecast`]: the forecast probe, its reference forecasters and its
//!   metrics (scored against the episode and its twin under the other
//!   disposition);
//! - `noise`: the observation noise model and the ideal observer's
//!   likelihoods (a leaf the worlds and the episode share);
//! - `grading`: reward, decision correctness, diagnostics;
//! - `rng`: the seeded per-episode random streams;
//! - `hash`: SplitMix64 and FNV-1a, the only hash functions;
//! - `par`: the parallel map used by the baseline grid and the report;
//! - [`stats`]: intervals, bootstraps, McNemar, pass^k;
//! - [`rundir`]: the run directory's schema (run.json, the JSON-lines
//!   records and their one reader), written by `eval`, read by `report`;
//! - [`baselines`]: the reference grid of the scripted policies;
//! - [`adversary`]: the search for a blind policy that wins anyway, and
//!   a learned (sighted) adversary looking for a hack;
//! - [`validate`]: the invariants;
//! - [`export`]: the table system: typed cells, columns defined once, one
//!   exporter per format (aligned text, Markdown, CSV, JSON, HTML);
//! - `llm`: the OpenAI-compatible chat client;
//! - `eval`: `eval`, a language model as the policy;
//! - `serve`: a scripted policy behind an OpenAI-compatible endpoint;
//! - `shutdown`: the signal `serve` and `envserver` stop on;
//! - `envserver`: the benchmark as an OpenEnv environment (HTTP and
//!   WebSocket) for trainers and other harnesses;
//! - `play`: a person drives the episodes in the terminal (`eval`
//!   against an in-process endpoint whose answers are the person's);
//! - [`report`]: leaderboards, paired comparisons, plots, report.html;
//! - [`redact`]: the one place secrets are scrubbed from everything the
//!   process writes; `atomic`: whole-file writes (temp file + rename);
//! - [`cli`]: one file per subcommand.

pub mod action;
pub mod adversary;
pub(crate) mod atomic;
pub mod baselines;
pub(crate) mod belief;
pub mod cli;
pub(crate) mod envserver;
/// env-server's `/ws/batch` in-process (the Python package's native vector).
pub use envserver::InProcessBatch;
pub mod episode;
pub(crate) mod eval;
pub mod export;
pub mod features;
pub(crate) mod fonts;
pub mod forecast;
pub(crate) mod grading;
pub(crate) mod hash;
pub mod inspect_log;
pub mod instructions;
pub(crate) mod llm;
pub mod metrics;
pub(crate) mod noise;
pub mod observation;
pub(crate) mod par;
pub mod picture;
pub(crate) mod play;
pub mod policy;
pub(crate) mod probe;
pub mod redact;
pub mod report;
pub(crate) mod rng;
pub mod rundir;
pub mod scenario;
pub(crate) mod serve;
pub(crate) mod shutdown;
pub(crate) mod sim;
pub mod stats;
pub mod validate;
