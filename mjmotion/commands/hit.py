"""``mjmotion hit``: adapt a swing or kick so it meets a ball somewhere else (Hicks 2010, §2)."""

from __future__ import annotations

import argparse
import sys

from ..errors import MjmotionError
from ..outputs import json_text, together, write_text_atomic
from ._common import add_bowler_option, add_input_options, check_bowler, check_model, clip_frame, extra_output, load_first, output_path, prop_option
from ._options import COORD, INNER_FRAME, VELOCITY, Given, number, prop_text
from ._progress import steps

NAME = "hit"
#: Why a hit frame must be inside the clip (hitpoint.end_taper: the edit keeps the first and last frames).
HIT_INSIDE = "; the edit fades in and out around the hit and keeps the clip's first and last frames as captured"
HELP = "move a swing's hit point (IK with importance-based blending, keeping the style)"
#: This verb renders nothing: the CLI imports MuJoCo without its import-time OpenGL backend.
MUJOCO_WITHOUT_GL = True
DESCRIPTION = """Adapt SHOT.bvh so its effector (a club's sweet spot, a foot, a fist, or a site) meets a new
ball position at the hit frame, blending IK in and out by the effector's distance to the hit
point (Hicks 2010, §2.2.5). Coordinates are metres in the model's world frame (Z up).
The hit frame is the moment of contact: the effector's lowest pass in the downswing (a ball on
the ground or a tee), or with --source-ball the downswing frame nearest the source's ball; the
report gives the rule and the effector's height there above the floor_m of the shot: the lowest
level its foot joints reach (not z = 0: CMU subject 64's is 2-4 cm below it), on which a fitted
club rests and under which the effector is not taken. It is not evaluate's floor_m (the stance
soles'): on the golf swings the two lie within 1 cm, on the CMU kicks and iClone rigs, whose toe
joints sit higher over the sole, 4-6 cm apart.
A delivered ball (Hicks 2010, §2.3.2: released, pitching on the floor in MuJoCo with restitution
0.5) can be given by its release (--ball-release, --release-velocity: the target is then where
its path passes nearest the source's hit point, §2.5.1, unless --target/--offset say
otherwise) or as --delivery PACE aimed at the target from the bowler's end (--bowler); the report
adds how it arrives and the launch of the ball struck by the adapted shot.
Every chain joint keeps within the clip's own range (plus a margin) and within the joint range
the judge counts (mjmotion.limits, the compiled model's ranges: evaluate's limit_violation_ratio).
An unreachable target is solved best-effort: the clip and report are written (with
"reachable": false), one error line says so, and the exit status is 2.
The report's hit_error_m is the effector's distance to the target point at the hit frame
(`mjmotion evaluate --ball` with the same --prop measures METRICS' hit_error_m, to a ball's surface).

examples:
  mjmotion hit 64_01.bvh --offset 0 0.1 0.1 -o swing_hit.bvh --json report.json
  mjmotion hit 64_01.bvh --target -0.15 0.55 0.15 --solver dls --falloff 0.4 -o out.bvh
  mjmotion hit 10_01.bvh --effector right_foot --offset 0.1 0 0 -o kick.bvh
  mjmotion hit 64_01.bvh --offset 0 0 0.2 --wrist swing --lock lclavicle -o out.bvh
  mjmotion hit drive.bvh --prop bat --frame 66 --offset 0 0 0.1 --delivery medium -o out.bvh
  mjmotion hit drive.bvh --prop bat --frame 66 --ball-release 0.3 18 2.1 --release-velocity 0 -30 -2 -o out.bvh
"""


def add_arguments(p: argparse.ArgumentParser) -> None:
    p.add_argument("file", metavar="SHOT.bvh", help="the source clip")
    g = p.add_mutually_exclusive_group()
    g.add_argument("--target", nargs=3, type=COORD, metavar=("X", "Y", "Z"), help="new hit point (metres, world; each within ±1000)")
    g.add_argument("--offset", nargs=3, type=COORD, metavar=("DX", "DY", "DZ"), help="move the hit point by this (metres, each within ±1000)")
    d = p.add_mutually_exclusive_group()
    d.add_argument(
        "--ball-release",
        nargs=3,
        type=COORD,
        metavar=("X", "Y", "Z"),
        help="a delivered ball released here (m, each within ±1000; with --release-velocity)",
    )
    d.add_argument(
        "--delivery",
        choices=("fast", "medium", "slow"),
        help="a ball delivered at the hit point from the bowler's end at this pace (38, 30, 22 m/s), pitching before it",
    )
    p.add_argument(
        "--release-velocity",
        nargs=3,
        type=VELOCITY,
        metavar=("VX", "VY", "VZ"),
        help="the delivered ball's release velocity (m/s, each within ±1000)",
    )
    add_bowler_option(p)
    p.add_argument(
        "--prop",
        default="club",
        type=prop_text,
        action=Given,
        metavar="KIND[:JOINT]",
        help="the prop for --effector club: club or bat fitted to both hands, or KIND:JOINT held by JOINT along its bone (default: club)",
    )
    p.add_argument(
        "--frame",
        type=INNER_FRAME,
        default=None,
        metavar="H",
        help="hit frame, a file frame inside the clip, not its first or last (default: the moment of contact, the effector's lowest pass in the downswing)",
    )
    p.add_argument(
        "--source-ball",
        nargs=3,
        type=COORD,
        default=None,
        metavar=("X", "Y", "Z"),
        help="where the ball was in the source (m): the hit frame is the downswing frame where the effector comes nearest to it",
    )
    p.add_argument("--effector", default="club", metavar="NAME", help="club|left_foot|right_foot|left_fist|right_fist|SITE (default: club)")
    p.add_argument("--solver", default="nlp", choices=("nlp", "nlp-shot", "dls", "ccd"), help="IK solver (default: nlp)")
    p.add_argument(
        "--falloff",
        type=number(0, 100, lo_open=True, what="a distance in metres"),
        default=None,
        metavar="D",
        help="importance falloff distance in metres, at most 100 (default: 0.6)",
    )
    p.add_argument(
        "--wrist",
        default="locked",
        choices=("locked", "swing", "ball"),
        help="freedom of the wrist in the effector's chain (a foot's chain has none; default: locked)",
    )
    p.add_argument("--lock", nargs="+", default=[], metavar="JOINT", help="joints of the effector's chain to keep as in the source")
    p.add_argument("-o", "--output", required=True, metavar="OUT.bvh", help="the adapted clip")
    p.add_argument("--json", default=None, metavar="REPORT.json", help="also write the report here")
    p.add_argument("--force", action="store_true", help="replace existing outputs")
    add_input_options(p)


def run(args: argparse.Namespace) -> int:
    import numpy as np

    from .. import bvh, hitpoint

    check_bowler(args)
    out = output_path(args, args.file, suffix=".bvh")
    report_path = extra_output(args.json, "--json", ".json", args.force, [args.file])
    if report_path is not None and report_path == out:
        raise MjmotionError("--json and -o name the same file")
    falloff = hitpoint.DEFAULT_FALLOFF if args.falloff is None else args.falloff
    if (args.ball_release is None) != (args.release_velocity is None):
        raise MjmotionError("--ball-release and --release-velocity go together")
    # (ignored options gave the same result as without them)
    if getattr(args, "_prop_given", False) and args.effector != "club":
        raise MjmotionError(f"--prop {args.prop}: the prop of --effector club; --effector {args.effector} moves no prop, leave it out")
    if args.source_ball is not None and args.frame is not None:
        raise MjmotionError(f"--source-ball with --frame {args.frame}: the source's ball finds the hit frame, --frame gives it; give one")
    if args.target is None and args.offset is None and args.ball_release is None and args.delivery is None:
        raise MjmotionError("give --target or --offset (or a delivered ball: --ball-release with --release-velocity, or --delivery)")
    delivered = args.ball_release is not None or args.delivery is not None
    names = ("read", "deliver", "solve", "launch", "write") if delivered else ("read", "solve", "write")
    with steps("hit", names) as step:
        step("read")
        m, first = load_first(args.file, args)
        check_model(m, args.file)
        for name in args.lock:
            if name not in m.skeleton.names:
                raise MjmotionError(f"--lock {name}: no joint of that name in {args.file}")
        # (the edit fades in and out around its hit frame and keeps the clip's first and last frames)
        frame = None if args.frame is None else clip_frame(args.frame, first, "--frame", m.n_frames, inner=True, why=HIT_INSIDE)
        prop = prop_option(m, args.prop) if args.effector == "club" else None
        hitpoint.check_chain_options(m.skeleton, hitpoint.resolve_effector(m, args.effector, prop)[0].joint, args.wrist, args.lock, dash="--")
        source_ball = None if args.source_ball is None else np.array(args.source_ball)
        target = None if args.target is None else np.array(args.target)
        flight = None
        if delivered:
            from .. import delivery

            step("deliver")
            base = hitpoint.setup(m, offset=np.zeros(3), frame=frame, effector=args.effector, weights="clip", prop=prop, source_ball=source_ball)
            source_hit = base.effector_fk[base.hit]
            if target is None and args.offset is not None:
                target = source_hit + np.array(args.offset)
            if args.delivery is not None:
                ball = delivery.aimed(source_hit if target is None else target, bowler=np.array(args.bowler), preset=args.delivery)
            else:
                try:
                    ball = delivery.Delivery(tuple(args.ball_release), tuple(args.release_velocity))
                except MjmotionError as e:
                    raise MjmotionError(f"--ball-release {' '.join(f'{v:g}' for v in args.ball_release)}: {e}") from None
            flight = delivery.fly(ball)
            if target is None:
                # Hicks 2010, §2.5.1: the new hit point is the point of the ball's path nearest the source's
                target = flight.nearest(source_hit)[1]
        step("solve")
        result = hitpoint.adapt(
            m,
            target=target,
            offset=None if (args.offset is None or target is not None) else np.array(args.offset),
            prop=prop,
            frame=frame,
            effector=args.effector,
            solver=args.solver,
            falloff=falloff,
            wrist=args.wrist,
            lock=tuple(args.lock),
            source_ball=source_ball,
        )
        if flight is not None:
            step("launch")
            result.report["delivery"] = _launch(result, ball, flight, args.delivery)
        step("write")
        text = json_text(result.report, indent=2)
        with together():  # (the clip and its report appear together or not at all)
            bvh.write(result.motion, out)
            if report_path is not None:
                write_text_atomic(report_path, text + "\n")
    r = result.report
    written = f"{out} and {report_path}" if report_path is not None else str(out)
    # human output to meaningful digits (the JSON keeps full precision); a grip only where two hands hold the prop
    grip = f"grip error {r['grip_error_m'] * 1000:.3f} mm, " if result.problem.second is not None else ""
    style = f"style_rmse {r['style_rmse']:.4f}, " if r["style_rmse"] is not None else ""
    print(
        f"wrote {written}: hit frame {r['hit_frame']} ({r['hit_rule']}; effector {r['source_effector_height_m']:.3f} m above the floor "
        f"at {r['floor_m']:.3f} m), hit error {r['hit_error_m'] * 1000:.3f} mm, {grip}{style}solver {r['solver']}"
    )
    if "delivery" in r:
        dl, ln = r["delivery"], r["delivery"]["launch"]
        pitched = "no bounce before the hit" if dl["pitched_m_before"] is None else f"pitched {dl['pitched_m_before']:.2f} m before the hit"
        print(
            f"delivered ball: {pitched}, met at {np.linalg.norm(dl['incoming_velocity']):.1f} m/s "
            f"({dl['miss_m'] * 1000:.1f} mm from the effector); launched at {ln['speed']:.1f} m/s, azimuth {ln['azimuth_deg']:.1f}°, "
            f"elevation {ln['elevation_deg']:.1f}°" + ("" if ln["contacted"] else " (no contact)")
        )
    if not r["reachable"]:
        # Best effort is written and reported (issue 5); the exit status says the request failed (issue 9).
        sys.stderr.write(f"error: {r['message']}; best effort written to {out}\n")
        return 2
    return 0


def _launch(result, ball, flight, preset: str | None) -> dict:
    """The delivered ball met by the adapted shot: where and how it arrives, and how it leaves (Hicks 2010, §2.3.2)."""
    import numpy as np

    from .. import mjcf, physics

    h = result.problem.hit
    t, at, incoming, miss = flight.nearest(result.achieved[h])
    prop = result.problem.prop
    hit = physics.hit_metrics(
        result.motion,
        mjcf.Ball(position=tuple(at), radius=ball.radius, mass=ball.mass),
        h,
        props=(prop,) if prop is not None else (),
        ball_velocity=tuple(incoming),
        restitution=ball.restitution,
    )
    bounce = flight.bounce
    return {
        "preset": preset,
        "release": list(ball.release),
        "release_velocity": list(ball.velocity),
        "bounce": None if bounce is None else bounce.tolist(),
        "pitched_m_before": None if bounce is None else float(np.linalg.norm((bounce - at)[:2])),
        "ball_at_hit": at.tolist(),
        "time_from_release_s": t,
        "incoming_velocity": incoming.tolist(),
        "miss_m": miss,
        "launch": {
            "azimuth_deg": hit["launch_azimuth_deg"],
            "elevation_deg": hit["launch_elevation_deg"],
            "speed": hit["launch_speed"],
            "contacted": hit["launch_contacted"],
        },
    }
