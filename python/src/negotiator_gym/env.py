"""`NegotiatorEnv`: one benchmark cell (scenario, tier) as a Gymnasium
environment over env-server's WebSocket (OpenEnv's protocol, `features`
view). The episode, its reward and its grades are env-server's, byte for
byte the episode `eval`, `baselines` and `play` give the same seed.

Observation: `Box(-1e6, 1e6, (N,), float32)`, env-server's feature vector
(SI units, unscaled; `feature_names` lists the slots, from `/metadata`; no
slot comes near the bounds: distances are metres along a short approach,
times and turn counts those of a 10-second episode).
Action: `Discrete(10)`, index i sending `actions[i]`, the (maneuver,
strength) pairs env-server publishes in `/metadata` as `discrete_actions`
(index 0, `proceed` at 0, holds the current speed; docs/rl.md lists them). Reward: 0 until the last step, then the
benchmark's episode reward (collision -1, timeout -0.5 to 0.3 by progress,
success 0.9 to 1). `terminated` is env-server's `done` (the turn budget is
part of the observation, so running out of turns is the task's own end,
never a truncation). `info` is empty until the end; the last step's `info`
has the outcome, reward, decision correctness, the evidence and commitment
turns, the choice, the teacher (None without one) and the hidden
disposition.

Teacher: `teacher="expert"` (any built-in policy `negotiator baselines`
names) adds `info["teacher_action"]` to the reset's and every step's info
but the last: the index of the discrete action nearest the move that
policy makes on the observation returned (env-server's `teacher`), and
`info["teacher_move"]`, the move itself, which `step_move` sends as it is. A
built-in policy reads only the public observation, so this is the
observation's information, interpreted; `negotiator_gym.train
--warm-start` imitates it before PPO starts.

Seeds: `reset(seed=s)` plays benchmark seed `s` (the episode `negotiator
eval --seed s -n 1` plays); a later `reset()` plays a seed drawn from the
environment's generator in [2**32, 2**53), so training never meets the small
seeds held-out evaluation uses unless it asks for them.
"""

from __future__ import annotations

import json
import os
import sys
import urllib.request
from collections.abc import Sequence
from typing import Any, SupportsFloat

import gymnasium as gym
import numpy as np
import orjson
from gymnasium import spaces

from negotiator.server import EnvServerError as ServerNotStarted
from negotiator.server import LocalServer, binary
from negotiator_gym._wire import Session

ENV_ID = "negotiator/Negotiator-v0"
TIERS = (1, 2, 3)
# The observation space's bound (see the module doc).
FEATURE_BOUND = 1e6
# Seeds a training run draws (never the small seeds of held-out evaluation).
_DRAWN_SEEDS = (2**32, 2**53)
# The grades the last step's `info` carries, as env-server names them.
FINAL_INFO = (
    "outcome",
    "reward",
    "decision_correctness",
    "evidence_turn",
    "commitment_turn",
    "choice",
    "guessed",
    "disposition",
    "teacher",
)


class EnvServerError(RuntimeError):
    """env-server refused a message (its own error code and message)."""


def register() -> None:
    """Register `negotiator/Negotiator-v0` with Gymnasium (idempotent)."""
    if ENV_ID not in gym.registry:
        gym.register(id=ENV_ID, entry_point="negotiator_gym.env:NegotiatorEnv")


def scenarios_at(base_url: str, token: str | None = None) -> list[str]:
    """The scenarios the env-server at `base_url` serves (its `/metadata`)."""
    return list(fetch_metadata(base_url.rstrip("/"), bearer_headers(token))["scenarios"])


def refused_cell(prog: str, scenario: str, tier: int, base_url: str) -> bool:
    """For a command line: whether the env-server at `base_url` lacks the
    cell, said on stderr in one line naming the served scenarios."""
    try:
        check_cell(scenario, tier, scenarios_at(base_url))
    except ValueError as e:
        print(f"{prog}: error: --scenario: {e}", file=sys.stderr)
        return True
    return False


def local_server(prog: str) -> LocalServer:
    """For a command line given no `--base-url`: an env-server started
    here, or (no binary to start) the one-line error naming the flag, and
    exit 2."""
    try:
        return LocalServer(binary("--base-url URL"))
    except ServerNotStarted as e:
        print(f"{prog}: error: {e}", file=sys.stderr)
        raise SystemExit(2) from None


def fetch_metadata(base_url: str, headers: dict[str, str]) -> dict[str, Any]:
    request = urllib.request.Request(base_url + "/metadata", headers=headers)
    with urllib.request.urlopen(request, timeout=30) as answer:
        meta: dict[str, Any] = json.load(answer)
    return meta


class Endpoint:
    """The env-server an environment plays on: the one at `base_url`, or
    one started here (the binary on `PATH` or named by `NEGOTIATOR_BIN`)
    and stopped by `close()`; with its feature layout and action list from
    `/metadata`, and the spaces they make. `meta` given (the in-process
    sessions' own document), no server is reached or started."""

    def __init__(self, base_url: str | None, token: str | None, meta: dict[str, Any] | None = None) -> None:
        self._local: LocalServer | None = None
        if base_url is None and meta is None:
            self._local = LocalServer(binary("base_url=URL"))
            base_url = self._local.url
        self.base_url = (base_url or "").rstrip("/")
        self.headers = bearer_headers(token)
        if meta is None:
            meta = fetch_metadata(self.base_url, self.headers)
        self.scenarios: list[str] = list(meta["scenarios"])
        self.feature_names: list[str] = list(meta["feature_names"])
        self.actions: list[dict[str, Any]] = list(meta["discrete_actions"])
        self.teachers: list[str] = list(meta["teachers"])
        self.observation_space = spaces.Box(-FEATURE_BOUND, FEATURE_BOUND, (len(self.feature_names),), np.float32)
        self.action_space = spaces.Discrete(len(self.actions))
        # Every step message, encoded once.
        self.step_messages = [json.dumps({"type": "step", "data": a}) for a in self.actions]

    def check(self, scenario: str, tier: int, teacher: str | None) -> None:
        """Refuse a cell or a teacher env-server does not have, naming the
        choices (and stop a server started here)."""
        try:
            check_cell(scenario, tier, self.scenarios)
            if teacher is not None and teacher not in self.teachers:
                raise ValueError(f"unknown teacher {teacher!r}: one of {', '.join(self.teachers)}")
        except ValueError:
            self.close()
            raise

    def connect(self, path: str) -> Session:
        """A WebSocket connection to `path` (`/ws`, `/ws/batch`)."""
        return Session("ws" + self.base_url.removeprefix("http") + path, self.headers)

    def close(self) -> None:
        if self._local is not None:
            self._local.close()
            self._local = None


def check_cell(scenario: str, tier: int, scenarios: Sequence[str]) -> None:
    """Refuse a scenario or tier the benchmark does not have, naming the
    choices: `scenarios` as the env-server's `/metadata` lists them (the
    benchmark's registry; this package keeps no list of its own)."""
    if scenario not in scenarios:
        raise ValueError(f"unknown scenario {scenario!r}: one of {', '.join(scenarios)}")
    if tier not in TIERS:
        raise ValueError(f"unknown tier {tier!r}: 1, 2 or 3")


def bearer_headers(token: str | None) -> dict[str, str]:
    """The headers env-server's `--token-var` asks for (`NEGOTIATOR_TOKEN` by default)."""
    token = token if token is not None else os.environ.get("NEGOTIATOR_TOKEN")
    return {"Authorization": f"Bearer {token}"} if token else {}


def draw_episode_seed(rng: np.random.Generator) -> int:
    """The benchmark seed a reset without one plays."""
    return int(rng.integers(*_DRAWN_SEEDS))


def reset_message(scenario: str, tier: int, seed: int, view: str, teacher: str | None = None) -> str:
    """The reset message that plays benchmark seed `seed` of the cell
    (with `teacher`'s move on every observation, if one is named)."""
    data: dict[str, Any] = {"scenario": scenario, "tier": tier, "seed": seed, "view": view}
    if teacher is not None:
        data["teacher"] = teacher
    return json.dumps({"type": "reset", "data": data})


def teacher_move(data: dict[str, Any]) -> dict[str, Any] | None:
    """The teacher's move itself on an answer's observation, as a step's
    data (`maneuver`, `acceleration`); None without a teacher, and at the
    episode's end."""
    move = data["observation"].get("teacher")
    return None if move is None else {"maneuver": move["maneuver"], "acceleration": move["acceleration"]}


def teacher_action(data: dict[str, Any]) -> int | None:
    """The discrete action nearest the teacher's move on an answer's
    observation (None without a teacher, and at the episode's end)."""
    move = data["observation"].get("teacher")
    return None if move is None else int(move["discrete_action"])


def answer_data(answer: dict[str, Any]) -> dict[str, Any]:
    """An answer's `data`, or env-server's refusal raised."""
    if answer.get("type") == "error":
        error = answer.get("data", {})
        raise EnvServerError(f"{error.get('code')}: {error.get('message')}")
    data: dict[str, Any] = answer["data"]
    return data


def final_info(data: dict[str, Any], episode_seed: int | None) -> dict[str, Any]:
    """The last step's `info`: the grades and the hidden disposition."""
    meta = data.get("metadata") or {}
    info = {key: meta.get(key) for key in FINAL_INFO}
    info["seed"] = episode_seed
    return info


def features(data: dict[str, Any]) -> np.ndarray:
    """An answer's observation as the `Box` holds it."""
    return np.asarray(data["observation"]["features"], dtype=np.float32)


class NegotiatorEnv(gym.Env[np.ndarray, np.int64]):
    metadata = {"render_modes": ["ansi"], "render_fps": 2}

    def __init__(
        self,
        scenario: str = "yield_standoff",
        tier: int = 1,
        base_url: str | None = None,
        token: str | None = None,
        render_mode: str | None = None,
        teacher: str | None = None,
    ) -> None:
        if render_mode is not None and render_mode not in self.metadata["render_modes"]:
            raise ValueError(f"unknown render_mode {render_mode!r}: 'ansi' or None")
        self.scenario = scenario
        self.tier = tier
        self.render_mode = render_mode
        self.teacher = teacher
        self._endpoint = Endpoint(base_url, token)
        self._endpoint.check(scenario, tier, teacher)
        self.base_url = self._endpoint.base_url
        self.feature_names = self._endpoint.feature_names
        self.actions = self._endpoint.actions
        self.observation_space = self._endpoint.observation_space
        self.action_space = self._endpoint.action_space
        self._ws: Session | None = self._endpoint.connect("/ws")
        self._scene = ""
        self._done = True
        self.episode_seed: int | None = None

    def _post_text(self, message: str) -> None:
        if self._ws is None:
            raise RuntimeError("the environment is closed")
        self._ws.send(message)

    def _receive(self) -> dict[str, Any]:
        assert self._ws is not None
        # orjson: a step's answer is read about 7x faster than with json.
        return answer_data(orjson.loads(self._ws.recv()))

    def _observe(self, answer: dict[str, Any]) -> np.ndarray:
        if self.render_mode == "ansi":
            self._scene = answer["observation"].get("scene", "")
        return features(answer)

    def reset(
        self, *, seed: int | None = None, options: dict[str, Any] | None = None
    ) -> tuple[np.ndarray, dict[str, Any]]:
        self.send_reset(seed=seed)
        return self.receive_reset()

    def send_reset(self, *, seed: int | None = None) -> None:
        """The first half of `reset`: draw the episode's seed (or take
        `seed`) and ask for the episode without waiting for it
        (`PipelinedVecEnv` sends every finished environment's reset before
        reading any)."""
        super().reset(seed=seed)
        if seed is not None:
            episode_seed = int(seed)
        else:
            episode_seed = draw_episode_seed(self.np_random)
        view = "full" if self.render_mode == "ansi" else "features"
        self._post_text(reset_message(self.scenario, self.tier, episode_seed, view, self.teacher))
        self.episode_seed = episode_seed

    def receive_reset(self) -> tuple[np.ndarray, dict[str, Any]]:
        """The second half of `reset`: the episode's first observation."""
        answer = self._receive()
        self._done = False
        info: dict[str, Any] = {"seed": self.episode_seed}
        if self.teacher is not None:
            info["teacher_action"] = teacher_action(answer)
            info["teacher_move"] = teacher_move(answer)
        return self._observe(answer), info

    def step(self, action: np.int64 | int) -> tuple[np.ndarray, SupportsFloat, bool, bool, dict[str, Any]]:
        self.send_step(action)
        return self.receive_step()

    def send_step(self, action: np.int64 | int) -> None:
        """The first half of `step`: send the action without waiting for
        the answer (`PipelinedVecEnv` sends every environment's action
        before reading any, so the server steps the sessions together)."""
        if self._done:
            raise RuntimeError("step() after the episode ended: call reset()")
        self._post_text(self._endpoint.step_messages[int(action)])

    def receive_step(self) -> tuple[np.ndarray, SupportsFloat, bool, bool, dict[str, Any]]:
        """The second half of `step`: the answer to the action sent."""
        answer = self._receive()
        done = bool(answer["done"])
        info: dict[str, Any] = {}
        if done:
            self._done = True
            info = final_info(answer, self.episode_seed)
        elif self.teacher is not None:
            info["teacher_action"] = teacher_action(answer)
            info["teacher_move"] = teacher_move(answer)
        reward = float(answer.get("reward") or 0.0)
        return self._observe(answer), reward, done, False, info

    def step_move(self, move: dict[str, Any]) -> tuple[np.ndarray, SupportsFloat, bool, bool, dict[str, Any]]:
        """`step` with a move outside the discrete actions: a maneuver and
        an acceleration in [-1, 1] (a teacher's `info["teacher_move"]`), as
        env-server's step takes it."""
        if self._done:
            raise RuntimeError("step_move() after the episode ended: call reset()")
        self._post_text(json.dumps({"type": "step", "data": move}))
        return self.receive_step()

    def render(self) -> str | None:
        if self.render_mode == "ansi":
            return self._scene
        return None

    def close(self) -> None:
        if self._ws is not None:
            try:
                self._ws.close()
            finally:
                self._ws = None
        self._endpoint.close()
        super().close()
