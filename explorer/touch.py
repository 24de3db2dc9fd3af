"""What the exploration loop knows beforehand and what a strategy asks for."""
from __future__ import annotations

from dataclasses import dataclass

import numpy as np


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

    @classmethod
    def from_mesh(cls, mesh, margin: float = 0.0) -> "ObjectPrior":
        """The bounding box of a mesh (object frame), grown by ``margin`` metres."""
        lo, hi = mesh.bounds
        return cls(0.5 * (lo + hi), 0.5 * (hi - lo) + margin)


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
