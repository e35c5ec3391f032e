"""negotiator's benchmark in Python harnesses, each driving the Rust
env-server: the Inspect AI task (`negotiator.task`, registered with Inspect
as `negotiator/negotiator`) and the local env-server both front ends start
(`negotiator.server`). The Gymnasium environment is `negotiator_gym`.

The task is imported only when asked for, so that the Gymnasium side works
without Inspect installed."""

from __future__ import annotations

import importlib
from typing import Any

__all__ = ["drive", "episode_grades", "negotiator"]


def __getattr__(name: str) -> Any:
    if name in __all__:
        # Imported by name, so that a type check of the Gymnasium side
        # does not need Inspect either.
        return getattr(importlib.import_module("negotiator.task"), name)
    raise AttributeError(f"module 'negotiator' has no attribute {name!r}")
