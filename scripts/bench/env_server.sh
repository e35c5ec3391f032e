#!/usr/bin/env bash
# Speed of `negotiator env-server` side by side with OpenEnv's own Python
# server (`create_fastapi_app` from openenv.core) serving a trivial
# environment (reset, three steps, done): a lower bound for any Python
# environment server. One run, same machine, same load generator
# (examples/ws_load.rs, Rust, so the client is not the bottleneck), at 1, 64
# and 512 concurrent WebSocket sessions. Prints a Markdown table: steps per
# second, step round-trip latency percentiles, server CPU per step (user +
# system, and each), and peak server memory.
# Usage: scripts/bench/env_server.sh [SECONDS per row, default 10]
# Needs the `newest` venv of scripts/openenv_check.sh (created if missing).
set -euo pipefail
cd "$(dirname "$0")/../.."
root=$(pwd)
seconds=${1:-10}
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

row() { # label, sessions, url, pid, reset, action
  local r
  r=$("$load" "$3" "$2" "$seconds" "$5" "$6" "$4")
  python3 -c '
import json, sys
r = json.loads(sys.argv[2])
l = r["latency_ms"]
cells = [sys.argv[1], str(r["sessions"]), format(r["steps_per_s"], ",.0f"),
         "%.2f / %.2f / %.2f" % (l["p50"], l["p90"], l["p99"]),
         "%.1f (%.1f + %.1f)" % (r["server_cpu_us_per_step"], r["server_user_us_per_step"], r["server_system_us_per_step"]),
         "%.0f" % r["server_peak_rss_mib"]]
print("| " + " | ".join(cells) + " |")
' "$1" "$r"
}

echo "| server | sessions | steps/s | step latency p50 / p90 / p99 (ms) | server CPU per step, us (user + system) | peak server memory (MiB) |"
echo "|---|---:|---:|---|---:|---:|"
for n in 1 64 512; do
  row "OpenEnv Python, trivial env" "$n" "ws://127.0.0.1:$python_port/ws" "$python_pid" '{}' '{"value": 1}'
  row "env-server, view full" "$n" "ws://127.0.0.1:$rust_port/ws" "$rust_pid" \
    '{"scenario": "yield_standoff", "tier": 1}' '{"maneuver": "proceed", "acceleration": 1}'
  row "env-server, view features" "$n" "ws://127.0.0.1:$rust_port/ws" "$rust_pid" \
    '{"scenario": "yield_standoff", "tier": 1, "view": "features"}' '{"maneuver": "proceed", "acceleration": 1}'
done
