"""The documentation a fresh clone carries: the API reference builds clean (docs/build_api.py)."""

from __future__ import annotations

import importlib
import re
import subprocess
import sys
from pathlib import Path

import pytest

ROOT = Path(__file__).resolve().parents[1]
sys.path.insert(0, str(ROOT / "docs"))
build_api = importlib.import_module("build_api")


def test_the_api_reference_builds_without_a_warning(tmp_path):
    out = tmp_path / "api"
    r = subprocess.run([sys.executable, str(ROOT / "docs" / "build_api.py"), "-o", str(out), "--no-source"], capture_output=True, text=True)
    assert r.returncode == 0, r.stderr[-4000:]
    assert "error:" not in r.stderr
    # Every public module has its page, the lazily exported names included.
    for name in build_api.public_modules():
        page = out.joinpath(*name.split(".")).with_suffix(".html")
        assert page.is_file(), f"no page for {name}"
    top = (out / "mjmotion.html").read_text(encoding="utf-8")
    assert 'id="Motion"' in top and 'id="Skeleton"' in top
    # A cross-reference is a link (the Sphinx ``~`` is understood, not printed).
    nway = (out / "mjmotion" / "registration" / "nway.html").read_text(encoding="utf-8")
    assert '<a href="curves.html#Spline">' in nway and "~.curves" not in nway


@pytest.fixture
def fake_module(tmp_path, monkeypatch):
    """A small module with one good and two broken cross-references, as pdoc sees it."""
    import pdoc.doc

    (tmp_path / "docfake.py").write_text(
        '"""Uses :func:`helper`, :class:`Thing` and :mod:`json`; :func:`missing` and :attr:`Thing.nope` are broken."""\n'
        "class Thing:\n"
        '    """Has :attr:`size` (set in __init__) and :meth:`grow`; not :meth:`shrink`."""\n'
        "    def __init__(self):\n"
        "        self.size = 1\n"
        "    def grow(self):\n"
        '        """The :attr:`size` plus one, see :func:`~docfake.helper`."""\n'
        "def helper():\n"
        '    """Nothing, see :class:`docfake.Thing`."""\n',
        encoding="utf-8",
    )
    monkeypatch.syspath_prepend(str(tmp_path))
    return pdoc.doc.Module(importlib.import_module("docfake"))


def test_broken_cross_references_are_found_and_good_ones_pass(fake_module):
    broken = build_api.broken_references([fake_module])
    assert sorted(broken) == sorted(
        [
            "docfake: :attr:`Thing.nope` names nothing",
            "docfake: :func:`missing` names nothing",
            "docfake.Thing: :meth:`shrink` names nothing",
        ]
    )


# --- references: every file a help text or the README names is in the repository -------------
#: The repository's own top-level entries: a path starting with one of them must exist.
TRACKED = {p.name for p in ROOT.iterdir() if p.name not in (".git", ".venv", ".venv-ci", "results") and not p.name.endswith(".egg-info")}
#: Folders commands write into (git-ignored): named as outputs, not as files of the repository.
GENERATED = ("results/", "docs/api")
PATH = re.compile(r"(?<![\w./~$-])(?:\.\./)?(?:\.?[\w-]+/)+[\w.*-]*[\w*]")
DOC_FILE = re.compile(r"(?<![\w./-])[A-Z][A-Z_]+\.md\b")
LINK = re.compile(r"\]\(([^)\s]+)\)")


def _help_texts() -> dict[str, str]:
    """``{"mjmotion VERB --help": text}`` for the command and every verb (all options added)."""
    import argparse

    from mjmotion import cli

    parser = cli.build_parser()
    texts = {"mjmotion --help": parser.format_help()}
    sub = next(a for a in parser._actions if isinstance(a, argparse._SubParsersAction))
    for name, p in sub.choices.items():
        texts[f"mjmotion {name} --help"] = p.format_help()
    return texts


def file_references(text: str) -> list[str]:
    """Paths into the repository a text names: ``docs/METRICS.md``, ``mjmotion/caps.py``, ``METRICS.md``."""
    out = [m.group(0) for m in PATH.finditer(text) if m.group(0).split("/")[0] in TRACKED or m.group(0).startswith("../")]
    return out + DOC_FILE.findall(text)


def _missing(refs: list[str]) -> list[str]:
    bad = []
    for ref in refs:
        if ref.startswith(GENERATED) or "*" in ref:
            continue
        if "/" not in ref:  # a bare document name: at the top or in docs/
            if not ((ROOT / ref).is_file() or (ROOT / "docs" / ref).is_file()):
                bad.append(ref)
        elif not (ROOT / ref).exists():
            bad.append(ref)
    return bad


def test_the_reference_finder_sees_paths_and_documents():
    text = "see docs/METRICS.md and mjmotion/caps.py, METRICS.md, ../shared/docs/X.md; 3 m/s, A/B, walk.bvh"
    assert file_references(text) == ["docs/METRICS.md", "mjmotion/caps.py", "../shared/docs/X.md", "METRICS.md"]
    assert _missing(["docs/METRICS.md", "mjmotion/caps.py", "METRICS.md", "docs/NOPE.md", "NOPE.md"]) == ["docs/NOPE.md", "NOPE.md"]


HELP = _help_texts()


@pytest.mark.parametrize("name", sorted(HELP))
def test_help_names_only_files_in_the_repository(name):
    text = HELP[name]
    assert "shared/" not in text, f"{name} names a path outside the repository"
    refs = file_references(text)
    assert not [r for r in refs if r.startswith("../")], f"{name}: {refs}"
    assert not _missing(refs), f"{name} names files that are not in the repository: {_missing(refs)}"
    # A seed is named by its author, year and section (docs/algorithms.md lists them), not by its number.
    assert not re.search(r"\bseeds? \d{3}\b", text), f"{name}: {re.search(r'.{30}seeds? [0-9]{3}.{20}', text, re.S)}"


def test_the_readme_names_only_files_in_the_repository():
    text = (ROOT / "README.md").read_text(encoding="utf-8")
    # The one path outside: the shared mocap folder, MJMOTION_DATA's default (data, not a document).
    outside = sorted({r for r in file_references(text) if r.startswith("../")} - {"../shared/mocap"})
    assert not outside, f"the README names paths outside the repository: {outside}"
    assert not re.search(r"(?<!\.\./)shared/(?!mocap)", text)
    refs = [r for r in file_references(text) if not r.startswith("../")]
    links = [m.group(1).split("#")[0] for m in LINK.finditer(text) if not m.group(1).startswith(("http", "#"))]
    assert len(refs) > 20 and len(links) > 5  # (the finder works on this text)
    assert not _missing(refs + links), f"the README names files that are not in the repository: {_missing(refs + links)}"
