#!/usr/bin/env bash
# The Inspect AI task (python/), checked offline in a virtual environment
# built from the package registries: `pip install ./python[test]`, mypy
# --strict over the package and its tests, then pytest (python/tests): Inspect's openai-api provider against `negotiator
# serve --policy expert` must play the episodes `negotiator eval` plays, seed
# for seed; Inspect's mockllm must drive as eval's firm stop.
# Usage: scripts/inspect_check.sh   (CI runs it from .ci/run)
# Environment: INSPECT_CHECK_VENV (default target/inspect-check, reused when
# present), PYTHON.
set -euo pipefail
cd "$(dirname "$0")/.."
root=$(pwd)
venv=${INSPECT_CHECK_VENV:-$root/target/inspect-check}
python=${PYTHON:-python3}
cargo build --release --quiet --bin negotiator --example reference_rollouts
if [ ! -x "$venv/bin/python" ]; then
  "$python" -m venv "$venv"
  "$venv/bin/pip" install --quiet --upgrade pip
fi
# Reinstalled every run: the package is the repository's, not a cached one.
"$venv/bin/pip" install --quiet "$root/python[test]"
echo "inspect-ai $("$venv/bin/python" -c 'import importlib.metadata as m; print(m.version("inspect_ai"))')"
cd "$root/python"
"$venv/bin/python" -m mypy src/negotiator tests
NEGOTIATOR_BIN=$root/target/release/negotiator NEGOTIATOR_EXAMPLES=$root/target/release/examples \
  "$venv/bin/python" -m pytest -q
