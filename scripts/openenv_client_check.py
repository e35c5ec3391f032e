"""OpenEnv's own GenericEnvClient plays whole episodes on `negotiator env-server`
over the WebSocket and must reproduce, seed for seed, the outcomes and rewards of
the same blind policies in the Rust episode loop (reference JSON lines from
`examples/reference_rollouts.rs`). Every observation is also checked against the
server's own /schema, and the reward protocol (None on reset, 0 until the last
step, the episode reward on it) is checked on every step.

usage: openenv_client_check.py URL POLICY REFERENCE.jsonl
POLICY is `always_proceed` or a schedule `maneuver:strength:turns,...` (the last
entry repeats), exactly as the reference was produced.

With NEGOTIATOR_TOKEN set (a server started with `--token-var`), the client
sends it as `Authorization: Bearer ...` through OpenEnv's own `headers`, after
checking that a client without it is refused.
"""

import json
import os
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
    token = os.environ.get("NEGOTIATOR_TOKEN")
    headers = {"Authorization": f"Bearer {token}"} if token else None
    if token:
        assert requests.get(f"{url}/schema", timeout=10).status_code == 401, "no token: refused"
        served = False
        try:
            with GenericEnvClient(base_url=url).sync() as env:
                env.reset(seed=1)
                served = True
        except Exception:
            pass
        assert not served, "a WebSocket client without the token was served"
    schema = requests.get(f"{url}/schema", headers=headers, timeout=10).json()["observation"]
    validator = jsonschema.Draft202012Validator(schema)
    reference = [json.loads(line) for line in open(reference_path) if line.strip()]
    mismatches = []
    steps = 0
    client = GenericEnvClient(base_url=url, headers=headers) if headers else GenericEnvClient(base_url=url)
    with client.sync() as env:
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
    guarded = ", bearer token" if token else ""
    print(f"GenericEnvClient ({policy}{guarded}): {len(reference)} episodes, {steps} steps, {len(mismatches)} mismatches")
    for m in mismatches[:10]:
        print("  mismatch", m)
    sys.exit(1 if mismatches else 0)


if __name__ == "__main__":
    main()
