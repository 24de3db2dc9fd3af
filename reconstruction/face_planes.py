"""Supporting face planes: flat faces of the contacts that no contact lies in front of (issue 10).

One measured normal is off by 7 deg on average (the sensor; more on steep surfaces), so a single
contact's tangent plane says little tens of millimetres away: the outside evidence allows each plane
a 15 deg tilt (:mod:`reconstruction.outside_evidence`). A flat face touched at several places is
known far better. Contacts within ``radius_m`` of a contact whose normals agree with its own and
that lie within ``flatness_m`` of its tangent plane are one face; a plane fitted through at least
``min_contacts`` of them (least squares, spanning an area, not a line) tilts by about their
position noise over the patch's span: about 1 deg for sampled contacts, 0.2 mm along the normal
over 20 mm.

Such a plane is *supporting* when no contact at all lies in front of it by more than ``margin_m``
plus ``sin(tolerance_rad)`` times its distance from the face. A convex object lies behind each of
its supporting planes, so space in front of one is free: past a sharp corner of a wedge or a prism,
beyond a flat bottom. A concave face is not supporting (a tray's floor has its walls in front of
it), nor is a face of one part of a non-convex object that has a touched part in front of it (one
arm of an L). A curved surface gives a plane only where several contacts crowd into the narrow
patch of it that stays within ``flatness_m`` of one tangent plane (12 mm across on a sphere of 50
mm radius, a strip along a cylinder's side). Such a plane can tilt by up to ``flatness_m`` over the
patch's half width where the contacts lie unevenly across it, so each plane's tilt allowance is at
least that: a narrow patch frees little.

:func:`supporting_contact_faces` gives each contact its supporting face with how well the face's
normal is known (its tilt and a bound on the curvature its departure from flat allows): the
symmetry search refuses a transform that turns one such face onto another
(:mod:`reconstruction.symmetry`).

:func:`whole_face_planes` grows each supporting patch to the whole face: every contact within
``flatness_m`` of its plane whose normal agrees, refitted. A face touched 20-40 times over 5-10 cm
knows its normal to a fraction of a degree, where a 25 mm patch allows 5-17 deg, so its plane says
where the object ends far along the face: past a wedge's corners and a prism's edges, where a
smooth GPIS rounds a lobe 3-8 mm out of the object between the faces (BENCHMARKS.md, issue 10).
``GPIS.mesh`` cuts its surface at them (:meth:`FacePlanes.clearance`). The planes of the contacts'
convex hull facets are grown too: a thin rim's top holds a few contacts far apart around the rim,
too sparse for any patch, and five of them spread 15 mm RMS or more across both directions are a
face (a curved surface spreads that wide within the normals' agreement only where it is too far
from flat to pass), so the field the walls carry up past the rim is cut at it.

Written here rather than taken from a library: a statement about measured contacts and normals,
not a mesh operation.
"""
from __future__ import annotations

from dataclasses import dataclass

import numpy as np

from reconstruction.synthetic_contacts import ContactNoise

#: Contacts within this distance of a contact can be on its face, metres ...
DEFAULT_FACE_RADIUS_M = 0.025
#: ... when their normals lie within this angle of its own, radians ...
DEFAULT_FACE_ANGLE_RAD = float(np.radians(20.0))
#: ... and they lie within this distance of its tangent plane (and of the fitted plane), metres.
DEFAULT_FLATNESS_M = 1.5e-3
#: A face is fitted through at least this many contacts.
DEFAULT_MIN_CONTACTS = 4
#: The fitted plane's tilt allowed for its error, radians.
DEFAULT_FACE_TOLERANCE_RAD = float(np.radians(5.0))
#: In front of a plane means by more than this plus the tilt's share of the distance, metres (above
#: ``DEFAULT_FLATNESS_M``: a gently curved face may bulge that far in front of its fitted plane).
DEFAULT_FACE_MARGIN_M = 2.0e-3
#: A patch whose second principal spread is below this fraction of its first is a line: its tilt
#: about that line is not known.
_MIN_SPREAD_RATIO = 0.3
_CHUNK = 2000


@dataclass(frozen=True)
class FacePlanes:
    """Fitted face planes, object frame.

    Attributes
    ----------
    centres : (m, 3) float
        A point on each plane (the centroid of its face's contacts), metres.
    normals : (m, 3) float
        Each plane's outward unit normal.
    margin_m : float or (m,) float
        What "in front of" means (:meth:`in_front`), metres, for every plane or each.
    tolerance_rad : float or (m,) float
        Each plane's tilt allowed for its error, radians.
    reach_m : float or (m,) float
        How far from its centre each plane holds, metres: nothing lies in front of a plane farther
        away (inf: everywhere).
    """

    centres: np.ndarray
    normals: np.ndarray
    margin_m: float | np.ndarray = DEFAULT_FACE_MARGIN_M
    tolerance_rad: float | np.ndarray = DEFAULT_FACE_TOLERANCE_RAD
    reach_m: float | np.ndarray = np.inf

    def __len__(self) -> int:
        return len(self.centres)

    def in_front(self, points: np.ndarray) -> np.ndarray:
        """(k,) bool: whether each point lies in front of some plane by more than ``margin_m`` plus
        ``sin`` of that plane's tolerance times its distance from the plane's centre, within the
        plane's reach.

        Parameters
        ----------
        points : (k, 3) float, metres
        """
        return self.in_front_of_each(points).any(axis=1)

    def in_front_of_each(self, points: np.ndarray) -> np.ndarray:
        """(k, m) bool: whether each point lies in front of each plane (see :meth:`in_front`)."""
        points = np.asarray(points, float).reshape(-1, 3)
        if not len(self) or not len(points):
            return np.zeros((len(points), len(self)), bool)
        return np.concatenate([self._clearances(x) < 0
                               for x in (points[s:s + _CHUNK] for s in range(0, len(points), _CHUNK))])

    def clearance(self, points: np.ndarray) -> np.ndarray:
        """(k,) float, metres: how far each point may still move out before it lies in front of a
        plane (its allowance there minus its distance ahead of the plane, the least over the
        planes); negative in front of one, +inf without planes. Its 0-level set is the boundary of
        the space the planes leave: ``min(f, clearance)`` cuts a field ``f`` (positive inside) at it.

        Parameters
        ----------
        points : (k, 3) float, metres
        """
        points = np.asarray(points, float).reshape(-1, 3)
        if not len(self):
            return np.full(len(points), np.inf)
        if not len(points):
            return np.zeros(0)
        return np.concatenate([self._clearances(x).min(axis=1)
                               for x in (points[s:s + _CHUNK] for s in range(0, len(points), _CHUNK))])

    def margins_array(self) -> np.ndarray:
        """(m,) float: each plane's margin, metres."""
        return np.broadcast_to(np.asarray(self.margin_m, float), (len(self),)).copy()

    def _clearances(self, x: np.ndarray) -> np.ndarray:
        """(k, m): allowance minus the distance ahead, per point and plane (inf beyond its reach)."""
        from scipy.spatial.distance import cdist

        offsets = np.einsum("ij,ij->i", self.centres, self.normals)
        sine = np.broadcast_to(np.sin(np.asarray(self.tolerance_rad, float)), (len(self),))
        margin = np.broadcast_to(np.asarray(self.margin_m, float), (len(self),))
        distance = cdist(x, self.centres)
        clearance = margin + sine * distance - (x @ self.normals.T - offsets)
        return np.where(distance <= np.asarray(self.reach_m, float), clearance, np.inf)


def supporting_face_planes(contacts: np.ndarray, normals: np.ndarray, radius_m: float = DEFAULT_FACE_RADIUS_M,
                           angle_rad: float = DEFAULT_FACE_ANGLE_RAD, flatness_m: float = DEFAULT_FLATNESS_M,
                           min_contacts: int = DEFAULT_MIN_CONTACTS,
                           tolerance_rad: float = DEFAULT_FACE_TOLERANCE_RAD,
                           margin_m: float = DEFAULT_FACE_MARGIN_M) -> FacePlanes:
    """The supporting face planes of contacts (module docstring): one per contact whose face could be
    fitted and that no contact lies in front of.

    Parameters
    ----------
    contacts : (n, 3) float, object frame, metres
    normals : (n, 3) float, outward unit normals
    radius_m, angle_rad, flatness_m, min_contacts : float, float, float, int
        What makes contacts one face.
    tolerance_rad, margin_m : float
        What "in front of" means, both for the support test and for :meth:`FacePlanes.in_front`:
        ``tolerance_rad`` is each plane's smallest tilt allowance; a narrow patch gets
        ``arctan(2 flatness_m / width)``, its width across its second principal direction.
    """
    for name, value in (("radius_m", radius_m), ("flatness_m", flatness_m), ("margin_m", margin_m)):
        if not (np.isfinite(value) and value > 0):
            raise ValueError(f"{name} must be a positive length, got {value!r}")
    for name, value in (("angle_rad", angle_rad), ("tolerance_rad", tolerance_rad)):
        if not (0 <= value < np.pi / 2):
            raise ValueError(f"{name} must be an angle in [0, pi / 2), got {value!r}")
    if not (isinstance(min_contacts, (int, np.integer)) and min_contacts >= 3):
        raise ValueError(f"min_contacts must be a count >= 3 (a plane needs three), got {min_contacts!r}")
    contacts = np.asarray(contacts, float).reshape(-1, 3)
    normals = np.asarray(normals, float).reshape(-1, 3)
    if normals.shape != contacts.shape:
        raise ValueError(f"normals must be one per contact, shape {contacts.shape}, got {normals.shape}")
    empty = FacePlanes(np.zeros((0, 3)), np.zeros((0, 3)), margin_m, np.zeros(0))
    if len(contacts) < min_contacts:
        return empty
    faces = _fitted_faces(contacts, normals, radius_m, angle_rad, flatness_m, min_contacts)
    kept = np.flatnonzero(faces.fitted)
    kept = kept[_supporting(faces.centres[kept], faces.normals[kept], contacts, margin_m, tolerance_rad)]
    if not len(kept):
        return empty
    # a curved patch's least-squares plane tilts by up to its departure from flat over its half
    # width (on a cylinder's side, towards the axis where the contacts lie unevenly): this plane
    # frees space in front of it, so it is allowed the whole flatness
    tilts = np.maximum(tolerance_rad, np.arctan2(2.0 * flatness_m, faces.widths_m[kept]))
    return FacePlanes(faces.centres[kept], faces.normals[kept], margin_m, tilts)


def _supporting(centres, normals, contacts, margin_m, tolerance_rad) -> np.ndarray:
    """(m,) bool: no contact lies in front of each plane, judged with the smallest allowance, so that
    a narrow patch's larger one (which frees less in front of it) does not also let contacts in
    front of it pass."""
    return ~FacePlanes(centres, normals, margin_m, tolerance_rad).in_front_of_each(contacts).any(axis=0)


@dataclass(frozen=True)
class ContactFaces:
    """The flat face each contact lies on, where one could be fitted (object frame).

    Attributes
    ----------
    fitted : (n,) bool
        Whether contact i's face was fitted (see :func:`supporting_face_planes`) and is supporting.
    centres : (n, 3) float
        The centroid of each face's contacts, metres (the contact itself where none was fitted).
    normals : (n, 3) float
        Each face's fitted outward unit normal (the contact's own where none was fitted).
    widths_m : (n,) float
        Each face's extent across its second principal direction, metres (0 where none).
    tilt_rad : (n,) float
        How far the fitted normal may be off the surface's normal at the centre: the face's largest
        departure from its plane over its half width, at least ``min_tilt_rad`` (inf where none).
    curvature_per_m : (n,) float
        The largest curvature the face's departure allows, 16 departure / width^2 (the departure at
        least ``position_noise_m``), 1 / metres: how fast the normal may turn away from the centre.
        A disc of width w on a sphere of radius R departs from its least-squares plane by
        w^2 / (16 R) at most (the centre and the rim), a strip across a cylinder by w^2 / (12 R).
    """

    fitted: np.ndarray
    centres: np.ndarray
    normals: np.ndarray
    widths_m: np.ndarray
    tilt_rad: np.ndarray
    curvature_per_m: np.ndarray


#: A fitted face's normal is known to no better than this, radians ...
DEFAULT_MIN_FACE_TILT_RAD = float(np.radians(2.0))
#: ... and its departure from flat to no better than the contacts' position noise, metres.
DEFAULT_FACE_POSITION_NOISE_M = 0.2e-3


def supporting_contact_faces(contacts: np.ndarray, normals: np.ndarray,
                             min_tilt_rad: float = DEFAULT_MIN_FACE_TILT_RAD,
                             position_noise_m: float = DEFAULT_FACE_POSITION_NOISE_M) -> ContactFaces:
    """Each contact's supporting face (:func:`supporting_face_planes`, the default face
    parameters), with how well its normal is known: a flat face touched at several places has a
    normal known to a few degrees, where one contact's is off by 7 deg on average.

    Parameters
    ----------
    contacts : (n, 3) float, object frame, metres
    normals : (n, 3) float, outward unit normals
    min_tilt_rad, position_noise_m : float
        Floors of each face's tilt and departure (:class:`ContactFaces`).
    """
    contacts = np.asarray(contacts, float).reshape(-1, 3)
    normals = np.asarray(normals, float).reshape(-1, 3)
    if normals.shape != contacts.shape:
        raise ValueError(f"normals must be one per contact, shape {contacts.shape}, got {normals.shape}")
    faces = _fitted_faces(contacts, normals, DEFAULT_FACE_RADIUS_M, DEFAULT_FACE_ANGLE_RAD,
                          DEFAULT_FLATNESS_M, DEFAULT_MIN_CONTACTS)
    fitted = faces.fitted.copy()
    ids = np.flatnonzero(fitted)
    fitted[ids] = _supporting(faces.centres[ids], faces.normals[ids], contacts, DEFAULT_FACE_MARGIN_M,
                              DEFAULT_FACE_TOLERANCE_RAD)
    widths = np.where(fitted, faces.widths_m, 0.0)
    with np.errstate(divide="ignore"):
        tilt = np.where(fitted, np.maximum(min_tilt_rad, np.arctan2(2.0 * faces.departures_m, widths)), np.inf)
        curvature = np.where(fitted, 16.0 * np.maximum(faces.departures_m, position_noise_m) / np.maximum(widths, 1e-9) ** 2,
                             np.inf)
    return ContactFaces(fitted, faces.centres, faces.normals, widths, tilt, curvature)


@dataclass(frozen=True)
class _Faces:
    fitted: np.ndarray
    centres: np.ndarray
    normals: np.ndarray
    widths_m: np.ndarray
    departures_m: np.ndarray


def _fitted_faces(contacts, normals, radius_m, angle_rad, flatness_m, min_contacts) -> _Faces:
    """Each contact's face (the contacts within ``radius_m`` whose normals agree with its own and that
    lie within ``flatness_m`` of its tangent plane), fitted by least squares where it has at least
    ``min_contacts`` contacts spanning an area and stays within ``flatness_m`` of its plane."""
    from scipy.spatial import cKDTree

    n = len(contacts)
    fitted, centres, fitted_normals = np.zeros(n, bool), contacts.copy(), normals.copy()
    widths, departures = np.zeros(n), np.zeros(n)
    if n < min_contacts:
        return _Faces(fitted, centres, fitted_normals, widths, departures)
    cosine = np.cos(angle_rad)
    for i, near in enumerate(cKDTree(contacts).query_ball_point(contacts, radius_m)):
        near = np.asarray(near)
        face = near[(normals[near] @ normals[i] > cosine)
                    & (np.abs((contacts[near] - contacts[i]) @ normals[i]) < flatness_m)]
        if len(face) < min_contacts:
            continue
        centre = contacts[face].mean(axis=0)
        _, spread, axes = np.linalg.svd(contacts[face] - centre, full_matrices=False)
        if spread[1] < _MIN_SPREAD_RATIO * spread[0]:
            continue
        normal = axes[2] * np.sign(axes[2] @ normals[i])
        departure = float(np.max(np.abs((contacts[face] - centre) @ normal)))
        if departure > flatness_m:
            continue
        fitted[i], centres[i], fitted_normals[i] = True, centre, normal
        widths[i], departures[i] = float(np.ptp((contacts[face] - centre) @ axes[1])), departure
    return _Faces(fitted, centres, fitted_normals, widths, departures)


#: A whole face's tilt allowance is this many standard errors of its fitted normal ...
DEFAULT_WHOLE_FACE_SIGMAS = 3.0
#: ... and at least this, radians.
DEFAULT_MIN_WHOLE_FACE_TILT_RAD = float(np.radians(0.5))
#: A whole face's margin is its contacts' largest departure from its plane plus this, metres ...
DEFAULT_WHOLE_FACE_MARGIN_EXTRA_M = 0.4e-3
#: ... and at least this, metres.
DEFAULT_MIN_WHOLE_FACE_MARGIN_M = 0.7e-3
#: A whole face is flat: its contacts depart from its plane by at most this RMS, metres (a curved
#: surface's strip within the flatness departs more, and its plane does not hold far along it).
DEFAULT_MAX_WHOLE_FACE_RMS_M = 0.3e-3
#: A whole face has at least this many contacts: through a few contacts of a curved surface a
#: plane can be a secant of a circle through them that tilts 5-6 deg off the surface there, with
#: their departures no larger than a flat face's noise (a sphere of 100 mm radius, 5-7 contacts).
DEFAULT_MIN_WHOLE_FACE_CONTACTS = 10
#: ... or this many when they spread wide in both directions (``DEFAULT_WIDE_FACE_SPREAD_M``): a
#: thin rim's top, a few contacts far apart. Within the faces' 20 deg normal agreement a curved
#: surface spreads that wide only with a radius over 17 cm, and departs from a plane by more than
#: the flatness there, so few contacts that wide and that close to one plane are a flat face.
DEFAULT_MIN_WIDE_FACE_CONTACTS = 5
#: RMS spread across a face's narrower principal direction that makes it wide, metres.
DEFAULT_WIDE_FACE_SPREAD_M = 15.0e-3
#: A whole face's fitted normal lies within this many standard errors of its contacts' mean
#: measured normal (and within 2 deg at least): a plane through a line of contacts and one far
#: off it (a lid's top and its knob) fits them closely, but tilted off what they all measured.
DEFAULT_NORMAL_AGREEMENT_SIGMAS = 3.0
#: One measured normal's error per tangent axis, radians: the sampled sensor's mean angle
#: (``ContactNoise``, 7 deg) is sigma sqrt(pi / 2) of a Rayleigh distribution.
DEFAULT_NORMAL_ERROR_STD_RAD = float(np.radians(ContactNoise().normal_error_mean_deg) / np.sqrt(np.pi / 2))
#: A whole face's measured normals do not splay out from (or in to) its plane's normal by more than
#: this many standard errors of their mean splay: on a curved surface they do, and a plane through a
#: zone of a sphere fits its contacts as closely as a flat face's (see :func:`_splayed`).
DEFAULT_SPLAY_SIGMAS = 2.5
#: A whole face's plane holds this far beyond its farthest contact from its centre, metres: past its
#: edges and corners, not across the object (a small patch's plane says nothing of a foot ring or a
#: stem 3-4 cm away, which the smooth surface between may put in front of it).
DEFAULT_WHOLE_FACE_REACH_M = 10.0e-3
#: A whole face stays supporting with one contact in front of it whose normal lies more than this
#: from the face's (a contact of the neighbouring face, smeared past the shared edge), radians ...
DEFAULT_FORGIVEN_ANGLE_RAD = float(np.radians(60.0))
#: ... by no more than this beyond the face's allowance, metres.
DEFAULT_FORGIVEN_DEPTH_M = 3.0e-3


def whole_face_planes(contacts: np.ndarray, normals: np.ndarray, angle_rad: float = DEFAULT_FACE_ANGLE_RAD,
                      flatness_m: float = DEFAULT_FLATNESS_M, min_contacts: int = DEFAULT_MIN_CONTACTS,
                      sigmas: float = DEFAULT_WHOLE_FACE_SIGMAS,
                      min_tilt_rad: float = DEFAULT_MIN_WHOLE_FACE_TILT_RAD,
                      margin_extra_m: float = DEFAULT_WHOLE_FACE_MARGIN_EXTRA_M,
                      min_margin_m: float = DEFAULT_MIN_WHOLE_FACE_MARGIN_M,
                      forgiven_angle_rad: float = DEFAULT_FORGIVEN_ANGLE_RAD,
                      forgiven_depth_m: float = DEFAULT_FORGIVEN_DEPTH_M,
                      position_noise_m: float = DEFAULT_FACE_POSITION_NOISE_M,
                      max_rms_m: float = DEFAULT_MAX_WHOLE_FACE_RMS_M,
                      reach_m: float = DEFAULT_WHOLE_FACE_REACH_M,
                      min_face_contacts: int = DEFAULT_MIN_WHOLE_FACE_CONTACTS,
                      splay_sigmas: float = DEFAULT_SPLAY_SIGMAS,
                      min_wide_face_contacts: int = DEFAULT_MIN_WIDE_FACE_CONTACTS,
                      wide_spread_m: float = DEFAULT_WIDE_FACE_SPREAD_M,
                      hull_seeds: bool = True,
                      normal_agreement_sigmas: float = DEFAULT_NORMAL_AGREEMENT_SIGMAS,
                      normal_error_std_rad: float = DEFAULT_NORMAL_ERROR_STD_RAD) -> FacePlanes:
    """The contacts' supporting patches (:func:`supporting_face_planes`) grown to whole flat faces.

    Each patch's plane takes every contact within ``flatness_m`` of it whose normal lies within
    ``angle_rad`` of its normal, and is refitted through them (three times, or until fewer than
    ``min_contacts`` remain); patches that grow to the same contacts give one face. With
    ``hull_seeds`` the planes of the contacts' convex hull facets are grown too: a face whose
    contacts lie too far apart for a patch (a thin rim's top) is found from them. A face is flat
    when it has at least ``min_face_contacts`` contacts (``min_wide_face_contacts`` when their RMS
    spread across its narrower principal direction is at least ``wide_spread_m``, and half that with
    any one of them left out), a fitted normal
    within ``normal_agreement_sigmas`` standard errors (``normal_error_std_rad / sqrt(k)``, at
    least 2 deg) of their mean measured normal, departing from its plane by at most
    ``max_rms_m`` RMS and its measured normals do not splay (:func:`_splayed`, ``splay_sigmas``):
    a curved surface's strip within the flatness, or a zone of a sphere through a few contacts, is
    not a face. Its tilt allowance is ``sigmas`` standard errors of its fitted normal,
    ``rms / (spread sqrt(k))`` for ``k`` contacts of RMS departure ``rms`` (at least
    ``position_noise_m``) spread ``spread`` (RMS) across its narrower principal direction, and at
    least ``min_tilt_rad``; its margin is its contacts' largest departure plus ``margin_extra_m``,
    at least ``min_margin_m``; its reach is its farthest contact from its centre plus ``reach_m``.

    A face is kept when no contact within its reach lies in front of it beyond that allowance,
    except for at most one whose normal lies more than ``forgiven_angle_rad`` from the face's and
    that lies no more than ``forgiven_depth_m`` beyond it: near a sharp edge a contact of the
    neighbouring face smeared along its surface past the edge (the sampled contacts' 1 mm) lies in
    front of this face's plane; a part of the object in front of the face is touched more than
    once, or on a face that faces the same way.

    Parameters
    ----------
    contacts : (n, 3) float, object frame, metres
    normals : (n, 3) float, outward unit normals

    Returns
    -------
    FacePlanes
        One plane per whole face, with per-face ``margin_m``, ``tolerance_rad`` and ``reach_m``
        arrays (none: empty).
    """
    contacts = np.asarray(contacts, float).reshape(-1, 3)
    normals = np.asarray(normals, float).reshape(-1, 3)
    if normals.shape != contacts.shape:
        raise ValueError(f"normals must be one per contact, shape {contacts.shape}, got {normals.shape}")
    for name, value in (("sigmas", sigmas), ("margin_extra_m", margin_extra_m), ("min_margin_m", min_margin_m),
                        ("forgiven_depth_m", forgiven_depth_m), ("position_noise_m", position_noise_m),
                        ("wide_spread_m", wide_spread_m), ("normal_error_std_rad", normal_error_std_rad)):
        if not (np.isfinite(value) and value >= 0):
            raise ValueError(f"{name} must be a finite number >= 0, got {value!r}")
    if not normal_agreement_sigmas >= 0:
        raise ValueError(f"normal_agreement_sigmas must be >= 0 (inf: no check), got {normal_agreement_sigmas!r}")
    for name, value in (("min_tilt_rad", min_tilt_rad), ("forgiven_angle_rad", forgiven_angle_rad)):
        if not (0 <= value < np.pi):
            raise ValueError(f"{name} must be an angle in [0, pi), got {value!r}")
    empty = FacePlanes(np.zeros((0, 3)), np.zeros((0, 3)), np.zeros(0), np.zeros(0), np.zeros(0))
    patches = supporting_face_planes(contacts, normals, angle_rad=angle_rad, flatness_m=flatness_m,
                                     min_contacts=min_contacts)
    seeds = [(patches.centres, patches.normals)]
    if hull_seeds:
        seeds.append(_hull_facet_planes(contacts))
    cosine = np.cos(angle_rad)
    seen: set[bytes] = set()
    centres, face_normals, tilts, margins, reaches = [], [], [], [], []
    for centre, normal in ((c, n) for seed_centres, seed_normals in seeds for c, n in zip(seed_centres, seed_normals)):
        members = None
        for _ in range(3):
            on = (np.abs((contacts - centre) @ normal) < flatness_m) & (normals @ normal > cosine)
            if on.sum() < min_contacts:
                break
            centre = contacts[on].mean(axis=0)
            _, spread, axes = np.linalg.svd(contacts[on] - centre, full_matrices=False)
            normal = axes[2] * np.sign(axes[2] @ normal)
            members = on
        if members is None or members.tobytes() in seen:
            continue
        seen.add(members.tobytes())
        k = int(members.sum())
        across = spread[1] / np.sqrt(k)  # RMS spread across the narrower principal direction
        if k < min_face_contacts and not (k >= min_wide_face_contacts
                                          and _wide_without_any_one(contacts[members], wide_spread_m)):
            continue
        measured = normals[members].sum(axis=0)
        off_measured = np.arctan2(np.linalg.norm(np.cross(measured, normal)), measured @ normal)
        if off_measured > max(np.radians(2.0), normal_agreement_sigmas * normal_error_std_rad / np.sqrt(k)):
            continue
        departure = (contacts[members] - centre) @ normal
        rms = float(np.sqrt(np.mean(departure ** 2)))
        if (np.max(np.abs(departure)) > flatness_m or rms > max_rms_m or not across > 0
                or _splayed(contacts[members] - centre, normals[members], normal, splay_sigmas)):
            continue
        rms = max(rms, position_noise_m)
        centres.append(centre)
        face_normals.append(normal)
        tilts.append(max(min_tilt_rad, float(np.arctan(sigmas * rms / (across * np.sqrt(k))))))
        margins.append(max(min_margin_m, float(np.max(np.abs(departure))) + margin_extra_m))
        reaches.append(float(np.max(np.linalg.norm(contacts[members] - centre, axis=1))) + reach_m)
    if not centres:
        return empty
    faces = FacePlanes(np.array(centres), np.array(face_normals), np.array(margins), np.array(tilts),
                       np.array(reaches))
    clearance = np.concatenate([faces._clearances(x) for x in (contacts[s:s + _CHUNK]
                                                                for s in range(0, len(contacts), _CHUNK))])
    in_front = clearance < 0
    forgiven = (in_front & (normals @ faces.normals.T < np.cos(forgiven_angle_rad))
                & (clearance >= -forgiven_depth_m))
    keep = in_front.sum(axis=0) - np.minimum(forgiven.sum(axis=0), 1) == 0
    return FacePlanes(faces.centres[keep], faces.normals[keep], faces.margins_array()[keep],
                      np.asarray(faces.tolerance_rad)[keep], np.asarray(faces.reach_m)[keep])


def _wide_without_any_one(points: np.ndarray, spread_m: float) -> bool:
    """Whether the (k, 3) points spread ``spread_m`` RMS or more across their narrower principal
    direction, and half that with any one of them left out: a cluster and one far point are not
    wide (an L tool's face at 100 contacts: 16 mm, 0.7 mm without its far contact)."""
    def across(p: np.ndarray) -> float:
        return float(np.linalg.svd(p - p.mean(axis=0), compute_uv=False)[1] / np.sqrt(len(p)))

    return across(points) >= spread_m and all(across(np.delete(points, i, axis=0)) >= spread_m / 2
                                              for i in range(len(points)))


def _hull_facet_planes(contacts: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
    """Centres (m, 3) and outward unit normals (m, 3) of the contacts' convex hull facets, one per
    distinct plane; none for fewer than four contacts or contacts in one plane."""
    from scipy.spatial import ConvexHull, QhullError

    if len(contacts) < 4:
        return np.zeros((0, 3)), np.zeros((0, 3))
    try:
        hull = ConvexHull(contacts)
    except QhullError:  # all in one plane or line: no solid hull
        return np.zeros((0, 3)), np.zeros((0, 3))
    _, first = np.unique(np.round(hull.equations, 4), axis=0, return_index=True)
    return contacts[hull.simplices[first]].mean(axis=1), hull.equations[first, :3]


def _splayed(offsets: np.ndarray, normals: np.ndarray, normal: np.ndarray, sigmas: float) -> bool:
    """Whether a face's measured normals lean away from its centre (a convex surface) or towards it
    (a concave one) more than their noise explains.

    ``offsets`` (k, 3): the contacts from the face's centre; ``normals`` (k, 3): their measured unit
    normals; ``normal``: the plane's. On a flat face the component of each measured normal along
    the in-plane direction away from the centre is noise of zero mean; on a surface of curvature
    ``1 / R`` it is ``sin(r / R)`` at distance ``r``. The mean over the face is compared with its
    standard error."""
    radial = offsets - np.outer(offsets @ normal, normal)
    length = np.linalg.norm(radial, axis=1)
    use = length > 1e-9
    if use.sum() < 3:
        return False
    splay = np.einsum("ij,ij->i", normals[use], radial[use] / length[use, None])
    error = float(np.std(splay, ddof=1)) / np.sqrt(use.sum())
    return bool(abs(float(np.mean(splay))) > sigmas * max(error, 1e-12))
