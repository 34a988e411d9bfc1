"""The documentation a fresh clone carries: the API reference builds clean (docs/build_api.py)."""

from __future__ import annotations

import importlib
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
