"""Play one negotiator episode with OpenEnv's own client.

    negotiator env-server --port 8000 &
    pip install openenv
    python examples/python/openenv_client.py http://127.0.0.1:8000

Prints each turn's scene and the terminal metadata. The policy here is the
simplest blind one (always proceed); swap in yours.
"""

import sys

from openenv import GenericEnvClient

url = sys.argv[1] if len(sys.argv) > 1 else "http://127.0.0.1:8000"
with GenericEnvClient(base_url=url).sync() as env:
    result = env.reset(scenario="pedestrian_feint", tier=2, seed=7)
    print(result.observation["instructions"][:200], "...\n")
    while not result.done:
        print(result.observation["scene"])
        result = env.step({"maneuver": "proceed", "acceleration": 0.5})
    print("reward", result.reward)
    print("metadata", result.metadata)
