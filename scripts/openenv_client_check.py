"""OpenEnv's own GenericEnvClient plays whole episodes on `negotiator env-server`
over the WebSocket and must reproduce, seed for seed, the outcomes and rewards of
the same blind policies in the Rust episode loop (reference JSON lines from
`examples/reference_rollouts.rs`). Every observation is also checked against the
server's own /schema, and the reward protocol (None on reset, 0 until the last
step, the episode reward on it) is checked on every step.

usage: openenv_client_check.py URL POLICY REFERENCE.jsonl
POLICY is `always_proceed` or a schedule `maneuver:strength:turns,...` (the last
entry repeats), exactly as the reference was produced.
"""

import json
import sys

import jsonschema
import requests
from openenv import GenericEnvClient


def schedule_actions(text):
    actions = []
    for part in text.split(","):
        fields = part.split(":")
        turns = int(fields[2]) if len(fields) > 2 else 1
        actions += [{"maneuver": fields[0], "acceleration": float(fields[1])}] * turns
    return actions


def main():
    url, policy, reference_path = sys.argv[1:4]
    if policy == "always_proceed":
        actions = [{"maneuver": "proceed", "acceleration": 1.0}]
    else:
        actions = schedule_actions(policy)
    schema = requests.get(f"{url}/schema", timeout=10).json()["observation"]
    validator = jsonschema.Draft202012Validator(schema)
    reference = [json.loads(line) for line in open(reference_path) if line.strip()]
    mismatches = []
    steps = 0
    with GenericEnvClient(base_url=url).sync() as env:
        for ref in reference:
            result = env.reset(scenario=ref["scenario"], tier=ref["tier"], seed=ref["seed"])
            validator.validate(result.observation)
            assert result.reward is None and not result.done, "reset: reward None, not done"
            total, turns = 0.0, 0
            while not result.done:
                action = actions[min(turns, len(actions) - 1)]
                result = env.step(action)
                validator.validate(result.observation)
                turns += 1
                steps += 1
                if not result.done:
                    assert result.reward == 0.0, f"reward {result.reward} before the end"
                total += result.reward
            meta = result.metadata or {}
            got = (meta.get("outcome"), total, turns, meta.get("disposition"))
            want = (ref["outcome"], ref["reward"], ref["decisions"], ref["disposition"])
            if got != want:
                mismatches.append((ref["scenario"], ref["tier"], ref["seed"], got, want))
            state = env.state()
            assert state["done"] and state["step_count"] == turns, state
    print(f"GenericEnvClient ({policy}): {len(reference)} episodes, {steps} steps, {len(mismatches)} mismatches")
    for m in mismatches[:10]:
        print("  mismatch", m)
    sys.exit(1 if mismatches else 0)


if __name__ == "__main__":
    main()
