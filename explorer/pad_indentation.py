"""A pad pressed on a body that curves away from it in every direction sinks deeper (issues 11, 12).

The pipeline adds the pad's compression back along the normal as ``force x compliance`` with the
compliance a flat plate gives (:mod:`explorer.contact`), where the whole face bears the load. On a
ball-like surface (a sphere, a fruit, a blob, a bowl's outside) the face bears on one point and
sinks by the point compliance instead (:attr:`sensor.pad_calibration.PadCalibration.
point_compliance_m_per_n`, measured on a meshed ball): about twice as far per newton in
simulation, so that contacts on surfaces curved by 20-30 /m lay 0.18 mm inside on average
(BENCHMARKS.md, "A pad on a ball sinks deeper"). Where the surface curves away in one direction
only (a cylinder) the face bears along a line and sinks as on the plate.

How far the face bears on one point depends on the surface's least curvature ``kappa`` towards the
pad: the surface falls away from the face by the sagitta ``s = kappa r^2 / 2`` at a distance ``r``
from the touched point. Once ``s`` exceeds the point compression ``c_point f`` the face touches at
one point; below it the face bears further out too. The depth is taken as

    ``f (c_flat + min(1, s / (c_point f)) (c_point - c_flat))``

with ``r`` = :attr:`PadIndentation.bearing_radius_m`, and each contact is moved out along its
normal by the part the flat compliance did not add back. With ``r`` the face's half width (9 mm)
the model follows head-on presses on smooth mesh balls of 50-150 mm radius (tests/
test_pad_indentation.py); on the objects' coarser meshes, where the face bears on one to three
vertices, the contacts' offsets from the truth over the tuning split's loop runs flatten against
the least curvature with 6 mm (4.5, 6 and 9 mm tried; BENCHMARKS.md, "A pad on a ball sinks
deeper").

``kappa`` is read from the neighbouring contacts' measured normals as in
:mod:`explorer.pad_bridging`: the curvature ``kappa_ij`` along the line to neighbour ``j``
(:mod:`explorer.neighbour_curvature`, convex positive). By Euler's theorem it is ``t^T S t`` for
the line's unit direction ``t`` in the tangent plane and the surface's 2 x 2 shape operator ``S``,
fitted to the neighbours by least squares; its smaller eigenvalue is the least curvature. A cylinder's, a plane's and a saddle's is about zero or
below, so they are left as measured.

Used for the reconstruction only (``LoopConfig.indent_convex_contacts``), like the bridging: the
field the strategy explores is left as measured, so the run's path does not change.
"""
from __future__ import annotations

from dataclasses import dataclass, replace

import numpy as np

from common.directions import perpendicular_frame
from explorer.neighbour_curvature import neighbour_curvatures


@dataclass(frozen=True)
class PadIndentation:
    """How much deeper than on a plate the pad sank into a surface curving away in every direction.

    Attributes
    ----------
    neighbour_radius_m, same_side_cosine : float
        Which neighbours read a contact's curvature, metres and a cosine: as for
        :class:`explorer.pad_bridging.PadBridging`.
    min_neighbours : int
        Fewer neighbours than this: no correction (the shape operator has three unknowns).
    bearing_radius_m : float
        ``r`` of the module docstring: how far from the touched point the surface must fall away
        by the point compression for the face to bear on that point alone, metres (chosen on the
        tuning split).
    """

    neighbour_radius_m: float = 0.03
    same_side_cosine: float = 0.5
    min_neighbours: int = 5
    bearing_radius_m: float = 0.006

    def least_curvatures(self, points: np.ndarray, normals: np.ndarray) -> np.ndarray:
        """(n,) float, 1/m: each contact's least convex curvature from its neighbours (0 where
        fewer than ``min_neighbours``; negative values are concave or saddle-like).

        Parameters
        ----------
        points : (n, 3) float
            Contact positions, any one frame, metres.
        normals : (n, 3) float
            Their outward unit normals, the same frame.
        """
        normals = np.asarray(normals, float).reshape(-1, 3)
        out = np.zeros(len(normals))
        if len(normals) == 0:
            return out
        first, second = perpendicular_frame(normals)   # each contact's tangent plane
        for i, step, kappa in neighbour_curvatures(points, normals, self.neighbour_radius_m, self.same_side_cosine):
            if len(kappa) < self.min_neighbours:
                continue
            tu, tv = step @ first[i], step @ second[i]
            length = np.hypot(tu, tv)
            keep = length > 1e-9
            tu, tv = tu[keep] / length[keep], tv[keep] / length[keep]
            rows = np.c_[tu * tu, 2.0 * tu * tv, tv * tv]
            (a, b, c), *_ = np.linalg.lstsq(rows, kappa[keep], rcond=None)
            out[i] = float(np.linalg.eigvalsh([[a, b], [b, c]])[0])
        return out

    def depths(self, points: np.ndarray, normals: np.ndarray, forces_n: np.ndarray, pad) -> np.ndarray:
        """(n,) float, metres (>= 0): how much further than ``force x pad.compliance_m_per_n``
        each contact's pad sank in (module docstring).

        Parameters
        ----------
        points, normals : (n, 3) float
            Contacts and outward unit normals, one frame, metres.
        forces_n : (n,) float
            Each contact's measured force, newtons.
        pad : sensor.pad_calibration.PadCalibration
            Its flat and point compliances (no point compliance: all zero).
        """
        forces = np.maximum(np.asarray(forces_n, float), 0.0)
        point = pad.point_compliance_m_per_n
        if point is None or point <= pad.compliance_m_per_n or len(forces) == 0:
            return np.zeros(len(forces))
        sagitta = 0.5 * np.maximum(self.least_curvatures(points, normals), 0.0) * self.bearing_radius_m**2
        on_one_point = np.clip(sagitta / np.maximum(point * forces, 1e-12), 0.0, 1.0)
        return on_one_point * (point - pad.compliance_m_per_n) * forces

    def apply(self, records: list, pad) -> tuple[list, int]:
        """The touches with each contact moved out along its normal by :meth:`depths` (copies where
        moved; every other touch as given), and the number moved.

        Parameters
        ----------
        records : list of explorer.touch.TouchOutcome, object frame
        pad : sensor.pad_calibration.PadCalibration
        """
        contacts = [i for i, r in enumerate(records) if r.kind == "contact" and r.contact is not None]
        if not contacts or pad.point_compliance_m_per_n is None:
            return list(records), 0
        points = np.array([records[i].position_m for i in contacts], float)
        normals = np.array([records[i].normal for i in contacts], float)
        forces = np.array([records[i].contact.force_n for i in contacts], float)
        depths = self.depths(points, normals, forces, pad)
        out = list(records)
        for k, i in enumerate(contacts):
            if depths[k] > 0.0:
                out[i] = replace(records[i], position_m=points[k] + depths[k] * normals[k])
        return out, int(np.count_nonzero(depths))

