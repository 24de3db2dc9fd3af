"""A partition of unity of local GPIS fits whose scale follows the contact density.

The region is cut into an octree whose leaves hold at most ``max_cell_contacts`` contacts, so cells
are small where contacts are dense. Every leaf that holds a contact gets its own GPIS, fitted to the
contacts within its *fit ball* (the leaf's support ball, grown until it holds ``min_fit_contacts``),
with a thin-plate ``R`` (or a Matern-3/2 length scale) proportional to that ball: the kernel's
scale is local. The fields are blended with compactly supported Wendland weights

    f(x) = (eps f_global(x) + sum_i w_i(x) f_i(x)) / (eps + sum_i w_i(x)),
    w_i(x) = psi(|x - c_i| / rho_i),  psi(t) = (1 - t)^4 (4 t + 1) for t < 1, else 0,

with ``c_i`` the leaf centre and ``rho_i = overlap x`` its half diagonal. The global GPIS (the
default of :class:`reconstruction.gpis.GPIS` on all contacts) has the small weight ``eps``: it is
the field wherever no local support reaches (empty interiors and the far outside), so those do not
become phantom holes, and it is what the information-based strategies score (``whiten``,
``joint_cross_covariance``).

Measured on the generated tuning split (BENCHMARKS.md, issue 10, "Partitioned GPIS"): it does **not**
beat the global default, because the phantom surface of the default is overshoot of a smooth
interpolant at sharp edges and thin walls within one contact spacing, which a local smooth fit
reproduces. It stays an option, not the default.

Convention as :class:`reconstruction.gpis.GPIS`: ``f`` positive inside, outward unit normals,
metres, the contacts' (object) frame.
"""
from __future__ import annotations

from dataclasses import dataclass, field
from typing import Sequence

import numpy as np
from scipy.spatial import cKDTree

from reconstruction.gpis import GPIS, VarianceTracker, _check_bounds, _finite_array
from reconstruction.kernels import ConstantKernel, Kernel, Matern32Kernel, SumKernel, ThinPlateKernel

#: Local kernels by name.
LOCAL_KERNELS = ("thin_plate", "matern32", "matern32-ml")

#: Candidate Matern-3/2 length scales of ``matern32-ml``, as multiples of the fit radius.
ML_LENGTH_FACTORS = (0.25, 0.5, 1.0, 2.0)


def wendland(t: np.ndarray) -> np.ndarray:
    """The C2 Wendland weight ``(1 - t)^4 (4 t + 1)`` for ``0 <= t < 1``, 0 beyond; any shape."""
    t = np.clip(np.asarray(t, float), 0.0, 1.0)
    return (1.0 - t) ** 4 * (4.0 * t + 1.0)


def wendland_derivative(t: np.ndarray) -> np.ndarray:
    """``d psi / d t = -20 t (1 - t)^3`` for ``0 <= t < 1``, 0 beyond; any shape."""
    t = np.clip(np.asarray(t, float), 0.0, 1.0)
    return -20.0 * t * (1.0 - t) ** 3


@dataclass
class Cell:
    """One octree leaf and its local fit.

    Attributes
    ----------
    centre : (3,) float, metres
    half : float
        Half the cell's side, metres.
    support_m : float
        Radius of the blending weight's support around ``centre``, metres.
    fit_radius_m : float
        Radius of the ball whose contacts the local GPIS was fitted to, metres.
    gp : GPIS or None
        The local fit (None: the cell holds no contact and does not contribute).
    contacts : list of int
        Indices of the contacts inside the cell's box (which decide when it splits).
    """

    centre: np.ndarray
    half: float
    support_m: float
    fit_radius_m: float = 0.0
    gp: GPIS | None = None
    contacts: list = field(default_factory=list)


class PartitionedGPIS:
    """Local GPIS fits over a density-adaptive octree, blended by a partition of unity.

    Parameters
    ----------
    bounds : ((3,), (3,)) float
        Workspace box, metres (required: it is the octree's root and the global GPIS's region).
    max_cell_contacts : int
        A leaf with more contacts than this is split (down to ``min_cell_m``).
    min_cell_m : float
        Smallest leaf side, metres.
    overlap : float
        Weight support radius over the leaf's half diagonal (> 1 so neighbouring supports overlap).
    min_fit_contacts : int
        The fit ball grows beyond the support until it holds this many contacts.
    local_kernel : {"thin_plate", "matern32", "matern32-ml"}
        ``thin_plate``: ``R = scale_factor x`` the fit ball's diameter (>= 1.5 keeps the system
        positive definite); ``matern32``: length scale ``scale_factor x`` the fit radius, plus a
        constant of 5 cm; ``matern32-ml``: the length scale among :data:`ML_LENGTH_FACTORS` x the
        fit radius with the highest local log marginal likelihood, chosen per cell at its fit
        (``scale_factor`` unused; incremental adds keep it).
    scale_factor : float
    global_weight : float
        ``eps``, the global GPIS's weight in the blend.
    **gpis_kwargs
        For the global and the local GPIS (noise, normal_noise, trend, opposing_normal_noise, ...);
        ``kernel`` and ``use_normals=False`` are not accepted.
    """

    def __init__(self, bounds: Sequence[Sequence[float]], max_cell_contacts: int = 40,
                 min_cell_m: float = 0.01, overlap: float = 1.5, min_fit_contacts: int = 12,
                 local_kernel: str = "thin_plate", scale_factor: float = 1.5,
                 global_weight: float = 1e-3, **gpis_kwargs):
        if bounds is None:
            raise ValueError("PartitionedGPIS needs bounds=((xmin, ymin, zmin), (xmax, ymax, zmax)), metres")
        if local_kernel not in LOCAL_KERNELS:
            raise ValueError(f"unknown local_kernel {local_kernel!r}; choose one of {', '.join(LOCAL_KERNELS)}")
        if "kernel" in gpis_kwargs or not gpis_kwargs.get("use_normals", True):
            raise ValueError("PartitionedGPIS uses its own kernels and needs normals (use_normals=True)")
        for name, value, least in (("max_cell_contacts", max_cell_contacts, 1), ("min_fit_contacts", min_fit_contacts, 1),
                                   ("overlap", overlap, 1.0), ("scale_factor", scale_factor, 0.0),
                                   ("min_cell_m", min_cell_m, 0.0), ("global_weight", global_weight, 0.0)):
            if not (np.isfinite(value) and value > least):
                raise ValueError(f"{name} must be a finite number above {least}, got {value!r}")
        if local_kernel == "thin_plate" and scale_factor < 1.5:
            raise ValueError(f"a thin-plate scale_factor below 1.5 makes local systems indefinite, got {scale_factor}")
        self.bounds = _check_bounds(bounds)
        self.max_cell_contacts = int(max_cell_contacts)
        self.min_cell_m = float(min_cell_m)
        self.overlap = float(overlap)
        self.min_fit_contacts = int(min_fit_contacts)
        self.local_kernel = local_kernel
        self.scale_factor = float(scale_factor)
        self.global_weight = float(global_weight)
        self.gpis_kwargs = dict(gpis_kwargs)
        self.global_gp = GPIS(bounds=self.bounds, **self.gpis_kwargs)
        self.cells: list[Cell] = []
        self.partition_generation = 0
        self._points = np.zeros((0, 3))
        self._normals = np.zeros((0, 3))
        self._floor = np.zeros(0)

    # ------------------------------------------------------------------ observations
    def fit(self, points: np.ndarray, normals: np.ndarray,
            normal_noise: float | np.ndarray | None = None) -> "PartitionedGPIS":
        """Replace all contacts: fit the global GPIS, build the octree, fit every local cell.

        Parameters
        ----------
        points : (n, 3) float, metres
        normals : (n, 3) float, outward
        normal_noise : float or (n,) float, optional
            Per-contact normal-noise floor, as :meth:`GPIS.fit`.
        """
        self.global_gp.fit(points, normals, normal_noise)
        self._points = self.global_gp.contact_points
        self._normals = self.global_gp.contact_normals
        self._floor = np.concatenate(self.global_gp._contact_noise_floor)
        lo, hi = self.bounds
        root = Cell(0.5 * (lo + hi), 0.5 * float(np.max(hi - lo)), 0.0)
        root.contacts = list(range(len(self._points)))
        self.cells = []
        self._split_into_leaves(root)
        self.partition_generation += 1
        return self

    def add(self, point: np.ndarray, normal: np.ndarray,
            normal_noise: float | np.ndarray | None = None) -> "PartitionedGPIS":
        """Add one contact (or (k, 3) arrays): incremental add to the global GPIS and to every local
        fit whose fit ball holds it; a leaf that grows past twice ``max_cell_contacts`` is split and
        its children fitted anew."""
        if not self.n_contacts:
            return self.fit(np.atleast_2d(point), np.atleast_2d(normal), normal_noise)
        self.global_gp.add(point, normal, normal_noise)
        first = len(self._points)
        self._points = self.global_gp.contact_points
        self._normals = self.global_gp.contact_normals
        self._floor = np.concatenate(self.global_gp._contact_noise_floor)
        new = np.arange(first, len(self._points))
        split, refitted = [], False
        for cell in self.cells:
            inside = new[np.all(np.abs(self._points[new] - cell.centre) <= cell.half, axis=1)]
            cell.contacts.extend(inside.tolist())
            if len(inside) and len(cell.contacts) > 2 * self.max_cell_contacts and 2 * cell.half > self.min_cell_m:
                split.append(cell)
                continue
            if cell.gp is None:
                if len(inside):
                    self._fit_cell(cell)
                    refitted = True
                continue
            near = new[np.linalg.norm(self._points[new] - cell.centre, axis=1) <= cell.fit_radius_m]
            if len(near):
                cell.gp.add(self._points[near], self._normals[near], self._floor[near])
        if split:
            self.cells = [c for c in self.cells if all(c is not s for s in split)]
            for cell in split:
                self._split_into_leaves(cell)
        if split or refitted:
            self.partition_generation += 1
        return self

    def add_values(self, points: np.ndarray, values: np.ndarray, noise: float | None = None) -> "PartitionedGPIS":
        """Value-only observations (e.g. free space, ``f < 0``), to the global GPIS and to the local
        fits whose fit ball holds them; (k, 3) metres, (k,) values."""
        points = _finite_array(points, "points", (None, 3))
        values = _finite_array(values, "values", (len(points),))
        self.global_gp.add_values(points, values, noise)
        for cell in self.cells:
            if cell.gp is None:
                continue
            near = np.linalg.norm(points - cell.centre, axis=1) <= cell.fit_radius_m
            if near.any():
                cell.gp.add_values(points[near], values[near], noise)
        return self

    # ------------------------------------------------------------------ queries
    def weights(self, x: np.ndarray) -> tuple[np.ndarray, list[tuple[np.ndarray, np.ndarray]]]:
        """Blending weights at (m, 3) points.

        Returns
        -------
        total : (m,) float
            ``eps + sum_i w_i``.
        per_cell : list of (indices (k,) int, w (k,) float), one per cell in ``cells``
            The points inside the cell's support and their weight (not normalised).
        """
        x = np.asarray(x, float)
        total = np.full(len(x), self.global_weight)
        per_cell = []
        for cell in self.cells:
            idx = self._in_support(cell, x)
            w = wendland(np.linalg.norm(x[idx] - cell.centre, axis=1) / cell.support_m) if cell.gp else np.zeros(len(idx))
            total[idx] += w
            per_cell.append((idx, w))
        return total, per_cell

    def mean(self, x: np.ndarray) -> np.ndarray:
        """Blended posterior mean of ``f`` at (m, 3) points; (m,) float32."""
        x = self._check_query(x)
        total, per_cell = self.weights(x)
        num = self.global_weight * self.global_gp.mean(x).astype(float)
        for cell, (idx, w) in zip(self.cells, per_cell):
            if cell.gp is not None and len(idx):
                num[idx] += w * cell.gp.mean(x[idx])
        return (num / total).astype(np.float32)

    def gradient(self, x: np.ndarray) -> np.ndarray:
        """Gradient of :meth:`mean` at (m, 3) points, weights' derivatives included; (m, 3) float32."""
        x = self._check_query(x)
        f_g = self.global_gp.mean(x).astype(float)
        num = self.global_weight * f_g
        dnum = self.global_weight * self.global_gp.gradient(x).astype(float)
        total = np.full(len(x), self.global_weight)
        dtotal = np.zeros((len(x), 3))
        for cell in self.cells:
            if cell.gp is None:
                continue
            idx = self._in_support(cell, x)
            if not len(idx):
                continue
            d = x[idx] - cell.centre
            r = np.linalg.norm(d, axis=1)
            w = wendland(r / cell.support_m)
            dw = (wendland_derivative(r / cell.support_m) / (cell.support_m * np.maximum(r, 1e-12)))[:, None] * d
            f = cell.gp.mean(x[idx]).astype(float)
            num[idx] += w * f
            dnum[idx] += w[:, None] * cell.gp.gradient(x[idx]) + dw * f[:, None]
            total[idx] += w
            dtotal[idx] += dw
        return ((dnum - (num / total)[:, None] * dtotal) / total[:, None]).astype(np.float32)

    def variance(self, x: np.ndarray) -> np.ndarray:
        """Weighted mean of the local (and global) posterior variances at (m, 3) points; (m,) float64.

        Not the variance of the blended mean under a joint model (the local fits share data); a
        score of how unexplored a point is, 0 at well-observed points, as the strategies use it.
        """
        x = self._check_query(x)
        total, per_cell = self.weights(x)
        out = self.global_weight * self.global_gp.variance(x)
        for cell, (idx, w) in zip(self.cells, per_cell):
            if cell.gp is not None and len(idx):
                out[idx] += w * cell.gp.variance(x[idx])
        return out / total

    def variance_tracker(self, candidates: np.ndarray) -> "PartitionedVarianceTracker":
        """Variance at a fixed (m, 3) candidate set, updated incrementally per contact."""
        return PartitionedVarianceTracker(self, candidates)

    def mesh(self, bounds: Sequence[Sequence[float]] | None = None, resolution: int = 64,
             max_std_m: float | None = None, refine_steps: int | None = None):
        """The blended mean's 0-level set as a ``trimesh.Trimesh`` (see :meth:`GPIS.mesh`)."""
        from reconstruction.confidence import mean_surface

        self._require_fit()
        return mean_surface(self, self.bounds if bounds is None else _check_bounds(bounds), resolution, max_std_m,
                            refine_steps)

    # ------------------------------------------------------------------ the global GPIS's interface
    @property
    def n_contacts(self) -> int:
        return len(self._points)

    @property
    def contact_points(self) -> np.ndarray:
        """(n, 3) float, metres."""
        return self._points.copy()

    @property
    def contact_normals(self) -> np.ndarray:
        """(n, 3) float, outward."""
        return self._normals.copy()

    @property
    def region(self) -> tuple[np.ndarray, np.ndarray]:
        return self.bounds

    use_normals = True
    positive_definite = True

    def __getattr__(self, name):
        # noise settings and the factor-level queries (n_rows, whiten, cross_covariance,
        # joint_cross_covariance, prior_joint_covariance, generation, ...) are the global GPIS's
        if name.startswith("_") or name in ("global_gp",):
            raise AttributeError(name)
        return getattr(self.global_gp, name)

    # ------------------------------------------------------------------ internals
    def _split_into_leaves(self, cell: Cell) -> None:
        """Split ``cell`` recursively into leaves of at most ``max_cell_contacts``; fit them."""
        stack = [cell]
        while stack:
            c = stack.pop()
            if len(c.contacts) > self.max_cell_contacts and 2 * c.half > self.min_cell_m:
                pts = self._points[c.contacts]
                for corner in np.array([[sx, sy, sz] for sx in (-1, 1) for sy in (-1, 1) for sz in (-1, 1)]):
                    child = Cell(c.centre + 0.5 * c.half * corner, 0.5 * c.half, 0.0)
                    inside = np.all(np.abs(pts - child.centre) <= child.half, axis=1)
                    child.contacts = [i for i, keep in zip(c.contacts, inside) if keep]
                    stack.append(child)
                continue
            c.support_m = self.overlap * c.half * np.sqrt(3.0)
            c.gp = None
            if c.contacts:
                self._fit_cell(c)
            self.cells.append(c)

    def _fit_cell(self, cell: Cell) -> None:
        tree = cKDTree(self._points)
        k = min(self.min_fit_contacts, len(self._points))
        kth = float(np.atleast_1d(tree.query(cell.centre, k=k)[0])[-1])
        cell.fit_radius_m = max(cell.support_m, kth) * (1 + 1e-9)  # the k-th contact surely inside
        idx = np.asarray(tree.query_ball_point(cell.centre, cell.fit_radius_m), int)
        def fit(kernel: Kernel) -> GPIS:
            gp = GPIS(kernel=kernel, bounds=self.bounds, **self.gpis_kwargs)
            return gp.fit(self._points[idx], self._normals[idx], self._floor[idx])

        if self.local_kernel == "matern32-ml":
            fits = [fit(_matern(f * cell.fit_radius_m)) for f in ML_LENGTH_FACTORS]
            cell.gp = max(fits, key=lambda gp: gp.log_marginal_likelihood())
        else:
            cell.gp = fit(self._local_kernel(cell.fit_radius_m))

    def _local_kernel(self, fit_radius_m: float) -> Kernel:
        if self.local_kernel == "thin_plate":
            return ThinPlateKernel(self.scale_factor * 2.0 * fit_radius_m)
        return _matern(self.scale_factor * fit_radius_m)

    @staticmethod
    def _in_support(cell: Cell, x: np.ndarray) -> np.ndarray:
        near = np.all(np.abs(x - cell.centre) < cell.support_m, axis=1)
        idx = np.flatnonzero(near)
        return idx[np.linalg.norm(x[idx] - cell.centre, axis=1) < cell.support_m]

    def _require_fit(self) -> None:
        if not self.n_contacts:
            raise RuntimeError("the PartitionedGPIS has no contacts yet: call fit() or add() first")

    def _check_query(self, x) -> np.ndarray:
        self._require_fit()
        return _finite_array(x, "query points", (None, 3))


def _matern(length_m: float) -> Kernel:
    """Matern-3/2 with unit prior gradient variance, plus a constant of 5 cm."""
    return SumKernel(Matern32Kernel(length_m, length_m / np.sqrt(3.0)), ConstantKernel(0.05))


class PartitionedVarianceTracker:
    """:meth:`PartitionedGPIS.variance` at a fixed candidate set, kept by one
    :class:`reconstruction.gpis.VarianceTracker` per local fit (over the candidates in its support)
    and one for the global GPIS; rebuilt when the partition changes (a leaf split).

    Parameters
    ----------
    gpis : PartitionedGPIS
    candidates : (m, 3) float, metres
    """

    def __init__(self, gpis: PartitionedGPIS, candidates: np.ndarray):
        self.gpis = gpis
        self.candidates = _finite_array(candidates, "candidates", (None, 3))
        self._partition = -1

    @property
    def nbytes(self) -> int:
        """Memory held by the trackers."""
        if self._partition < 0:
            return 0
        return self._global.nbytes + sum(t.nbytes for t in self._trackers if t is not None)

    def variance(self) -> np.ndarray:
        """(m,) float64."""
        gp = self.gpis
        if self._partition != gp.partition_generation:
            self._build()
        out = gp.global_weight * self._global.variance()
        for (idx, w), tracker in zip(self._weights, self._trackers):
            if tracker is not None:
                out[idx] += w * tracker.variance()
        return out / self._total

    def _build(self) -> None:
        gp = self.gpis
        self._total, self._weights = gp.weights(self.candidates)
        self._global = VarianceTracker(gp.global_gp, self.candidates)
        self._trackers = [VarianceTracker(cell.gp, self.candidates[idx]) if cell.gp is not None and len(idx) else None
                          for cell, (idx, _) in zip(gp.cells, self._weights)]
        self._partition = gp.partition_generation
