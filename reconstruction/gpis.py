"""Gaussian Process Implicit Surface with contact positions and, optionally, surface normals.

Convention: the implicit function ``f`` is **positive inside** the object, **negative outside** and 0
on the surface. Input normals are **outward** unit normals, so a contact with normal ``n`` is observed
as ``f = 0`` and ``grad f = -n`` (4 rows per contact). Near the surface ``f`` then behaves like the
signed distance (metres, positive inside).

Without normals (the classic GPIS) each contact is one row ``f = 0``, plus an inside sample
``f = +1`` at the prior object centre and outside samples ``f = -1`` on a sphere around the region.

The posterior is factored with a Cholesky factor in float64 that grows by one block per contact
(:class:`reconstruction.cholesky.GrowingCholesky`), so :meth:`GPIS.add` costs one triangular
solve instead of a refit. The mean is evaluated in float32 from the float64 weights.
"""
from __future__ import annotations

import contextlib
import copy
import warnings
from typing import Sequence

import numpy as np
import scipy.linalg
import torch

from reconstruction.cholesky import GrowingCholesky, NotPositiveDefiniteError
from reconstruction.kernels import Kernel, QuadraticTrend, kernel_names, make_kernel

#: Names of the registered kernels (:data:`reconstruction.kernels.KERNELS`).
KERNEL_NAMES = kernel_names()

#: Bounding boxes without user bounds are the contacts' box grown by this fraction on each side.
DEFAULT_REGION_PADDING = 0.25


class GPIS:
    """Gaussian process implicit surface.

    Parameters
    ----------
    kernel : str or Kernel
        ``"thin_plate"`` (Williams-Fitzgibbon ``2r^3 - 3Rr^2 + R^3``, positive definite; default),
        ``"thin_plate_reference"`` (the reference work's ``2r^3 + 3Rr^2 + R^3``, indefinite, solved
        by a symmetric indefinite factorisation and refitted on every add), ``"squared_exponential"``
        (length scale a fifth of the region diagonal), or a :class:`Kernel` instance used as given.
        For the named thin-plate kernels ``R`` is chosen once, at the first fit, from the workspace:
        ``max(region diagonal, 1.2 x contact spread)``.
    noise : float
        Standard deviation of the value observations (units of ``f``: metres near the surface when
        normals are used). Must be > 0: it keeps repeated contacts well posed.
    opposing_normal_noise : float, optional
        Normal noise for contacts that have another contact within ``opposing_radius_m`` with an
        opposing normal (the two sides of a thin wall or tip); None uses ``normal_noise`` for all.
        The default, 0.05, was chosen on the generated tuning set (BENCHMARKS.md, issue 10): the
        loose ``normal_noise`` lets the smooth kernel bend the two sides of a 4-7 mm wall into a
        slab that runs on past the rim. With incremental :meth:`add` only the later contact of
        a pair is tightened (rows in the factor keep their noise); :meth:`fit` tightens both.
    opposing_radius_m : float
        The neighbourhood of ``opposing_normal_noise``, metres.
    opposing_overrides_floor : bool
        A contact given a normal-noise floor (a doubtful one, ``add``/``fit`` ``normal_noise``)
        that has an opposing neighbour gets ``opposing_normal_noise`` too. False: the floor wins.
    opposing_gradient_gain : float
        A contact given ``opposing_normal_noise`` is observed as ``grad f = -gain n`` with its noise
        scaled alike: the field rises ``gain`` times faster into a thin wall, so that it does not
        sag through the wall between contacts. 1 (default): a unit gradient like every contact.
    normal_noise : float
        Standard deviation of each gradient component of the normal observations (unitless;
        0.1 is about a 6 deg direction error). The default, 0.2, is twice the sensor's error: a
        sweep over 0.05-0.4 on the reference objects (BENCHMARKS.md) found the smooth kernel
        fits better when it may bend measured normals near edges and under noise.
    use_normals : bool
        Observe gradients (4 rows per contact) or only values plus inside/outside samples.
    bounds : ((3,), (3,)) float, optional
        Workspace box ``((xmin, ymin, zmin), (xmax, ymax, zmax))``, metres, in the contacts' frame.
        Fixes ``R`` and is the default meshing region; contacts outside it are rejected. Without it,
        the region is the contacts' bounding box padded by 25 % per side, and ``R`` grows (with a
        full refit and a warning) if later contacts leave it.
    image_kernel : str or Kernel or None
        The kernel of the copy that observes a symmetry's images (``mesh(symmetry=...)``): a
        registered name (its default for this GPIS's region) or a :class:`Kernel`; None: this
        GPIS's own. The default, ``"matern32"`` (length a quarter of the region diagonal), was
        chosen on the generated tuning set (BENCHMARKS.md, "The images' kernel"): the thin plate's
        ``R`` spans the workspace, and where the images stand 3 mm apart its field rings between
        them, so a thin wall came out thinner with 400 contacts than with 200.
    """

    def __init__(self, kernel: str | Kernel = "thin_plate", noise: float = 5e-4,
                 normal_noise: float = 0.2, use_normals: bool = True,
                 bounds: Sequence[Sequence[float]] | None = None, trend: float | None = 3.0,
                 opposing_normal_noise: float | None = 0.05, opposing_radius_m: float = 0.015,
                 opposing_overrides_floor: bool = False, opposing_gradient_gain: float = 1.0,
                 image_kernel: str | Kernel | None = "matern32"):
        for name, value in (("kernel", kernel), ("image_kernel", image_kernel)):
            if isinstance(value, str) and value not in kernel_names():
                raise ValueError(f"unknown {name} {value!r}; choose one of {', '.join(kernel_names())} "
                                 "or pass a Kernel instance")
            if not isinstance(value, (str, Kernel)) and not (name == "image_kernel" and value is None):
                raise ValueError(f"{name} must be a name or a Kernel instance, got {type(value).__name__}")
        for name, value in (("noise", noise), ("normal_noise", normal_noise)):
            if not (np.isfinite(value) and value > 0):
                raise ValueError(f"{name} must be a positive finite standard deviation, got {value!r}")
        if trend is not None and not (np.isfinite(trend) and trend > 0):
            raise ValueError(f"trend must be None or a positive scale, got {trend!r}")
        if opposing_normal_noise is not None and not (np.isfinite(opposing_normal_noise)
                                                      and opposing_normal_noise > 0):
            raise ValueError(f"opposing_normal_noise must be None or a positive standard deviation, "
                             f"got {opposing_normal_noise!r}")
        if not (np.isfinite(opposing_radius_m) and opposing_radius_m > 0):
            raise ValueError(f"opposing_radius_m must be a positive length, got {opposing_radius_m!r}")
        if not (np.isfinite(opposing_gradient_gain) and opposing_gradient_gain > 0):
            raise ValueError(f"opposing_gradient_gain must be a positive finite factor, got {opposing_gradient_gain!r}")
        self.opposing_normal_noise = None if opposing_normal_noise is None else float(opposing_normal_noise)
        self.opposing_radius_m = float(opposing_radius_m)
        self.opposing_overrides_floor = bool(opposing_overrides_floor)
        self.opposing_gradient_gain = float(opposing_gradient_gain)
        self.trend_spec = None if trend is None else float(trend)
        self.trend: QuadraticTrend | None = None
        self.kernel_spec = kernel
        self.image_kernel = image_kernel
        self.noise = float(noise)
        self.normal_noise = float(normal_noise)
        self.use_normals = bool(use_normals)
        self.bounds = None if bounds is None else _check_bounds(bounds)
        self.kernel: Kernel | None = kernel if isinstance(kernel, Kernel) else None
        self._generation = 0  # counts factorisations, so trackers notice refits
        self._clear()

    # ------------------------------------------------------------------ observations
    def fit(self, points: np.ndarray, normals: np.ndarray | None = None,
            normal_noise: float | np.ndarray | None = None) -> "GPIS":
        """Replace all observations by these contacts and factor the system.

        Parameters
        ----------
        points : (n, 3) float
            Contact positions, metres.
        normals : (n, 3) float, optional
            Outward surface normals (normalised here; zero vectors are an error). Required when
            ``use_normals`` is True, ignored otherwise.
        normal_noise : float or (n,) float, optional
            Per-contact normal noise at least this large (NaN: the default rules), e.g. for a
            contact whose normal is doubtful; None: the default rules for all.
        """
        points, normals = self._check_contacts(points, normals)
        floor = _noise_floor(normal_noise, len(points))
        self._clear()
        self._normal_noise_floor = floor
        self._choose_kernel(points)
        if not self.use_normals:
            prior_points, prior_values = self._inside_outside_samples(points)
            self._stage(prior_points, prior_values, None)
        self._stage(points, np.zeros(len(points)), normals)
        self._normal_noise_floor = None
        self._contact_points.append(points)
        self._contact_noise_floor.append(floor)
        if normals is not None:
            self._contact_normals.append(normals)
        self._factor_all()
        return self

    def add(self, point: np.ndarray, normal: np.ndarray | None = None,
            normal_noise: float | np.ndarray | None = None) -> "GPIS":
        """Add one contact (or a few, as (k, 3) arrays) with a rank-4 update of the factor.

        Before any :meth:`fit`, the first call fits. Adding a contact outside ``bounds`` raises.
        ``normal_noise`` (scalar or (k,), NaN for the default) raises the normal noise of these
        contacts to at least that value (see :meth:`fit`); a refit keeps it.
        """
        points, normals = self._check_contacts(np.atleast_2d(point),
                                               None if normal is None else np.atleast_2d(normal))
        floor = _noise_floor(normal_noise, len(points))
        if not self.n_contacts:
            return self.fit(points, normals, floor)
        if self._needs_larger_radius(points):
            warnings.warn("contacts left the region that fixed the thin-plate radius; refitting "
                          "with a larger radius (pass bounds= to avoid this)", RuntimeWarning,
                          stacklevel=2)
            all_points = np.vstack([self.contact_points, points])
            all_normals = None if normals is None else np.vstack([self.contact_normals, normals])
            return self.fit(all_points, all_normals, np.concatenate(self._contact_noise_floor + [floor]))
        self._normal_noise_floor = floor
        try:
            self._append(points, np.zeros(len(points)), normals)
        finally:
            self._normal_noise_floor = None
        self._contact_points.append(points)
        self._contact_noise_floor.append(floor)
        if normals is not None:
            self._contact_normals.append(normals)
        return self

    def add_values(self, points: np.ndarray, values: np.ndarray, noise: float | None = None) -> "GPIS":
        """Add value-only observations, e.g. free-space evidence (``f < 0`` outside).

        Parameters
        ----------
        points : (k, 3) float, metres
        values : (k,) float, implicit-function values (negative outside)
        noise : float, optional
            Their standard deviation; defaults to ``noise``.

        Any number of points at once. If the update fails (e.g. ``NotPositiveDefiniteError``) the
        GPIS is left exactly as it was before the call.
        """
        points = _finite_array(points, "points", (None, 3))
        values = _finite_array(values, "values", (len(points),))
        if not self.n_contacts:
            raise ValueError("add_values needs at least one contact first (fit or add)")
        if noise is not None and not (np.isfinite(noise) and noise > 0):
            raise ValueError(f"noise must be a positive finite standard deviation, got {noise!r}")
        if self.bounds is not None:
            _check_inside(points, self.bounds)
        self._append(points, values, None, noise)
        return self

    def unfitted_copy(self) -> "GPIS":
        """A GPIS with this one's settings (kernel, noises, trend, bounds) and no observations, to
        rebuild a field from a subset of its evidence (rows cannot be taken out of a factor)."""
        return GPIS(kernel=self.kernel_spec, noise=self.noise, normal_noise=self.normal_noise,
                    use_normals=self.use_normals, bounds=self.bounds, trend=self.trend_spec,
                    opposing_normal_noise=self.opposing_normal_noise, opposing_radius_m=self.opposing_radius_m,
                    opposing_overrides_floor=self.opposing_overrides_floor,
                    opposing_gradient_gain=self.opposing_gradient_gain, image_kernel=self.image_kernel)

    @property
    def n_contacts(self) -> int:
        return sum(len(p) for p in self._contact_points)

    @property
    def contact_points(self) -> np.ndarray:
        """(n, 3) float, the contacts fitted so far."""
        return np.vstack(self._contact_points) if self._contact_points else np.zeros((0, 3))

    @property
    def contact_normals(self) -> np.ndarray | None:
        """(n, 3) float outward normals, or None without normals."""
        return np.vstack(self._contact_normals) if self._contact_normals else None

    @property
    def n_rows(self) -> int:
        """Rows of the linear system (4 per contact with normals)."""
        return len(self._y)

    @property
    def region(self) -> tuple[np.ndarray, np.ndarray]:
        """The box (lo (3,), hi (3,)) that fixed ``R`` and is the default meshing region."""
        self._require_fit()
        return self._region

    # ------------------------------------------------------------------ queries
    def mean(self, x: np.ndarray) -> np.ndarray:
        """Posterior mean of ``f`` at (m, 3) points; (m,) float32."""
        x = self._check_query(x)
        out = _field(self._weights_table(), self._obs_points, self.kernel, x, gradient=False)
        if self.trend is not None:
            out += (self.trend.features(x)[:, 0] * self._trend_coefficient()).astype(np.float32)
        return out

    def gradient(self, x: np.ndarray) -> np.ndarray:
        """Gradient of the posterior mean at (m, 3) points; (m, 3) float32 (points inward)."""
        x = self._check_query(x)
        out = _field(self._weights_table(), self._obs_points, self.kernel, x, gradient=True)
        if self.trend is not None:
            out += (self.trend.features(x)[:, 1:] * self._trend_coefficient()).astype(np.float32)
        return out

    def variance(self, x: np.ndarray, chunk: int = 2048) -> np.ndarray:
        """Posterior variance of ``f`` (noise-free) at (m, 3) points; (m,) float64.

        Full recomputation, O(m n^2); see :class:`VarianceTracker` for a fixed candidate set.
        For the indefinite reference kernel this "variance" can be negative.
        """
        x = self._check_query(x)
        out = np.empty(len(x))
        for s in range(0, len(x), chunk):
            kx = self.cross_covariance(x[s:s + chunk])
            if self._factor is not None:
                w = self._factor.solve_lower(kx)
                out[s:s + chunk] = self.prior_variance(x[s:s + chunk]) - np.einsum("ij,ij->j", w, w)
            else:
                out[s:s + chunk] = self.prior_variance(x[s:s + chunk]) - np.einsum(
                    "ij,ij->j", kx, scipy.linalg.lu_solve(self._lu, kx, check_finite=False))
        return out

    def cross_covariance(self, x: np.ndarray, start: int = 0, stop: int | None = None) -> np.ndarray:
        """Covariance between observation rows ``start:stop`` and ``f`` at (m, 3) points.

        Returns
        -------
        (stop - start, m) float64
        """
        stop = self.n_rows if stop is None else stop
        if not 0 <= start <= stop <= self.n_rows:
            raise ValueError(f"rows {start}:{stop} outside 0:{self.n_rows}")
        points, comps = self._row_point[start:stop], self._row_comp[start:stop]
        used, index = np.unique(points, return_inverse=True)
        full = self._joint(self._obs_points[used], np.asarray(x, float))[:, :, :, 0]
        return full[index, comps]

    def joint_cross_covariance(self, x: np.ndarray) -> np.ndarray:
        """Covariance between every observation row and ``[f, grad f]`` at (m, 3) points.

        What a contact at ``x`` would add is a block of these columns (value, and gradient with
        normals), so a strategy can score hypothetical contacts without adding them.

        Returns
        -------
        (rows, m, 4) float64
        """
        self._require_fit()
        used, index = np.unique(self._row_point, return_inverse=True)
        full = self._joint(self._obs_points[used], np.asarray(x, float))  # (u, 4, m, 4)
        return full[index, self._row_comp]

    def prior_joint_covariance(self, x: np.ndarray, y: np.ndarray) -> np.ndarray:
        """(m, 4, n, 4) prior covariance of ``[f, grad f]`` at (m, 3) ``x`` and (n, 3) ``y``
        (kernel plus trend, as the posterior uses)."""
        self._require_fit()
        return self._joint(np.asarray(x, float), np.asarray(y, float))

    def log_marginal_likelihood(self) -> float:
        """``log p(y)`` of all observations under the prior (kernel, trend, noise), nats.

        ``-y^T K^-1 y / 2 - log|K| / 2 - rows log(2 pi) / 2`` from the Cholesky factor, O(rows) once
        the factor exists. Comparing it between kernels of different length scale chooses a scale
        from the data (:func:`reconstruction.scale_selection.choose_length_scale`).
        """
        self._require_factor()
        log_det = 2.0 * float(np.sum(np.log(np.diag(self._factor.dense()))))
        return float(-0.5 * self._z @ self._z - 0.5 * log_det - 0.5 * self.n_rows * np.log(2 * np.pi))

    def leave_one_out(self) -> tuple[np.ndarray, np.ndarray]:
        """Each contact's value as all other observations predict it, and that prediction's std.

        A contact's four rows (value and gradient) are left out together, in closed form from the
        inverse of the observation covariance (Rasmussen & Williams 2006, sec. 5.4.2, by blocks),
        without a refit: a contact's own gradient rows would otherwise pin its value. The other
        rows keep the noise they have (a contact's neighbours are not rejudged without it). Only
        with normals; O(rows^3) once.

        Returns
        -------
        mean : (n_contacts,) float, metres
            ``f`` at each contact predicted without it (0: the others put the surface through it;
            negative: they put it in free space).
        std : (n_contacts,) float, metres
            The posterior standard deviation of that prediction (noise-free, as :meth:`variance`).
        """
        return self.leave_one_out_with_normals()[:2]

    def leave_one_out_with_normals(self) -> tuple[np.ndarray, np.ndarray, np.ndarray]:
        """:meth:`leave_one_out`'s mean and std and, from the same inverse, the field's unit outward
        normal at each contact as all other observations predict it: (n_contacts, 3), ``-grad f``
        without the contact's four rows, a zero row where they predict no gradient. Only with normals."""
        predicted, block, rows = self._left_out_blocks()
        variance = block[:, 0, 0] - self._noise_var[rows[:, 0]]
        gradient = predicted[:, 1:]
        norm = np.linalg.norm(gradient, axis=1, keepdims=True)
        normals = np.divide(-gradient, norm, out=np.zeros_like(gradient), where=norm > 0)
        return predicted[:, 0], np.sqrt(np.maximum(variance, 0.0)), normals

    def _left_out_blocks(self) -> tuple[np.ndarray, np.ndarray, np.ndarray]:
        """(n, 4) each contact's rows (value, gradient) predicted without them, (n, 4, 4) the
        blocks of the inverse's inverse, (n, 4) the contacts' row indices."""
        self._require_fit()
        if not self.use_normals:
            raise ValueError("leave_one_out needs a GPIS with normals (use_normals=True)")
        eye = np.eye(self.n_rows)
        if self._factor is not None:
            whitened = self._factor.solve_lower(eye)
            inverse = whitened.T @ whitened
        else:
            inverse = scipy.linalg.lu_solve(self._lu, eye, check_finite=False)
        contacts = np.unique(self._row_point[self._row_comp > 0])
        rows = np.full((len(contacts), 4), -1)
        mine = np.flatnonzero(np.isin(self._row_point, contacts))
        rows[np.searchsorted(contacts, self._row_point[mine]), self._row_comp[mine]] = mine
        block = np.linalg.inv(inverse[rows[:, :, None], rows[:, None, :]])  # (n, 4, 4)
        residual = np.einsum("nij,nj->ni", block, (inverse @ self._y)[rows])
        return self._y[rows] - residual, block, rows

    # ------------------------------------------------------------------ factor (for trackers)
    @property
    def positive_definite(self) -> bool:
        """Whether the system is positive definite, so a growing Cholesky factor holds it."""
        self._require_fit()
        return bool(self.kernel.positive_definite)

    @property
    def generation(self) -> int:
        """Counts full factorisations (fit, radius growth); unchanged by incremental adds."""
        return self._generation

    def whiten(self, rhs: np.ndarray) -> np.ndarray:
        """``L^-1 rhs`` with ``L`` the Cholesky factor of the observation covariance.

        Parameters
        ----------
        rhs : (rows,) or (rows, r) float
        """
        self._require_factor()
        return self._factor.solve_lower(rhs)

    def factor_rows(self, start: int, stop: int) -> np.ndarray:
        """Rows of the Cholesky factor, ``L[start:stop, :stop]``; (stop - start, stop) float64."""
        self._require_factor()
        return self._factor.rows(start, stop)

    def prior_variance(self, x: np.ndarray) -> np.ndarray:
        """(m,) prior variance of ``f`` at (m, 3) points."""
        base = np.full(len(x), self.kernel.prior_variance)
        return base if self.trend is None else base + self.trend.variance(x)

    def variance_tracker(self, candidates: np.ndarray) -> "VarianceTracker":
        """A tracker of the variance at a fixed (m, 3) candidate set, updated per contact."""
        return VarianceTracker(self, candidates)

    def mesh(self, bounds: Sequence[Sequence[float]] | None = None, resolution: int = 64,
             max_std_m: float | None = None, outside_evidence: bool = True, symmetry=False,
             refine_steps: int | None = None, cut_at_faces: bool = True):
        """The mean surface (0-level set) as a ``trimesh.Trimesh`` with outward normals.

        Parameters
        ----------
        bounds : ((3,), (3,)) float, optional
            Box to mesh; defaults to ``bounds`` or the padded contact box.
        resolution : int
            Grid samples along the longest side (cubic voxels).
        max_std_m : float, optional
            Keep only faces where the posterior standard deviation of ``f`` is at most this
            (metres), cutting phantom surface far from the contacts; faces near a contact are
            always kept (:func:`reconstruction.confidence.confident_surface`). The mesh is then
            open where it was cut. None (default) returns the closed 0-level set.
        outside_evidence : bool
            Mesh a copy that takes the space well outside both the contacts' convex hull and
            their tangent planes as free where the mean still puts solid there
            (:mod:`reconstruction.outside_evidence`): removes phantom lobes past sparse rims, and
            leaves a convex object's surface alone however few its contacts (BENCHMARKS.md,
            issue 10). Only with normals; this GPIS is not changed. False: the plain mean.
        symmetry : bool or Symmetry
            True: mesh a copy that also observes the contacts' images under the mirror planes or
            the axis of revolution the contacts support (:meth:`symmetry`; none found: no
            change); a :class:`reconstruction.symmetry.Symmetry`: under that one. Only with
            normals; this GPIS is not changed. False (default): no images. The images of a
            contact that the field with the images, the contact left out, puts in free space are
            left out; the mesh's ``metadata["symmetry_disputed_contacts"]`` lists those contacts.
        refine_steps : int, optional
            Evaluations of the mean per vertex that move it along its grid edge to the 0-level
            (:func:`reconstruction.meshing.mesh_zero_level`); None: its default, 2. 0: the linear
            interpolation of marching cubes, which puts thin walls a third of a voxel too thin.
        cut_at_faces : bool
            Mesh ``min(mean, clearance)`` of the whole flat faces this GPIS's contacts support
            (:func:`reconstruction.face_planes.whole_face_planes`): nothing stands in front of a flat
            face that no contact stands in front of, so the lobe a smooth mean rounds past a sharp
            corner between such faces is cut at their planes (BENCHMARKS.md, issue 10). Only with
            normals; the faces come from the contacts, not from symmetric images. False: uncut.
        """
        from reconstruction.confidence import mean_surface

        self._require_fit()
        cut = None
        if cut_at_faces and self.use_normals:
            from reconstruction.face_planes import whole_face_planes

            normals = self.contact_normals
            cut = whole_face_planes(self.contact_points, normals / np.linalg.norm(normals, axis=1, keepdims=True))
        model, disputed = self, None
        if symmetry is not False and self.use_normals:
            model, disputed = self._with_symmetric_images(self.symmetry() if symmetry is True else symmetry)
        if outside_evidence and self.use_normals:
            from reconstruction.outside_evidence import add_outside_evidence

            model = copy.deepcopy(self) if model is self else model
            add_outside_evidence(model)
        surface = mean_surface(model, self._region if bounds is None else _check_bounds(bounds), resolution,
                               max_std_m, refine_steps, cut)
        if disputed is not None:
            surface.metadata["symmetry_disputed_contacts"] = np.flatnonzero(disputed)
        return surface

    def symmetry(self):
        """The mirror planes or axis of revolution this GPIS's contacts support
        (:func:`reconstruction.symmetry.find_symmetry`, judged with this GPIS's mean)."""
        from reconstruction.symmetry import Symmetry, find_symmetry

        if not (self.use_normals and self.n_contacts):
            return Symmetry()
        return find_symmetry(self.contact_points, self.contact_normals, self)

    def _with_symmetric_images(self, found) -> tuple["GPIS", np.ndarray]:
        """A copy observing the contacts' images under ``found`` as contacts, or this GPIS if none,
        and (n_contacts,) bool: the contacts whose images were left out as disputed.
        Images outside the GPIS's region are not used (they are inferred, not measured), nor those
        both the contacts' hull and this GPIS's mean put off the surface
        (:func:`reconstruction.symmetry.contradicted_images`: a feature a near symmetry copies),
        nor the images of a contact that the field with the images, the contact left out, puts in
        free space (:func:`reconstruction.symmetry.disputed_contacts`, re-judged without those)."""
        from reconstruction.symmetry import SymmetrySettings, contradicted_images, disputed_contacts

        settings = SymmetrySettings()
        points, normals = self.contact_points, self.contact_normals
        priority = None
        if found.rank_images:
            # Keep the copy of the contact the others predict best, in their own standard
            # deviations (off by default: no better on the tuning split, see SymmetrySettings).
            mean, std = self.leave_one_out()
            priority = np.abs(mean) / np.maximum(std, 1e-9)
        images, image_normals, sources = found.images(points, normals, settings, return_sources=True,
                                                      priority=priority)
        lo, hi = self.region
        used = np.all((images > lo) & (images < hi), axis=1)
        if used.any():
            used[used] = ~contradicted_images(self, images[used], settings)
        disputed = np.zeros(len(points), bool)
        if not used.any():
            return self, disputed
        try:
            base = self._under_image_kernel()  # once for every re-judged set of images
        except NotPositiveDefiniteError as exc:
            warnings.warn(f"the symmetric images were left out of the mesh: {exc}")
            return self, disputed
        model = self._observing(images[used], image_normals[used], base)
        for _ in range(settings.dispute_rounds):
            if model is self:
                break
            disputed |= disputed_contacts(model, len(points), settings)
            dropped = used & disputed[sources]
            if not dropped.any():
                break
            used &= ~dropped
            model = self._observing(images[used], image_normals[used], base) if used.any() else self
        return model, disputed

    def _observing(self, images: np.ndarray, image_normals: np.ndarray, base: "GPIS | None" = None) -> "GPIS":
        """A copy of ``base`` (default: :meth:`_under_image_kernel`) that also observes ``images`` as
        contacts; this GPIS if that is not positive definite."""
        try:
            base = self._under_image_kernel() if base is None else base
            model = copy.deepcopy(base, {id(base.kernel): base.kernel})  # a kernel is only parameters: shared
            model.add(images, image_normals)
        except NotPositiveDefiniteError as exc:
            warnings.warn(f"the symmetric images were left out of the mesh: {exc}")
            return self
        return model

    def _under_image_kernel(self) -> "GPIS":
        """This GPIS, or with an ``image_kernel`` a copy of it refactored under that kernel
        (every row as it is, O(rows^3)): the base that observes a symmetry's images."""
        if self.image_kernel is None:
            return self
        model = copy.deepcopy(self)
        model.kernel = model.kernel_spec = self._image_kernel()
        model._factor_all()
        return model

    # ------------------------------------------------------------------ internals
    def _image_kernel(self) -> Kernel:
        if isinstance(self.image_kernel, Kernel):
            return self.image_kernel
        lo, hi = self._region
        points = self._obs_points
        return make_kernel(self.image_kernel, float(np.linalg.norm(hi - lo)),
                           float(np.linalg.norm(points.max(0) - points.min(0))))

    def _joint(self, x: np.ndarray, y: np.ndarray) -> np.ndarray:
        """(m, 4, n, 4) prior covariance of ``[f, grad f]``: kernel plus trend."""
        cov = self.kernel.joint_covariance(x, y)
        return cov if self.trend is None else cov + self.trend.joint_covariance(x, y)

    def _trend_coefficient(self) -> float:
        """Posterior mean of the trend's ``gamma``: ``s^2 sum_rows alpha_row feature_row``."""
        table = self._weights_table()
        feats = self.trend.features(self._obs_points)
        return float(self.trend.scale_per_m**2 * np.sum(table * feats))

    def _clear(self) -> None:
        if not isinstance(self.kernel_spec, Kernel):
            self.kernel = None
        self._contact_points: list[np.ndarray] = []
        self._contact_normals: list[np.ndarray] = []
        self._contact_noise_floor: list[np.ndarray] = []  # per contact, NaN: the default rules
        self._normal_noise_floor: np.ndarray | None = None  # of the contacts being staged
        self._obs_points = np.zeros((0, 3))
        self._row_point = np.zeros(0, dtype=int)
        self._row_comp = np.zeros(0, dtype=int)
        self._y = np.zeros(0)
        self._noise_var = np.zeros(0)
        self._factor: GrowingCholesky | None = None
        self._lu = None
        self._z = np.zeros(0)
        self._alpha: np.ndarray | None = None

    def _choose_kernel(self, points: np.ndarray) -> None:
        lo, hi = points.min(0), points.max(0)
        if self.bounds is not None:
            _check_inside(points, self.bounds)
            region = self.bounds
        else:
            pad = DEFAULT_REGION_PADDING * max(float(np.max(hi - lo)), 1e-3)
            region = (lo - pad, hi + pad)
        self._region = (np.asarray(region[0], float), np.asarray(region[1], float))
        diagonal = float(np.linalg.norm(self._region[1] - self._region[0]))
        if self.trend_spec is not None and self.use_normals:
            centre = 0.5 * (self._region[0] + self._region[1])
            self.trend = QuadraticTrend(centre, self.trend_spec / (0.5 * diagonal))
        if isinstance(self.kernel_spec, str):
            self.kernel = make_kernel(self.kernel_spec, diagonal, float(np.linalg.norm(hi - lo)))

    def _needs_larger_radius(self, points: np.ndarray) -> bool:
        if self.bounds is not None:
            _check_inside(points, self.bounds)
            return False
        if not isinstance(self.kernel_spec, str) or not self.kernel.grows_with_workspace:
            return False
        lo, hi = self._region
        return bool(np.any(points < lo) or np.any(points > hi))

    def _inside_outside_samples(self, points: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
        """+1 at the prior centre, -1 at 14 points (box corners and face centres) on the region."""
        lo, hi = self._region
        centre = 0.5 * (lo + hi)
        half = 0.5 * (hi - lo)
        dirs = np.array([[sx, sy, sz] for sx in (-1, 1) for sy in (-1, 1) for sz in (-1, 1)]
                        + [list(v) for v in np.vstack([np.eye(3), -np.eye(3)])], float)
        outside = centre + dirs * half
        return np.vstack([centre, outside]), np.concatenate([[1.0], -np.ones(len(outside))])

    def _observation_rows(self, points, values, normals, noise):
        """Rows (point index offsets, component, y, noise variance) for a block of points."""
        k = len(points)
        if normals is None:
            comps = np.zeros((k, 1), int)
            y = values[:, None]
            var = np.full((k, 1), (self.noise if noise is None else noise) ** 2)
        else:
            comps = np.tile(np.arange(4), (k, 1))
            normal_std, gain = self._normal_noise_per_contact(points, normals)
            y = np.column_stack([values, -normals * gain[:, None]])
            var = np.column_stack([np.full(k, self.noise**2), np.repeat((normal_std * gain)[:, None] ** 2, 3, 1)])
        offsets = np.repeat(np.arange(k), comps.shape[1])
        return offsets, comps.ravel(), y.ravel(), var.ravel()

    def _normal_noise_per_contact(self, points: np.ndarray, normals: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
        """(k,) normal noise and (k,) gradient gain of new contacts (:meth:`_gradient_noise`), judged
        against the contacts already fitted and each other, with the floor being staged."""
        floor = self._normal_noise_floor
        return self._gradient_noise(points, normals, floor if floor is not None and len(floor) == len(points) else None,
                                    np.vstack([self.contact_points, points]),
                                    np.vstack([self.contact_normals, normals]) if self._contact_normals else normals)

    def _gradient_noise(self, points: np.ndarray, normals: np.ndarray, floor: np.ndarray | None,
                        others_p: np.ndarray, others_n: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
        """(k,) normal noise and (k,) gradient gain of contacts ``points``, ``normals`` among the
        contacts ``others_p``, ``others_n`` (they may include these): ``opposing_normal_noise`` and
        ``opposing_gradient_gain`` for a contact with another within ``opposing_radius_m`` whose
        normal opposes its own (cosine < -0.5: the two sides of a thin wall or a sharp tip),
        ``normal_noise`` and 1 otherwise. A contact given a noise floor (``add``/``fit``
        ``normal_noise``, ``floor`` (k,) with NaN for none) has at least that and is tightened only
        with ``opposing_overrides_floor``.

        Contacts already in the factor keep the noise they were added with until the next fit
        (or :meth:`reassess_contact_noise`).
        """
        out = np.full(len(points), self.normal_noise)
        gain = np.ones(len(points))
        if floor is not None:
            out = np.fmax(out, floor)
        if self.opposing_normal_noise is None:
            return out, gain
        tight = _opposing(points, normals, others_p, others_n, self.opposing_radius_m)
        if floor is not None and not self.opposing_overrides_floor:
            tight &= ~np.isfinite(floor)
        out[tight] = self.opposing_normal_noise
        gain[tight] = self.opposing_gradient_gain
        return out, gain

    def thin_wall_contacts(self) -> np.ndarray:
        """(n,) bool: the contacts with another within ``opposing_radius_m`` whose normal opposes
        theirs (cosine < -0.5), all contacts known; all False without normals."""
        normals = self.contact_normals
        if normals is None:
            return np.zeros(self.n_contacts, bool)
        points = self.contact_points
        return _opposing(points, normals, points, normals, self.opposing_radius_m)

    def reassess_contact_noise(self) -> "GPIS":
        """Give every contact the normal noise and gradient gain the rules give with all contacts
        known, and refactor (one full factorisation, O(rows^3)).

        :meth:`add` judges a contact against the contacts before it, so the side of a thin wall
        touched first keeps ``normal_noise`` after its opposite side was touched; :meth:`fit` of
        the same contacts would have tightened both. This does that without losing the value rows
        (free space) added since. In place; returns ``self``; if the factorisation fails the GPIS is
        left as it was.
        """
        self._require_fit()
        grad_rows = np.flatnonzero(self._row_comp > 0)
        if not len(grad_rows):
            return self
        points, normals = self.contact_points, self.contact_normals
        floor = np.concatenate(self._contact_noise_floor)
        std, gain = self._gradient_noise(points, normals, floor, points, normals)
        # Contacts are the observation points with gradient rows, in the order they were added.
        contact = np.searchsorted(np.unique(self._row_point[grad_rows]), self._row_point[grad_rows])
        component = self._row_comp[grad_rows] - 1
        with self._restored_on_failure():
            self._y = self._y.copy()
            self._noise_var = self._noise_var.copy()
            self._y[grad_rows] = -normals[contact, component] * gain[contact]
            self._noise_var[grad_rows] = (std * gain)[contact] ** 2
            self._factor_all()
        return self

    def _stage(self, points, values, normals, noise=None):
        """Append observation rows without touching the factor."""
        offsets, comps, y, var = self._observation_rows(points, values, normals, noise)
        self._row_point = np.concatenate([self._row_point, offsets + len(self._obs_points)])
        self._row_comp = np.concatenate([self._row_comp, comps])
        self._y = np.concatenate([self._y, y])
        self._noise_var = np.concatenate([self._noise_var, var])
        self._obs_points = np.vstack([self._obs_points, points])

    def _factor_all(self) -> None:
        full = self._joint(self._obs_points, self._obs_points)
        K = full[self._row_point, self._row_comp][:, self._row_point, self._row_comp]
        K[np.diag_indices_from(K)] += self._noise_var
        self._generation += 1
        self._alpha = None
        if self.positive_definite:
            self._factor = GrowingCholesky(K)
            self._z = self._factor.solve_lower(self._y)
        else:
            self._factor = None
            self._lu = scipy.linalg.lu_factor(K, check_finite=False)
            self._K = K


    def _append(self, points, values, normals, noise=None):
        """Add observation rows and update the factor; on any failure the GPIS is left as it was."""
        with self._restored_on_failure():
            self._append_unguarded(points, values, normals, noise)

    @contextlib.contextmanager
    def _restored_on_failure(self):
        """Put the observations and the factor back as they were if the block raises."""
        saved = {name: getattr(self, name) for name in _OBSERVATION_STATE}
        n_factor = None if self._factor is None else self._factor.n
        try:
            yield
        except BaseException:
            for name, value in saved.items():
                setattr(self, name, value)
            if self._factor is not None and n_factor is not None:
                self._factor.truncate(n_factor)
            raise

    def _append_unguarded(self, points, values, normals, noise):
        if not self.positive_definite:
            self._stage(points, values, normals, noise)
            self._factor_all()
            return
        n_rows_old = self.n_rows
        offsets, comps, y, var = self._observation_rows(points, values, normals, noise)
        full_old = self._joint(self._obs_points, points)
        cross = full_old[self._row_point, self._row_comp][:, offsets, comps]
        full_new = self._joint(points, points)
        block = full_new[offsets, comps][:, offsets, comps]
        block[np.diag_indices_from(block)] += var
        new_rows = self._factor.append(cross, block)
        z_new = scipy.linalg.solve_triangular(
            new_rows[:, n_rows_old:], y - new_rows[:, :n_rows_old] @ self._z, lower=True)
        self._z = np.concatenate([self._z, z_new])
        self._stage(points, values, normals, noise)
        self._alpha = None

    def _weights_table(self) -> np.ndarray:
        """(points, 4) float64: the posterior weights K^-1 y arranged per observation point."""
        self._require_fit()
        if self._alpha is None:
            if self._factor is not None:
                self._alpha = self._factor.solve_upper(self._z)
            else:
                self._alpha = scipy.linalg.lu_solve(self._lu, self._y, check_finite=False)
        table = np.zeros((len(self._obs_points), 4))
        np.add.at(table, (self._row_point, self._row_comp), self._alpha)
        return table

    def _require_factor(self) -> None:
        self._require_fit()
        if self._factor is None:
            raise RuntimeError(f"the kernel {self.kernel!r} is not positive definite: its system has "
                               "no Cholesky factor")

    def _require_fit(self) -> None:
        if self.kernel is None or not self.n_rows:
            raise RuntimeError("the GPIS has no observations yet: call fit() or add() first")

    def _check_query(self, x) -> np.ndarray:
        self._require_fit()
        return _finite_array(x, "query points", (None, 3))

    def _check_contacts(self, points, normals):
        points = _finite_array(points, "points", (None, 3))
        if len(points) == 0:
            raise ValueError("no contact points given (points has shape (0, 3))")
        if not self.use_normals:
            return points, None
        if normals is None:
            raise ValueError("use_normals=True needs normals (n, 3), one outward normal per point")
        normals = _finite_array(normals, "normals", (len(points), 3))
        length = np.linalg.norm(normals, axis=1)
        if np.any(length < 1e-6):
            raise ValueError(f"normals {np.flatnonzero(length < 1e-6).tolist()} are zero vectors; "
                             "each contact needs an outward surface direction")
        return points, normals / length[:, None]


class VarianceTracker:
    """Posterior variance at a fixed candidate set, updated incrementally as contacts arrive.

    Keeps ``W = L^-1 k_*`` (rows x candidates) and extends it by the new rows of the factor after
    each :meth:`GPIS.add`: ``W_new = M^-1 (k_new - S^T W)``, one pass over ``W`` instead of a
    triangular solve with all candidates. A refit of the GPIS triggers a full recomputation.
    ``W`` is stored transposed, (candidates x row capacity), so the update is one tall-skinny
    product over contiguous rows; it stays float64 because ``M^-1`` has entries up to 1/noise,
    which would amplify float32 rounding of ``S^T W`` into visible variance errors.

    Parameters
    ----------
    gpis : GPIS
    candidates : (m, 3) float, metres
    """

    def __init__(self, gpis: GPIS, candidates: np.ndarray):
        if not gpis.positive_definite:
            raise ValueError("incremental variance needs a positive definite kernel")
        self.gpis = gpis
        self.candidates = _finite_array(candidates, "candidates", (None, 3))
        self._generation = -1
        self._rows = 0
        self._Wt = np.zeros((len(self.candidates), 0))
        self._variance = np.zeros(len(self.candidates))

    @property
    def nbytes(self) -> int:
        """Memory held by the tracker."""
        return self._Wt.nbytes + self._variance.nbytes

    def variance(self) -> np.ndarray:
        """(m,) float64 posterior variance at the candidates."""
        gp = self.gpis
        if self._generation != gp.generation:
            self._recompute()
        elif self._rows < gp.n_rows:
            self._extend()
        return self._variance

    def _recompute(self) -> None:
        gp = self.gpis
        W = gp.whiten(gp.cross_covariance(self.candidates))
        self._variance = gp.prior_variance(self.candidates) - np.einsum("ij,ij->j", W, W)
        self._Wt = np.zeros((len(self.candidates), 0))
        self._store(W, used=0)
        self._rows = gp.n_rows
        self._generation = gp.generation

    def _extend(self) -> None:
        gp = self.gpis
        start, stop = self._rows, gp.n_rows
        rows = gp.factor_rows(start, stop)
        k_new = gp.cross_covariance(self.candidates, start, stop)
        rhs = k_new - (self._Wt[:, :start] @ rows[:, :start].T).T
        W_new = scipy.linalg.solve_triangular(rows[:, start:], rhs, lower=True)
        self._variance = self._variance - np.einsum("ij,ij->j", W_new, W_new)
        self._store(W_new, used=start)
        self._rows = stop

    def _store(self, new_rows: np.ndarray, used: int) -> None:
        """Write rows used.. of W (as columns of W^T), doubling the capacity when full."""
        need = used + len(new_rows)
        if self._Wt.shape[1] < need:
            grown = np.zeros((len(self.candidates), max(need, 2 * self._Wt.shape[1], 64)))
            grown[:, :used] = self._Wt[:, :used]
            self._Wt = grown
        self._Wt[:, used:need] = new_rows.T


def _opposing(points: np.ndarray, normals: np.ndarray, others_p: np.ndarray, others_n: np.ndarray,
              radius_m: float) -> np.ndarray:
    """(k,) bool: ``points`` with one of ``others_p`` within ``radius_m`` whose normal opposes
    theirs (cosine < -0.5: the two sides of a thin wall or a sharp tip)."""
    from scipy.spatial import cKDTree

    out = np.zeros(len(points), bool)
    for i, near in enumerate(cKDTree(others_p).query_ball_point(points, radius_m)):
        out[i] = bool(near) and float(np.min(others_n[near] @ normals[i])) < -0.5
    return out


def _noise_floor(normal_noise, n: int) -> np.ndarray:
    """(n,) per-contact normal-noise floor from a scalar, an (n,) array or None (NaN: none)."""
    if normal_noise is None:
        return np.full(n, np.nan)
    floor = np.broadcast_to(np.asarray(normal_noise, float), (n,)).copy()
    if np.any(floor[np.isfinite(floor)] <= 0) or np.any(np.isinf(floor)):
        raise ValueError(f"normal_noise must be positive finite standard deviations (NaN: default), got {normal_noise!r}")
    return floor


#: Attributes an append replaces (never mutates in place), restored when an append fails.
_OBSERVATION_STATE = ("_obs_points", "_row_point", "_row_comp", "_y", "_noise_var", "_z", "_alpha",
                      "_factor", "_lu", "_generation")


# ---------------------------------------------------------------------- field evaluation
def _field(weights: np.ndarray, points: np.ndarray, kernel: Kernel, x: np.ndarray,
           gradient: bool, chunk: int = 8192) -> np.ndarray:
    """``f(x) = sum_p w_p0 phi(r) - g(r) (d . w_p,1:4)`` and its gradient, in float32.

    ``d = x - p``. Coordinates are centred on the observation points first so float32 keeps
    sub-micrometre resolution.
    """
    centre = points.mean(0)
    c = torch.from_numpy((points - centre).astype(np.float32))
    w0 = torch.from_numpy(weights[:, 0].astype(np.float32))
    beta = torch.from_numpy(weights[:, 1:].astype(np.float32))
    c_beta = (c * beta).sum(1)
    c_sq = (c * c).sum(1)
    out = np.empty((len(x), 3) if gradient else len(x), np.float32)
    for s in range(0, len(x), chunk):
        xs = torch.from_numpy((x[s:s + chunk] - centre).astype(np.float32))
        r = torch.sqrt(torch.clamp((xs * xs).sum(1, keepdim=True) + c_sq - 2.0 * xs @ c.T, min=0.0))
        d_beta = xs @ beta.T - c_beta
        g = _radial(kernel.g, r)
        if not gradient:
            out[s:s + chunk] = (_radial(kernel.phi, r) @ w0 - (g * d_beta).sum(1)).numpy()
            continue
        q_over_r2 = _radial(kernel.q, r) / torch.clamp(r * r, min=1e-20)
        a = g * w0 - q_over_r2 * d_beta
        grad = a.sum(1, keepdim=True) * xs - a @ c - g @ beta
        out[s:s + chunk] = grad.numpy()
    return out


def _radial(fn, r: torch.Tensor) -> torch.Tensor:
    """Apply a kernel's numpy radial function to a float32 tensor without leaving float32."""
    return torch.from_numpy(np.asarray(fn(r.numpy()), dtype=np.float32))


# ---------------------------------------------------------------------- validation
def _finite_array(value, name: str, shape: tuple) -> np.ndarray:
    try:
        arr = np.asarray(value, dtype=float)
    except (TypeError, ValueError) as exc:
        raise ValueError(f"{name} must be numeric, got {type(value).__name__}") from exc
    if arr.ndim != len(shape) or any(s is not None and a != s for a, s in zip(arr.shape, shape)):
        want = "(" + ", ".join("n" if s is None else str(s) for s in shape) + ")"
        raise ValueError(f"{name} must have shape {want}, got {arr.shape}")
    bad = ~np.isfinite(arr)
    if bad.any():
        rows = np.unique(np.nonzero(bad)[0]).tolist()[:10]
        raise ValueError(f"{name} contain NaN or inf (rows {rows})")
    return arr


def _check_bounds(bounds) -> tuple[np.ndarray, np.ndarray]:
    arr = _finite_array(bounds, "bounds", (2, 3))
    if np.any(arr[1] <= arr[0]):
        raise ValueError(f"bounds must be ((xmin, ymin, zmin), (xmax, ymax, zmax)) with min < max, "
                         f"got {arr.tolist()}")
    return arr[0].copy(), arr[1].copy()


def _check_inside(points: np.ndarray, bounds) -> None:
    lo, hi = bounds
    outside = np.any((points < lo) | (points > hi), axis=1)
    if outside.any():
        i = int(np.flatnonzero(outside)[0])
        raise ValueError(f"point {points[i].tolist()} lies outside the GPIS bounds "
                         f"{lo.tolist()} - {hi.tolist()}")
