"""Shot variations: exaggerated, muted and aborted swings and kicks, before and after cleanup (seed 003 §3; issue 8).

python experiments/variations.py [--data DIR | --bundled] [--out DIR] [--quick] [--jobs N]
"""

from mjmotion.experiments import script

if __name__ == "__main__":
    raise SystemExit(script("variations", __doc__))
