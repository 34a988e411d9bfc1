"""Regenerate every model in this folder: ``python models/make_models.py`` (or ``python -m mjmotion.models``)."""

from pathlib import Path

from mjmotion.models import main

if __name__ == "__main__":
    # (the options are main's: --help shows them rather than writing the models)
    raise SystemExit(main(prog="python models/make_models.py", out=str(Path(__file__).resolve().parent)))
