"""Cleanup of every linear blend of the shared walks and runs (pairs of one flavour, weights 0.5,
0.3 and 0.7) and of every walk against itself, judged by issue 13's bar; counts per flavour and kind.

    python experiments/cleanup_blends.py [--data DIR | --bundled] [--out DIR] [--quick] [--jobs N]
"""

from mjmotion.experiments import script

if __name__ == "__main__":
    raise SystemExit(script("cleanup_blends", __doc__))
