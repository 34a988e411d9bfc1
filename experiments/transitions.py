"""A motion stream with weight ramps, kicks and returns (seed 000 §3.3): continuity metrics and the time-blip check (§4.1).

    python experiments/transitions.py [--data DIR | --bundled] [--out DIR] [--quick]

Without --data the real mocap is MJMOTION_DATA or ../shared/mocap; --bundled uses the procedural
clips of mjmotion.synth instead (what `mjmotion demo` runs).
"""

from mjmotion.experiments import script

if __name__ == "__main__":
    raise SystemExit(script("transitions", __doc__))
