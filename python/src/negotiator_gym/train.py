"""Train stable-baselines3's PPO on one benchmark cell, on CPU.

    python -m negotiator_gym.train --scenario pedestrian_feint --tier 1 \\
        --steps 200000 --seed 0 --out results/rl/pedestrian_feint-t1

Writes, in OUT: `model.zip` and `vecnormalize.pkl` (the checkpoint, which
`hack_check --checkpoint OUT` reads), `curve.csv` and `curve.png` (success,
decision correctness and reward on held-out seeds against training steps)
`command.txt` (the exact command) and `timing.json` (training's steps per
second and the share of its wall time spent stepping the environments). Training episodes are seeds drawn
from [2**32, 2**53); the curve plays seeds CURVE_SEED.. (never trained on).

`--warm-start expert` first imitates a built-in policy (env-server's
`teacher`) with DAgger: `--warm-steps` decisions over `WARM_ROUNDS` rounds,
the first driven by the teacher and the rest by the learner, every
observation labelled with the teacher's discrete action; the network's
policy learns the labels and its value the returns of the episodes played.
PPO then starts from that network (the curve's first point is the
imitation's level). The warm start's decisions are not counted in
`--steps`; `timing.json` reports them.
"""

from __future__ import annotations

import argparse
import csv
import json
import shlex
import sys
import time
from pathlib import Path
from typing import Any

import numpy as np

from negotiator_gym.env import TIERS, local_server, refused_cell
from negotiator_gym.evaluate import MODEL_FILE, NORMALIZE_FILE, play, rates

CURVE_SEED = 10_000
# DAgger's rounds, and the passes over the aggregated data after each.
WARM_ROUNDS = 4
WARM_EPOCHS = 10
CURVE_FIELDS = ["steps", "success", "decision_correctness", "reward", "collision", "timeout", "wall_s"]


def parse_args(argv: list[str]) -> argparse.Namespace:
    p = argparse.ArgumentParser(prog="python -m negotiator_gym.train", description=__doc__.split("\n")[0])
    p.add_argument("--scenario", required=True, help="one of the scenarios the env-server serves (its /metadata lists them)")
    p.add_argument("--tier", required=True, type=int, choices=TIERS)
    p.add_argument("--steps", required=True, type=int, help="environment steps (decisions) to train for")
    p.add_argument("--seed", type=int, default=0, help="seeds PPO, the network and the drawn episodes")
    p.add_argument("--out", required=True, type=Path)
    p.add_argument("--base-url", help="an env-server to train on (default: start a local one)")
    p.add_argument("--envs", type=int, default=8, help="environments stepped together (sessions of one env-server batch connection, at most 64)")
    p.add_argument(
        "--native",
        action="store_true",
        help="step the training environments in this process (NativeBatchVecEnv; pip install ./python/native)",
    )
    p.add_argument("--curve-points", type=int, default=20, help="evaluations along the run")
    p.add_argument("--curve-episodes", type=int, default=100, help="held-out episodes per evaluation")
    p.add_argument("--ent-coef", type=float, default=0.01, help="PPO's entropy bonus (exploration)")
    p.add_argument("--gamma", type=float, default=0.99, help="PPO's discount")
    p.add_argument("--n-steps", type=int, default=256, help="steps per environment per PPO update")
    p.add_argument("--learning-rate", type=float, default=3e-4, help="PPO's learning rate")
    p.add_argument(
        "--warm-start",
        metavar="POLICY",
        help="imitate this built-in policy, e.g. expert (DAgger on env-server's teacher; /metadata lists them) before PPO starts",
    )
    p.add_argument("--warm-steps", type=int, default=40_000, help="decisions the warm start plays and labels")
    args = p.parse_args(argv)
    if min(args.steps, args.envs, args.curve_points, args.curve_episodes, args.n_steps, args.warm_steps) <= 0:
        p.error("--steps, --envs, --curve-points, --curve-episodes, --n-steps and --warm-steps must be positive")
    if args.ent_coef < 0 or not 0 < args.gamma <= 1 or args.learning_rate <= 0:
        p.error("--ent-coef must be at least 0, --gamma in (0, 1], --learning-rate positive")
    return args


def train(args: argparse.Namespace, base_url: str) -> None:
    # Imported here so that `--help` and a bad flag answer at once.
    import torch
    from stable_baselines3 import PPO
    from stable_baselines3.common.callbacks import BaseCallback
    from stable_baselines3.common.vec_env import VecEnv, VecEnvWrapper, VecNormalize
    from stable_baselines3.common.vec_env.base_vec_env import VecEnvStepReturn

    from negotiator_gym.vec import BatchVecEnv, NativeBatchVecEnv

    # A network this small gains nothing from threads; one keeps the run on
    # its own core (and several runs side by side).
    torch.set_num_threads(1)

    class Timed(VecEnvWrapper):
        """Counts the wall time spent stepping and resetting the
        environments (env-server and the client, auto-resets included)."""

        def __init__(self, venv: VecEnv) -> None:
            super().__init__(venv)
            self.seconds = 0.0
            self.steps = 0

        def reset(self) -> Any:
            t = time.perf_counter()
            out = self.venv.reset()
            self.seconds += time.perf_counter() - t
            return out

        def step_wait(self) -> VecEnvStepReturn:
            t = time.perf_counter()
            out = self.venv.step_wait()
            self.seconds += time.perf_counter() - t
            self.steps += self.num_envs
            return out

    out: Path = args.out
    out.mkdir(parents=True, exist_ok=True)

    if args.native:
        batch: BatchVecEnv = NativeBatchVecEnv(args.envs, scenario=args.scenario, tier=args.tier, teacher=args.warm_start)
    else:
        batch = BatchVecEnv(args.envs, scenario=args.scenario, tier=args.tier, base_url=base_url, teacher=args.warm_start)
    timed = Timed(batch)
    venv = VecNormalize(timed, norm_obs=True, norm_reward=False)
    venv.seed(2**40 + args.seed * 1000)
    model = PPO(
        "MlpPolicy",
        venv,
        n_steps=args.n_steps,
        batch_size=256,
        n_epochs=10,
        gamma=args.gamma,
        learning_rate=args.learning_rate,
        ent_coef=args.ent_coef,
        seed=args.seed,
        device="cpu",
        verbose=0,
    )
    curve_seeds = range(CURVE_SEED, CURVE_SEED + args.curve_episodes)
    every = max(1, args.steps // args.curve_points)
    started = time.perf_counter()
    rows: list[dict[str, float]] = []
    curve_seconds = 0.0

    def evaluate(steps: int) -> None:
        nonlocal curve_seconds
        t = time.perf_counter()
        def act(observation: np.ndarray) -> int:
            action, _ = model.predict(venv.normalize_obs(observation), deterministic=True)
            return int(action)

        r = rates(play(act, args.scenario, args.tier, curve_seeds, base_url))
        row = {
            "steps": steps,
            "success": r.success,
            "decision_correctness": r.decision_correctness,
            "reward": r.reward,
            "collision": r.collision,
            "timeout": r.timeout,
            "wall_s": round(time.perf_counter() - started, 1),
        }
        rows.append(row)
        curve_seconds += time.perf_counter() - t
        print(", ".join(f"{k} {v:.3f}" if isinstance(v, float) else f"{k} {v}" for k, v in row.items()), flush=True)

    class Curve(BaseCallback):
        def _on_step(self) -> bool:
            if self.num_timesteps // every > (self.num_timesteps - args.envs) // every:
                evaluate(self.num_timesteps)
            return True

    warm: dict[str, float] = {}
    if args.warm_start:
        warm = warm_start(model, venv, batch, args)
        # The share below is PPO's own.
        timed.seconds, timed.steps = 0.0, 0
    evaluate(0)
    curve_before = curve_seconds
    learn_started = time.perf_counter()
    model.learn(total_timesteps=args.steps, callback=Curve())
    # The curve's evaluations run inside `learn` (in the callback) on their
    # own environments; the share is of training alone.
    train_seconds = time.perf_counter() - learn_started - (curve_seconds - curve_before)
    if not rows or rows[-1]["steps"] != model.num_timesteps:
        evaluate(model.num_timesteps)
    timing = {
        "train_seconds": round(train_seconds, 2),
        "env_seconds": round(timed.seconds, 2),
        "env_share": round(timed.seconds / train_seconds, 4),
        "env_steps": timed.steps,
        "steps_per_second": round(timed.steps / train_seconds, 1),
    } | warm
    (out / "timing.json").write_text(json.dumps(timing, indent=2) + "\n")
    print(f"training: {timing['steps_per_second']} steps/s, {100 * timing['env_share']:.1f}% of it in the environment")
    model.save(out / MODEL_FILE)
    venv.save(str(out / NORMALIZE_FILE))
    venv.close()
    with open(out / "curve.csv", "w", newline="") as f:
        writer = csv.DictWriter(f, fieldnames=CURVE_FIELDS)
        writer.writeheader()
        writer.writerows(rows)
    plot(rows, out / "curve.png", f"PPO on {args.scenario} tier {args.tier}")


def warm_start(model: Any, venv: Any, batch: Any, args: argparse.Namespace) -> dict[str, float]:
    """DAgger from env-server's teacher into `model`'s network (see the
    module doc). `venv` is the VecNormalize over `batch`; its observation
    statistics are updated as the warm start plays, as PPO's will be."""
    import torch

    started = time.perf_counter()
    n = batch.num_envs
    per_round = max(1, args.warm_steps // (WARM_ROUNDS * n))
    observations: list[np.ndarray] = []
    labels: list[np.ndarray] = []
    returns: list[np.ndarray] = []
    known: list[np.ndarray] = []
    optimizer = torch.optim.Adam(model.policy.parameters(), lr=1e-3)
    played = 0
    for round_ in range(WARM_ROUNDS):
        obs = venv.reset()
        # Each environment's open episode: the rows it has written.
        open_rows: list[list[int]] = [[] for _ in range(n)]
        raw_rows: list[np.ndarray] = []
        label_rows: list[int] = []
        value_rows: list[float] = []
        known_rows: list[bool] = []
        for _ in range(per_round):
            teacher = batch.teacher_actions.copy()
            if round_ == 0:
                actions = teacher
            else:
                actions, _ = model.predict(obs, deterministic=True)
            raw = venv.get_original_obs()
            for i in range(n):
                open_rows[i].append(len(raw_rows))
                raw_rows.append(raw[i].copy())
                label_rows.append(int(teacher[i]))
                value_rows.append(0.0)
                known_rows.append(False)
            obs, rewards, dones, _ = venv.step(actions)
            played += n
            for i in np.flatnonzero(dones).tolist():
                # The reward comes at the end: each decision's return is
                # it discounted by the decisions left.
                rows = open_rows[i]
                for k, row in enumerate(rows):
                    value_rows[row] = float(rewards[i]) * args.gamma ** (len(rows) - 1 - k)
                    known_rows[row] = True
                open_rows[i] = []
        observations.append(np.asarray(raw_rows, dtype=np.float32))
        labels.append(np.asarray(label_rows, dtype=np.int64))
        returns.append(np.asarray(value_rows, dtype=np.float32))
        known.append(np.asarray(known_rows, dtype=bool))
        fit(model, optimizer, venv.normalize_obs(np.concatenate(observations)), np.concatenate(labels),
            np.concatenate(returns), np.concatenate(known))
        agree = float(np.mean(model.predict(venv.normalize_obs(observations[-1]), deterministic=True)[0] == labels[-1]))
        print(f"warm start round {round_ + 1}: {played} decisions, the learner agrees with the teacher on {agree:.3f}", flush=True)
    return {"warm_start_steps": played, "warm_start_seconds": round(time.perf_counter() - started, 2)}


def fit(model: Any, optimizer: Any, obs: np.ndarray, labels: np.ndarray, returns: np.ndarray, known: np.ndarray) -> None:
    """WARM_EPOCHS passes of cross-entropy on the teacher's labels, and the
    value's squared error on the returns known (episodes that ended)."""
    import torch

    policy = model.policy
    policy.set_training_mode(True)
    generator = torch.Generator().manual_seed(len(obs))
    obs_t, labels_t = torch.as_tensor(obs), torch.as_tensor(labels)
    returns_t, known_t = torch.as_tensor(returns), torch.as_tensor(known, dtype=torch.float32)
    for _ in range(WARM_EPOCHS):
        order = torch.randperm(len(obs), generator=generator)
        for batch in torch.split(order, 256):
            values, log_prob, _ = policy.evaluate_actions(obs_t[batch], labels_t[batch])
            weight = known_t[batch]
            value_loss = (weight * (values.flatten() - returns_t[batch]) ** 2).sum() / weight.sum().clamp(min=1.0)
            loss = -log_prob.mean() + 0.5 * value_loss
            optimizer.zero_grad()
            loss.backward()
            optimizer.step()
    policy.set_training_mode(False)


def plot(rows: list[dict[str, float]], path: Path, title: str) -> None:
    import matplotlib

    matplotlib.use("Agg")
    import matplotlib.pyplot as plt

    steps = [r["steps"] for r in rows]
    fig, ax = plt.subplots(figsize=(6, 3.5), dpi=100)
    for key, label in [("success", "success"), ("decision_correctness", "decision correctness"), ("reward", "reward")]:
        ax.plot(steps, [r[key] for r in rows], label=label)
    ax.set_xlabel("training steps (decisions)")
    ax.set_ylim(-1.05, 1.05)
    ax.set_title(title)
    ax.grid(alpha=0.3)
    ax.legend(loc="lower right")
    fig.tight_layout()
    fig.savefig(path)
    plt.close(fig)


def main(argv: list[str] | None = None) -> int:
    argv = sys.argv[1:] if argv is None else argv
    args = parse_args(argv)
    args.out.mkdir(parents=True, exist_ok=True)
    (args.out / "command.txt").write_text(
        "python -m negotiator_gym.train " + " ".join(shlex.quote(a) for a in argv) + "\n"
    )
    local = None if args.base_url else local_server("python -m negotiator_gym.train")
    try:
        base_url = args.base_url or (local.url if local else "")
        if refused_cell("python -m negotiator_gym.train", args.scenario, args.tier, base_url):
            return 2
        train(args, base_url)
    finally:
        if local is not None:
            local.close()
    return 0


if __name__ == "__main__":
    sys.exit(main())
