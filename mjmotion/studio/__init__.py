"""The Studio: the seeds' interactive programs in one local browser app (``mjmotion studio``).

Seed 000 §2.1's interactive motion stream, seed 004 §6.3–6.4's Motion Blender and seed 003's
interactive hit-point adaptation and variations, served by viser to a browser on this machine.
Modules:

- :mod:`.live` — the motion stream driven one frame at a time (pure; no viser);
- :mod:`.clips` — the clips a Studio may show: given files, ``--data``, the bundled library, uploads;
- :mod:`.jobs` — work off the GUI thread: latest request wins, progress, cancel;
- :mod:`.player` — play, pause, step, speed, loop over a clip's frames;
- :mod:`.scene` — the compiled MuJoCo model's geoms drawn in the viser scene (pluggable draw modes);
- :mod:`.engine` — thin adapters over blend, registration, hitpoint, variations, evaluate and physics;
- :mod:`.session` — one browser page's state; :mod:`.tabs` — one module per tab;
- :mod:`.app` — the server.

viser is imported only by :mod:`.scene`, :mod:`.session`, :mod:`.tabs` and :mod:`.app`.
"""
