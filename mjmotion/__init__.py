"""mjmotion: make new character motion out of motion capture and check it against physics.

A clip is a :class:`Motion` (frames of local joint rotations and a root path over a
:class:`Skeleton`; metres, seconds, MuJoCo's Z-up world). Every operation takes clips and
returns a new one; the judge measures any clip. The README's "Quick start" runs this:

    import mjmotion
    from mjmotion import blend, cleanup, evaluate

    walk, run = mjmotion.read("walk.bvh"), mjmotion.read("run.bvh")
    jog = blend.blend([walk, run], [0.5, 0.5])
    print(evaluate.evaluate(jog, sources=[walk, run]).to_markdown())

Where things are (one concept per module; ``docs/algorithms.md`` says which paper each method
comes from and where we differ, ``docs/METRICS.md`` defines every metric):

- Clips: :mod:`mjmotion.bvh` reads and writes BVH (:func:`read`, :func:`write`),
  :mod:`mjmotion.skeleton` is the data model, :mod:`mjmotion.synth` makes procedural clips with
  ground truth, :mod:`mjmotion.trim` finds a leading T-pose.
- MuJoCo: :mod:`mjmotion.mjcf` compiles a skeleton (with props, a ball, a skin) to a model,
  :mod:`mjmotion.kinematics` runs forward kinematics, :mod:`mjmotion.skin` is the skinned surface.
- Operations: :mod:`mjmotion.registration` (distance grids, time-warp paths and curves,
  alignment), :mod:`mjmotion.blend` and :mod:`mjmotion.stream` (blends, transitions),
  :mod:`mjmotion.hitpoint` with :mod:`mjmotion.ik` (a shot adapted to a new ball),
  :mod:`mjmotion.style` and :mod:`mjmotion.variations` (PCA variants), :mod:`mjmotion.cleanup`
  (footskate cleanup).
- The judge: :mod:`mjmotion.evaluate` (the report) with :mod:`mjmotion.physics`,
  :mod:`mjmotion.feet`, :mod:`mjmotion.floor`; :mod:`mjmotion.audit` over a whole folder.
- Output: :mod:`mjmotion.render` (videos), :mod:`mjmotion.plots` (figures),
  :mod:`mjmotion.experiments` (the seeds' tables), :mod:`mjmotion.studio` (the browser app).

Every name here loads on first use, so that ``import mjmotion`` (and the CLI's ``--help``) loads
neither NumPy nor MuJoCo.
"""

from __future__ import annotations

import importlib
import importlib.util
from typing import TYPE_CHECKING, Any

from .errors import BvhError, MjmotionError

if TYPE_CHECKING:
    from . import blend, cleanup, evaluate, registration, render, synth
    from .bvh import read, write
    from .skeleton import Motion, Skeleton

__version__ = "0.1.0"

__all__ = [
    "BvhError",
    "MjmotionError",
    "Motion",
    "Skeleton",
    "__version__",
    "blend",
    "cleanup",
    "evaluate",
    "read",
    "registration",
    "render",
    "synth",
    "write",
]

#: Names loaded on first use: ``name → (module, attribute)``; an attribute of ``None`` is the module itself.
_LAZY = {
    "Motion": ("skeleton", "Motion"),
    "Skeleton": ("skeleton", "Skeleton"),
    "read": ("bvh", "read"),
    "write": ("bvh", "write"),
    **{m: (m, None) for m in ("blend", "cleanup", "evaluate", "registration", "render", "synth")},
}


def __getattr__(name: str) -> Any:
    if name in _LAZY:
        module, attribute = _LAZY[name]
        mod = importlib.import_module(f".{module}", __name__)
        value = mod if attribute is None else getattr(mod, attribute)
        globals()[name] = value  # loaded once: the next access does not come here
        return value
    # Any module of the package, as ``mjmotion.trim.…`` after ``import mjmotion`` (the README's
    # ``mjmotion.trim.skip_leading_transient`` raised AttributeError).
    if name.isidentifier() and not name.startswith("_") and importlib.util.find_spec(f"{__name__}.{name}") is not None:
        value = importlib.import_module(f".{name}", __name__)
        globals()[name] = value
        return value
    raise AttributeError(f"module {__name__!r} has no attribute {name!r}")


def __dir__() -> list[str]:
    return sorted(set(globals()) | set(__all__))
