"""Errors a user can act on. The CLI prints them as one ``error:`` line and exits with status 2."""

from __future__ import annotations


class MjmotionError(Exception):
    """Base of every error caused by input (a file, an argument, an impossible request)."""


class BvhError(MjmotionError):
    """A BVH file that cannot be read: names the file, the line and what was expected."""

    def __init__(self, path: str, line: int | None, message: str):
        self.path = path
        self.line = line
        self.message = message
        where = f"{path}:{line}" if line is not None else path
        super().__init__(f"{where}: {message}")


class SkeletonMismatchError(MjmotionError):
    """Clips whose skeleton topologies differ where one topology is required."""


class OutputExistsError(MjmotionError):
    """An output path exists (and ``--force`` was not given) or names an input."""
