"""Physics audit: every shared clip and every synthesized result through the evaluation report.

Captured clips (with ``data_dir``) are evaluated in parallel processes; the synthesized
results are the bundled procedural clips and what the lab makes from them: a linear and a
registered blend of the bundled walk and run, and the footskate cleanup of the linear blend.
The notes add what cleanup does to linear walk/run blends of the shared skeletons and to a clean
walk (:func:`cleanup_of_blends`), with foot height and speed drawn before and after.
Metric definitions: ``shared/docs/METRICS.md`` (thresholds in the table's notes).
"""

from __future__ import annotations

import functools
from pathlib import Path
from typing import TYPE_CHECKING

import numpy as np

from .. import evaluate as ev
from ..cleanup import CleanupResult
from ..skeleton import Motion
from . import Table

if TYPE_CHECKING:
    from ..executor import Executor

COLUMNS = (
    "source", "clip", "frames", "fps", "skate mm/s", "planted skate mm/s", "skating ratio", "flight frac",
    "penetrate mm", "float mm", "phys_err mm", "floor m", "flight residual", "phys violation", "limit violation",
)  # fmt: skip


def _row(source: str, name: str, r: dict) -> tuple:
    return (
        source, name, r["n_frames"], round(r["fps"], 1), r["skate_mm_per_s"], r["planted_skate_mm_per_s"],
        r["skating_ratio"], r["flight_fraction"], r["penetrate_mm"], r["float_mm"], r["phys_err_mm"],
        r["floor_offset_m"], r["flight_residual"], r["physics_violation_ratio"], r["limit_violation_ratio"],
    )  # fmt: skip


def synthesized(quick: bool = False) -> dict[str, tuple[object, tuple]]:
    """Bundled clips and results made from them: ``{name: (motion, props)}``."""
    from .. import blend, synth

    clips = synth.library()
    if quick:
        clips = {k: v for k, v in clips.items() if k in ("walk", "run", "drive", "kick")}
    out: dict[str, tuple[object, tuple]] = {name: (c.motion, (c.prop,) if c.prop is not None else ()) for name, c in clips.items()}
    (walk, run), lin, cleaned = _bundled_linear_blend()
    reg = blend.blend([walk, run], [0.5, 0.5], method="registered", name="registered_blend")
    out["linear blend walk/run .5"] = (lin, ())
    out["registered blend walk/run .5"] = (reg, ())
    out["cleanup of the linear blend"] = (cleaned.motion, ())
    return out


@functools.lru_cache(maxsize=1)
def _bundled_linear_blend() -> tuple[tuple[Motion, Motion], Motion, CleanupResult]:
    """The bundled walk and run (3 s each), their linear .5 blend and its cleanup: built once for
    the synthesized rows and the cleanup notes."""
    from .. import blend, cleanup, synth

    clips = (synth.walk(seconds=3.0).motion, synth.run(seconds=3.0).motion)
    lin = blend.blend(list(clips), [0.5, 0.5], method="linear", name="linear_blend")
    return clips, lin, cleanup.cleanup(lin)


#: Walk and run of one skeleton each, blended linearly (frame by frame, no timewarp) for the cleanup check.
BLEND_PAIRS = (
    ("cmu_cgspeed_daz/07_01.bvh", "cmu_cgspeed_daz/09_01.bvh"),
    ("cmu_iclone_ccrig/002_01.bvh", "cmu_iclone_ccrig/002_03.bvh"),
    ("cmu_cgspeed_daz/08_01.bvh", "cmu_cgspeed_daz/09_11.bvh"),  # last: the one drawn
)

#: A clean captured walk, to show what cleanup does where there is little to fix.
CLEAN_WALKS = ("cmu_asfamc_converted/16_15.bvh",)


def cleanup_of_blends(data_dir: Path | None, out_dir: Path | None = None) -> tuple[list[str], list[str]]:
    """What cleanup does, one line each: to every :data:`CLEAN_WALKS` clip, and to the linear
    blend of the bundled walk and run and of every :data:`BLEND_PAIRS` pair found under
    ``data_dir`` (issue 7's bar: ≥ 80 % less ``skate_mm_per_s``, no penetration added beyond
    2 mm, ``max_joint_speed_ratio`` ≤ 1.5). With ``out_dir``, foot height and speed before and
    after cleanup of the last pair are drawn there. Returns the lines and the figure files."""
    from .. import blend, bvh, cleanup, kinematics, mjcf

    pairs = [("bundled walk+run", *_bundled_linear_blend())]
    for a, b in BLEND_PAIRS if data_dir is not None else ():
        if (data_dir / a).is_file() and (data_dir / b).is_file():
            clips = [bvh.read(data_dir / x) for x in (a, b)]
            clips = [m[ev.leading_transient(m) :] for m in clips]
            lin = blend.blend(clips, [0.5, 0.5], method="linear")
            pairs.append((f"{a.split('/')[0]} {Path(a).stem}+{Path(b).stem}", clips, lin, cleanup.cleanup(lin)))
    lines = []
    for rel in CLEAN_WALKS if data_dir is not None else ():
        if (data_dir / rel).is_file():
            m = bvh.read(data_dir / rel)
            done = cleanup.cleanup(m).motion
            lines.append(
                f"cleanup of the clean walk {rel}: skate_mm_per_s {ev.skate_mm_per_s(m):.0f} → {ev.skate_mm_per_s(done):.0f}, "
                f"planted skate {ev.planted_skate_mm_per_s(m):.0f} → {ev.planted_skate_mm_per_s(done):.1f}, "
                f"max_joint_speed_ratio {ev.max_joint_speed_ratio(done, m):.2f}"
            )
    for label, clips, lin, res in pairs:
        c = mjcf.compile(lin.skeleton)
        low0 = ev.lowest_body_point(c, kinematics.forward(c, lin))
        low1 = ev.lowest_body_point(c, kinematics.forward(c, res.motion))
        sk0, sk1 = ev.skate_mm_per_s(lin), ev.skate_mm_per_s(res.motion)
        pl0, pl1 = ev.planted_skate_mm_per_s(lin), ev.planted_skate_mm_per_s(res.motion)
        added = max(0.0, float((np.minimum(low0, 0.0) - low1).max())) * 1000
        info = res.to_dict()
        lines.append(
            f"cleanup of the linear blend of {label}: skate_mm_per_s {sk0:.0f} → {sk1:.0f} "
            f"({100 * (1 - sk1 / sk0):.0f} % less), planted skate {pl0:.0f} → {pl1:.2f}, max_joint_speed_ratio "
            f"{ev.max_joint_speed_ratio(res.motion, clips):.2f}, penetration added {added:.1f} mm, "
            f"{info['lifted_frames']}/{lin.n_frames} frames with a foot lifted (≤ {100 * info['max_lift_m']:.1f} cm)"
        )
    files = []
    if out_dir is not None:
        from .. import plots

        label, _, lin, res = pairs[-1]
        out_dir.mkdir(parents=True, exist_ok=True)
        for tag, m in (("before", lin), ("after", res.motion)):
            tr = ev.foot_heights_speeds(None, m)
            f = plots.foot_contacts(
                np.arange(m.n_frames) / m.fps, tr.heights, tr.speeds, ev.contacts(tr), out_dir / f"cleanup_{tag}.png",
                title=f"linear blend {label}, {tag} cleanup: skate_mm_per_s {ev.skate_mm_per_s(tr):.0f}",
            )  # fmt: skip
            files.append(str(f))
    return lines, files


def run(out_dir: Path, data_dir: Path | None = None, quick: bool = False, jobs: int = 2, executor: Executor | None = None) -> Table:
    """Evaluate everything and write ``out_dir/table.md``; captured clips run on ``executor`` (Dask,
    :mod:`mjmotion.executor`) if given, else in ``jobs`` processes."""
    params = ev.Params()
    table = Table(
        "Physics audit: captured and synthesized motion",
        COLUMNS,
        notes=[
            (
                f"thresholds: h_c = {params.h_c} m, v_c = {params.v_c} m/s, float tolerance {params.float_tol * 1000:.0f} mm, "
                f"friction μ = {params.mu}, CoP margin {params.cop_margin} m, finite-difference step {params.fd_step:.3f} s"
            ),
            (
                "skate mm/s: METRICS.md's definition (contact by height alone, which also counts low swing feet); "
                "planted skate: the same speed over frames in contact by height and speed (v_c)"
            ),
            "captured clips: a leading T-pose or transition (cgspeed's frames 0–3) is skipped",
        ],
    )
    if data_dir is not None:
        from ..commands.evaluate import evaluate_file
        from ..executor import in_order, using

        files = sorted(str(p) for p in Path(data_dir).rglob("*.bvh"))
        if quick:
            files = files[:: max(1, len(files) // 6)]
        opts = {
            "units": "auto", "up": "y", "frames": None, "keep_start": False, "prop": [], "ball": None, "frame": None,
            "ball_radius": 0.036, "ball_velocity": (0.0, 0.0, 0.0), "h_c": params.h_c, "v_c": params.v_c,
        }  # fmt: skip
        with using(executor, jobs) as ex:
            outcomes = in_order(ex.run(evaluate_file, [(f, (f, opts)) for f in files], desc="evaluate", unit="clip"), files)
        for out in outcomes:
            label = f"{Path(out.key).parent.name}/{Path(out.key).stem}"
            if out.kind == "input":
                table.notes.append(f"{label}: {out.error}")
                continue
            table.add(*_row("captured", label, out.unwrap()["report"]))
    for name, (motion, props) in synthesized(quick).items():
        rep = ev.evaluate(motion, props, params=params)  # type: ignore[arg-type]
        table.add(*_row("synthesized", name, rep.to_dict()))
    lines, files = cleanup_of_blends(None if data_dir is None or quick else Path(data_dir), out_dir)
    table.notes.extend(lines)
    table.files.extend(files)
    table.write(out_dir)
    return table
