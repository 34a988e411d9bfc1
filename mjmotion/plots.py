"""Figures of the experiments, as PNG files (Matplotlib, Agg backend).

Every function takes plain arrays (so it depends on no other module's internals), writes one
PNG atomically and returns its path. Image size is ``figsize × dpi`` pixels exactly.
"""

from __future__ import annotations

import os
from collections.abc import Mapping, Sequence
from pathlib import Path
from typing import Literal

import numpy as np

from .errors import MjmotionError
from .outputs import write_with

#: Line colours, in order (matches the renderer's character palette where it matters).
COLORS = ("#4d8cd9", "#f29933", "#59bf59", "#b380d9", "#d94040", "#66cccc", "#8c6d31", "#7f7f7f")
#: Colour of paths drawn over a distance grid.
PATH_COLOR = "#ffffff"
CURVE_COLOR = "#ff3030"


def _figure(
    figsize: tuple[float, float], ncols: int = 1, nrows: int = 1, layout: Literal["constrained", "compressed", "tight"] | None = "constrained", **kw
):
    import matplotlib

    matplotlib.use("Agg", force=False)
    from matplotlib.figure import Figure

    # A bare Figure (no pyplot): no global state, safe in threads and scripts.
    fig = Figure(figsize=figsize, layout=layout)
    axes = fig.subplots(nrows, ncols, squeeze=False, **kw)
    return fig, axes


def _save(fig, out: str | os.PathLike[str], dpi: int, metadata: Mapping[str, str] | None = None) -> Path:
    path = Path(out)
    if path.suffix.lower() != ".png":
        raise MjmotionError(f"{path}: plots are written as PNG; expected a .png path")
    write_with(path, lambda tmp: fig.savefig(tmp, format="png", dpi=dpi, metadata=dict(metadata) if metadata else None))
    return path


def png_text(path: str | os.PathLike[str]) -> dict[str, str]:
    """The text entries of a PNG (what :func:`histograms` wrote as ``metadata``); empty when the file
    is missing or not a readable PNG."""
    from PIL import Image, UnidentifiedImageError

    try:
        with Image.open(path) as im:
            return {str(k): str(v) for k, v in getattr(im, "text", {}).items()}
    except (OSError, UnidentifiedImageError, ValueError):
        return {}


def _array(name: str, value, ndim: int, cols: int | tuple[int, ...] | None = None) -> np.ndarray:
    a = np.asarray(value, dtype=float)
    if a.ndim != ndim or (cols is not None and a.shape[-1] not in np.atleast_1d(cols)):
        want = f"{ndim}-D" + ("" if cols is None else f" with {' or '.join(map(str, np.atleast_1d(cols)))} columns")
        raise MjmotionError(f"{name}: expected a {want} array, got shape {a.shape}")
    if not np.all(np.isfinite(a)):
        raise MjmotionError(f"{name}: contains NaN or infinite values")
    return a


def distance_grid(
    grid: np.ndarray,
    path: np.ndarray | None,
    curve: np.ndarray | None,
    out: str | os.PathLike[str],
    *,
    labels: tuple[str, str] = ("frame of A", "frame of B"),
    title: str = "",
    figsize: tuple[float, float] = (6.0, 5.0),
    dpi: int = 100,
) -> Path:
    """The frame-distance grid with the optimal path and the fitted timewarp curve (seed 004 Fig. 5, 9).

    Args:
        grid: ``(nA, nB)`` distances; ``grid[i, j]`` compares frame ``i`` of A with frame ``j`` of B.
            Drawn with A along x and B along y, frame 0 at the bottom left; dark = similar.
        path: ``(K, 2)`` frame pairs ``(i, j)`` of the discrete path (white), or ``None``.
        curve: ``(M, 2)`` points ``(i, j)`` of the continuous timewarp curve (red), or ``None``.
        out: the ``.png`` to write.
    """
    g = _array("grid", grid, 2)
    fig, ax = _figure(figsize)
    ax = ax[0, 0]
    na, nb = g.shape
    im = ax.imshow(g.T, origin="lower", cmap="viridis", aspect="auto", extent=(-0.5, na - 0.5, -0.5, nb - 0.5), interpolation="nearest")
    fig.colorbar(im, ax=ax, label="distance")
    if path is not None:
        p = _array("path", path, 2, 2)
        ax.plot(p[:, 0], p[:, 1], color=PATH_COLOR, lw=1.5, label="path")
    if curve is not None:
        c = _array("curve", curve, 2, 2)
        ax.plot(c[:, 0], c[:, 1], color=CURVE_COLOR, lw=1.5, ls="--", label="timewarp curve")
    if path is not None or curve is not None:
        # Outside the axes, so nothing hides the grid; a dark box because the path is white.
        fig.legend(loc="outside upper left", ncols=2, fontsize=8, facecolor="#333333", labelcolor="white", framealpha=1.0)
    ax.set_xlim(-0.5, na - 0.5)
    ax.set_ylim(-0.5, nb - 0.5)
    ax.set_xlabel(labels[0])
    ax.set_ylabel(labels[1])
    if title:
        ax.set_title(title)
    return _save(fig, out, dpi)


def weight_curves(
    times: np.ndarray,
    weights: np.ndarray,
    out: str | os.PathLike[str],
    *,
    labels: Sequence[str] | None = None,
    title: str = "",
    figsize: tuple[float, float] = (7.0, 3.0),
    dpi: int = 100,
) -> Path:
    """Blend weights over time, one line per input clip, and their sum (dashed).

    Args:
        times: ``(T,)`` seconds.
        weights: ``(T, N)`` weights of ``N`` clips (or ``(T,)`` for one).
    """
    t = _array("times", times, 1)
    w = np.asarray(weights, dtype=float)
    w = _array("weights", w[:, None] if w.ndim == 1 else w, 2)
    if w.shape[0] != t.shape[0]:
        raise MjmotionError(f"weights: {w.shape[0]} rows for {t.shape[0]} times")
    names = list(labels) if labels is not None else [f"clip {k}" for k in range(w.shape[1])]
    if len(names) != w.shape[1]:
        raise MjmotionError(f"labels: {len(names)} labels for {w.shape[1]} weight columns")
    fig, ax = _figure(figsize)
    ax = ax[0, 0]
    for k in range(w.shape[1]):
        ax.plot(t, w[:, k], color=COLORS[k % len(COLORS)], lw=1.8, label=names[k])
    if w.shape[1] > 1:
        ax.plot(t, w.sum(axis=1), color="#444444", lw=1.0, ls="--", label="sum")
    ax.set_xlabel("time (s)")
    ax.set_ylabel("weight")
    ax.set_xlim(t[0], t[-1])
    ax.legend(fontsize=8, loc="best")
    ax.grid(alpha=0.3)
    if title:
        ax.set_title(title)
    return _save(fig, out, dpi)


def foot_contacts(
    times: np.ndarray,
    heights: np.ndarray,
    speeds: np.ndarray,
    contacts: np.ndarray,
    out: str | os.PathLike[str],
    *,
    labels: tuple[str, str] = ("left", "right"),
    title: str = "",
    figsize: tuple[float, float] = (8.0, 4.5),
    dpi: int = 100,
) -> Path:
    """Foot height and speed over time, with each foot's contact frames shaded in its colour.

    Args:
        times: ``(T,)`` seconds.
        heights: ``(T, 2)`` metres above the floor (left, right).
        speeds: ``(T, 2)`` metres per second, horizontal.
        contacts: ``(T, 2)`` bool, the foot is planted.
    """
    t = _array("times", times, 1)
    h = _array("heights", heights, 2, 2)
    s = _array("speeds", speeds, 2, 2)
    c = np.asarray(contacts, dtype=bool)
    for name, a in (("heights", h), ("speeds", s), ("contacts", c)):
        if a.shape != (t.shape[0], 2):
            raise MjmotionError(f"{name}: expected shape ({t.shape[0]}, 2) to match times, got {a.shape}")
    fig, axes = _figure(figsize, nrows=2, sharex=True)
    for ax, values, ylabel in ((axes[0, 0], h, "foot height (m)"), (axes[1, 0], s, "foot speed (m/s)")):
        for k in range(2):
            color = COLORS[k]
            ax.plot(t, values[:, k], color=color, lw=1.5, label=labels[k])
            # Shade whole frames: contact k covers [t_i - dt/2, t_i + dt/2], drawn as one filled step.
            ax.fill_between(
                t,
                0.5 * k,
                0.5 * (k + 1),
                where=c[:, k],
                step="mid",
                color=color,
                alpha=0.25,
                lw=0,
                transform=ax.get_xaxis_transform(),
                label=f"{labels[k]} contact" if ax is axes[0, 0] else None,
            )
        ax.set_ylabel(ylabel)
        ax.grid(alpha=0.3)
    fig.legend(*axes[0, 0].get_legend_handles_labels(), fontsize=8, ncols=4, loc="outside upper right")
    axes[1, 0].set_xlabel("time (s)")
    axes[1, 0].set_xlim(t[0], t[-1])
    if title:
        axes[0, 0].set_title(title)
    return _save(fig, out, dpi)


def score_paths(
    paths: Mapping[str, np.ndarray],
    out: str | os.PathLike[str],
    dims: int = 2,
    *,
    highlight: int | Mapping[str, int] | None = None,
    title: str = "",
    figsize: tuple[float, float] | None = None,
    dpi: int = 100,
) -> Path:
    """Paths of clips through principal-component space (seed 003 Fig. 2.12, 3.7).

    ``dims=2``: PC1–PC2 and, with at least four components, PC3–PC4 beside it (Fig. 2.12 shows
    the top four components as two 2-D plots); ``dims=3``: PC1–PC3 in 3-D.

    Args:
        paths: name → ``(T, k)`` scores of one clip, ``k ≥ dims``; drawn in :data:`COLORS` order.
        highlight: a frame (e.g. the hit point) to mark on every path, or one frame per name.
    """
    if dims not in (2, 3):
        raise MjmotionError(f"score_paths: dims must be 2 or 3, got {dims}")
    if not paths:
        raise MjmotionError("score_paths: no paths to plot")
    arrays = {name: _array(f"paths[{name!r}]", p, 2) for name, p in paths.items()}
    k = min(a.shape[1] for a in arrays.values())
    if k < dims:
        raise MjmotionError(f"score_paths: {dims}-D plot needs at least {dims} components, got {k}")
    marks: dict[str, int] = {}
    if isinstance(highlight, Mapping):
        marks = {n: int(f) for n, f in highlight.items()}
    elif highlight is not None:
        marks = {n: int(highlight) for n in arrays}
    for n, f in marks.items():
        if n not in arrays or not (-arrays[n].shape[0] <= f < arrays[n].shape[0]):
            raise MjmotionError(f"score_paths: highlight frame {f} is not a frame of path {n!r}")
    if dims == 3:
        fig, axes = _figure(figsize or (6.0, 5.5), subplot_kw={"projection": "3d"})
        ax = axes[0, 0]
        for i, (name, a) in enumerate(arrays.items()):
            color = COLORS[i % len(COLORS)]
            ax.plot(a[:, 0], a[:, 1], a[:, 2], color=color, lw=1.5, label=name)
            ax.scatter(*a[0, :3], color=color, marker="o", s=20)
            if name in marks:
                ax.scatter(*a[marks[name], :3], color=color, marker="*", s=120, edgecolor="black")
        ax.set_xlabel("PC1")
        ax.set_ylabel("PC2")
        ax.set_zlabel("PC3")
        ax.legend(fontsize=8)
    else:
        pairs = [(0, 1), (2, 3)] if k >= 4 else [(0, 1)]
        fig, axes = _figure(figsize or (5.0 * len(pairs), 4.5), ncols=len(pairs))
        for (x, y), ax in zip(pairs, axes[0]):
            for i, (name, a) in enumerate(arrays.items()):
                color = COLORS[i % len(COLORS)]
                ax.plot(a[:, x], a[:, y], color=color, lw=1.5, label=name)
                ax.plot(a[0, x], a[0, y], "o", color=color, ms=5)
                if name in marks:
                    ax.plot(a[marks[name], x], a[marks[name], y], "*", color=color, ms=14, mec="black")
            ax.set_xlabel(f"PC{x + 1}")
            ax.set_ylabel(f"PC{y + 1}")
            ax.grid(alpha=0.3)
        axes[0, 0].legend(fontsize=8)
    if title:
        fig.suptitle(title)
    return _save(fig, out, dpi)


def hitpoint_grid(
    hit_points: np.ndarray,
    launch_dirs: np.ndarray,
    out: str | os.PathLike[str],
    *,
    title: str = "",
    arrow_length: float | None = None,
    figsize: tuple[float, float] | None = None,
    dpi: int = 100,
) -> Path:
    """Hit points and the ball's launch directions from each (seed 003 Fig. 2.6).

    Args:
        hit_points: ``(N, 2)`` ground-plane ``(x, y)`` or ``(N, 3)`` world ``(x, y, z)`` metres.
        launch_dirs: ``(N, 2)`` azimuth (from +x toward +y) and elevation, degrees.
        arrow_length: metres for a horizontal launch (default: the grid's spacing scale).

    Top view: an arrow from each hit point along the launch azimuth, its length the horizontal
    part ``cos(elevation)``, coloured by elevation. With ``(N, 3)`` points a side view (x–z)
    shows the rise.
    """
    p = _array("hit_points", hit_points, 2, (2, 3))
    d = _array("launch_dirs", launch_dirs, 2, 2)
    if d.shape[0] != p.shape[0]:
        raise MjmotionError(f"launch_dirs: {d.shape[0]} directions for {p.shape[0]} hit points")
    az, el = np.radians(d[:, 0]), np.radians(d[:, 1])
    direction = np.column_stack([np.cos(el) * np.cos(az), np.cos(el) * np.sin(az), np.sin(el)])
    if arrow_length is None:
        extent = float(np.ptp(p[:, :2], axis=0).max()) if p.shape[0] > 1 else 0.0
        arrow_length = 0.6 * extent / max(np.sqrt(p.shape[0]) - 1, 1) if extent > 0 else 0.1
    views = [((0, 1), "x (m)", "y (m)", "top view")]
    if p.shape[1] == 3:
        views.append(((0, 2), "x (m)", "z (m)", "side view"))
    fig, axes = _figure(figsize or (5.5 * len(views), 4.8), ncols=len(views))
    import matplotlib as mpl

    lo_el, hi_el = float(d[:, 1].min()), float(d[:, 1].max())
    spread = max(hi_el - lo_el, 1.0)  # one elevation for all: a 1° window keeps the colour mid-scale
    norm = mpl.colors.Normalize(vmin=(lo_el + hi_el - spread) / 2, vmax=(lo_el + hi_el + spread) / 2)
    cmap = mpl.colormaps["plasma"]
    for ((i, j), xl, yl, name), ax in zip(views, axes[0]):
        ax.scatter(p[:, i], p[:, j], color="black", s=18, zorder=3, label="hit point")
        ax.quiver(
            p[:, i],
            p[:, j],
            direction[:, i] * arrow_length,
            direction[:, j] * arrow_length,
            color=cmap(norm(d[:, 1])),
            angles="xy",
            scale_units="xy",
            scale=1,
            width=0.006,
            zorder=2,
        )
        pts = np.concatenate([p[:, [i, j]], p[:, [i, j]] + direction[:, [i, j]] * arrow_length])
        lo, hi = pts.min(axis=0), pts.max(axis=0)
        pad = 0.1 * max(float((hi - lo).max()), 1e-3)
        ax.set_xlim(lo[0] - pad, hi[0] + pad)
        ax.set_ylim(lo[1] - pad, hi[1] + pad)
        ax.set_aspect("equal", adjustable="box")
        ax.set_xlabel(xl)
        ax.set_ylabel(yl)
        ax.set_title(name, fontsize=10)
        ax.grid(alpha=0.3)
    fig.colorbar(mpl.cm.ScalarMappable(norm=norm, cmap=cmap), ax=axes[0, -1], label="launch elevation (deg)")
    if title:
        fig.suptitle(title)
    return _save(fig, out, dpi)


def ik_blend(
    times: np.ndarray,
    curves: Mapping[str, np.ndarray],
    hit_time: float,
    out: str | os.PathLike[str],
    *,
    distance: np.ndarray | None = None,
    title: str = "",
    figsize: tuple[float, float] = (7.5, 3.4),
    dpi: int = 100,
) -> Path:
    """IK blend parameters over a shot (seed 003 Fig. 2.3: time-based red, importance-based blue).

    Args:
        times: ``(T,)`` seconds; curves: name → ``(T,)`` blend in [0, 1], drawn in the seed's colours
            (red, blue) and then :data:`COLORS`.
        hit_time: seconds, marked with a vertical line.
        distance: ``(T,)`` metres, the effector's distance to the hit point, on a second axis.
    """
    t = _array("times", times, 1)
    fig, ax = _figure(figsize)
    ax = ax[0, 0]
    colours = ["#d94040", "#4d8cd9", *COLORS[2:]]
    for i, (name, c) in enumerate(curves.items()):
        y = _array(f"curves[{name!r}]", c, 1)
        if y.shape != t.shape:
            raise MjmotionError(f"curves[{name!r}]: {y.shape[0]} values for {t.shape[0]} times")
        ax.plot(t, y, color=colours[i % len(colours)], lw=1.8, label=name)
    ax.axvline(hit_time, color="#444444", lw=1.0, ls=":", label="hit frame")
    ax.set_xlabel("time (s)")
    ax.set_ylabel("IK blend")
    ax.set_ylim(-0.03, 1.05)
    ax.set_xlim(t[0], t[-1])
    ax.grid(alpha=0.3)
    if distance is not None:
        d = _array("distance", distance, 1)
        ax2 = ax.twinx()
        ax2.plot(t, d, color="#7f7f7f", lw=1.0, ls="--", label="effector to hit point (m)")
        ax2.set_ylabel("distance to the hit point (m)", color="#7f7f7f")
        h1, l1 = ax.get_legend_handles_labels()
        h2, l2 = ax2.get_legend_handles_labels()
        ax.legend(h1 + h2, l1 + l2, fontsize=8, loc="upper right")
    else:
        ax.legend(fontsize=8, loc="upper right")
    if title:
        ax.set_title(title, fontsize=10)
    return _save(fig, out, dpi)


def prop_frames(
    segments: Mapping[str, np.ndarray],
    frame_labels: Sequence[str],
    out: str | os.PathLike[str],
    *,
    ball: np.ndarray | None = None,
    axes: np.ndarray | None = None,
    axis_labels: tuple[str, str] = ("along the swing (m)", "up (m)"),
    title: str = "",
    dpi: int = 100,
) -> Path:
    """A prop (bat, club) at a few frames of several versions of a shot (seed 003 Fig. 2.7).

    Args:
        segments: version → ``(F, 2, 3)`` world endpoints (grip, head) of the prop at ``F`` frames;
            one panel per frame, versions in :data:`COLORS` order.
        frame_labels: ``F`` panel titles.
        ball: ``(3,)`` the ball (drawn in every panel).
        axes: ``(2, 3)`` unit axes of the view (default: world x and z).
    """
    segs = {n: np.asarray(v, dtype=float) for n, v in segments.items()}
    f = len(frame_labels)
    for n, v in segs.items():
        if v.shape != (f, 2, 3) or not np.all(np.isfinite(v)):
            raise MjmotionError(f"segments[{n!r}]: expected a finite ({f}, 2, 3) array, got shape {v.shape}")
    view = np.array([[1.0, 0, 0], [0, 0, 1.0]]) if axes is None else _array("axes", axes, 2, 3)
    fig, panels = _figure((3.2 * f, 3.6), ncols=f, sharex=True, sharey=True)
    pts = np.concatenate([v.reshape(-1, 3) for v in segs.values()] + ([np.asarray(ball, float)[None]] if ball is not None else []))
    xy = pts @ view.T
    lo, hi = xy.min(axis=0), xy.max(axis=0)
    pad = 0.1 * float((hi - lo).max())
    for k, ax in enumerate(panels[0]):
        for i, (name, v) in enumerate(segs.items()):
            p = v[k] @ view.T
            ax.plot(p[:, 0], p[:, 1], color=COLORS[i % len(COLORS)], lw=3, solid_capstyle="round", label=name)
            ax.plot(p[1, 0], p[1, 1], "o", color=COLORS[i % len(COLORS)], ms=4)
        if ball is not None:
            b = np.asarray(ball, float) @ view.T
            ax.plot(b[0], b[1], "o", color="#d94040", ms=8, mec="black", label="ball")
        ax.set_title(frame_labels[k], fontsize=10)
        ax.set_xlim(lo[0] - pad, hi[0] + pad)
        ax.set_ylim(lo[1] - pad, hi[1] + pad)
        ax.set_aspect("equal", adjustable="box")
        ax.set_xlabel(axis_labels[0])
        ax.grid(alpha=0.3)
    panels[0, 0].set_ylabel(axis_labels[1])
    panels[0, 0].legend(fontsize=8, loc="best")
    if title:
        fig.suptitle(title)
    return _save(fig, out, dpi)


def skinning_artefacts(
    series: Mapping[str, Mapping[str, np.ndarray]],
    views: Mapping[str, np.ndarray],
    faces: np.ndarray,
    centre: np.ndarray,
    reach: float,
    out: str | os.PathLike[str],
    *,
    dpi: int = 100,
) -> Path:
    """Skinning artefacts: kept area and volume against angle, and the skin at the joint.

    Args:
        series: ``{"twist": {...}, "bend": {...}}``, each with ``angles`` ``(A,)`` and
            ``lbs_area``, ``dqs_area``, ``lbs_volume``, ``dqs_volume`` ``(A,)`` in % of the bind pose.
        views: ``{label: (V, 3) vertices}`` of one pose to draw near the joint (e.g. LBS and DQS at 180°).
        faces: ``(F, 3)`` of the mesh; centre: ``(3,)`` the joint; reach: metres drawn around it.
    """
    from mpl_toolkits.mplot3d.art3d import Poly3DCollection

    fig, axes = _figure((11.0, 7.5), ncols=2, nrows=2)
    for ax, kind in zip(axes[0], ("twist", "bend")):
        s = series[kind]
        angles = _array(f"{kind} angles", s["angles"], 1)
        for k, (key, label, style) in enumerate(
            (("lbs_area", "LBS area", "-"), ("dqs_area", "DQS area", "-"), ("lbs_volume", "LBS volume", "--"), ("dqs_volume", "DQS volume", "--"))
        ):
            ax.plot(angles, np.asarray(s[key], dtype=float), style, color=COLORS[k % 2], marker="o", ms=3, label=label)  # NaN: not measured
        ax.axhline(90.0, color="#999999", lw=0.8, ls=":")
        ax.set_xlabel(f"elbow {kind}, degrees")
        ax.set_ylabel("% of the bind pose")
        ax.set_title(f"forearm {kind}: cross-section area and volume at the elbow")
        ax.legend(loc="lower left", fontsize=8)
    for i, (label, verts) in enumerate(views.items()):
        ax = axes[1, i]
        ax.remove()
        ax = fig.add_subplot(2, 2, 3 + i, projection="3d")
        v = _array(label, verts, 2, 3)
        near = np.all(np.abs(v[faces] - centre).max(axis=2) < reach, axis=1)
        tri = v[faces[near]]
        n = np.cross(tri[:, 1] - tri[:, 0], tri[:, 2] - tri[:, 0])
        shade = 0.35 + 0.65 * np.clip((n / np.maximum(np.linalg.norm(n, axis=1, keepdims=True), 1e-12)) @ np.array([0.3, -0.5, 0.8]), 0, 1)
        ax.add_collection3d(Poly3DCollection(tri, facecolors=np.outer(shade, [0.30, 0.55, 0.85]), edgecolor="none"))
        for k, lim in enumerate((ax.set_xlim, ax.set_ylim, ax.set_zlim)):
            lim(centre[k] - 0.55 * reach, centre[k] + 0.55 * reach)
        ax.set_box_aspect((1, 1, 1))
        ax.view_init(elev=20, azim=-60)
        ax.set_title(f"{label}, 180° twist: the skin at the elbow")
        ax.set_axis_off()
    return _save(fig, out, dpi)


def histograms(
    values: Mapping[str, Sequence[float]],
    out: str | os.PathLike[str],
    *,
    title: str = "",
    bins: int = 30,
    dpi: int = 100,
    metadata: Mapping[str, str] | None = None,
) -> Path:
    """One small histogram per named series (finite values only; a series with none is skipped), on a grid;
    ``metadata``: text entries stored in the PNG (:func:`png_text` reads them back)."""
    series = {k: a[np.isfinite(a)] for k, v in values.items() if (a := np.asarray(v, dtype=float)).size}
    series = {k: a for k, a in series.items() if a.size}
    if not series:
        raise MjmotionError(f"{out}: no finite values to draw")
    ncols = min(4, len(series))
    nrows = -(-len(series) // ncols)
    # A fixed layout: the constrained one takes a second more on a grid of thirty panels.
    fig, axes = _figure((3.2 * ncols, 2.3 * nrows + 0.4), ncols=ncols, nrows=nrows, layout=None)
    fig.subplots_adjust(left=0.05, right=0.98, bottom=0.04, top=1 - 0.5 / (2.3 * nrows + 0.4), hspace=0.55, wspace=0.3)
    for ax, (name, a) in zip(axes.flat, series.items()):
        counts, edges = np.histogram(a, bins=bins)
        ax.stairs(counts, edges, fill=True, color=COLORS[0])  # one artist per panel (ax.hist makes one per bar)
        # Fixed ticks (the range, the tallest bin) and a title at a fixed height: Matplotlib's tick locators
        # and its title placement, which measures every tick label, took two thirds of the drawing.
        top = int(counts.max())
        ax.set_xlim(edges[0], edges[-1])
        ax.set_ylim(0, 1.08 * top)
        ax.set_xticks([edges[0], edges[-1]], [f"{edges[0]:.4g}", f"{edges[-1]:.4g}"])
        ax.set_yticks([0, top])
        ax.set_title(name, fontsize=8, y=1.0, pad=3)
        ax.tick_params(labelsize=7)
    for ax in list(axes.flat)[len(series) :]:
        ax.set_visible(False)
    if title:
        fig.suptitle(title, fontsize=10)
    return _save(fig, out, dpi, metadata)
