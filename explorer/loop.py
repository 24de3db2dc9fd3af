"""The exploration loop: choose a touch, reach it, press until contact, record, retract, update.

It talks only to a :class:`robots.interface.Robot` (joint positions, moves), a
:class:`sensor.interface.TactileSensor` (timestamped readings), a :class:`Positioner` (stand angles),
the arm's kinematics (the same URDF as the robot) and a recorder; the simulated and the hardware
backends are interchangeable and the loop never asks which it has.

Per touch:

1. the strategy proposes touches (object frame), the planner turns the first reachable one into a
   stand pose and a joint path (standoff -> target -> ``depth`` beyond it);
2. the arm goes to a rest pose when the stand must turn, then to the standoff;
3. a guarded move follows the approach line until the pressure detector confirms a contact;
4. the arm keeps pressing (at most ``press_depth_m`` further) until the force estimate reaches
   ``press_force_n`` and the IMU orientation has settled, so the spring has aligned the pad;
5. the contact is measured by the one contact pipeline (:mod:`explorer.contact`: forward
   kinematics of the encoder readings through the spring pivot, the IMU orientation, the rig's pad
   calibration, the stand angles), recorded, and added to the GPIS (one incremental update);
6. a miss (no contact within the path) adds free-space evidence along the swept line.

The loop is built from a :class:`explorer.rig.Rig` (robot, sensor, kinematics, positioner, prior,
pad calibration) and a :class:`LoopConfig`.
"""
from __future__ import annotations

import time
from collections import Counter
from dataclasses import dataclass, replace

import numpy as np

from explorer.config import ExplorationConfig
from explorer.contact import (LOOP_SETTLING, ContactPipeline, DoubtRule, NoContactMeasured, ObjectFrame,
                              PadSideContact, PressReleased, wants_realign)
from explorer.evidence import SurfaceEvidence, with_swept_free_space
from explorer.motion_time import MotionTimeEstimator
from explorer.pad_bridging import PadBridging
from explorer.pad_indentation import PadIndentation
from explorer.planner import ApproachPlan, ApproachPlanner
from explorer.rig import Rig
from explorer.rim_standoff import RimStandoff
from explorer.strategies import ExplorationState, TouchStrategy
from explorer.touch import Touch, TouchOutcome
from reconstruction.gpis import GPIS
from reconstruction.meshing import check_refine_steps
from robots.interface import MoveNotReachedError
from sensor.contact_detection import PressureContactDetector, PressureDetectorConfig
from sensor.normal_estimation import SettlingConfig
from sensor.pad_calibration import PadCalibration
from sensor.reading import Reading


#: Recovery after a blocked free move (the arm's protective stop): joint speed of its moves, rad/s
#: (a recovery jog) ...
RECOVERY_SPEED_RAD_S = 0.2
#: ... and how far inside its software limits each joint is first brought, radians.
RECOVERY_LIMIT_CLEARANCE_RAD = 0.05
#: A pad face met on one corner carries the press on one of the four contact points it has lying
#: flat (PyBullet's pad; a real pad's corner is softer still): this many times its flat compliance.
ONE_CORNER_COMPLIANCE_FACTOR = 4.0


def back_out(robot, toward_q: np.ndarray, lower_rad: np.ndarray, upper_rad: np.ndarray,
             speed_rad_s: float = RECOVERY_SPEED_RAD_S,
             clearance_rad: float = RECOVERY_LIMIT_CLEARANCE_RAD) -> None:
    """Recovery after a blocked move: off the joint stops, then back to where the move started, slowly.

    A blocked free move can leave the hand pressed on the table or the object with joints that
    the contact pushed onto their mechanical stops (beyond the software limits) and every motor
    saturated towards a target far away. The stops take any load, so the contact, the stops and
    friction lock the arm: the next long move at transfer speed presses the hand harder (issue 12:
    wrist on the table at 3-8 kN, shoulder and wrist joints on their stops, 145 deg from rest, no
    joint moving, while the joint torques balance). Taking the joints off their stops first (a
    step of a few degrees to ``clearance_rad`` inside the software limits) opens the lock;
    reversing the blocked move then lifts the hand off. Both at ``speed_rad_s``; never raises
    for a target not reached (the next move says whether the arm is free).

    Parameters
    ----------
    robot : robots.interface.Robot
    toward_q : (dof,) float
        Where the blocked move started, radians.
    lower_rad, upper_rad : (dof,) float
        Software joint limits, radians.
    """
    lower, upper = np.asarray(lower_rad, float), np.asarray(upper_rad, float)
    margin = np.minimum(clearance_rad, 0.5 * (upper - lower))
    off_stops = np.clip(robot.joint_positions(), lower + margin, upper - margin)
    robot.guarded_move(off_stops[None], stop=lambda: False, speed_rad_s=speed_rad_s)
    target = np.clip(np.asarray(toward_q, float), lower, upper)
    robot.guarded_move(target[None], stop=lambda: False, speed_rad_s=speed_rad_s)


@dataclass(frozen=True)
class LoopConfig:
    """Exploration settings (SI units).

    Attributes
    ----------
    touches : int
        Touch budget (contacts plus misses).
    variance_threshold : float or None
        Stop early when the largest posterior variance on the surface falls below this.
    approach_speed_mps : float
        Pad speed along the approach line (the detector needs about 50 ms to confirm a contact,
        so this sets the overshoot: 0.5 mm at 1 cm/s).
    press_speed_mps : float
        Pad speed while pressing on after the contact.
    transfer_speed_rad_s : float
        Joint speed of free moves.
    press_depth_m : float
        Extra travel after the contact is confirmed, at most.
    press_force_n : float
        The press ends once the force estimate reaches this (or after ``press_depth_m``).
    settle_timeout_s : float
        After the press the arm holds until the IMU orientation has settled (the spring has
        aligned the pad), at most this long.
    candidates : int
        Touches requested from the strategy per round (tried in order until one is reachable).
    proposal_rounds : int
        Rounds of ``candidates`` proposals per step before the step counts as unreachable; each
        round's unreachable targets are avoided by the next (an object that cannot be turned has
        a whole side out of reach, and the most uncertain places are all there).
    free_space_value : float
        Implicit-function value given to points swept by a missed approach (about minus half the
        pad width: the pad passed there, so the surface is at least that far).
    free_space_noise : float
        Standard deviation of those values.
    side_press_value, side_press_noise : float, float or None
        Implicit-function value, and its standard deviation, given to the pad-face centre of a
        press on the pad's side (``no_normal``; ``TouchOutcome.side_m``): the surface it met lies
        between the face centre and the pad's corners, 0 to 12.7 mm away (18 mm square pad), so
        the centre is outside the surface by about half that (a uniform spread: 6.4 mm, standard
        deviation 3.7 mm). It tells the GPIS that the surface is near where it cannot measure a
        normal (a rim or an edge narrower than the pad), so the variance strategy stops aiming
        there. None: such presses add nothing (the loop before issue 11's side presses counted).
    max_unreachable_in_a_row : int
        Give up after this many steps without any reachable touch.
    realign_angle_rad : float
        When the measured normal differs from the approach by more than this, the pad may have
        stuck part way (friction holds its leading edge on surfaces tilted 35 deg or more from the
        approach, and its centre is then off the contact by millimetres): the contact is set aside
        and the next touch repeats it along the measured normal ("realign"), where the pad has
        little left to turn. The realign touch's contact is used as measured (simulated banana and
        cylinder: 0.2-0.6 mm and 1-6 deg off where the first was 2-5 mm and 15-25 deg off).
        Since issue 11 only a doubtful contact (``doubt_*``) is set aside, and at most
        ``max_realign_fraction`` of the budget goes to it (:func:`explorer.contact.wants_realign`).
    max_realign_fraction : float
        Largest share of ``touches`` set aside for realign repeats.
    doubt_rim_margin_m, doubt_approach_angle_rad : float
        The doubtful-contact rule (:class:`explorer.contact.DoubtRule`).
    doubtful_normal_noise : float
        Normal noise (GPIS gradient units) of a doubtful contact used as measured: at least this.
    side_contact_force_n, side_contact_tilt_rad : float
        A press that ends below this force with the pad turned less than this angle met the
        pad's side, not its face: ``no_normal`` (:class:`explorer.contact.DoubtRule`, ``side_*``).
        0 force: no such test.
    swept_free_space : bool
        The reconstruction (the run's mesh and error curve) also knows that the approach line a
        contact's or a side press's pad went along before it met the surface, up to
        ``-free_space_value`` short of it, is free space where the field puts the surface nearer
        (:func:`explorer.evidence.with_swept_free_space`): the probe past a phantom lid or through a
        ring's closed hole. The loop's own field, which the strategy explores, does not. False: runs
        before 2026-11-27.
    probe_corridor_m : float or None
        A contact met more than this far past its target also tells the loop's own field (the one
        the strategy explores) that the line its pad swept there is free, where the field put
        surface nearer (:class:`explorer.evidence.SurfaceEvidence`): a probe through a guessed
        surface that ended on a wall already touched then steers the next probe away from the
        same corridor. None: off.
    reconstruction_free_space_noise : float or None
        Standard deviation of those rows: firmer than the loop's ``free_space_noise`` (a miss's rows),
        since a row is only added where the final field still puts surface inside the line the pad
        passed. Chosen on the tuning split; the misses' points were left out after the held-out
        split showed misses whose pad had been dragged around a tool's handle, off their line
        (``line_tolerance_m``; BENCHMARKS.md, "Firmer free space in the reconstruction"). None:
        ``free_space_noise`` (runs before 2026-11-27).
    reconstruction_tightens_doubtful : bool
        In the reconstruction's field a doubtful contact (normal-noise floor ``doubtful_normal_noise``)
        with an opposing contact within the GPIS's ``opposing_radius_m`` gets the GPIS's
        ``opposing_normal_noise`` like any other contact there (``GPIS.opposing_overrides_floor``):
        with its floor the two sides of a thin wall part where one side was doubtful. The loop's
        own field keeps the floor. Chosen on the tuning split (BENCHMARKS.md, "A doubtful contact
        on a thin wall"). False: runs recorded before this setting.
    reconstruction_doubtful_normal_noise : float or None
        The normal-noise floor of a doubtful contact in the reconstruction's field; the loop's own
        field keeps ``doubtful_normal_noise``. 0.2, the GPIS's ``normal_noise``: the reconstruction
        fits a doubtful contact like any other. Chosen on the tuning split against 0.3, 0.5 and 1.0
        (BENCHMARKS.md, "A doubtful contact on a thin wall"). None: ``doubtful_normal_noise`` (runs
        recorded before this setting).
    reconstruction_wall_gain : float or None
        In the reconstruction's field both faces of a thin wall are tightened, whichever was touched
        first (the GPIS's opposing-normal rule judged over all the run's contacts,
        :meth:`reconstruction.gpis.GPIS.reassess_contact_noise`), and their gradient rows ask for
        a field rising this many times faster into the wall (``GPIS.opposing_gradient_gain``), so
        that the mean does not sag through a 4-7 mm wall between contacts 2 cm apart. The loop's own
        field is unchanged. 3, chosen on the tuning split against 1-6 on the same contacts at 100
        touches (BENCHMARKS.md, "Both faces of a thin wall"); from several hundred sampled contacts
        the gain costs a little (1.0: both faces tightened, no gain). None: runs recorded before
        this setting.
    reconstruction_gates_misses : bool
        The reconstruction takes a miss's free space as it takes the swept lines: only where the
        final field puts surface nearer than ``-free_space_value``, at
        ``reconstruction_free_space_noise`` (its field is rebuilt from the records without the loop's
        ungated miss rows). A row at ``free_space_value`` on a point the field already has
        centimetres outside pulls the surface out towards it: on the bowls those rows cost 0.3-0.9
        mm (BENCHMARKS.md, "The misses' free space through the gate"). The loop's field keeps them.
        False: runs recorded before this setting.
    line_tolerance_m : float or None
        A miss's free space ends ``-free_space_value`` before the point where the pad (forward
        kinematics of the encoders) first was this far off its planned line, as for an approach
        held back: another link or the pad's side had met the object and the arm, still driven
        along its joint path, pushed the pad around it. In the 64 split runs before, 36 of 147
        misses left their line by 3-114 mm while the whole line was recorded as free (two through a
        tool's handle). None: the whole line (the loop before 2026-11-27).
    stop_off_line : bool
        Also stop the approach there (a miss). Off: most approaches that go on end in good
        contacts; stopping them made the contacts more accurate but the tuning split's
        reconstructions worse (BENCHMARKS.md, "Approaches pushed off their line").
    drop_released_presses : bool
        A press whose settled force lies below the release pressure (see
        ``release_at_contact_threshold``) had let go before the orientation settled (:class:`explorer.contact.PressReleased`): ``no_normal``,
        and the pad's place is not taken as a side press. False: the loop before 2026-11-26.
    release_at_contact_threshold : bool
        The release test's pressure is the detector's start threshold, the rise that makes a
        contact (about 0.16 N on the simulated pads), not its end threshold (half that): a pad
        settled below it is not a contact by the loop's own criterion, and at 0.08 N its spring
        has no torque left to turn the pad flat (held-out mug/1000's first touch settled at
        0.085 N, 23.5 mm from the mug, its normal 90 deg off). False: the end threshold (sessions
        recorded before 2026-11-27 replay so).
    repress_force_n : float
        A contact that is doubtful after the press is pressed on (at most ``press_depth_m`` further)
        to this force and measured again from the readings of that second press: the pad reaches
        the rim of its face at a tilt of about ``force x half width / spring stiffness`` (26 deg at
        1 N), so more force turns it flat onto steeper slopes (issue 11). 0: no second press.
    repress_side_contacts : bool or None
        A press that looks like one on the pad's side after the first press (below
        ``side_contact_force_n`` with the pad turned less than ``side_contact_tilt_rad``) is pressed
        on too, and the side test asks the second press. On a soft pad the first press's
        ``press_depth_m`` runs out before that force where the pad met a face with one corner (the
        hardware-like pad: 0.76 mm/N flat, about four times that on one corner), and 20-40 of 100
        touches on the cereal box and the flat plate were thrown away as side presses. On a stiff
        pad such a press is a true side press, and pressing on makes it a contact in the wrong
        place (BENCHMARKS.md, "Presses that ran out of depth on a soft pad"). None (default): only
        where the depth is too short for the pad's compliance (:meth:`presses_on_side_contacts`).
        False: the loop before.
    loose_settle_deviation_rad : float or None
        A press whose orientation never settles (no window of the settling test within its 0.5 deg)
        is measured again with this looser bound, from the mean of its steadiest window, as a doubtful contact
        (:meth:`loose_settling`; the loop presses on and may repeat it, as any doubtful contact); only
        presses that fail this too are ``no_normal``. Teleoperation keeps the strict test. On a rim or
        in a curved hollow the pad can rock by a degree for the whole hold while it rests where it
        touched: 5-16 % of the budget on bowls, rings, plates and lids. Chosen on the tuning split
        (BENCHMARKS.md). None: the loop before 2026-11-27.
    bridge_concave_contacts : bool
        The reconstruction takes each contact on a concave surface as lying below where the pad's
        centre stayed, by the height the flat pad bridged (:meth:`reconstruction_records`,
        :mod:`explorer.pad_bridging`); with normals only. The loop's own field is left as measured.
        Chosen on the tuning split (BENCHMARKS.md, "A flat pad bridges concave surfaces"). False:
        runs recorded before 2026-11-27.
    indent_convex_contacts : bool
        The reconstruction takes each contact on a surface curving away from the pad in every
        direction as lying further out than the flat compliance put it, by what the pad sank further
        on one point (:mod:`explorer.pad_indentation`, from the neighbours' measured normals and the
        pad's point compliance; none where that is not measured), with or without normals in the
        GPIS (where the contact is, as the compression). The loop's own field is left as measured.
        Chosen on the tuning split (BENCHMARKS.md, "A pad on a ball sinks deeper"). False: runs
        recorded before 2026-12-08.
    reconstruction_symmetry : bool
        The run's mesh also takes the contacts' images under the mirror planes or the axis of
        revolution the contacts support (``GPIS.mesh(symmetry=...)``, :mod:`reconstruction.symmetry`);
        ``metrics.json`` says what was found. The loop's own field and the strategy are left as
        measured. Chosen on the tuning split (BENCHMARKS.md, "Symmetry found from the contacts").
        False: runs recorded before 2026-11-29.
    reconstruction_sets_aside_rim_standoffs : bool
        The reconstruction is fitted without the contacts whose pad met the surface with its rim
        while its face stood off it (:class:`explorer.rim_standoff.RimStandoff`: the field fitted
        without the contact puts the surface 3 mm or more behind it, facing more than 50 deg away,
        within the pad rim's reach), counted in ``metrics.json`` (``rim_standoff_contacts``,
        ``rim_standoff_touches``). With normals only; the loop's own field keeps them. Chosen on the
        tuning split (BENCHMARKS.md, "A pad's rim on the surface"). False: runs recorded before
        this setting.
    reconstruction_refine_steps : int
        ``GPIS.mesh(refine_steps=...)`` for the run's mesh. 0: the vertices where marching cubes
        interpolates them linearly, a third of a voxel inside a thin wall. The loop's contacts lie
        0.1-0.4 mm outside flat and thin-walled surfaces on average (the pad's edge presses) and that
        shrink offsets part of it: with the vertices moved to the field's zero (2), the tuning
        split's loop runs lost 0.03 mm on average and up to 0.17 mm on thin walls (BENCHMARKS.md,
        "Vertices on the field's zero"), while sampled contacts, unbiased, gain. Chosen on the
        tuning split; raise it once the contacts' outward bias is modelled.
    """

    touches: int = ExplorationConfig.touches
    variance_threshold: float | None = None
    approach_speed_mps: float = 0.01
    press_speed_mps: float = 0.005
    transfer_speed_rad_s: float = 1.0
    press_depth_m: float = 0.002
    press_force_n: float = 1.5
    settle_timeout_s: float = 1.0
    candidates: int = 6
    proposal_rounds: int = 3
    free_space_value: float = -0.009
    free_space_noise: float = 0.005
    side_press_value: float = -0.0065
    side_press_noise: float | None = 0.004
    max_unreachable_in_a_row: int = 5
    realign_angle_rad: float = np.radians(15.0)
    max_realign_fraction: float = 0.1
    doubt_rim_margin_m: float = DoubtRule.rim_margin_m
    doubt_approach_angle_rad: float = DoubtRule.approach_angle_rad
    doubtful_normal_noise: float = 0.5
    repress_force_n: float = 3.0
    repress_side_contacts: bool | None = None
    side_contact_force_n: float = 1.3
    side_contact_tilt_rad: float = float(np.radians(12.0))
    drop_released_presses: bool = True
    release_at_contact_threshold: bool = True
    swept_free_space: bool = True
    probe_corridor_m: float | None = None
    reconstruction_free_space_noise: float | None = 0.002
    reconstruction_gates_misses: bool = True
    reconstruction_tightens_doubtful: bool = True
    reconstruction_doubtful_normal_noise: float | None = 0.2
    reconstruction_wall_gain: float | None = 3.0
    line_tolerance_m: float | None = 0.005
    stop_off_line: bool = False
    loose_settle_deviation_rad: float | None = float(np.radians(1.5))
    bridge_concave_contacts: bool = True
    indent_convex_contacts: bool = True
    reconstruction_symmetry: bool = True
    reconstruction_refine_steps: int = 0
    reconstruction_sets_aside_rim_standoffs: bool = True

    def release_threshold_pa(self, detector: PressureDetectorConfig) -> float | None:
        """The contact pipeline's release test pressure (``ContactPipeline.release_threshold_pa``)
        for this contact detector; None when released presses are kept."""
        if not self.drop_released_presses:
            return None
        return detector.start_threshold_pa if self.release_at_contact_threshold else detector.end_threshold_pa

    def __post_init__(self):
        check_refine_steps(self.reconstruction_refine_steps, "LoopConfig.reconstruction_refine_steps")

    def loose_settling(self, settling: SettlingConfig) -> SettlingConfig | None:
        """The contact pipeline's fallback settling test (``ContactPipeline.loose_settling``):
        ``settling`` with the looser bound, reading the steadiest window and averaging all of it (a
        rocking pad's mean); None when off."""
        if self.loose_settle_deviation_rad is None:
            return None
        return replace(settling, max_deviation_rad=self.loose_settle_deviation_rad, window="steadiest",
                       average_window_s=settling.settle_window_s)

    def reconstruction_records(self, records, pad: PadCalibration,
                               use_normals: bool = True) -> tuple[list, int, int]:
        """The touches the reconstruction is fitted to, and the numbers of contacts bridged and
        indented: ``records`` with each contact on a concave surface moved in by the height its pad
        bridged when the GPIS uses normals (``bridge_concave_contacts``,
        :class:`explorer.pad_bridging.PadBridging`), then each on a surface curving away in every
        direction moved out by what its pad sank further there, with or without normals in the
        GPIS: a correction of where the contact is, as the compression is
        (``indent_convex_contacts``, :class:`explorer.pad_indentation.PadIndentation`); both read
        the surface's curvature from the neighbours' measured normals. ``pad``: the pad's half width
        and compliances."""
        taken, bridged, indented = list(records), 0, 0
        if self.bridge_concave_contacts and use_normals:
            taken, bridged = PadBridging().apply(taken, pad.half_width_m)
        if self.indent_convex_contacts:  # where the contact is, as the compression: both GPIS kinds
            taken, indented = PadIndentation().apply(taken, pad)
        return taken, bridged, indented

    def reconstruction_field(self, gpis: GPIS, records, pad: PadCalibration) -> tuple[GPIS, int]:
        """The field the run's reconstruction is meshed from and the number of free-space rows it
        adds (:meth:`reconstruction`'s ``field`` and ``swept_rows``)."""
        built = self.reconstruction(gpis, records, pad)
        return built.field, built.swept_rows

    def reconstruction(self, gpis: GPIS, records, pad: PadCalibration) -> "Reconstruction":
        """The run's reconstruction field and what went into it: ``gpis`` rebuilt from
        :meth:`reconstruction_records` (without the misses' rows when ``reconstruction_gates_misses``;
        its doubtful contacts with ``reconstruction_doubtful_normal_noise`` and, on thin walls,
        tightened with ``reconstruction_tightens_doubtful``; both faces of a thin wall tightened with
        ``reconstruction_wall_gain``) plus the gated rows of ``swept_free_space``, and then bridged and
        fitted again without the contacts that stood off on the pad's rim
        (``reconstruction_sets_aside_rim_standoffs``), round after round while another shows
        (at most :data:`RIM_STANDOFF_ROUNDS`).
        ``gpis`` itself is unchanged; with none of these settings it is the field.
        ``pad``: the pad's half width and compliances."""
        taken, bridged, indented = self.reconstruction_records(records, pad, gpis.use_normals)
        field, rows = self._reconstruction_field(gpis, taken, rebuild=bool(bridged or indented))
        standing_off: tuple[int, ...] = ()
        rounds = RIM_STANDOFF_ROUNDS if self.reconstruction_sets_aside_rim_standoffs and gpis.use_normals else 0
        for _ in range(rounds):  # until none is left: a standing-off neighbour can hide one
            found = tuple(r.index for r in RimStandoff().records(field, taken, pad.half_width_m))
            if not found:
                break
            standing_off += found  # bridged again without them: their normals, 55-70 deg off, bent the neighbours'
            kept = [r for r in records if not (r.kind == "contact" and r.index in standing_off)]
            taken, bridged, indented = self.reconstruction_records(kept, pad, gpis.use_normals)
            field, rows = self._reconstruction_field(gpis, taken, rebuild=True)
        return Reconstruction(field, rows, bridged, tuple(sorted(standing_off)), indented)

    def _reconstruction_field(self, gpis: GPIS, records, rebuild: bool) -> tuple[GPIS, int]:
        """``gpis`` as the reconstruction takes ``records`` (see :meth:`reconstruction`); ``rebuild``:
        fitted again from them even where no setting asks for it (they differ from its own)."""
        gated_misses = self.reconstruction_gates_misses and self.swept_free_space
        doubtful_noise = (self.doubtful_normal_noise if self.reconstruction_doubtful_normal_noise is None
                          else self.reconstruction_doubtful_normal_noise)
        doubtful = any(r.kind == "contact" and getattr(r.quality, "doubtful", False) for r in records)
        refloor = doubtful and (self.reconstruction_tightens_doubtful or doubtful_noise != self.doubtful_normal_noise)
        walls = (self.reconstruction_wall_gain is not None and gpis.opposing_normal_noise is not None
                 and bool(gpis.thin_wall_contacts().any()))
        if gated_misses or rebuild or refloor or walls:
            settings = gpis.unfitted_copy()
            settings.opposing_overrides_floor |= self.reconstruction_tightens_doubtful
            if walls:
                settings.opposing_gradient_gain = self.reconstruction_wall_gain
            gpis = self.evidence(settings).rebuilt(records, doubtful_noise, misses=not gated_misses).gpis
            if walls:
                gpis.reassess_contact_noise()
        if not self.swept_free_space:
            return gpis, 0
        noise = self.free_space_noise if self.reconstruction_free_space_noise is None else self.reconstruction_free_space_noise
        return with_swept_free_space(gpis, records, self.free_space_value, noise,
                                     misses=self.reconstruction_gates_misses)

    def presses_on_side_contacts(self, pad_compliance_m_per_n: float) -> bool:
        """Whether a press that looks like one on the pad's side is pressed on: as set, or (None)
        where ``press_depth_m`` cannot bring a pad met on one corner to ``side_contact_force_n``,
        the one corner carrying the load of the four a flat face has
        (``ONE_CORNER_COMPLIANCE_FACTOR`` x the flat ``pad_compliance_m_per_n``, m/N)."""
        if self.repress_side_contacts is not None:
            return self.repress_side_contacts
        corner_depth_m = self.side_contact_force_n * ONE_CORNER_COMPLIANCE_FACTOR * pad_compliance_m_per_n
        return self.press_depth_m < corner_depth_m

    def evidence(self, gpis: GPIS) -> SurfaceEvidence:
        """What touches add to ``gpis`` under these settings."""
        return SurfaceEvidence(gpis, self.free_space_value, self.free_space_noise, self.side_press_value,
                               self.side_press_noise, self.probe_corridor_m)

    def doubt_rule(self) -> DoubtRule:
        """The doubtful-contact rule of these settings."""
        return DoubtRule(self.doubt_rim_margin_m, self.doubt_approach_angle_rad,
                         self.side_contact_force_n or None, self.side_contact_tilt_rad)

    @property
    def max_realigns(self) -> int:
        """Realign repeats allowed in the whole budget."""
        return int(np.floor(self.max_realign_fraction * self.touches + 1e-9))


#: Rounds of :class:`explorer.rim_standoff.RimStandoff` the reconstruction runs at most, each on the
#: field without the contacts set aside before: two neighbouring contacts that stood off hold each
#: other's surface out, and the second shows once the first is gone (tuning torus/0: 3, 1, 1 contacts
#: in three rounds, BENCHMARKS.md "A pad's rim on the surface").
RIM_STANDOFF_ROUNDS = 5


@dataclass(frozen=True)
class Reconstruction:
    """The run's reconstruction field and what went into it (:meth:`LoopConfig.reconstruction`).

    Attributes
    ----------
    field : GPIS
        The field the run's mesh is taken from, object frame.
    swept_rows : int
        Free-space rows of the approach lines it holds.
    bridged_contacts : int
        Contacts moved in by the height the flat pad bridged.
    rim_standoff_touches : tuple of int
        Indices of the touches whose contacts stood off on the pad's rim, left out of it.
    indented_contacts : int
        Contacts moved out by what the pad sank further on a surface curving away in every direction.
    """

    field: GPIS
    swept_rows: int
    bridged_contacts: int
    rim_standoff_touches: tuple[int, ...] = ()
    indented_contacts: int = 0


@dataclass
class PhaseTimes:
    """Wall-clock seconds spent per phase of the loop."""

    simulation_s: float = 0.0
    planning_s: float = 0.0
    gpis_s: float = 0.0
    selection_s: float = 0.0

    def as_dict(self) -> dict:
        return dict(self.__dict__)


class Recorder:
    """Receives everything the loop sees; the default records nothing."""

    def readings(self, readings: list[Reading]) -> None: ...
    def joint_state(self, t_s: float, q: np.ndarray) -> None: ...
    def touch(self, record: TouchOutcome) -> None: ...
    def event(self, kind: str, t_s: float, **fields) -> None: ...


class ExplorationLoop:
    """Runs touches until the budget or the variance threshold is reached.

    Parameters
    ----------
    rig : explorer.rig.Rig
        Robot, sensor (opened by the caller), kinematics, positioner, prior and pad calibration.
    planner : ApproachPlanner
    strategy : TouchStrategy
    gpis : GPIS
        Empty; filled in the object frame.
    config : LoopConfig
    recorder : Recorder
    detector : PressureContactDetector
    settling : SettlingConfig
        When the pad's orientation counts as settled (default :data:`explorer.contact.LOOP_SETTLING`).
    """

    def __init__(self, rig: Rig, planner: ApproachPlanner, strategy: TouchStrategy, gpis: GPIS,
                 config: LoopConfig = LoopConfig(), recorder: Recorder | None = None,
                 detector: PressureContactDetector | None = None, settling: SettlingConfig = LOOP_SETTLING):
        self.robot = rig.robot
        self.sensor = rig.sensor
        self.kin = rig.kinematics
        self.positioner = rig.positioner
        self.prior = rig.prior
        reserve = planner.config.press_reserve_m
        if reserve < 2 * config.press_depth_m:
            raise ValueError(f"PlannerConfig.press_reserve_m ({1e3 * reserve:.1f} mm) must be at least twice "
                             f"LoopConfig.press_depth_m ({1e3 * config.press_depth_m:.1f} mm): a contact at the "
                             "end of an approach line needs room for the press and the re-press")
        self.planner = planner
        self.strategy = strategy
        self.gpis = gpis
        self.config = config
        self.recorder = recorder or Recorder()
        self.detector = detector or PressureContactDetector()
        self.contact_pipeline = ContactPipeline(rig.kinematics, rig.pad, settling, doubt=config.doubt_rule(),
                                                release_threshold_pa=config.release_threshold_pa(self.detector.config),
                                                loose_settling=config.loose_settling(settling))
        self.evidence = config.evidence(gpis)
        self._repress_side_contacts = config.presses_on_side_contacts(rig.pad.compliance_m_per_n)
        self.state = ExplorationState(rig.prior, motion=MotionTimeEstimator(planner, rig.positioner))
        self.records: list[TouchOutcome] = []
        self.times = PhaseTimes()
        #: Moves the arm's protective stop (or the controller) ended, by phase (``transfer``,
        #: ``retract``, ``rest``, ``retrace``, ``rest_forced``) and by what the arm met (``on``:
        #: body name, or ``unknown`` when the robot does not say). See :meth:`blocked_moves_summary`.
        self.blocked_moves: Counter = Counter()
        self.blocked_on: Counter = Counter()
        self._contact_readings: list[Reading] = []
        self._baseline_pa: float | None = None
        self._press_start_s = -np.inf
        self._left_line_pad_m: np.ndarray | None = None  # (3,) world: where the pad first left its line
        self._follow_up: Touch | None = None
        #: Joint positions (dof,) the free moves reached since the arm was last at rest (or since the
        #: run began), in order; the last is where the arm stands between touches. Retraced when
        #: the way to rest is blocked (:meth:`_retrace`).
        self._trail: list[np.ndarray] = []

    # ------------------------------------------------------------------ public
    @property
    def contacts(self) -> list[TouchOutcome]:
        return [r for r in self.records if r.kind == "contact"]

    def run(self, progress=None) -> list[TouchOutcome]:
        """Explore until the budget is spent; returns the touch records."""
        unreachable_in_a_row = 0
        while self.state.touches < self.config.touches:
            record = self.step()
            if progress is not None:
                progress(record)
            unreachable_in_a_row = unreachable_in_a_row + 1 if record.kind == "unreachable" else 0
            if unreachable_in_a_row >= self.config.max_unreachable_in_a_row:
                self.recorder.event("stopped", self.robot.time_s(), reason="no reachable touch")
                break
            if self._variance_converged():
                self.recorder.event("stopped", self.robot.time_s(), reason="variance below threshold")
                break
        return self.records

    def step(self) -> TouchOutcome:
        """One touch: plan, move, press, record, update."""
        self.state.gpis = self.gpis if self.gpis.n_contacts else None
        plan, first_proposals = None, None
        touched = self._touched_points()
        for _ in range(max(self.config.proposal_rounds, 1)):
            t0 = time.perf_counter()
            proposals = self.strategy.propose(self.state, self.config.candidates)
            if self._follow_up is not None:
                proposals = [self._follow_up] + proposals
                self._follow_up = None
            first_proposals = proposals if first_proposals is None else first_proposals
            t1 = time.perf_counter()
            self.times.selection_s += t1 - t0
            for touch in proposals:
                plan = self.planner.plan(touch, seed_q=self.robot.joint_positions(), touched_m=touched)
                if plan is not None:
                    break
                self.state.unreachable_m.append(touch.target_m)
            self.times.planning_s += time.perf_counter() - t1
            if plan is not None or not proposals:
                break
        proposals = first_proposals
        index = len(self.records)
        self.state.touches += 1
        if plan is None:
            touch = proposals[0] if proposals else None
            record = TouchOutcome(index, "unreachable",
                                 np.zeros(3) if touch is None else touch.target_m,
                                 np.zeros(3) if touch is None else touch.approach_dir,
                                 t_s=self.robot.time_s(), strategy="" if touch is None else touch.strategy)
            return self._finish(record)
        if plan.touch.strategy != "realign":
            self.strategy.accepted(plan.touch)
        self.state.tried_m.append(plan.touch.target_m)
        record = self._execute(plan, index)
        record.strategy = plan.touch.strategy
        self.state.passed_m.extend(record.passed_points(-self.config.free_space_value))
        return self._finish(record)

    def restore(self, records: list[TouchOutcome]) -> None:
        """Continue a run from the touches it recorded before it stopped (see ``explorer.resume``).

        Replays their effect in the original order: the touch count, the tried and unreachable
        targets, the strategy's bookkeeping, the GPIS (contacts and the free space of misses, so
        the field equals the one the run had) and a realign repeat still owed. Targets the planner
        rejected on the way to an accepted touch were not recorded, so the strategy may propose
        them again.
        """
        if self.records or self.gpis.n_contacts:
            raise RuntimeError("restore() must be called on a fresh loop, before any touch")
        for expected, record in enumerate(records):
            if record.index != expected:
                raise ValueError(f"recorded touches must be numbered 0, 1, ... in order; touch {expected} "
                                 f"is numbered {record.index}")
            self.records.append(record)
            self.state.touches += 1
            if record.kind == "unreachable":
                self.state.unreachable_m.append(record.target_m)
                continue
            self.state.tried_m.append(record.target_m)
            if record.kind == "blocked":
                self.state.unreachable_m.append(record.target_m)
            if record.strategy and record.strategy != "realign":
                self.strategy.accepted(Touch(record.target_m, record.approach_dir, strategy=record.strategy))
            self.state.passed_m.extend(record.passed_points(-self.config.free_space_value))
            self.evidence.add_touch(record, self.config.doubtful_normal_noise)
        if records and records[-1].kind == "realign":
            last = records[-1]
            self._follow_up = Touch(last.position_m, -last.normal, strategy="realign",
                                    depth_m=self.planner.config.depth_m)

    # ------------------------------------------------------------------ one touch
    def _execute(self, plan: ApproachPlan, index: int) -> TouchOutcome:
        cfg = self.config
        t0 = time.perf_counter()
        if plan.stand != self.positioner.pose():
            self._to_rest()
            self.positioner.move_to(plan.stand)
        if not self._transfer(plan.standoff_q):
            self.state.unreachable_m.append(plan.touch.target_m)
            self.times.simulation_s += time.perf_counter() - t0
            return TouchOutcome(index, "blocked", plan.touch.target_m, plan.touch.approach_dir,
                               plan.stand.yaw_rad, plan.stand.tilt_rad, t_s=self.robot.time_s())
        self._poll()
        self.detector.reset()
        # The press is the readings stamped after t0, t0 < t (as replay takes it).
        press_start = self.robot.time_s()
        self._press_start_s = press_start
        self._contact_readings = []
        speed = self._joint_speed(plan)
        self._left_line_pad_m = None
        approach = self.robot.guarded_move(plan.path_q[1:], stop=lambda: self._approach_stopped(plan),
                                           speed_rad_s=speed)
        record = TouchOutcome(index, "miss", plan.touch.target_m, plan.touch.approach_dir,
                             plan.stand.yaw_rad, plan.stand.tilt_rad, t_s=self.robot.time_s())
        if self._left_line_pad_m is not None:
            record.left_line_m = self.positioner.to_object(self._left_line_pad_m[None])[0]
        if approach.stopped and not (self.config.stop_off_line and self._left_line_pad_m is not None):
            start_pad = self.kin.pose_of_one(self.robot.joint_positions())[0]
            remaining = plan.path_q[min(approach.waypoint_index + 1, len(plan.path_q) - 1):]
            press_speed = speed * cfg.press_speed_mps / cfg.approach_speed_mps
            press = self.robot.guarded_move(remaining, stop=lambda: self._pressed(start_pad),
                                            speed_rad_s=press_speed)
            self.robot.hold(cfg.settle_timeout_s, stop=self._settled_now)
            if cfg.repress_force_n > 0 and self._worth_pressing_on(record):
                record.repress_t_s = self._repress(remaining[min(press.waypoint_index, len(remaining) - 1):],
                                                   press_speed)
            record = self._contact_record(record)
        record.press_t_s = (press_start, self.robot.time_s())
        self._retract(plan)
        self._poll()
        self.times.simulation_s += time.perf_counter() - t0
        realigns = sum(r.kind == "realign" for r in self.records)
        if (record.kind == "contact" and plan.touch.strategy != "realign"
                and wants_realign(record.quality, record.normal, record.approach_dir, cfg.realign_angle_rad,
                                  realigns, cfg.max_realigns)):
            record.kind = "realign"
            self._follow_up = Touch(record.position_m, -record.normal, strategy="realign",
                                    depth_m=self.planner.config.depth_m)
        if record.kind == "miss":
            swept = self._swept(plan, approach.q)
            record.free_space_m = self.evidence.inside_bounds(self.positioner.to_object(swept))
        self._add_evidence(record)
        return record

    def _touched_points(self) -> np.ndarray:
        """(n, 3) object-frame points the pad has touched: contacts and presses on its side."""
        points = [r.position_m for r in self.records if r.kind == "contact"]
        points += [r.side_m for r in self.records if r.kind == "no_normal" and r.side_m is not None]
        return np.array(points, float).reshape(-1, 3)

    def blocked_moves_summary(self) -> dict:
        """``{phase: count, ..., "on": {body: count}}`` of the moves that were blocked (for
        ``metrics.json``): on a concave object the hand meeting its rim shows up here as
        ``retract`` stops on the object."""
        return {**dict(self.blocked_moves), "on": dict(self.blocked_on)}

    def _blocked(self, phase: str, err: MoveNotReachedError, message: str | None = None) -> None:
        """Record a blocked move (event ``<phase>_blocked``, or ``rest_forced``) and count it."""
        kind = phase if phase == "rest_forced" else f"{phase}_blocked"
        body = getattr(err, "body", None)
        self.recorder.event(kind, self.robot.time_s(), message=str(err) if message is None else message,
                            body=body, link=getattr(err, "link", None))
        self.blocked_moves[phase] += 1
        self.blocked_on[body or "unknown"] += 1

    def _transfer(self, q: np.ndarray) -> bool:
        """Free move to the standoff ``q``: directly (around the prior box where the straight joint
        path would not clear it, :meth:`_free_route`); when that is blocked, to a point on the
        approach line behind the standoff and straight in along it (the way the pad will go on;
        :meth:`ApproachPlanner.retreat_path` from ``q``, reversed); then the same from the rest
        pose. A straight joint path from rest or from the last touch can sweep the hand through
        the object, and the arm's protective stop ends it. When no clear path to ``q`` is known
        (a standoff inside the prior box, as in a bowl) the approach line comes first: the hand
        then enters the box the way the pad does.

        Returns False (arm back at rest) when ``q`` itself cannot be reached: the arm would
        touch the object there (the planner checks only the arm up to the wrist).
        """
        route = self.planner.transfer_path(self.robot.joint_positions(), q)
        attempts = ("direct", "along the approach line", "via rest")
        if route is None:
            attempts = ("along the approach line", "direct", "via rest")
        line = None  # far end first, the standoff's neighbour last; IK only once needed
        for attempt in attempts:
            if attempt != "direct" and line is None:
                line = self.planner.retreat_path(q)[::-1]
            if attempt == "along the approach line" and not len(line):
                continue
            try:
                if attempt == "direct":
                    self._free_route(q, route if attempt == attempts[0] else None)
                    return True
                if attempt == "via rest":
                    self._free_route(self.planner.rest_q)
                if len(line):
                    self._free_route(line[0])
                    self.robot.guarded_move(np.vstack([line[1:], q[None]]), stop=lambda: False,
                                            speed_rad_s=self.config.transfer_speed_rad_s)
                    self._free_move(q, passed=line[1:])
                else:
                    self._free_route(q)
                return True
            except MoveNotReachedError as err:
                self._blocked("transfer", err, f"{attempt}: {err}")
        self._to_rest()
        return False

    def _free_route(self, q: np.ndarray, route: np.ndarray | None = None) -> None:
        """Free move to ``q`` along ``route`` or else :meth:`ApproachPlanner.transfer_path` (around
        the prior box, with a ``free_path`` event); straight when no clear path is known."""
        if route is None:
            route = self.planner.transfer_path(self.robot.joint_positions(), q)
        if route is None:
            route = np.asarray(q, float)[None]
        if len(route) > 1:
            self.recorder.event("free_path", self.robot.time_s(), waypoints=len(route))
        for waypoint in route:
            self._free_move(waypoint)

    def _free_move(self, q: np.ndarray, passed=()) -> None:
        """Move to ``q`` at transfer speed and add it (after the (k, dof) waypoints ``passed`` on the
        way) to the trail; when blocked, step back the way it came (:func:`back_out`) and raise
        the MoveNotReachedError."""
        start = self.robot.joint_positions()
        if not self._trail:
            self._trail.append(start)
        try:
            self.robot.move_joints(q, self.config.transfer_speed_rad_s)
        except MoveNotReachedError:
            back_out(self.robot, start, self.kin.lower_rad, self.kin.upper_rad)
            raise
        q = np.asarray(q, float)
        if np.allclose(q, self.planner.rest_q):
            self._trail = [q]
        else:
            self._trail.extend([*np.asarray(passed, float).reshape(-1, len(q)), q])

    def _to_rest(self) -> None:
        """To the rest pose; when blocked (``rest_blocked`` event), back the way the arm came
        (:meth:`_retrace`: the free moves since it was last at rest, in reverse), then to rest.
        Blocked on that too (``retrace_blocked`` event), the pad backs straight out along its
        face axis (:meth:`ApproachPlanner.retreat_path`: the straight joint path to rest from near
        the object can sweep the hand through it), then once more to rest, both at recovery speed
        (a real arm's recovery after a protective stop). Blocked again (``rest_forced`` event): a
        last slow guarded move to rest, whose only guard is the robot's own (the simulated arm's is
        none: it pushes past the object as every move did before the protective stop). Still not
        at rest: the MoveNotReachedError ends the run, with what was recorded kept."""
        rest = self.planner.rest_q
        try:
            self._free_route(rest)
        except MoveNotReachedError as err:
            self._blocked("rest", err)
            if self._retrace():
                return
            retreat = self.planner.retreat_path(self.robot.joint_positions())
            if len(retreat):
                self.robot.guarded_move(retreat, stop=lambda: False, speed_rad_s=RECOVERY_SPEED_RAD_S)
            try:
                self.robot.move_joints(rest, RECOVERY_SPEED_RAD_S)
            except MoveNotReachedError as again:
                self._blocked("rest_forced", again)
                self.robot.guarded_move(np.asarray(rest, float)[None], stop=lambda: False,
                                        speed_rad_s=RECOVERY_SPEED_RAD_S)
                self.robot.move_joints(rest, RECOVERY_SPEED_RAD_S)

    def _retrace(self) -> bool:
        """Back along the trail (the free moves since the arm was last at rest, in reverse) to its
        start, then to rest: the arm reached every trail point without a block and nothing has
        moved since, so this is the one way known to be clear when the planned way to rest is
        not (a hand pressed into a lid's rim it reached from the other side). At transfer speed,
        each move with the protective stop. False, with a ``retrace_blocked`` event and the arm
        backed out of the blocked move, when a move was blocked all the same. Logged as a
        ``retrace`` event (``waypoints``: trail points gone back through)."""
        if len(self._trail) < 2:
            return False
        self.recorder.event("retrace", self.robot.time_s(), waypoints=len(self._trail) - 1)
        try:
            for q in self._trail[::-1]:  # the first: where the arm should stand, e.g. after a retract
                self._free_move(q)
            if not np.allclose(self._trail[-1], self.planner.rest_q):
                self._free_route(self.planner.rest_q)
        except MoveNotReachedError as err:
            self._blocked("retrace", err)
            return False
        return True

    def _swept(self, plan: ApproachPlan, q_end: np.ndarray) -> np.ndarray:
        """(k, 3) world points of the approach line the pad passed on a miss.

        The whole line when the pad got to its end on it; otherwise (another link met the object
        and held the arm back, or pushed the pad off the line: ``line_tolerance_m``) only the points
        at least ``-free_space_value`` (the pad's half width) behind where it stopped or first left
        the line: the surface may be just beyond it.
        """
        line = plan.path_world_m
        along = plan.along_line(line)
        reached = float(plan.along_line(self.kin.forward_kinematics(q_end).position_m))
        if self._left_line_pad_m is not None:
            reached = min(reached, float(plan.along_line(self._left_line_pad_m)))
        elif reached >= along[-1] - 0.002:
            return line
        return line[along <= reached + self.config.free_space_value]

    def _retract(self, plan: ApproachPlan) -> None:
        """Back to the standoff the way the pad came in: through the approach line's waypoints in
        reverse, from the last one the pad had passed (:meth:`_passed_waypoint`), at transfer
        speed, then onto the standoff with the protective stop. A straight joint move from deep in
        a bowl or a ring's hole swings the wrist into the rim (93 blocked retracts in the 32 seed-1
        split runs before, BENCHMARKS.md). Blocked all the same (``retract_blocked`` event): to
        rest (:meth:`_to_rest`)."""
        speed = self.config.transfer_speed_rad_s
        passed = self._passed_waypoint(plan)
        try:
            if passed > 0:
                self.robot.guarded_move(plan.path_q[passed::-1], stop=lambda: False, speed_rad_s=speed)
            self.robot.move_joints(plan.standoff_q, speed)
        except MoveNotReachedError as err:
            self._blocked("retract", err)
            self._to_rest()

    def _passed_waypoint(self, plan: ApproachPlan) -> int:
        """Index of the last waypoint of ``plan.path_q`` the pad has gone past along the approach
        line (0: still at or behind the standoff); going back from there never pushes it deeper."""
        pad = self.kin.pose_of_one(self.robot.joint_positions())[0]
        reached = float(plan.along_line(pad))
        return max(int(np.searchsorted(plan.along_line(plan.path_world_m), reached + 1e-9, side="right")) - 1, 0)

    def _contact_record(self, record: TouchOutcome) -> TouchOutcome:
        record.baseline_pa = self._baseline_pa
        q = self.robot.joint_positions()
        # Logged so that replay measures the contact at these very encoder readings (on hardware
        # each call reads the encoders afresh).
        self.recorder.joint_state(self.robot.time_s(), q)
        try:
            measured = self.contact_pipeline.measure(self._contact_readings, self._baseline_pa, q,
                                                      ObjectFrame.of_positioner(self.positioner), record.approach_dir)
        except NoContactMeasured as err:
            self.recorder.event("no_normal", self.robot.time_s(), message=str(err))
            record.kind = "no_normal"
            if not isinstance(err, PressReleased):  # a released pad's place says nothing
                record.side_m = self.contact_pipeline.pad_centre(q, ObjectFrame.of_positioner(self.positioner))
            return record
        record.kind = "contact"
        record.contact = measured.world
        record.position_m = measured.position_m
        record.normal = measured.normal
        record.quality = measured.quality
        record.t_s = measured.world.t_s
        return record

    def _worth_pressing_on(self, record: TouchOutcome) -> bool:
        """The contact as it stands after the first press (same pipeline, not recorded) is doubtful,
        or (``repress_side_contacts``) looks like a press on the pad's side."""
        try:
            measured = self.contact_pipeline.measure(self._contact_readings, self._baseline_pa,
                                                     self.robot.joint_positions(),
                                                     ObjectFrame.of_positioner(self.positioner), record.approach_dir)
        except PadSideContact:
            return self._repress_side_contacts
        except NoContactMeasured:
            return False
        return measured.quality.doubtful

    def _repress(self, path_q: np.ndarray, speed_rad_s: float) -> float:
        """Press on along ``path_q`` to ``repress_force_n`` (or ``press_depth_m`` further), hold until
        settled; the contact is then measured from the readings after the returned time, seconds."""
        cfg = self.config
        self._collect()  # the second press's readings are those stamped after the first's last
        t_s = self._contact_readings[-1].t_s if self._contact_readings else self.robot.time_s()
        self._contact_readings = []
        start_pad = self.kin.forward_kinematics(self.robot.joint_positions()).position_m
        self.robot.guarded_move(path_q, stop=lambda: self._pressed(start_pad, cfg.repress_force_n),
                                speed_rad_s=speed_rad_s)
        self.robot.hold(cfg.settle_timeout_s, stop=self._settled_now)
        return t_s

    def _finish(self, record: TouchOutcome) -> TouchOutcome:
        self.records.append(record)
        self.recorder.touch(record)
        return record

    # ------------------------------------------------------------------ sensing
    def _poll(self) -> list[Reading]:
        readings = self.sensor.drain()
        if readings:
            self.recorder.readings(readings)
            self.recorder.joint_state(self.robot.time_s(), self.robot.joint_positions())
        return readings

    def _approach_stopped(self, plan: ApproachPlan) -> bool:
        """The approach's stop test, every control tick: a contact started, or (``stop_off_line``)
        the pad left its planned line. The first tick the pad is more than ``line_tolerance_m`` off
        the line sets ``_left_line_pad_m`` and logs a ``left_line`` event."""
        if self._contact_started():
            return True
        tolerance = self.config.line_tolerance_m
        if tolerance is None or self._left_line_pad_m is not None:  # off, or already logged
            return False
        pad = self.kin.pose_of_one(self.robot.joint_positions())[0]  # numpy FK: runs every control tick
        lateral = plan.off_line_m(pad)
        if lateral <= tolerance:
            return False
        self._left_line_pad_m = np.array(pad, float)
        self.recorder.event("left_line", self.robot.time_s(), lateral_m=lateral)
        return self.config.stop_off_line

    def _contact_started(self) -> bool:
        """Feed every new reading to the detector; keep the readings from the confirmed start on."""
        started = False
        for reading in self._poll():
            if reading.t_s <= self._press_start_s:  # a device may stamp two readings alike
                continue
            event = self.detector.update(reading)
            if event is not None and event.kind == "start":
                started = True
                self._baseline_pa = event.baseline_pa
                self.recorder.event("contact_start", event.t_s, baseline_pa=event.baseline_pa)
            if started:
                self._contact_readings.append(reading)
        return started

    def _collect(self) -> None:
        for reading in self._poll():
            self.detector.update(reading)
            self._contact_readings.append(reading)

    def _pressed(self, start_pad_m: np.ndarray, force_n: float | None = None) -> bool:
        """The press has reached its force (``press_force_n`` unless given), or its depth."""
        self._collect()
        if not self._contact_readings:
            return False
        rise = self._contact_readings[-1].pressure_pa - (self._baseline_pa or 0.0)
        pad = self.kin.pose_of_one(self.robot.joint_positions())[0]  # numpy FK: runs every control tick
        travelled = float(np.linalg.norm(pad - start_pad_m))
        target = self.config.press_force_n if force_n is None else force_n
        return travelled >= self.config.press_depth_m or self.contact_pipeline.force_estimate_n(rise) >= target

    def _settled_now(self) -> bool:
        """The orientation over the latest settling window is steady."""
        self._collect()
        return self.contact_pipeline.settled(self._contact_readings, self._baseline_pa)

    def _add_evidence(self, record: TouchOutcome) -> None:
        """What the touch tells the loop's field, as resume and replay add it."""
        t0 = time.perf_counter()
        self.evidence.add_touch(record, self.config.doubtful_normal_noise)
        self.times.gpis_s += time.perf_counter() - t0

    def _joint_speed(self, plan: ApproachPlan) -> float:
        """Joint speed that moves the pad at ``approach_speed_mps`` along the approach line."""
        joint_length = float(np.max(np.abs(plan.path_q[-1] - plan.path_q[0])))
        line_length = float(np.linalg.norm(plan.path_world_m[-1] - plan.path_world_m[0]))
        return max(joint_length / line_length * self.config.approach_speed_mps, 1e-3)

    def _variance_converged(self) -> bool:
        threshold = self.config.variance_threshold
        if threshold is None or self.gpis.n_contacts < 4:
            return False
        estimate = self.strategy.surface_variance(ExplorationState(self.prior, self.gpis))
        return estimate is not None and bool(estimate[1].max() < threshold)
