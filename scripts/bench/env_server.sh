#!/usr/bin/env bash
# Speed of `negotiator env-server` side by side with OpenEnv's own Python
# server (`create_fastapi_app` from openenv.core) serving a trivial
# environment (reset, three steps, done): a lower bound for any Python
# environment server. One run, same machine, same load generator
# (examples/ws_load.rs, Rust, so the client is not the bottleneck), at 1, 64
# and 512 concurrent WebSocket sessions.
#
# The servers take turns: each round measures every (sessions, server) cell
# once, and the table gives each cell's median over the rounds, so a slow
# minute on a shared machine lands on every server alike instead of on one.
# Prints two Markdown tables: per cell, steps per second, step round-trip
# latency percentiles, server CPU per step (user + system, and each) and
# peak server memory (first round); then, per session count, how many times
# less CPU per step env-server spends than the Python server (the median of
# the rounds' ratios, and their range).
# Usage: scripts/bench/env_server.sh [SECONDS per cell, default 8] [ROUNDS, default 3]
# Needs the `newest` venv of scripts/openenv_check.sh (created if missing).
set -euo pipefail
cd "$(dirname "$0")/../.."
root=$(pwd)
seconds=${1:-8}
rounds=${2:-3}
venv=${OPENENV_CHECK_VENVS:-$root/target/openenv-check}/newest
if [ ! -x "$venv/bin/python" ]; then
  "${PYTHON:-python3}" -m venv "$venv"
  "$venv/bin/pip" install --quiet openenv jsonschema
fi
cargo build --release --quiet --bin negotiator
cargo build --release --quiet --example ws_load
load=$root/target/release/examples/ws_load

work=$(mktemp -d)
pids=()
cleanup() {
  for p in "${pids[@]}"; do kill "$p" 2>/dev/null || true; done
  rm -rf "$work"
}
trap cleanup EXIT

"$root/target/release/negotiator" env-server --port 0 --max-sessions 4096 >"$work/rust.out" 2>/dev/null &
rust_pid=$!
pids+=($rust_pid)
python_port=$((20000 + RANDOM % 20000))
"$venv/bin/python" scripts/bench/trivial_openenv_server.py "$python_port" 4096 >"$work/python.out" 2>&1 &
python_pid=$!
pids+=($python_pid)
for _ in $(seq 100); do
  rust_port=$(sed -n 's#^listening on http://127.0.0.1:\([0-9]*\)#\1#p' "$work/rust.out")
  if [ -n "$rust_port" ] && curl -sf "http://127.0.0.1:$python_port/health" >/dev/null; then break; fi
  sleep 0.2
done

cell() { # label, sessions, url, pid, reset, action
  # Reset the server's memory high-water mark to its current size, so each
  # cell's peak is its own. The memory column still reads the first round
  # only: the allocator keeps what 512 sessions freed, so a later round's
  # small cells would show the earlier round's 512.
  echo 5 >"/proc/$4/clear_refs"
  "$load" "$3" "$2" "$seconds" "$5" "$6" "$4" |
    python3 -c 'import json, sys; r = json.load(sys.stdin); r["server"] = sys.argv[1]; print(json.dumps(r))' "$1" \
      >>"$work/cells.jsonl"
}

for round in $(seq "$rounds"); do
  echo "round $round of $rounds" >&2
  for n in 1 64 512; do
    cell "OpenEnv Python, trivial env" "$n" "ws://127.0.0.1:$python_port/ws" "$python_pid" '{}' '{"value": 1}'
    cell "env-server, view full" "$n" "ws://127.0.0.1:$rust_port/ws" "$rust_pid" \
      '{"scenario": "yield_standoff", "tier": 1}' '{"maneuver": "proceed", "acceleration": 1}'
    cell "env-server, view features" "$n" "ws://127.0.0.1:$rust_port/ws" "$rust_pid" \
      '{"scenario": "yield_standoff", "tier": 1, "view": "features"}' '{"maneuver": "proceed", "acceleration": 1}'
  done
done

python3 - "$work/cells.jsonl" "$rounds" <<'TABLES'
import json, statistics, sys
from collections import defaultdict

cells = defaultdict(list)  # (sessions, server) -> one result per round
order = []
for line in open(sys.argv[1]):
    r = json.loads(line)
    key = (r["sessions"], r["server"])
    if key not in cells:
        order.append(key)
    cells[key].append(r)
rounds = sys.argv[2]
med = statistics.median

def cpu(r):
    return r["server_cpu_us_per_step"]

print(f"Each cell: the median of {rounds} rounds.")
print()
print("| server | sessions | steps/s | step latency p50 / p90 / p99 (ms) | server CPU per step, us (user + system) | peak server memory, first round (MiB) |")
print("|---|---:|---:|---|---:|---:|")
for key in order:
    rs = cells[key]
    lat = [med(r["latency_ms"][p] for r in rs) for p in ("p50", "p90", "p99")]
    print("| " + " | ".join([
        key[1], str(key[0]), format(med(r["steps_per_s"] for r in rs), ",.0f"),
        "%.2f / %.2f / %.2f" % tuple(lat),
        "%.1f (%.1f + %.1f)" % (med(cpu(r) for r in rs),
                                med(r["server_user_us_per_step"] for r in rs),
                                med(r["server_system_us_per_step"] for r in rs)),
        "%.0f" % rs[0]["server_peak_rss_mib"]]) + " |")

print()
print("| sessions | Python CPU per step, us | env-server full: x less CPU | env-server features: x less CPU |")
print("|---:|---:|---|---|")
python = "OpenEnv Python, trivial env"
for n in sorted({k[0] for k in order}):
    base = cells[(n, python)]
    row = [str(n), "%.1f (%.1f-%.1f)" % (med(map(cpu, base)), min(map(cpu, base)), max(map(cpu, base)))]
    for view in ("full", "features"):
        ours = cells[(n, f"env-server, view {view}")]
        ratios = [cpu(p) / cpu(o) for p, o in zip(base, ours)]
        row.append("%.1fx (%.1f-%.1fx)" % (med(ratios), min(ratios), max(ratios)))
    print("| " + " | ".join(row) + " |")
TABLES
