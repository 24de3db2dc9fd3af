"""Figures: each PNG is written and valid, and what it shows can be checked against the data.

Pixel checks render the Figure twin of each function to an RGBA array and read colours at data
coordinates; artist checks read the plotted values back from the Figure.
"""
import struct

import numpy as np
import pytest
import trimesh

from reconstruction.figures import (contact_intervals, distances_to_surface, edge_error_view,
                                    edge_error_view_figure, edge_piece_errors, error_colours,
                                    error_coloured_views, error_coloured_views_figure,
                                    error_vs_touches, error_vs_touches_figure,
                                    normal_error_vs_tilt, normal_error_vs_tilt_figure,
                                    orientation_change_deg, potential_slice,
                                    potential_slice_figure, running_baseline, sensor_traces,
                                    sensor_traces_figure)
from reconstruction.figures.canvas import rendered_rgba
from reconstruction.figures.simplify import simplify_to
from reconstruction.gpis import GPIS
from objects.features import sharp_edges
from sensor.contact_detection import ContactEvent, PressureContactDetector
from sensor.reading import Reading
from reconstruction.synthetic_contacts import sphere_contacts as exact_sphere_contacts

RADIUS = 0.03
BOUNDS = ((-0.05,) * 3, (0.05,) * 3)


# ---------------------------------------------------------------------- helpers
def png_size(path) -> tuple[int, int]:
    """(width, height) from a PNG's IHDR chunk; fails unless the file is a PNG."""
    data = path.read_bytes()
    assert data[:8] == b"\x89PNG\r\n\x1a\n", "not a PNG signature"
    assert data[12:16] == b"IHDR"
    assert data[-8:-4] == b"IEND"
    return struct.unpack(">II", data[16:24])


def assert_png(path, width=(500, 2400), height=(350, 1000)):
    w, h = png_size(path)
    assert width[0] <= w <= width[1] and height[0] <= h <= height[1], (w, h)


def pixel_at(rgba, ax, x, y):
    """Mean RGB (0-255) of a 5 x 5 patch at data point (x, y) of a drawn axes."""
    px, py = ax.transData.transform((x, y))
    row, col = rgba.shape[0] - int(round(py)), int(round(px))
    return rgba[row - 2:row + 3, col - 2:col + 3, :3].reshape(-1, 3).mean(0)


def red_pixels(rgba, axes) -> int:
    """Count of saturated red pixels inside the given axes' boxes."""
    count = 0
    for ax in axes:
        x0, y0, x1, y1 = ax.bbox.extents
        rows = slice(rgba.shape[0] - int(y1), rgba.shape[0] - int(y0))
        patch = rgba[rows, int(x0):int(x1), :3].astype(int)
        count += int(np.sum((patch[..., 0] > 140) & (patch[..., 1] < 90) & (patch[..., 2] < 90)))
    return count


def sphere_contacts(n, seed=0):
    return exact_sphere_contacts(n, RADIUS, seed)


@pytest.fixture(scope="module")
def sphere():
    return trimesh.creation.icosphere(subdivisions=3, radius=RADIUS)


@pytest.fixture(scope="module")
def sphere_gps():
    points, normals = sphere_contacts(60)
    with_normals = GPIS(noise=1e-4, bounds=BOUNDS).fit(points, normals)
    without = GPIS(use_normals=False, noise=1e-3, bounds=BOUNDS).fit(points)
    return with_normals, without


# ---------------------------------------------------------------------- potential slice
def test_slice_is_inside_colour_at_centre_and_outside_colour_at_corner(sphere_gps, sphere, tmp_path):
    figure = potential_slice_figure(*sphere_gps, sphere, plane="z", offset_m=0.0)
    rgba = rendered_rgba(figure)
    panels = [ax for ax in figure.axes if ax.images]
    assert len(panels) == 2
    for ax in panels:
        (x0, x1), (y0, y1) = ax.get_xlim(), ax.get_ylim()
        r, g, b = pixel_at(rgba, ax, 0.0, 0.0)
        assert r > b + 60, f"centre should be red (inside), got {(r, g, b)}"
        r, g, b = pixel_at(rgba, ax, x0 + 0.03 * (x1 - x0), y0 + 0.03 * (y1 - y0))
        assert b > r + 60, f"corner should be blue (outside), got {(r, g, b)}"
    path = potential_slice(*sphere_gps, sphere, plane="z", offset_m=0.0, path=tmp_path / "s.png")
    assert path == tmp_path / "s.png"
    assert_png(path)


def test_slice_draws_the_truth_section_the_zero_level_and_contacts_near_the_plane(sphere_gps, sphere):
    offset, band = 0.01, 3e-3
    figure = potential_slice_figure(sphere_gps[0], None, sphere, plane="y", offset_m=offset,
                                    contact_band_m=band)
    ax = next(ax for ax in figure.axes if ax.images)
    section_radius_mm = 1e3 * np.sqrt(RADIUS**2 - offset**2)
    dashed = [line for line in ax.lines if line.get_linestyle() == "--"]
    assert dashed
    for line in dashed:
        radius = np.hypot(line.get_xdata(), line.get_ydata())
        # the icosphere's chords lie up to ~0.4 mm inside the sphere
        assert np.all(np.abs(radius - section_radius_mm) < 0.6)
    contour = next(c for c in ax.collections if type(c).__name__ == "QuadContourSet")
    vertices = np.vstack([p.vertices for p in contour.get_paths() if len(p.vertices)])
    assert np.abs(np.hypot(vertices[:, 0], vertices[:, 1]) - section_radius_mm).max() < 1.0
    points = sphere_gps[0].contact_points
    expected = points[np.abs(points[:, 1] - offset) <= band]
    scatter = next(c for c in ax.collections if type(c).__name__ == "PathCollection")
    np.testing.assert_allclose(np.sort(scatter.get_offsets()[:, 0]), np.sort(1e3 * expected[:, 0]))
    quiver = next(c for c in ax.collections if type(c).__name__ == "Quiver")
    assert quiver.N == len(expected) > 0


def test_slice_rejects_bad_input(sphere_gps, sphere, tmp_path):
    with pytest.raises(ValueError, match="both"):
        potential_slice(None, None, sphere, path=tmp_path / "a.png")
    with pytest.raises(ValueError, match="plane"):
        potential_slice(sphere_gps[0], None, sphere, plane="w", path=tmp_path / "a.png")
    with pytest.raises(ValueError, match="outside"):
        potential_slice(sphere_gps[0], None, sphere, offset_m=0.5, path=tmp_path / "a.png")
    with pytest.raises(ValueError, match=".png"):
        potential_slice(sphere_gps[0], None, sphere, path=tmp_path / "a.jpg")
    assert not list(tmp_path.iterdir())


# ---------------------------------------------------------------------- error colouring
def test_error_colours_run_green_through_yellow_to_red_and_clip():
    colours = error_colours(np.array([0.0, 1e-3, 2e-3, 5e-3]), max_error_m=2e-3)
    green, yellow, red, beyond = colours[:, :3]
    assert green[1] > green[0] + 0.3 and green[1] > green[2] + 0.15
    assert yellow[0] > 0.8 and yellow[1] > 0.8 and yellow[2] < 0.8
    assert red[0] > red[1] + 0.4 and red[0] > red[2] + 0.4
    np.testing.assert_array_equal(beyond, red)
    from matplotlib.colors import rgb_to_hsv

    hue = rgb_to_hsv(error_colours(np.linspace(0, 2e-3, 50), 2e-3)[:, :3])[:, 0]
    hue = np.where(hue > 0.5, hue - 1.0, hue)  # dark red sits just below 0 deg, not at 350
    assert np.all(np.diff(hue) <= 1e-9), "hue must move steadily from green to red"
    assert colours.shape == (4, 4) and np.all(colours[:, 3] == 1)


def test_error_colours_reject_bad_input():
    with pytest.raises(ValueError, match=">= 0"):
        error_colours([-1e-3], 1e-3)
    with pytest.raises(ValueError, match="NaN"):
        error_colours([np.nan], 1e-3)
    with pytest.raises(ValueError, match="max_error_m"):
        error_colours([1e-3], 0.0)
    with pytest.raises(ValueError, match="shape"):
        error_colours(np.zeros((2, 2)), 1e-3)


def test_distances_to_surface_match_a_box_in_closed_form():
    box = trimesh.creation.box((0.04, 0.04, 0.04))
    points = np.array([[0, 0, 0.025], [0.03, 0, 0], [0.03, 0.03, 0.02], [0.0, 0.0, 0.02]])
    expected = [0.005, 0.01, np.hypot(0.01, 0.01), 0.0]
    np.testing.assert_allclose(distances_to_surface(points, box), expected, atol=1e-12)


# ---------------------------------------------------------------------- 3D error views
def displaced_sphere(sphere, shift_m=5e-3):
    """A copy of the sphere with its +x cap (x > 0.6 R) pushed outward by shift_m."""
    vertices = sphere.vertices.copy()
    cap = vertices[:, 0] > 0.6 * RADIUS
    vertices[cap] *= (RADIUS + shift_m) / RADIUS
    return trimesh.Trimesh(vertices, sphere.faces, process=False)


def test_error_views_colour_a_displaced_region_red(sphere, tmp_path):
    view_from_plus_x = ((10.0, 0.0),)
    contacts = sphere_contacts(30)[0]
    displaced = error_coloured_views_figure(displaced_sphere(sphere), sphere, contacts,
                                            views=view_from_plus_x, max_error_m=3e-3)
    control = error_coloured_views_figure(sphere, sphere, contacts, views=view_from_plus_x,
                                          max_error_m=3e-3)
    red_displaced = red_pixels(rendered_rgba(displaced), displaced.axes[:1])
    red_control = red_pixels(rendered_rgba(control), control.axes[:1])
    assert red_displaced > 2000 and red_control < 20, (red_displaced, red_control)
    path = error_coloured_views(displaced_sphere(sphere), sphere, contacts, tmp_path / "v.png",
                                max_error_m=3e-3)
    assert_png(path, width=(1200, 2400))


def test_error_view_numbers_do_not_depend_on_the_drawing_simplification():
    truth = trimesh.creation.icosphere(subdivisions=4, radius=RADIUS)
    fine = displaced_sphere(truth)
    titles = [error_coloured_views_figure(fine, truth, np.zeros((0, 3)), views=((30, 45),),
                                          max_faces=budget).get_suptitle()
              for budget in (300, 10 * len(fine.faces))]
    assert titles[0] == titles[1]
    assert "max 5.00 mm" in titles[0]


def test_error_views_reject_bad_input(sphere, tmp_path):
    with pytest.raises(ValueError, match="contacts_m"):
        error_coloured_views(sphere, sphere, np.zeros((3, 2)), tmp_path / "v.png")
    with pytest.raises(ValueError, match="views"):
        error_coloured_views(sphere, sphere, np.zeros((0, 3)), tmp_path / "v.png", views=())
    with pytest.raises(ValueError, match="trimesh"):
        error_coloured_views(np.zeros((3, 3)), sphere, np.zeros((0, 3)), tmp_path / "v.png")
    with pytest.raises(ValueError, match="max_error_m"):
        error_coloured_views(sphere, sphere, np.zeros((0, 3)), tmp_path / "v.png", max_error_m=-1)


def test_simplification_respects_the_face_budget_and_keeps_the_shape(sphere):
    fine = trimesh.creation.icosphere(subdivisions=5, radius=RADIUS)
    vertices, faces, cluster = simplify_to(fine.vertices, fine.faces, 2000)
    assert 200 < len(faces) <= 2000
    assert np.abs(np.linalg.norm(vertices, axis=1) - RADIUS).max() < 0.1 * RADIUS
    normals = np.cross(vertices[faces[:, 1]] - vertices[faces[:, 0]],
                       vertices[faces[:, 2]] - vertices[faces[:, 0]])
    outward = np.sum(normals * vertices[faces].mean(1), axis=1) > 0
    assert outward.mean() > 0.97
    assert cluster.shape == (len(fine.vertices),)
    assert np.linalg.norm(vertices[cluster] - fine.vertices, axis=1).max() < 0.2 * RADIUS


def test_edge_errors_measure_distance_to_the_reconstruction():
    truth = trimesh.creation.box((0.04, 0.04, 0.04))
    narrower = truth.copy()
    narrower.apply_scale((0.9, 1.0, 1.0))  # x faces 2 mm in, at |x| = 18 mm
    pieces, distances = edge_piece_errors(sharp_edges(truth), narrower, piece_m=1e-3)
    lengths = np.linalg.norm(pieces[:, 1] - pieces[:, 0], axis=1)
    assert lengths.max() <= 1e-3 + 1e-12
    assert lengths.sum() == pytest.approx(12 * 0.04)
    on_x_faces = np.all(np.isclose(np.abs(pieces[:, :, 0]), 0.02), axis=1)
    assert on_x_faces.sum() == 8 * 40
    np.testing.assert_allclose(distances[on_x_faces], 0.002, atol=1e-9)
    # along the edges parallel to x, only the last 2 mm overhang the reconstruction
    mid_x = np.abs(pieces[~on_x_faces].mean(1)[:, 0])
    np.testing.assert_allclose(distances[~on_x_faces], np.maximum(0.0, mid_x - 0.018), atol=1e-9)


def test_edge_error_view_shows_red_only_where_edges_are_off(tmp_path):
    truth = trimesh.creation.box((0.04, 0.04, 0.04))
    narrower = truth.copy()
    narrower.apply_scale((0.9, 1.0, 1.0))
    view = ((20.0, 30.0),)
    off = edge_error_view_figure(truth, narrower, views=view, max_error_m=2e-3)
    exact = edge_error_view_figure(truth, truth, views=view, max_error_m=2e-3)
    assert red_pixels(rendered_rgba(off), off.axes[:1]) > 300
    assert red_pixels(rendered_rgba(exact), exact.axes[:1]) < 20
    assert_png(edge_error_view(truth, narrower, tmp_path / "e.png"), width=(1200, 2400))
    with pytest.raises(ValueError, match="no sharp edges"):
        edge_error_view(trimesh.creation.icosphere(2, RADIUS), truth, tmp_path / "e.png")


# ---------------------------------------------------------------------- sensor traces
def synthetic_readings(presses=((2.0, 3.5), (6.0, 6.8), (9.0, 11.0)), drift_pa_per_s=3.0,
                       press_pa=400.0, tilt_deg=15.0, rate_hz=83.0, duration_s=12.0):
    rng = np.random.default_rng(0)
    t = np.arange(0.0, duration_s, 1 / rate_hz)
    press = np.zeros_like(t)
    for a, b in presses:
        inside = (t > a) & (t < b)
        press[inside] = press_pa * (1 - np.exp(-(t[inside] - a) / 0.05))
    pressure = 101325.0 + drift_pa_per_s * t + rng.normal(0, 2.1, len(t)) + press
    angle = np.radians(tilt_deg) * press / press_pa
    quats = np.column_stack([np.cos(angle / 2), np.sin(angle / 2), 0 * t, 0 * t])
    acc = rng.normal(0, 0.012, (len(t), 3))
    return [Reading(float(tk), float(pk), q, a, np.array([0, 0, 9.81]))
            for tk, pk, q, a in zip(t, pressure, quats, acc)]


def test_trace_shading_equals_the_detected_contacts(tmp_path):
    readings = synthetic_readings()
    events = PressureContactDetector().process(readings)
    assert [e.kind for e in events] == ["start", "end"] * 3
    figure = sensor_traces_figure(readings, events)
    expected = [(s.onset_t_s, e.onset_t_s) for s, e in zip(events[::2], events[1::2])]
    assert len(figure.axes) == 3
    for ax in figure.axes:
        spans = [p for p in ax.patches if p.get_gid() == "contact-interval"]
        got = sorted((p.get_x(), p.get_x() + p.get_width()) for p in spans)
        np.testing.assert_allclose(got, expected)
    peak_deg = max(ax.lines[0].get_ydata().max() for ax in figure.axes[1:2])
    assert peak_deg == pytest.approx(15.0, abs=0.05)
    assert_png(sensor_traces(readings, events, tmp_path / "t.png"))


def test_contact_intervals_close_open_ends_and_reject_disorder():
    def event(kind, t):
        return ContactEvent(kind=kind, t_s=t + 0.01, onset_t_s=t, signal=0.0)

    got = contact_intervals([event("end", 1.0), event("start", 2.0), event("end", 3.0),
                             event("start", 4.0)], 0.5, 5.0)
    np.testing.assert_array_equal(got, [[0.5, 1.0], [2.0, 3.0], [4.0, 5.0]])
    assert contact_intervals([], 0.0, 1.0).shape == (0, 2)
    with pytest.raises(ValueError, match="alternate"):
        contact_intervals([event("start", 1.0), event("start", 2.0)], 0.0, 5.0)
    with pytest.raises(ValueError, match="outside"):
        contact_intervals([event("start", 6.0)], 0.0, 5.0)
    with pytest.raises(ValueError, match="before"):
        contact_intervals([event("start", 2.0), event("end", 1.0)], 0.0, 5.0)


def test_running_baseline_lags_a_ramp_by_rate_times_tau_and_freezes_in_contact():
    tau, rate = 2.0, 3.0
    t = np.arange(0.0, 40.0, 0.01)
    pressure = 1e5 + rate * t
    pressure[(t >= 30.0) & (t <= 32.0)] += 500.0
    baseline = running_baseline(t, pressure, [[30.0, 32.0]], time_constant_s=tau)
    settled = (t > 20.0) & (t < 30.0)
    # a first-order filter lags a ramp a*t by a*tau once settled
    np.testing.assert_allclose(pressure[settled] - baseline[settled], rate * tau, rtol=0.01)
    during = (t >= 30.0) & (t <= 32.0)
    assert np.ptp(baseline[during]) == 0.0
    assert baseline[during][0] == baseline[np.flatnonzero(during)[0] - 1]


def test_orientation_change_is_the_rotation_angle_and_sign_blind():
    angles = np.radians([0.0, 10.0, 90.0, 170.0])
    quats = np.column_stack([np.cos(angles / 2), 0 * angles, np.sin(angles / 2), 0 * angles])
    quats[2] *= -1.0
    quats[3] *= 3.0
    np.testing.assert_allclose(orientation_change_deg(quats), [0.0, 10.0, 90.0, 170.0], atol=1e-6)


def test_sensor_traces_reject_bad_input(tmp_path):
    readings = synthetic_readings(duration_s=1.0, presses=())
    with pytest.raises(ValueError, match="empty"):
        sensor_traces([], [], tmp_path / "t.png")
    with pytest.raises(ValueError, match="baseline_pa"):
        sensor_traces(readings, [], tmp_path / "t.png", baseline_pa=np.zeros(3))
    with pytest.raises(ValueError, match="time order"):
        sensor_traces(readings[::-1], [], tmp_path / "t.png")
    with pytest.raises(ValueError, match="Reading"):
        sensor_traces([object()], [], tmp_path / "t.png")


# ---------------------------------------------------------------------- normal error vs tilt
def test_normal_error_plot_shows_per_tilt_mean_rmse_overall_and_reference(tmp_path):
    rng = np.random.default_rng(1)
    tilts = np.repeat([0.0, 15.0, 30.0, 45.0], 25)
    errors = np.abs(rng.normal(0, 4 + 0.1 * tilts))
    figure = normal_error_vs_tilt_figure(tilts, errors, reference_deg=7.3)
    ax = figure.axes[0]
    lines = {line.get_gid(): line for line in ax.lines if line.get_gid()}
    for tilt, mean, rmse in zip(lines["mean"].get_xdata(), lines["mean"].get_ydata(),
                                lines["rmse"].get_ydata()):
        chosen = errors[tilts == tilt]
        assert mean == pytest.approx(sum(chosen) / len(chosen))
        assert rmse == pytest.approx(np.sqrt(sum(chosen**2) / len(chosen)))
    np.testing.assert_array_equal(lines["mean"].get_xdata(), [0.0, 15.0, 30.0, 45.0])
    assert lines["overall-mean"].get_ydata()[0] == pytest.approx(errors.mean())
    assert lines["reference"].get_ydata()[0] == 7.3
    assert_png(normal_error_vs_tilt(tilts, errors, tmp_path / "n.png"))


def test_normal_error_plot_rejects_bad_input(tmp_path):
    with pytest.raises(ValueError, match="shape"):
        normal_error_vs_tilt([0.0, 10.0], [1.0], tmp_path / "n.png")
    with pytest.raises(ValueError, match=">= 0"):
        normal_error_vs_tilt([0.0], [-1.0], tmp_path / "n.png")
    with pytest.raises(ValueError, match="empty"):
        normal_error_vs_tilt([], [], tmp_path / "n.png")
    with pytest.raises(ValueError, match="reference"):
        normal_error_vs_tilt([0.0], [1.0], tmp_path / "n.png", reference_deg=np.nan)


# ---------------------------------------------------------------------- error vs touches
def test_touch_curves_plot_the_seed_mean_and_band_in_mm(tmp_path):
    rng = np.random.default_rng(2)
    curves = {"random": 0.01 * rng.random((4, 20)), "variance": 0.005 * rng.random((3, 12))}
    figure = error_vs_touches_figure(curves, band="minmax")
    ax = figure.axes[0]
    for name, errors in curves.items():
        mean = next(line for line in ax.lines if line.get_gid() == f"mean:{name}")
        np.testing.assert_array_equal(mean.get_xdata(), np.arange(1, errors.shape[1] + 1))
        np.testing.assert_allclose(mean.get_ydata(), 1e3 * errors.mean(0))
        band = next(c for c in ax.collections if c.get_gid() == f"band:{name}")
        vertices = np.vstack([p.vertices for p in band.get_paths()])
        for touch in range(1, errors.shape[1] + 1):
            at = vertices[np.isclose(vertices[:, 0], touch), 1]
            assert at.min() == pytest.approx(1e3 * errors[:, touch - 1].min())
            assert at.max() == pytest.approx(1e3 * errors[:, touch - 1].max())
    std_band = next(c for c in error_vs_touches_figure(curves, band="std").axes[0].collections
                    if c.get_gid() == "band:random")
    top = np.vstack([p.vertices for p in std_band.get_paths()])
    first = top[np.isclose(top[:, 0], 1.0), 1]
    column = 1e3 * curves["random"][:, 0]
    assert first.max() == pytest.approx(column.mean() + column.std())
    assert_png(error_vs_touches(curves, tmp_path / "c.png"))


def test_touch_curves_reject_bad_input(tmp_path):
    with pytest.raises(ValueError, match="non-empty"):
        error_vs_touches({}, tmp_path / "c.png")
    with pytest.raises(ValueError, match="'a'.*shape"):
        error_vs_touches({"a": np.zeros(5)}, tmp_path / "c.png")
    with pytest.raises(ValueError, match="NaN"):
        error_vs_touches({"a": np.full((2, 3), np.nan)}, tmp_path / "c.png")
    with pytest.raises(ValueError, match="band"):
        error_vs_touches({"a": np.zeros((2, 3))}, tmp_path / "c.png", band="iqr")
