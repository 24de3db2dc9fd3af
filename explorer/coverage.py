"""How much of an object the pad can reach, and why the rest is out of reach (simulation evaluation).

Computed from the true mesh after a run; the loop never sees it. Area-uniform surface samples are
sorted into exclusive classes, in this order:

1. ``pad_does_not_fit`` - the fingertip (the 18 mm pad lying on the tangent plane, 7.7 mm deep,
   and the finger behind it along the approach) cannot be placed at the point from any approach
   within :attr:`ToolEnvelope.tilts_rad` of the inward normal without meeting the object
   elsewhere: narrow insides, the crease under a handle, gaps narrower than the pad, surfaces
   curving concavely faster than the pad can sit on;
2. ``arm_cannot_reach`` - the fingertip fits, but on every such approach the hand behind it meets
   the object, or the planner finds no stand pose with an IK solution clear of the prior box;
3. ``hidden_by_stand`` - the stand's structure covers the point (the simulated stand holds the
   object with no structure: always 0 there; a stand model would add its occluded area here);
4. ``reachable_untouched`` - reachable, but no contact within the coverage radius;
5. ``touched`` - reachable and within the coverage radius of a contact.

The fingertip and hand are tested against exact distances to the true surface where a voxel field
of it cannot tell (the field alone, before 2026-11-28, put 10 % of generated:mug/0 on the wrong side
of the pad's clearance).
"""
from __future__ import annotations

from dataclasses import asdict, dataclass

import numpy as np

from explorer.touch import Touch

#: The classes of :class:`ReachBreakdown`, in the order they are assigned.
REACH_CLASSES = ("pad_does_not_fit", "arm_cannot_reach", "hidden_by_stand", "reachable_untouched", "touched")


@dataclass(frozen=True)
class ToolEnvelope:
    """What must fit around a touch point, measured back from the pad face (metres, radians).

    Defaults: the fingertip module of :class:`robots.fingertip.FingertipGeometry` (18 mm wide,
    7.7 mm deep, its face 8.7 mm beyond the tool point) on ARMAR-III's finger (8 mm radius, 35 mm)
    and hand (a 60 x 30 mm box, 70 mm long, taken as a cylinder of its smaller half width: the hand
    can be turned about the approach to its narrow side).

    Attributes
    ----------
    pad_half_width_m : float
        Half width of the pad (a disc of this radius on the tangent plane).
    module_depth_m : float
        Depth of the module behind the pad face.
    finger_radius_m, finger_start_m, finger_end_m : float
        The finger: a cylinder on the approach axis, from ``finger_start_m`` to ``finger_end_m``
        behind the pad face.
    hand_radius_m, hand_end_m : float
        The hand: a cylinder from ``finger_end_m`` to ``hand_end_m`` behind the face.
    tilts_rad : tuple of float
        Angles between the approach and the inward normal that are tried (the spring turns the
        pad onto the surface up to about 45 deg); "reachable" means reachable along one of them.
    azimuths : int
        Approach directions per non-zero tilt.
    hover_m : float
        The pad is tested this far off the surface.
    clearance_m : float
        A tool point closer than this to the surface collides.
    """

    pad_half_width_m: float = 0.009
    module_depth_m: float = 0.0077
    finger_radius_m: float = 0.008
    finger_start_m: float = 0.0087
    finger_end_m: float = 0.0437
    hand_radius_m: float = 0.015
    hand_end_m: float = 0.1137
    tilts_rad: tuple = (0.0, np.radians(20.0), np.radians(35.0))
    azimuths: int = 8
    hover_m: float = 0.003
    clearance_m: float = 0.0012

    def approach_directions(self, normal: np.ndarray) -> np.ndarray:
        """(k, 3) approach directions (into the surface) around the inward normal ``-normal``, the
        normal's own first, then by growing tilt."""
        n = np.asarray(normal, float) / np.linalg.norm(normal)
        u, v = tangent_basis(n)
        dirs = []
        for tilt in self.tilts_rad:
            if tilt == 0.0:
                dirs.append(-n)
                continue
            for phi in 2 * np.pi * np.arange(self.azimuths) / self.azimuths:
                side = np.cos(phi) * u + np.sin(phi) * v
                dirs.append(-np.cos(tilt) * n + np.sin(tilt) * side)
        return np.array(dirs)

    def fingertip_points(self, point: np.ndarray, normal: np.ndarray, approach: np.ndarray) -> np.ndarray:
        """(m, 3) points of the pad module (on the tangent plane of ``normal``) and of the finger
        (along ``-approach``) for a touch at ``point``."""
        n = np.asarray(normal, float)
        u, v = tangent_basis(n)
        face = point + self.hover_m * n
        disc = _disc(self.pad_half_width_m, 0.0015)
        layers = np.linspace(0.0, self.module_depth_m, 3)
        pad = (face + disc[:, None, 0, None] * u + disc[:, None, 1, None] * v
               + layers[None, :, None] * n).reshape(-1, 3)
        finger = _cylinder(face, -approach, self.finger_radius_m, self.finger_start_m, self.finger_end_m)
        return np.vstack([pad, finger])

    def hand_points(self, point: np.ndarray, normal: np.ndarray, approach: np.ndarray) -> np.ndarray:
        """(m, 3) points of the hand behind the finger."""
        face = point + self.hover_m * np.asarray(normal, float)
        return _cylinder(face, -approach, self.hand_radius_m, self.finger_end_m, self.hand_end_m)


def tangent_basis(normal: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
    """Two unit vectors (3,) orthogonal to ``normal`` and to each other."""
    n = np.asarray(normal, float)
    helper = np.array([1.0, 0.0, 0.0]) if abs(n[0]) < 0.9 else np.array([0.0, 1.0, 0.0])
    u = np.cross(n, helper)
    u /= np.linalg.norm(u)
    return u, np.cross(n, u)


def _disc(radius: float, step: float) -> np.ndarray:
    """(k, 2) grid points of a disc, its rim included."""
    g = np.arange(-radius, radius + 1e-12, step)
    xy = np.stack(np.meshgrid(g, g), -1).reshape(-1, 2)
    xy = xy[np.linalg.norm(xy, axis=1) <= radius]
    angles = np.linspace(0, 2 * np.pi, 24, endpoint=False)
    return np.vstack([xy, radius * np.column_stack([np.cos(angles), np.sin(angles)])])


def _cylinder(base: np.ndarray, axis: np.ndarray, radius: float, start: float, end: float) -> np.ndarray:
    """(k, 3) points of a solid cylinder's rim and axis along ``axis`` from ``start`` to ``end``."""
    a = axis / np.linalg.norm(axis)
    u, v = tangent_basis(a)
    s = np.arange(start, end + 1e-9, 0.003)
    angles = np.linspace(0, 2 * np.pi, 12, endpoint=False)
    ring = np.vstack([[[0.0, 0.0]], radius * np.column_stack([np.cos(angles), np.sin(angles)])])
    return (base + s[:, None, None] * a + ring[None, :, 0, None] * u + ring[None, :, 1, None] * v).reshape(-1, 3)


class SurfaceDistance:
    """Distance (m) from any point to a mesh's surface: a voxel field of the surface for most points,
    exact distances (libigl's AABB tree) where the field cannot tell.

    Parameters
    ----------
    mesh : trimesh.Trimesh
        Object frame, metres.
    pitch_m : float
        Voxel size of the field; :meth:`field` is within :attr:`bound_m` of the exact distance.
    """

    def __init__(self, mesh, pitch_m: float = 0.0015):
        import igl
        from scipy import ndimage

        voxels = mesh.voxelized(pitch_m)
        occupied = np.pad(np.asarray(voxels.matrix, bool), 2)
        self.pitch_m = pitch_m
        #: The field's largest error: a surface voxel's centre is within half a voxel diagonal of the
        #: surface, and a query snaps to the nearest voxel centre, another half diagonal.
        self.bound_m = pitch_m * np.sqrt(3.0)
        self.origin_m = np.asarray(voxels.transform[:3, 3], float) - 2 * pitch_m
        self.distance_m = ndimage.distance_transform_edt(~occupied) * pitch_m
        self._vertices = np.ascontiguousarray(mesh.vertices, dtype=np.float64)
        self._faces = np.ascontiguousarray(mesh.faces, dtype=np.int64)
        self._tree = igl.AABB()
        self._tree.init(self._vertices, self._faces)

    def field(self, points: np.ndarray) -> np.ndarray:
        """(n,) distances of (n, 3) points from the voxel field; points outside the grid (more than
        two voxels beyond the surface's bounds) are far (inf)."""
        index = np.rint((np.asarray(points, float) - self.origin_m) / self.pitch_m).astype(int)
        inside = np.all((index >= 0) & (index < np.array(self.distance_m.shape)), axis=1)
        out = np.full(len(index), np.inf)
        i = index[inside]
        out[inside] = self.distance_m[i[:, 0], i[:, 1], i[:, 2]]
        return out

    def exact(self, points: np.ndarray) -> np.ndarray:
        """(n,) exact distances of (n, 3) points."""
        squared, _, _ = self._tree.squared_distance(self._vertices, self._faces,
                                                    np.ascontiguousarray(points, dtype=np.float64).reshape(-1, 3))
        return np.sqrt(squared)

    def any_within(self, points: np.ndarray, clearance_m: float) -> bool:
        """Whether any of the (n, 3) points is closer than ``clearance_m`` to the surface, exactly:
        the field settles every point farther than :attr:`bound_m` from the threshold, the AABB tree
        the rest."""
        field = self.field(points)
        if np.any(field + self.bound_m < clearance_m):
            return True
        unsure = np.abs(field - clearance_m) <= self.bound_m
        if clearance_m > 1.6 * self.pitch_m:
            # Off the grid is 2.5 voxels beyond an outermost surface voxel, whose centre is within half a
            # diagonal of the surface: more than 1.6 voxels away, certain only for a smaller clearance.
            unsure |= ~np.isfinite(field)
        return bool(np.any(unsure) and np.min(self.exact(np.asarray(points)[unsure])) < clearance_m)


@dataclass(frozen=True)
class ReachBreakdown:
    """Surface fractions by why they were or were not touched (they sum to 1).

    Attributes
    ----------
    pad_does_not_fit, arm_cannot_reach, hidden_by_stand, reachable_untouched, touched : float
        Area fractions of the true surface (see the module docstring).
    samples : int
        Area-uniform surface samples they were estimated from (standard error about
        ``sqrt(f (1 - f) / samples)``).
    """

    pad_does_not_fit: float
    arm_cannot_reach: float
    hidden_by_stand: float
    reachable_untouched: float
    touched: float
    samples: int

    @property
    def reachable(self) -> float:
        """Fraction the pad can reach: touched or not."""
        return self.reachable_untouched + self.touched

    @property
    def reachable_coverage(self) -> float:
        """Touched share of the reachable surface (nan when nothing is reachable)."""
        return self.touched / self.reachable if self.reachable > 0 else float("nan")

    def as_dict(self) -> dict:
        return dict(asdict(self), reachable=self.reachable, reachable_coverage=self.reachable_coverage)


def classify_fit(mesh, points: np.ndarray, normals: np.ndarray, tool: ToolEnvelope = ToolEnvelope(),
                 distance: SurfaceDistance | None = None) -> tuple[np.ndarray, list[np.ndarray]]:
    """For each surface point: does the fingertip fit, and along which approaches does the hand fit.

    Parameters
    ----------
    mesh : trimesh.Trimesh, object frame
    points, normals : (n, 3) float
        Surface points and outward unit normals, object frame.

    Returns
    -------
    fits : (n,) bool
        The fingertip fits along at least one approach.
    clear : list of (k_i, 3) float
        Per point, the approaches (into the surface) along which fingertip and hand both fit,
        closest to the inward normal first.
    """
    distance = SurfaceDistance(mesh) if distance is None else distance
    fits = np.zeros(len(points), bool)
    clear: list[np.ndarray] = []
    for i, (p, n) in enumerate(zip(points, normals)):
        ok = []
        for a in tool.approach_directions(n):
            if distance.any_within(tool.fingertip_points(p, n, a), tool.clearance_m):
                continue
            fits[i] = True
            if not distance.any_within(tool.hand_points(p, n, a), tool.clearance_m):
                ok.append(a)
        clear.append(np.array(ok).reshape(-1, 3))
    return fits, clear


def reach_breakdown(mesh, contacts: np.ndarray, planner=None, radius_m: float = 0.01, n_samples: int = 64,
                    seed: int = 0, tool: ToolEnvelope = ToolEnvelope(), directions_to_plan: int = 4,
                    progress=None) -> ReachBreakdown:
    """Sort area-uniform samples of the true surface by why they were (not) touched.

    Parameters
    ----------
    mesh : trimesh.Trimesh
        Ground truth, object frame, metres.
    contacts : (m, 3) float
        Contacts of the run, object frame.
    planner : explorer.planner.ApproachPlanner or None
        Asked for a plan along each clear approach as it is (at most ``directions_to_plan``,
        closest to the normal first; stand poses as the planner ranks them); None counts every
        clear approach as reachable (geometry only).
    radius_m : float
        A sample within this distance of a contact counts as touched.
    progress : callable(int) or None
        Called with the number of samples planned so far.
    """
    from objects.sampling import sample_surface

    points, faces = sample_surface(mesh, n_samples, np.random.default_rng(seed))
    normals = mesh.face_normals[faces]
    fits, clear = classify_fit(mesh, points, normals, tool)
    label = np.empty(len(points), object)
    contacts = np.asarray(contacts, float).reshape(-1, 3)
    for i, (p, ok) in enumerate(zip(points, clear)):
        if not fits[i]:
            label[i] = "pad_does_not_fit"
        elif not len(ok) or (planner is not None and not any(
                planner.plan(Touch(p, a, depth_m=0.005), tilted=False) is not None for a in ok[:directions_to_plan])):
            label[i] = "arm_cannot_reach"
        elif len(contacts) and np.min(np.linalg.norm(contacts - p, axis=1)) <= radius_m:
            label[i] = "touched"
        else:
            label[i] = "reachable_untouched"
        if progress is not None:
            progress(i + 1)
    fractions = {name: float(np.mean(label == name)) for name in REACH_CLASSES}
    return ReachBreakdown(**fractions, samples=len(points))


def coverage_ceiling(mesh, contacts: int, radius_m: float = 0.01, per_disc: int = 400, seed: int = 0) -> float:
    """The most coverage ``contacts`` contacts can give: an upper bound, whatever their placement.

    Each contact covers at most the largest surface area found within ``radius_m`` of one surface
    point (about pi r^2 on a flat face; up to twice that where a wall thinner than the radius
    counts on both sides), so ``contacts`` of them cover at most that many times it.

    Parameters
    ----------
    mesh : trimesh.Trimesh, object frame, metres
    contacts : int
    per_disc : int
        Surface samples per flat disc of ``radius_m`` (the bound's own sampling error is about
        ``3 / sqrt(per_disc)``, upwards: the largest of many noisy counts).

    Returns
    -------
    float
        In [0, 1].
    """
    from scipy.spatial import cKDTree

    from objects.sampling import sample_surface

    n_samples = int(min(400_000, per_disc * mesh.area / (np.pi * radius_m**2)))
    points, _ = sample_surface(mesh, n_samples, np.random.default_rng(seed))
    tree = cKDTree(points)
    probe = points[np.random.default_rng(seed + 1).choice(len(points), min(2000, len(points)), replace=False)]
    largest_share = max(len(near) for near in tree.query_ball_point(probe, radius_m)) / len(points)
    return float(min(1.0, contacts * largest_share))


def placed_coverage(mesh, contacts: int, radius_m: float = 0.01, per_disc: int = 60, seed: int = 0) -> float:
    """The coverage ``contacts`` contacts give when placed greedily on the true surface, arm ignored.

    A reference for a run's coverage that, unlike :func:`coverage_ceiling`, is achieved by an actual
    placement: each contact in turn goes to the surface sample that covers the most samples not yet
    within ``radius_m`` of a contact (greedy maximum coverage, at least ``1 - 1/e`` of the best
    placement). It is what a placement that knew the shape achieves, not a bound: that is
    :func:`coverage_ceiling`. A run below it could have placed its contacts better (or could not
    reach there, which this ignores).

    Parameters
    ----------
    mesh : trimesh.Trimesh, object frame, metres
    contacts : int
    radius_m : float
        The coverage radius (as ``metrics.json``'s ``coverage``), metres.
    per_disc : int
        Surface samples per flat disc of ``radius_m`` (candidates and the covered area alike).

    Returns
    -------
    float
        In [0, 1].
    """
    import scipy.sparse
    from scipy.spatial import cKDTree

    from objects.sampling import sample_surface

    if contacts <= 0:
        return 0.0
    n_samples = int(min(40_000, max(200, per_disc * mesh.area / (np.pi * radius_m**2))))
    points, _ = sample_surface(mesh, n_samples, np.random.default_rng(seed))
    pairs = cKDTree(points).query_pairs(radius_m, output_type="ndarray")
    rows = np.concatenate([pairs[:, 0], pairs[:, 1], np.arange(len(points))])
    cols = np.concatenate([pairs[:, 1], pairs[:, 0], np.arange(len(points))])
    covers = scipy.sparse.csr_matrix((np.ones(len(rows)), (rows, cols)), shape=(len(points),) * 2)
    uncovered = np.ones(len(points))
    chosen = []
    for _ in range(int(contacts)):
        gain = covers @ uncovered
        best = int(np.argmax(gain))
        if gain[best] <= 0:
            break
        chosen.append(best)
        uncovered[covers[best].indices] = 0.0
    # Scored on samples of their own: the greedy's choice favours discs its samples happen to crowd
    # (on a sphere one contact would count 1.2-1.4 times its cap), the fresh samples do not.
    scored, _ = sample_surface(mesh, n_samples, np.random.default_rng(seed + 1))
    distance, _ = cKDTree(points[chosen]).query(scored)
    return float(np.mean(distance <= radius_m))
