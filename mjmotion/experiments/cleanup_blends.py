"""Cleanup of every linear blend: issue 13's bar over the shared walks and runs, pair by pair.

Every pair of walks and runs of one skeleton flavour (walk/run, run/run, walk/walk; iClone 007_04
has another skeleton than 002_xx and is left out) is blended linearly (frame by frame, no timewarp)
at weights 0.5/0.5, 0.3/0.7 and 0.7/0.3, cleaned against its two inputs, and judged against them
before and after (their floor and feet, ``mjmotion evaluate --source``). A case passes when
cleanup cuts ``planted_skate_mm_per_s`` by at least 80 %, leaves ``penetrate_mm`` ≤ 2,
``worst_joint_speed_ratio`` ≤ 1.3 and adds no ``pop_frames``; a blend with no planted frame has no
skate to cut (``n/a``). Every walk is also cleaned against itself (cut at least half, the same
joint bars). The table gives, per flavour and kind, how many cases pass and why the others fail;
the notes list each failing case. The largest root shift is how far cleanup moved the body
towards feet it held (``max_root_shift_m``): a crouch the bar itself does not see.
"""

from __future__ import annotations

import itertools
import math
from dataclasses import dataclass
from pathlib import Path
from typing import TYPE_CHECKING, Any

import numpy as np

from . import Table

if TYPE_CHECKING:
    from ..executor import Executor

#: Walks and runs (or jogs) per flavour folder (SOURCES.md).
CLIPS = {
    "cmu_cgspeed_daz": (
        ("02_01", "07_01", "07_02", "08_01", "07_04", "07_05", "08_04", "08_05", "08_11", "05_01"),
        ("02_03", "09_01", "09_02", "09_06", "09_11"),
    ),
    "cmu_asfamc_converted": (("16_15", "16_16", "16_12", "16_24", "16_13", "16_26", "16_17", "16_18", "16_29"), ()),
    "cmu_iclone_ccrig": (("002_01",), ("002_03",)),
    "cmu_cgspeed_max": (("131_01", "131_02"), ("102_01",)),
}
#: The weight of the first clip of a pair (the second gets the rest).
WEIGHTS = (0.5, 0.3, 0.7)
#: The quick version: a few pairs, one weight.
QUICK = (("cmu_cgspeed_daz", "07_01", "09_01"), ("cmu_iclone_ccrig", "002_01", "002_03"), ("cmu_asfamc_converted", "16_15", "16_16"))

#: Issue 13's bar (a blend's cut; a clean walk cleaned against itself needs half).
MIN_CUT, MIN_SELF_CUT = 0.8, 0.5
MAX_PENETRATE_MM = 2.0
MAX_JOINT_RATIO = 1.3


@dataclass(frozen=True)
class Case:
    """One blend (``b`` set) or one walk cleaned against itself (``b`` None) of ``folder``."""

    folder: str
    kind: str
    a: str
    b: str | None = None
    weight: float = 1.0

    @property
    def label(self) -> str:
        if self.b is None:
            return f"{self.folder.replace('cmu_', '')} {self.a} itself"
        return f"{self.folder.replace('cmu_', '')} {self.a}+{self.b} {self.weight:g}/{1 - self.weight:g}"


def cases(data_dir: Path | None, quick: bool = False) -> list[Case]:
    """Every case whose clips are under ``data_dir`` (the bundled walk and run when it is None)."""
    if data_dir is None:
        # (the bundled walk's feet are planted by construction: it has no skate to cut against itself)
        return [Case("bundled", "walk/run", "walk", "run", w) for w in ((0.5,) if quick else WEIGHTS)]
    if quick:
        return [Case(f, "blend", a, b, 0.5) for f, a, b in QUICK if (data_dir / f / f"{a}.bvh").is_file() and (data_dir / f / f"{b}.bvh").is_file()]
    out = []
    for folder, (walks, runs) in CLIPS.items():
        w, r = ([n for n in names if (data_dir / folder / f"{n}.bvh").is_file()] for names in (walks, runs))
        pairs = [("walk/run", a, b) for a in w for b in r]
        pairs += [("run/run", a, b) for a, b in itertools.combinations(r, 2)]
        pairs += [("walk/walk", a, b) for a, b in itertools.combinations(w, 2)]
        out += [Case(folder, kind, a, b, wt) for kind, a, b in pairs for wt in WEIGHTS]
        out += [Case(folder, "self", a) for a in w]
    return out


def _clip(data_dir: str | None, folder: str, name: str) -> Any:
    from .. import bvh, synth
    from ..trim import leading_transient

    if data_dir is None:
        return (synth.walk(seconds=3.0) if name == "walk" else synth.run(seconds=3.0)).motion.replace(name=name)
    m = bvh.read(Path(data_dir) / folder / f"{name}.bvh")
    return m[leading_transient(m) :].replace(name=name)


def clean_case(case: Case, data_dir: str | None) -> dict[str, Any]:
    """Blend, clean and judge one case: ``before``/``after`` ``{metric: value}``, plants found, and its verdict."""
    from .. import blend, cleanup
    from .. import evaluate as ev

    a = _clip(data_dir, case.folder, case.a)
    if case.b is None:
        inputs, clip = [a], a
    else:
        b = _clip(data_dir, case.folder, case.b)
        inputs, clip = [a, b], blend.blend([a, b], [case.weight, 1.0 - case.weight], method="linear")
    sources = [m.replace() for m in inputs]  # (a clip cleaned against itself: a copy, not the clip)
    done = cleanup.cleanup(clip, sources=sources)
    keys = ("planted_skate_mm_per_s", "penetrate_mm", "worst_joint_speed_ratio", "pop_frames")
    before, after = ev.evaluate(clip, sources=sources), ev.evaluate(done.motion, sources=sources)
    judged = {k: _num(getattr(before, k)) for k in keys}, {k: _num(getattr(after, k)) for k in keys}
    return {
        "before": judged[0],
        "after": judged[1],
        "worst_joint": after.worst_joint,
        "plants": len(done.plants),
        "root_shift_m": done.max_root_shift_m,
        "fails": verdict(*judged, self_clean=case.b is None),
    }


def _num(v: Any) -> float:
    return float("nan") if v is None else float(v)


def cut(before: dict[str, float], after: dict[str, float]) -> float:
    """The share of planted skate cleanup removed (1: all, a result left with no contact frame), NaN
    when there was none to cut (no planted frame before)."""
    skate0, skate1 = before["planted_skate_mm_per_s"], after["planted_skate_mm_per_s"]
    if not math.isfinite(skate0) or skate0 <= 0:
        return math.nan
    return 1.0 - (skate1 if math.isfinite(skate1) else 0.0) / skate0


def verdict(before: dict[str, float], after: dict[str, float], self_clean: bool = False) -> list[str] | None:
    """Why a case misses the bar (``[]``: it passes; None: no planted frame before, nothing to cut)."""
    share = cut(before, after)
    if math.isnan(share):
        return None
    fails = []
    if share < (MIN_SELF_CUT if self_clean else MIN_CUT):
        fails.append("skate")
    if after["penetrate_mm"] > MAX_PENETRATE_MM:
        fails.append("penetrate")
    if after["worst_joint_speed_ratio"] > MAX_JOINT_RATIO:
        fails.append("joint speed")
    if after["pop_frames"] > before["pop_frames"]:
        fails.append("pops")
    return fails


def _clean(args: tuple[Case, str | None]) -> dict[str, Any] | str:
    case, data = args
    try:
        return clean_case(case, data)
    except Exception as e:  # a case that fails is reported, not fatal
        return f"{type(e).__name__}: {e}"


def run(out_dir: Path, data_dir: Path | None = None, quick: bool = False, jobs: int = 2, executor: Executor | None = None) -> Table:
    """Every case of :func:`cases`, on ``executor`` (Dask) if given, else in ``jobs`` processes; writes ``out_dir/table.md``."""
    from ..executor import in_order, using

    todo = cases(data_dir, quick)
    args = [(c, None if data_dir is None else str(data_dir)) for c in todo]
    with using(executor, jobs if len(args) > 1 else 1) as ex:
        outs = in_order(
            ex.run(_clean, [(i, (a,)) for i, a in enumerate(args)], desc="cleanup", unit="case", progress=not quick), list(range(len(args)))
        )
        results = [o.unwrap() for o in outs]
    table = Table(
        "Cleanup of linear blends against their inputs (issue 13's bar)",
        (
            "flavour",
            "kind",
            "cases",
            "pass",
            "n/a",
            "skate cut < 80 %",
            "penetrate > 2 mm",
            "joint > 1.3x",
            "new pops",
            "median cut %",
            "largest joint ratio",
            "largest root shift (m)",
        ),
        notes=[
            "each blend (weights 0.5/0.5, 0.3/0.7, 0.7/0.3) cleaned and judged against its two inputs; each walk cleaned against itself "
            "(kind self: cut ≥ 50 %); n/a: no planted frame in the blend, nothing to cut",
        ],
    )
    groups: dict[tuple[str, str], list[tuple[Case, dict[str, Any] | str]]] = {}
    for c, r in zip(todo, results):
        groups.setdefault((c.folder.replace("cmu_", ""), c.kind), []).append((c, r))
    failing = []
    passed = judged_all = 0
    for (folder, kind), members in groups.items():
        done = [(c, r) for c, r in members if isinstance(r, dict)]
        judged = [(c, r) for c, r in done if r["fails"] is not None]
        cuts = [100 * cut(r["before"], r["after"]) for _, r in judged]
        ratios = [r["after"]["worst_joint_speed_ratio"] for _, r in done]
        shifts = [r["root_shift_m"] for _, r in done]
        n_pass = sum(not r["fails"] for _, r in judged)
        passed, judged_all = passed + n_pass, judged_all + len(judged)
        table.add(
            folder, kind, len(members), n_pass, len(done) - len(judged),
            *(sum(why in r["fails"] for _, r in judged) for why in ("skate", "penetrate", "joint speed", "pops")),
            float(np.median(cuts)) if cuts else float("nan"), max(ratios) if ratios else float("nan"),
            max(shifts) if shifts else float("nan"),
        )  # fmt: skip
        for c, r in members:
            if not isinstance(r, dict):
                failing.append(f"{c.label}: {r}")
            elif r["fails"]:
                b, a = r["before"], r["after"]
                failing.append(
                    f"{c.label} ({', '.join(r['fails'])}): skate {b['planted_skate_mm_per_s']:.0f} → {a['planted_skate_mm_per_s']:.0f} mm/s, "
                    f"worst joint {a['worst_joint_speed_ratio']:.2f} ({r['worst_joint']}), pops {b['pop_frames']:.0f} → {a['pop_frames']:.0f}"
                )
    table.notes.append(f"{passed} of {judged_all} judged cases pass ({len(todo)} cases)")
    table.notes += [f"fails: {f}" for f in failing]
    table.write(Path(out_dir))
    return table
