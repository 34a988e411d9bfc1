"""Physics audit: every shared clip and every synthesized result through the evaluation report.

Captured clips (with ``data_dir``) are evaluated in parallel processes; the synthesized
results are the bundled procedural clips and what the lab makes from them: a linear and a
registered blend of the bundled walk and run, and the footskate cleanup of the linear blend.
Metric definitions: ``shared/docs/METRICS.md`` (thresholds in the table's notes).
"""

from __future__ import annotations

from pathlib import Path

import numpy as np

from .. import evaluate as ev
from . import Table

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
    from .. import blend, cleanup, synth

    clips = synth.library()
    if quick:
        clips = {k: v for k, v in clips.items() if k in ("walk", "run", "drive", "kick")}
    out: dict[str, tuple[object, tuple]] = {
        name: (c.motion, (c.prop,) if c.prop is not None else ()) for name, c in clips.items()
    }
    walk, run = synth.walk(seconds=3.0).motion, synth.run(seconds=3.0).motion
    lin = blend.blend([walk, run], [0.5, 0.5], method="linear", name="linear_blend")
    reg = blend.blend([walk, run], [0.5, 0.5], method="registered", name="registered_blend")
    out["linear blend walk/run .5"] = (lin, ())
    out["registered blend walk/run .5"] = (reg, ())
    out["cleanup of the linear blend"] = (cleanup.cleanup(lin).motion, ())
    return out


def run(out_dir: Path, data_dir: Path | None = None, quick: bool = False, jobs: int = 2) -> Table:
    """Evaluate everything and write ``out_dir/table.md``."""
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
        from ..commands.evaluate import evaluate_files

        files = sorted(str(p) for p in Path(data_dir).rglob("*.bvh"))
        if quick:
            files = files[:: max(1, len(files) // 6)]
        opts = {
            "units": "auto", "up": "y", "frames": None, "keep_start": False, "prop": [], "ball": None, "frame": None,
            "ball_radius": 0.036, "ball_velocity": (0.0, 0.0, 0.0), "h_c": params.h_c, "v_c": params.v_c,
        }  # fmt: skip
        for r in evaluate_files(files, opts, jobs):
            label = f"{Path(r['file']).parent.name}/{Path(r['file']).stem}"
            if "error" in r:
                table.notes.append(f"{label}: {r['error']}")
                continue
            table.add(*_row("captured", label, r["report"]))
    for name, (motion, props) in synthesized(quick).items():
        rep = ev.evaluate(motion, props, params=params)  # type: ignore[arg-type]
        table.add(*_row("synthesized", name, rep.to_dict()))
    for col, what in ((4, "skate_mm_per_s"), (5, "planted skate")):
        skate = {row[1]: row[col] for row in table.rows}
        lin, cle = skate.get("linear blend walk/run .5"), skate.get("cleanup of the linear blend")
        if lin and cle is not None and np.isfinite(lin) and np.isfinite(cle) and lin > 0:
            table.notes.append(f"cleanup cut the linear blend's {what} from {lin:.0f} to {cle:.0f} mm/s ({100 * (1 - cle / lin):.0f} %)")
    table.write(out_dir)
    return table
