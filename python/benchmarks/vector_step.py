"""The client's cost per environment step of the vectorised environments,
side by side on one local env-server: `BatchVecEnv` (one `/ws/batch`
connection), `PipelinedVecEnv` (one `/ws` connection per environment) and
`NativeBatchVecEnv` (the batch sessions in this process; `pip install
./python/native`; its "client CPU" includes the sessions' own), stepping
random actions, in alternating rounds.

    NEGOTIATOR_BIN=target/release/negotiator python python/benchmarks/vector_step.py [ENVS] [STEPS] [ROUNDS]

Prints, per round and vector, the wall time and the client's own CPU time
(the process's) per environment step, in microseconds."""

from __future__ import annotations

import sys
import time
from typing import Any

import numpy as np

from negotiator.server import LocalServer, binary
from negotiator_gym.env import NegotiatorEnv
from negotiator_gym.vec import BatchVecEnv, NativeBatchVecEnv, PipelinedVecEnv


def measure(vec: Any, actions: np.ndarray) -> tuple[float, float]:
    vec.seed(1)
    vec.reset()
    wall, cpu = time.perf_counter(), time.process_time()
    for step in actions:
        vec.step(step)
    per_step = actions.size / 1e6
    return (time.perf_counter() - wall) / per_step, (time.process_time() - cpu) / per_step


def main() -> None:
    envs, steps, rounds = (int(a) for a in (sys.argv[1:] + ["8", "3000", "2"][len(sys.argv) - 1 :])[:3])
    actions = np.random.default_rng(0).integers(0, 10, size=(steps, envs))
    server = LocalServer(binary())
    try:
        for round in range(1, rounds + 1):
            for name, make in (
                ("PipelinedVecEnv", lambda: PipelinedVecEnv([lambda: NegotiatorEnv(base_url=server.url)] * envs)),
                ("BatchVecEnv", lambda: BatchVecEnv(envs, base_url=server.url)),
                ("NativeBatchVecEnv", lambda: NativeBatchVecEnv(envs)),
            ):
                vec = make()
                try:
                    wall, cpu = measure(vec, actions)
                finally:
                    vec.close()
                print(f"round {round} {name:17} {envs} envs: {wall:5.1f} us wall, {cpu:5.1f} us client CPU per env-step")
    finally:
        server.close()


if __name__ == "__main__":
    main()
