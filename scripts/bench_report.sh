#!/usr/bin/env bash
# Speed of `negotiator report` (issue 4): 10 runs ("models") of n 200 across
# every scenario and tier (10 x 1,800 = 18,000 episode lines with full
# transcripts and trajectories), made with `serve` + `eval`, then
#
#   hyperfine 'negotiator report RUNS/* --out REPORT -q'
#
# target: under 5 s on the 2-core development machine. Also prints the
# report's peak memory and the size of report.html.
#
# The 10 models: expert, cue_follower, always_proceed, always_stop,
# cautious, and random behind five servers with different --seed (so every
# random "model" drives differently). Generating the runs takes a minute or
# two; pass an existing OUT_DIR to reuse its runs.
#
# Usage: scripts/bench_report.sh [OUT_DIR]   (default: a fresh temporary dir)
# Needs: cargo, hyperfine, /usr/bin/time (Debian package `time`).
set -euo pipefail

cd "$(dirname "$0")/.."
OUT=${1:-$(mktemp -d -t negotiator-bench-report.XXXXXX)}
mkdir -p "$OUT/runs"
BIN=$PWD/target/release/negotiator
N=${N:-200}

cargo build --release --quiet
command -v hyperfine >/dev/null || { echo "needs hyperfine" >&2; exit 1; }

SERVE_PID=""
cleanup() { if [ -n "$SERVE_PID" ]; then kill "$SERVE_PID" 2>/dev/null || true; wait "$SERVE_PID" 2>/dev/null || true; fi; }
trap cleanup EXIT

# run_model NAME POLICY SEED: one run of every scenario and tier, n $N.
run_model() {
  local name=$1 policy=$2 seed=$3 log="$OUT/serve-$1.out"
  if [ -s "$OUT/runs/$name/rollouts.jsonl" ] && [ "$(wc -l <"$OUT/runs/$name/rollouts.jsonl")" -ge $((9 * N)) ]; then
    return
  fi
  "$BIN" serve --policy "$policy" --seed "$seed" --port 0 >"$log" 2>/dev/null &
  SERVE_PID=$!
  for _ in $(seq 100); do grep -q '^listening on ' "$log" 2>/dev/null && break; sleep 0.05; done
  local url
  url=$(sed -n 's/^listening on //p' "$log")
  [ -n "$url" ] || { echo "serve did not start" >&2; exit 1; }
  "$BIN" eval --base-url "$url" --model "$name" --scenario all --tier all -n "$N" -c 64 \
    --output "$OUT/runs" --run-name "$name" --quiet >/dev/null
  kill "$SERVE_PID"; wait "$SERVE_PID" 2>/dev/null || true; SERVE_PID=""
}

echo "== generating 10 runs of n $N x 3 scenarios x 3 tiers in $OUT/runs"
for p in expert cue_follower always_proceed always_stop cautious; do run_model "$p" "$p" 0; done
for s in 1 2 3 4 5; do run_model "random-s$s" random "$s"; done
LINES=$(cat "$OUT"/runs/*/rollouts.jsonl | wc -l)
BYTES=$(cat "$OUT"/runs/*/rollouts.jsonl | wc -c)
echo "episode lines: $LINES, rollouts.jsonl total $((BYTES / 1000000)) MB"

echo "== hyperfine: negotiator report (10 runs, $LINES episodes)"
hyperfine -w 1 -r 5 --export-json "$OUT/hyperfine.json" \
  "$BIN report $OUT/runs --out $OUT/report -q"
/usr/bin/time -v "$BIN" report "$OUT/runs" --out "$OUT/report" -q 2>"$OUT/report.time" || { cat "$OUT/report.time"; exit 1; }
RSS_KB=$(sed -n 's/.*Maximum resident set size (kbytes): //p' "$OUT/report.time")
MEAN=$(sed -n 's/.*"mean": *\([0-9.]*\).*/\1/p' "$OUT/hyperfine.json" | head -1)
HTML=$(wc -c <"$OUT/report/report.html")
echo "mean wall time ${MEAN} s (target < 5 s); peak RSS $((RSS_KB / 1024)) MB; report.html $((HTML / 1000)) kB"
echo "outputs in $OUT"
