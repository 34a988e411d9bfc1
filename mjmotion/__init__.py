"""mjmotion: make new character motion out of motion capture and check it against physics.

The data model is :class:`~mjmotion.skeleton.Motion` over a :class:`~mjmotion.skeleton.Skeleton`;
:mod:`mjmotion.bvh` reads and writes clips, :mod:`mjmotion.mjcf` compiles skeletons to MuJoCo,
:mod:`mjmotion.kinematics` runs forward kinematics through MuJoCo.
"""

from .errors import BvhError, MjmotionError
from .skeleton import Motion, Skeleton

__version__ = "0.1.0"

__all__ = ["BvhError", "MjmotionError", "Motion", "Skeleton", "__version__"]
