"""negotiator's benchmark as an Inspect AI task (`inspect eval negotiator/negotiator`)."""

from .task import drive, episode_grades, negotiator

__all__ = ["drive", "episode_grades", "negotiator"]
