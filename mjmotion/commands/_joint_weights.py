"""``--joint-weights FILE``: per-joint weights of the registration distance (Macleod 2006, §3.1), for
register, blend and stream.

Seed 000 reads them from an XML file; ours is JSON or TOML, a table of joint name → non-negative
weight. Joints the file does not name keep their default weight (1, and 0 for fingers, thumbs,
eyes and end nubs: :func:`mjmotion.registration.joint_weights`).
"""

from __future__ import annotations

import argparse
import importlib
import json
import math
from pathlib import Path

from ..caps import MAX_JSON_BYTES
from ..errors import MjmotionError
from ..inputs import DuplicateKey, once, read_text
from ..skeleton import Skeleton

#: Weights are relative; a larger one would overflow the squared distances (1e308 read "mean cost 0").
MAX_WEIGHT = 1e6


def add_option(p: argparse.ArgumentParser) -> None:
    p.add_argument(
        "--joint-weights",
        metavar="FILE",
        help="JSON or TOML table of joint name -> weight from 0 to 1e6 in the frame distance (Macleod 2006, §3.1); "
        "joints not named keep 1 (fingers, thumbs, eyes 0)",
    )


def inputs(args: argparse.Namespace) -> tuple[str, ...]:
    """The weight file as one of the verb's inputs, which no output may replace (``--force`` or not)."""
    return (args.joint_weights,) if getattr(args, "joint_weights", None) else ()


def parse(text: str, path: str) -> dict[str, float]:
    """Joint name → weight from the text of ``path`` (TOML for a ``.toml`` file, else JSON)."""
    what = "a table of joint name -> non-negative weight"
    if Path(path).suffix.lower() == ".toml":
        try:  # (by name: the type checker targets Python 3.10, which has no tomllib)
            tomllib = importlib.import_module("tomllib")
        except ImportError:  # Python 3.10
            raise MjmotionError(f"{path}: reading TOML needs Python 3.11 or later; write the weights as JSON") from None
        try:
            data = tomllib.loads(text)
        except tomllib.TOMLDecodeError as e:
            raise MjmotionError(f"{path}: not valid TOML ({e}); expected {what}") from None
    else:
        try:
            data = json.loads(text, object_pairs_hook=once)
        except DuplicateKey as e:
            raise MjmotionError(f"{path}: joint {e.key!r} is given twice; give each joint once") from None
        except json.JSONDecodeError as e:
            raise MjmotionError(f"{path}:{e.lineno}: not valid JSON ({e.msg}); expected {what}") from None
        except RecursionError:
            raise MjmotionError(f"{path}: JSON nested too deeply; expected {what}") from None
    if not isinstance(data, dict) or not data:
        raise MjmotionError(f'{path}: expected {what}, e.g. {{"lfemur": 2, "lhand": 0}}')
    out = {}
    for name, value in data.items():
        if isinstance(value, bool) or not isinstance(value, (int, float)) or not math.isfinite(value) or not 0 <= value <= MAX_WEIGHT:
            raise MjmotionError(f"{path}: joint {name!r}: expected a number from 0 to {MAX_WEIGHT:g} (weights are relative), got {value!r}")
        out[str(name)] = float(value)
    return out


def load(args: argparse.Namespace, skeleton: Skeleton) -> dict[str, float] | None:
    """The weights of ``--joint-weights`` (``None`` without it), every name checked against ``skeleton``."""
    path = getattr(args, "joint_weights", None)
    if not path:
        return None
    from ..registration import joint_weights

    # (read as every small input: a regular file of at most caps.MAX_JSON_BYTES, UTF-8)
    weights = parse(read_text(path, MAX_JSON_BYTES, "a joint-weight table (JSON or TOML)"), path)
    try:
        joint_weights(skeleton, weights)
    except MjmotionError as e:
        raise MjmotionError(f"{path}: {e}") from None
    return weights
