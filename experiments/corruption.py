"""Corruption benchmark: clean clips of every flavour lifted, sunk, dragged, sped up, popped and
blended, judged against their clean clips; ROC AUC per corruption and metric (docs/METRICS.md).

    python experiments/corruption.py [--data DIR | --bundled] [--out DIR] [--quick] [--jobs N]
"""

from mjmotion.experiments import script

if __name__ == "__main__":
    raise SystemExit(script("corruption", __doc__))
