"""Choosing a GPIS kernel's length scale from the data (type-II maximum likelihood).

Each candidate length scale is fitted once and scored by the log marginal likelihood of all its
observations (contact values, normals, free-space values); the best one wins. Costs one fit per
candidate (O(rows^3)), so it belongs at a refit, not in every incremental add.
"""
from __future__ import annotations

from typing import Callable, Sequence

import numpy as np

from reconstruction.gpis import GPIS
from reconstruction.kernels import Kernel


def choose_length_scale(fit: Callable[[Kernel], GPIS], make_kernel: Callable[[float], Kernel],
                        lengths_m: Sequence[float]) -> tuple[float, np.ndarray]:
    """The candidate length scale whose fitted GPIS has the highest log marginal likelihood.

    Parameters
    ----------
    fit : callable (Kernel) -> GPIS
        Builds and fits a GPIS with the given kernel on the data, e.g.
        ``lambda k: GPIS(kernel=k, bounds=b).fit(points, normals)``.
    make_kernel : callable (length_m) -> Kernel
        The kernel of one candidate; it must be positive definite.
    lengths_m : sequence of float
        Candidate length scales, metres.

    Returns
    -------
    best_m : float
    log_likelihoods : (len(lengths_m),) float, nats
    """
    lengths = [float(v) for v in lengths_m]
    if not lengths or not all(np.isfinite(v) and v > 0 for v in lengths):
        raise ValueError(f"lengths_m must be positive finite length scales, got {lengths_m!r}")
    scores = np.array([fit(make_kernel(length)).log_marginal_likelihood() for length in lengths])
    return lengths[int(np.argmax(scores))], scores
