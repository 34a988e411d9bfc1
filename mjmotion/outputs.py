"""Writing results safely: atomically, never over an input, never over a file without ``force``."""

from __future__ import annotations

import contextlib
import os
import tempfile
from collections.abc import Callable, Iterable, Iterator
from pathlib import Path

from .errors import MjmotionError, OutputExistsError


def check_output(
    path: str | os.PathLike[str],
    force: bool = False,
    inputs: Iterable[str | os.PathLike[str]] = (),
) -> Path:
    """Validate an output path before any work is done; returns it as a ``Path``.

    Refuses an output that names one of ``inputs`` (even through a link), an existing file
    without ``force``, a directory, or a folder that does not exist.
    """
    out = Path(path)
    for src in inputs:
        try:
            if out.exists() and os.path.samefile(out, src):
                raise OutputExistsError(f"{out}: is an input of this command; choose another output path")
        except FileNotFoundError:
            pass
        if out.resolve() == Path(src).resolve():
            raise OutputExistsError(f"{out}: is an input of this command; choose another output path")
    if out.is_dir():
        raise OutputExistsError(f"{out}: is a directory; expected a file path")
    if out.exists() and not force:
        raise OutputExistsError(f"{out}: already exists; pass --force to replace it")
    parent = out.parent if str(out.parent) else Path(".")
    if not parent.is_dir():
        raise MjmotionError(f"{out}: folder {parent} does not exist")
    return out


@contextlib.contextmanager
def atomic_path(path: str | os.PathLike[str]) -> Iterator[Path]:
    """Yield a temporary path beside ``path``; rename it onto ``path`` only if the block succeeds."""
    out = Path(path)
    parent = out.parent if str(out.parent) else Path(".")
    fd, tmp = tempfile.mkstemp(prefix=f".{out.name}.", suffix=out.suffix or ".tmp", dir=parent)
    os.close(fd)
    # mkstemp makes the file private (0600); results get the usual umask-based mode.
    umask = os.umask(0)
    os.umask(umask)
    os.chmod(tmp, 0o666 & ~umask)
    try:
        yield Path(tmp)
        os.replace(tmp, out)
    except BaseException:
        with contextlib.suppress(FileNotFoundError):
            os.unlink(tmp)
        raise


def write_text_atomic(path: str | os.PathLike[str], text: str) -> None:
    with atomic_path(path) as tmp:
        tmp.write_text(text, encoding="utf-8")


def write_bytes_atomic(path: str | os.PathLike[str], data: bytes) -> None:
    with atomic_path(path) as tmp:
        tmp.write_bytes(data)


def write_with(path: str | os.PathLike[str], writer: Callable[[Path], None]) -> None:
    """Call ``writer(tmp_path)`` and move the result onto ``path`` atomically."""
    with atomic_path(path) as tmp:
        writer(tmp)
