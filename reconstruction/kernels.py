"""Covariance kernels for GPIS with value and gradient observations.

Every kernel here is stationary and isotropic, ``k(x, y) = phi(r)`` with ``d = x - y`` and
``r = |d|``. Its derivative blocks follow from three radial functions:

* ``phi(r)``                      value,                      ``k``
* ``g(r) = phi'(r) / r``          so that ``dk/dx = g(r) d``
* ``q(r) = phi''(r) - phi'(r)/r`` so that ``d2k/dx dx^T = g(r) I + q(r) u u^T``, ``u = d / r``

(``q`` is finite at r = 0 for the kernels below, and ``u`` is taken as 0 there.) For a GP ``f`` with
covariance ``k`` the joint covariance of ``[f, grad f]`` at ``x`` and at ``y`` is then

* ``cov(f(x), f(y))            = phi``
* ``cov(f(x), d f(y)/dy_b)     = -g d_b``
* ``cov(d f(x)/dx_a, f(y))     = +g d_a``
* ``cov(d f(x)/dx_a, d f(y)/dy_b) = -(g delta_ab + q u_a u_b)``

These are derived here directly (the reference paper's printed derivative formulas contain sign and
coefficient slips) and every block is tested against finite differences of ``phi``.
"""
from __future__ import annotations

import abc

import numpy as np


class Kernel(abc.ABC):
    """A stationary isotropic kernel described by its radial functions (see module docstring).

    Attributes
    ----------
    name : str
        The registry name (set by :func:`register_kernel`; empty for unregistered kernels).
    positive_definite : bool
        Whether the joint covariance of values and gradients is positive definite for points in the
        workspace the kernel was made for. The GPIS factors a positive definite system with a
        growing Cholesky factor (incremental add, variance tracker) and anything else with a
        symmetric indefinite factorisation that is refitted on every add.
    grows_with_workspace : bool
        Whether :meth:`for_workspace` depends on the workspace size, so that contacts outside the
        region the kernel was made for need a new kernel (and a refit).
    """

    name: str = ""
    positive_definite: bool = True
    grows_with_workspace: bool = False

    @classmethod
    def for_workspace(cls, region_diagonal_m: float, contact_spread_m: float) -> "Kernel":
        """The kernel's default for a workspace: region diagonal and contacts' spread, metres."""
        raise NotImplementedError(f"{cls.__name__} has no default for a workspace; pass an instance")

    @abc.abstractmethod
    def phi(self, r: np.ndarray) -> np.ndarray:
        """Kernel value at distance ``r`` (any shape, metres)."""

    @abc.abstractmethod
    def g(self, r: np.ndarray) -> np.ndarray:
        """``phi'(r) / r``, finite at r = 0."""

    @abc.abstractmethod
    def q(self, r: np.ndarray) -> np.ndarray:
        """``phi''(r) - phi'(r) / r``, finite at r = 0."""

    @property
    def prior_variance(self) -> float:
        """``k(x, x)``, the prior variance of the function value."""
        return float(self.phi(np.zeros(1))[0])

    def value(self, x: np.ndarray, y: np.ndarray) -> np.ndarray:
        """``k(x_i, y_j)``.

        Parameters
        ----------
        x : (m, 3) float
        y : (n, 3) float

        Returns
        -------
        (m, n) float
        """
        return self.phi(_distances(x, y))

    def gradient(self, x: np.ndarray, y: np.ndarray) -> np.ndarray:
        """``d k(x_i, y_j) / d x_i``, shape (m, n, 3)."""
        d = x[:, None, :] - y[None, :, :]
        return self.g(np.linalg.norm(d, axis=-1))[..., None] * d

    def hessian(self, x: np.ndarray, y: np.ndarray) -> np.ndarray:
        """``d^2 k(x_i, y_j) / d x_i d x_i^T``, shape (m, n, 3, 3)."""
        d = x[:, None, :] - y[None, :, :]
        r = np.linalg.norm(d, axis=-1)
        u = _unit(d, r)
        eye = np.eye(3)
        return (self.g(r)[..., None, None] * eye
                + self.q(r)[..., None, None] * u[..., :, None] * u[..., None, :])

    def joint_covariance(self, x: np.ndarray, y: np.ndarray) -> np.ndarray:
        """Covariance of ``[f, df/dx, df/dy, df/dz]`` at each ``x_i`` with the same at each ``y_j``.

        Parameters
        ----------
        x : (m, 3) float
        y : (n, 3) float

        Returns
        -------
        (m, 4, n, 4) float
            ``out[i, a, j, b]``; component 0 is the value, 1-3 the gradient.
        """
        x = np.asarray(x, dtype=float)
        y = np.asarray(y, dtype=float)
        d = x[:, None, :] - y[None, :, :]
        r = np.linalg.norm(d, axis=-1)
        u = _unit(d, r)
        phi, g, q = self.phi(r), self.g(r), self.q(r)
        out = np.empty((x.shape[0], y.shape[0], 4, 4))
        out[..., 0, 0] = phi
        out[..., 0, 1:] = -g[..., None] * d
        out[..., 1:, 0] = g[..., None] * d
        out[..., 1:, 1:] = -(g[..., None, None] * np.eye(3)
                             + q[..., None, None] * u[..., :, None] * u[..., None, :])
        return out.transpose(0, 2, 1, 3)


#: Registered kernels by name, in registration order (see :func:`register_kernel`).
KERNELS: dict[str, type[Kernel]] = {}


def register_kernel(name: str):
    """Class decorator: register a :class:`Kernel` subclass under ``name``.

    The class must implement :meth:`Kernel.for_workspace`; the GPIS builds named kernels with it.
    """
    def decorate(cls: type[Kernel]) -> type[Kernel]:
        if not (isinstance(cls, type) and issubclass(cls, Kernel)):
            raise TypeError(f"register_kernel needs a Kernel subclass, got {cls!r}")
        if name in KERNELS and KERNELS[name] is not cls:
            raise ValueError(f"kernel name {name!r} is already registered by {KERNELS[name].__name__}")
        cls.name = name
        KERNELS[name] = cls
        return cls
    return decorate


def kernel_names() -> tuple[str, ...]:
    """Names of the registered kernels."""
    return tuple(KERNELS)


def make_kernel(name: str, region_diagonal_m: float, contact_spread_m: float = 0.0) -> Kernel:
    """The registered kernel ``name`` with its default for a workspace.

    Parameters
    ----------
    name : str
        One of :func:`kernel_names`.
    region_diagonal_m : float
        Diagonal of the box in which the GP is evaluated, metres.
    contact_spread_m : float
        Largest distance between observed points, metres.
    """
    if name not in KERNELS:
        raise ValueError(f"unknown kernel {name!r}; choose one of {', '.join(KERNELS)} "
                         "or pass a Kernel instance")
    return KERNELS[name].for_workspace(region_diagonal_m, contact_spread_m)


@register_kernel("thin_plate")
class ThinPlateKernel(Kernel):
    """Thin-plate covariance ``phi(r) = 2 r^3 - 3 R r^2 + R^3`` (Williams and Fitzgibbon, 2007).

    Positive definite with gradient observations when ``R`` is at least the largest distance between
    any two points the GP sees (``R`` is chosen once from the workspace, see
    :func:`thin_plate_radius`). ``g = 6 (r - R)``, ``q = 6 r``.

    Parameters
    ----------
    radius_m : float
        ``R``, metres.
    """

    sign = -1.0
    positive_definite = True
    grows_with_workspace = True

    @classmethod
    def for_workspace(cls, region_diagonal_m, contact_spread_m):
        """``R`` from :func:`thin_plate_radius`."""
        return cls(thin_plate_radius(region_diagonal_m, contact_spread_m))

    def __init__(self, radius_m: float):
        if not np.isfinite(radius_m) or radius_m <= 0:
            raise ValueError(f"thin-plate radius must be a positive finite length, got {radius_m!r}")
        self.radius_m = float(radius_m)

    def phi(self, r):
        R = self.radius_m
        return 2.0 * r**3 + self.sign * 3.0 * R * r**2 + R**3

    def g(self, r):
        return 6.0 * r + self.sign * 6.0 * self.radius_m

    def q(self, r):
        return 6.0 * r

    def __repr__(self) -> str:
        return f"{type(self).__name__}(radius_m={self.radius_m:.4g})"


@register_kernel("thin_plate_reference")
class ReferenceThinPlateKernel(ThinPlateKernel):
    """The ``phi(r) = 2 r^3 + 3 R r^2 + R^3`` form used by the reference work.

    Indefinite for every ``R`` once gradients are observed: ``cov(df/dx, df/dx) = -6 R`` at r = 0,
    a negative variance. The GP solves it with a symmetric indefinite factorisation and its
    "variance" can be negative; it is kept for comparison with the reference table.
    """

    sign = +1.0
    positive_definite = False


@register_kernel("squared_exponential")
class SquaredExponentialKernel(Kernel):
    """Smooth kernel ``phi(r) = s^2 exp(-r^2 / (2 l^2))``.

    Parameters
    ----------
    length_m : float
        Length scale ``l``, metres.
    scale : float
        Output standard deviation ``s`` (units of the implicit function).
    """

    @classmethod
    def for_workspace(cls, region_diagonal_m, contact_spread_m):
        """Length scale a fifth of the region diagonal, unit scale."""
        return cls(length_m=region_diagonal_m / 5, scale=1.0)

    def __init__(self, length_m: float, scale: float = 1.0):
        if not (np.isfinite(length_m) and length_m > 0 and np.isfinite(scale) and scale > 0):
            raise ValueError(f"length_m and scale must be positive, got {length_m!r}, {scale!r}")
        self.length_m = float(length_m)
        self.scale = float(scale)

    def phi(self, r):
        return self.scale**2 * np.exp(-0.5 * (r / self.length_m) ** 2)

    def g(self, r):
        return -self.phi(r) / self.length_m**2

    def q(self, r):
        return self.phi(r) * r**2 / self.length_m**4

    def __repr__(self) -> str:
        return f"SquaredExponentialKernel(length_m={self.length_m:.4g}, scale={self.scale:.4g})"


@register_kernel("matern52")
class Matern52Kernel(Kernel):
    """Matern-5/2 kernel ``phi(r) = s^2 (1 + a r + a^2 r^2 / 3) exp(-a r)``, ``a = sqrt(5) / l``.

    Twice differentiable, so gradients can be observed; unlike the squared exponential its
    correlation falls off polynomially-times-exponentially, so it bends to local detail without the
    squared exponential's ringing. ``g = -(s^2 a^2 / 3)(1 + a r) exp(-a r)``,
    ``q = (s^2 a^4 r^2 / 3) exp(-a r)``.

    Parameters
    ----------
    length_m : float
        Length scale ``l``, metres.
    scale : float
        Output standard deviation ``s`` (units of the implicit function). With
        ``s = l sqrt(3/5)`` the prior gradient has unit variance per component, as a signed
        distance's has.
    """

    @classmethod
    def for_workspace(cls, region_diagonal_m, contact_spread_m):
        """Length scale a tenth of the region diagonal, unit prior gradient variance."""
        length = region_diagonal_m / 10
        return cls(length_m=length, scale=length * np.sqrt(0.6))

    def __init__(self, length_m: float, scale: float = 1.0):
        if not (np.isfinite(length_m) and length_m > 0 and np.isfinite(scale) and scale > 0):
            raise ValueError(f"length_m and scale must be positive, got {length_m!r}, {scale!r}")
        self.length_m = float(length_m)
        self.scale = float(scale)

    def phi(self, r):
        ar = np.sqrt(5.0) / self.length_m * r
        return self.scale**2 * (1.0 + ar + ar**2 / 3.0) * np.exp(-ar)

    def g(self, r):
        a = np.sqrt(5.0) / self.length_m
        return -(self.scale**2 * a**2 / 3.0) * (1.0 + a * r) * np.exp(-a * r)

    def q(self, r):
        a = np.sqrt(5.0) / self.length_m
        return (self.scale**2 * a**4 / 3.0) * r**2 * np.exp(-a * r)

    def __repr__(self) -> str:
        return f"Matern52Kernel(length_m={self.length_m:.4g}, scale={self.scale:.4g})"


@register_kernel("matern32")
class Matern32Kernel(Kernel):
    """Matern-3/2 kernel ``phi(r) = s^2 (1 + a r) exp(-a r)``, ``a = sqrt(3) / l``.

    Once mean-square differentiable: the least smooth Matern that still has gradient
    observations (its posterior has the thin plate's smoothness order, plus a length scale that
    acts as tension). ``g = -s^2 a^2 exp(-a r)``, ``q = s^2 a^3 r exp(-a r)``.

    Parameters
    ----------
    length_m : float
        Length scale ``l``, metres.
    scale : float
        Output standard deviation ``s``; ``s = l / sqrt(3)`` gives unit prior gradient variance.
    """

    @classmethod
    def for_workspace(cls, region_diagonal_m, contact_spread_m):
        """Length scale a quarter of the region diagonal, unit prior gradient variance."""
        length = region_diagonal_m / 4
        return cls(length_m=length, scale=length / np.sqrt(3.0))

    def __init__(self, length_m: float, scale: float = 1.0):
        if not (np.isfinite(length_m) and length_m > 0 and np.isfinite(scale) and scale > 0):
            raise ValueError(f"length_m and scale must be positive, got {length_m!r}, {scale!r}")
        self.length_m = float(length_m)
        self.scale = float(scale)

    def phi(self, r):
        ar = np.sqrt(3.0) / self.length_m * r
        return self.scale**2 * (1.0 + ar) * np.exp(-ar)

    def g(self, r):
        a = np.sqrt(3.0) / self.length_m
        return -self.scale**2 * a**2 * np.exp(-a * r)

    def q(self, r):
        a = np.sqrt(3.0) / self.length_m
        return self.scale**2 * a**3 * r * np.exp(-a * r)

    def __repr__(self) -> str:
        return f"Matern32Kernel(length_m={self.length_m:.4g}, scale={self.scale:.4g})"


class ConstantKernel(Kernel):
    """A random constant offset, ``phi(r) = c^2``: positive semi-definite, no gradient covariance.

    Added to a decaying kernel (:class:`SumKernel`) it lets the posterior keep a level far from
    the data instead of falling back to 0.

    Parameters
    ----------
    scale : float
        Prior standard deviation ``c`` of the offset (units of the implicit function).
    """

    def __init__(self, scale: float):
        if not (np.isfinite(scale) and scale > 0):
            raise ValueError(f"scale must be positive, got {scale!r}")
        self.scale = float(scale)

    def phi(self, r):
        return np.full_like(np.asarray(r, float), self.scale**2)

    def g(self, r):
        return np.zeros_like(np.asarray(r, float))

    def q(self, r):
        return np.zeros_like(np.asarray(r, float))

    def __repr__(self) -> str:
        return f"ConstantKernel(scale={self.scale:.4g})"


class SumKernel(Kernel):
    """The sum of kernels (a multi-scale kernel): positive definite when every part is.

    Parameters
    ----------
    parts : sequence of Kernel
    """

    def __init__(self, *parts: Kernel):
        if not parts or not all(isinstance(k, Kernel) for k in parts):
            raise ValueError("SumKernel needs one or more Kernel instances")
        self.parts = tuple(parts)
        self.positive_definite = all(k.positive_definite for k in parts)
        self.grows_with_workspace = any(k.grows_with_workspace for k in parts)

    def phi(self, r):
        return sum(k.phi(r) for k in self.parts)

    def g(self, r):
        return sum(k.g(r) for k in self.parts)

    def q(self, r):
        return sum(k.q(r) for k in self.parts)

    def __repr__(self) -> str:
        return " + ".join(repr(k) for k in self.parts)


def thin_plate_radius(region_diagonal_m: float, contact_spread_m: float = 0.0) -> float:
    """The thin-plate ``R`` for a workspace: its diagonal, and at least 1.2x the contacts' spread.

    Parameters
    ----------
    region_diagonal_m : float
        Diagonal of the box in which the GP is evaluated, metres.
    contact_spread_m : float
        Largest distance between observed points, metres.
    """
    return float(max(region_diagonal_m, 1.2 * contact_spread_m))


def _distances(x: np.ndarray, y: np.ndarray) -> np.ndarray:
    return np.linalg.norm(x[:, None, :] - y[None, :, :], axis=-1)


def _unit(d: np.ndarray, r: np.ndarray) -> np.ndarray:
    """``d / r`` with 0 where r == 0."""
    safe = np.where(r > 0, r, 1.0)
    return np.where((r > 0)[..., None], d / safe[..., None], 0.0)


class QuadraticTrend:
    """A random quadratic bowl added to the GP: ``f(x) += gamma |x - c|^2``, ``gamma ~ N(0, s^2)``.

    Its covariance ``s^2 |x - c|^2 |y - c|^2`` is positive semi-definite, so the sum with a positive
    definite kernel stays positive definite. It gives the posterior a closed-surface shape to fall
    back on far from contacts (``gamma < 0``: positive inside, negative outside); without it the
    thin-plate mean fades towards 0 between sparse contacts and grows spurious 0-level sheets.
    (The reference ``+3Rr^2`` form contains such a quadratic term too, but with an indefinite
    cross-covariance.)

    Parameters
    ----------
    centre_m : (3,) float
        ``c``, metres (the prior object centre).
    scale_per_m : float
        ``s``, prior standard deviation of ``gamma`` (1/m). A sphere of radius ``rho`` written as
        signed distance has ``gamma = -1 / (2 rho)``.
    """

    def __init__(self, centre_m, scale_per_m: float):
        self.centre_m = np.asarray(centre_m, float).reshape(3)
        if not (np.isfinite(scale_per_m) and scale_per_m > 0):
            raise ValueError(f"scale_per_m must be positive, got {scale_per_m!r}")
        self.scale_per_m = float(scale_per_m)

    def features(self, x: np.ndarray) -> np.ndarray:
        """``[q(x), dq/dx, dq/dy, dq/dz]`` with ``q = |x - c|^2``; (m, 4)."""
        d = np.asarray(x, float) - self.centre_m
        return np.column_stack([np.sum(d * d, axis=1), 2.0 * d])

    def joint_covariance(self, x: np.ndarray, y: np.ndarray) -> np.ndarray:
        """(m, 4, n, 4) covariance of ``[f, grad f]`` contributed by the trend."""
        return self.scale_per_m**2 * np.einsum("ia,jb->iajb", self.features(x), self.features(y))

    def variance(self, x: np.ndarray) -> np.ndarray:
        """(m,) prior variance of ``f`` contributed by the trend."""
        return self.scale_per_m**2 * self.features(x)[:, 0] ** 2
