"""verifiers' own `vf-eval` runs the benchmark through its OpenEnv taskset against
`negotiator env-server`, with `negotiator serve --policy expert` as the model
endpoint, offline (no account, no push). The expert's reward there must equal, seed
for seed, its reward through `negotiator eval` on the same episodes (and so its
success).

usage: vf_eval_check.py ENV_URL MODEL_URL EVAL_ROLLOUTS.jsonl WORKDIR
The episodes are those of EVAL_ROLLOUTS.jsonl (a `negotiator eval` run against
the same model endpoint).
"""

import json
import pathlib
import subprocess
import sys


def main():
    env_url, model_url, rollouts_path, workdir = sys.argv[1:5]
    work = pathlib.Path(workdir)
    work.mkdir(parents=True, exist_ok=True)
    reference = {}
    for line in open(rollouts_path):
        if line.strip():
            r = json.loads(line)
            reference[(r["scenario"], r["tier"], r["seed"])] = r
    keys = sorted(reference)
    resets = ",\n  ".join(
        f'{{scenario = "{s}", tier = {t}, seed = {n}, view = "text"}}' for (s, t, n) in keys
    )
    (work / "eval.toml").write_text(
        f"""model = "expert"
num_rollouts = 1
max_concurrent = 4
output_dir = "{work / 'out'}"

[client]
base_url = "{model_url}"
api_key_var = "NEGOTIATOR_CHECK_UNUSED_KEY"

[env.taskset]
id = "openenv"
base_url = "{env_url}"
resets = [
  {resets},
]

[env.player.runtime]
type = "subprocess"

[env.player.harness]
id = "null"
"""
    )
    run = subprocess.run(
        ["vf-eval", "@", "eval.toml", "--no-push", "--no-rich"],
        cwd=work,
        capture_output=True,
        text=True,
    )
    if run.returncode != 0:
        print(run.stdout[-3000:], run.stderr[-3000:])
        sys.exit(f"vf-eval failed with exit code {run.returncode}")
    traces = sorted((work / "out").glob("*/traces.jsonl"))
    if not traces:
        sys.exit("vf-eval wrote no traces.jsonl")
    got = {}
    for line in open(traces[-1]):
        row = json.loads(line)
        reset = row["task"]["data"]["reset"]
        trace = row["traces"][0]
        score = trace["rewards"].get("openenv_reward", {}).get("score")
        got[(reset["scenario"], reset["tier"], reset["seed"])] = (score, trace.get("errors"))
    mismatches = []
    for key in keys:
        want = reference[key]["reward"]
        score, errors = got.get(key, (None, "missing"))
        if score != want:
            mismatches.append((key, score, want, errors))
    success_vf = sum(got.get(k, (None,))[0] == reference[k]["reward"] and reference[k]["outcome"] == "success" for k in keys)
    success_eval = sum(reference[k]["outcome"] == "success" for k in keys)
    per_scenario = {}
    for (s, _, _) in keys:
        per_scenario[s] = per_scenario.get(s, 0) + 1
    print(
        f"vf-eval (OpenEnv taskset): {len(keys)} episodes {per_scenario}; expert successes "
        f"{success_vf} through vf-eval, {success_eval} through negotiator eval; {len(mismatches)} reward mismatches"
    )
    for m in mismatches[:10]:
        print("  mismatch", m)
    sys.exit(1 if mismatches or success_vf != success_eval else 0)


if __name__ == "__main__":
    main()
