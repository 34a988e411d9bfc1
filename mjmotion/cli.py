"""The ``mjmotion`` command: one sub-command per verb.

Each verb lives in its own module under :mod:`mjmotion.commands` and exposes ``NAME``,
``HELP``, ``add_arguments(parser)`` and ``run(args) -> int``; this front end discovers them,
so adding a verb touches no shared file. Errors a user can act on print one ``error:`` line
and exit with status 2; ``--verbose`` adds the traceback for bug reports.
"""

from __future__ import annotations

import argparse
import importlib
import pkgutil
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
    "hit", "vary", "evaluate", "cleanup", "render", "demo",
)  # fmt: skip


class _Parser(argparse.ArgumentParser):
    """argparse that reports a usage mistake as one ``error:`` line (status 2)."""

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


def build_parser() -> argparse.ArgumentParser:
    parser = _Parser(
        prog="mjmotion",
        description=(
            "Make new character motion out of motion capture and check it against physics.\n"
            "Clips are BVH files; lengths are metres in MuJoCo's Z-up world unless a verb says otherwise.\n"
            "Run 'mjmotion VERB --help' for each verb's options and examples."
        ),
        formatter_class=argparse.RawDescriptionHelpFormatter,
    )
    parser.add_argument("--version", action="version", version=f"mjmotion {__version__}")
    parser.add_argument("-v", "--verbose", action="store_true", help="show the traceback of an error (for bug reports)")
    sub = parser.add_subparsers(dest="verb", metavar="VERB", parser_class=_Parser)
    for mod in _verbs():
        p = sub.add_parser(
            mod.NAME,
            help=mod.HELP,
            description=getattr(mod, "DESCRIPTION", mod.HELP),
            formatter_class=argparse.RawDescriptionHelpFormatter,
        )
        p.add_argument("-v", "--verbose", action="store_true", default=argparse.SUPPRESS, help="show the traceback of an error")
        mod.add_arguments(p)
        p.set_defaults(_run=mod.run)
    return parser


def _one_line(message: str) -> str:
    """The message on one printable line: a file name, a script's text or a verb's message may hold
    line breaks or terminal escape sequences (they are shown escaped, as Python writes them)."""
    return printable(message)


def main(argv: Sequence[str] | None = None) -> int:
    reset_claims()  # outputs checked by an earlier command in this process are not this one's
    parser = build_parser()
    try:
        args = parser.parse_args(argv)
    except SystemExit as e:  # a usage error (exit status 2, already reported) or --help (0)
        return e.code if isinstance(e.code, int) else 2
    if not getattr(args, "verb", None):
        parser.print_help()
        return 2
    verbose = bool(getattr(args, "verbose", False))
    try:
        return int(args._run(args) or 0)
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
