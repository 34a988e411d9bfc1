"""Make the README's figures from the experiments: ``python docs/make_images.py [--out docs/images] [--only NAME …]``.

Each picture is made by the experiment (or the renderer) that draws it, on the shared mocap
(``--data DIR``, default ``MJMOTION_DATA`` or ``../shared/mocap``), into a temporary results
folder; the file it wrote is then copied to ``OUT/<name>.png`` (written to a temporary name
beside it and renamed, so OUT never holds half a picture). A run that two pictures share is run
once. Pictures, and the time of each run (1.5 min in all on a 2-core machine, 2026-12-03):

  registration_grid    experiments/timewarp_blend.py   grid.png                 (with contacts_registered: 5 s)
  contacts_registered  experiments/timewarp_blend.py   contacts_registered.png
  launch_64_01         experiments/hitpoint_grid.py    launch_64_01_locked.png  (64_01 × nlp × locked wrist only: 65 s)
  variations_64_01     experiments/variations.py       variants_64_01.png       (64_01 only: 1 s)
  cleanup_before       experiments/physics_audit.py    cleanup_before.png       (the whole audit, with cleanup_after: 14 s)
  cleanup_after        experiments/physics_audit.py    cleanup_after.png
  skinning             experiments/skinning.py         skinning.png             (12 s)
  skin_vs_capsules     mjmotion.render as `mjmotion render CLIP --skin both --hq` draws it: a frame of a golf
                       swing (64_01) and of a walk (daz 07_01), each skinned beside its capsules (3 s)

The launch picture is Figure 2.6 of one task of the hit-point grid, 64_01 with the NLP and the
locked wrist (the first golf shot, the main solver), and depends on that task alone
(``hitpoint_grid.launch_figures``): it is drawn from that task, run as the full grid runs it
(``hitpoint_grid.plan``), instead of the whole grid (17 minutes on 2 cores) (the two were checked byte for
byte equal). ``--from DIR`` copies it from a full grid's folder instead
(``DIR/launch_64_01_locked.png``, e.g. ``results/hitpoint_grid``). Likewise the variations
picture comes from ``variations.run_shot`` of 64_01 alone, the shot it draws (equal to the full
experiment's too). ``--keep DIR`` keeps the runs' folders (``DIR/<run>/``).

Not made here: ``demo_frames.png`` is written by ``mjmotion demo`` (its ``results/demo/``), the
``studio_*.png`` screenshots by ``python docs/studio_screenshots.py``.
"""

from __future__ import annotations

import argparse
import shutil
import sys
import tempfile
import time
from collections.abc import Callable
from dataclasses import dataclass
from pathlib import Path

REPO = Path(__file__).resolve().parents[1]
sys.path.insert(0, str(REPO))

#: The clips of skin_vs_capsules (under the data folder) and the frame of each drawn, and its size.
SKIN_CLIPS = (("cmu_asfamc_converted/64_01.bvh", 0.66), ("cmu_cgspeed_daz/07_01.bvh", 0.5))
SKIN_PANEL = (640, 400)


@dataclass(frozen=True)
class Picture:
    """A README picture: the run that makes it (a key of :data:`RUNS`) and the file of that run it is."""

    run: str
    source: str


#: Every picture this script makes: README name (``docs/images/<name>.png``) → its run and file.
PICTURES: dict[str, Picture] = {
    "registration_grid": Picture("timewarp_blend", "grid.png"),
    "contacts_registered": Picture("timewarp_blend", "contacts_registered.png"),
    "launch_64_01": Picture("hitpoint_grid", "launch_64_01_locked.png"),
    "variations_64_01": Picture("variations", "variants_64_01.png"),
    "cleanup_before": Picture("physics_audit", "cleanup_before.png"),
    "cleanup_after": Picture("physics_audit", "cleanup_after.png"),
    "skinning": Picture("skinning", "skinning.png"),
    "skin_vs_capsules": Picture("render", "skin_vs_capsules.png"),
}
#: README pictures made elsewhere: a file-name pattern → the command that writes it.
ELSEWHERE = {"demo_frames.png": "mjmotion demo", "studio_*.png": "python docs/studio_screenshots.py"}


def _experiment(name: str) -> Callable[[Path, Path], None]:
    """The whole experiment ``name`` (its ``run``), as its script runs it (BLAS on one thread)."""

    def make(out: Path, data: Path) -> None:
        import importlib

        from mjmotion.experiments import single_thread_blas

        module = importlib.import_module(f"mjmotion.experiments.{name}")
        with single_thread_blas():
            module.run(out, data)

    return make


def _shot(data: Path, name: str):
    from mjmotion.experiments import hitpoint_grid as hg

    shots = [s for s in hg.load_shots(data, quick=True) if s.name == name]
    if not shots:
        from mjmotion.errors import MjmotionError

        raise MjmotionError(f"{data}: no shot {name} (hitpoint_grid.load_shots)")
    return shots[0]


def _launch(out: Path, data: Path) -> None:
    """The hit-point grid's task 64_01 × nlp × locked wrist, as the full grid plans it, and its launch figure."""
    from mjmotion.experiments import hitpoint_grid as hg
    from mjmotion.experiments import single_thread_blas

    shot = _shot(data, "64_01")
    task = next(t for t in hg.plan([shot], quick=False) if t[1] == "nlp" and t[2] == "locked")
    with single_thread_blas():
        hg.launch_figures(hg.run_grid(*task), out)


def _variations(out: Path, data: Path) -> None:
    """The variations experiment's figures of 64_01 (its source and variants depend on that shot alone)."""
    from mjmotion.experiments import single_thread_blas
    from mjmotion.experiments import variations as V

    with single_thread_blas():
        V.plot(V.run_shot(_shot(data, "64_01")), out)


def _skin_vs_capsules(out: Path, data: Path) -> None:
    """A frame of each :data:`SKIN_CLIPS` clip skinned beside its capsules, side by side in one PNG.

    Each panel is what ``mjmotion render CLIP --skin both --hq`` draws (labels ``skin`` and
    ``capsules``, the clip's judged floor, levelled if tilted) at that fraction of the clip."""
    import imageio.v3 as iio
    import numpy as np

    from mjmotion import bvh, render
    from mjmotion.feet import judged_floor, level_motion
    from mjmotion.trim import skip_leading_transient

    panels = []
    for rel, at in SKIN_CLIPS:
        m = skip_leading_transient(bvh.read(data / rel))[0]
        floor = judged_floor(m, [], None)
        if not floor.level.flat:
            m = level_motion(floor.level, m)
        colour = render.PALETTE[0]
        actors = [render.Actor(m, label=kind, color=colour, skin=kind == "skin") for kind in ("skin", "capsules")]
        scene = render.build_scene(actors, fps=30.0, floor=floor.height)
        with render.Renderer(scene, *SKIN_PANEL, shadows=True, reflections=True, contact_shadows=False) as r:
            panels.append(r.frame(int(round(at * (scene.n_frames - 1)))))
    iio.imwrite(out / "skin_vs_capsules.png", np.concatenate(panels, axis=1), extension=".png")


#: The runs: name → ``make(out_dir, data_dir)``, writing its files into ``out_dir``.
RUNS: dict[str, Callable[[Path, Path], None]] = {
    "timewarp_blend": _experiment("timewarp_blend"),
    "hitpoint_grid": _launch,
    "variations": _variations,
    "physics_audit": _experiment("physics_audit"),
    "skinning": _experiment("skinning"),
    "render": _skin_vs_capsules,
}
#: What each run is, as printed.
RUN_TEXT = {
    "timewarp_blend": "experiments/timewarp_blend.py",
    "hitpoint_grid": "hitpoint_grid task 64_01/nlp/locked",
    "variations": "variations of 64_01",
    "physics_audit": "experiments/physics_audit.py",
    "skinning": "experiments/skinning.py",
    "render": "mjmotion.render --skin both --hq of 64_01 and daz 07_01",
}


def _copy(src: Path, dst: Path) -> None:
    """Copy ``src`` onto ``dst`` through a temporary file beside it (never half a file at ``dst``)."""
    from mjmotion.outputs import atomic_path

    with atomic_path(dst, replace=True) as tmp:
        shutil.copyfile(src, tmp)


class _Parser(argparse.ArgumentParser):
    """argparse that reports a usage mistake as one ``error:`` line (status 2), as ``mjmotion`` does."""

    def error(self, message: str) -> None:  # type: ignore[override]
        sys.stderr.write(f"error: {' '.join(message.split())} (see '{self.prog} --help')\n")
        raise SystemExit(2)


def parse(argv: list[str] | None = None) -> argparse.Namespace:
    p = _Parser(prog="docs/make_images.py", description=__doc__, formatter_class=argparse.RawDescriptionHelpFormatter)
    p.add_argument("--out", default=str(REPO / "docs" / "images"), metavar="DIR", help="where the pictures go (default docs/images)")
    p.add_argument("--only", nargs="+", metavar="NAME", help=f"make only these ({', '.join(PICTURES)})")
    p.add_argument("--data", metavar="DIR", help="mocap directory (default: MJMOTION_DATA or ../shared/mocap)")
    p.add_argument("--from", dest="from_", metavar="DIR", help="copy launch_64_01 from a full hit-point grid's folder instead of running its task")
    p.add_argument("--keep", metavar="DIR", help="keep the runs' results folders in DIR (default: a temporary folder, removed)")
    args = p.parse_args(argv)
    unknown = [n for n in args.only or () if n not in PICTURES]
    if unknown:
        p.error(f"--only {' '.join(unknown)}: no such picture; choose from {', '.join(PICTURES)}")
    if args.from_ is not None and not (Path(args.from_) / PICTURES["launch_64_01"].source).is_file():
        p.error(f"--from {args.from_}: no {PICTURES['launch_64_01'].source} there (expected a full experiments/hitpoint_grid.py run's folder)")
    if not Path(args.out).is_dir():
        p.error(f"--out {args.out}: not a directory")
    return args


def main(argv: list[str] | None = None) -> int:
    args = parse(argv)
    from mjmotion.errors import MjmotionError
    from mjmotion.experiments import data_dir

    out = Path(args.out)
    names = list(dict.fromkeys(args.only)) if args.only else list(PICTURES)
    try:
        data = data_dir(args.data)
        assert data is not None
        with tempfile.TemporaryDirectory(prefix="make_images_") as tmp:
            root = Path(args.keep) if args.keep else Path(tmp)
            done: dict[str, float] = {}
            for name in names:
                pic = PICTURES[name]
                if name == "launch_64_01" and args.from_ is not None:
                    src, how = Path(args.from_) / pic.source, f"copied from {args.from_}"
                else:
                    folder = root / pic.run
                    if pic.run not in done:
                        folder.mkdir(parents=True, exist_ok=True)
                        start = time.perf_counter()
                        RUNS[pic.run](folder, data)
                        done[pic.run] = time.perf_counter() - start
                        how = f"{RUN_TEXT[pic.run]}, {done[pic.run]:.1f} s"
                    else:
                        how = f"{RUN_TEXT[pic.run]}, the same run"
                    src = folder / pic.source
                if not src.is_file():
                    raise MjmotionError(f"{RUN_TEXT[pic.run]} wrote no {pic.source}")
                _copy(src, out / f"{name}.png")
                print(f"{name}.png: {pic.source} of {how} -> {out / f'{name}.png'}", flush=True)
    except MjmotionError as e:
        sys.stderr.write(f"error: {e}\n")
        return 2
    return 0


if __name__ == "__main__":
    raise SystemExit(main())
