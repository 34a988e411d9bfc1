"""Reading inputs safely: regular files only, measured before they are read, never read past a limit.

Every file a user names (BVH clips, stream scripts, score files, joint-weight files) is opened
here. A FIFO with no writer would block forever, ``/dev/zero`` never ends, a sparse 2 GB file
would be read whole before a parser refused it: :func:`open_input` refuses anything but a
regular file (following symbolic links, reporting a loop), stats its size and refuses one over
the caller's limit before reading a byte, and :func:`read_input` reads at most that many bytes
(a file that grows while it is read is refused too).

Errors are :class:`InputError` (an :class:`~mjmotion.errors.MjmotionError`) naming the file;
readers with their own error type (``BvhError``) convert it.
"""

from __future__ import annotations

import contextlib
import errno
import os
import stat
from collections.abc import Iterator
from pathlib import Path
from typing import Any, BinaryIO

from .caps import MAX_FILE_BYTES
from .errors import MjmotionError

_KINDS = (
    (stat.S_ISDIR, "is a directory"),
    (stat.S_ISFIFO, "is a named pipe (FIFO)"),
    (stat.S_ISCHR, "is a character device"),
    (stat.S_ISBLK, "is a block device"),
    (stat.S_ISSOCK, "is a socket"),
)
_ERRNO = {
    errno.ENOENT: "no such file",
    errno.EACCES: "permission denied",
    errno.EPERM: "permission denied",
    errno.ELOOP: "too many levels of symbolic links (a symlink loop?)",
    errno.ENOTDIR: "a part of the path is not a directory",
    errno.ENAMETOOLONG: "file name too long",
    errno.EISDIR: "is a directory",
}


class InputError(MjmotionError):
    """An input that cannot be read: ``path`` and the ``message`` (what is wrong, what was expected)."""

    def __init__(self, path: str, message: str):
        self.path = path
        self.message = message
        super().__init__(f"{path}: {message}")


def describe_os_error(e: OSError) -> str:
    """The part of a message that says why ``e`` happened, without the path."""
    return _ERRNO.get(e.errno or 0) or (e.strerror or str(e)).lower()


def kind_of(mode: int) -> str | None:
    """What a non-regular file is ("is a named pipe (FIFO)"), or ``None`` for a regular file."""
    if stat.S_ISREG(mode):
        return None
    return next((text for test, text in _KINDS if test(mode)), "is not a regular file")


@contextlib.contextmanager
def open_input(path: str | os.PathLike[str], limit: int = MAX_FILE_BYTES, what: str = "a file") -> Iterator[tuple[BinaryIO, int]]:
    """Open ``path`` for reading; yields ``(binary file, size in bytes)``.

    Refuses (:class:`InputError`) a path that is not a regular file (a directory, FIFO, device or
    socket; a symbolic link is followed), one that cannot be opened, and one larger than
    ``limit`` bytes. ``what`` ("a .bvh file") completes the messages ("expected a .bvh file").
    """
    p = os.fspath(path)
    try:
        st = os.stat(p)  # no open() of a FIFO or a device: opening may block or have effects
    except OSError as e:
        raise InputError(p, describe_os_error(e)) from None
    if (kind := kind_of(st.st_mode)) is not None:
        raise InputError(p, f"{kind}; expected {what} (a regular file)")
    if st.st_size > limit:
        raise InputError(p, f"file is {st.st_size} bytes, larger than the limit of {limit} bytes for {what}")
    try:
        # O_NONBLOCK: if a FIFO was put at the path since the stat, opening it cannot block.
        fd = os.open(p, os.O_RDONLY | getattr(os, "O_NONBLOCK", 0) | getattr(os, "O_NOCTTY", 0) | getattr(os, "O_CLOEXEC", 0))
    except OSError as e:
        raise InputError(p, describe_os_error(e)) from None
    try:
        st = os.fstat(fd)
        if (kind := kind_of(st.st_mode)) is not None:
            raise InputError(p, f"{kind}; expected {what} (a regular file)")
        if st.st_size > limit:
            raise InputError(p, f"file is {st.st_size} bytes, larger than the limit of {limit} bytes for {what}")
        if hasattr(os, "set_blocking"):
            os.set_blocking(fd, True)
        fh = os.fdopen(fd, "rb")
    except BaseException:
        os.close(fd)
        raise
    with fh:
        yield fh, int(st.st_size)


def read_input(path: str | os.PathLike[str], limit: int = MAX_FILE_BYTES, what: str = "a file") -> bytes:
    """The bytes of ``path`` (see :func:`open_input`), at most ``limit`` of them."""
    with open_input(path, limit, what) as (fh, size):
        try:
            # The measured size plus one byte (which tells a file that grew), then more only if
            # it did (or the size was not known: /proc reports 0): never a limit-sized buffer.
            chunks = [fh.read(min(limit, size) + 1)]
            total = len(chunks[0])
            while total <= limit and total > size and (chunk := fh.read(min(1 << 20, limit + 1 - total))):
                chunks.append(chunk)
                total += len(chunk)
        except OSError as e:
            raise InputError(os.fspath(path), f"cannot read: {describe_os_error(e)}") from None
    data = chunks[0] if len(chunks) == 1 else b"".join(chunks)
    if len(data) > limit:  # it grew since it was measured (or the size was not known: /proc)
        raise InputError(os.fspath(path), f"more than the limit of {limit} bytes for {what}")
    return data


def read_text(path: str | os.PathLike[str], limit: int = MAX_FILE_BYTES, what: str = "a text file") -> str:
    """:func:`read_input` decoded as UTF-8 (a byte-order mark is dropped); refuses binary data."""
    data = read_input(path, limit, what)
    if data.startswith(b"\xef\xbb\xbf"):
        data = data[3:]
    try:
        text = data.decode("utf-8")
    except UnicodeDecodeError as e:
        raise InputError(os.fspath(path), f"not a text file (invalid UTF-8 at byte {e.start}); expected {what}") from None
    nul = text.find("\x00")
    if nul >= 0:
        raise InputError(os.fspath(path), f"binary data (a NUL byte at character {nul}); expected {what}")
    return text


class DuplicateKey(ValueError):
    """A JSON object of an input names one key twice (:func:`once`); ``key`` is that key."""

    def __init__(self, key: str):
        super().__init__(key)
        self.key = key


def once(pairs: list[tuple[str, Any]]) -> dict[str, Any]:
    """A JSON ``object_pairs_hook``: the object as a dict, or :class:`DuplicateKey` for a key given twice
    (``json`` keeps the last silently: a script's second "duration" replaced its first)."""
    out = dict(pairs)
    if len(out) < len(pairs):
        seen: set[str] = set()
        for k, _ in pairs:
            if k in seen:
                raise DuplicateKey(k)
            seen.add(k)
    return out


def find_bvh(root: str | os.PathLike[str], unreadable: list[str] | None = None, skipped: list[tuple[Path, str]] | None = None) -> list[Path]:
    """Every ``.bvh`` file under the folder ``root`` (any case), sorted, as paths under ``root`` as given.
    Linked folders are not entered, and a linked file counts only if it resolves inside ``root`` (a
    link loop is no file): a folder a user names is all that is read (audit, evaluate, studio and
    demo list folders through this). Folders that cannot be listed are appended to ``unreadable``;
    names ending in ``.bvh`` that are no file to read (a dangling link or a link loop, a pipe, a
    socket, a device) to ``skipped`` as ``(path, why)``."""
    given = Path(root)
    base = given.resolve()
    out = []

    def listing_failed(e: OSError) -> None:
        if unreadable is not None:
            unreadable.append(f"{e.filename}: {e.strerror or e}")

    for folder, dirs, files in os.walk(given, followlinks=False, onerror=listing_failed):
        dirs.sort()
        for name in files:
            p = Path(folder) / name
            if p.suffix.lower() != ".bvh":
                continue
            try:
                if p.is_symlink() and not p.resolve(strict=True).is_relative_to(base):
                    continue  # a link out of the folder: documented, not followed
                if not p.is_file():
                    if skipped is not None:
                        skipped.append((p, "not a regular file"))
                    continue
            except (OSError, RuntimeError):  # a dangling link or a link loop
                if skipped is not None:
                    skipped.append((p, "a link to nothing (or a link loop)"))
                continue
            out.append(p)
    if skipped is not None:
        skipped.sort()
    return sorted(out)
