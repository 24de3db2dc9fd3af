"""What the exploration loop knows beforehand, what a strategy asks for, and what a touch gave."""
from __future__ import annotations

from dataclasses import dataclass

import numpy as np

#: What a touch can end as. The loop records the first six; replay adds ``same_press`` (teleop:
#: in the same detected contact as an earlier touch) and ``not_modelled`` (outside the GPIS box).
TOUCH_KINDS = ("contact", "realign", "miss", "unreachable", "blocked", "no_normal", "same_press",
               "not_modelled")


@dataclass(frozen=True)
class ObjectPrior:
    """The object's rough location and size: the only prior knowledge of the loop.

    Attributes
    ----------
    centre_m : (3,) float
        Rough centre, object frame, metres.
    half_extent_m : (3,) float
        Rough half size along x, y, z, metres (an over-estimate is safe).
    """

    centre_m: np.ndarray
    half_extent_m: np.ndarray

    def __post_init__(self):
        centre = np.asarray(self.centre_m, float)
        half = np.asarray(self.half_extent_m, float)
        if centre.shape != (3,) or half.shape != (3,) or not np.all(np.isfinite(centre)):
            raise ValueError(f"ObjectPrior needs (3,) centre and half extent, got {self.centre_m!r}, "
                             f"{self.half_extent_m!r}")
        if not np.all(half > 0):
            raise ValueError(f"ObjectPrior half extents must be positive, got {half.tolist()}")
        object.__setattr__(self, "centre_m", centre)
        object.__setattr__(self, "half_extent_m", half)

    @property
    def radius_m(self) -> float:
        """Radius of the sphere around the prior box, metres."""
        return float(np.linalg.norm(self.half_extent_m))

    def bounds(self, padding: float = 0.25) -> tuple[np.ndarray, np.ndarray]:
        """The prior box grown by ``padding`` x its largest half extent on every side."""
        pad = padding * float(self.half_extent_m.max())
        return self.centre_m - self.half_extent_m - pad, self.centre_m + self.half_extent_m + pad


@dataclass(frozen=True)
class Touch:
    """A touch to try: where contact is expected and which way the pad travels.

    Attributes
    ----------
    target_m : (3,) float
        Expected contact point, object frame, metres. The guarded move starts ``standoff`` before
        it and may go ``max_depth`` beyond it.
    approach_dir : (3,) float
        Unit direction of pad travel (into the surface), object frame.
    score : float
        The strategy's preference (higher first); variance for ``variance``.
    strategy : str
        Name of the strategy that proposed it.
    depth_m : float or None
        How far beyond the target the pad may travel before the touch is a miss; None leaves it
        to the planner's default.
    """

    target_m: np.ndarray
    approach_dir: np.ndarray
    score: float = 0.0
    strategy: str = ""
    depth_m: float | None = None

    def __post_init__(self):
        target = np.asarray(self.target_m, float)
        direction = np.asarray(self.approach_dir, float)
        if target.shape != (3,) or direction.shape != (3,):
            raise ValueError("Touch needs (3,) target and approach direction")
        norm = np.linalg.norm(direction)
        if not np.isfinite(norm) or norm < 1e-9 or not np.all(np.isfinite(target)):
            raise ValueError(f"Touch needs a finite target and a non-zero approach direction, got "
                             f"{target.tolist()}, {direction.tolist()}")
        object.__setattr__(self, "target_m", target)
        object.__setattr__(self, "approach_dir", direction / norm)


@dataclass
class TouchOutcome:
    """What happened on one touch (object frame unless stated): the one record the loop writes,
    resume reads back and replay recomputes.

    Attributes
    ----------
    index : int
    kind : str
        One of :data:`TOUCH_KINDS`.
    target_m, approach_dir : (3,) float
        The touch as planned.
    stand_yaw_rad, stand_tilt_rad : float
        The stand during the touch.
    contact : sensor.oriented_contact.OrientedContact or None
        World frame, as measured.
    position_m, normal : (3,) float or None
        Surface point and outward unit normal (also for a contact set aside for a realign).
    t_s : float
        Time of the outcome (the contact's time for a contact), seconds.
    press_t_s : (float, float) or None
        Detector reset .. end of the hold: the press is the readings with ``t0 < t <= t1``
        (for the loop's detector and for replay alike).
    strategy : str
        The strategy that proposed the touch (``realign`` for a repeat).
    free_space_m : (k, 3) float or None
        Points a missed approach swept, object frame.
    baseline_pa : float or None
        The detector's free-pad pressure at the contact start, pascals.
    quality : explorer.contact.ContactQuality or None
    repress_t_s : float or None
        A doubtful contact, or a press that looked like one on the pad's side, was pressed on from
        this time (``LoopConfig.repress_force_n``): it is measured from the press's readings after it.
    side_m : (3,) float or None
        A press on the pad's side (kind ``no_normal``): the pad-face centre at its end, object
        frame, metres. The surface met lies within about the pad's half diagonal of it.
    left_line_m : (3,) float or None
        The pad-face centre, object frame, metres, the first control tick the pad was more than
        ``LoopConfig.line_tolerance_m`` off its planned approach line (another link met the object
        and the arm dragged the pad on); None: it kept to the line, or the check was off. Checked
        until the contact started, so a contact with it was made after the push.
    """

    index: int
    kind: str
    target_m: np.ndarray
    approach_dir: np.ndarray
    stand_yaw_rad: float = 0.0
    stand_tilt_rad: float = 0.0
    contact: object | None = None
    position_m: np.ndarray | None = None
    normal: np.ndarray | None = None
    t_s: float = 0.0
    press_t_s: tuple[float, float] | None = None
    strategy: str = ""
    free_space_m: np.ndarray | None = None
    baseline_pa: float | None = None
    quality: object | None = None
    repress_t_s: float | None = None
    side_m: np.ndarray | None = None
    left_line_m: np.ndarray | None = None

    def passed_points(self, margin_m: float, spacing_m: float = 0.01) -> np.ndarray:
        """(k, 3) points of the approach line from the target on that the pad went through before it
        met the surface, at least ``margin_m`` short of the contact, every ``spacing_m``; object
        frame. Empty without a contact position or when the contact came before that."""
        return self._line_before(self.position_m, margin_m, spacing_m)

    def past_target_m(self) -> float:
        """How far along its approach the contact lies beyond the target, metres (negative: before
        it); 0 without a contact position."""
        return 0.0 if self.position_m is None else self._along(self.position_m)

    def _along(self, point_m) -> float:
        return float((np.asarray(point_m) - self.target_m) @ self.approach_dir)

    def swept_points(self, margin_m: float, spacing_m: float = 0.01) -> np.ndarray:
        """:meth:`passed_points` of a contact the GPIS takes (kind ``contact``) or of a press on the
        pad's side (kind ``no_normal``, up to ``side_m``); empty for any other touch."""
        end = self.position_m if self.kind == "contact" else self.side_m if self.kind == "no_normal" else None
        return self._line_before(end, margin_m, spacing_m)

    def _line_before(self, end_m, margin_m: float, spacing_m: float) -> np.ndarray:
        if end_m is None:
            return np.zeros((0, 3))
        reached = self._along(end_m)
        along = np.arange(0.0, reached - margin_m + 1e-12, spacing_m)
        return self.target_m + along[:, None] * self.approach_dir


def left_line_counts(records) -> dict:
    """``metrics.json``'s counts (run and replay alike) of the touches whose pad left its line
    (``left_line``: ``TouchOutcome.left_line_m`` set) and of the contacts among them
    (``contacts_after_left_line``)."""
    pushed = [r for r in records if r.left_line_m is not None]
    return dict(left_line=len(pushed), contacts_after_left_line=sum(r.kind == "contact" for r in pushed))
