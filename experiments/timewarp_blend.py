"""Linear vs registered blending of walks and runs, and discrete vs B-spline timewarp (seed 004 §5.3–5.4, Table 5).

    python experiments/timewarp_blend.py [--data DIR | --bundled] [--out DIR] [--quick]

Without --data the real mocap is MJMOTION_DATA or ../shared/mocap; --bundled uses the procedural
clips of mjmotion.synth instead (what `mjmotion demo` runs).
"""

from mjmotion.experiments import script

if __name__ == "__main__":
    raise SystemExit(script("timewarp_blend", __doc__))
