"""Figures a researcher reads: PNGs from plain data (numpy arrays, trimesh meshes, dataclasses).

Each figure is a function that takes its data and a ``path``, writes a PNG there and returns the
path; a ``*_figure`` twin returns the :class:`matplotlib.figure.Figure` instead, for adjusting before
saving. Rendering is headless (Agg canvas per figure, no pyplot, no global backend switch). Inputs
are SI (metres, radians, pascals, seconds) except where a name says ``_deg``; axes read mm and degrees.
"""
from reconstruction.figures.error_colours import distances_to_surface, error_colours
from reconstruction.figures.error_views import (edge_error_view, edge_error_view_figure, edge_piece_errors,
                                                error_coloured_views, error_coloured_views_figure)
from reconstruction.figures.learning_curves import error_vs_touches, error_vs_touches_figure
from reconstruction.figures.normal_error import normal_error_vs_tilt, normal_error_vs_tilt_figure
from reconstruction.figures.potential_slice import potential_slice, potential_slice_figure
from reconstruction.figures.sensor_traces import (contact_intervals, orientation_change_deg,
                                                  running_baseline, sensor_traces,
                                                  sensor_traces_figure)

__all__ = [
    "contact_intervals", "distances_to_surface", "edge_error_view", "edge_error_view_figure",
    "edge_piece_errors",
    "error_colours", "error_coloured_views", "error_coloured_views_figure", "error_vs_touches",
    "error_vs_touches_figure", "normal_error_vs_tilt", "normal_error_vs_tilt_figure",
    "orientation_change_deg", "potential_slice", "potential_slice_figure", "running_baseline",
    "sensor_traces", "sensor_traces_figure",
]
