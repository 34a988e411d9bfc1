"""Linear vs registered blending of walks and runs, and discrete vs B-spline timewarps (seed 004 §5–7).

Two tables (both in ``table.md``):

1. *Blends* — a walk and a run blended frame by frame (seed 004 §6.2.2, the baseline) and along
   their registration curve (seed 000 §3.2) at run weights 0, .25, .5, .75, 1: footskate
   (``skate_mm_per_s`` at contact heights ``h_c`` = 3, 5, 8 cm, and ``planted_skate_mm_per_s``),
   contact rhythm (steps per second) and mean root speed.
2. *Timewarp* (seed 004 Table 5) — Sako's discrete insertion/deletion timewarp against the
   B-spline: how well each recovers a known warp made with :func:`mjmotion.transform.timewarp`
   (plus a floor move), how long it takes, and how smooth a blend along it is.
3. *Blendability* (seed 004 §7.2, Fig. 10) — the score of
   :mod:`mjmotion.registration.blendability` for walks and runs and for a walk with a shot (a
   baseball pitch, golf swings, a kick, a jump): the calibration of its threshold
   (``blendability.md``).
"""

from __future__ import annotations

from dataclasses import dataclass
from pathlib import Path

import numpy as np

from .. import blend as bl
from .. import bvh, mjcf, plots, transform
from .. import evaluate as ev
from .. import registration as reg
from ..errors import MjmotionError
from ..registration.blendability import THRESHOLD
from ..skeleton import Motion
from ..trim import skip_leading_transient
from . import Table
from .path_search import daz_clip, timed

RUN_WEIGHTS = (0.0, 0.25, 0.5, 0.75, 1.0)
#: The known warp: source frame of warped frame ``i`` is ``(n−1)·(a + b·u + c·sin 2πu)``, ``u = i/(m−1)``;
#: it keeps both ends, so the pair registers corner to corner (a periodic bundled walk matches
#: itself a whole cycle later, so a free end would be free to slip by a cycle).
WARP = (0.0, 1.0, 0.05)
#: ... and the floor move applied after it (radians, metres).
WARP_MOVE = (0.7, (1.2, -0.6))

BLEND_COLUMNS = (
    "pair", "run weight", "method", "frames", "speed m/s", "steps/s",
    "skate@0.03 mm/s", "skate@0.05 mm/s", "skate@0.08 mm/s", "planted skate mm/s",
)  # fmt: skip
BLENDABILITY_COLUMNS = (
    "pair",
    "kind",
    "alike (Sako §7.2)",
    "frames",
    "mean path cost m²",
    "self-similarity A m²",
    "self-similarity B m²",
    "score",
    "blendable",
)
#: Pairs of the blendability table: (kind, clip A, clip B, alike), shared clips by folder/name or bundled
#: clips by name.
#: Sako's "logical similarity" (seed 004 §7.2): walks and runs, or shots of one kind, are alike; a walk
#: and a pitch, a golf swing or a standing kick are not; 10_01 (an approach walk, then a kick) and a
#: jump in place are mixed.
BLENDABILITY_PAIRS_REAL = (
    ("walk / run", "cmu_cgspeed_daz/07_01", "cmu_cgspeed_daz/09_01", "yes"),
    ("walk / run", "cmu_cgspeed_daz/08_01", "cmu_cgspeed_daz/09_11", "yes"),
    ("walk / run", "cmu_cgspeed_daz/02_01", "cmu_cgspeed_daz/02_03", "yes"),
    ("walk / walk", "cmu_cgspeed_daz/07_01", "cmu_cgspeed_daz/08_01", "yes"),
    ("walk / slow walk", "cmu_cgspeed_daz/07_01", "cmu_cgspeed_daz/07_04", "yes"),
    ("run / run", "cmu_cgspeed_daz/09_01", "cmu_cgspeed_daz/09_11", "yes"),
    ("walk / fast walk", "cmu_asfamc_converted/16_15", "cmu_asfamc_converted/16_24", "yes"),
    ("walk / fast walk", "cmu_asfamc_converted/16_16", "cmu_asfamc_converted/16_26", "yes"),
    ("walk / turning walk", "cmu_asfamc_converted/16_15", "cmu_asfamc_converted/16_17", "yes"),
    ("walk / veering walk", "cmu_asfamc_converted/16_15", "cmu_asfamc_converted/16_12", "yes"),
    ("golf / golf", "cmu_asfamc_converted/64_01", "cmu_asfamc_converted/64_02", "yes"),
    ("walk / kick", "cmu_asfamc_converted/16_15", "cmu_asfamc_converted/10_01", "mixed"),
    ("walk / jump", "cmu_asfamc_converted/16_15", "cmu_asfamc_converted/16_01", "mixed"),
    ("walk / pitch", "cmu_asfamc_converted/16_15", "cmu_asfamc_converted/124_01", "no"),
    ("walk / golf", "cmu_asfamc_converted/16_15", "cmu_asfamc_converted/64_01", "no"),
    ("walk / golf", "cmu_asfamc_converted/16_24", "cmu_asfamc_converted/64_03", "no"),
    ("golf / pitch", "cmu_asfamc_converted/64_01", "cmu_asfamc_converted/124_01", "no"),
)
BLENDABILITY_PAIRS_BUNDLED = (
    ("walk / run", "walk", "run", "yes"),
    ("walk / fast walk", "walk", "walk_fast", "yes"),
    ("walk / sneak", "walk", "sneak", "yes"),
    ("walk / limp", "walk", "limp", "yes"),
    ("walk / kick", "walk", "kick", "no"),
    ("walk / punch", "walk", "punch", "no"),
    ("walk / drive", "walk", "drive", "no"),
)

WARP_COLUMNS = (
    "pair", "timewarp", "samples", "recovery RMS frames", "recovery max frames", "alignment max °", "alignment max mm",
    "curve ms", "time performance %", "clock jerk frames/frame²", "RMS ang. accel rad/s²", "sources' RMS rad/s²", "max joint speed ratio",
    "planted skate mm/s",
)  # fmt: skip


@dataclass(frozen=True)
class Pair:
    """A walk and a run (``a`` is the registration's reference)."""

    label: str
    a: Motion
    b: Motion


# --------------------------------------------------------------------------------------------
# clips
# --------------------------------------------------------------------------------------------
def pairs_of(data_dir: Path | None, quick: bool) -> list[Pair]:
    """Walk/run pairs: daz 07_01/09_01 and 08_01/09_11, or the bundled walk and run."""
    if data_dir is None:
        from .. import synth

        pairs = [Pair("walk / run", synth.walk().motion, synth.run().motion)]
        if not quick:
            pairs.append(Pair("walk_fast / run", synth.walk(speed=1.7, name="walk_fast").motion, synth.run().motion))
        return pairs
    names = [("07_01", "09_01")] + ([] if quick else [("08_01", "09_11")])
    return [Pair(f"{a} / {b}", daz_clip(data_dir, a), daz_clip(data_dir, b)) for a, b in names]


# --------------------------------------------------------------------------------------------
# measures
# --------------------------------------------------------------------------------------------
def mean_speed(motion: Motion) -> float:
    """Horizontal root path length over duration, m/s."""
    return float(np.linalg.norm(np.diff(motion.root_positions[:, :2], axis=0), axis=1).sum() / motion.duration)


def steps_per_s(track: ev.FootTrack, hysteresis: float = 0.02) -> float:
    """Contact rhythm: how often the stance passes from one foot to the other, steps per second.

    The stance foot is the lower one; it changes side when the other foot is ``hysteresis`` m
    lower (so a shuffle within 2 cm is no step). Counted between the first and the last change;
    NaN with fewer than two changes. Unlike swing-peak counting this needs no clear swing peak,
    which short clips and blends of out-of-phase clips often lack.
    """
    d = track.heights[:, 0] - track.heights[:, 1]
    side = np.where(d < -hysteresis, 0, np.where(d > hysteresis, 1, -1))
    known = np.flatnonzero(side >= 0)
    if len(known) < 2:
        return float("nan")
    s = side[known]
    changes = known[1:][s[1:] != s[:-1]]  # first frame of each new stance side
    if len(changes) < 2:
        return float("nan")
    return (len(changes) - 1) / ((changes[-1] - changes[0]) / track.fps)


def on_floor(motion: Motion, compiled: mjcf.CompiledModel) -> Motion:
    """The clip lowered (or raised) onto ``z = 0``: its stance floor (METRICS floor offset, the median
    lowest body point while the lower foot stands still) is the floor. The cgspeed daz clips' feet
    stand ~5 cm above it, which would leave no frame below a 3–5 cm contact height."""
    from .. import kinematics

    pose = kinematics.forward(compiled, motion)
    track = ev.foot_heights_speeds(compiled, motion, pose)
    offset = ev.ground_metrics(ev.lowest_body_point(compiled, pose), track).floor_offset_m
    return motion.replace(root_positions=motion.root_positions - np.array([0.0, 0.0, offset]))


def angular_accelerations(motion: Motion) -> np.ndarray:
    """``(T-2, J)`` magnitude (rad/s²) of each joint's local angular acceleration: the judge's
    (:func:`mjmotion.evaluate.joint_angular_accelerations`) at the frames with a step either side."""
    return ev.joint_angular_accelerations(motion)[1:-1]


def rms_angular_acceleration(motion: Motion) -> float:
    """RMS over frames and joints of :func:`angular_accelerations`, rad/s² (the peak is mocap noise)."""
    return float(np.sqrt(np.mean(angular_accelerations(motion) ** 2)))


def known_warp(n_source: int, n_frames: int) -> tuple:
    """The known smooth monotone warp ``w`` (result frame → source frame) and its inverse."""
    a, b, c = WARP

    def w(i: np.ndarray) -> np.ndarray:
        u = np.asarray(i, dtype=float) / (n_frames - 1)
        return (n_source - 1) * (a + b * u + c * np.sin(2 * np.pi * u))

    dense = np.linspace(0, n_frames - 1, 20 * n_frames)

    def w_inv(t: np.ndarray) -> np.ndarray:
        return np.interp(t, w(dense), dense)

    return w, w_inv


def registration_from(pr: reg.PairRegistration) -> reg.Registration:
    """A two-clip :class:`~mjmotion.registration.Registration` (A the reference) along ``pr``'s curve,
    sampled once per frame of A as :func:`~mjmotion.registration.register_many` does."""
    s = pr.curve.samples
    tau = np.arange(np.ceil(s[0, 0]), np.floor(s[-1, 0]) + 1e-9, 1.0)
    times = np.column_stack([tau, np.interp(tau, s[:, 0], s[:, 1])])
    align = np.zeros((len(tau), 2, 3))
    for c in range(3):
        align[:, 1, c] = np.interp(tau, s[:, 0], pr.alignment[:, c])
    keep = np.r_[True, np.all(np.diff(times, axis=0) > 0, axis=1)]
    return reg.Registration(times[keep], align[keep], 0, np.array([0.0, pr.path.mean_cost]))


# --------------------------------------------------------------------------------------------
# the experiment
# --------------------------------------------------------------------------------------------
def blend_rows(
    pair: Pair, compiled: mjcf.CompiledModel, weights: tuple[float, ...], positions: tuple[np.ndarray, np.ndarray] | None = None
) -> tuple[list[tuple], dict]:
    """Rows of :data:`BLEND_COLUMNS` for every weight and method, and the 0.5 blends' foot tracks.

    ``positions``: the pair's joint positions ``(T, J, 3)`` if already computed."""
    registration = reg.register_many([pair.a, pair.b], reference=0, positions=list(positions) if positions is not None else None)
    rows, tracks = [], {}
    for w in weights:
        for method in ("linear", "registered"):
            m = bl.blend([pair.a, pair.b], [1 - w, w], method=method, registration=registration if method == "registered" else None)
            tr = ev.foot_heights_speeds(compiled, m)
            skates = [s["skate_mm_per_s"] for s in ev.skate_sensitivity(tr)]
            rows.append((pair.label, w, method, m.n_frames, mean_speed(m), steps_per_s(tr), *skates, ev.planted_skate_mm_per_s(tr)))
            if w == 0.5:
                tracks[method] = (m, tr)
    return rows, tracks


def warp_rows(
    pair: Pair, compiled: mjcf.CompiledModel, out_dir: Path, figure: bool, positions: tuple[np.ndarray, np.ndarray] | None = None
) -> tuple[list[tuple], list[str]]:
    """Rows of :data:`WARP_COLUMNS`: recovery of a known warp of ``pair.a`` and a .5 walk/run blend,
    with the discrete and the B-spline timewarp (seed 004 Table 5). ``positions``: the pair's joint
    positions ``(T, J, 3)`` if already computed."""
    a = pair.a
    n_b = round(0.85 * a.n_frames)
    w, w_inv = known_warp(a.n_frames, n_b)
    theta, shift = WARP_MOVE
    c, sn = np.cos(theta), np.sin(theta)
    undo = -np.array([[c, sn], [-sn, c]]) @ np.asarray(shift)  # the floor move that takes the warped clip back onto A
    warped = transform.floor_transform(transform.timewarp(a, w, n_b), theta, shift).replace(name=f"{a.name} warped")
    rows, files = [], []
    pos_a, pos_b = positions if positions is not None else (reg.positions_of(a), reg.positions_of(pair.b))
    joint_w, rms_a = reg.joint_weights(a.skeleton), rms_angular_acceleration(a)
    for label, b, truth, pos in ((f"{a.name} / known warp of it", warped, w_inv, None), (pair.label, pair.b, None, pos_b)):
        positions = (pos_a, reg.positions_of(b) if pos is None else pos)
        base = reg.register(a, b, positions=positions, loop=truth is not None)  # grid and DP path, shared by both curves
        src_rms = float(np.mean([rms_a, rms_angular_acceleration(b)]))
        t_discrete = None
        curves = {}
        for kind in ("discrete", "bspline"):

            def make(kind: str = kind, base: reg.PairRegistration = base, positions: tuple = positions, joint_w=joint_w) -> tuple:
                c = reg.discrete_timewarp(base.path) if kind == "discrete" else reg.timewarp_curve(base.path)
                return c, reg.alignment_curve(positions[0], positions[1], c.samples, joint_w)

            make()  # warm-up (lazy imports, caches)
            t_curve, (curve, align) = timed(make, 5)
            t_discrete = t_curve if kind == "discrete" else t_discrete
            curves[kind] = curve
            pr = reg.PairRegistration(base.grid, base.path, curve, align)
            s = curve.samples
            if truth is not None:
                err = s[:, 1] - truth(s[:, 0])
                rms, worst = float(np.sqrt(np.mean(err**2))), float(np.abs(err).max())
                turn = float(np.degrees(np.abs(np.angle(np.exp(1j * (align[:, 0] + theta))))).max())
                move = float(1e3 * np.linalg.norm(align[:, 1:] - undo, axis=1).max())
            else:
                rms = worst = turn = move = float("nan")
            # the clock's jerk: second differences of B's time per frame of A (kinks of the discrete curve)
            tb = np.interp(np.arange(np.ceil(s[0, 0]), s[-1, 0] + 1e-9), s[:, 0], s[:, 1])
            jerk = float(np.abs(np.diff(tb, 2)).max()) if len(tb) > 2 else float("nan")
            m = bl.blend([a, b], [0.5, 0.5], registration=registration_from(pr))
            tr = ev.foot_heights_speeds(compiled, m)
            rows.append((
                label, kind, len(s), rms, worst, turn, move, 1e3 * t_curve, 100.0 * (t_discrete or t_curve) / t_curve, jerk,
                rms_angular_acceleration(m), src_rms, ev.max_joint_speed_ratio(m, [a, b]), ev.planted_skate_mm_per_s(tr),
            ))  # fmt: skip
        if figure and truth is not None:
            f = plots.distance_grid(
                base.grid.cost, curves["discrete"].samples, curves["bspline"].samples, out_dir / "timewarp_discrete_vs_bspline.png",
                labels=(f"frame of {a.name}", f"frame of {b.name}"),
                title="known warp: discrete timewarp (white) vs B-spline (red)",
            )  # fmt: skip
            files.append(str(f))
    return rows, files


def run(out_dir: Path, data_dir: Path | None = None, quick: bool = False) -> Table:
    """Both tables on real mocap (``data_dir``) or the bundled clips; writes ``out_dir/table.md`` and PNGs.

    Returns the blend table; the timewarp table follows it in ``table.md`` (and in the returned
    table's notes as its file ``timewarp.md``).
    """
    out_dir = Path(out_dir)
    out_dir.mkdir(parents=True, exist_ok=True)
    pairs = pairs_of(data_dir, quick)
    source = (
        "real mocap, cgspeed daz at 120 fps (T-pose frames 0–3 dropped)" if data_dir is not None
        else "bundled procedural clips (mjmotion.synth, 60 fps)"
    )  # fmt: skip
    blends = Table(
        "Linear vs registered blends of a walk and a run",
        BLEND_COLUMNS,
        notes=[
            f"source: {source}",
            ("linear: frame n of both clips averaged (seed 004 §6.2.2; clips first moved to start at the same place and heading); "
                "registered: along the DP registration curve with incremental root (seed 000 §3.2)"),
            ("skate@h_c: docs/METRICS.md skate_mm_per_s, the height-weighted footskate (speed × (2 − 2^(h/h_c)) over frames a "
                "foot is below h_c, m); planted skate: planted_skate_mm_per_s, over contact frames (5 cm, 0.5 m/s, with hysteresis)"),
            "every clip first set on its floor (its detected stance floor: the daz feet stand from 0.5 cm below to 5 cm above z = 0)",
            ("steps/s: changes of the stance (lower) foot per second, with 2 cm hysteresis (contact rhythm); "
                "speed: root path length / duration"),
        ],
    )  # fmt: skip
    warps = Table(
        "Discrete (Sako) vs B-spline timewarp (seed 004 Table 5)",
        WARP_COLUMNS,
        notes=[
            (f"known warp: source frame (n−1)·({WARP[0]} + {WARP[1]}u + {WARP[2]} sin 2πu) of a clip 0.85× as long, then turned "
                f"{np.degrees(WARP_MOVE[0]):.0f}° and moved {WARP_MOVE[1]} m on the floor, registered corner to corner; "
                "recovery error in frames of the warped clip (METRICS path_rms_frames), alignment error: the largest over the curve's "
                "samples of the floor transform's turn and move against the inverse of the known move; the walk/run pair has a free end"),
            "both curves from the same DP path; curve ms: curve plus alignment (median of 5); time performance = 100 · t(discrete) / t (Sako's Eq. 6)",
            ("blend: weight .5 along each curve; clock jerk: max |second difference| of the second clip's time per frame of the first; "
                "RMS ang. accel: joint angular acceleration (finite differences of the angular velocity vectors), RMS over "
                "frames and joints, of the blend and (mean) of its two sources"),
        ],
    )  # fmt: skip
    files: list[str] = []
    for n, pair in enumerate(pairs):
        compiled = mjcf.compile(pair.a.skeleton)
        pair = Pair(pair.label, on_floor(pair.a, compiled), on_floor(pair.b, mjcf.compile(pair.b.skeleton)))
        positions = (reg.positions_of(pair.a), reg.positions_of(pair.b))  # FK once per clip, for every registration below
        rows, tracks = blend_rows(pair, compiled, RUN_WEIGHTS, positions)
        for r in rows:
            blends.add(*r)
        wrows, wfiles = warp_rows(pair, compiled, out_dir, figure=n == 0, positions=positions)
        for r in wrows:
            warps.add(*r)
        if n == 0:
            files += wfiles + figures(out_dir, pair, tracks, positions)
    blendable = blendability_table(data_dir)
    blends.files = [str(out_dir / "timewarp.md"), str(out_dir / "blendability.md"), *files]
    (out_dir / "timewarp.md").write_text(warps.markdown(), encoding="utf-8")
    (out_dir / "blendability.md").write_text(blendable.markdown(), encoding="utf-8")
    (out_dir / "table.md").write_text(blends.markdown() + "\n" + warps.markdown() + "\n" + blendable.markdown(), encoding="utf-8")
    return blends


def blendability_table(data_dir: Path | None) -> Table:
    """Rows of :data:`BLENDABILITY_COLUMNS` for :data:`BLENDABILITY_PAIRS_REAL` (or the bundled pairs):
    each pair registered as ``mjmotion register`` does and its blendability score."""
    if data_dir is None:
        from .. import synth

        lib = synth.library()
        pairs = [(kind, lib[a].motion.replace(name=a), lib[b].motion.replace(name=b), alike) for kind, a, b, alike in BLENDABILITY_PAIRS_BUNDLED]
    else:

        def read(rel: str) -> Motion:
            path = Path(data_dir) / f"{rel}.bvh"
            if not path.is_file():
                raise MjmotionError(f"{path}: missing; the blendability table needs the shared CMU clips (SOURCES.md)")
            return skip_leading_transient(bvh.read(str(path)))[0].replace(name=Path(rel).name)

        pairs = [(kind, read(a), read(b), alike) for kind, a, b, alike in BLENDABILITY_PAIRS_REAL]
    table = Table(
        "Blendability: mean path cost over the smaller self-similarity (seed 004 §7.2, Fig. 10)",
        BLENDABILITY_COLUMNS,
        notes=[
            ("each pair registered as mjmotion register does (free end, per-end rule, default joint weights; leading "
                "transients skipped); self-similarity: the mean of a clip's own distance grid (up to 200 evenly spaced frames); "
                f"score = mean path cost / min(self-similarity); blendable: score ≤ {THRESHOLD:g}"),
        ],
    )  # fmt: skip
    for kind, a, b, alike in pairs:
        pr = reg.register(a, b)
        bl = pr.blendability
        assert bl is not None
        table.add(
            f"{a.name} / {b.name}",
            kind,
            alike,
            f"{a.n_frames}×{b.n_frames}",
            bl.mean_cost,
            *bl.self_similarity,
            bl.score,
            bl.blendable,
        )
    scores = {k: [float(str(r[7])) for r in table.rows if r[2] == k] for k in ("yes", "mixed", "no")}
    table.notes.append("; ".join(f"alike '{k}': score {min(v):.3f}–{max(v):.3f}" for k, v in scores.items() if v) + f" (threshold {THRESHOLD:g})")
    return table


def figures(out_dir: Path, pair: Pair, tracks: dict, positions: tuple[np.ndarray, np.ndarray] | None = None) -> list[str]:
    """Foot contacts of the .5 linear and registered blends, and the pair's distance grid
    (``positions``: the pair's joint positions if already computed)."""
    files = []
    for method, (m, tr) in tracks.items():
        con = ev.contacts(tr)
        skate = ev.planted_skate_mm_per_s(tr)
        f = plots.foot_contacts(
            np.arange(m.n_frames) / m.fps, tr.heights, tr.speeds, con, out_dir / f"contacts_{method}.png",
            title=f"{method} blend {pair.label} at .5: planted skate {skate:.0f} mm/s, {steps_per_s(tr):.2f} steps/s",
        )  # fmt: skip
        files.append(str(f))
    pr = reg.register(pair.a, pair.b, positions=positions or (reg.positions_of(pair.a), reg.positions_of(pair.b)))
    f = plots.distance_grid(
        pr.grid.cost, pr.path.cells, pr.curve.samples, out_dir / "grid.png",
        labels=(f"frame of {pair.a.name}", f"frame of {pair.b.name}"), title=f"{pair.label}: DP path and B-spline timewarp",
    )  # fmt: skip
    files.append(str(f))
    return files
