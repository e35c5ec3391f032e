"""Vectorised environments for stable-baselines3.

- `BatchVecEnv` (what `negotiator_gym.train` uses): environments of one
  cell as the sessions of a single env-server `/ws/batch` connection, one
  message each way per vector step.
- `NativeBatchVecEnv`: `BatchVecEnv` with env-server's batch sessions in
  this process (the optional `negotiator-native` extension, `pip install
  ./python/native`): the same messages and answers, no socket.
- `PipelinedVecEnv`: stable-baselines3's `DummyVecEnv` over several
  `NegotiatorEnv`s (one env-server session each, so each may be a
  different cell) that sends every environment's action before it reads
  any answer. env-server steps the sessions on its own threads while the
  client waits once per vector step instead of once per environment, and
  the resets of the environments whose episodes ended are sent together
  too; the episodes are the same ones, answer for answer (each session is
  independent)."""

from __future__ import annotations

from collections.abc import Callable
from types import ModuleType
from typing import Any, Protocol

import gymnasium as gym
import numpy as np
import orjson
from gymnasium.utils import seeding
from stable_baselines3.common.vec_env import DummyVecEnv, VecEnv
from stable_baselines3.common.vec_env.base_vec_env import VecEnvIndices, VecEnvObs, VecEnvStepReturn

from negotiator_gym._wire import Session
from negotiator_gym.env import (
    Endpoint,
    EnvServerError,
    NegotiatorEnv,
    answer_data,
    draw_episode_seed,
    features,
    final_info,
    reset_message,
    teacher_action,
)

# Most sessions one `/ws/batch` connection holds (env-server's bound).
MAX_BATCH_SESSIONS = 64


class PipelinedVecEnv(DummyVecEnv):
    def __init__(self, env_fns: list[Callable[[], gym.Env]]) -> None:
        super().__init__(env_fns)
        for env in self.envs:
            if not isinstance(env, NegotiatorEnv):
                raise TypeError("PipelinedVecEnv steps NegotiatorEnv instances, unwrapped")
        self.sessions: list[NegotiatorEnv] = [env for env in self.envs if isinstance(env, NegotiatorEnv)]

    def step_wait(self) -> VecEnvStepReturn:
        for session, action in zip(self.sessions, self.actions):
            session.send_step(action)
        finished: list[int] = []
        for i, session in enumerate(self.sessions):
            obs, reward, terminated, truncated, info = session.receive_step()
            self.buf_rews[i] = float(reward)
            self.buf_infos[i] = info
            # DummyVecEnv's own bookkeeping, unchanged.
            self.buf_dones[i] = terminated or truncated
            self.buf_infos[i]["TimeLimit.truncated"] = truncated and not terminated
            if self.buf_dones[i]:
                self.buf_infos[i]["terminal_observation"] = obs
                finished.append(i)
                # Its next episode is asked for now and read below, with
                # the others', so the server starts them together.
                session.send_reset()
            else:
                self._save_obs(i, obs)
        for i in finished:
            obs, self.reset_infos[i] = self.sessions[i].receive_reset()
            self._save_obs(i, obs)
        # Every info is a fresh dict each step (receive_step builds it), so
        # the list is returned without DummyVecEnv's deep copy.
        return (self._obs_from_buf(), np.copy(self.buf_rews), np.copy(self.buf_dones), list(self.buf_infos))


class Transport(Protocol):
    """Where `BatchVecEnv`'s messages go: a `/ws/batch` connection, or
    the same sessions in-process."""

    def send(self, text: str) -> None: ...

    def recv(self) -> bytes | str: ...

    def close(self) -> None: ...


class BatchVecEnv(VecEnv):
    """`num_envs` environments of one cell (scenario, tier) over a single
    `/ws/batch` connection: each vector step is one message each way, the
    actions of every environment in one and their answers in the other
    (and, when episodes ended, one more pair for their resets). Each
    environment is a session of its own on the server, and plays exactly
    the episodes `NegotiatorEnv` plays under stable-baselines3's
    `DummyVecEnv` on the same seeds: the same first seed `seed(s)` gives
    (s + i for environment i), the same seeds drawn after it, the same
    observations, rewards and infos (a test holds them equal).

    Per environment step this costs the client about half the CPU of one
    connection per environment (`PipelinedVecEnv`; docs/rl.md has the
    figures).

    With `teacher` (a built-in policy's name), each environment's reset
    and step infos carry `teacher_action` as `NegotiatorEnv`'s do, and
    `teacher_actions` holds the teacher's action for every environment's
    current observation."""

    def __init__(
        self,
        num_envs: int,
        scenario: str = "yield_standoff",
        tier: int = 1,
        base_url: str | None = None,
        token: str | None = None,
        teacher: str | None = None,
    ) -> None:
        if not 1 <= num_envs <= MAX_BATCH_SESSIONS:
            raise ValueError(f"num_envs {num_envs!r}: 1 to {MAX_BATCH_SESSIONS} per connection")
        self.scenario = scenario
        self.tier = tier
        self.render_mode = None
        self.teacher = teacher
        self.teacher_actions = np.zeros(num_envs, dtype=np.int64)
        self._endpoint = self._make_endpoint(base_url, token)
        self._endpoint.check(scenario, tier, teacher)
        self.feature_names = self._endpoint.feature_names
        self.actions = self._endpoint.actions
        super().__init__(num_envs, self._endpoint.observation_space, self._endpoint.action_space)
        self._ws: Transport | None = self._connect()
        # Each environment's generator, as `NegotiatorEnv.np_random`.
        self._rngs: list[np.random.Generator | None] = [None] * num_envs
        self.episode_seeds: list[int | None] = [None] * num_envs
        self._obs = np.zeros((num_envs, len(self.feature_names)), dtype=np.float32)
        self._actions: np.ndarray | None = None

    def _make_endpoint(self, base_url: str | None, token: str | None) -> Endpoint:
        return Endpoint(base_url, token)

    def _connect(self) -> Transport:
        session: Session = self._endpoint.connect("/ws/batch")
        return session

    def _reset_entry(self, i: int, seed: int | None) -> str:
        """Environment i's reset message, its seed taken as
        `NegotiatorEnv.reset(seed=seed)` takes it."""
        if seed is not None:
            self._rngs[i] = seeding.np_random(seed)[0]
            episode_seed = int(seed)
        else:
            rng = self._rngs[i]
            if rng is None:
                rng = self._rngs[i] = seeding.np_random()[0]
            episode_seed = draw_episode_seed(rng)
        self.episode_seeds[i] = episode_seed
        return reset_message(self.scenario, self.tier, episode_seed, "features", self.teacher)

    def _read_reset(self, i: int, answer: dict[str, Any]) -> None:
        self._obs[i] = features(answer)
        self.reset_infos[i] = {"seed": self.episode_seeds[i]}
        self._read_teacher(i, answer, self.reset_infos[i])

    def _read_teacher(self, i: int, answer: dict[str, Any], info: dict[str, Any]) -> None:
        if self.teacher is not None:
            action = teacher_action(answer)
            assert action is not None
            self.teacher_actions[i] = info["teacher_action"] = action

    def _exchange(self, entries: list[str | None]) -> list[dict[str, Any] | None]:
        if self._ws is None:
            raise RuntimeError("the environments are closed")
        self._ws.send('{"type":"batch","data":[' + ",".join(e or "null" for e in entries) + "]}")
        answer: dict[str, Any] = orjson.loads(self._ws.recv())
        if answer.get("type") != "batch":
            answer_data(answer)  # env-server's refusal of the whole batch, raised
            raise EnvServerError(f"expected a batch answer, got {answer.get('type')!r}")
        answers: list[dict[str, Any] | None] = answer["data"]
        return [None if a is None else answer_data(a) for a in answers]

    def reset(self) -> VecEnvObs:
        answers = self._exchange([self._reset_entry(i, self._seeds[i]) for i in range(self.num_envs)])
        for i, answer in enumerate(answers):
            assert answer is not None
            self._read_reset(i, answer)
        self._reset_seeds()
        self._reset_options()
        return self._obs.copy()

    def step_async(self, actions: np.ndarray) -> None:
        self._actions = actions

    def step_wait(self) -> VecEnvStepReturn:
        if self._actions is None:
            raise RuntimeError("step_wait() without step_async()")
        answers = self._exchange([self._endpoint.step_messages[int(a)] for a in self._actions])
        self._actions = None
        rewards = np.zeros(self.num_envs, dtype=np.float32)
        dones = np.zeros(self.num_envs, dtype=bool)
        infos: list[dict[str, Any]] = []
        resets: list[str | None] = [None] * self.num_envs
        for i, answer in enumerate(answers):
            assert answer is not None
            rewards[i] = float(answer.get("reward") or 0.0)
            dones[i] = bool(answer["done"])
            # As DummyVecEnv marks every step of NegotiatorEnv (never truncated).
            info: dict[str, Any] = {"TimeLimit.truncated": False}
            if dones[i]:
                info = final_info(answer, self.episode_seeds[i]) | info
                info["terminal_observation"] = features(answer)
                resets[i] = self._reset_entry(i, None)
            else:
                self._obs[i] = features(answer)
                self._read_teacher(i, answer, info)
            infos.append(info)
        if any(resets):
            for i, answer in enumerate(self._exchange(resets)):
                if answer is not None:
                    self._read_reset(i, answer)
        return self._obs.copy(), rewards, dones, infos

    def close(self) -> None:
        if self._ws is not None:
            try:
                self._ws.close()
            finally:
                self._ws = None
        self._endpoint.close()

    def get_attr(self, attr_name: str, indices: VecEnvIndices = None) -> list[Any]:
        """The environments share every attribute but their episode seed."""
        if attr_name == "episode_seed":
            return [self.episode_seeds[i] for i in self._get_indices(indices)]
        value = getattr(self, attr_name)
        return [value for _ in self._get_indices(indices)]

    def set_attr(self, attr_name: str, value: Any, indices: VecEnvIndices = None) -> None:
        raise AttributeError(f"BatchVecEnv's environments share their attributes: cannot set {attr_name!r} on some")

    def env_method(self, method_name: str, *args: Any, indices: VecEnvIndices = None, **kwargs: Any) -> list[Any]:
        raise AttributeError(f"BatchVecEnv holds no environment objects to call {method_name!r} on")

    def env_is_wrapped(self, wrapper_class: type[gym.Wrapper], indices: VecEnvIndices = None) -> list[bool]:
        return [False for _ in self._get_indices(indices)]


class _InProcess:
    """The `Transport` of `NativeBatchVecEnv`: each message handed to the
    in-process sessions, whose answer the next `recv` returns."""

    def __init__(self, batch: Any) -> None:
        self._batch = batch
        self._answer: str | None = None

    def send(self, text: str) -> None:
        self._answer = self._batch.message(text)

    def recv(self) -> str:
        if self._answer is None:
            raise EnvServerError("no answer: the in-process sessions are closed")
        answer, self._answer = self._answer, None
        return answer

    def close(self) -> None:
        self._batch.message('{"type":"close"}')


def _native() -> ModuleType:
    try:
        import negotiator_native
    except ImportError as e:
        raise ImportError(
            "NativeBatchVecEnv needs the negotiator-native extension: pip install ./python/native "
            "(a Rust toolchain builds it)"
        ) from e
    return negotiator_native


class NativeBatchVecEnv(BatchVecEnv):
    """`BatchVecEnv` over env-server's batch sessions held in this process
    (`negotiator::InProcessBatch` through PyO3) instead of a `/ws/batch`
    connection: the same JSON messages and answers, so the same episodes
    (a test holds them equal), without a socket, a server process or a
    thread wake-up per step. Needs `pip install ./python/native`."""

    def __init__(
        self,
        num_envs: int,
        scenario: str = "yield_standoff",
        tier: int = 1,
        teacher: str | None = None,
    ) -> None:
        self._module = _native()
        self._meta: dict[str, Any] = orjson.loads(self._module.metadata())
        super().__init__(num_envs, scenario=scenario, tier=tier, teacher=teacher)

    def _make_endpoint(self, base_url: str | None, token: str | None) -> Endpoint:
        return Endpoint(None, None, meta=self._meta)

    def _connect(self) -> Transport:
        return _InProcess(self._module.Batch())
