"""Minimal-cost path search: seed 004 Tables 2–4 (brute force, greedy, threshold recursion, DP) on real walks and runs.

    python experiments/path_search.py [--data DIR | --bundled] [--out DIR] [--quick]

Without --data the real mocap is MJMOTION_DATA or ../shared/mocap; --bundled uses the procedural
clips of mjmotion.synth instead (what `mjmotion demo` runs).
"""

from mjmotion.experiments import script

if __name__ == "__main__":
    raise SystemExit(script("path_search", __doc__))
