"""Skinning artefacts at the elbow (seed 000 §1.1.2, Figs. 5–6): linear blend vs dual-quaternion skinning under a forearm twist and an elbow bend.

    python experiments/skinning.py [--data DIR | --bundled] [--out DIR] [--quick]

Without --data the real mocap is MJMOTION_DATA or ../shared/mocap (the CMU ASF skeleton of 16_15);
--bundled skins the bundled humanoid of mjmotion.synth instead.
"""

from mjmotion.experiments import script

if __name__ == "__main__":
    raise SystemExit(script("skinning", __doc__))
