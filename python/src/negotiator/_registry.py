"""Inspect's entry point: importing this registers the `negotiator` task."""

from .task import negotiator  # noqa: F401
