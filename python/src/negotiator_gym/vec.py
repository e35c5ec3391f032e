"""`PipelinedVecEnv`: stable-baselines3's `DummyVecEnv` over several
`NegotiatorEnv`s (one env-server session each) that sends every
environment's action before it reads any answer. env-server steps the
sessions on its own threads while the client waits once per vector step
instead of once per environment, and the resets of the environments
whose episodes ended are sent together too; the episodes are the same
ones, answer for answer (each session is independent)."""

from __future__ import annotations

from collections.abc import Callable

import gymnasium as gym
import numpy as np
from stable_baselines3.common.vec_env import DummyVecEnv
from stable_baselines3.common.vec_env.base_vec_env import VecEnvStepReturn

from negotiator_gym.env import NegotiatorEnv


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
