"""Regenerate every model in this folder: ``python models/make_models.py`` (or ``python -m mjmotion.models``)."""

from pathlib import Path

from mjmotion.models import main

if __name__ == "__main__":
    raise SystemExit(main(["--out", str(Path(__file__).resolve().parent)]))
