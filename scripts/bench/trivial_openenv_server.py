"""A trivial environment on OpenEnv's own Python server (`create_app` from
openenv.core): reset, three steps, done. A lower bound for any Python
environment server, for `scripts/bench/env_server.sh` to compare against.

usage: python trivial_openenv_server.py PORT MAX_SESSIONS
"""

import sys
from typing import Any, Optional

import uvicorn
from openenv.core.env_server.http_server import create_fastapi_app
from openenv.core.env_server.interfaces import Environment
from openenv.core.env_server.types import Action, Observation, State


class CountAction(Action):
    value: int = 1


class CountObservation(Observation):
    count: int = 0


class ThreeSteps(Environment):
    SUPPORTS_CONCURRENT_SESSIONS = True

    def __init__(self):
        super().__init__()
        self._state = State(step_count=0)

    def reset(self, seed: Optional[int] = None, episode_id: Optional[str] = None, **kwargs: Any) -> CountObservation:
        self._state = State(episode_id=episode_id, step_count=0)
        return CountObservation(count=0)

    def step(self, action: CountAction, timeout_s: Optional[float] = None, **kwargs: Any) -> CountObservation:
        self._state.step_count += 1
        done = self._state.step_count >= 3
        return CountObservation(count=self._state.step_count, done=done, reward=1.0 if done else 0.0)

    @property
    def state(self) -> State:
        return self._state


if __name__ == "__main__":
    port, sessions = int(sys.argv[1]), int(sys.argv[2])
    app = create_fastapi_app(ThreeSteps, CountAction, CountObservation, max_concurrent_envs=sessions)
    uvicorn.run(app, host="127.0.0.1", port=port, log_level="warning", ws_max_size=1 << 20)
