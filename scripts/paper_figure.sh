#!/usr/bin/env bash
# The paper-style figure (README, docs/report.md): four scripted policies behind `negotiator
# serve` (expert, cue_follower, cautious, always_proceed), n 50 of every
# scenario and tier each, then
#
#   negotiator report RUNS --tiers all --style paper
#
# and its tier ladder copied to results/figures/tier_ladder.{svg,pdf}.
# Deterministic: the same figure every time (seeded episodes, scripted
# policies, bootstrap seed 0).
#
# Usage: scripts/paper_figure.sh [OUT_DIR]   (default: a fresh temporary dir)
set -euo pipefail

cd "$(dirname "$0")/.."
OUT=${1:-$(mktemp -d -t negotiator-paper-figure.XXXXXX)}
mkdir -p "$OUT/runs" results/figures
N=${N:-50}

cargo build --release --quiet
# The binary cargo just built, wherever CARGO_TARGET_DIR puts it (absolute:
# the servers below run from elsewhere).
BIN=$(cd "${CARGO_TARGET_DIR:-target}" && pwd)/release/negotiator

SERVE_PID=""
cleanup() { if [ -n "$SERVE_PID" ]; then kill "$SERVE_PID" 2>/dev/null || true; wait "$SERVE_PID" 2>/dev/null || true; fi; }
trap cleanup EXIT

for policy in expert cue_follower cautious always_proceed; do
  log="$OUT/serve-$policy.out"
  rm -rf "$OUT/runs/$policy"
  "$BIN" serve --policy "$policy" --port 0 >"$log" 2>/dev/null &
  SERVE_PID=$!
  for _ in $(seq 100); do grep -q '^listening on ' "$log" 2>/dev/null && break; sleep 0.05; done
  url=$(sed -n 's/^listening on //p' "$log")
  [ -n "$url" ] || { echo "serve did not start" >&2; exit 1; }
  "$BIN" eval --base-url "$url" --model "$policy" --scenario all --tier all -n "$N" -c 32 \
    --output "$OUT/runs" --run-name "$policy" --quiet >/dev/null
  kill "$SERVE_PID"; wait "$SERVE_PID" 2>/dev/null || true; SERVE_PID=""
done

"$BIN" report "$OUT/runs" --tiers all --style paper --out "$OUT/report" -q
cp "$OUT/report/plots/tier_ladder.svg" "$OUT/report/plots/tier_ladder.pdf" results/figures/
echo "results/figures/tier_ladder.svg and .pdf from $OUT/report"
