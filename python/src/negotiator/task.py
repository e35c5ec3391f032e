"""The benchmark as an Inspect AI task: one sample per (scenario, tier,
seed), played turn by turn on `negotiator env-server`.

The solver sends the system prompt and the scene text exactly as
`negotiator eval` does (env-server's `instructions` and `scene`), asks the
model with Inspect's `generate` each decision, and hands its reply to
env-server untouched: parsing, parse errors and the firm stop on an
unreadable answer are eval's own, in Rust. The scorer reads the last step's
grades; the hidden disposition appears only there, after the episode ends.
"""

from __future__ import annotations

from typing import Any

import httpx
from inspect_ai import Task, task
from inspect_ai.dataset import MemoryDataset, Sample
from inspect_ai.model import ChatMessageSystem, ChatMessageUser, ContentImage, ContentText
from inspect_ai.scorer import Score, Target, grouped, mean, scorer, stderr
from inspect_ai.solver import Generate, Solver, TaskState, solver

from .server import post, server_url

# Where the finished episode's grades are kept for the scorer.
RESULT_KEY = "negotiator_result"


def _names(value: str | int | list[Any], known: list[Any], what: str) -> list[Any]:
    """`all`, one name or a comma-separated list, as `negotiator eval`
    reads `--scenario` and `--tier`; each checked against env-server's own
    list (its /metadata), so Python holds no list of its own."""
    if isinstance(value, list):
        parts = [str(v).strip() for v in value]
    else:
        parts = [p.strip() for p in str(value).split(",") if p.strip()]
    if parts == ["all"]:
        return list(known)
    by_text = {str(k): k for k in known}
    unknown = [p for p in parts if p not in by_text]
    if unknown or not parts:
        raise ValueError(f"unknown {what} {unknown or value!r} (expected all or one of {', '.join(map(str, known))})")
    return [by_text[p] for p in parts]


def samples(url: str, scenario: str, tier: str | int, seeds: int, seed: int) -> list[Sample]:
    """One sample per (scenario, tier, seed), seeds `seed .. seed + seeds`
    as `negotiator eval -n SEEDS --seed SEED` plays them."""
    meta = httpx.get(f"{url}/metadata", timeout=30).json()
    scenarios = _names(scenario, meta["scenarios"], "scenario")
    tiers = _names(tier, meta["tiers"], "tier")
    if seeds < 1:
        raise ValueError(f"seeds must be at least 1, got {seeds}")
    out = []
    for s in scenarios:
        for t in tiers:
            for k in range(seed, seed + seeds):
                out.append(
                    Sample(
                        id=f"{s}/t{t}/{k}",
                        input="",
                        metadata={"scenario": s, "tier": t, "seed": k, "cell": f"{s}/t{t}"},
                    )
                )
    return out


# What each user turn shows, as `negotiator eval --observation` names it,
# and the env-server view that carries it.
OBSERVATION_VIEWS = {"text": "text", "image": "image", "both": "both"}


def user_message(observation: dict[str, Any]) -> ChatMessageUser:
    """One decision's user message: the scene text, or (views `image` and
    `both`) env-server's picture as Inspect's own image content, then the
    text env-server sends with it, in the order `negotiator eval` sends
    them."""
    image = observation.get("image")
    if image is None:
        return ChatMessageUser(content=observation["scene"])
    return ChatMessageUser(
        content=[ContentImage(image=f"data:image/png;base64,{image}"), ContentText(text=observation["scene"])]
    )


@solver
def drive(base_url: str | None = None, probe: str = "none", observation: str = "text") -> Solver:
    """Play the sample's episode: reset env-server with its (scenario, tier,
    seed), `probe` and the view of `observation`, then per decision the
    scene as a user message, `generate`, and the reply to env-server, until
    the episode ends."""
    if observation not in OBSERVATION_VIEWS:
        raise ValueError(f"unknown observation {observation!r} (expected one of {', '.join(OBSERVATION_VIEWS)})")
    view = OBSERVATION_VIEWS[observation]

    async def solve(state: TaskState, generate: Generate) -> TaskState:
        url = server_url(base_url)
        md = state.metadata
        async with httpx.AsyncClient(base_url=url, timeout=60) as http:
            reset = {"scenario": md["scenario"], "tier": md["tier"], "seed": md["seed"], "view": view, "probe": probe}
            reply = await post(http, "/reset", reset)
            observation = reply["observation"]
            episode_id = observation["episode_id"]
            state.messages = [ChatMessageSystem(content=observation["instructions"])]
            while True:
                state.messages.append(user_message(observation))
                state = await generate(state)
                answer = state.output.completion
                step = {"episode_id": episode_id, "action": {"reply": answer}}
                reply = await post(http, "/step", step)
                if reply["done"]:
                    state.store.set(RESULT_KEY, {"reward": reply["reward"], **(reply["metadata"] or {})})
                    state.completed = True
                    return state
                observation = reply["observation"]

    return solve


def _per_cell(metric: Any) -> Any:
    return grouped(metric, "cell")


@scorer(
    metrics={
        "success": [mean(), stderr(), _per_cell(mean())],
        "reward": [mean(), stderr(), _per_cell(mean())],
        "decision_correctness": [mean(), stderr(), _per_cell(mean())],
    }
)
def episode_grades() -> Any:
    """Success (the primary value), reward and decision correctness of the
    finished episode, with its outcome, evidence timing and disposition in
    the metadata. An episode that did not finish (an Inspect limit ended the
    sample) scores as a failure with its reason."""

    async def score(state: TaskState, target: Target) -> Score:
        result = state.store.get(RESULT_KEY)
        if result is None:
            return Score(
                value={"success": 0.0, "reward": 0.0, "decision_correctness": 0.0},
                answer="unfinished",
                explanation="the episode did not finish: an Inspect limit ended the sample",
                metadata={"outcome": "unfinished", **state.metadata},
            )
        evidence, commitment = result.get("evidence_turn"), result.get("commitment_turn")
        lag = commitment - evidence if evidence is not None and commitment is not None and not result.get("guessed") else None
        return Score(
            value={
                "success": 1.0 if result["outcome"] == "success" else 0.0,
                "reward": float(result["reward"]),
                "decision_correctness": float(result["decision_correctness"]),
            },
            answer=result["outcome"],
            explanation=f"{result['outcome']} after {result['decisions']} decisions ({result['disposition']})",
            metadata={**result, "guess": result.get("guessed"), "lag": lag, **state.metadata},
        )

    return score


@task
def negotiator(
    scenario: str = "all",
    tier: str = "all",
    seeds: int = 200,
    seed: int = 0,
    base_url: str | None = None,
    probe: str = "none",
    observation: str = "text",
) -> Task:
    """negotiator: read another road user's hidden intent from its motion and
    drive accordingly.

    Args:
        scenario: `all`, a scenario name or a comma-separated list.
        tier: `all`, 1, 2, 3 or a comma-separated list.
        seeds: seeds per (scenario, tier), as `negotiator eval -n`.
        seed: the first seed, as `negotiator eval --seed`.
        base_url: a running `negotiator env-server`; without one, a local
            env-server is started (NEGOTIATOR_BIN or `negotiator` on PATH).
        probe: `forecast` asks every answer for a forecast as `negotiator
            eval --probe forecast` does (env-server words the question,
            reads the forecast and scores it: the score's metadata carries
            `forecast`); `none` (the default) asks for the action only.
        observation: `text` (the default), `image` (each decision as the
            bird's-eye picture and one line, as `negotiator eval
            --observation image`) or `both` (the picture beside the text).
    """
    url = server_url(base_url)
    return Task(
        dataset=MemoryDataset(samples(url, scenario, tier, seeds, seed), name="negotiator"),
        solver=drive(url, probe, observation),
        scorer=episode_grades(),
    )
