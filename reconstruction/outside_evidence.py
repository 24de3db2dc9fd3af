"""Outside evidence beyond the contacts' convex hull: removing phantom surface before meshing.

A smooth GPIS extrapolates where no contact constrains it: the slab between the two sides of a thin
wall runs on past an untouched rim, a sharp tip rounds into a lobe, and the 0-level set bulges out
of the object there (BENCHMARKS.md, issue 10). Those lobes lie outside the convex hull of the
contacts. True surface can lie there too, in two ways, and the rule keeps both:

* between sparse contacts (a box's corner between contacts on three faces) it bulges out of the
  hull facet they span, by an amount that grows with the gaps between them: a point counts as free
  only when it lies outside the hull by more than ``facet_fraction`` times the size of the gap it
  lies in front of, and by at least ``min_margin_m``. The gap's size is the circumradius of the
  facet it lies in front of (the facet of the largest plane distance) or, when smaller, the
  distance from its foot on that facet's plane to the ``local_neighbours``-th nearest contact, with
  a floor of ``min_local_margin_m`` on the margin this one sets. A large facet can span many
  contacts a few millimetres behind it (a tray's wall between contacts at its two ends); where
  contacts are spread over the surface, a bulge much higher than their spacing would have been
  touched (BENCHMARKS.md, issue 10: the facet alone let a 30 mm lobe stand off a tray's wall 20 mm
  from the contacts on its inside). The local gap is used only with the tangent-plane test below,
  which keeps every convex part; its floor keeps an untouched tip or stem of a curved part (6-9 mm
  past the local margin on tuning shapes and the registry banana);
* beyond the border of the touched region (the untouched half of an object) it may continue
  anywhere: a point counts as free only when its foot on that facet's plane is enclosed by
  contacts, no opening wider than ``max_open_angle_rad`` between the directions to its nearest
  ``ENCLOSURE_NEIGHBOURS`` contacts.

A third condition uses the measured normals. The hull is an inner bound of a convex object; the
intersection of the contacts' tangent half-spaces is an outer one, and a convex surface lies
between the two. A point counts as free only when it lies outside that intersection too: ahead of
the tangent plane of at least one contact by more than ``tangent_margin_m``. Without this test, a
sphere touched 6 to 15 times had its true surface taken as free and its mesh went from 1-3 mm to
8-19 mm; with it, a convex object never loses surface, however few its contacts. A phantom lobe
past a thin rim lies ahead of the plane of a contact on the far side (a bowl's floor).

Flat faces are known better than any one contact's normal. Where several contacts lie on one
plane and no contact lies in front of it (a supporting face plane,
:mod:`reconstruction.face_planes`), a point in front of that plane by more than 2 mm plus
``sin(5 deg)`` (more for a narrow patch) times its distance is free wherever it lies more than
``min_margin_m`` outside the hull and its foot is enclosed, within the facet's and the local
margin too: the lobe a smooth GPIS rounds past a wedge's sharp corner or a prism's edge, 4-10 mm
outside the hull (BENCHMARKS.md, issue 10). Enclosed there means among the nearest
``FACE_ENCLOSURE_NEIGHBOURS`` contacts: near the corner of a face the nearest eight often all lie on
the neighbouring face, which projects to one side of the foot, and the lobe off the corner stayed.

Where the GPIS mean still puts solid at such a free point, a value row ``f = -d`` (``d`` its
distance outside the hull) is added with a loose noise, at most one per ``ROW_SPACING_M`` cube,
and this is repeated a few times, since a lobe pushed back in one place can grow in another.

The settings were chosen on the generated tuning split; the held-out split is reported separately
(BENCHMARKS.md, issue 10). ``GPIS.mesh()`` applies it to a copy of the GPIS by default
(``outside_evidence=False`` gives the plain mean); the GPIS that the loop and the strategies use
is never changed.

Written here rather than taken from a library: it is a statement about this GP's observations,
not a mesh operation.
"""
from __future__ import annotations

import numpy as np

from reconstruction.face_planes import DEFAULT_FACE_TOLERANCE_RAD, FacePlanes, supporting_face_planes

#: Free space starts this fraction of a hull facet's circumradius outside the facet ...
DEFAULT_FACET_FRACTION = 0.75
#: ... or of the distance from its foot to this nearest contact, when that is smaller ...
DEFAULT_LOCAL_NEIGHBOURS = 3
#: ... but the margin that distance sets is at least this, metres.
DEFAULT_MIN_LOCAL_MARGIN_M = 10.0e-3
#: ... and never nearer the hull than this, metres.
DEFAULT_MIN_MARGIN_M = 4.0e-3
#: ... and only where its foot is enclosed by contacts: no wider opening than this between the
#: directions to its nearest ``ENCLOSURE_NEIGHBOURS`` contacts, radians.
DEFAULT_MAX_OPEN_ANGLE_RAD = float(np.radians(120.0))
ENCLOSURE_NEIGHBOURS = 8
#: In front of a supporting face plane, among this many: by a sharp corner the nearest eight are
#: often all on the neighbouring face, one side of the foot (module docstring).
FACE_ENCLOSURE_NEIGHBOURS = 16
#: ... and only ahead of some contact's tangent plane by more than this, metres: a few times the
#: contacts' position noise along the normal.
DEFAULT_TANGENT_MARGIN_M = 2.0e-3
#: ... with each plane tilted by up to this angle, the normal's error (the sensor's is 7 deg on
#: average, more on steep surfaces), radians.
DEFAULT_NORMAL_TOLERANCE_RAD = float(np.radians(15.0))
#: Standard deviation of the added value rows, metres (units of ``f``).
DEFAULT_EVIDENCE_NOISE_M = 2.0e-3
#: Candidate grid: this spacing, or the region's longest side / ``GRID_CELLS`` if larger, metres.
GRID_SPACING_M = 4.0e-3
GRID_CELLS = 48
#: At most one added row per cube of this side, metres.
ROW_SPACING_M = 6.0e-3
MAX_ROUNDS = 4
_CHUNK = 20000


def free_space_candidates(contacts: np.ndarray, box, facet_fraction: float = DEFAULT_FACET_FRACTION,
                          min_margin_m: float = DEFAULT_MIN_MARGIN_M,
                          max_open_angle_rad: float | None = DEFAULT_MAX_OPEN_ANGLE_RAD,
                          normals: np.ndarray | None = None,
                          tangent_margin_m: float | None = DEFAULT_TANGENT_MARGIN_M,
                          normal_tolerance_rad: float = DEFAULT_NORMAL_TOLERANCE_RAD,
                          local_neighbours: int | None = DEFAULT_LOCAL_NEIGHBOURS,
                          min_local_margin_m: float = DEFAULT_MIN_LOCAL_MARGIN_M,
                          face_tolerance_rad: float | None = DEFAULT_FACE_TOLERANCE_RAD) -> tuple[np.ndarray, np.ndarray]:
    """Grid points of ``box`` taken as free space by the hull rule (module docstring).

    Parameters
    ----------
    contacts : (n, 3) float, metres
    box : ((3,), (3,)) float, metres
        The region to cover (usually the GPIS region).
    facet_fraction, min_margin_m : float
        The margin outside a hull facet: ``max(facet_fraction * circumradius, min_margin_m)``, or
        where smaller ``max(facet_fraction * d, min_local_margin_m, min_margin_m)``, ``d`` the
        distance from the point's foot on the facet's plane to its ``local_neighbours``-th nearest
        contact.
    max_open_angle_rad : float or None
        The widest opening around the foot between its nearest contacts; None: no enclosure test.
    normals : (n, 3) float, optional
        The contacts' outward unit normals; None: no tangent-plane test.
    tangent_margin_m : float or None
        How far ahead of a contact's tangent plane a free point must lie, metres; None: no
        tangent-plane test.
    normal_tolerance_rad : float
        The tangent planes' tilt allowed for the normals' error, radians.
    local_neighbours : int or None
        Which nearest contact of the foot sets the local margin (module docstring); None, or no
        tangent-plane test: the facet's circumradius alone.
    min_local_margin_m : float
        The local margin's floor, metres.
    face_tolerance_rad : float or None
        The supporting face planes' tilt allowance (:mod:`reconstruction.face_planes`); None, or no
        normals or tangent-plane test: no face planes.

    Returns
    -------
    points : (m, 3) float, metres
    distance : (m,) float, how far each lies outside the hull, metres (a lower bound near the
        hull's edges and corners). Both empty when the contacts span no volume.
    """
    from scipy.spatial import ConvexHull, QhullError, cKDTree

    if not (np.isfinite(facet_fraction) and facet_fraction >= 0):
        raise ValueError(f"facet_fraction must be a finite number >= 0, got {facet_fraction!r}")
    if max_open_angle_rad is not None and not (0 < max_open_angle_rad <= 2 * np.pi):
        raise ValueError(f"max_open_angle_rad must be None or an angle in (0, 2 pi], got {max_open_angle_rad!r}")
    if not (np.isfinite(min_margin_m) and min_margin_m >= 0):
        raise ValueError(f"min_margin_m must be a length >= 0, got {min_margin_m!r}")
    if tangent_margin_m is not None and not (np.isfinite(tangent_margin_m) and tangent_margin_m >= 0):
        raise ValueError(f"tangent_margin_m must be None or a length >= 0, got {tangent_margin_m!r}")
    if not (0 <= normal_tolerance_rad < np.pi / 2):
        raise ValueError(f"normal_tolerance_rad must be an angle in [0, pi / 2), got {normal_tolerance_rad!r}")
    if local_neighbours is not None and not (isinstance(local_neighbours, (int, np.integer)) and local_neighbours >= 1):
        raise ValueError(f"local_neighbours must be None or a count >= 1, got {local_neighbours!r}")
    if not (np.isfinite(min_local_margin_m) and min_local_margin_m >= 0):
        raise ValueError(f"min_local_margin_m must be a length >= 0, got {min_local_margin_m!r}")
    if face_tolerance_rad is not None and not (0 <= face_tolerance_rad < np.pi / 2):
        raise ValueError(f"face_tolerance_rad must be None or an angle in [0, pi / 2), got {face_tolerance_rad!r}")
    contacts = np.asarray(contacts, float)
    if normals is not None:
        normals = np.asarray(normals, float)
        if normals.shape != contacts.shape:
            raise ValueError(f"normals must be one per contact, shape {contacts.shape}, got {normals.shape}")
    empty = np.zeros((0, 3)), np.zeros(0)
    try:
        hull = ConvexHull(contacts)
    except (QhullError, ValueError):
        return empty
    planes = hull.equations  # unit outward normals, offsets
    corners = contacts[hull.simplices]
    circumradius = np.linalg.norm(corners - corners.mean(axis=1, keepdims=True), axis=2).max(axis=1)
    tree = cKDTree(contacts)
    faces = None
    if face_tolerance_rad is not None and normals is not None and tangent_margin_m is not None:
        faces = supporting_face_planes(contacts, normals, tolerance_rad=face_tolerance_rad)
        faces = faces if len(faces) else None
    lo, hi = (np.asarray(b, float) for b in box)
    spacing = max(GRID_SPACING_M, float(np.max(hi - lo)) / GRID_CELLS)
    axes = [_cell_centres(a, b, spacing) for a, b in zip(lo, hi)]
    grid = np.stack(np.meshgrid(*axes, indexing="ij"), axis=-1).reshape(-1, 3)
    points, distance = [], []
    for start in range(0, len(grid), _CHUNK):
        x = grid[start:start + _CHUNK]
        signed = x @ planes[:, :3].T + planes[:, 3]
        facet = np.argmax(signed, axis=1)
        outside = signed[np.arange(len(x)), facet]
        beyond = outside > min_margin_m
        x, outside, facet = x[beyond], outside[beyond], facet[beyond]
        foot = x - outside[:, None] * planes[facet, :3]  # each point's foot on its facet's plane
        free = outside > np.maximum(facet_fraction * circumradius[facet], min_margin_m)
        if local_neighbours is not None and normals is not None and tangent_margin_m is not None:
            # the local margin frees more only beyond its floor: look up the nearest contacts there alone
            maybe = np.flatnonzero(~free & (outside > max(min_local_margin_m, min_margin_m)))
            if len(maybe):
                k = min(int(local_neighbours), len(contacts))
                nearest, _ = tree.query(foot[maybe], k=k)
                free[maybe] = outside[maybe] > facet_fraction * nearest.reshape(len(maybe), k)[:, -1]
        # in front of a supporting face plane: free within the facet's and the local margin too,
        # without the single contacts' looser tangent test
        by_face = np.zeros(len(x), bool)
        if faces is not None and not free.all():
            by_face[~free] = faces.in_front(x[~free])
        if max_open_angle_rad is not None:
            if free.any():
                free[free] = _enclosed(foot[free], planes[facet[free], :3], contacts, tree, max_open_angle_rad)
            if by_face.any():
                by_face[by_face] = _enclosed(foot[by_face], planes[facet[by_face], :3], contacts, tree,
                                             max_open_angle_rad, FACE_ENCLOSURE_NEIGHBOURS)
        if normals is not None and tangent_margin_m is not None and free.any():
            free[free] = _ahead_of_a_tangent_plane(x[free], contacts, normals, tangent_margin_m,
                                                   normal_tolerance_rad)
        free |= by_face
        points.append(x[free])
        distance.append(outside[free])
    if not points:
        return empty
    return np.concatenate(points), np.concatenate(distance)


def _cell_centres(lo: float, hi: float, spacing: float) -> np.ndarray:
    """Centres of the whole cells of ``spacing`` from ``lo`` (the middle if none fits): counted, not
    stepped to, so that no centre falls a rounding error past ``hi``."""
    count = int(np.floor((hi - lo) / spacing))
    return lo + spacing * (np.arange(count) + 0.5) if count else np.array([0.5 * (lo + hi)])


def _enclosed(feet: np.ndarray, normals: np.ndarray, contacts: np.ndarray, tree, max_open_angle_rad: float,
              neighbours: int = ENCLOSURE_NEIGHBOURS) -> np.ndarray:
    """Whether the nearest contacts surround each foot in its facet's plane: the widest angle
    between the directions to them, seen from the foot, is at most ``max_open_angle_rad``.
    A foot on the border of the touched region (an untouched half beyond it) is not enclosed."""
    k = min(neighbours, len(contacts))
    _, index = tree.query(feet, k=k)
    offsets = contacts[index.reshape(len(feet), k)] - feet[:, None, :]
    seed = np.where(np.abs(normals[:, :1]) < 0.9, np.array([[1.0, 0.0, 0.0]]), np.array([[0.0, 1.0, 0.0]]))
    u = np.cross(normals, seed)
    u /= np.linalg.norm(u, axis=1, keepdims=True)
    v = np.cross(normals, u)
    angles = np.sort(np.arctan2(np.einsum("pkj,pj->pk", offsets, v), np.einsum("pkj,pj->pk", offsets, u)), axis=1)
    steps = np.diff(np.concatenate([angles, angles[:, :1] + 2 * np.pi], axis=1), axis=1)
    return steps.max(axis=1) <= max_open_angle_rad


def _ahead_of_a_tangent_plane(points: np.ndarray, contacts: np.ndarray, normals: np.ndarray,
                              margin_m: float, tolerance_rad: float) -> np.ndarray:
    """Whether each point lies ahead of some contact's tangent plane by more than ``margin_m``,
    with the plane tilted by up to ``tolerance_rad`` either way: outside the intersection of the
    contacts' tangent half-spaces, which holds a convex object. (Each contact as a plane of its own.)"""
    return FacePlanes(contacts, normals, margin_m, tolerance_rad).in_front(points)


def add_outside_evidence(gpis, facet_fraction: float = DEFAULT_FACET_FRACTION,
                         min_margin_m: float = DEFAULT_MIN_MARGIN_M,
                         max_open_angle_rad: float | None = DEFAULT_MAX_OPEN_ANGLE_RAD,
                         noise_m: float = DEFAULT_EVIDENCE_NOISE_M, box=None,
                         tangent_margin_m: float | None = DEFAULT_TANGENT_MARGIN_M,
                         normal_tolerance_rad: float = DEFAULT_NORMAL_TOLERANCE_RAD,
                         local_neighbours: int | None = DEFAULT_LOCAL_NEIGHBOURS,
                         min_local_margin_m: float = DEFAULT_MIN_LOCAL_MARGIN_M,
                         face_tolerance_rad: float | None = DEFAULT_FACE_TOLERANCE_RAD) -> int:
    """Add value rows where the GPIS puts solid in the hull rule's free space (module docstring).

    Parameters
    ----------
    gpis : reconstruction.gpis.GPIS
        Fitted (at least 4 contacts spanning a volume, else nothing is added); modified in place
        through :meth:`GPIS.add_values`.
    facet_fraction, min_margin_m, max_open_angle_rad, tangent_margin_m, normal_tolerance_rad : float or None
        See :func:`free_space_candidates` (the tangent test uses the GPIS's contact normals).
    local_neighbours, min_local_margin_m, face_tolerance_rad : int or None, float, float or None
        See :func:`free_space_candidates`.
    noise_m : float
        Standard deviation of the added rows, metres.
    box : ((3,), (3,)) float, optional
        Region searched; default the GPIS region.

    Returns
    -------
    int
        Rows added.
    """
    if not (np.isfinite(noise_m) and noise_m > 0):
        raise ValueError(f"noise_m must be a positive length, got {noise_m!r}")
    points, distance = free_space_candidates(gpis.contact_points, gpis.region if box is None else box,
                                             facet_fraction, min_margin_m, max_open_angle_rad,
                                             gpis.contact_normals, tangent_margin_m, normal_tolerance_rad,
                                             local_neighbours, min_local_margin_m, face_tolerance_rad)
    added = 0
    for _ in range(MAX_ROUNDS):
        if not len(points):
            break
        mean = np.concatenate([gpis.mean(points[s:s + _CHUNK]) for s in range(0, len(points), _CHUNK)])
        solid = mean > 0.0
        if not solid.any():
            break
        cells = np.floor(points[solid] / ROW_SPACING_M).astype(np.int64)
        _, first = np.unique(cells, axis=0, return_index=True)
        gpis.add_values(points[solid][first], -distance[solid][first], noise=noise_m)
        added += len(first)
    return added
