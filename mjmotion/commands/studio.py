"""``mjmotion studio``: the seeds' interactive programs in one local browser app."""

from __future__ import annotations

import argparse
import sys
import threading

from ._common import add_input_options
from ._options import integer

NAME = "studio"
HELP = "serve the interactive Studio (blend, stream, hit, vary, evaluate) to a browser on this machine"
DESCRIPTION = """Serve the Studio, a local web app (viser), and print its URL. Tabs:
  Blend     pick clips, method (linear, discrete or B-spline timewarp), path search (DP, greedy,
            threshold), constant or curved weights; the distance grid with path and timewarp
            curve; the blend played beside its inputs (Sako 2008, §6.3-6.4)
  Stream    a live motion stream: weight sliders, Kick and Punch (keys K, P, R, 1-3) (Macleod 2006, §2.1, §3.3)
  Hit       drag the ball; the shot is adapted (DLS while dragging, NLP on demand), the launch
            simulated and drawn, the report shown (Hicks 2010, §2)
  Vary      exaggerate, mute or abort a shot; the PCA score paths (Hicks 2010, §3)
  Evaluate  the metrics of the clip on screen; contacts on the feet, penetration and skate on the timeline
Clips: the files given, the .bvh files under --data, else the bundled procedural library; a page
may upload more (validated, at most 32 MiB). Saving writes only inside --out and never over a
file. Runs until Ctrl-C.

examples:
  mjmotion studio
  mjmotion studio walk.bvh run.bvh kick.bvh --port 8090
  mjmotion studio --data "$MJMOTION_DATA/cmu_asfamc_converted"
  mjmotion studio walk.bvh run.bvh --check
"""


def add_arguments(p: argparse.ArgumentParser) -> None:
    p.add_argument("files", nargs="*", default=[], metavar="CLIP.bvh", help="clips to open (default: the bundled library)")
    p.add_argument("--data", metavar="DIR", help="also list every .bvh file under DIR")
    p.add_argument("--host", default="127.0.0.1", help="address to listen on (default 127.0.0.1: this machine only)")
    p.add_argument("--port", type=integer(1, 65535, what="a TCP port"), default=8080, help="port, 1 to 65535 (default 8080)")
    p.add_argument("--out", default=None, metavar="DIR", help="the folder saved clips go to (default ./studio_output)")
    add_input_options(p)  # --units, --up, --keep-start: clips are read as every verb reads them
    p.add_argument("--check", action="store_true", help="read and validate the clips, print what would be served, and exit (no server)")


#: Where saved clips go without --out.
DEFAULT_OUT = "studio_output"


def run(args: argparse.Namespace) -> int:
    from ..errors import MjmotionError, printable
    from ..outputs import check_folder
    from ..studio.app import LOCAL_HOSTS, Studio, check_host, check_port
    from ..studio.clips import ClipLibrary
    from ._common import check_model, note_skipped, note_up, stature_note, units_scale

    if not 0 <= args.port <= 65535:
        raise MjmotionError(f"--port {args.port}: expected 0-65535")
    # (--check said "ready" for a --host the server then refused; the port is bound only by the server:
    # a check while a studio runs on it is fine)
    if args.check:
        check_host(args.host)
    else:
        check_port(args.host, args.port)
    if args.out is not None:  # a folder given that takes no files is said now, not at the first save
        check_folder(args.out, "--out")
    else:  # the default: the studio still serves from a folder it cannot write in; saving says why it fails
        args.out = DEFAULT_OUT
    library = ClipLibrary.from_paths(args.files, args.data, keep_start=args.keep_start, scale=units_scale(args.units), up=args.up)
    for clip in map(library.get, library.names()):
        if clip.source is not None:  # as every verb reads a file: a skeleton no model takes, the wrong axis or units
            check_model(clip.motion, str(clip.source))
            note_up(clip.motion, str(clip.source))
            for line in stature_note(clip.motion, args.units or "auto"):
                sys.stderr.write(printable(line) + "\n")
        if clip.skipped:
            note_skipped(str(clip.source or clip.name), clip.skipped)
    if args.check:
        n = len(library.names())
        print(f"mjmotion studio: {n} clip{'s' * (n != 1)} ready: {printable(', '.join(library.names()))}")
        return 0
    studio = Studio(library, args.host, args.port, args.out)
    if args.host not in LOCAL_HOSTS:
        sys.stderr.write(f"warning: listening on {args.host}: anyone who can reach this machine on that network can use the studio\n")
    print(f"mjmotion studio: {studio.url} ({len(library.names())} clips; Ctrl-C to stop)", flush=True)
    stop = threading.Event()
    try:
        while not stop.wait(0.5):
            pass
    except KeyboardInterrupt:
        pass
    finally:
        studio.stop()
    return 0
