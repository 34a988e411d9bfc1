"""``mjmotion fk``: world joint (and site) positions of a clip, through MuJoCo."""

from __future__ import annotations

import argparse
import io

from ..outputs import write_bytes_atomic
from ._common import add_input_options, check_model, load, output_path, prop_option
from ._options import UniqueProps
from ._progress import steps

NAME = "fk"
HELP = "forward kinematics of a BVH clip to an .npz of world positions (metres, Z-up)"
#: This verb renders nothing: the CLI imports MuJoCo without its import-time OpenGL backend.
MUJOCO_WITHOUT_GL = True
DESCRIPTION = """Run forward kinematics through the compiled MuJoCo model and save arrays:
  joint_names (J,), positions (T, J, 3) metres in the model's world frame (Z up), fps;
with --prop also site_names (S,) and site_positions (T, S, 3) (grip, sweet spot, tip).

examples:
  mjmotion fk walk.bvh -o walk_fk.npz
  mjmotion fk swing.bvh --prop club -o swing_fk.npz
"""


def add_arguments(p: argparse.ArgumentParser) -> None:
    p.add_argument("file", help="a .bvh file")
    p.add_argument("-o", "--output", required=True, metavar="OUT.npz", help="the .npz file to write")
    p.add_argument("--force", action="store_true", help="replace the output if it exists")
    p.add_argument("--prop", action=UniqueProps, default=[], metavar="KIND[:JOINT]", help="attach a prop and export its sites (each kind once)")
    add_input_options(p)


def run(args: argparse.Namespace) -> int:
    import numpy as np

    from .. import kinematics, mjcf

    out = output_path(args, args.file, suffix=".npz")
    with steps("fk", ("read", "compile", "forward kinematics", "write")) as step:
        step("read")
        m = load(args.file, args)
        check_model(m, args.file)
        step("compile")
        props = tuple(prop_option(m, text) for text in args.prop)
        compiled = mjcf.compile(m.skeleton, props)
        step("forward kinematics")
        pose = kinematics.forward(compiled, m)
        step("write")
        arrays, n_sites = _arrays(m, pose, props)
        buf = io.BytesIO()
        np.savez(buf, **arrays)
        write_bytes_atomic(out, buf.getvalue())
    print(f"wrote {out}: positions {pose.joint_positions.shape}" + (f", {n_sites} sites" if props else ""))
    return 0


def _arrays(m, pose, props) -> tuple[dict, int]:
    """The arrays of the .npz and the number of prop sites among them."""
    import numpy as np

    arrays = {
        "joint_names": np.array(m.skeleton.names),
        "positions": pose.joint_positions,
        "fps": np.array(m.fps),
    }
    if props:
        keep = [i for i, n in enumerate(pose.site_names) if any(n.startswith(f"{p.name}/") for p in props)]
        arrays["site_names"] = np.array([pose.site_names[i] for i in keep])
        arrays["site_positions"] = pose.site_positions[:, keep]
    return arrays, len(arrays.get("site_names", ()))
