"""Physics audit of every shared clip and every synthesized result (issue 8; METRICS.md).

python experiments/physics_audit.py [--data DIR | --bundled] [--out DIR] [--quick] [--jobs N | --workers N | --scheduler ADDRESS]
"""

from mjmotion.experiments import script

if __name__ == "__main__":
    raise SystemExit(script("physics_audit", __doc__))
