"""A pad that met the surface with its rim while its face stood off it: the contact is not there
(issue 11).

The pipeline places a contact on the pad's face, at the centre of pressure the spring's deflection
gives (:func:`explorer.contact.pad_load`), with the pad's face axis as the normal. That model
assumes the force pushes along the face's normal. When the pad comes in almost along a surface (a
ring's flat band met by a pad moving across it, a torus's top) its rim meets the surface first,
the force runs across the face close to the spring's pivot, the spring hardly turns, and the
contact is placed near the pad's centre, up to the pad's half width off the surface, with a normal
55-70 deg off (held-out ring/1000, seed 1: three contacts 6-8 mm off). The press alone cannot tell
such a contact from a good one; it says only that the pad met the surface near its centre (the
contact is not doubtful and the spring turned little).

The other contacts tell the rest: the reconstruction field fitted without the contact
(:meth:`reconstruction.gpis.GPIS.leave_one_out_with_normals`)
puts the surface well behind it, facing far from its normal, and no farther behind it than the
pad's rim reaches at that angle (half its width times the sine, plus a margin). A contact is
standing off when the press and all three of these agree; the reconstruction is then fitted
without it (``LoopConfig.reconstruction_sets_aside_rim_standoffs``; counted in ``metrics.json``,
the contact stays in ``contacts.csv``). A part of the object the others do not know (a knob, a
handle touched once) lies in their free space too, but farther out than the pad's rim reaches it
is kept. On the split runs of BENCHMARKS.md ("A pad's rim on the surface") 9 of the 10 held-out
contacts set aside were 4-8 mm off the surface.

Used for the reconstruction only: the field the strategy explores is left as measured.
"""
from __future__ import annotations

from dataclasses import dataclass

import numpy as np


@dataclass(frozen=True)
class RimStandoff:
    """When a contact stood off the surface on the pad's rim, from the field fitted without it.

    Attributes
    ----------
    min_depth_m : float
        The field without the contact puts the surface at least this far behind it, metres (its
        value there is below ``-min_depth_m``) ...
    min_angle_rad : float
        ... its normal there lies more than this from the contact's, radians ...
    reach_margin_m : float
        ... and the depth is at most the pad's half width times the sine of that angle plus this,
        metres: the rim of a pad turned so can touch the surface there ...
    max_tilt_rad : float
        ... and the press itself says the pad met the surface near its face's centre: the contact
        is not doubtful (a centre of pressure near the rim already placed it where the rim
        touched, :class:`explorer.contact.DoubtRule`) and the spring turned less than this,
        radians (a rim load passes near the spring's pivot and hardly turns it). A contact whose
        quality is not known is kept.

    Thresholds chosen on the tuning split's loop runs against 2-5 mm, 40-60 deg and 0-20 mm
    (BENCHMARKS.md, "A pad's rim on the surface"); the margin allows for the field's own error
    behind a contact (a looser one, no reach limit at all, gained one more plate contact there).
    """

    min_depth_m: float = 0.003
    min_angle_rad: float = float(np.radians(50.0))
    reach_margin_m: float = 0.004
    max_tilt_rad: float = float(np.radians(20.0))

    def __post_init__(self):
        if not self.min_depth_m > 0 or not self.reach_margin_m >= 0:
            raise ValueError(f"RimStandoff needs min_depth_m > 0 and reach_margin_m >= 0, got "
                             f"{self.min_depth_m}, {self.reach_margin_m}")
        for name in ("min_angle_rad", "max_tilt_rad"):
            if not 0 < getattr(self, name) < np.pi:
                raise ValueError(f"RimStandoff.{name} must lie in (0, pi), got {getattr(self, name)}")

    def standing_off(self, gpis, pad_half_width_m: float) -> np.ndarray:
        """(n_contacts,) bool over ``gpis``'s contacts (its order): which stood off on the pad's rim.

        Parameters
        ----------
        gpis : reconstruction.gpis.GPIS
            A fitted field with normals (object frame); without normals or contacts nothing is flagged.
        pad_half_width_m : float
            Half the side of the square pad, metres.
        """
        if not gpis.use_normals or gpis.n_contacts < 2:
            return np.zeros(gpis.n_contacts, bool)
        mean, _, left_out_normals = gpis.leave_one_out_with_normals()
        depth = -mean
        cosine = np.einsum("ij,ij->i", left_out_normals, gpis.contact_normals)
        angle = np.arccos(np.clip(cosine, -1.0, 1.0))
        reach = pad_half_width_m * np.sin(np.minimum(angle, np.pi / 2)) + self.reach_margin_m
        return (depth > self.min_depth_m) & (angle > self.min_angle_rad) & (depth <= reach)

    def pressed_near_centre(self, quality) -> bool:
        """Whether a contact's :class:`explorer.contact.ContactQuality` says the pad met the
        surface near its face's centre (see ``max_tilt_rad``); False when it is not known."""
        tilt = getattr(quality, "tilt_rad", None)
        return tilt is not None and not quality.doubtful and tilt < self.max_tilt_rad

    def records(self, gpis, records, pad_half_width_m: float) -> list:
        """The contact records (kind ``contact``, of ``records``, object frame) that stood off on
        the pad's rim: their point is one of ``gpis``'s contacts that :meth:`standing_off` flags
        and their press met the pad near its centre (:meth:`pressed_near_centre`). ``gpis`` must
        be fitted to these records."""
        flagged = gpis.contact_points[self.standing_off(gpis, pad_half_width_m)]
        if not len(flagged):
            return []
        return [r for r in records if r.kind == "contact" and r.position_m is not None
                and self.pressed_near_centre(r.quality)
                and np.min(np.linalg.norm(flagged - np.asarray(r.position_m), axis=1)) < 1e-9]
