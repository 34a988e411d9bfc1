"""Hit-point grid: solvers × wrist × 3×3 targets on the golf swings and kicks (seed 003 §2.5, Table 2.1, Fig. 2.6; issue 8).

python experiments/hitpoint_grid.py [--data DIR | --bundled] [--out DIR] [--quick] [--jobs N | --workers N | --scheduler ADDRESS]
"""

from mjmotion.experiments import script

if __name__ == "__main__":
    raise SystemExit(script("hitpoint_grid", __doc__))
