#!/usr/bin/env bash
# env-server on a shared machine, measured side by side with another build:
# for each binary, per round,
#   - 256 well-behaved WebSocket sessions playing episodes for SECONDS
#     (examples/ws_load.rs): steps/s, latency, CPU per step, peak memory;
#   - 32 HTTP and 32 WebSocket clients that each send a 1 MB body of
#     100,000 unknown keys and never read (scripts/bench/env_server_abuse.py):
#     peak memory, and how long a normal reset takes meanwhile.
# Each cell starts a fresh server, so every peak is that cell's own.
# Usage: scripts/bench/env_server_shared.sh [SECONDS] [ROUNDS] [OTHER_BINARY]
#   OTHER_BINARY: e.g. an earlier build of negotiator (optional).
# Linux only (reads /proc); loopback only.
set -euo pipefail
cd "$(dirname "$0")/../.."
seconds=${1:-8}
rounds=${2:-3}
other=${3:-}
cargo build --release --quiet --bin negotiator --example ws_load
load=target/release/examples/ws_load
bins=("target/release/negotiator")
[ -n "$other" ] && bins+=("$other")

serve() { # binary, args...: starts it, sets $pid and $port
  local out
  out=$(mktemp)
  "$@" --port 0 >"$out" 2>/dev/null &
  pid=$!
  for _ in $(seq 100); do
    port=$(sed -n 's#^listening on http://127.0.0.1:\([0-9]*\)#\1#p' "$out")
    [ -n "$port" ] && break
    sleep 0.1
  done
  rm -f "$out"
}

for round in $(seq "$rounds"); do
  for bin in "${bins[@]}"; do
    serve "$bin" env-server --max-sessions 4096
    "$load" "ws://127.0.0.1:$port/ws" 256 "$seconds" '{"scenario": "yield_standoff", "tier": 1}' \
      '{"maneuver": "proceed", "acceleration": 1}' "$pid" |
      python3 -c 'import json,sys; r=json.load(sys.stdin); print(json.dumps({"round": int(sys.argv[1]), "binary": sys.argv[2], "cell": "256 sessions", "steps_per_s": round(r["steps_per_s"]), "p50_ms": r["latency_ms"]["p50"], "p99_ms": r["latency_ms"]["p99"], "cpu_us_per_step": round(r["server_cpu_us_per_step"], 1), "peak_mib": round(r["server_peak_rss_mib"], 1)}))' "$round" "$bin"
    kill "$pid"
    wait "$pid" 2>/dev/null || true
    serve "$bin" env-server --max-sessions 4096
    python3 scripts/bench/env_server_abuse.py "$port" "$pid" 32 |
      python3 -c 'import json,sys; r=json.load(sys.stdin); r.update({"round": int(sys.argv[1]), "binary": sys.argv[2], "cell": "64 clients that never read"}); print(json.dumps(r))' "$round" "$bin"
    kill "$pid"
    wait "$pid" 2>/dev/null || true
  done
done
