"""Cross-section areas and local volumes of closed meshes, against shapes with known answers."""

from __future__ import annotations

import numpy as np
import pytest
import trimesh

from mjmotion.skin import measure


@pytest.fixture(scope="module")
def cylinder():
    """A 128-sided cylinder of radius 4 cm and length 50 cm along y, centred on the origin."""
    c = trimesh.creation.cylinder(radius=0.04, height=0.5, sections=128)
    c.apply_transform(trimesh.transformations.rotation_matrix(np.pi / 2, [1, 0, 0]))
    return np.asarray(c.vertices), np.asarray(c.faces)


def test_section_area_of_a_cylinder_across_and_on_a_slant(cylinder):
    v, f = cylinder
    polygon = 0.5 * 128 * 0.04**2 * np.sin(2 * np.pi / 128)  # the 128-gon's exact area
    assert measure.section_area(v, f, np.zeros(3), [0, 1, 0], 0.1) == pytest.approx(polygon, rel=1e-9)
    assert measure.section_area(v, f, np.zeros(3), [0, -3, 0], 0.1) == pytest.approx(polygon, rel=1e-9)  # either side, any length
    tilt = 0.5
    assert measure.section_area(v, f, np.zeros(3), [0, np.cos(tilt), np.sin(tilt)], 0.1) == pytest.approx(polygon / np.cos(tilt), rel=1e-9)
    assert measure.section_area(v, f, np.array([0, 0.4, 0]), [0, 1, 0], 0.1) == 0.0  # past the end


def test_section_area_sees_only_the_part_near_the_point(cylinder):
    v, f = cylinder
    two = np.vstack([v, v + [0.5, 0.0, 0.0]]), np.vstack([f, f + len(v)])  # a second cylinder 50 cm away
    near = measure.section_area(*two, np.zeros(3), [0, 1, 0], 0.1)
    both = measure.section_area(*two, np.array([0.25, 0, 0]), [0, 1, 0], 0.6)
    assert both == pytest.approx(2 * near, rel=1e-9)


def test_volume_in_a_ball_of_a_sphere_and_a_cylinder(cylinder):
    s = trimesh.creation.icosphere(subdivisions=4, radius=0.05)
    sv, sf = np.asarray(s.vertices), np.asarray(s.faces)
    assert measure.volume_in_ball(sv, sf, np.zeros(3), 0.08, 0.003) == pytest.approx(s.volume, rel=3e-3)
    # The lens of the sphere (radius r) and a ball (radius R) centred d away.
    r, big, d = 0.05, 0.05, 0.05
    lens = np.pi * (r + big - d) ** 2 * (d**2 + 2 * d * big - 3 * big**2 + 2 * d * r + 6 * big * r - 3 * r**2) / (12 * d)
    assert measure.volume_in_ball(sv, sf, np.array([d, 0, 0]), big, 0.0015) == pytest.approx(lens, rel=5e-3)
    v, f = cylinder
    g = np.linspace(-0.04, 0.04, 1601)
    x, z = np.meshgrid(g, g)
    inside = x**2 + z**2 <= 0.04**2
    exact = np.sum(2 * np.sqrt(0.08**2 - x[inside] ** 2 - z[inside] ** 2)) * (g[1] - g[0]) ** 2
    assert measure.volume_in_ball(v, f, np.zeros(3), 0.08, 0.002) == pytest.approx(exact, rel=3e-3)
