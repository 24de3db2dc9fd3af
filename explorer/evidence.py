"""What a touch tells the GPIS: a contact (a surface point and normal) or, for a miss, free space.

The loop, resume and replay feed the GPIS through one :class:`SurfaceEvidence`, so a replay with the
recorded settings updates the field in the same order with the same values. Free space seen before
the first contact waits for it (the GPIS has no surface to be outside of until then).
"""
from __future__ import annotations

import numpy as np

from reconstruction.gpis import GPIS


class SurfaceEvidence:
    """Adds touches to ``gpis`` (object frame).

    Parameters
    ----------
    gpis : GPIS
    free_space_value : float
        Implicit-function value of a point a missed approach swept (see ``LoopConfig``).
    free_space_noise : float
        Standard deviation of those values.
    """

    def __init__(self, gpis: GPIS, free_space_value: float, free_space_noise: float):
        self.gpis = gpis
        self.free_space_value = free_space_value
        self.free_space_noise = free_space_noise
        self._pending: list[np.ndarray] = []

    def add_contact(self, point: np.ndarray, normal: np.ndarray, normal_noise: float | None = None) -> None:
        """A surface point (3,) and outward unit normal (3,); raises ValueError outside the GPIS bounds.

        ``normal_noise``: a floor for this contact's normal noise (a doubtful contact), None: the GPIS's rules.
        """
        first = self.gpis.n_contacts == 0
        self.gpis.add(point, normal, normal_noise=normal_noise)
        if first and self._pending:
            self._add_values(np.vstack(self._pending))
            self._pending = []

    def add_free_space(self, points: np.ndarray) -> None:
        """(k, 3) points outside the object (held back until the first contact)."""
        if not len(points):
            return
        if self.gpis.n_contacts == 0:
            self._pending.append(points)
            return
        self._add_values(points)

    def inside_bounds(self, points: np.ndarray) -> np.ndarray:
        """The (k, 3) points strictly inside the GPIS bounds (all when it has none)."""
        if self.gpis.bounds is None:
            return points
        lo, hi = self.gpis.bounds
        return points[np.all((points > lo) & (points < hi), axis=1)]

    def _add_values(self, points: np.ndarray) -> None:
        values = np.full(len(points), self.free_space_value)
        self.gpis.add_values(points, values, noise=self.free_space_noise)
