"""Corruption benchmark: does each metric tell corrupted motion from clean?

Clean captured clips of every skeleton flavour (walks, and a run or jog where the flavour has one)
are corrupted in known ways (:data:`CORRUPTIONS`): lifted 5 cm, sunk 5 cm, dragged at 0.3 m/s
along the walking direction, played twice as fast, one frame with a knee bent 60° more, and a
linear (frame-by-frame) blend with another clip of the same skeleton. Every corrupted clip is
judged against its clean clip(s) as ``sources``; every clean clip against itself, so both sides
are judged the same way. Per corruption and metric the table gives the ROC AUC of "corrupted
scores higher than clean" over all (clean, corrupted) pairs: 1 separates perfectly, 0.5 is chance.
The notes give, per corruption, its change in the metric it should move (``docs/METRICS.md``).
"""

from __future__ import annotations

from collections.abc import Callable
from pathlib import Path
from typing import TYPE_CHECKING

import numpy as np

from .. import evaluate as ev
from .. import rotations as rot
from ..skeleton import Motion
from ..trim import leading_transient
from . import Table

if TYPE_CHECKING:
    from ..executor import Executor

#: Clean clips per flavour, each with a partner of the same skeleton for the linear blend.
CLEAN = (
    ("cmu_asfamc_converted/16_15.bvh", "cmu_asfamc_converted/16_24.bvh"),
    ("cmu_asfamc_converted/16_16.bvh", "cmu_asfamc_converted/16_26.bvh"),
    ("cmu_asfamc_converted/16_12.bvh", "cmu_asfamc_converted/16_24.bvh"),
    ("cmu_cgspeed_daz/07_01.bvh", "cmu_cgspeed_daz/09_01.bvh"),
    ("cmu_cgspeed_daz/08_04.bvh", "cmu_cgspeed_daz/09_11.bvh"),
    ("cmu_cgspeed_daz/02_01.bvh", "cmu_cgspeed_daz/02_03.bvh"),
    ("cmu_cgspeed_daz/09_01.bvh", "cmu_cgspeed_daz/07_01.bvh"),
    ("cmu_iclone_ccrig/007_04.bvh", "cmu_iclone_ccrig/002_05.bvh"),
    ("cmu_iclone_ccrig/002_01.bvh", "cmu_iclone_ccrig/002_03.bvh"),
    ("cmu_cgspeed_max/131_02.bvh", "cmu_cgspeed_max/131_01.bvh"),
    ("cmu_cgspeed_max/102_01.bvh", "cmu_cgspeed_max/131_02.bvh"),
)
#: The quick version: one walk per flavour.
QUICK = (0, 3, 7, 9)

LIFT_M = 0.05
DRAG_M_S = 0.3
SPEED_UP = 2
POP_DEG = 60.0


def lifted(m: Motion, dz: float = LIFT_M) -> Motion:
    """The clip moved up by ``dz`` metres (down for a negative ``dz``)."""
    return m.replace(root_positions=m.root_positions + [0.0, 0.0, dz], name=f"{m.name} lifted {dz:+.2f} m")


def sunk(m: Motion, dz: float = LIFT_M) -> Motion:
    return lifted(m, -dz).replace(name=f"{m.name} sunk {dz:.2f} m")


def walking_direction(m: Motion) -> np.ndarray:
    """``(3,)`` unit horizontal direction from the first to the last root position (+x if it stays put)."""
    d = m.root_positions[-1, :2] - m.root_positions[0, :2]
    n = float(np.linalg.norm(d))
    return np.array([*(d / n), 0.0]) if n > 1e-6 else np.array([1.0, 0.0, 0.0])


def dragged(m: Motion, speed: float = DRAG_M_S) -> Motion:
    """The whole clip slid along its walking direction at ``speed`` m/s (every plant skates)."""
    return m.replace(root_positions=m.root_positions + np.outer(m.times * speed, walking_direction(m)), name=f"{m.name} dragged {speed} m/s")


def sped_up(m: Motion, factor: int = SPEED_UP) -> Motion:
    """Every ``factor``-th frame at the same frame rate: the clip played ``factor`` times as fast."""
    return m[::factor].replace(fps=m.fps, name=f"{m.name} x{factor}")


def knee_axis(m: Motion, knee: int) -> np.ndarray:
    """``(3,)`` the knee's bend axis in its local frame: the mean direction of its rotation vectors
    (flexion dominates a knee's rotation)."""
    v = rot.log(m.rotations[:, knee])
    axis = v.sum(axis=0)
    return axis / max(float(np.linalg.norm(axis)), 1e-12)


def knee_popped(m: Motion, degrees: float = POP_DEG, frame: int | None = None) -> Motion:
    """One frame (default: the middle) with the first knee bent ``degrees`` more about its own axis."""
    from ..limits import joint_classes

    knee = joint_classes(m.skeleton).index("knee")
    t = m.n_frames // 2 if frame is None else frame
    q = m.rotations.copy()
    q[t, knee] = rot.multiply(q[t, knee], rot.exp(knee_axis(m, knee) * np.radians(degrees)))
    return m.replace(rotations=q, name=f"{m.name} knee +{degrees:g}° at {t}")


def blended(m: Motion, partner: Motion) -> Motion:
    """The linear (frame-by-frame, unaligned) 50/50 blend of the clip with ``partner``."""
    from .. import blend

    return blend.blend([m, partner], [0.5, 0.5], method="linear", name=f"{m.name}+{partner.name} linear")


#: name → (corrupt(clean, partner), the metric it should move, the change the issue asks for or None).
CORRUPTIONS: dict[str, tuple[Callable[[Motion, Motion], Motion], str, float | None]] = {
    "lifted 5 cm": (lambda m, _p: lifted(m), "float_mm", 40.0),
    "sunk 5 cm": (lambda m, _p: sunk(m), "penetrate_mm", 35.0),
    "dragged 0.3 m/s": (lambda m, _p: dragged(m), "planted_skate_mm_per_s", 150.0),
    "played 2x fast": (lambda m, _p: sped_up(m), "physics_violation_ratio", 0.25),
    "knee +60° one frame": (lambda m, _p: knee_popped(m), "worst_joint_speed_ratio", 2.0),
    "linear blend": (lambda m, p: blended(m, p), "planted_skate_mm_per_s", None),
}

#: The metrics the table scores (higher = worse for each).
METRICS = (
    "planted_skate_mm_per_s", "skate_mm_per_s", "skating_ratio", "float_mm", "penetrate_mm", "flight_fraction",
    "physics_violation_ratio", "pop_frames", "worst_joint_speed_ratio", "max_joint_speed_ratio", "limit_violation_ratio",
)  # fmt: skip


def roc_auc(negatives: list[float], positives: list[float]) -> float:
    """P(positive > negative) + ½ P(tie) over all pairs (the Mann–Whitney form of ROC AUC); NaN values rank lowest."""
    neg = np.nan_to_num(np.asarray(negatives, dtype=float), nan=-np.inf)
    pos = np.nan_to_num(np.asarray(positives, dtype=float), nan=-np.inf)
    if len(neg) == 0 or len(pos) == 0:
        return float("nan")
    d = pos[:, None] - neg[None, :]
    return float(np.mean(d > 0) + 0.5 * np.mean(d == 0))


def _clip(path: Path) -> Motion:
    from .. import bvh

    m = bvh.read(path)
    m = m[leading_transient(m) :]
    # SOURCES.md: iClone 007_04's frame 0 is a rest pose elsewhere (a one-frame pop, not a T-pose run).
    return (m[1:] if path.stem == "007_04" else m).replace(name=path.stem)


def judge_clip(pair: tuple[str, str], data_dir: str | None) -> dict[str, dict[str, float]]:
    """Scores of one clean clip and its corruptions: ``{"clean" | corruption: {metric: value}}``
    (the bundled walk and run stand in when ``data_dir`` is None)."""
    if data_dir is None:
        from .. import synth

        clips = {"walk": synth.walk(seconds=3.0).motion, "run": synth.run(seconds=3.0).motion}
        clean, partner = clips[pair[0]].replace(name=pair[0]), clips[pair[1]].replace(name=pair[1])
    else:
        clean, partner = (_clip(Path(data_dir) / p) for p in pair)

    def scores(r: ev.Report) -> dict[str, float]:
        return {k: float("nan") if getattr(r, k) is None else float(getattr(r, k)) for k in METRICS}

    out = {"clean": scores(ev.evaluate(clean, sources=[clean.replace()]))}
    for name, (corrupt, _, _) in CORRUPTIONS.items():
        bad = corrupt(clean, partner)
        sources = [clean, partner] if name == "linear blend" else [clean]
        out[name] = scores(ev.evaluate(bad, sources=sources))
    return out


def _judge(args: tuple[tuple[str, str], str | None]) -> tuple[str, dict[str, dict[str, float]] | str]:
    pair, data = args
    try:
        return pair[0], judge_clip(pair, data)
    except Exception as e:  # a clip that fails is reported, not fatal
        return pair[0], f"{type(e).__name__}: {e}"


def run(out_dir: Path, data_dir: Path | None = None, quick: bool = False, jobs: int = 2, executor: Executor | None = None) -> Table:
    """Corrupt, judge and score; writes ``out_dir/table.md``. Clips run on ``executor`` (Dask,
    :mod:`mjmotion.executor`) if given, else in ``jobs`` processes."""
    from ..executor import in_order, using

    if data_dir is None:
        pairs: list[tuple[str, str]] = [("walk", "run"), ("run", "walk")]
        label = "the bundled walk and run (mjmotion.synth)"
    else:
        chosen = [CLEAN[i] for i in QUICK] if quick else list(CLEAN)
        pairs = [p for p in chosen if (data_dir / p[0]).is_file() and (data_dir / p[1]).is_file()]
        label = "clean CMU clips: " + ", ".join(p[0].split("/")[0].replace("cmu_", "") + " " + Path(p[0]).stem for p in pairs)
    args = [(p, None if data_dir is None else str(data_dir)) for p in pairs]
    with using(executor, jobs if len(args) > 1 else 1) as ex:
        results = [
            out.unwrap()
            for out in in_order(
                ex.run(_judge, [(a[0][0], (a,)) for a in args], desc="corruption", unit="clip", progress=not quick), [a[0][0] for a in args]
            )
        ]
    good = {k: v for k, v in results if isinstance(v, dict)}
    table = Table(
        "Corruption benchmark: ROC AUC of corrupted vs clean, per metric",
        ("corruption", *METRICS),
        notes=[
            f"{label}; each corruption judged against its clean clip(s) as --source, each clean clip against itself",
            "AUC = P(corrupted scores higher than clean) over all (clean, corrupted) pairs; 1 = perfect, 0.5 = chance",
        ],
    )
    for key, msg in results:
        if not isinstance(msg, dict):
            table.notes.append(f"{key}: {msg}")
    clean = [v["clean"] for v in good.values()]
    for name, (_, target, want) in CORRUPTIONS.items():
        bad = [v[name] for v in good.values()]
        table.add(name, *(roc_auc([c[m] for c in clean], [b[m] for b in bad]) for m in METRICS))
        deltas = [v[name][target] - v["clean"][target] for v in good.values()]
        if target == "worst_joint_speed_ratio":
            deltas = [v[name][target] for v in good.values()]
        per = ", ".join(f"{k} {d:+.3g}" for k, d in zip(good, deltas))
        what = f"{target}{' (value)' if target == 'worst_joint_speed_ratio' else ' change'}"
        goal = f"; asked ≥ {'+' if target != 'worst_joint_speed_ratio' else ''}{want:g}" if want is not None else ""
        table.notes.append(f"{name}: {what} min {np.nanmin(deltas):+.3g}, median {np.nanmedian(deltas):+.3g}{goal} ({per})")
    table.write(Path(out_dir))
    return table
