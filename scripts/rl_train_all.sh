#!/usr/bin/env bash
# Train PPO on every cell and write results/rl/: one directory per cell
# (checkpoint, learning curve, command, timing) and summary.json, one entry
# per cell from the reward-hacking regression on held-out seeds 0..N.
# Usage: scripts/rl_train_all.sh [STEPS (400000)] [N (200)] [JOBS (2)]
# Needs a Python with `pip install "./python[rl]"` as PYTHON (default
# python3) and the built binary (cargo build --release).
# WARM_START=expert trains every cell from a DAgger warm start on that
# built-in policy (train.py's --warm-start) into results/rl/warm-start-expert/.
# TRAIN_ARGS (e.g. --native) are added to every train.py command.
# SCENARIOS (default: every scenario the binary serves, from env-server's
# /metadata) retrains only those scenarios' cells, e.g. after a change to
# one world; summary.json still lists every cell, in the served order.
set -euo pipefail
cd "$(dirname "$0")/.."
steps=${1:-400000}
n=${2:-200}
jobs=${3:-2}
python=${PYTHON:-python3}
export NEGOTIATOR_BIN=${NEGOTIATOR_BIN:-$(pwd)/target/release/negotiator}
warm=${WARM_START:-}
out=results/rl${warm:+/warm-start-$warm}
mkdir -p "$out"
served=$("$python" -c 'from negotiator.server import LocalServer; from negotiator_gym.env import scenarios_at
server = LocalServer(__import__("os").environ["NEGOTIATOR_BIN"])
try: print(" ".join(scenarios_at(server.url)))
finally: server.close()')
cells=()
for s in ${SCENARIOS:-$served}; do
  for t in 1 2 3; do cells+=("$s $t"); done
done
train_cell() { # scenario tier
  mkdir -p "$out/$1-t$2"
  "$python" -m negotiator_gym.train --scenario "$1" --tier "$2" --steps "$steps" --seed 0 \
    ${warm:+--warm-start "$warm"} ${TRAIN_ARGS:-} --out "$out/$1-t$2" >"$out/$1-t$2/train.log" 2>&1
  "$python" -m negotiator_gym.hack_check --checkpoint "$out/$1-t$2" --scenario "$1" --tier "$2" \
    --seed 0 -n "$n" --json >"$out/$1-t$2/hack_check.json" || true
  echo "$1 tier $2: $(tail -1 "$out/$1-t$2/train.log")"
}
running=0
for c in "${cells[@]}"; do
  train_cell $c &
  running=$((running + 1))
  if [ "$running" -ge "$jobs" ]; then wait -n; running=$((running - 1)); fi
done
wait
"$python" - "$out" "$steps" "$warm" "$served" <<'PY'
import json, pathlib, sys
out, steps, warm = pathlib.Path(sys.argv[1]), int(sys.argv[2]), sys.argv[3] or None
served = sys.argv[4].split()
keys = ["scenario", "tier", "n", "success", "collision", "timeout", "decision_correctness", "hack_rate",
        "expert_hack_rate", "masked_success", "expert_success", "no_hack", "reads", "success_minus_expert",
        "success_minus_expert_stderr"]
entries = []
for cell in sorted(out.glob("*-t[123]/hack_check.json")):
    e = json.loads(cell.read_text())
    row = {k: e[k] for k in keys}
    row["steps"] = steps
    row["warm_start"] = warm
    row["checkpoint"] = str(cell.parent)
    entries.append(row)
entries.sort(key=lambda r: (served.index(r["scenario"]), r["tier"]))
(out / "summary.json").write_text(json.dumps(entries, indent=2) + "\n")
print(f"{out / 'summary.json'}: {len(entries)} cells")
PY
