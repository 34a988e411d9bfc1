"""The ``mjmotion`` command: one sub-command per verb.

Each verb lives in its own module under :mod:`mjmotion.commands` and exposes ``NAME``,
``HELP``, ``add_arguments(parser)`` and ``run(args) -> int``; this front end discovers them,
so adding a verb touches no shared file. Errors a user can act on print one ``error:`` line
and exit with status 2; ``--verbose`` adds the traceback for bug reports.

Start-up is what a user feels first, so the front end imports every verb module (for the list
of verbs) but calls ``add_arguments`` only for the verb being run, and a verb module imports
nothing heavier than the standard library at its top: NumPy, SciPy, MuJoCo, CasADi,
Matplotlib and Numba load inside ``run()`` (``tests/test_cli.py`` checks this for every
verb module, new ones included). A verb that renders nothing sets ``MUJOCO_WITHOUT_GL = True``
and MuJoCo is imported for it without the OpenGL backend its package would load. A new verb
adds its name to :data:`VERB_ORDER` only to choose its place in ``--help``.
"""

from __future__ import annotations

import argparse
import importlib
import os
import pkgutil
import re
import sys
import traceback
from collections.abc import Sequence
from types import ModuleType

from . import __version__
from .errors import MjmotionError, printable
from .outputs import reset_claims

#: Order of verbs in ``--help``; verbs not listed follow alphabetically.
VERB_ORDER = (
    "info", "convert", "compile", "fk", "synth", "register", "blend", "stream",
    "hit", "vary", "evaluate", "audit", "cleanup", "render", "demo", "studio",
)  # fmt: skip


#: What reads as a negative number, not an option: argparse's own pattern takes ``-0.001`` but not ``-1e-3``,
#: ``-inf`` or ``-nan`` ("--floor -1e-3: expected one argument"); these reach the option's own check now.
#: So do a frame range counted from the end, ``--frames -100:`` or ``-100:-50`` (its help says negatives
#: are allowed, and argparse read them as an option), and a list of numbers led by a negative one
#: (``--weights -0.2,1.2``: refused by the option's own check, not as "expected one argument").
_NUMBER = r"(\d+\.?\d*|\.\d+)([eE][-+]?\d+)?"
NEGATIVE_NUMBER = re.compile(
    rf"^-{_NUMBER}$|^-(inf|infinity|nan)$|^-\d+:-?\d*$|^-{_NUMBER}(,\s*-?{_NUMBER})+$",
    re.IGNORECASE,
)


class _Parser(argparse.ArgumentParser):
    """argparse that reports a usage mistake as one ``error:`` line (status 2)."""

    def __init__(self, *args: object, **kwargs: object) -> None:
        super().__init__(*args, **kwargs)  # type: ignore[arg-type]
        self._negative_number_matcher = NEGATIVE_NUMBER

    def error(self, message: str) -> None:  # type: ignore[override]
        sys.stderr.write(f"error: {_one_line(message)} (see '{self.prog} --help')\n")
        raise SystemExit(2)

    def _get_value(self, action: argparse.Action, arg_string: str) -> object:
        # An option domain (mjmotion.commands._options) says "VALUE: expected …": the line reads
        # "--fps 1e308: expected …", like the checks made after parsing.
        try:
            return super()._get_value(action, arg_string)
        except argparse.ArgumentError as e:
            if not getattr(action.type, "option_domain", False):
                raise
            name = max(action.option_strings, key=len) if action.option_strings else action.metavar or action.dest
            raise argparse.ArgumentError(None, f"{name} {e.message}") from None


def _verbs() -> list[ModuleType]:
    from . import commands

    mods = [
        importlib.import_module(f"{commands.__name__}.{info.name}")
        for info in pkgutil.iter_modules(commands.__path__)
        if not info.name.startswith("_")
    ]
    rank = {name: i for i, name in enumerate(VERB_ORDER)}
    return sorted(mods, key=lambda m: (rank.get(m.NAME, len(rank)), m.NAME))


def _chosen_verb(argv: Sequence[str], names: set[str]) -> str | None:
    """The verb named in ``argv`` (its first word that is not an option), or ``None``."""
    for word in argv:
        if word == "--":
            return None
        if not word.startswith("-"):
            return word if word in names else None
    return None


def build_parser(argv: Sequence[str] | None = None) -> argparse.ArgumentParser:
    """The ``mjmotion`` parser; with ``argv``, only the verb it names gets its options (and imports).

    Without ``argv`` every verb's options are added (for documentation and tests).
    """
    parser = _Parser(
        prog="mjmotion",
        description=(
            "Make new character motion out of motion capture and check it against physics.\n"
            "Clips are BVH files; lengths are metres in MuJoCo's Z-up world unless a verb says otherwise.\n"
            "Run 'mjmotion VERB --help' for each verb's options and examples. The methods, the papers they\n"
            "come from (Macleod 2006, Sako 2008, Hicks 2010) and where we differ: docs/algorithms.md;\n"
            "the metrics: docs/METRICS.md."
        ),
        formatter_class=argparse.RawDescriptionHelpFormatter,
    )
    parser.add_argument("--version", action="version", version=f"mjmotion {__version__}")
    parser.add_argument("-v", "--verbose", action="store_true", help="show the traceback of an error (for bug reports)")
    sub = parser.add_subparsers(dest="verb", metavar="VERB", parser_class=_Parser)
    verbs = _verbs()
    chosen = None if argv is None else _chosen_verb(argv, {m.NAME for m in verbs})
    for mod in verbs:
        p = sub.add_parser(
            mod.NAME,
            help=mod.HELP,
            description=getattr(mod, "DESCRIPTION", mod.HELP),
            formatter_class=argparse.RawDescriptionHelpFormatter,
        )
        p.add_argument("-v", "--verbose", action="store_true", default=argparse.SUPPRESS, help="show the traceback of an error")
        if argv is None or mod.NAME == chosen:
            mod.add_arguments(p)
            from .commands._options import state_ranges  # (loaded by the verbs' options already)

            state_ranges(p)
        p.set_defaults(_run=mod.run, _mujoco_without_gl=getattr(mod, "MUJOCO_WITHOUT_GL", False))
    return parser


def _verb_parser(parser: argparse.ArgumentParser, verb: str | None) -> argparse.ArgumentParser | None:
    """The parser of ``verb`` (None when no verb, or an unknown one, was named)."""
    sub = next((a for a in parser._actions if isinstance(a, argparse._SubParsersAction)), None)
    return sub.choices.get(verb) if sub is not None and verb else None


def _unrecognized(parser: argparse.ArgumentParser, verb: str | None, extra: list[str]) -> None:
    """Report words no option took, through the verb's own parser (its ``--help`` is the one to read); numbers
    left over after an option that takes a comma-separated list get the list's spelling."""
    p = _verb_parser(parser, verb) or parser
    message = f"unrecognized arguments: {' '.join(extra)}"
    lists = [a for a in p._actions if a.option_strings and isinstance(a.metavar, str) and "," in a.metavar]
    if lists and all(_is_number(w) for w in extra):
        a = lists[0]
        message += f"; {max(a.option_strings, key=len)} takes one comma-separated list ({a.metavar}), no spaces"
    p.error(message)


def _refuse_empty(parser: argparse.ArgumentParser, args: argparse.Namespace) -> None:
    """An empty value of an option that takes text (a path, a name, a range) is a usage error: ``--json ""``
    was skipped as if not given, ``-o ""`` became the current folder."""
    p = _verb_parser(parser, getattr(args, "verb", None))
    if p is None:
        return
    for a in p._actions:
        if not a.option_strings or a.type is not None or a.nargs == 0 or a.choices is not None:
            continue
        value = getattr(args, a.dest, None)
        blank = [v for v in (value if isinstance(value, list) else [value]) if isinstance(v, str) and not v.strip()]
        if blank:
            p.error(f"{max(a.option_strings, key=len)} {blank[0]!r}: expected {a.metavar or a.dest.upper()}, not an empty value")


def _refuse_repeated(parser: argparse.ArgumentParser, args: argparse.Namespace, argv: Sequence[str]) -> None:
    """An option that holds one value given twice is a usage error: argparse keeps the last
    (``--fps 30 --fps 60`` wrote 60 fps, silently). Repeatable options (``--source``, ``--prop``) append."""
    p = _verb_parser(parser, getattr(args, "verb", None))
    if p is None:
        return
    words = list(argv)
    words = words[: words.index("--")] if "--" in words else words
    longs = [o for a in p._actions for o in a.option_strings if o.startswith("--")]
    for a in p._actions:
        if not a.option_strings or not (isinstance(a, argparse._StoreAction) or getattr(a, "holds_one_value", False)):
            continue
        given = [w for w in words if _names(w, a.option_strings, longs)]
        if len(given) > 1:
            p.error(f"{max(a.option_strings, key=len)} is given {len(given)} times; give it once")


def _names(word: str, options: Sequence[str], longs: Sequence[str]) -> bool:
    """Whether the command-line ``word`` gives the option of ``options``: by one of its names, as
    ``--name=value``, or by a prefix of its long name that no other long option starts with (argparse
    takes ``--fp 30`` for ``--fps 30``)."""
    if word in options:
        return True
    if not word.startswith("--"):
        return False
    name = word.partition("=")[0]
    if name in options:
        return True
    matches = {o for o in longs if o.startswith(name)}
    return bool(matches) and matches <= set(options)


def _is_number(word: str) -> bool:
    try:
        float(word)
    except ValueError:
        return False
    return True


def _one_line(message: str) -> str:
    """The message on one printable line: a file name, a script's text or a verb's message may hold
    line breaks or terminal escape sequences (they are shown escaped, as Python writes them)."""
    return printable(message)


#: Thread-count variables OpenBLAS reads; when none is set, the CLI runs BLAS on one thread.
_BLAS_THREAD_VARS = ("OPENBLAS_NUM_THREADS", "GOTO_NUM_THREADS", "OMP_NUM_THREADS")


def main(argv: Sequence[str] | None = None) -> int:
    """Run the ``mjmotion`` command on ``argv`` (default ``sys.argv[1:]``); the exit status.

    A reader that closes the pipe early (``mjmotion info X.bvh --json | head -1``) ends the command
    quietly with status 141 (128 + SIGPIPE, as a tool killed by the signal reports).
    """
    try:
        return _main(argv)
    except BrokenPipeError:
        if not _stdout_closed():
            raise
        _quiet_stdout()
        return 141


def _stdout_closed() -> bool:
    """Whether standard output is a pipe whose reader has gone (a broken pipe to a helper
    process such as ffmpeg is an error, not a reader that has read enough)."""
    import select

    try:
        fd = sys.stdout.fileno()
        poller = select.poll()
        poller.register(fd, select.POLLOUT)
        return any(ev & (select.POLLERR | select.POLLHUP) for _, ev in poller.poll(0))
    except (AttributeError, OSError, ValueError):  # (no poll on this platform, or stdout is not a file)
        return True


def _quiet_stdout() -> None:
    """Point standard output at the null device, so that the interpreter's flush at exit does not
    fail again on the closed pipe (Python's documentation, "Note on SIGPIPE")."""
    try:
        devnull = os.open(os.devnull, os.O_WRONLY)
        os.dup2(devnull, sys.stdout.fileno())
    except (AttributeError, OSError, ValueError):
        pass


def _main(argv: Sequence[str] | None) -> int:
    if not any(v in os.environ for v in _BLAS_THREAD_VARS):
        # One BLAS thread unless the user says otherwise: OpenBLAS starting its pool costs ~60 ms
        # of CPU at NumPy's import, and our products (600 × 210) are too small to gain from two
        # threads on a shared 2-core machine; verbs that parallelise use processes (--jobs).
        os.environ["OPENBLAS_NUM_THREADS"] = "1"
    reset_claims()  # outputs checked by an earlier command in this process are not this one's
    argv = sys.argv[1:] if argv is None else list(argv)
    parser = build_parser(argv)
    try:
        args, extra = parser.parse_known_args(argv)
        if extra:
            _unrecognized(parser, getattr(args, "verb", None), extra)
        _refuse_empty(parser, args)
        _refuse_repeated(parser, args, argv)
    except SystemExit as e:  # a usage error (exit status 2, already reported) or --help (0)
        return e.code if isinstance(e.code, int) else 2
    if not getattr(args, "verb", None):  # a usage error like any other: the help, then one error line, on stderr
        parser.print_help(sys.stderr)
        sys.stderr.write("error: expected a VERB (listed above)\n")
        return 2
    if args._mujoco_without_gl:
        _import_mujoco_without_gl()
    try:
        return _run(args)
    finally:
        reset_claims()  # a library write after this command is not bound by its outputs' --force


def _import_mujoco_without_gl() -> None:
    """Import MuJoCo with the OpenGL backend its package loads at import switched off
    (``MUJOCO_GL=disable`` for the import alone; the value it had is restored at once). The verbs
    that ask for it (``MUJOCO_WITHOUT_GL``) render nothing, and that backend costs 40-50 ms of
    start-up (glfw's library search, or EGL's); mjmotion's renders never use it either
    (:func:`mjmotion.render.open_gl_context` opens its own context). MuJoCo stays imported so for
    the process: ``mujoco.Renderer`` then has no context class, so a library user who calls
    :func:`main` in-process and needs it imports MuJoCo first."""
    if "mujoco" in sys.modules:
        return
    saved = os.environ.get("MUJOCO_GL")
    os.environ["MUJOCO_GL"] = "disable"
    try:
        import mujoco  # noqa: F401
    except ImportError:
        pass  # the verb's own import reports it
    finally:
        if saved is None:
            os.environ.pop("MUJOCO_GL", None)
        else:
            os.environ["MUJOCO_GL"] = saved


def _run(args: argparse.Namespace) -> int:
    verbose = bool(getattr(args, "verbose", False))
    try:
        status = int(args._run(args) or 0)
        sys.stdout.flush()  # a reader gone before the last line is seen here, not at exit
        return status
    except BrokenPipeError:
        if _stdout_closed():
            raise  # main ends quietly
        if verbose:
            traceback.print_exc()
        sys.stderr.write("error: broken pipe (a helper process ended early)\n")
        return 2
    except MjmotionError as e:
        if verbose:
            traceback.print_exc()
        sys.stderr.write(f"error: {_one_line(str(e))}\n")
        return 2
    except OSError as e:
        if verbose:
            traceback.print_exc()
        where = f"{e.filename}: " if getattr(e, "filename", None) else ""
        sys.stderr.write(f"error: {_one_line(f'{where}{e.strerror or e}')}\n")
        return 2
    except KeyboardInterrupt:
        sys.stderr.write("error: interrupted\n")
        return 130
    except Exception as e:  # a bug: still one line, the traceback on request
        if verbose:
            traceback.print_exc()
        msg = _one_line(f"{type(e).__name__}: {e}")
        sys.stderr.write(f"error: internal error: {msg} (rerun with --verbose and report it)\n")
        return 1


if __name__ == "__main__":
    raise SystemExit(main())
