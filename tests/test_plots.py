"""Plots: valid PNGs of the stated size whose marks land where the data say."""

from __future__ import annotations

import numpy as np
import pytest
from PIL import Image

from mjmotion import plots
from mjmotion.errors import MjmotionError


def _rgb(path) -> np.ndarray:
    with Image.open(path) as im:
        assert im.format == "PNG"
        return np.asarray(im.convert("RGB")).astype(int)


def _near(img: np.ndarray, color, tol: int = 6) -> np.ndarray:
    """``(H, W)`` mask of pixels within ``tol`` of ``color`` (0–255) in every channel."""
    return np.all(np.abs(img - np.asarray(color)) <= tol, axis=2)


def _hex(c: str) -> np.ndarray:
    return np.array([int(c[i : i + 2], 16) for i in (1, 3, 5)])


def test_distance_grid_path_lies_on_the_grid_with_a_along_x(tmp_path):
    na, nb = 40, 20
    grid = np.zeros((na, nb))  # one colour, viridis(0), but for the top-right cell
    grid[-1, -1] = 1.0
    # An L-shaped path: along A first (j = 0), then up B. Transposing the grid would put it on the left edge.
    path = np.array([(i, 0) for i in range(20)] + [(20 + k, k) for k in range(20)])
    out = plots.distance_grid(grid, path, None, tmp_path / "g.png", figsize=(6, 4), dpi=100)
    img = _rgb(out)
    assert img.shape == (400, 600, 3)
    cell = _near(img, (68, 1, 84), tol=3)  # viridis(0)
    cell[:, 520:] = False  # the colourbar's foot is viridis(0) too
    rows, cols = np.nonzero(cell)
    r0, r1, c0, c1 = rows.min(), rows.max(), cols.min(), cols.max()
    assert cell.sum() > 0.5 * (r1 - r0) * (c1 - c0)  # the grid is one solid block
    inside = img[r0 : r1 + 1, c0 : c1 + 1]
    white = _near(inside, (255, 255, 255), tol=20)
    pr, pc = np.nonzero(white)
    assert len(pr) > 0.8 * (c1 - c0)  # a drawn line, not a speck
    # Grid coordinates of the white pixels (A along x from the left, B along y from the bottom).
    a = (pc + 0.5) / (c1 - c0 + 1) * na - 0.5
    b = (r1 - r0 - pr + 0.5) / (r1 - r0 + 1) * nb - 0.5
    first = a < 18
    assert first.any() and np.all(b[first] < 1.0)  # the flat leg runs along the bottom
    second = a > 21
    assert second.any() and np.all(np.abs(b[second] - (a[second] - 20)) < 1.5)  # then the diagonal


def test_distance_grid_draws_the_curve_and_checks_shapes(tmp_path):
    grid = np.random.default_rng(1).random((30, 30))
    curve = np.column_stack([np.linspace(0, 29, 50), np.linspace(0, 29, 50)])
    img = _rgb(plots.distance_grid(grid, None, curve, tmp_path / "c.png"))
    assert img.shape == (500, 600, 3)
    assert _near(img, _hex(plots.CURVE_COLOR), tol=25).sum() > 50
    with pytest.raises(MjmotionError, match="path"):
        plots.distance_grid(grid, np.zeros((5, 3)), None, tmp_path / "bad.png")
    with pytest.raises(MjmotionError, match=r"\.png"):
        plots.distance_grid(grid, None, None, tmp_path / "bad.jpg")
    assert sorted(p.name for p in tmp_path.iterdir()) == ["c.png"]  # nothing half-written


def test_foot_contacts_shading_covers_the_contact_frames(tmp_path):
    t = np.arange(100) / 10.0  # 0 … 9.9 s
    h = np.column_stack([np.abs(np.sin(t)), np.abs(np.cos(t))]) * 0.1
    s = np.abs(np.gradient(h, t, axis=0))
    none = np.zeros((100, 2), dtype=bool)
    early, late = none.copy(), none.copy()
    early[:50, 0] = True
    late[50:, 0] = True
    kw = dict(figsize=(8, 4), dpi=100)
    base = _rgb(plots.foot_contacts(t, h, s, none, tmp_path / "n.png", **kw))
    a = _rgb(plots.foot_contacts(t, h, s, early, tmp_path / "e.png", **kw))
    b = _rgb(plots.foot_contacts(t, h, s, late, tmp_path / "l.png", **kw))
    assert base.shape == a.shape == b.shape == (400, 800, 3)
    da = np.nonzero(np.abs(a - base).sum(axis=2) > 30)[1]
    db = np.nonzero(np.abs(b - base).sum(axis=2) > 30)[1]
    assert len(da) > 1000 and len(db) > 1000
    # the two shadings meet at t = 5 s: early lies left of late, both about as wide
    assert np.percentile(da, 99) <= np.percentile(db, 1) + 2
    assert 0.8 < np.ptp(da) / np.ptp(db) < 1.25
    # the left foot's contact is shaded in the left foot's colour (alpha 0.25 over white)
    shade = 255 - 0.25 * (255 - _hex(plots.COLORS[0]))
    changed = np.abs(a - base).sum(axis=2) > 30
    assert _near(a, shade, tol=4)[changed].mean() > 0.7  # what the contact added is mostly the shade
    with pytest.raises(MjmotionError, match="contacts"):
        plots.foot_contacts(t, h, s, none[:10], tmp_path / "x.png")


def test_weight_curves_lines_and_validation(tmp_path):
    t = np.linspace(0, 2, 60)
    w = np.column_stack([1 - t / 2, t / 2])
    img = _rgb(plots.weight_curves(t, w, tmp_path / "w.png", labels=["walk", "run"], figsize=(7, 3), dpi=100))
    assert img.shape == (300, 700, 3)
    for c in plots.COLORS[:2]:
        assert _near(img, _hex(c), tol=10).sum() > 100
    with pytest.raises(MjmotionError, match="rows"):
        plots.weight_curves(t[:-1], w, tmp_path / "x.png")
    with pytest.raises(MjmotionError, match="labels"):
        plots.weight_curves(t, w, tmp_path / "x.png", labels=["one"])


def test_score_paths_panels_and_errors(tmp_path):
    th = np.linspace(0, 2 * np.pi, 80)
    base = np.column_stack([np.cos(th), np.sin(th), 0.5 * np.cos(2 * th), 0.3 * np.sin(3 * th)])
    four = _rgb(plots.score_paths({"source": base, "muted": 0.6 * base}, tmp_path / "p4.png", highlight=40))
    two = _rgb(plots.score_paths({"source": base[:, :2]}, tmp_path / "p2.png"))
    three = _rgb(plots.score_paths({"source": base}, tmp_path / "p3.png", dims=3, highlight={"source": 10}))
    assert four.shape == (450, 1000, 3) and two.shape == (450, 500, 3) and three.shape == (550, 600, 3)
    for c in plots.COLORS[:2]:
        assert _near(four, _hex(c), tol=10).sum() > 200
    with pytest.raises(MjmotionError, match="at least 3"):
        plots.score_paths({"source": base[:, :2]}, tmp_path / "x.png", dims=3)
    with pytest.raises(MjmotionError, match="highlight"):
        plots.score_paths({"source": base}, tmp_path / "x.png", highlight=500)


def test_hitpoint_grid_colours_launch_elevation(tmp_path):
    import matplotlib as mpl

    gx, gy = np.meshgrid([0.4, 0.5, 0.6], [-0.1, 0.0, 0.1])
    hp = np.column_stack([gx.ravel(), gy.ravel(), np.full(9, 0.05)])
    el = np.linspace(5.0, 35.0, 9)
    dirs = np.column_stack([np.degrees(np.arctan2(gy.ravel(), 1.0)), el])
    img3 = _rgb(plots.hitpoint_grid(hp, dirs, tmp_path / "h3.png", figsize=(11, 4.8), dpi=100))
    img2 = _rgb(plots.hitpoint_grid(hp[:, :2], dirs, tmp_path / "h2.png", figsize=(5.5, 4.8), dpi=100))
    assert img3.shape == (480, 1100, 3) and img2.shape == (480, 550, 3)
    cmap = mpl.colormaps["plasma"]
    lowest, highest = (np.array(cmap(x)[:3]) * 255 for x in (0.0, 1.0))
    # the flattest and the steepest launches get the two ends of the colour scale (arrows + colourbar)
    left = img2[:, :400]  # the axes, not the colourbar
    assert _near(left, lowest, tol=12).sum() > 20 and _near(left, highest, tol=12).sum() > 20
    with pytest.raises(MjmotionError, match="launch_dirs"):
        plots.hitpoint_grid(hp, dirs[:3], tmp_path / "x.png")


def test_ik_blend_draws_both_blends_in_the_seeds_colours(tmp_path):
    t = np.linspace(0, 2, 100)
    time_based = np.sin(np.pi * t / 2) ** 2
    importance = np.clip(1 - np.abs(t - 1) / 0.2, 0, 1)
    img = _rgb(plots.ik_blend(t, {"time-based": time_based, "importance-based": importance}, 1.0, tmp_path / "b.png", distance=np.abs(t - 1)))
    assert img.shape == (340, 750, 3)
    for c in ("#d94040", "#4d8cd9"):  # seed Fig. 2.3: red time-based, blue importance-based
        assert _near(img, _hex(c), tol=10).sum() > 100
    with pytest.raises(MjmotionError, match="values for"):
        plots.ik_blend(t, {"x": importance[:-1]}, 1.0, tmp_path / "x.png")


def test_prop_frames_panels_and_errors(tmp_path):
    seg = np.array([[[0, 0, 1.0], [0.5, 0, 0.1]]] * 3)
    img = _rgb(plots.prop_frames({"source": seg, "adapted": seg + [0, 0, 0.1]}, ["a", "b", "c"], tmp_path / "p.png", ball=np.array([0.5, 0, 0.2])))
    assert img.shape == (360, 960, 3)
    for c in plots.COLORS[:2]:
        assert _near(img, _hex(c), tol=10).sum() > 50
    with pytest.raises(MjmotionError, match=r"\(3, 2, 3\)"):
        plots.prop_frames({"source": seg[:2]}, ["a", "b", "c"], tmp_path / "x.png")
