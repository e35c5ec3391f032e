#!/usr/bin/env bash
# `negotiator env-server` checked by clients we did not write, each in a
# Python virtual environment built from the package registries:
#   1. OpenEnv's validator (`openenv validate --url`), for the openenv that
#      `verifiers[openenv]` installs and for the newest openenv;
#   2. OpenEnv's GenericEnvClient plays SEEDS seeds of every scenario and tier
#      over the WebSocket with a fixed action (always_proceed) and a blind
#      schedule, and must reproduce the Rust episode loop's outcomes and
#      rewards seed for seed (both openenv versions);
#   3. verifiers' `vf-eval` runs the environment through its OpenEnv taskset
#      with `negotiator serve --policy expert` as the model, offline, and the
#      expert's rewards must equal those of `negotiator eval` on the same
#      episodes (EVAL_SEEDS seeds of every scenario and tier);
#   4. the Python examples of docs/env-server.md (OpenEnv's client, the TRL rollout
#      function's episode loop) each play an episode;
#   5. the Kubernetes manifest is validated offline (kubernetes-validate);
#   and GenericEnvClient again, through a bearer token (`--token-var`).
# Usage: scripts/openenv_check.sh [venvs]   (CI runs it from .ci/run; `venvs`
# only builds the virtual environments)
# Environment: OPENENV_CHECK_VENVS (default target/openenv-check, reused when
# present), OPENENV_CHECK_SEEDS (12: each client episode costs about 0.12 s
# of Python, and CI has 30 minutes), OPENENV_CHECK_EVAL_SEEDS (1: vf-eval
# takes about 15 s an episode, 400 s of CI's 30 minutes at 3), PYTHON.
set -euo pipefail
cd "$(dirname "$0")/.."
root=$(pwd)
venvs=${OPENENV_CHECK_VENVS:-$root/target/openenv-check}
seeds=${OPENENV_CHECK_SEEDS:-12}
eval_seeds=${OPENENV_CHECK_EVAL_SEEDS:-1}
python=${PYTHON:-python3}
schedule="yield:0.6:3,nudge_forward:0.5:3,proceed:0.8"

make_venv() { # dir, packages...
  local dir=$1
  shift
  if [ ! -x "$dir/bin/python" ]; then
    "$python" -m venv "$dir"
    "$dir/bin/pip" install --quiet --upgrade pip
    "$dir/bin/pip" install --quiet "$@"
  fi
}
# uv runs vf-eval's chat program; installed from PyPI so nothing is fetched
# from elsewhere.
make_venv "$venvs/verifiers" "verifiers[openenv]==0.4.*" jsonschema uv
make_venv "$venvs/newest" openenv jsonschema kubernetes-validate
# `openenv_check.sh venvs` only builds them (CI does, while Rust compiles).
if [ "${1:-}" = venvs ]; then
  exit 0
fi

cargo build --release --quiet --bin negotiator
cargo build --release --quiet --example reference_rollouts
bin=$root/target/release/negotiator
for v in verifiers newest; do
  echo "openenv $("$venvs/$v/bin/python" -c 'import importlib.metadata as m; print(m.version("openenv"))') ($v venv)"
done

work=$(mktemp -d)
# A token for the guarded server's check, passed through the environment.
NEGOTIATOR_CHECK_TOKEN=$(od -An -N16 -tx1 /dev/urandom | tr -d ' \n')
export NEGOTIATOR_CHECK_TOKEN
pids=()
cleanup() {
  for p in "${pids[@]}"; do kill "$p" 2>/dev/null || true; done
  rm -rf "$work"
}
trap cleanup EXIT

start() { # name, args... ; sets $port from the server's first line
  local name=$1
  shift
  "$bin" "$@" --port 0 >"$work/$name.out" 2>"$work/$name.err" &
  pids+=($!)
  for _ in $(seq 100); do
    port=$(sed -n 's#^listening on http://127.0.0.1:\([0-9]*\).*#\1#p' "$work/$name.out")
    [ -n "$port" ] && return 0
    sleep 0.1
  done
  echo "$name did not start: $(cat "$work/$name.err")" >&2
  exit 1
}
start env-server env-server
env_url=http://127.0.0.1:$port
start model serve --policy expert
model_url=http://127.0.0.1:$port/v1

echo "== openenv validate --url $env_url"
for v in verifiers newest; do
  "$venvs/$v/bin/openenv" validate --url "$env_url" >"$work/validate-$v.txt" \
    || { cat "$work/validate-$v.txt"; exit 1; }
  echo "openenv validate ($v venv): passed"
done

echo "== GenericEnvClient against the Rust episode loop ($seeds seeds per cell)"
"$root/target/release/examples/reference_rollouts" always_proceed "$seeds" >"$work/ref-fixed.jsonl"
"$root/target/release/examples/reference_rollouts" "$schedule" "$seeds" >"$work/ref-schedule.jsonl"
for v in verifiers newest; do
  "$venvs/$v/bin/python" scripts/openenv_client_check.py "$env_url" always_proceed "$work/ref-fixed.jsonl"
  "$venvs/$v/bin/python" scripts/openenv_client_check.py "$env_url" "$schedule" "$work/ref-schedule.jsonl"
done

# The same with a bearer token (`--token-var`), sent through OpenEnv's own
# `headers` (the newest openenv; 0.4 has no such argument).
start guarded env-server --token-var NEGOTIATOR_CHECK_TOKEN
guarded_url=http://127.0.0.1:$port
NEGOTIATOR_TOKEN=$NEGOTIATOR_CHECK_TOKEN "$venvs/newest/bin/python" scripts/openenv_client_check.py \
  "$guarded_url" always_proceed "$work/ref-fixed.jsonl"

echo "== vf-eval (verifiers' OpenEnv taskset) against negotiator eval ($eval_seeds seeds per cell)"
"$bin" eval --base-url "$model_url" --model expert --scenario all --tier all -n "$eval_seeds" \
  --output "$work/eval" --run-name expert >/dev/null 2>"$work/eval.err" || { cat "$work/eval.err"; exit 1; }
PATH="$venvs/verifiers/bin:$PATH" "$venvs/verifiers/bin/python" scripts/vf_eval_check.py \
  "$env_url" "$model_url" "$work/eval/expert/rollouts.jsonl" "$work/vf"
echo "== the Python examples of docs/env-server.md"
"$venvs/newest/bin/python" examples/python/openenv_client.py "$env_url" | tail -1
"$venvs/verifiers/bin/python" examples/python/trl_grpo_rollout.py "$env_url" "$model_url"

echo "== the Kubernetes manifest"
"$venvs/newest/bin/kubernetes-validate" --strict --quiet deploy/env-server.k8s.yaml && echo "deploy/env-server.k8s.yaml: valid"
echo "openenv checks passed"
