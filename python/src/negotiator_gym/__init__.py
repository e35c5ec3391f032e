"""negotiator's episodes as a Gymnasium environment, driven by the Rust
`negotiator env-server` (nothing of an episode is re-implemented here).

    import gymnasium as gym
    import negotiator_gym  # registers the id
    env = gym.make("negotiator/Negotiator-v0", scenario="pedestrian_feint", tier=1)

or, without the import, `gym.make("negotiator_gym:negotiator/Negotiator-v0")`
(Gymnasium imports the module named before the colon).
"""

from __future__ import annotations

from negotiator_gym.env import ENV_ID, NegotiatorEnv, register

register()

__all__ = ["ENV_ID", "NegotiatorEnv", "register"]
