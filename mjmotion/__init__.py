"""mjmotion: make new character motion out of motion capture and check it against physics.

The data model is :class:`~mjmotion.skeleton.Motion` over a :class:`~mjmotion.skeleton.Skeleton`;
:mod:`mjmotion.bvh` reads and writes clips, :mod:`mjmotion.mjcf` compiles skeletons to MuJoCo,
:mod:`mjmotion.kinematics` runs forward kinematics through MuJoCo.

``Motion`` and ``Skeleton`` are loaded on first use, so that ``import mjmotion`` (and the
CLI's ``--help``) does not load NumPy.
"""

from __future__ import annotations

from typing import TYPE_CHECKING, Any

from .errors import BvhError, MjmotionError

if TYPE_CHECKING:
    from .skeleton import Motion, Skeleton

__version__ = "0.1.0"

__all__ = ["BvhError", "MjmotionError", "Motion", "Skeleton", "__version__"]


def __getattr__(name: str) -> Any:
    if name in ("Motion", "Skeleton"):
        from . import skeleton

        value = getattr(skeleton, name)
        globals()[name] = value  # loaded once: the next access does not come here
        return value
    raise AttributeError(f"module {__name__!r} has no attribute {name!r}")
