"""Writing results safely: never over an input, never over a file without ``force``, never half-written.

Two steps, for every file a verb writes:

1. :func:`check_output` before any work: refuses an output that names an input, a folder
   (``out.bvh/``), a directory, a FIFO, a device or a socket, an existing file or symbolic link
   (dangling too) without ``force``, and a folder that does not exist or takes no files (probed
   with a temporary named as step 2's). It records the decision for the path (a *claim*: replace
   or not). :func:`check_folder` is its counterpart for a verb that writes a whole folder.
2. :func:`atomic_path` (and the ``write_*`` helpers on it) at the end: the result goes to a
   temporary file beside the output, is flushed to the disk (``fsync``: a full disk shows here,
   not later), and is *published*: without ``force`` by a rename that fails if the output exists
   (``renameat2(RENAME_NOREPLACE)``, else a hard link, else an exclusive create), so a file that
   appeared at the output while the command ran — another run writing the same output — is
   never replaced; with ``force`` by ``os.replace``, and only over a regular file or a symbolic
   link (the link itself, never what it points to).

A verb with several outputs (a clip, its report, its plot) writes them inside :func:`together`: each is
finished as a temporary as above, and all are published at the end of the block, so an interrupt or an
error on the way leaves none of them (a clip without its report read as a finished run).

A path no :func:`check_output` claimed (library code writing results) is published with
replacement, as ``os.replace`` would, but never over a directory, FIFO, device or socket.

Every JSON file a verb writes is :func:`json_text`: standard JSON, a value that is not a finite
number (a metric with nothing to measure) written as ``null``.
"""

from __future__ import annotations

import contextlib
import ctypes
import errno
import functools
import json
import math
import os
import shutil
import stat
import tempfile
import threading
from collections.abc import Callable, Iterable, Iterator
from pathlib import Path
from typing import Any

from .errors import AlreadyExistsError, MjmotionError, OutputExistsError
from .inputs import kind_of

#: Claims of :func:`check_output`: absolute path → replace allowed (``force``). Kept until
#: :func:`reset_claims` (the CLI resets them per command): a stale claim can only refuse a
#: replacement, never allow one.
_CLAIMS: dict[str, bool] = {}
#: Per thread, the outputs held by :func:`together` blocks (innermost last): temporary, output, replace.
_HELD = threading.local()


def _key(path: str | os.PathLike[str]) -> str:
    return os.path.abspath(os.fspath(path))


def reset_claims() -> None:
    """Forget every claim (the CLI does this before each command)."""
    _CLAIMS.clear()


def _lstat(path: Path) -> os.stat_result | None:
    try:
        return os.lstat(path)
    except FileNotFoundError:
        return None
    except NotADirectoryError:  # a path through a regular file: the folder check below says so
        return None


def _is_dir(path: Path) -> bool:
    try:
        return stat.S_ISDIR(os.stat(path).st_mode)
    except OSError:
        return False


def check_output(
    path: str | os.PathLike[str],
    force: bool = False,
    inputs: Iterable[str | os.PathLike[str]] = (),
) -> Path:
    """Validate an output path before any work is done; returns it as a ``Path``.

    Refuses an output that names one of ``inputs`` (even through a link), a path ending in a
    separator, a directory, a FIFO, device or socket (``--force`` or not), an existing file or
    symbolic link without ``force``, or a folder that does not exist. Records whether the
    output may be replaced, for :func:`atomic_path`.
    """
    raw = os.fspath(path)
    if not raw.strip():
        raise OutputExistsError(f"{raw!r}: an empty output path; expected a file path, not an empty value")
    if raw.endswith(("/", os.sep)) or os.path.basename(raw) in (".", ".."):
        raise OutputExistsError(f"{raw}: names a folder; expected a file path (no trailing '/')")
    out = Path(raw)
    for src in inputs:
        try:
            if out.exists() and os.path.samefile(out, src):
                raise OutputExistsError(f"{out}: is an input of this command, or another of its outputs; choose another output path")
        except FileNotFoundError:
            pass
        if os.path.realpath(out) == os.path.realpath(src):  # (realpath, unlike resolve, takes a symlink loop)
            raise OutputExistsError(f"{out}: is an input of this command, or another of its outputs; choose another output path")
    st = _lstat(out)
    if st is not None:
        if _is_dir(out):
            raise OutputExistsError(f"{out}: is a directory; expected a file path")
        _check_replaceable(out, st)
        if not force:
            link = " (a symbolic link)" if stat.S_ISLNK(st.st_mode) else ""
            raise AlreadyExistsError(f"{out}: already exists{link}; pass --force to replace it")
    parent = out.parent if str(out.parent) else Path(".")
    if not parent.is_dir():
        raise MjmotionError(f"{out}: folder {parent} does not exist")
    _probe(out)
    _CLAIMS[_key(out)] = bool(force)
    return out


def _probe(out: Path) -> None:
    """Make and remove a temporary beside ``out``, as :func:`atomic_path` will: a folder the user
    cannot write in (permissions, a read-only mount, ``/sys``) is refused before the work, not after.
    (``os.access`` is no test: root passes it on a read-only mount.)"""
    with _beside(out) as parent:
        _make_and_remove(parent, prefix=f".{out.name}.", suffix=out.suffix or ".tmp")  # named as atomic_path's


def _make_and_remove(folder: Path, prefix: str, suffix: str) -> None:
    """Create a temporary file in ``folder`` and remove it (raises ``OSError`` where none can be made)."""
    fd, tmp = tempfile.mkstemp(prefix=prefix, suffix=suffix, dir=folder)
    os.close(fd)
    with contextlib.suppress(FileNotFoundError):
        os.unlink(tmp)


def check_folder(path: str | os.PathLike[str], option: str = "") -> Path:
    """Before any work, for an output *folder*: ``path`` is a folder this process can write in, or can be
    made (its nearest existing ancestor is such a folder). Errors name ``option`` (none for a
    positional argument). Returns it as a ``Path``."""
    d = Path(path)
    where = f"{option} {d}" if option else str(d)
    existing = next((p for p in (d, *d.parents) if os.path.lexists(p)), Path("."))
    if not _is_dir(existing):
        raise MjmotionError(f"{where}: {existing} exists and is not a folder")
    try:
        _make_and_remove(existing, prefix=".mjmotion-", suffix=".probe")
    except OSError as e:
        raise MjmotionError(f"{where}: cannot write in {existing} ({e.strerror or e})") from None
    return d


def _check_replaceable(out: Path, st: os.stat_result) -> None:
    """Refuse an existing output that is not a regular file or a symbolic link (``/dev/null``, a FIFO)."""
    if stat.S_ISLNK(st.st_mode) or stat.S_ISREG(st.st_mode):
        return
    raise OutputExistsError(f"{out}: {kind_of(st.st_mode)}; an output must be a new file (--force replaces only a regular file)")


# --- publishing ------------------------------------------------------------------------------
_RENAME_NOREPLACE = 1
_AT_FDCWD = -100


@functools.lru_cache(maxsize=1)
def _renameat2() -> Callable[..., int] | None:
    """glibc's ``renameat2`` (Linux 3.15+, glibc 2.28+), or ``None``."""
    try:
        fn = ctypes.CDLL(None, use_errno=True).renameat2
    except (OSError, AttributeError):
        return None
    fn.argtypes = (ctypes.c_int, ctypes.c_char_p, ctypes.c_int, ctypes.c_char_p, ctypes.c_uint)
    fn.restype = ctypes.c_int
    return fn


def rename_noreplace(src: str | os.PathLike[str], dst: str | os.PathLike[str]) -> None:
    """Move ``src`` to ``dst`` atomically; ``FileExistsError`` if ``dst`` exists (a dangling link too).

    ``renameat2(RENAME_NOREPLACE)`` where the system and filesystem have it; else a hard link
    (which fails if ``dst`` exists) and unlinking ``src``; else (filesystems without hard links)
    an exclusive create of ``dst`` and a rename over it. A folder without ``renameat2``: a rename
    if ``dst`` does not exist.
    """
    s, d = os.fsencode(src), os.fsencode(dst)
    fn = _renameat2()
    if fn is not None:
        if fn(_AT_FDCWD, s, _AT_FDCWD, d, _RENAME_NOREPLACE) == 0:
            return
        err = ctypes.get_errno()
        if err not in (errno.EINVAL, errno.ENOSYS, errno.ENOTSUP, errno.EOPNOTSUPP):
            raise OSError(err, os.strerror(err), os.fsdecode(d))
    if os.path.isdir(s):  # no hard links of folders: a rename, which replaces only an empty folder
        if os.path.lexists(d):
            raise FileExistsError(errno.EEXIST, os.strerror(errno.EEXIST), os.fsdecode(d))
        os.rename(s, d)
        return
    try:
        os.link(s, d, follow_symlinks=False)
    except FileExistsError:
        raise
    except OSError as e:
        if e.errno not in (errno.EPERM, errno.ENOTSUP, errno.EOPNOTSUPP, errno.EMLINK, errno.EXDEV, errno.ENOSYS):
            raise
        fd = os.open(d, os.O_CREAT | os.O_EXCL | os.O_WRONLY, 0o600)  # FileExistsError if it appeared
        os.close(fd)
        os.replace(s, d)
        return
    os.unlink(s)


def publish(tmp: str | os.PathLike[str], path: str | os.PathLike[str], replace: bool) -> None:
    """Move the finished ``tmp`` onto ``path``: with ``replace`` over a regular file or link only,
    without it never over anything (:class:`OutputExistsError` if ``path`` appeared meanwhile)."""
    out = Path(path)
    if replace:
        st = _lstat(out)
        if st is not None:
            if _is_dir(out):
                raise OutputExistsError(f"{out}: is a directory; expected a file path")
            _check_replaceable(out, st)
        os.replace(tmp, out)
        return
    try:
        rename_noreplace(tmp, out)
    except FileExistsError:
        raise OutputExistsError(
            f"{out}: appeared while this command ran (another run writing it?); not replaced — pass --force to replace it"
        ) from None


def _fsync(path: str | os.PathLike[str]) -> None:
    """Flush a written file to the disk: a full disk (delayed allocation) fails here, not after 'wrote'."""
    fd = os.open(path, os.O_RDONLY)
    try:
        os.fsync(fd)
    finally:
        os.close(fd)


@contextlib.contextmanager
def _beside(out: Path) -> Iterator[Path]:
    """The folder ``out`` is written in, for making a temporary there: a failure is named after the
    user's path, not the hidden temporary's."""
    parent = out.parent if str(out.parent) else Path(".")
    try:
        yield parent
    except OSError as e:
        raise MjmotionError(f"{out}: cannot write in {parent} ({e.strerror or e})") from None


@contextlib.contextmanager
def atomic_path(path: str | os.PathLike[str], replace: bool | None = None) -> Iterator[Path]:
    """Yield a temporary path beside ``path``; publish it onto ``path`` only if the block succeeds.

    ``replace``: whether an existing output may be replaced; ``None`` takes the claim of
    :func:`check_output` for this path (``--force``), or ``True`` for a path nobody claimed.
    """
    out = Path(path)
    if replace is None:
        replace = _CLAIMS.get(_key(out), True)
    with _beside(out) as parent:
        fd, tmp = tempfile.mkstemp(prefix=f".{out.name}.", suffix=out.suffix or ".tmp", dir=parent)
    os.close(fd)
    # mkstemp makes the file private (0600); results get the usual umask-based mode.
    umask = os.umask(0)
    os.umask(umask)
    os.chmod(tmp, 0o666 & ~umask)
    try:
        yield Path(tmp)
        _fsync(tmp)
        held = getattr(_HELD, "stack", None)
        if held:
            held[-1].append((tmp, out, replace))
        else:
            publish(tmp, out, replace)
    except BaseException as e:
        with contextlib.suppress(FileNotFoundError):
            os.unlink(tmp)
        if isinstance(e, OSError) and not isinstance(e, MjmotionError) and getattr(e, "filename", None) is None:
            # (a full disk read "error: No space left on device", naming no file)
            raise MjmotionError(f"{out}: cannot be written ({e.strerror or e}); nothing was written there") from None
        raise


@contextlib.contextmanager
def together() -> Iterator[None]:
    """Publish every file :func:`atomic_path` finishes in this block (in this thread) when the block ends,
    in the order written; if it raises or is interrupted, remove them all and publish none."""
    stack = _HELD.__dict__.setdefault("stack", [])
    pending: list[tuple[str, Path, bool]] = []
    stack.append(pending)
    published = 0
    try:
        try:
            yield
        finally:
            stack.pop()
        for tmp, out, replace in pending:
            publish(tmp, out, replace)
            published += 1
    except BaseException:
        for tmp, _, _ in pending[published:]:
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
    """Call ``writer(tmp_path)`` and publish the result onto ``path`` (see :func:`atomic_path`)."""
    with atomic_path(path) as tmp:
        writer(tmp)


@contextlib.contextmanager
def staged_folder(path: str | os.PathLike[str]) -> Iterator[Path]:
    """Yield a new temporary folder beside ``path``; on success it is renamed to ``path`` (which
    must not exist then), on failure removed: a folder of results appears whole or not at all."""
    out = Path(path)
    with _beside(out) as parent:
        tmp = Path(tempfile.mkdtemp(prefix=f".{out.name}.", dir=parent))
    try:
        umask = os.umask(0)
        os.umask(umask)
        os.chmod(tmp, 0o777 & ~umask)
        yield tmp
        try:
            rename_noreplace(tmp, out)
        except FileExistsError:
            raise OutputExistsError(f"{out}: appeared while this command ran; not replaced") from None
    except BaseException:
        shutil.rmtree(tmp, ignore_errors=True)
        raise


def _plain(x: Any) -> Any:
    """``x`` with NumPy values as Python ones and every non-finite float as ``None`` (nested dicts, lists,
    tuples; NumPy keys too)."""
    import numpy as np

    if isinstance(x, dict):
        return {_plain(k): _plain(v) for k, v in x.items()}
    if isinstance(x, (list, tuple)):
        return [_plain(v) for v in x]
    if isinstance(x, np.ndarray):
        # (row by row: tolist() keeps a longdouble a longdouble)
        return _plain(x[()]) if x.ndim == 0 else [_plain(v) for v in x]
    if isinstance(x, np.generic):
        kind = x.dtype.kind
        x = bool(x) if kind == "b" else int(x) if kind in "iu" else float(x) if kind == "f" else x.item()
    if isinstance(x, float) and not math.isfinite(x):
        return None
    return x


def json_text(value: Any, indent: int | None = None) -> str:
    """``value`` as standard JSON text: NaN and ±inf (which ``json.dumps`` writes as ``NaN`` and
    ``Infinity``, refused by strict readers) become ``null``; NumPy scalars and arrays become numbers
    and lists; anything else JSON cannot hold raises ``TypeError``."""
    return json.dumps(_plain(value), indent=indent, allow_nan=False)
