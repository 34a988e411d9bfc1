"""An independent forward kinematics for BVH text, written for the tests only.

It shares no code with :mod:`mjmotion`: its own tokenizer, Euler matrices built from
``Rx/Ry/Rz`` products in channel order, and its own hierarchy walk. Positions are returned in
the file's own units and axes; the tests map them to the Z-up world to compare with MuJoCo.
"""

from __future__ import annotations

import numpy as np


def _axis_matrix(axis: str, deg: np.ndarray) -> np.ndarray:
    a = np.radians(deg)
    c, s = np.cos(a), np.sin(a)
    m = np.zeros(a.shape + (3, 3))
    i = "XYZ".index(axis)
    j, k = (i + 1) % 3, (i + 2) % 3  # cyclic, so the sine signs follow the right-hand rule
    m[..., i, i] = 1.0
    m[..., j, j] = c
    m[..., k, k] = c
    m[..., j, k] = -s
    m[..., k, j] = s
    return m


def reference_fk(text: str) -> tuple[list[str], np.ndarray]:
    """Joint names and world positions ``(T, J, 3)`` in file units and axes."""
    lines = text.replace("\r\n", "\n").replace("\r", "\n").lstrip("\ufeff").split("\n")
    names: list[str] = []
    parents: list[int] = []
    offsets: list[list[float]] = []
    channels: list[list[str]] = []
    stack: list[int] = []
    in_end = False
    idx = 0
    while True:
        toks = lines[idx].split()
        idx += 1
        if not toks:
            continue
        if toks[0] == "MOTION":
            break
        if toks[0] in ("ROOT", "JOINT"):
            names.append(" ".join(toks[1:]))
            parents.append(stack[-1] if stack else -1)
            offsets.append([0.0, 0.0, 0.0])
            channels.append([])
            stack.append(len(names) - 1)
            in_end = False
        elif toks[0] == "End":
            in_end = True
        elif toks[0] == "OFFSET" and not in_end:
            offsets[stack[-1]] = [float(x) for x in toks[1:4]]
        elif toks[0] == "CHANNELS":
            channels[stack[-1]] = toks[2:]
        elif toks[0] == "}":
            if in_end:
                in_end = False
            else:
                stack.pop()
    frames = int(lines[idx].split(":")[1])
    data_lines = [ln for ln in lines[idx + 2 :] if ln.strip()][:frames]
    data = np.array([[float(x) for x in ln.split()] for ln in data_lines])
    t = data.shape[0]
    n = len(names)
    world_r = np.zeros((t, n, 3, 3))
    world_p = np.zeros((t, n, 3))
    col = 0
    for j in range(n):
        local_p = np.tile(np.array(offsets[j]), (t, 1))
        local_r = np.tile(np.eye(3), (t, 1, 1))
        for ch in channels[j]:
            v = data[:, col]
            col += 1
            if ch.endswith("position"):
                local_p[:, "XYZ".index(ch[0])] += v
            else:
                local_r = local_r @ _axis_matrix(ch[0], v)
        p = parents[j]
        if p < 0:
            world_r[:, j] = local_r
            world_p[:, j] = local_p
        else:
            world_r[:, j] = world_r[:, p] @ local_r
            world_p[:, j] = world_p[:, p] + np.einsum("tij,tj->ti", world_r[:, p], local_p)
    return names, world_p


def file_to_world(p: np.ndarray, scale: float, up: str = "y") -> np.ndarray:
    """File axes/units → mjmotion's Z-up metres (Y-up files: ``(x, y, z) → (z, x, y)``)."""
    if up == "y":
        p = p[..., [2, 0, 1]]
    return p * scale
