#!/usr/bin/env bash
# Rewrite every generated block of the README and docs/ (the blocks between
# `<!-- generated: COMMAND -->` and `<!-- end generated -->`) with what
# `negotiator COMMAND` prints now, and the reference CSV and Markdown in
# results/baselines/. tests/it/docs.rs fails when a committed block is stale.
# Speed figures are machine-dependent and re-measured by the scripts named
# next to them (scripts/bench/, scripts/bench_*.sh, hyperfine, criterion).
set -euo pipefail
cd "$(dirname "$0")/.."
cargo build --release --quiet
# The binary cargo just built, wherever CARGO_TARGET_DIR puts it.
bin=${CARGO_TARGET_DIR:-target}/release/negotiator
NEGOTIATOR_REGEN_DOCS=1 cargo test --release --quiet --test it -- docs::generated_blocks
"$bin" baselines --format csv >results/baselines/baselines.csv
"$bin" baselines --format md >results/baselines/baselines.md
git status --short README.md docs results/baselines
