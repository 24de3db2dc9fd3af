"""Mirror planes and an axis of revolution of an unknown object, found from its contacts (issue 10).

Most household objects are symmetric: cups, bowls, plates, bottles and lids are surfaces of
revolution, boxes, trays and tools have mirror planes. A symmetry maps every contact to another
point of the surface (its *image*), so a symmetry found from the contacts fills the sampling gaps
where the GPIS otherwise grows phantom surface (BENCHMARKS.md, "Symmetry found from the
contacts"). Nothing is assumed about the object's pose: planes and axes are searched in every
direction.

A candidate transform ``x -> M x + t`` is judged by the images of all contacts:

* *consistent*: an image lies within ``match_radius_m`` of a contact whose normal agrees with the
  image's normal (within ``normal_cone_rad``) and within ``plane_tolerance_m`` of the plane through
  that contact across the contact's normal (its tangent plane) or across the bisector of the two
  normals (a chord of a circle is perpendicular to the bisector of its ends' normals, so a rim's
  curvature between the two does not count against the image as it does against the tangent
  plane; the search's smooth score uses the tangent plane alone);
* *inconsistent*: such a contact is near but its plane is not (a testable image that fails);
* *outside*: the image lies outside the contacts' convex hull by more than ``hull_margin_m`` and
  more than ``hull_gap_fraction`` of the gap it lies in front of (the smaller of its hull facet's
  circumradius and the distance from its foot on the facet to the third nearest contact): between
  sparse contacts a curved surface bulges out of the hull, a bowl's wall 5-11 mm at 100 contacts;
* *free*: the GPIS mean at the image is deeper than ``free_depth_m`` in free space or in solid
  (a mug's handle turned about the cup's axis lands in free space), and deeper than
  ``free_confidence`` posterior standard deviations: where no contact is near, the plain mean is
  itself the phantom the images correct (a bowl's rim), and says nothing against them.

Accepted when at least ``min_consistent`` of the images are consistent, at most
``max_inconsistent`` are inconsistent and ``min_consistent_share`` of the testable ones are
consistent (or no more than ``consistency_exceptions`` are not: with the 20-33 testable images of
60-100 contacts, 97 % allows none, and one image 8 mm from a contact whose normal is 9 deg off, the
loop's typical error, misses its tangent plane by 1.3 mm), at most ``max_outside`` lie outside, and
at most ``max_free`` lie in free space, or as large a share as the GPIS puts of the contacts
themselves, each left out, when that is more than chance at ``max_free`` gives
(:meth:`reconstruction.gpis.GPIS.leave_one_out`): images of a true symmetry are points of the
surface the GPIS has not seen, and a field that misplaces its own contacts by several millimetres
(thin walls touched through the loop) misplaces them as often; and no supporting flat face of the
contacts (several contacts on one plane, its normal known to a few degrees) is turned onto another
by more than their errors allow (:meth:`_ImageJudge.face_conflicts`: the plane halving a wedge's
top and bottom turns its end face 20 deg); and the GPIS predicts the images no worse than it
predicts its own contacts, each left out (:meth:`_ImageJudge._images_worse_predicted`): a body
with no symmetry often has one it nearly has (a blob's axis, a banana's mirror) whose images pass
every test above within a millimetre of the surface, but off it where the contacts already pin the
surface, so their standardised GPIS values ``|mean| / std`` are larger than a left-out contact's,
where a true symmetry's images, unseen points of the surface, are like it. The defaults were
chosen on the generated tuning split (BENCHMARKS.md).

Search. An axis of revolution first: every normal line of a surface of revolution meets its axis,
so the axis is fitted to the contacts' normal lines (robust least squares over a hemisphere of
directions), then refined on the images of rotations by 37, 90 and 180 deg, and accepted by the
images of 37 and 90 deg turns. An accepted axis is then polished where the contacts' profile in
(height, radius) about it is thinnest (:func:`profile_misfit`), and the polished axis replaces it
if its turns are accepted too: the images' score is flat within a degree or two, the profile is
not. A refused axis is polished too, from itself and from starts tilted 2 deg about it (a
plate's normals pin its axis poorly, so the refined one can be degrees off): the thinnest profile
whose turns are accepted is the axis, unless the mirror planes below cross in an axis of
revolution about which the profile is thinner (:func:`_rescue_axis`). Otherwise mirror planes: a hemisphere of plane normals through the
contacts' centroid, the best ``starts`` refined (Nelder-Mead on a soft score, then a finer one),
up to three accepted planes at least 80 deg apart. An axis the turns refused (a mug: its handle)
first offers the planes through it, scored every 2 deg, as starts: every one of them fits the cup
and only the handle's plane fits the handle, which a local search from elsewhere does not see.
When those planes typically put more than ``max_free`` of the images in free space (a feature
refused the axis), a plane through the axis must halve their share to be accepted. Such an axis
still holds for the rest of the object when the contacts whose turned images fail (in free space,
beyond the sag or inconsistent: the handle's) are at most ``max_feature_share`` of them and the
others' images pass every test: the turns then copy every contact but the feature's, and no image
onto it (``Symmetry.body_transforms``), beside the planes found. Without them a mug's opening,
where nothing is touched, was left to the plain GPIS, which can close it with a dome 2 cm high
(BENCHMARKS.md, "A handle is a feature of the cup's revolution"). The soft
score counts images in the GPIS's free space or solid too (its mean on a grid). An axis's mirror
across it (top to bottom) is placed where the contacts' profile maps onto itself
(:func:`_mirror_offset`), and leaves out a feature the same way: the contacts whose mirrored
profile points lie off the profile or whose images the GPIS puts in free space or solid, an
apple's stem (:func:`_feature_of_mirror`). Two accepted
planes whose intersection is an axis of revolution (images of a 37 deg turn accepted) give the
revolution too.

The images a mesh observes (:meth:`reconstruction.gpis.GPIS.mesh`) leave out those two tests put
off the surface at once (:func:`contradicted_images`): outside the contacts' hull beyond the sag
and deep in the GPIS's free space. An accepted symmetry may hold for all of the object but a small
feature (a fruit's stem: 1.5 % of each transform's images, under the 2 % ``max_free``), and the
feature's images would grow it where the object has none; either test alone also drops images of
a true symmetry (a bowl's bottom, where the mean between sparse contacts is itself wrong, lies
inside the hull). Nor do they copy a contact that is itself off the surface (a pad's rim on an
edge, a few millimetres out): :func:`disputed_contacts` leaves each contact out of the field that
observes the images and asks whether the rest put it in free space; those that do lose their
images, and the others are asked again without them. A true symmetry's images agree on the
surface, so one wrong contact stands out against them where, alone, it had no neighbour to
contradict it (a ring's hole filled by the images of three contacts at its edge, BENCHMARKS.md,
"A contact the images put in free space"). It costs a true contact on a feature no other contact
or image covers its images as well (ideal sampled contacts: 0.44 -> 0.45 mm on average).

Written here rather than taken from a library: the symmetry detectors of the mesh libraries
(``trimesh.Trimesh.symmetry``) work on a finished, exact mesh; this works on 50-400 noisy oriented
points and must say no on an object that is not symmetric.
"""
from __future__ import annotations

from dataclasses import dataclass, replace
from functools import cached_property

import numpy as np
from scipy.ndimage import map_coordinates
from scipy.optimize import minimize, minimize_scalar
from scipy.spatial import ConvexHull, cKDTree
from scipy.spatial.transform import Rotation
from scipy.stats import binom, mannwhitneyu

from common.directions import fibonacci_directions, perpendicular_frame
from reconstruction.face_planes import DEFAULT_FLATNESS_M, ContactFaces, supporting_contact_faces
from reconstruction.outside_evidence import DEFAULT_FACET_FRACTION, DEFAULT_LOCAL_NEIGHBOURS

#: A rigid map ``x -> M @ x + t``: (M (3, 3), t (3,)), object frame, metres.
Transform = tuple[np.ndarray, np.ndarray]


@dataclass(frozen=True)
class SymmetrySettings:
    """How symmetries are searched and judged (lengths in metres, angles in radians).

    ``match_radius_m``: how near a contact an image must lie to be tested; ``coarse_tolerance_m``,
    ``plane_tolerance_m``, ``fine_tolerance_m``: off-plane distances of the three search stages
    (the middle one also judges); ``normal_cone_rad``: how far the image's and the contact's
    normals may differ; ``min_consistent`` ... ``max_free``: the acceptance shares of the module
    docstring, with ``hull_margin_m`` and ``free_depth_m`` their distances; ``directions`` /
    ``starts``: plane normals scored on a hemisphere and how many are refined; ``hull_gap_fraction``
    and ``free_confidence``: how far beyond the sag between contacts an image counts as outside, and
    how many posterior standard deviations deep in free space it counts as free;
    ``consistency_exceptions``: inconsistent testable images allowed whatever their share;
    ``misplaced_significance``: how unlikely by chance the share of its own contacts the GPIS
    misplaces must be before the images may be free as often; ``axis_starts``:
    planes through a refused axis of revolution refined first; ``search_grid``: points per axis
    of the GPIS mean the search interpolates; ``rotations``: turns about an axis of revolution
    (360 / rotations apart); ``min_image_gap_m`` / ``max_images``: images kept
    (:meth:`Symmetry.images`); ``merge_images``: images that compete for a place (nearer each
    other than ``min_image_gap_m``) are merged into their mean (the default; False: the first is
    kept, and the order of the transforms decides which; merged was better on the tuning split,
    BENCHMARKS.md "Competing images merged into their mean"), and ``rank_images``: the GPIS
    orders competing images by how well its other observations predict their contacts (their
    left-out values in their standard deviations), so the best leads a merged group or, unmerged,
    is kept (False, the default: the transforms' order; ranked was worse on the tuning split,
    BENCHMARKS.md "Competing images ranked by their contacts");
    ``min_contacts``: fewer contacts say nothing;
    ``face_match_radius_m`` / ``face_conflict_rad``: how near a face's mapped centre must lie to
    another face's centre to be compared, and by how much more than both faces' tilt and curvature
    allowances their normals may not differ (:meth:`_ImageJudge.face_conflicts`), for faces at least
    ``face_min_width_m`` wide (a narrow strip's normal is not known about its long axis);
    ``across_bisector``: the judge also measures an image's distance across the bisector of its
    and the contact's normals, not only along the contact's normal (:meth:`_ImageJudge._residuals`);
    ``prediction_significance`` / ``max_prediction_ratio``: how unlikely by chance, and by how
    many times larger in the median, the images' standardised GPIS values must be than the
    left-out contacts' to refuse a transform (None: not tested;
    :meth:`_ImageJudge._images_worse_predicted`); ``dispute_depth_m`` / ``dispute_sigma`` /
    ``dispute_rounds``: how deep in free space, in metres and in posterior standard deviations, the
    other contacts and their images must put a contact before its images are left out, and how
    many times that is re-judged without the images left out (None depth: never;
    :func:`disputed_contacts`); ``max_feature_share``: the largest share of the contacts an axis's
    turns may refuse as a feature (a mug's handle) and the axis still hold for the rest (None:
    never; :func:`_feature_of_revolution`), and ``feature_radius_m`` how near those contacts a
    contact or an image counts as part of the feature; ``profile_scales_m``: the residual scales
    (Huber) of the stages that polish an axis by its profile (:func:`_polish_axis`; empty: not
    polished); ``rescue_starts`` / ``rescue_tilt_rad``: the starts tilted about a refused axis
    from which it is polished again, and their tilt (None: a refused axis is not polished;
    :func:`_rescue_axis`); ``mirror_by_profile``: the mirror across an axis of revolution is
    placed by the contacts' profile and leaves out the contacts it maps off it (a stem;
    :func:`_mirror_offset`, :func:`_feature_of_mirror`; False: as the images' score places it,
    for every contact); ``polish_planes_axis``: an axis that two mirror planes' crossing gives is
    polished by its profile too (:func:`_polish_planes_axis`), and ``"planes"`` keeps the planes
    (moved onto it) and their turns, ``"revolution"`` the turns about it and the mirror across it
    alone; None: the planes and their crossing as found.
    """

    match_radius_m: float = 0.008
    coarse_tolerance_m: float = 5e-3
    plane_tolerance_m: float = 1.5e-3
    fine_tolerance_m: float = 0.7e-3
    normal_cone_rad: float = float(np.radians(30.0))
    min_consistent: float = 0.1
    max_inconsistent: float = 0.05
    min_consistent_share: float = 0.97
    consistency_exceptions: int = 1
    max_outside: float = 0.1
    hull_margin_m: float = 5e-3
    hull_gap_fraction: float = DEFAULT_FACET_FRACTION
    max_free: float = 0.02
    free_depth_m: float = 4e-3
    free_confidence: float = 2.5
    misplaced_significance: float = 0.05
    directions: int = 400
    starts: int = 12
    axis_starts: int = 3
    search_grid: int = 32
    rotations: int = 8
    min_image_gap_m: float = 3e-3
    max_images: int = 1000
    rank_images: bool = False
    merge_images: bool = True
    min_contacts: int = 20
    face_match_radius_m: float = 5e-3
    face_min_width_m: float = 0.010
    face_conflict_rad: float = float(np.radians(10.0))
    across_bisector: bool = True
    prediction_significance: float | None = 1e-3
    max_prediction_ratio: float = 1.5
    dispute_depth_m: float | None = 3e-3
    dispute_sigma: float = 2.0
    dispute_rounds: int = 3
    max_feature_share: float | None = 0.2
    feature_radius_m: float = 0.008
    profile_scales_m: tuple[float, ...] = (2e-3, 5e-4, 5e-4)
    rescue_starts: int | None = 4
    rescue_tilt_rad: float = float(np.radians(2.0))
    mirror_by_profile: bool = True
    polish_planes_axis: str | None = "planes"

    def __post_init__(self):
        if self.polish_planes_axis not in ("planes", "revolution", None):
            raise ValueError(f"SymmetrySettings.polish_planes_axis must be 'planes', 'revolution' or None, "
                             f"got {self.polish_planes_axis!r}")


@dataclass(frozen=True)
class Symmetry:
    """What was found: the transforms (identity left out), the accepted mirror planes and the axis.

    Attributes
    ----------
    transforms : tuple of (M (3, 3), t (3,))
        The symmetry group's elements other than the identity, ``x -> M x + t``, object frame.
    planes : tuple of (u (3,), d)
        Accepted mirror planes ``u . x = d`` (unit normal, offset in metres).
    axis : (point (3,), direction (3,)) or None
        The axis of revolution, metres / unit vector; None if not a surface of revolution.
    body_transforms : tuple of (M (3, 3), t (3,))
        Transforms that hold for every part but a feature: turns about ``axis`` that a mug's
        handle refused, or the mirror across the axis (and its products with the turns) that an
        apple's stem refused. Applied only to points farther than ``feature_radius_m`` from every
        point of ``feature_points``, and their images kept only where they land as far from the
        feature (a cup's wall turned onto the handle's root).
    feature_points : (k, 3) float or None
        The contacts the body's transforms leave out, object frame, metres.
    feature_radius_m : float
        How near a feature contact a point counts as part of the feature, metres.
    rank_images : bool
        Whether the GPIS that observes the images ranks competing images by their contacts'
        agreement (``SymmetrySettings.rank_images`` of the search that found this).
    merge_images : bool
        Whether :meth:`images` merges competing images into their mean
        (``SymmetrySettings.merge_images`` of the search that found this).
    """

    transforms: tuple[Transform, ...] = ()
    planes: tuple[tuple[np.ndarray, float], ...] = ()
    axis: tuple[np.ndarray, np.ndarray] | None = None
    body_transforms: tuple[Transform, ...] = ()
    feature_points: np.ndarray | None = None
    feature_radius_m: float = SymmetrySettings.feature_radius_m
    rank_images: bool = SymmetrySettings.rank_images
    merge_images: bool = SymmetrySettings.merge_images

    @property
    def kind(self) -> str:
        """``"revolution"`` (also when a feature is left out of it), ``"mirror"`` (one or more planes)
        or ``"none"``."""
        if self.axis is not None:
            return "revolution"
        return "mirror" if self.planes else "none"

    def images(self, points: np.ndarray, normals: np.ndarray,
               settings: SymmetrySettings = SymmetrySettings(), return_sources: bool = False,
               priority: np.ndarray | None = None):
        """Images of the contacts under every transform (and of those off the feature under the body's
        turns, where they land off it), away from the contacts and each other.

        Parameters
        ----------
        points : (n, 3) float, object frame, metres; normals : (n, 3) float, outward unit normals.
        return_sources : bool
            Also return which contact each image copies.
        priority : (n,) float, optional
            Where images compete for a place (within ``min_image_gap_m`` of each other), the copy
            of the contact with the lower priority is kept (a stable order: ties keep the
            transforms' order); None: the transforms' order decides. The GPIS passes how far the
            other observations put each contact off the surface, in their posterior standard
            deviations (:meth:`GPIS.leave_one_out`).

        Returns
        -------
        image_points : (k, 3) float; image_normals : (k, 3) float; with ``return_sources``,
        sources : (k,) int, the index of the contact each image copies. An image closer than
        ``min_image_gap_m`` to a contact or to an image kept before it is left out (it adds nothing
        a contact does not say); with this Symmetry's ``merge_images`` (the search copies it from
        its settings, ``settings`` here does not change it), an image near a contact is left out and
        the others closer than that to an image taken first are merged with it into their mean
        (its source is the first's), so no single copy decides the place. At most ``max_images``
        are kept (an even, seeded subsample).
        """
        points, normals = np.asarray(points, float), np.asarray(normals, float)
        if not (self.transforms or self.body_transforms) or len(points) == 0:
            empty = (np.zeros((0, 3)), np.zeros((0, 3)))
            return empty + (np.zeros(0, int),) if return_sources else empty
        turned, turned_normals, turned_sources = [], [], []
        body = np.flatnonzero(~self.in_feature(points))
        for m, t in self.body_transforms:  # neither from the feature nor onto it
            q = points[body] @ m.T + t
            keep = ~self.in_feature(q)
            turned.append(q[keep])
            turned_normals.append(normals[body[keep]] @ m.T)
            turned_sources.append(body[keep])
        all_points = np.vstack([points] + [points @ m.T + t for m, t in self.transforms] + turned)
        all_normals = np.vstack([normals] + [normals @ m.T for m, _ in self.transforms] + turned_normals)
        all_sources = np.concatenate([np.tile(np.arange(len(points)), 1 + len(self.transforms))] + turned_sources)
        if priority is not None:
            priority = np.asarray(priority, float)
            if priority.shape != (len(points),):
                raise ValueError(f"priority must be one value per contact, shape ({len(points)},), got {priority.shape}")
            order = np.concatenate([np.arange(len(points)),
                                    len(points) + np.argsort(priority[all_sources[len(points):]], kind="stable")])
            all_points, all_normals, all_sources = all_points[order], all_normals[order], all_sources[order]
        image_points, image_normals, sources = _grouped_images(all_points, all_normals, all_sources, len(points),
                                                               settings.min_image_gap_m, self.merge_images)
        if len(image_points) > settings.max_images:
            keep = np.sort(np.random.default_rng(0).choice(len(image_points), settings.max_images, replace=False))
            image_points, image_normals, sources = image_points[keep], image_normals[keep], sources[keep]
        return (image_points, image_normals, sources) if return_sources else (image_points, image_normals)

    def in_feature(self, points: np.ndarray) -> np.ndarray:
        """(n,) bool: each point (n, 3) lies within ``feature_radius_m`` of a feature contact."""
        points = np.asarray(points, float)
        if self.feature_points is None or len(self.feature_points) == 0:
            return np.zeros(len(points), bool)
        distance, _ = cKDTree(self.feature_points).query(points)
        return distance <= self.feature_radius_m


def _grouped_images(points: np.ndarray, normals: np.ndarray, sources: np.ndarray, n_contacts: int,
                    gap_m: float, merge: bool) -> tuple[np.ndarray, np.ndarray, np.ndarray]:
    """The images kept where copies compete: ``points`` / ``normals`` (m, 3) and ``sources`` (m,)
    list the ``n_contacts`` contacts first, then their copies in order. A copy within ``gap_m`` of
    a contact is left out. Each remaining copy not yet grouped leads a group of the ungrouped copies
    within ``gap_m`` of it; ``merge``: only those whose normal is less than 90 deg from its own (the
    other side of a thin wall does not compete), and the group is one image at its mean position
    with its mean normal (unit); otherwise the leader alone is kept. Each image names its leader's
    source. Returns (k, 3), (k, 3), (k,)."""
    copies = np.arange(n_contacts, len(points))
    if n_contacts:
        distance, _ = cKDTree(points[:n_contacts]).query(points[copies])
        copies = copies[distance > gap_m]
    if len(copies) == 0:
        return np.zeros((0, 3)), np.zeros((0, 3)), np.zeros(0, int)
    tree = cKDTree(points[copies])
    grouped = np.zeros(len(copies), bool)
    leaders, out_points, out_normals = [], [], []
    for i in range(len(copies)):
        if grouped[i]:
            continue
        near = np.asarray(tree.query_ball_point(points[copies[i]], gap_m), int)
        group = near[~grouped[near]]
        if merge:
            group = group[normals[copies[group]] @ normals[copies[i]] > 0.0]
        grouped[group] = True
        leaders.append(copies[i])
        if merge:
            out_points.append(points[copies[group]].mean(0))
            normal = normals[copies[group]].sum(0)
            out_normals.append(normal / np.linalg.norm(normal))
    leaders = np.array(leaders, int)
    if not merge:
        return points[leaders], normals[leaders], sources[leaders]
    return np.array(out_points), np.array(out_normals), sources[leaders]


def reflection(normal: np.ndarray, offset_m: float) -> Transform:
    """The mirror across the plane ``normal . x = offset_m`` (normal a unit vector)."""
    u = np.asarray(normal, float)
    return np.eye(3) - 2.0 * np.outer(u, u), 2.0 * offset_m * u


def rotation(direction: np.ndarray, point_m: np.ndarray, angle_rad: float) -> Transform:
    """The turn by ``angle_rad`` about the axis through ``point_m`` along ``direction``."""
    v = np.asarray(direction, float) / np.linalg.norm(direction)
    r = Rotation.from_rotvec(angle_rad * v).as_matrix()
    return r, np.asarray(point_m, float) - r @ point_m


def find_symmetry(points: np.ndarray, normals: np.ndarray, gpis=None,
                  settings: SymmetrySettings = SymmetrySettings()) -> Symmetry:
    """The symmetry of the object the contacts lie on, or ``Symmetry()`` if none is supported.

    Parameters
    ----------
    points : (n, 3) float
        Contact positions, object frame, metres.
    normals : (n, 3) float
        Outward unit normals at the contacts.
    gpis : GPIS, optional
        The contacts' GPIS: an image its mean puts deep in free space or in solid counts against a
        candidate (without it, only the contacts and their hull judge).
    """
    found = _find_symmetry(points, normals, gpis, settings)
    return replace(found, rank_images=settings.rank_images, merge_images=settings.merge_images)


def _find_symmetry(points, normals, gpis, settings: SymmetrySettings) -> Symmetry:
    points, normals = np.asarray(points, float), np.asarray(normals, float)
    if len(points) < settings.min_contacts:
        return Symmetry()
    normals = normals / np.linalg.norm(normals, axis=1, keepdims=True)
    judge = _ImageJudge(points, normals, gpis, settings)
    if not judge.usable:
        return Symmetry()
    centre = points.mean(0)

    direction, point = _fit_axis(points, normals)
    through_axis: list[tuple[np.ndarray, float]] = []
    feature = None
    rescued = None
    if direction is not None:
        direction, point = _refine_axis(judge, direction, point)
        if _turns_accepted(judge, direction, point):
            polished = _polish_axis(points, normals, direction, point, settings)
            if polished is not None and _turns_accepted(judge, *polished):
                direction, point = polished
            return _revolution(judge, direction, point, centre, settings)
        rescued = _rescue_axis(judge, direction, point, settings)
        if rescued is None:
            through_axis, typical_free = _planes_through_axis(judge, direction, point, settings)
            if typical_free > settings.max_free:
                # A feature refused the axis (the planes through it put its images in free space):
                # a plane through the axis is its mirror only if it halves that share (a plane 10
                # deg off a mug's handle still passes max_free), and the axis may hold for the rest.
                judge.feature_axis = (direction, point, 0.5 * typical_free)
                feature = _feature_of_revolution(judge, direction, point, settings)

    planes = _mirror_planes(judge, centre, settings, through_axis)
    if len(planes) >= 2:
        (u1, d1), (u2, d2) = planes[:2]
        v = np.cross(u1, u2)
        v /= np.linalg.norm(v)
        crossing = np.linalg.solve(np.vstack([u1, u2, v]), [d1, d2, v @ centre])
        if judge.accepts(rotation(v, crossing, np.radians(37.0))):
            if rescued is not None and _thinner(judge, rescued, (v, crossing), settings):
                return _revolution(judge, *rescued, centre, settings)
            polished = _polish_planes_axis(judge, v, crossing, settings)
            if polished is not None:
                if settings.polish_planes_axis == "revolution":
                    return _revolution(judge, *polished, centre, settings)
                planes = [_replaced(u, d, v, crossing, *polished) for u, d in planes]
                v, crossing = polished
            turns = _turns(v, crossing, settings)
            along = [reflection(u, d) for u, d in planes if abs(u @ v) < 0.05][:1]
            across = [reflection(u, d) for u, d in planes if abs(u @ v) > 0.995][:1]
            group = list(turns)
            for m, t in along:
                group += [(m, t)] + [(m @ r, m @ s + t) for r, s in turns]
            for m, t in across:
                group = group + [(m, t)] + [(m @ a, m @ b + t) for a, b in group]
            return Symmetry(tuple(group), tuple(planes), (crossing, v))
    if rescued is not None:
        return _revolution(judge, *rescued, centre, settings)
    group = [reflection(u, d) for u, d in planes]
    for a in range(len(planes)):
        for b in range(a + 1, len(planes)):
            if abs(planes[a][0] @ planes[b][0]) < np.cos(np.radians(88.0)):
                (ma, ta), (mb, tb) = group[a], group[b]
                group.append((ma @ mb, ma @ tb + ta))
    if len(planes) == 3 and len(group) == 6:
        (ma, ta), (mb, tb), (mc, tc) = group[:3]
        group.append((ma @ mb @ mc, ma @ (mb @ tc + tb) + ta))
    if feature is not None:
        return Symmetry(tuple(group), tuple(planes), (point, direction),
                        body_transforms=tuple(_turns(direction, point, settings)),
                        feature_points=points[feature], feature_radius_m=settings.feature_radius_m)
    return Symmetry(tuple(group), tuple(planes), None)


def contradicted_images(gpis, images: np.ndarray, settings: SymmetrySettings = SymmetrySettings()) -> np.ndarray:
    """Which images both the contacts' hull and the GPIS put off the surface.

    Parameters
    ----------
    gpis : GPIS
        The contacts' GPIS (its contacts give the hull, its mean and variance the depth).
    images : (k, 3) float
        Image points, object frame, metres.

    Returns
    -------
    (k,) bool: the image lies outside the contacts' convex hull by more than ``hull_margin_m`` and
    the sag between contacts (the judge's *outside*) and the GPIS mean there is deeper than
    ``free_depth_m`` and ``free_confidence`` posterior standard deviations (its *free*).
    """
    images = np.asarray(images, float)
    contradicted = np.zeros(len(images), bool)
    points = gpis.contact_points
    if len(images) == 0 or len(points) < 4:
        return contradicted
    normals = gpis.contact_normals / np.linalg.norm(gpis.contact_normals, axis=1, keepdims=True)
    judge = _ImageJudge(points, normals, gpis, settings)
    if not judge.usable:
        return contradicted
    contradicted = judge._beyond_the_sag(images, *judge._outside_hull(images))
    if contradicted.any():
        contradicted[contradicted] = judge._in_free_space(images[contradicted])
    return contradicted


def disputed_contacts(model, n_contacts: int, settings: SymmetrySettings = SymmetrySettings()) -> np.ndarray:
    """Which contacts the other contacts and the images put in free space.

    A contact a few millimetres off the surface (a pad's rim on an edge) is one wrong point; its
    images under a revolution are fifteen, and they may fill a ring's hole (BENCHMARKS.md, "A
    contact the images put in free space"). Left out of a field that observes the images, such a
    contact is predicted in free space by the surface the other contacts' images agree on, where a
    good one is predicted on it. Its own images stay in: near an axis they lie close enough to vouch
    for a small feature only this contact touched (a lid's knob, a fruit's stem), which would
    otherwise be disputed; far from it (a ring's hole edge) they say nothing about it. Only free
    space counts: a pad's centre can stand off the surface but not sink into it, so a contact the
    others put inside the solid says they are wrong there (both signs were worse on the tuning split).

    Parameters
    ----------
    model : GPIS
        Observes the ``n_contacts`` contacts first, then their images.
    n_contacts : int
        How many of the model's contacts are measured ones, not images.

    Returns
    -------
    (n_contacts,) bool: ``f`` at the contact, predicted without its own rows
    (:meth:`reconstruction.gpis.GPIS.leave_one_out`), is deeper in free space than
    ``dispute_depth_m`` and ``dispute_sigma`` posterior standard deviations.
    """
    if settings.dispute_depth_m is None or model.n_contacts <= n_contacts:
        return np.zeros(n_contacts, bool)
    mean, std = (values[:n_contacts] for values in model.leave_one_out())
    return (-mean > settings.dispute_depth_m) & (-mean > settings.dispute_sigma * std)


class _ImageJudge:
    """Scores a transform by where the contacts' images land (module docstring)."""

    def __init__(self, points, normals, gpis, settings: SymmetrySettings):
        self.points, self.normals, self.gpis, self.s = points, normals, gpis, settings
        self.tree = cKDTree(points)
        self._depth_grid = None
        self.feature_axis = None
        self.cos_cone = np.cos(settings.normal_cone_rad)
        try:
            hull = ConvexHull(points)
        except Exception:  # flat or degenerate contact sets: nothing to judge by
            self.hull, self.usable = None, False
            return
        self.hull, self.usable = hull.equations, True
        corners = points[hull.simplices]
        self.circumradius = np.linalg.norm(corners - corners.mean(axis=1, keepdims=True), axis=2).max(axis=1)

    @cached_property
    def free_allowance(self) -> float:
        """The share of images allowed in free space or solid: ``max_free``, or the share of its own
        contacts the GPIS misplaces if larger (computed on first use: it costs a leave-one-out)."""
        if self.gpis is not None and self.gpis.use_normals:
            return max(self.s.max_free, self._contacts_free_share())
        return self.s.max_free

    def _contacts_free_share(self) -> float:
        """The share of the contacts themselves the GPIS puts in free space or solid by the images'
        rule when each is left out (:meth:`GPIS.leave_one_out`): the images of a true symmetry are
        points of the same surface the GPIS has not seen, so they may be judged free as often. Zero
        unless more contacts are misplaced than ``max_free`` of them would be by chance (a one-sided
        binomial test at ``misplaced_significance``): one misplaced contact among 46 says nothing."""
        misplaced = self._deep(*self._left_out)
        k, n = int(misplaced.sum()), len(misplaced)
        if k == 0 or binom.sf(k - 1, n, self.s.max_free) > self.s.misplaced_significance:
            return 0.0
        return k / n

    @cached_property
    def _left_out(self) -> tuple[np.ndarray, np.ndarray]:
        """(n,) each contact's GPIS mean and (n,) its std with the contact left out (metres)."""
        return self.gpis.leave_one_out()

    def _images_worse_predicted(self, q: np.ndarray) -> bool:
        """Whether the GPIS predicts the images ``q`` (k, 3) worse than it predicts its own contacts
        left out: their standardised values ``|mean| / std`` larger by a one-sided Mann-Whitney test
        below ``prediction_significance`` and with a median more than ``max_prediction_ratio`` times
        the contacts'. Images of a true symmetry are points of the surface the GPIS has not seen,
        like a contact left out; a near symmetry's images lie off the surface where the contacts
        already pin it (the tuning split's blobs: medians up to 3.8 times the contacts', p down to
        1e-38; BENCHMARKS.md, "A near symmetry's images are predicted worse than the contacts").
        Only images inside the GPIS's region count."""
        s = self.s
        if s.prediction_significance is None or self.gpis is None or not self.gpis.use_normals:
            return False
        lo, hi = self.gpis.region
        q = q[np.all((q >= lo) & (q <= hi), axis=1)]
        if len(q) < 2:
            return False
        mean = np.asarray(self.gpis.mean(q), float)
        std = np.sqrt(np.maximum(np.asarray(self.gpis.variance(q), float), 0.0))
        images = np.abs(mean) / np.maximum(std, 1e-9)
        left_mean, left_std = self._left_out
        contacts = np.abs(left_mean) / np.maximum(left_std, 1e-9)
        if np.median(images) <= s.max_prediction_ratio * np.median(contacts):
            return False
        return bool(mannwhitneyu(images, contacts, alternative="greater").pvalue < s.prediction_significance)

    def _deep(self, mean: np.ndarray, std: np.ndarray, depth_m: float | None = None) -> np.ndarray:
        """(n,) bool: the GPIS mean puts these points (an image, or a contact left out) in free
        space or solid, deeper than ``depth_m`` (default ``free_depth_m``) and ``free_confidence``
        posterior stds."""
        depth = self.s.free_depth_m if depth_m is None else depth_m
        return (np.abs(mean) > depth) & (np.abs(mean) > self.s.free_confidence * std)

    def _residuals(self, transform: Transform, neighbours: int = 4, across_bisector: bool = False):
        """(n, 3) the images, (n,) distance of each image to the plane of the best agreeing contact
        within the match radius (inf: none near), (n,) its distance outside the hull and (n,) int
        the hull facet it lies farthest in front of.

        The plane is the contact's tangent plane or, with ``across_bisector``, the nearer of it and
        the plane through the contact across the bisector of the contact's and the image's normals:
        a chord of a circle is perpendicular to the bisector of its ends' normals, so between two
        points of a sphere or a rim the second is exact where the tangent plane misses an image 8 mm
        along a rim of 10 mm radius by 3 mm; near a sharp edge, where noisy normals differ for
        another reason, the tangent plane can be the nearer."""
        m, t = transform
        q, qn = self.points @ m.T + t, self.normals @ m.T
        dist, idx = self.tree.query(q, k=neighbours, distance_upper_bound=self.s.match_radius_m)
        near = np.isfinite(dist)
        idx = np.where(near, idx, 0)
        contact_normals = self.normals[idx]  # (n, k, 3)
        agrees = near & (np.einsum("ikj,ij->ik", contact_normals, qn) > self.cos_cone)
        chord = q[:, None, :] - self.points[idx]
        off_plane = np.abs(np.einsum("ikj,ikj->ik", chord, contact_normals))
        if across_bisector:  # agreeing normals are within the cone, so only others' sum can vanish
            bisector = contact_normals + qn[:, None, :]
            bisector /= np.where(agrees, np.linalg.norm(bisector, axis=2), 1.0)[..., None]
            off_plane = np.minimum(off_plane, np.abs(np.einsum("ikj,ikj->ik", chord, bisector)))
        residual = np.min(np.where(agrees, off_plane, np.inf), axis=1)
        return (q, residual, *self._outside_hull(q))

    def _outside_hull(self, q: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
        """(n,) distance of each point outside the contacts' hull (negative inside) and (n,) int the
        hull facet it lies farthest in front of."""
        signed = q @ self.hull[:, :3].T + self.hull[:, 3]
        facet = np.argmax(signed, axis=1)
        return signed[np.arange(len(q)), facet], facet

    def _in_free_space(self, q: np.ndarray, depth_m: float | None = None) -> np.ndarray:
        """(n,) bool: the GPIS mean puts these points deep in free space or solid (:meth:`_deep`,
        ``depth_m`` instead of ``free_depth_m`` if given; the variance only where the mean is deep
        enough)."""
        mean = np.asarray(self.gpis.mean(q), float)
        deep = np.abs(mean) > (self.s.free_depth_m if depth_m is None else depth_m)
        if deep.any():
            std = np.sqrt(np.maximum(np.asarray(self.gpis.variance(q[deep]), float), 0.0))
            deep[deep] = self._deep(mean[deep], std, depth_m)
        return deep

    def soft_score(self, transform: Transform, tolerance_m: float | None = None) -> float:
        """Smooth score for the search: Gaussian agreement minus inconsistent, outside and free
        images (the last from the GPIS mean interpolated on a grid: a mug's handle decides between
        vertical planes that all fit its cup)."""
        tolerance = tolerance_m or self.s.plane_tolerance_m
        q, residual, outside, _ = self._residuals(transform)
        testable = np.isfinite(residual)
        agreement = np.where(testable, np.exp(-0.5 * (np.where(testable, residual, 0.0) / tolerance) ** 2), 0.0)
        inconsistent = testable & (residual >= max(tolerance, self.s.plane_tolerance_m))
        free = 0.0
        if self.gpis is not None:
            free = float(np.mean(np.abs(self._grid_depth(q)) > self.s.free_depth_m))
        return float(agreement.mean() - 2.0 * inconsistent.mean() - (outside > self.s.hull_margin_m).mean()
                     - 2.0 * free)

    def _grid_depth(self, q: np.ndarray) -> np.ndarray:
        """(n,) the GPIS mean at ``q``, trilinear on a grid of ``search_grid`` points per axis
        (built once: the search scores thousands of candidates)."""
        lo, hi = self.gpis.region
        steps = self.s.search_grid - 1
        if self._depth_grid is None:
            axes = [np.linspace(lo[k], hi[k], self.s.search_grid) for k in range(3)]
            grid = np.stack(np.meshgrid(*axes, indexing="ij"), axis=-1).reshape(-1, 3)
            self._depth_grid = np.asarray(self.gpis.mean(grid), float).reshape((self.s.search_grid,) * 3)
        index = (np.clip(q, lo, hi) - lo) / (hi - lo) * steps
        return map_coordinates(self._depth_grid, index.T, order=1, mode="nearest")

    def verdicts(self, transform: Transform) -> dict:
        """(n,) bool per contact's image: ``testable``, ``consistent``, ``outside`` (beyond the
        sag) and ``free`` (in the GPIS's free space or solid; all False without a GPIS)."""
        q, residual, outside, facet = self._residuals(transform, across_bisector=self.s.across_bisector)
        testable = np.isfinite(residual)
        free = np.zeros(len(q), bool)
        if self.gpis is not None:
            lo, hi = self.gpis.region
            free = self._in_free_space(np.clip(q, lo, hi))
        return dict(testable=testable, consistent=testable & (residual < self.s.plane_tolerance_m),
                    outside=self._beyond_the_sag(q, outside, facet), free=free)

    def fractions(self, transform: Transform, subset: np.ndarray | None = None) -> dict:
        """Shares of the images (of the contacts in ``subset``, (n,) bool, if given): testable,
        consistent, outside the hull, in free space or solid; and ``inconsistent_count``, the
        testable images that are not consistent."""
        v = self.verdicts(transform)
        if subset is not None:
            v = {key: value[subset] for key, value in v.items()}
        testable, consistent = v["testable"], v["consistent"]
        return dict(testable=float(testable.mean()), consistent=float(consistent.mean()),
                    share=float(consistent.sum() / testable.sum()) if testable.any() else 0.0,
                    inconsistent_count=int(np.sum(testable & ~consistent)),
                    outside=float(np.mean(v["outside"])), free=float(np.mean(v["free"])))

    def _beyond_the_sag(self, q: np.ndarray, outside: np.ndarray, facet: np.ndarray) -> np.ndarray:
        """(n,) bool: each image lies outside the hull by more than ``hull_margin_m`` and more than
        ``hull_gap_fraction`` of the gap in front of which it lies (module docstring; the gap as the
        outside evidence measures it)."""
        foot = q - outside[:, None] * self.hull[facet, :3]
        k = min(DEFAULT_LOCAL_NEIGHBOURS, len(self.points))
        nearest = self.tree.query(foot, k=k)[0].reshape(len(q), k)[:, -1]
        gap = np.minimum(self.circumradius[facet], nearest)
        return outside > np.maximum(self.s.hull_margin_m, self.s.hull_gap_fraction * gap)

    def accepts(self, transform: Transform, subset: np.ndarray | None = None) -> bool:
        """Whether the images pass every test of the module docstring (only the images of the
        contacts in ``subset``, (n,) bool, if given)."""
        f, s = self.fractions(transform, subset), self.s
        chosen = slice(None) if subset is None else subset
        # the face and prediction tests are the costly ones: asked only of a transform the shares pass
        return (f["consistent"] >= s.min_consistent and f["testable"] - f["consistent"] <= s.max_inconsistent
                and (f["share"] >= s.min_consistent_share or f["inconsistent_count"] <= s.consistency_exceptions)
                and f["outside"] <= s.max_outside
                and f["free"] <= min(self.free_allowance, self._free_limit(transform))
                and not self.face_conflicts(transform)[chosen].any()
                and not self._images_worse_predicted((self.points @ transform[0].T + transform[1])[chosen]))

    @cached_property
    def faces(self) -> ContactFaces:
        """The contacts' supporting flat faces (:func:`reconstruction.face_planes.supporting_contact_faces`)."""
        return supporting_contact_faces(self.points, self.normals)

    @cached_property
    def _wide_faces(self) -> tuple[np.ndarray, cKDTree | None]:
        """The contacts whose face is at least ``face_min_width_m`` wide, and a tree of those faces'
        centres (built once: every candidate that passes the other tests is checked)."""
        ids = np.flatnonzero(self.faces.fitted & (self.faces.widths_m >= self.s.face_min_width_m))
        return ids, (cKDTree(self.faces.centres[ids]) if len(ids) else None)

    def face_conflicts(self, transform: Transform) -> np.ndarray:
        """(n,) bool: contact i's supporting face (at least ``face_min_width_m`` wide), mapped, lands
        on another such face (centres within ``face_match_radius_m``, the mapped centre within the
        faces' flatness of its plane) facing the same side, and the two normals differ by more than
        ``face_conflict_rad`` beyond both faces' tilts and the turn their curvature allows over the
        centres' distance.

        A flat face touched at several places knows its normal to a few degrees, so a transform that
        turns one onto another by 20 deg is not a symmetry, however few contacts the face has: the
        plane halving a wedge's top and bottom maps those exactly and its tall end face 20 deg off
        onto itself, with most of the end face's images too far from a contact to be tested."""
        faces, s = self.faces, self.s
        conflicts = np.zeros(len(self.points), bool)
        ids, tree = self._wide_faces
        if len(ids) == 0:
            return conflicts
        m, t = transform
        mapped_centres, mapped_normals = faces.centres[ids] @ m.T + t, faces.normals[ids] @ m.T
        for a, near in enumerate(tree.query_ball_point(mapped_centres, s.face_match_radius_m)):
            if not near:
                continue
            i, near = ids[a], ids[np.asarray(near)]
            angle = np.arccos(np.clip(faces.normals[near] @ mapped_normals[a], -1.0, 1.0))
            offset = mapped_centres[a] - faces.centres[near]
            turn = np.maximum(faces.curvature_per_m[i], faces.curvature_per_m[near]) * np.linalg.norm(offset, axis=1)
            allowed = faces.tilt_rad[i] + faces.tilt_rad[near] + turn + s.face_conflict_rad
            # on the other face: not past a sharp edge beside it (a prism's face mirrored onto its
            # neighbour), nor on the far side of a thin wall
            on_face = np.abs(np.einsum("ij,ij->i", offset, faces.normals[near])) <= DEFAULT_FLATNESS_M
            conflicts[i] = bool(np.any(on_face & (angle < np.pi / 2) & (angle > allowed)))
        return conflicts

    def _free_limit(self, transform: Transform) -> float:
        """The free-space share allowed: half the typical one for a mirror containing the axis a
        feature refused (``feature_axis``: direction, point, limit), else no extra limit."""
        if self.feature_axis is None:
            return np.inf
        m, t = transform
        v, point, limit = self.feature_axis
        if np.linalg.det(m) > 0:
            return np.inf
        u = np.linalg.eigh(m)[1][:, 0]  # a mirror's normal: its eigenvector of eigenvalue -1
        offset = float(u @ t) / 2.0
        contains = abs(u @ v) < np.sin(np.radians(5.0)) and abs(u @ point - offset) < self.s.plane_tolerance_m * 2
        return limit if contains else np.inf


def _hemisphere(n: int) -> np.ndarray:
    """About ``n`` unit vectors evenly spread over the upper hemisphere (z >= 0), (k, 3)."""
    d = fibonacci_directions(2 * n)
    return d[d[:, 2] >= 0]


def _angles(u: np.ndarray) -> tuple[float, float]:
    return float(np.arccos(np.clip(u[2], -1.0, 1.0))), float(np.arctan2(u[1], u[0]))


def _unit(polar: float, azimuth: float) -> np.ndarray:
    return np.array([np.sin(polar) * np.cos(azimuth), np.sin(polar) * np.sin(azimuth), np.cos(polar)])


def _axis_through(points, normals, v):
    """The axis along ``v`` that the normal lines come nearest to meeting (reweighted least
    squares: a handle's contacts are outliers), and the median miss distance, metres."""
    v = v / np.linalg.norm(v)
    c = np.cross(normals, v)
    w = np.linalg.norm(c, axis=1)
    use = w > 0.2  # normals along the axis (a flat bottom) say nothing about where it is
    if use.sum() < 10:
        return None, np.inf
    e1, e2 = (w[0] for w in perpendicular_frame(v[None]))
    cu = c[use] / w[use, None]
    a = np.column_stack([cu @ e1, cu @ e2])
    b = np.einsum("ij,ij->i", points[use], cu)
    weights = np.ones(len(b))
    for _ in range(4):
        st, *_ = np.linalg.lstsq(a * weights[:, None], b * weights, rcond=None)
        miss = np.abs(a @ st - b)
        scale = max(1.5 * float(np.median(miss)), 2e-4)
        weights = 1.0 / np.maximum(miss / scale, 1.0)
    return st[0] * e1 + st[1] * e2, float(np.median(miss))


def _fit_axis(points, normals, directions: int = 400, starts: int = 5):
    """(direction, point) of the best-fitting axis of the normal lines, or (None, None)."""
    dirs = _hemisphere(directions)
    misses = np.array([_axis_through(points, normals, v)[1] for v in dirs])
    best = None
    for i in np.argsort(misses)[:starts]:
        if not np.isfinite(misses[i]):
            continue
        x0 = np.array(_angles(dirs[i]))
        res = minimize(lambda x: _axis_through(points, normals, _unit(*x))[1], x0, method="Nelder-Mead",
                       options=dict(xatol=1e-5, fatol=1e-7, maxiter=200,
                                    initial_simplex=[x0, x0 + [0.03, 0.0], x0 + [0.0, 0.03]]))
        v = _unit(*res.x)
        point, miss = _axis_through(points, normals, v)
        if point is not None and (best is None or miss < best[0]):
            best = (miss, v, point)
    return (None, None) if best is None else (best[1], best[2])


def _axis_search(v, point):
    """An axis near (``v``, ``point``) as four search parameters: the direction's polar and azimuth
    angles (radians) and the point's offsets across ``v`` (metres). Returns the start (4,),
    ``unpack(x) -> (direction, point)`` and ``simplex(x, (angle_step, offset_step))``, the
    Nelder-Mead start simplex (5 vertices)."""
    e1, e2 = (w[0] for w in perpendicular_frame(v[None]))

    def unpack(x):
        return _unit(x[0], x[1]), point + x[2] * e1 + x[3] * e2

    def simplex(x, step):
        return [x] + [x + np.eye(4)[i] * (step[0] if i < 2 else step[1]) for i in range(4)]

    return np.array([*_angles(v), 0.0, 0.0]), unpack, simplex


def _refine_axis(judge: _ImageJudge, v, point):
    """Refine the axis on the images of turns by 37, 90 and 180 deg, coarse then fine."""
    x, unpack, simplex = _axis_search(v, point)

    def score(x, tolerance):
        d, a = unpack(x)
        return -sum(judge.soft_score(rotation(d, a, np.radians(angle)), tolerance) for angle in (37.0, 90.0, 180.0))

    for tolerance, step in ((judge.s.plane_tolerance_m, (0.03, 0.002)), (judge.s.fine_tolerance_m, (0.01, 0.001))):
        x = minimize(score, x, args=(tolerance,), method="Nelder-Mead",
                     options=dict(xatol=1e-6, fatol=1e-6, maxiter=400, initial_simplex=simplex(x, step))).x
    return unpack(x)


def profile_misfit(points: np.ndarray, normals: np.ndarray, direction: np.ndarray, point: np.ndarray,
                   scale_m: float, neighbours: int = 8, radius_m: float = 0.008) -> float:
    """How far the contacts are from lying on one profile curve about an axis (mean Huber loss).

    About the axis of a surface of revolution every contact, whatever its azimuth, falls on the
    profile curve in the (height, radius) half-plane, and its normal lies in that half-plane. Each
    contact's residual is its distance from the line through its profile neighbours (at most
    ``neighbours`` within ``radius_m`` whose profile normals agree with its own within 30 deg, so
    a bowl's inside and outside stay apart), fitted by total least squares: positions decide, not
    the normals, which are the noisier.

    Parameters
    ----------
    points : (n, 3) float
        Contact positions, object frame, metres.
    normals : (n, 3) float
        Outward unit normals at the contacts.
    direction : (3,) float
        Unit direction of the axis.
    point : (3,) float
        A point of the axis, metres.
    scale_m : float
        Huber scale: residuals below it count quadratically, above it linearly.

    Returns
    -------
    float
        Mean of ``huber(residual / scale_m)`` over the contacts with at least three profile
        neighbours (inf if none has).
    """
    profile, profile_normal = _profile(points, normals, direction, point)
    residual = _profile_residuals(profile, profile_normal, profile, profile_normal, neighbours, radius_m, skip_self=True)
    return _mean_huber(residual, scale_m)


def _mean_huber(residual: np.ndarray, scale_m: float) -> float:
    """Mean Huber loss of the finite residuals (metres) at ``scale_m``; inf if none is finite."""
    r = residual[np.isfinite(residual)] / scale_m
    if not len(r):
        return float("inf")
    return float(np.mean(np.where(r < 1.0, 0.5 * r ** 2, r - 0.5)))


def _profile(points, normals, direction, point):
    """(n, 2) the contacts' (height along the axis, radius) and (n, 2) their unit normals in that
    half-plane, about the axis through ``point`` along ``direction``."""
    rel = points - point
    height = rel @ direction
    radial = rel - np.outer(height, direction)
    radius = np.linalg.norm(radial, axis=1)
    outward = radial / np.maximum(radius, 1e-12)[:, None]
    profile = np.column_stack([height, radius])
    profile_normal = np.column_stack([normals @ direction, np.einsum("ij,ij->i", normals, outward)])
    profile_normal /= np.maximum(np.linalg.norm(profile_normal, axis=1, keepdims=True), 1e-12)
    return profile, profile_normal


def _profile_residuals(query, query_normals, reference, reference_normals, neighbours: int, radius_m: float,
                       skip_self: bool) -> np.ndarray:
    """(m,) each query profile point's distance from the total-least-squares line through its
    reference neighbours (at most ``neighbours`` within ``radius_m`` whose normals agree within
    30 deg; ``skip_self``: the nearest, the point itself, is not one); NaN with fewer than three."""
    skip = int(skip_self)
    dist, idx = cKDTree(reference).query(query, k=neighbours + skip, distance_upper_bound=radius_m)
    dist, idx = dist[:, skip:], idx[:, skip:]
    near = np.isfinite(dist)
    idx = np.where(near, idx, 0)
    use = near & (np.einsum("ikj,ij->ik", reference_normals[idx], query_normals) > np.cos(np.radians(30.0)))
    count = use.sum(axis=1)
    centroid = (use[..., None] * reference[idx]).sum(axis=1) / np.maximum(count, 1)[:, None]
    d = reference[idx] - centroid[:, None, :]
    sxx, syy = (use * d[..., 0] ** 2).sum(axis=1), (use * d[..., 1] ** 2).sum(axis=1)
    sxy = (use * d[..., 0] * d[..., 1]).sum(axis=1)
    along = 0.5 * np.arctan2(2.0 * sxy, sxx - syy)  # the neighbours' principal direction
    off = query - centroid
    residual = np.abs(-np.sin(along) * off[:, 0] + np.cos(along) * off[:, 1])
    return np.where(count >= 3, residual, np.nan)


def _polish_axis(points, normals, v, point, settings: SymmetrySettings):
    """(direction, point) of the axis about which the contacts' profile is thinnest
    (:func:`profile_misfit`), searched from a refined axis (Nelder-Mead, one stage per residual
    scale of ``profile_scales_m``, coarse to fine), or that axis if its profile is thinner at the
    finest scale; None when not asked for (``profile_scales_m`` empty).

    The images' soft score that refines the axis is flat within a degree or two at 100-200
    contacts, so a bowl's accepted axis was 1-3 deg off and lost 0.2-0.65 mm; the profile uses
    every contact at every azimuth at once (BENCHMARKS.md, "An axis polished by its profile").
    From a refused axis far off, the polish can stop on a wrong axis that the turns then accept:
    :func:`_rescue_axis` polishes a refused one only with its safeguards."""
    if not settings.profile_scales_m:
        return None
    x, unpack, simplex = _axis_search(v, point)
    for k, scale in enumerate(settings.profile_scales_m):
        step = (0.05, 0.005) if k == 0 else (0.01, 0.001)
        x = minimize(lambda y: profile_misfit(points, normals, *unpack(y), scale), x, method="Nelder-Mead",
                     options=dict(xatol=1e-6, fatol=1e-8, maxiter=600, initial_simplex=simplex(x, step))).x
    fine = settings.profile_scales_m[-1]
    if profile_misfit(points, normals, *unpack(x), fine) > profile_misfit(points, normals, v, point, fine):
        return v, point  # the coarse stage moved it to a thicker profile
    return unpack(x)


def _rescue_axis(judge: _ImageJudge, v, point, settings: SymmetrySettings):
    """(direction, point) of an axis whose turns pass every test, polished from a refused one and
    from ``rescue_starts`` starts tilted ``rescue_tilt_rad`` about it, the thinnest profile of
    those accepted; None if none is (or ``rescue_starts`` is None).

    A plate's or a shallow bowl's normals pin its axis poorly, so the refined axis can be a few
    degrees off and refused; its profile pins it (BENCHMARKS.md, "A refused axis rescued by its
    profile"). The polish can also stop on a wrong axis that the turns accept, which
    :func:`_thinner` weighs against the mirror planes' axis."""
    if settings.rescue_starts is None or not settings.profile_scales_m:
        return None
    e1, e2 = (w[0] for w in perpendicular_frame(v[None]))
    starts = [v] + [np.cos(settings.rescue_tilt_rad) * v + np.sin(settings.rescue_tilt_rad)
                    * (np.cos(a) * e1 + np.sin(a) * e2)
                    for a in 2 * np.pi * np.arange(settings.rescue_starts) / max(settings.rescue_starts, 1)]
    fine = settings.profile_scales_m[-1]
    best = None
    for start in starts:
        axis = _polish_axis(judge.points, judge.normals, start, point, settings)
        misfit = profile_misfit(judge.points, judge.normals, *axis, fine)
        if (best is None or misfit < best[0]) and _turns_accepted(judge, *axis):
            best = (misfit, axis)
    return None if best is None else best[1]


def _polish_planes_axis(judge: _ImageJudge, v, point, settings: SymmetrySettings):
    """(direction, point) of the mirror planes' crossing axis polished by its profile, if its
    turns pass every test and its profile is thinner; else None (also when
    ``polish_planes_axis`` is None).

    Where the normal lines pin no axis (a bowl's flat floor and rim at 200 contacts put the fit
    30 deg off, and the rescue tilts only 2 deg about it), the axis comes from two mirror planes
    whose crossing is as far off as their offsets are loose: 1.4 deg, 1.2 mm on a bowl, 0.1 mm
    worse than the true axis (BENCHMARKS.md, "The mirror planes' axis polished by its profile")."""
    if not settings.polish_planes_axis:
        return None
    polished = _polish_axis(judge.points, judge.normals, v, point, settings)
    if polished is None or not _thinner(judge, polished, (v, point), settings):
        return None
    return polished if _turns_accepted(judge, *polished) else None


def _replaced(u, d, v, point, new_v, new_point) -> tuple[np.ndarray, float]:
    """The mirror plane ``u . x = d`` moved with its axis (``v`` through ``point``) onto the new
    axis: a plane through the axis turned to contain the new one, a plane across it turned to
    be perpendicular to it through the same point of the old axis, any other unchanged."""
    if abs(u @ v) < 0.05:
        w = u - (u @ new_v) * new_v
        w /= np.linalg.norm(w)
        return w, float(w @ new_point)
    if abs(u @ v) > 0.995:
        w = np.sign(u @ new_v) * new_v
        return w, float(w @ (point + (d - u @ point) * u))
    return u, d


def _thinner(judge: _ImageJudge, axis, other, settings: SymmetrySettings) -> bool:
    """Whether the contacts' profile about ``axis`` is thinner than about ``other`` (each
    (direction, point)), at the finest polishing scale."""
    fine = settings.profile_scales_m[-1]
    return profile_misfit(judge.points, judge.normals, *axis, fine) < profile_misfit(judge.points, judge.normals, *other, fine)


def _turns_accepted(judge: _ImageJudge, v, point) -> bool:
    """Whether the images of turns by 37 and 90 deg about the axis pass every test."""
    return all(judge.accepts(rotation(v, point, np.radians(a))) for a in (37.0, 90.0))


def _turns(v, point, settings: SymmetrySettings) -> list[Transform]:
    """The ``rotations - 1`` turns about the axis through ``point`` along ``v``, 360 / rotations apart."""
    return [rotation(v, point, 2 * np.pi * k / settings.rotations) for k in range(1, settings.rotations)]


def _revolution(judge: _ImageJudge, v, point, centre, settings: SymmetrySettings) -> Symmetry:
    """The turns about an accepted axis, and the mirror across it (top-bottom) if accepted."""
    group = _turns(v, point, settings)
    d0 = float(v @ centre)
    res = minimize(lambda x: -judge.soft_score(reflection(v, x[0])), [d0], method="Nelder-Mead",
                   options=dict(xatol=1e-5, initial_simplex=[[d0], [d0 + 0.003]]))
    offsets = [float(res.x[0])]
    if settings.mirror_by_profile and settings.profile_scales_m:
        polished = _mirror_offset(judge.points, judge.normals, v, point, offsets[0], settings.profile_scales_m[-1])
        if polished != offsets[0]:
            offsets.insert(0, polished)  # the profile's offset if accepted, else the score's
    offset = next((d for d in offsets if judge.accepts(reflection(v, d))), None)
    if offset is None:
        return Symmetry(tuple(group), (), (point, v))
    m, t = across = reflection(v, offset)
    mirrored = [across] + [(m @ r, m @ s + t) for r, s in group]
    planes = ((v, offset),)
    feature = _feature_of_mirror(judge, v, point, offset, settings)
    if feature is None:
        return Symmetry(tuple(group + mirrored), planes, (point, v))
    return Symmetry(tuple(group), planes, (point, v), body_transforms=tuple(mirrored),
                    feature_points=judge.points[feature], feature_radius_m=settings.feature_radius_m)


def _mirror_offset(points, normals, v, point, offset: float, scale_m: float, reach_m: float = 0.003) -> float:
    """The offset ``d`` of the plane ``v . x = d`` across an axis of revolution (through ``point``
    along ``v``) that maps the contacts' profile onto itself best, searched within ``reach_m`` of
    ``offset`` (a 0.1 mm grid, then Brent's method about its best), metres; ``offset`` itself if
    no offset searched fits better.

    The images' soft score that finds the plane is flat within a millimetre, and a lemon's plane
    0.6 mm off put its images 1.2 mm off at the tips (BENCHMARKS.md, "A refused axis rescued by
    its profile, and the mirror across an axis that leaves a stem out"); the profile, every
    contact at every azimuth, pins it."""
    def misfit(d):
        return _mean_huber(_mirrored_profile_residuals(points, normals, v, point, d), scale_m)

    grid = offset + np.arange(-reach_m, reach_m + 1e-9, 1e-4)
    best = float(grid[int(np.argmin([misfit(d) for d in grid]))])
    found = minimize_scalar(misfit, bounds=(best - 1e-4, best + 1e-4), method="bounded", options=dict(xatol=1e-6))
    candidate = float(found.x) if found.fun < misfit(best) else best
    return candidate if misfit(candidate) < misfit(offset) else offset


def _mirrored_profile_residuals(points, normals, v, point, offset: float) -> np.ndarray:
    """(n,) each contact's profile point mirrored across the plane ``v . x = offset``: its distance
    from the contacts' profile about the axis through ``point`` along ``v``, metres
    (:func:`_profile_residuals`; NaN where fewer than three contacts are near)."""
    profile, profile_normal = _profile(points, normals, v, point)
    height = offset - v @ point
    mirrored = np.column_stack([2.0 * height - profile[:, 0], profile[:, 1]])
    return _profile_residuals(mirrored, profile_normal * [-1.0, 1.0], profile, profile_normal, 8, 0.008, False)


def _feature_of_mirror(judge: _ImageJudge, v, point, offset: float, settings: SymmetrySettings) -> np.ndarray | None:
    """(n,) bool: the contacts an accepted mirror across an axis of revolution must leave out, or
    None if it holds for all of them.

    An apple is nearly mirror-symmetric top to bottom but for its stem: the stem's few contacts
    pass the acceptance's shares, and their images grow a phantom stem under the bottom
    (BENCHMARKS.md, "A refused axis rescued by its profile, and the mirror across an axis that
    leaves a stem out"). The feature is the contacts whose mirrored profile points lie more than
    ``plane_tolerance_m`` off the profile or whose images the GPIS puts that deep in free space or
    solid (and ``free_confidence`` standard deviations; the judge's *free* asks ``free_depth_m``,
    which a stem's root mirrored just under the bottom does not reach), and those within
    ``feature_radius_m`` of them, when at most ``max_feature_share`` of the contacts; None when
    there are none or more (or ``max_feature_share`` is None, or ``mirror_by_profile`` False)."""
    if not settings.mirror_by_profile or settings.max_feature_share is None or judge.gpis is None:
        return None
    m, t = reflection(v, offset)
    lo, hi = judge.gpis.region
    free = judge._in_free_space(np.clip(judge.points @ m.T + t, lo, hi), depth_m=settings.plane_tolerance_m)
    free |= _mirrored_profile_residuals(judge.points, judge.normals, v, point, offset) > settings.plane_tolerance_m
    if not free.any():
        return None
    feature = Symmetry(feature_points=judge.points[free], feature_radius_m=settings.feature_radius_m).in_feature(judge.points)
    return feature if feature.mean() <= settings.max_feature_share else None


def _feature_of_revolution(judge: _ImageJudge, v, point, settings: SymmetrySettings) -> np.ndarray | None:
    """(n,) bool: the contacts of a feature that alone refused the axis, or None.

    Asked only when the planes through the axis typically put more than ``max_free`` of the images
    in free space (a feature refused it; a near symmetry's axis, a prism's or a blob's, is refused
    by inconsistent or worse-predicted images instead). A mug's handle turned about its cup's axis
    lands in free space, so the axis is refused although it holds for the rest of the mug; the
    cup's opening, where nothing can be touched, is then left to the plain GPIS, which may close it
    with a dome. The feature is the contacts whose images under the acceptance's turns (37 and
    90 deg) or the turns the images copy (``rotations``) are in free space, beyond the sag, or
    testable and inconsistent, and the contacts within ``feature_radius_m`` of those; the axis
    holds for the rest when the feature is at most ``max_feature_share`` of the contacts and the
    images of the others pass every test (:meth:`_ImageJudge.accepts`)."""
    if settings.max_feature_share is None:
        return None
    turns = [rotation(v, point, np.radians(a)) for a in (37.0, 90.0)]
    refused = np.zeros(len(judge.points), bool)
    for turn in turns + _turns(v, point, settings):
        verdict = judge.verdicts(turn)
        refused |= verdict["free"] | verdict["outside"] | (verdict["testable"] & ~verdict["consistent"])
    grown = Symmetry(feature_points=judge.points[refused], feature_radius_m=settings.feature_radius_m)
    feature = grown.in_feature(judge.points)
    if not feature.any() or feature.mean() > settings.max_feature_share:
        return None
    body = ~feature
    return feature if all(judge.accepts(turn, body) for turn in turns) else None


def _planes_through_axis(judge: _ImageJudge, v, point, settings: SymmetrySettings):
    """The best ``axis_starts`` planes (unit normal, offset) containing a refused axis of
    revolution, of the planes through it every 2 deg, and the median share of their images in free
    space or solid.

    A body of revolution with a feature (a mug's handle, a jug's spout) has every plane through
    its axis as a near-mirror; only the one through the feature is a mirror. The search's score
    sees the feature's few images only where the plane is already right, so the planes through the
    axis are scored one by one and the best become starts."""
    e1, e2 = (w[0] for w in perpendicular_frame(v[None]))
    candidates = []
    for angle in np.radians(np.arange(0.0, 180.0, 2.0)):
        u = np.cos(angle) * e1 + np.sin(angle) * e2
        f = judge.fractions(reflection(u, float(u @ point)))  # exact: the feature's images are few
        score = f["consistent"] - 2.0 * (f["testable"] - f["consistent"]) - f["outside"] - 4.0 * f["free"]
        candidates.append((score, u, float(u @ point), f["free"]))
    candidates.sort(key=lambda c: -c[0])
    return [(u, d) for _, u, d, _ in candidates[:settings.axis_starts]], float(np.median([c[3] for c in candidates]))


def _mirror_planes(judge: _ImageJudge, centre, settings: SymmetrySettings,
                   extra_starts: list[tuple[np.ndarray, float]] = ()) -> list[tuple[np.ndarray, float]]:
    """Accepted mirror planes (unit normal, offset), at most three, at least 80 deg apart;
    ``extra_starts`` (unit normal, offset) are refined first."""
    dirs = _hemisphere(settings.directions)
    scores = np.array([judge.soft_score(reflection(u, u @ centre), settings.coarse_tolerance_m) for u in dirs])
    starts: list[int] = []
    for i in np.argsort(-scores):  # the best directions, 15 deg apart: one plane does not take every start
        if all(abs(dirs[i] @ dirs[j]) < np.cos(np.radians(15.0)) for j in starts):
            starts.append(int(i))
        if len(starts) == settings.starts:
            break
    found: list[tuple[np.ndarray, float]] = []
    initial = [(u if u[2] >= 0 else -u, d if u[2] >= 0 else -d) for u, d in extra_starts]
    for u0, d0 in initial + [(dirs[i], float(dirs[i] @ centre)) for i in starts]:
        x = np.array([*_angles(u0), d0])
        for tolerance, step in ((settings.coarse_tolerance_m, (0.05, 0.003)), (settings.plane_tolerance_m, (0.02, 0.002)),
                                (settings.fine_tolerance_m, (0.01, 0.001))):
            simplex = [x, x + [step[0], 0, 0], x + [0, step[0], 0], x + [0, 0, step[1]]]
            x = minimize(lambda y: -judge.soft_score(reflection(_unit(y[0], y[1]), y[2]), tolerance), x,
                         method="Nelder-Mead", options=dict(xatol=1e-5, fatol=1e-5, maxiter=300,
                                                            initial_simplex=simplex)).x
        u, d = _unit(x[0], x[1]), float(x[2])
        if u[2] < 0:
            u, d = -u, -d
        if any(abs(u @ w) > np.cos(np.radians(10.0)) for w, _ in found):
            continue
        if judge.accepts(reflection(u, d)) and all(abs(u @ w) < np.cos(np.radians(80.0)) for w, _ in found):
            found.append((u, d))
    return found[:3]
