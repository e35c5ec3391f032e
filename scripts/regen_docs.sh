#!/usr/bin/env bash
# Rewrite every generated block of the README and docs/ (the blocks between
# `<!-- generated: COMMAND -->` and `<!-- end generated -->`) with what
# `negotiator COMMAND` prints now, and the reference CSV and Markdown of
# each scenario in results/baselines/. tests/it/docs.rs fails when a
# committed block or table is stale.
# Speed figures are machine-dependent and re-measured by the scripts named
# next to them (scripts/bench/, scripts/bench_*.sh, hyperfine, criterion).
set -euo pipefail
cd "$(dirname "$0")/.."
# The generated blocks, and one reference table per scenario (what `report`
# reads) for every scenario the binary has.
NEGOTIATOR_REGEN_DOCS=1 cargo test --release --quiet --test it -- docs::generated_ picture::generated_
git status --short README.md docs results/baselines
