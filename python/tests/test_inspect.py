"""The Inspect task against what we did not write and against `negotiator
eval`, offline: Inspect's `openai-api` provider pointed at `negotiator serve
--policy expert` must play the episodes `negotiator eval` plays against the
same server, seed for seed; Inspect's `mockllm`, whose default answer is no
JSON action, must drive every turn as eval's firm stop.

Needs NEGOTIATOR_BIN (the built binary) and NEGOTIATOR_EXAMPLES (the
directory with the built `reference_rollouts` example).
"""

from __future__ import annotations

import json
import os
import subprocess
from collections.abc import Iterator
from pathlib import Path
from typing import Any

import pytest
from inspect_ai import Task
from inspect_ai import eval as inspect_eval
from inspect_ai.log import EvalLog, write_eval_log
from inspect_ai.model import ContentImage, ModelOutput, ModelUsage, get_model

from negotiator.task import negotiator

SEEDS = 3
BIN = os.environ.get("NEGOTIATOR_BIN", "negotiator")
MOCK_DEFAULT = "Default output from mockllm/model"


def start(*args: str) -> tuple[subprocess.Popen[str], str]:
    process = subprocess.Popen(
        [BIN, *args, "--port", "0"], stdout=subprocess.PIPE, stderr=subprocess.DEVNULL, text=True
    )
    assert process.stdout is not None
    line = process.stdout.readline().strip()
    assert line.startswith("listening on "), line
    return process, line[len("listening on ") :]


@pytest.fixture(scope="module")
def env_server() -> Iterator[str]:
    process, url = start("env-server")
    yield url
    process.terminate()
    process.wait()


@pytest.fixture(scope="module")
def expert_endpoint() -> Iterator[str]:
    process, url = start("serve", "--policy", "expert")
    yield url
    process.terminate()
    process.wait()


def served(task: Task, service: str, endpoint: str, tmp_path: Path) -> EvalLog:
    """Inspect's own `openai-api` provider plays `task` against a served
    policy: the service's base URL and key as its docs say to give them."""
    os.environ[f"{service.upper()}_BASE_URL"] = endpoint
    os.environ[f"{service.upper()}_API_KEY"] = "offline"
    [log] = inspect_eval(
        task, model=f"openai-api/{service}/expert", log_dir=str(tmp_path / "logs"), display="none"
    )
    return log


def episodes(log: EvalLog) -> dict[tuple[str, int, int], dict[str, object]]:
    assert log.status == "success", log.error
    assert log.samples is not None
    out = {}
    for sample in log.samples:
        assert sample.scores is not None
        score = next(iter(sample.scores.values()))
        md = score.metadata or {}
        out[(md["scenario"], int(md["tier"]), int(md["seed"]))] = md
    return out


def import_log(location: str, out: Path) -> subprocess.CompletedProcess[str]:
    """`negotiator import-inspect` of one log into `out`."""
    return subprocess.run(
        [BIN, "import-inspect", location, "--output", str(out)], capture_output=True, text=True, check=False
    )


def imported_beside_eval(
    location: str, out: Path, rollouts: list[dict[str, Any]], same: list[str]
) -> list[tuple[dict[str, Any], dict[str, Any]]]:
    """Import the log into `out` and pair each line with eval's line for
    the same episode, having checked the fields `same` agree."""
    run = import_log(location, out)
    assert run.returncode == 0, run.stderr
    lines = [json.loads(line) for line in (out / "rollouts.jsonl").read_text().splitlines()]
    theirs = {(r["scenario"], r["tier"], r["seed"]): r for r in rollouts}
    assert len(lines) == len(theirs)
    pairs = []
    for line in lines:
        other = theirs[(line["scenario"], line["tier"], line["seed"])]
        assert [line[f] for f in same] == [other[f] for f in same], line["scenario"]
        pairs.append((line, other))
    return pairs


def test_inspect_plays_the_episodes_eval_plays(env_server: str, expert_endpoint: str, tmp_path: Path) -> None:
    log = served(
        negotiator(seeds=SEEDS, base_url=env_server),
        "negotiator",
        expert_endpoint,
        tmp_path,
    )
    ours = episodes(log)
    run = subprocess.run(
        [BIN, "eval", "--base-url", expert_endpoint, "--model", "expert", "--scenario", "all", "--tier", "all",
         "-n", str(SEEDS), "--output", str(tmp_path / "eval"), "--run-name", "expert"],
        capture_output=True, text=True, check=False,
    )
    assert run.returncode == 0, run.stderr
    rollouts = [json.loads(line) for line in (tmp_path / "eval" / "expert" / "rollouts.jsonl").read_text().splitlines()]
    assert len(rollouts) == len(ours) == 9 * SEEDS
    for r in rollouts:
        mine = ours[(r["scenario"], r["tier"], r["seed"])]
        assert (mine["outcome"], mine["reward"], mine["decisions"], mine["disposition"]) == (
            r["outcome"], r["reward"], r["turns_taken"], r["disposition"],
        ), r["scenario"]
        assert mine["decision_correctness"] == r["decision_correctness"]
    # The log on the leaderboard: imported, it is eval's run line for line
    # (but for what only the harness knows: the model's name, usage, timing).
    assert log.location
    imported = tmp_path / "imported"
    same = ["outcome", "reward", "decision_correctness", "disposition", "turns_taken", "evidence_turn",
            "commitment_turn", "diagnostics", "trajectory"]
    for line, other in imported_beside_eval(log.location, imported, rollouts, same):
        assert [t["reply"] for t in line["turns"]] == [t["reply"] for t in other["turns"]]
    assert json.loads((imported / "run.json").read_text())["config"]["model"] == "openai-api/negotiator/expert"


def test_mockllms_default_answer_drives_as_evals_firm_stop(env_server: str, tmp_path: Path) -> None:
    # mockllm's default answer, with usage given so that it does not count
    # tokens with tiktoken (which fetches its encoding from the internet).
    answer = ModelOutput.from_content(model="mockllm", content=MOCK_DEFAULT)
    answer.usage = ModelUsage(input_tokens=1, output_tokens=1, total_tokens=2)
    model = get_model("mockllm/model", custom_outputs=[answer] * 1000)
    [log] = inspect_eval(
        negotiator(seeds=SEEDS, base_url=env_server), model=model, log_dir=str(tmp_path / "logs"), display="none"
    )
    ours = episodes(log)
    # The Rust loop's conservative action for an unreadable answer: stop,
    # acceleration -0.5 (|0.5| of the stop band).
    examples = os.environ.get("NEGOTIATOR_EXAMPLES", str(Path(BIN).parent / "examples"))
    reference = subprocess.run(
        [str(Path(examples) / "reference_rollouts"), "stop:0.5", str(SEEDS)],
        capture_output=True, text=True, check=True,
    ).stdout.splitlines()
    assert len(reference) == len(ours) == 9 * SEEDS
    for line in reference:
        ref = json.loads(line)
        mine = ours[(ref["scenario"], ref["tier"], ref["seed"])]
        assert (mine["outcome"], mine["reward"], mine["decisions"]) == (ref["outcome"], ref["reward"], ref["decisions"])
        assert mine["parse_errors"] == mine["decisions"], "every answer is a parse error"


def test_the_disposition_shows_only_after_the_episode(env_server: str, expert_endpoint: str, tmp_path: Path) -> None:
    log = served(
        negotiator(scenario="yield_standoff", tier="1", seeds=SEEDS, base_url=env_server),
        "negotiator",
        expert_endpoint,
        tmp_path,
    )
    assert log.samples
    for sample in log.samples:
        assert sample.scores is not None
        metadata = next(iter(sample.scores.values())).metadata or {}
        disposition = metadata["disposition"]
        for message in sample.messages:
            assert disposition not in message.text, f"{disposition} in a message"
        assert disposition not in json.dumps(sample.metadata)


@pytest.fixture(scope="module")
def forecasting_endpoint() -> Iterator[str]:
    process, url = start("serve", "--policy", "expert", "--probe", "forecast")
    yield url
    process.terminate()
    process.wait()


def test_the_forecast_probe_is_asked_read_and_scored_by_env_server(
    env_server: str, forecasting_endpoint: str, tmp_path: Path
) -> None:
    # A service of its own: Inspect keeps one client per model name.
    log = served(
        negotiator(scenario="yield_standoff,contested_merge", tier="1", seeds=SEEDS, base_url=env_server,
                   probe="forecast"),
        "forecasting",
        forecasting_endpoint,
        tmp_path,
    )
    ours = episodes(log)
    assert len(ours) == 2 * SEEDS
    for md in ours.values():
        forecast = md["forecast"]
        assert isinstance(forecast, dict)
        assert forecast["episode"]["probe_errors"] == 0, forecast
        assert forecast["episode"]["stated_turns"] == md["decisions"], forecast
    assert log.samples is not None
    system = log.samples[0].messages[0].text
    assert "if_it_lets_you_go_first" in system, system


def test_inspect_shows_the_picture_and_plays_the_episodes_eval_plays(
    env_server: str, expert_endpoint: str, tmp_path: Path
) -> None:
    # observation=image: env-server's picture goes to the model as Inspect's
    # own image content (the served expert finds the episode from it), and
    # the episodes are those `negotiator eval --observation image` plays.
    log = served(
        negotiator(seeds=2, tier="1", base_url=env_server, observation="image"),
        "negotiator",
        expert_endpoint,
        tmp_path,
    )
    ours = episodes(log)
    assert log.samples is not None
    first = log.samples[0].messages[1]
    assert isinstance(first.content, list)
    assert [type(c).__name__ for c in first.content] == ["ContentImage", "ContentText"]
    assert first.content[1].text.startswith("Turn 1 of ")  # type: ignore[union-attr]
    run = subprocess.run(
        [BIN, "eval", "--base-url", expert_endpoint, "--model", "expert", "--scenario", "all", "--tier", "1",
         "-n", "2", "--observation", "image", "--output", str(tmp_path / "eval"), "--run-name", "image"],
        capture_output=True, text=True, check=False,
    )
    assert run.returncode == 0, run.stderr
    rollouts = [json.loads(line) for line in (tmp_path / "eval" / "image" / "rollouts.jsonl").read_text().splitlines()]
    assert len(rollouts) == len(ours) > 0
    for r in rollouts:
        mine = ours[(r["scenario"], r["tier"], r["seed"])]
        assert (mine["outcome"], mine["decisions"], mine["disposition"]) == (
            r["outcome"], r["turns_taken"], r["disposition"],
        ), r["scenario"]
        assert mine["outcome"] == "success"
    # Imported, the picture run is eval's picture run line for line: each
    # picture Inspect logged is checked against the one this build draws.
    assert log.location
    imported = tmp_path / "imported"
    same = ["outcome", "reward", "decision_correctness", "turns_taken", "trajectory"]
    for line, other in imported_beside_eval(log.location, imported, rollouts, same):
        assert [(t["scene"], t["pictures"]) for t in line["turns"]] == [
            (t["scene"], t["pictures"]) for t in other["turns"]
        ]
    config = json.loads((imported / "run.json").read_text())["config"]
    assert config["pictures"] == {"observation": "image", "detail": "auto"}
    # A picture that is not the one this build draws (the first turn's
    # shown again at the second) is refused, naming the turn.
    sample = log.samples[0]
    second = sample.messages[3]
    assert isinstance(second.content, list) and isinstance(first.content[0], ContentImage)
    second.content[0] = first.content[0]
    tampered = tmp_path / "tampered.eval"
    write_eval_log(log, str(tampered))
    run = import_log(str(tampered), tmp_path / "refused")
    assert run.returncode != 0
    assert "the picture at turn 2 is not the one this negotiator draws" in run.stderr, run.stderr
    with pytest.raises(ValueError, match="unknown observation"):
        negotiator(seeds=1, base_url=env_server, observation="video")
