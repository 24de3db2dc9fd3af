"""What a touch tells the GPIS: a contact (a surface point and normal), for a miss free space, for
a press on the pad's side that the surface is within the pad's reach; and for the reconstruction
(:func:`with_swept_free_space`) the free space the approaches of both swept before the pad met the
surface.

The loop, resume and replay feed the GPIS through one :class:`SurfaceEvidence`, so a replay with the
recorded settings updates the field in the same order with the same values. Free space seen before
the first contact waits for it (the GPIS has no surface to be outside of until then).
"""
from __future__ import annotations

import copy

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
    side_press_value, side_press_noise : float or None
        Implicit-function value (and its standard deviation) at the pad-face centre of a press on
        the pad's side; None: such presses add nothing.
    probe_corridor_m : float or None
        A contact met more than this far past its target (a probe through surface the field had
        guessed) also adds the line its pad swept on the way (:meth:`add_swept`, gated): the
        corridor it showed to be free. None: contacts add only themselves.
    """

    def __init__(self, gpis: GPIS, free_space_value: float, free_space_noise: float,
                 side_press_value: float | None = None, side_press_noise: float | None = None,
                 probe_corridor_m: float | None = None):
        self.gpis = gpis
        self.probe_corridor_m = probe_corridor_m
        self.free_space_value = free_space_value
        self.free_space_noise = free_space_noise
        self.side_press_value = side_press_value
        self.side_press_noise = side_press_noise
        self._pending: list[tuple[np.ndarray, float, float]] = []

    def add_contact(self, point: np.ndarray, normal: np.ndarray, normal_noise: float | None = None) -> None:
        """A surface point (3,) and outward unit normal (3,); raises ValueError outside the GPIS bounds.

        ``normal_noise``: a floor for this contact's normal noise (a doubtful contact), None: the GPIS's rules.
        """
        first = self.gpis.n_contacts == 0
        self.gpis.add(point, normal, normal_noise=normal_noise)
        if first:
            for points, value, noise in self._pending:
                self._add_values(points, value, noise)
            self._pending = []

    def add_free_space(self, points: np.ndarray) -> None:
        """(k, 3) points outside the object (held back until the first contact)."""
        self._add_values(points, self.free_space_value, self.free_space_noise)

    def add_touch(self, record, doubtful_normal_noise: float | None, misses: bool = True) -> None:
        """What a recorded touch (:class:`explorer.touch.TouchOutcome`) tells, as the loop added it:
        a contact (a doubtful one with ``doubtful_normal_noise`` as its normal-noise floor), a miss's
        free space (unless ``misses`` is False), a press on the pad's side; nothing otherwise."""
        if record.kind == "contact":
            doubtful = getattr(record.quality, "doubtful", False)
            self.add_contact(record.position_m, record.normal, doubtful_normal_noise if doubtful else None)
            if self.probe_corridor_m is not None and record.past_target_m() > self.probe_corridor_m:
                self.add_swept(record.swept_points(-self.free_space_value))
        elif record.kind == "miss":
            if misses and record.free_space_m is not None:
                self.add_free_space(record.free_space_m)
        elif record.side_m is not None:
            self.add_side_press(record.side_m)

    def rebuilt(self, records, doubtful_normal_noise: float | None, misses: bool = True) -> "SurfaceEvidence":
        """New evidence with these settings on an unfitted copy of this GPIS, fed ``records`` in
        order (:meth:`add_touch`): the field again from the recorded touches, or (``misses`` False)
        without the misses' rows, which cannot be taken out of a factor."""
        evidence = SurfaceEvidence(self.gpis.unfitted_copy(), self.free_space_value, self.free_space_noise,
                                   self.side_press_value, self.side_press_noise, self.probe_corridor_m)
        for record in records:
            evidence.add_touch(record, doubtful_normal_noise, misses)
        return evidence

    def add_swept(self, points: np.ndarray) -> None:
        """(k, 3) points an approach swept before the pad met the surface (``TouchOutcome.swept_points``):
        free space, added only where the field disagrees, i.e. where its mean lies above
        ``free_space_value`` (surface or solid nearer than the pad allows). Elsewhere such a row
        would ask for -``free_space_value`` where the surface may be much farther (a bound, not a
        value) and pull the field in. Nothing before the first contact."""
        points = self.inside_bounds(np.asarray(points, float).reshape(-1, 3))
        if not len(points) or self.gpis.n_contacts == 0:
            return
        self._add_values(points[self.gpis.mean(points) > self.free_space_value], self.free_space_value,
                         self.free_space_noise)

    def add_side_press(self, pad_m: np.ndarray) -> None:
        """The (3,) pad-face centre of a press on the pad's side (``TouchOutcome.side_m``): the
        surface the pad met lies between the face centre and the pad's corners. Nothing when
        ``side_press_noise`` is None or the point is outside the bounds; held back until the first
        contact."""
        if self.side_press_noise is None:
            return
        self._add_values(self.inside_bounds(np.asarray(pad_m, float)[None]), self.side_press_value,
                         self.side_press_noise)

    def inside_bounds(self, points: np.ndarray) -> np.ndarray:
        """The (k, 3) points strictly inside the GPIS bounds (all when it has none)."""
        if self.gpis.bounds is None:
            return points
        lo, hi = self.gpis.bounds
        return points[np.all((points > lo) & (points < hi), axis=1)]

    def _add_values(self, points: np.ndarray, value: float, noise: float) -> None:
        if not len(points):
            return
        if self.gpis.n_contacts == 0:
            self._pending.append((points, value, noise))
            return
        self.gpis.add_values(points, np.full(len(points), value), noise=noise)


def with_swept_free_space(gpis: GPIS, records, free_space_value: float, free_space_noise: float,
                          misses: bool = False) -> tuple[GPIS, int]:
    """A copy of ``gpis`` that also holds the free space the pads of contacts and of presses on the
    pad's side swept on their approach lines (``TouchOutcome.swept_points``, up to
    ``-free_space_value`` short of where they met the surface), where the field disagrees
    (:meth:`SurfaceEvidence.add_swept`, one gate on the whole field); and the number of rows added.

    For the reconstruction only: ``gpis`` (the field the strategy explores with) is unchanged. Fed to
    the loop touch by touch the same rows steered the variance strategy elsewhere and did not help
    (BENCHMARKS.md, "Free space along the swept approach line").

    Parameters
    ----------
    gpis : GPIS, object frame
    records : sequence of explorer.touch.TouchOutcome
    free_space_value, free_space_noise : float
        As :class:`SurfaceEvidence` (``LoopConfig``'s).
    misses : bool
        Offer the misses' free space (``TouchOutcome.free_space_m``) through the same gate.
    """
    field = copy.deepcopy(gpis)
    lines = [np.asarray(r.swept_points(-free_space_value), float).reshape(-1, 3) for r in records]
    if misses:
        lines += [np.asarray(r.free_space_m, float).reshape(-1, 3) for r in records
                  if r.kind == "miss" and r.free_space_m is not None]
    rows = field.n_rows
    SurfaceEvidence(field, free_space_value, free_space_noise).add_swept(
        np.vstack(lines) if lines else np.zeros((0, 3)))
    return field, field.n_rows - rows
