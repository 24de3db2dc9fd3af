"""A flat pad on a concave surface bridges it: the contact lies above the surface (issue 11).

The pipeline measures a contact at the pad face's centre of pressure, pushed back along the
normal by the pad's compression (:mod:`explorer.contact`). On a surface that curves away from the
pad (a torus's inner ring, a ring's hole, a mug's inside) the flat 18 mm pad cannot reach the point
under its centre: it rests on its rim or corners, and its centre stays above the surface by the
sagitta ``kappa r^2 / 2`` over the pad's reach ``r`` (half its diagonal, 12.7 mm, for a pad whose
corners meet the surface first), ``kappa`` the surface's curvature towards the pad. On a 40 mm
radius that is 2 mm, for every contact there.

The surface's curvature is read from the neighbouring contacts' measured normals, not from the
GPIS (whose ripples near edges and thin walls read as curvature that is not there; BENCHMARKS.md,
"A flat pad bridges concave surfaces"): for contacts ``i`` and ``j`` on the same side of the
surface, ``kappa_ij = -(n_j - n_i) . (p_j - p_i) / |p_j - p_i|^2`` is the curvature along the line
between them (positive where the normals converge: concave). The pad bridges along the most concave
direction, so a high quantile of ``kappa_ij`` over the neighbours is taken, a robust stand-in for
the largest; convex and flat places and edges give none. Each such contact is moved in along its
measured normal by the sagitta, at most ``max_height_m``.

Used for the reconstruction only (``LoopConfig.bridge_concave_contacts``): the field the strategy
explores is left as measured, so the run's path does not change.
"""
from __future__ import annotations

from dataclasses import dataclass, replace

import numpy as np

from explorer.neighbour_curvature import neighbour_curvatures


@dataclass(frozen=True)
class PadBridging:
    """How far a flat pad's centre stayed above a concave surface, from the contacts around it.

    Attributes
    ----------
    neighbour_radius_m : float
        Contacts within this distance of a contact read its surface's curvature, metres.
    same_side_cosine : float
        Only neighbours whose normal is within ``arccos`` of this of the contact's (the other side
        of a thin wall is not a neighbour).
    quantile : float
        Percentile of the neighbours' curvatures taken as the surface's curvature towards the pad.
    min_neighbours : int
        Fewer neighbours than this: no correction.
    max_height_m : float
        Largest correction, metres: larger estimates come from normals too noisy or too far apart
        to tell (moved further off the truth than they were in the tuning runs).
    """

    neighbour_radius_m: float = 0.03
    same_side_cosine: float = 0.5
    quantile: float = 90.0
    min_neighbours: int = 3
    max_height_m: float = 0.002

    def heights(self, points: np.ndarray, normals: np.ndarray, pad_reach_m: float) -> np.ndarray:
        """(n,) height, metres (>= 0), each contact's pad centre stayed above the surface.

        Parameters
        ----------
        points, normals : (n, 3) float
            Contacts and their measured outward unit normals, object frame, metres.
        pad_reach_m : float
            Distance from the pad face's centre to the farthest point of its face that can meet the
            surface (half the diagonal of a square pad), metres.
        """
        heights = np.zeros(len(np.asarray(points).reshape(-1, 3)))
        if len(heights) <= self.min_neighbours:
            return heights
        for i, _, convex in neighbour_curvatures(points, normals, self.neighbour_radius_m, self.same_side_cosine):
            if len(convex) >= self.min_neighbours:
                heights[i] = 0.5 * pad_reach_m**2 * float(np.percentile(-convex, self.quantile))
        return np.clip(heights, 0.0, self.max_height_m)

    def apply(self, records: list, pad_half_width_m: float) -> tuple[list, int]:
        """The touches with each contact moved in along its normal by :meth:`heights` (copies where
        moved; every other touch as given), and the number moved.

        Parameters
        ----------
        records : list of explorer.touch.TouchOutcome, object frame
        pad_half_width_m : float
            Half the side of the square pad, metres (``PadCalibration.half_width_m``).
        """
        contacts = [i for i, r in enumerate(records) if r.kind == "contact"]
        if not contacts:
            return list(records), 0
        points = np.array([records[i].position_m for i in contacts], float)
        normals = np.array([records[i].normal for i in contacts], float)
        heights = self.heights(points, normals, np.sqrt(2.0) * pad_half_width_m)
        out = list(records)
        for k, i in enumerate(contacts):
            if heights[k] > 0.0:
                out[i] = replace(records[i], position_m=points[k] - heights[k] * normals[k])
        return out, int(np.count_nonzero(heights))
