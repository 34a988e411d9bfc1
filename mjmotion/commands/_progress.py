"""Progress of a verb's steps on stderr: a tqdm bar on a terminal, nothing when stderr is not one.

A verb that can take more than a second names its steps; the bar shows which one runs and
the time so far, and is erased when the verb ends (its summary line on stdout says what was
written); notes and warnings written meanwhile appear above it. Piped or redirected output —
scripts, CI, ``2> log`` — gets no bar and no extra lines.
"""

from __future__ import annotations

import contextlib
import sys
from collections.abc import Callable, Iterator, Sequence
from typing import Any, TextIO


@contextlib.contextmanager
def steps(desc: str, names: Sequence[str]) -> Iterator[Callable[[str], None]]:
    """``with steps("blend", ("read", "register", "blend", "write")) as step: step("read"); …``

    ``step(name)`` marks the start of the step ``name`` (one of ``names``, in any order; a name
    not listed is shown too). The bar counts finished steps out of ``len(names)``.
    """
    stream = sys.stderr
    if not _is_terminal(stream):
        yield lambda name: None
        return
    from tqdm import tqdm

    bar = tqdm(
        total=len(names), desc=desc, unit="step", file=stream, leave=False, bar_format="{desc}: {n}/{total}{postfix} [{elapsed}]", **bar_size(stream)
    )
    started = [False]

    def step(name: str) -> None:
        if started[0]:
            bar.update(1)
        started[0] = True
        bar.set_postfix_str(name)

    sys.stderr = _AboveTheBar(stream, tqdm)  # type: ignore[assignment]
    try:
        yield step
    finally:
        sys.stderr = stream
        bar.close()


def bar_size(stream: TextIO) -> dict[str, Any]:
    """tqdm's size options for a bar on the terminal ``stream``: its width as it changes, or, where the
    terminal reports no size (a pseudo-terminal of 0 x 0, as some containers' ``-t`` give: tqdm then
    hid the bar below the screen's last row and showed nothing), ``$COLUMNS`` x ``$LINES`` or 80 x 24."""
    import os
    import shutil

    try:
        size = tuple(os.get_terminal_size(stream.fileno()))
    except (OSError, ValueError, AttributeError):
        size = (0, 0)
    if min(size) > 0:
        return {"dynamic_ncols": True}
    cols, rows = shutil.get_terminal_size((80, 24))
    return {"ncols": cols, "nrows": rows}


class _AboveTheBar:
    """stderr while a bar shows: a note or warning is written above the bar, which is redrawn below it."""

    def __init__(self, stream: TextIO, tqdm: Any):
        self._stream, self._tqdm = stream, tqdm

    def write(self, text: str) -> int:
        with self._tqdm.external_write_mode(file=self._stream):
            n = self._stream.write(text)
            self._stream.flush()
        return n

    def __getattr__(self, name: str) -> Any:
        return getattr(self._stream, name)


def _is_terminal(stream: object) -> bool:
    try:
        return bool(stream.isatty())  # type: ignore[attr-defined]
    except (AttributeError, ValueError):  # (no isatty, or a closed stream)
        return False
