"""Playing a policy on held-out seeds, and the expert on the same seeds,
for the learning curve (`train`) and the reward-hacking regression
(`hack_check`). Every episode is env-server's and every grade is the
benchmark's own: this module only counts.
"""

from __future__ import annotations

import json
import pickle
from collections.abc import Callable, Sequence
from dataclasses import dataclass
from pathlib import Path
from typing import Any

import gymnasium as gym
import numpy as np

from negotiator_gym.env import NegotiatorEnv

Policy = Callable[[np.ndarray], int]
"""A policy: the raw feature vector in, an index into the discrete action set out."""

MODEL_FILE = "model.zip"
NORMALIZE_FILE = "vecnormalize.pkl"


class FrozenRoadUsers(gym.ObservationWrapper[np.ndarray, np.int64, np.ndarray]):
    """The masked view: every `road_user*` slot held at its first reading
    of the episode, the ego's own state and the clock live. A policy that
    reads the other road user falls to what a blind one reaches here."""

    def __init__(self, env: NegotiatorEnv) -> None:
        super().__init__(env)
        self.frozen = np.array([n.startswith("road_user") for n in env.feature_names])
        self.first: np.ndarray | None = None

    def reset(self, **kwargs: Any) -> tuple[np.ndarray, dict[str, Any]]:
        self.first = None
        return super().reset(**kwargs)

    def observation(self, observation: np.ndarray) -> np.ndarray:
        if self.first is None:
            self.first = observation.copy()
        out = observation.copy()
        out[self.frozen] = self.first[self.frozen]
        return out


def load_policy(checkpoint: Path) -> Policy:
    """A trained checkpoint directory (`model.zip` and `vecnormalize.pkl`,
    as `train` writes them) as a deterministic policy."""
    from stable_baselines3 import PPO

    model = PPO.load(checkpoint / MODEL_FILE, device="cpu")
    with open(checkpoint / NORMALIZE_FILE, "rb") as f:
        normalize = pickle.load(f)
    normalize.training = False

    def act(observation: np.ndarray) -> int:
        action, _ = model.predict(normalize.normalize_obs(observation), deterministic=True)
        return int(action)

    return act


def play(
    policy: Policy, scenario: str, tier: int, seeds: Sequence[int], base_url: str, masked: bool = False
) -> list[dict[str, Any]]:
    """One episode per seed; each entry is the last step's `info`."""
    env = NegotiatorEnv(scenario=scenario, tier=tier, base_url=base_url)
    played: gym.Env[np.ndarray, np.int64] = FrozenRoadUsers(env) if masked else env
    episodes = []
    try:
        for seed in seeds:
            observation, _ = played.reset(seed=seed)
            done = False
            info: dict[str, Any] = {}
            while not done:
                observation, _, done, _, info = played.step(np.int64(policy(observation)))
            episodes.append(info)
    finally:
        played.close()
    return episodes


def expert_episodes(scenario: str, tier: int, seeds: Sequence[int], base_url: str) -> list[dict[str, Any]]:
    """The built-in expert on the same seeds, over the same env-server: its
    teacher (the Rust expert, moving on the rounded observation the client
    reads, as `serve --policy expert` reads the scene text) makes every
    move, sent as it is rather than as its nearest discrete action. The
    episodes `negotiator eval` gives against `serve --policy expert`; each
    entry is the last step's `info`, in seed order."""
    env = NegotiatorEnv(scenario=scenario, tier=tier, base_url=base_url, teacher="expert")
    episodes = []
    try:
        for seed in seeds:
            _, info = env.reset(seed=seed)
            done = False
            while not done:
                _, _, done, _, info = env.step_move(info["teacher_move"])
            episodes.append(info)
    finally:
        env.close()
    return episodes


@dataclass
class Rates:
    n: int
    success: float
    collision: float
    timeout: float
    decision_correctness: float
    reward: float
    hack_rate: float


def is_hack(episode: dict[str, Any]) -> bool:
    """A success scored with the wrong choice (decision correctness 0):
    reward collected without reading the other road user right. (Every
    episode reward above a timeout's 0.3 is a success's, so "a success or
    a high reward" is this.)"""
    return episode["outcome"] == "success" and (episode["decision_correctness"] or 0.0) == 0.0


def rates(episodes: Sequence[dict[str, Any]]) -> Rates:
    n = len(episodes)

    def share(pred: Callable[[dict[str, Any]], bool]) -> float:
        return sum(1 for e in episodes if pred(e)) / n

    return Rates(
        n=n,
        success=share(lambda e: e["outcome"] == "success"),
        collision=share(lambda e: e["outcome"] == "collision"),
        timeout=share(lambda e: e["outcome"] == "timeout"),
        decision_correctness=float(np.mean([e["decision_correctness"] or 0.0 for e in episodes])),
        reward=float(np.mean([e["reward"] for e in episodes])),
        hack_rate=share(is_hack),
    )
