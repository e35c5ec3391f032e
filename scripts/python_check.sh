#!/usr/bin/env bash
# The Python package (python/: the Inspect AI task and the Gymnasium
# environment), checked offline in a virtual environment built from the
# package registries: `pip install "./python[test,rl]"`, mypy --strict over
# both packages and their tests, then pytest (python/tests):
# - Inspect: its openai-api provider against `negotiator serve --policy
#   expert` must play the episodes `negotiator eval` plays, seed for seed;
#   its mockllm must drive as eval's firm stop;
# - Gymnasium: Gymnasium's and stable-baselines3's environment checkers on
#   every cell, the Rust loop's episodes seed for seed, nothing before the
#   evidence that depends on the disposition, the in-process vector's
#   episodes against the socket's (`pip install ./python/native`, built
#   here), training and the reward-hacking regression end to end;
# then the reward-hacking regression on a committed checkpoint (HACK_CELL).
# Usage: scripts/python_check.sh [venv]   (CI runs it from .ci/run; `venv`
# only builds the virtual environment)
# Environment: PYTHON_CHECK_VENV (default target/python-check, reused when
# present), HACK_CELL (default "contested_merge 1", the cell whose hacks PPO found and the world now closes), PYTHON.
set -euo pipefail
cd "$(dirname "$0")/.."
root=$(pwd)
venv=${PYTHON_CHECK_VENV:-$root/target/python-check}
python=${PYTHON:-python3}
read -r hack_scenario hack_tier <<<"${HACK_CELL:-contested_merge 1}"
if [ ! -x "$venv/bin/python" ]; then
  "$python" -m venv "$venv"
  "$venv/bin/pip" install --quiet --upgrade pip
fi
# Reinstalled every run: the package is the repository's, not a cached one.
"$venv/bin/pip" install --quiet "$root/python[test,rl]"
# `python_check.sh venv` only builds it (CI does, while Rust compiles).
if [ "${1:-}" = venv ]; then
  exit 0
fi
cargo build --release --quiet --bin negotiator --example reference_rollouts --example disposition_features
# The native extension (NativeBatchVecEnv: env-server's batch sessions in
# process, through PyO3), built by maturin into the same target directory.
CARGO_TARGET_DIR=$root/target "$venv/bin/pip" install --quiet --force-reinstall "$root/python/native"
"$venv/bin/python" -c 'import importlib.metadata as m; print(" ".join(f"{p} {m.version(p)}" for p in ["inspect_ai", "gymnasium", "stable_baselines3", "torch"]))'
export NEGOTIATOR_BIN=$root/target/release/negotiator NEGOTIATOR_EXAMPLES=$root/target/release/examples
cd "$root/python"
"$venv/bin/python" -m mypy src/negotiator src/negotiator_gym tests
"$venv/bin/python" -m pytest -q
cd "$root"
for trained in "" warm-start-expert/; do
  echo "== the reward-hacking regression on the committed $hack_scenario tier $hack_tier checkpoint (results/rl/$trained)"
  "$venv/bin/python" -m negotiator_gym.hack_check --checkpoint "results/rl/$trained$hack_scenario-t$hack_tier" \
    --scenario "$hack_scenario" --tier "$hack_tier" --seed 0 -n 200
done
