"""Shot variations along new paths through a clip's PCA space (seed 003 §3).

- :mod:`.paths` — score paths (:func:`source_path`, :func:`scaled_path`, :func:`aborted_path`,
  :func:`explicit_path`) and :func:`synthesise`, the motion a path stands for.
- :mod:`.fixes` — :func:`clean_up`: the repairs §3.3 names (feet held to the source's
  placement, the second hand returned to the club).
- :mod:`.measure` — :func:`report`: style error, footskate, joint speeds, grip error and path
  length of a variant.

Score paths are drawn by :func:`mjmotion.plots.score_paths`.
"""

from .fixes import FEET_METHODS, CleanupReport, clean_up, copied_frames, grip_joints, hold_source_feet, restore_grip_minimal, two_bone_ik
from .measure import effector_path_length, first_hand_for, fitted_club, grip_error_m, report
from .paths import (
    DEFAULT_VARIANCE,
    END_FADE,
    END_RAMP_S,
    MAX_SCORE,
    SCALE_CUTOFF_HZ,
    SEGMENT_TAPER,
    ScorePath,
    aborted_path,
    default_abort_frames,
    end_weights,
    explicit_path,
    read_scores,
    rest_in_place,
    scaled_path,
    segment_weights,
    source_path,
    synthesise,
)

__all__ = [
    "DEFAULT_VARIANCE",
    "END_FADE",
    "END_RAMP_S",
    "MAX_SCORE",
    "FEET_METHODS",
    "SCALE_CUTOFF_HZ",
    "SEGMENT_TAPER",
    "CleanupReport",
    "ScorePath",
    "aborted_path",
    "clean_up",
    "copied_frames",
    "default_abort_frames",
    "end_weights",
    "effector_path_length",
    "explicit_path",
    "first_hand_for",
    "fitted_club",
    "grip_error_m",
    "grip_joints",
    "hold_source_feet",
    "read_scores",
    "report",
    "rest_in_place",
    "restore_grip_minimal",
    "scaled_path",
    "segment_weights",
    "source_path",
    "synthesise",
    "two_bone_ik",
]
