"""objects.closing against closed forms: open and overlapping surfaces closed where they should be."""
from __future__ import annotations

import numpy as np
import pytest
import trimesh

from objects.closing import DECIMATED_FACES, SPACING_BOUNDS_M, close_surface, grid_spacing


def box_distance(points: np.ndarray, half_extents: np.ndarray) -> np.ndarray:
    """Signed distance of (n, 3) points to an origin-centred box, closed form."""
    q = np.abs(points) - half_extents
    return np.linalg.norm(np.maximum(q, 0.0), axis=1) + np.minimum(q.max(axis=1), 0.0)


def test_a_box_with_a_hole_is_closed_to_within_half_the_spacing():
    box = trimesh.creation.box(extents=(0.1, 0.07, 0.05)).subdivide().subdivide().subdivide()
    centres = box.triangles_center
    hole = np.isclose(centres[:, 2], 0.025) & (np.hypot(centres[:, 0], centres[:, 1]) < 0.008)
    assert hole.sum() >= 2
    holed = trimesh.Trimesh(box.vertices, box.faces[~hole], process=False)
    assert not holed.is_watertight

    closed = close_surface(holed, spacing_m=0.002)
    half = np.array([0.05, 0.035, 0.025])
    assert closed.mesh.is_watertight and closed.mesh.body_count == 1
    assert np.max(np.abs(box_distance(closed.mesh.vertices, half))) <= closed.spacing_m / 2  # edges cut
    edge_length, spacing = 4 * (0.1 + 0.07 + 0.05), closed.spacing_m
    # at most a right triangle of legs one spacing cut off along each edge
    assert 0.1 * 0.07 * 0.05 - edge_length * spacing**2 / 2 <= closed.mesh.volume <= 0.1 * 0.07 * 0.05 + 1e-12
    hole_share = box.area_faces[hole].sum() / box.area
    assert closed.spanned_fraction <= hole_share + 1e-3


def test_a_sphere_with_a_cap_cut_away_keeps_its_radius_and_spans_the_cut():
    radius, cut_deg = 0.05, 20.0
    sphere = trimesh.creation.icosphere(subdivisions=5, radius=radius)
    cut = sphere.triangles_center[:, 2] > radius * np.cos(np.radians(cut_deg))
    closed = close_surface(trimesh.Trimesh(sphere.vertices, sphere.faces[~cut], process=False), spacing_m=0.002)

    vertices = closed.mesh.vertices
    away = vertices[:, 2] < radius * np.cos(np.radians(cut_deg + 5.0))
    sag = radius * (1 - np.cos(np.pi / 160))  # the icosphere's faces: edges of ~1/80 rad
    assert np.max(np.abs(np.linalg.norm(vertices[away], axis=1) - radius)) < 0.05 * closed.spacing_m + sag
    cap_height = radius * (1 - np.cos(np.radians(cut_deg)))
    cap_volume = np.pi * cap_height**2 * (3 * radius - cap_height) / 3
    ball = 4 / 3 * np.pi * radius**3
    assert 0.99 * (ball - cap_volume) < closed.mesh.volume < ball  # spans the cut near its plane
    cap_share = (1 - np.cos(np.radians(cut_deg))) / 2  # of the sphere's area
    assert 0.5 * cap_share < closed.spanned_fraction < 1.1 * cap_share


def test_two_overlapping_open_balls_become_their_union():
    """Two balls, each with a hole and one wound inside out, overlapping: the union's volume, in
    closed form (two balls minus their lens)."""
    radius, gap = 0.03, 0.04
    parts = []
    for x, flip in ((-gap / 2, False), (gap / 2, True)):
        ball = trimesh.creation.icosphere(subdivisions=4, radius=radius)
        keep = ball.triangles_center[:, 1] < radius * 0.95
        faces = ball.faces[keep][:, ::-1] if flip else ball.faces[keep]
        parts.append(trimesh.Trimesh(ball.vertices + [x, 0.0, 0.0], faces, process=False))
    soup = trimesh.util.concatenate(parts)
    closed = close_surface(soup, spacing_m=0.0015)
    lens = np.pi * (4 * radius + gap) * (2 * radius - gap) ** 2 / 12
    union = 2 * 4 / 3 * np.pi * radius**3 - lens
    assert closed.mesh.is_watertight and closed.mesh.body_count == 1
    assert closed.mesh.volume == pytest.approx(union, rel=0.01)


def test_a_flat_sheet_encloses_nothing():
    sheet = trimesh.Trimesh([[0, 0, 0], [0.1, 0, 0], [0, 0.1, 0]], [[0, 1, 2]], process=False)
    with pytest.raises(ValueError, match="enclose no volume"):
        close_surface(sheet)


def test_the_grid_spacing_scales_with_the_object_within_its_bounds():
    low, high = SPACING_BOUNDS_M
    for side, expected in ((0.15, 0.001), (0.03, low), (3.0, high)):
        assert grid_spacing(trimesh.creation.box(extents=(side, side / 2, side / 3))) == pytest.approx(expected)


def test_a_fine_level_set_is_decimated_within_half_a_cell_and_stays_closed():
    radius = 0.05
    sphere = trimesh.creation.icosphere(subdivisions=5, radius=radius)
    cut = sphere.triangles_center[:, 2] > radius * np.cos(np.radians(10.0))
    closed = close_surface(trimesh.Trimesh(sphere.vertices, sphere.faces[~cut], process=False), spacing_m=0.001)
    assert closed.level_set_faces > DECIMATED_FACES[0] >= len(closed.mesh.faces)
    assert closed.mesh.is_watertight and closed.mesh.body_count == 1
    vertices = closed.mesh.vertices
    away = vertices[:, 2] < radius * np.cos(np.radians(15.0))
    assert np.max(np.abs(np.linalg.norm(vertices[away], axis=1) - radius)) <= closed.spacing_m / 2
