"""Contact quality on edges and curvature (issue 11): the centre of pressure from the spring's
deflection, the doubtful-contact rule, the realign budget and the GPIS noise of doubtful contacts.

The pad geometry is checked against closed forms: a pad resting on a straight edge or tangent to a
cylinder, turned on its spring until the contact's torque about the pivot equals the spring's
(``k angle = F u``), must be measured on the edge / on the cylinder, where the pad centre is
millimetres off.
"""
import dataclasses
from types import SimpleNamespace

import numpy as np
import pytest
from scipy.spatial.transform import Rotation

from common.rotations import wxyz_from_rotation
from explorer.contact import (ContactPipeline, ContactQuality, DoubtRule, ObjectFrame, pad_load,
                              wants_realign)
from reconstruction.gpis import GPIS
from sensor.pad_calibration import PadCalibration
from sensor.reading import Reading
from sensor.sim.pad_response import PadResponse
from reconstruction.synthetic_contacts import sphere_contacts as exact_sphere_contacts

PIVOT_TO_FACE_M = 0.0047
K_NM_PER_RAD = 0.02
BASELINE_PA = 101325.0


class TiltedToolKinematics:
    """The pivot at ``pivot_m`` with the tool axis along ``rotation[:, 2]``; the pad face
    ``PIVOT_TO_FACE_M`` in front of the pivot along the body's +z."""

    def __init__(self, pivot_m, rotation=np.eye(3)):
        self.pivot_m = np.asarray(pivot_m, float)
        self.rotation = np.asarray(rotation, float)
        self.spec = SimpleNamespace(pivot_link="pivot")
        self.pivot_to_pad_in_body = np.array([0.0, 0.0, PIVOT_TO_FACE_M])

    def forward_kinematics(self, q, link=None):
        return SimpleNamespace(position_m=self.pivot_m.copy(), rotation=self.rotation.copy())


def press_readings(body: Rotation, force_n: float, n: int = 40, dt_s: float = 0.01) -> list[Reading]:
    """A settled press: constant orientation ``body`` and the pad's pressure for ``force_n``."""
    pressure = BASELINE_PA + PadResponse().pressure_rise_pa(force_n)
    quat = wxyz_from_rotation(body)
    return [Reading(i * dt_s, pressure, tuple(quat), (0.0, 0.0, 0.0), (0.0, 0.0, -9.81), 25.0) for i in range(n)]


def measure_resting_pad(tilt_rad: float, offset_m: float, force_n: float, contact_m: np.ndarray,
                        centre_of_pressure: bool = True, doubt: DoubtRule | None = None):
    """The pipeline's contact for a pad turned by ``tilt_rad`` about the tool's y axis and touching at
    ``contact_m``, ``offset_m`` along the pad's x axis from the face centre (world frame)."""
    body = Rotation.from_euler("y", tilt_rad)
    pivot = contact_m - body.apply([offset_m, 0.0, PIVOT_TO_FACE_M])
    pad = PadCalibration(compliance_m_per_n=0.0, spring_stiffness_nm_per_rad=K_NM_PER_RAD)
    pipeline = ContactPipeline(TiltedToolKinematics(pivot), pad, centre_of_pressure=centre_of_pressure, doubt=doubt)
    frame = ObjectFrame(np.eye(3), np.zeros(3))
    return pipeline.measure(press_readings(body, force_n), BASELINE_PA, np.zeros(3), frame,
                            approach_dir=np.array([0.0, 0.0, 1.0])), body


@pytest.mark.parametrize("tilt_deg, force_n", [(12.0, 1.5), (-20.0, 2.0), (30.0, 1.2)])
def test_the_centre_of_pressure_balances_the_spring_torque(tilt_deg, force_n):
    """Independent check: the force F n at the estimated point has the spring's torque about both axes."""
    rng = np.random.default_rng(int(abs(tilt_deg)))
    pivot_rotation = Rotation.random(random_state=rng.integers(1 << 30)).as_matrix()
    a, b = np.radians(tilt_deg), np.radians(0.4 * tilt_deg)
    rx, ry = Rotation.from_euler("x", a).as_matrix(), Rotation.from_euler("y", b).as_matrix()
    body = pivot_rotation @ rx @ ry
    normal = -body[:, 2]
    load = pad_load(pivot_rotation, normal, force_n, K_NM_PER_RAD, half_width_m=1.0)
    np.testing.assert_allclose(load.spring_angles_rad, [a, b], atol=1e-12)
    lever = load.offset_m - PIVOT_TO_FACE_M * normal
    torque = np.cross(lever, force_n * normal)
    assert torque @ pivot_rotation[:, 0] == pytest.approx(K_NM_PER_RAD * a, abs=1e-12)
    assert torque @ (pivot_rotation @ rx)[:, 1] == pytest.approx(K_NM_PER_RAD * b, abs=1e-12)
    assert abs(load.offset_m @ normal) < 1e-12  # in the face plane
    assert load.tilt_rad == pytest.approx(np.arccos(np.cos(a) * np.cos(b)))


def test_a_pad_resting_on_an_edge_is_measured_on_the_edge():
    """A straight edge along y through the origin; the pad rests on it 6 mm off its centre, turned by
    the angle whose spring torque that contact holds: k b = F u."""
    force, offset = 1.5, 0.006
    tilt = force * offset / K_NM_PER_RAD
    edge_point = np.zeros(3)
    measured, body = measure_resting_pad(tilt, offset, force, edge_point)
    distance_to_edge = np.linalg.norm(measured.position_m[[0, 2]])
    assert distance_to_edge < 2e-5
    before, _ = measure_resting_pad(tilt, offset, force, edge_point, centre_of_pressure=False)
    assert np.linalg.norm(before.position_m[[0, 2]]) == pytest.approx(offset, rel=1e-6)
    assert measured.quality.pad_uv_m[0] == pytest.approx(offset, rel=1e-6)
    assert measured.quality.rim_distance_m == pytest.approx(0.009 - offset, abs=1e-9)


@pytest.mark.parametrize("radius_m", [0.004, 0.01, 0.03])
def test_a_pad_tangent_to_a_cylinder_is_measured_on_the_cylinder(radius_m):
    """A cylinder along y, the pad tangent to it where its outward normal is the pad's."""
    force, offset = 2.0, 0.004
    tilt = force * offset / K_NM_PER_RAD
    normal = -Rotation.from_euler("y", tilt).apply([0.0, 0.0, 1.0])
    centre = np.array([0.01, 0.0, -0.05])
    tangent = centre + radius_m * normal
    measured, _ = measure_resting_pad(tilt, offset, force, tangent)
    off_surface = abs(np.linalg.norm((measured.position_m - centre)[[0, 2]]) - radius_m)
    before, _ = measure_resting_pad(tilt, offset, force, tangent, centre_of_pressure=False)
    off_before = abs(np.linalg.norm((before.position_m - centre)[[0, 2]]) - radius_m)
    assert off_surface < 2e-5
    assert off_before == pytest.approx(np.hypot(radius_m, offset) - radius_m, rel=1e-3)


def test_a_pad_on_its_rim_is_doubtful_and_a_flat_head_on_pad_is_not():
    force, offset = 1.5, 0.0085
    tilt = force * offset / K_NM_PER_RAD  # 36.5 deg: on the rim, well away from the approach
    rim, _ = measure_resting_pad(tilt, offset, force, np.zeros(3))
    assert rim.quality.doubtful
    flat, _ = measure_resting_pad(0.0, 0.0, force, np.zeros(3))
    assert not flat.quality.doubtful and flat.quality.rim_distance_m == pytest.approx(0.009)


def rocking_readings(body: Rotation, amplitude_rad: float, force_n: float = 1.5, n: int = 120,
                     dt_s: float = 0.01) -> list[Reading]:
    """A press whose pad rocks about ``body`` by +-``amplitude_rad`` (about the pad's x axis, a
    0.05 s period: whole periods in a 0.15 s window) for the whole hold."""
    pressure = BASELINE_PA + PadResponse().pressure_rise_pa(force_n)
    out = []
    for i in range(n):
        rock = Rotation.from_rotvec([amplitude_rad * np.sin(2 * np.pi * i * dt_s / 0.05), 0.0, 0.0])
        out.append(Reading(i * dt_s, pressure, tuple(wxyz_from_rotation(body * rock)), (0.0, 0.0, 0.0),
                           (0.0, 0.0, -9.81), 25.0))
    return out


def test_a_pad_that_rocks_is_a_doubtful_contact_only_with_the_loose_fallback():
    """Rocking by +-0.7 deg never passes the loop's 0.5 deg test: no contact without the fallback; with
    it a doubtful contact whose normal is the rocking's centre (the mean of the whole window). Rocking by +-3
    deg fails both."""
    from explorer.contact import LOOP_SETTLING, NoContactMeasured
    from explorer.loop import LoopConfig

    body = Rotation.from_euler("y", np.radians(5.0))
    pad = PadCalibration(compliance_m_per_n=0.0, spring_stiffness_nm_per_rad=K_NM_PER_RAD)
    frame = ObjectFrame(np.eye(3), np.zeros(3))
    strict = ContactPipeline(TiltedToolKinematics(np.zeros(3)), pad)
    with pytest.raises(NoContactMeasured, match="never settled"):
        strict.measure(rocking_readings(body, np.radians(0.7)), BASELINE_PA, np.zeros(3), frame)
    loose = ContactPipeline(TiltedToolKinematics(np.zeros(3)), pad,
                            loose_settling=LoopConfig().loose_settling(LOOP_SETTLING))
    measured = loose.measure(rocking_readings(body, np.radians(0.7)), BASELINE_PA, np.zeros(3), frame)
    assert measured.quality.loosely_settled and measured.quality.doubtful
    expected = -body.apply([0.0, 0.0, 1.0])
    assert np.degrees(np.arccos(np.clip(measured.normal @ expected, -1.0, 1.0))) < 0.15
    settled = loose.measure(press_readings(body, 1.5), BASELINE_PA, np.zeros(3), frame)
    assert not settled.quality.loosely_settled and not settled.quality.doubtful
    with pytest.raises(NoContactMeasured, match="1.50 deg"):
        loose.measure(rocking_readings(body, np.radians(3.0)), BASELINE_PA, np.zeros(3), frame)
    assert LoopConfig(loose_settle_deviation_rad=None).loose_settling(LOOP_SETTLING) is None


def test_a_soft_press_that_did_not_turn_the_pad_is_no_contact():
    """Below the side-contact force the pad must have turned (yielded by its spring) or the press
    met the pad's side: no contact. Without the test (teleoperation) a light press is a contact."""
    from explorer.contact import NoContactMeasured

    rule = DoubtRule(side_force_n=1.3, side_tilt_rad=np.radians(12.0))
    with pytest.raises(NoContactMeasured, match="side or corner"):
        measure_resting_pad(0.0, 0.0, 0.8, np.zeros(3), doubt=rule)
    assert measure_resting_pad(0.0, 0.0, 2.0, np.zeros(3), doubt=rule)[0].quality.force_n == pytest.approx(2.0)
    turned = 1.0 * 0.007 / K_NM_PER_RAD  # 20 deg: the pad yielded by turning onto its rim
    assert measure_resting_pad(turned, 0.007, 1.0, np.zeros(3), doubt=rule)[0].quality.doubtful
    assert measure_resting_pad(0.0, 0.0, 0.8, np.zeros(3))[0].quality.force_n == pytest.approx(0.8)


def test_a_press_that_reached_the_force_and_then_crept_is_a_contact():
    """A pad that creeps or cools after the press stopped on force reads less while the IMU
    settles; the side test looks at the press's peak, so such a press stays a contact."""
    from explorer.contact import NoContactMeasured

    rule = DoubtRule(side_force_n=1.3, side_tilt_rad=np.radians(12.0))
    pad = PadCalibration(compliance_m_per_n=0.0, spring_stiffness_nm_per_rad=K_NM_PER_RAD)
    pipeline = ContactPipeline(TiltedToolKinematics(np.array([0.0, 0.0, -PIVOT_TO_FACE_M])), pad, doubt=rule)
    frame = ObjectFrame(np.eye(3), np.zeros(3))
    peak, settled = press_readings(Rotation.identity(), 1.6)[:5], press_readings(Rotation.identity(), 1.1)
    crept = peak + [dataclasses.replace(r, t_s=r.t_s + 0.05) for r in settled]
    measured = pipeline.measure(crept, BASELINE_PA, np.zeros(3), frame, approach_dir=np.array([0.0, 0.0, 1.0]))
    assert measured.quality.force_n == pytest.approx(1.1, abs=0.05)  # settled: below the side force
    assert measured.quality.peak_force_n == pytest.approx(1.6, abs=0.05)
    with pytest.raises(NoContactMeasured, match="reached 1.1"):  # never above it: the pad's side
        pipeline.measure(press_readings(Rotation.identity(), 1.1), BASELINE_PA, np.zeros(3), frame)


@pytest.mark.parametrize("settled_n, released", [(0.06, True), (0.5, False)])
def test_a_press_whose_pad_let_go_before_it_settled_is_no_contact(settled_n, released):
    """Peak 1.6 N, then the pressure falls: below the detector's end threshold (50 Pa, the force of
    PadResponse's inverse there) the contact was over when the orientation settled."""
    from explorer.contact import NoContactMeasured, PressReleased

    pad = PadCalibration(compliance_m_per_n=0.0, spring_stiffness_nm_per_rad=K_NM_PER_RAD)
    kinematics = TiltedToolKinematics(np.array([0.0, 0.0, -PIVOT_TO_FACE_M]))
    frame = ObjectFrame(np.eye(3), np.zeros(3))
    peak, settled = press_readings(Rotation.identity(), 1.6)[:5], press_readings(Rotation.identity(), settled_n)
    readings = peak + [dataclasses.replace(r, t_s=r.t_s + 0.05) for r in settled]
    end_n = pad.force_model.force_estimate_n(50.0)
    assert 0.06 < end_n < 0.5  # the two cases straddle the threshold
    pipeline = ContactPipeline(kinematics, pad, release_threshold_pa=50.0)
    if released:
        with pytest.raises(PressReleased, match="let go"):
            pipeline.measure(readings, BASELINE_PA, np.zeros(3), frame)
        assert issubclass(PressReleased, NoContactMeasured)  # every caller already handles it
    else:
        assert pipeline.measure(readings, BASELINE_PA, np.zeros(3), frame).quality.force_n == pytest.approx(settled_n, abs=0.02)
    # without the test (teleoperation, sessions recorded before it) the same press is a contact
    assert ContactPipeline(kinematics, pad).measure(readings, BASELINE_PA, np.zeros(3), frame).quality.force_n < 1.0
    with pytest.raises(ValueError, match="release_threshold_pa"):
        ContactPipeline(kinematics, pad, release_threshold_pa=0.0)
    # a light press (0.6 N peak) that let go stays a press on the pad's side: its place is evidence
    light = press_readings(Rotation.identity(), 0.6)[:5] + [dataclasses.replace(r, t_s=r.t_s + 0.05) for r in
                                                           press_readings(Rotation.identity(), 0.0)]
    sided = ContactPipeline(kinematics, pad, doubt=DoubtRule(side_force_n=1.3), release_threshold_pa=50.0)
    with pytest.raises(NoContactMeasured, match="side or corner") as caught:
        sided.measure(light, BASELINE_PA, np.zeros(3), frame)
    assert not isinstance(caught.value, PressReleased)


def test_the_loop_releases_a_press_settled_below_its_own_contact_criterion():
    """The loop's release test asks the detector's start threshold (the rise that makes a contact);
    a press that peaked at 1.6 N and settled between the end and the start threshold is released by
    default and kept by the rule before 2026-11-27 (the end threshold)."""
    from explorer.contact import PressReleased
    from explorer.loop import LoopConfig
    from sensor.contact_detection import PressureDetectorConfig

    detector = PressureDetectorConfig()
    assert LoopConfig().release_threshold_pa(detector) == detector.start_threshold_pa
    assert LoopConfig(release_at_contact_threshold=False).release_threshold_pa(detector) == detector.end_threshold_pa
    assert LoopConfig(drop_released_presses=False).release_threshold_pa(detector) is None

    pad = PadCalibration(compliance_m_per_n=0.0, spring_stiffness_nm_per_rad=K_NM_PER_RAD)
    kinematics = TiltedToolKinematics(np.array([0.0, 0.0, -PIVOT_TO_FACE_M]))
    frame = ObjectFrame(np.eye(3), np.zeros(3))
    end_n = pad.force_model.force_estimate_n(detector.end_threshold_pa)
    start_n = pad.force_model.force_estimate_n(detector.start_threshold_pa)
    settled_n = 0.5 * (end_n + start_n)
    peak, settled = press_readings(Rotation.identity(), 1.6)[:5], press_readings(Rotation.identity(), settled_n)
    readings = peak + [dataclasses.replace(r, t_s=r.t_s + 0.05) for r in settled]
    with pytest.raises(PressReleased, match="let go"):
        ContactPipeline(kinematics, pad, release_threshold_pa=LoopConfig().release_threshold_pa(detector)).measure(
            readings, BASELINE_PA, np.zeros(3), frame)
    before = ContactPipeline(kinematics, pad,
                             release_threshold_pa=LoopConfig(release_at_contact_threshold=False).release_threshold_pa(detector))
    assert before.measure(readings, BASELINE_PA, np.zeros(3), frame).quality.force_n == pytest.approx(settled_n, abs=0.02)


def test_the_doubt_rule_needs_both_the_rim_and_an_oblique_approach():
    rule = DoubtRule(rim_margin_m=0.006, approach_angle_rad=np.radians(10.0))

    def quality(rim_m, approach_deg):
        return ContactQuality(1.5, 10, float(np.cos(np.radians(approach_deg))), rim_distance_m=rim_m)

    assert rule.doubtful(quality(0.002, 20.0))
    assert not rule.doubtful(quality(0.008, 20.0))
    assert not rule.doubtful(quality(0.002, 5.0))
    assert not rule.doubtful(ContactQuality(1.5, 10))  # no pad-load estimate


def test_realigns_stop_when_their_budget_is_spent():
    approach = np.array([0.0, 0.0, -1.0])
    oblique = Rotation.from_euler("x", 30, degrees=True).apply([0.0, 0.0, 1.0])
    doubtful = ContactQuality(1.5, 10, float(oblique @ -approach), rim_distance_m=0.001, doubtful=True)
    trusted = ContactQuality(1.5, 10, float(oblique @ -approach), rim_distance_m=0.008, doubtful=False)
    angle = np.radians(15.0)
    assert wants_realign(doubtful, oblique, approach, angle, realigns_so_far=9, max_realigns=10)
    assert not wants_realign(doubtful, oblique, approach, angle, realigns_so_far=10, max_realigns=10)
    assert not wants_realign(trusted, oblique, approach, angle, realigns_so_far=0, max_realigns=10)
    assert not wants_realign(doubtful, -approach, approach, angle, realigns_so_far=0, max_realigns=10)


def sphere_contacts(n: int, seed: int = 0):
    return exact_sphere_contacts(n, 0.05, seed)


def test_a_doubtful_normal_pulls_the_field_less():
    points, normals = sphere_contacts(30)
    wrong = Rotation.from_euler("x", 50, degrees=True).apply(normals[-1])
    normals_wrong = np.vstack([normals[:-1], wrong])
    bounds = ([-0.08] * 3, [0.08] * 3)
    trusting = GPIS(bounds=bounds).fit(points, normals_wrong)
    doubting = GPIS(bounds=bounds).fit(points, normals_wrong, normal_noise=np.r_[np.full(29, np.nan), 1.0])

    def angle_to_truth(gp):
        gradient = -gp.gradient(points[-1:])[0]
        return np.degrees(np.arccos(gradient @ normals[-1] / np.linalg.norm(gradient)))

    assert angle_to_truth(doubting) < 0.5 * angle_to_truth(trusting)


def test_added_and_fitted_noise_floors_give_one_field():
    points, normals = sphere_contacts(20, seed=1)
    floors = np.where(np.arange(20) % 3 == 0, 0.7, np.nan)
    bounds = ([-0.08] * 3, [0.08] * 3)
    fitted = GPIS(bounds=bounds).fit(points, normals, normal_noise=floors)
    added = GPIS(bounds=bounds)
    for p, n, floor in zip(points, normals, floors):
        added.add(p, n, normal_noise=None if np.isnan(floor) else floor)
    queries = np.random.default_rng(2).uniform(-0.06, 0.06, size=(50, 3))
    np.testing.assert_allclose(added.mean(queries), fitted.mean(queries), atol=1e-6)
    plain = GPIS(bounds=bounds).fit(points, normals)
    assert np.max(np.abs(plain.mean(queries) - fitted.mean(queries))) > 1e-5


def test_the_pad_calibration_keeps_the_spring_and_pad_size():
    pad = PadCalibration(spring_stiffness_nm_per_rad=0.031, half_width_m=0.0085)
    again = PadCalibration.from_dict(pad.as_dict())
    assert again.spring_stiffness_nm_per_rad == 0.031 and again.half_width_m == 0.0085
    assert PadCalibration.from_dict({}).spring_stiffness_nm_per_rad == PadCalibration().spring_stiffness_nm_per_rad
    with pytest.raises(ValueError, match="spring_stiffness_nm_per_rad"):
        PadCalibration(spring_stiffness_nm_per_rad=0.0)


def test_an_edged_shape_keeps_its_contacts_on_the_surface_and_realigns_within_budget(tmp_path):
    """A generated chamfered box (sharp edges and chamfers): the realigns stay within their budget,
    the contacts stay within the pad's reach of the truth, the centre of pressure is no worse than
    the pad centre on the same presses, and replay gives back the recorded contacts and flags."""
    import objects
    from explorer import ReplaySettings, RunSettings, SessionReplay, explore
    from explorer.contact_truth import contact_truth
    from explorer.recording import read_contacts_csv

    touches = 10
    run = explore(RunSettings(object="generated:chamfered_box/0", touches=touches, seed=1, eval_every=0,
                              mesh_resolution=24, reach_samples=0), tmp_path / "run")
    kinds = [r.kind for r in run.records]
    assert kinds.count("realign") <= int(0.1 * touches)
    contacts = [r for r in run.records if r.kind == "contact"]
    assert len(contacts) >= 3
    flags = np.loadtxt(tmp_path / "run" / "contacts.csv", delimiter=",", skiprows=1, ndmin=2)[:, -1]
    assert flags.tolist() == [float(r.quality.doubtful) for r in contacts]
    assert run.metrics["doubtful"] == int(flags.sum())

    model = objects.load("generated:chamfered_box/0")
    points, normals = read_contacts_csv(tmp_path / "run" / "contacts.csv")
    truth = contact_truth(points, normals, model.mesh, model.sharp_edges, samples=5000)
    rms = float(np.sqrt(np.mean(truth.position_error_m ** 2)))
    assert rms < 0.003 and truth.position_error_m.max() < model_half_pad()

    replay = SessionReplay(tmp_path / "run")
    again = replay.run(ReplaySettings(figures=False))
    assert again.notes == []
    np.testing.assert_array_equal(again.points_m, points)
    assert [t.quality.doubtful for t in again.contacts] == [r.quality.doubtful for r in contacts]
    replay.pipeline.centre_of_pressure = False
    centre = replay.run(ReplaySettings(figures=False))
    centre_truth = contact_truth(centre.points_m, centre.normals, model.mesh, model.sharp_edges, samples=5000)
    assert rms <= float(np.sqrt(np.mean(centre_truth.position_error_m ** 2))) + 3e-4

    # The analysis replays with another pad compliance: each contact moves out along its normal by
    # force x the difference, which the signed offset from the surface shows.
    from scripts.contact_quality import analyse, run_contacts

    name, rows = run_contacts(tmp_path / "run", "recorded", compliance_m_per_n=0.0)
    stiff = analyse(name, rows)
    soft = analyse(*run_contacts(tmp_path / "run", "recorded", compliance_m_per_n=2e-3))
    moved = [(b["offset_mm"] - a["offset_mm"]) / (2.0 * a["force_n"]) for a, b in zip(stiff, soft) if a["kind"] == "contact"]
    assert len(moved) >= 3 and np.median(moved) == pytest.approx(1.0, abs=0.1)  # mm per (N x mm/N)


def test_the_signed_offset_is_positive_outside_the_surface_and_negative_inside():
    import trimesh

    from explorer.contact_truth import contact_truth

    box = trimesh.creation.box(extents=(0.1, 0.1, 0.1))
    points = np.array([[0.0, 0.0, 0.052], [0.0, 0.0, 0.047], [0.051, 0.02, 0.0], [0.0, -0.049, 0.01]])
    normals = np.array([[0.0, 0.0, 1.0], [0.0, 0.0, 1.0], [1.0, 0.0, 0.0], [0.0, -1.0, 0.0]])
    truth = contact_truth(points, normals, box, np.zeros((0, 2, 3)), samples=2000)
    np.testing.assert_allclose(truth.offset_m, [0.002, -0.003, 0.001, -0.001], atol=1e-9)
    np.testing.assert_allclose(np.abs(truth.offset_m), truth.position_error_m)


def model_half_pad() -> float:
    """A contact further than the pad's half width from the truth is not on the pad at all."""
    return 0.009


def test_the_analysis_script_refuses_a_directory_without_a_run(tmp_path, capsys):
    from scripts.contact_quality import main

    with pytest.raises(SystemExit) as exit_info:
        main([str(tmp_path)])
    assert exit_info.value.code == 2
    assert "not a run directory" in capsys.readouterr().err
    with pytest.raises(SystemExit) as exit_info:
        main([str(tmp_path), "--compliance", "0.136"])
    assert exit_info.value.code == 2
    assert "--compliance needs --replay" in capsys.readouterr().err


def test_the_analysis_bins_by_distance_past_the_target_incidence_and_force(monkeypatch):
    """On a 10 cm box with hand-placed contacts: the distance past the target along the approach,
    the angle between the approach and the true normal, the peak force over the press force, and
    each bin's share of the squared position error, all known in closed form."""
    import trimesh

    import objects
    from scripts.contact_quality import analyse, binned

    box = trimesh.creation.box(extents=(0.1, 0.1, 0.1))
    monkeypatch.setattr(objects, "load", lambda name, **_: type("Model", (), {"mesh": box, "sharp_edges": np.zeros((0, 2, 3))})())
    down = np.array([0.0, 0.0, -1.0])
    tilted = np.array([np.sin(np.radians(50.0)), 0.0, -np.cos(np.radians(50.0))])   # 50 deg off the top's normal
    rows = [  # (surface point, approach, target, peak force): the top face z = 0.05 m
        (np.array([0.0, 0.0, 0.051]), down, np.array([0.0, 0.0, 0.056]), 1.6),    # 5 mm past, head on, 1 mm out
        (np.array([0.01, 0.0, 0.053]), tilted, np.array([0.01, 0.0, 0.053]) - 0.03 * tilted, 1.2),  # 30 mm past, 3 mm out
    ]
    table = analyse("box", [dict(index=i, kind="contact", strategy="variance", position_m=p, normal=np.array([0.0, 0.0, 1.0]),
                                 quality=dict(peak_force_n=f, force_n=f), target_m=t, approach_dir=a, press_force_n=1.5)
                            for i, (p, a, t, f) in enumerate(rows)])
    assert [r["past_target_mm"] for r in table] == pytest.approx([5.0, 30.0])
    assert [r["incidence_deg"] for r in table] == pytest.approx([0.0, 50.0])
    assert [r["force_ratio"] for r in table] == pytest.approx([1.6 / 1.5, 1.2 / 1.5])
    past = binned(table, "past_target_mm", (-np.inf, 9, 20, 40, np.inf))
    assert [r["n"] for r in past] == [1, 0, 1, 0] and past[0]["bin"] == "< 9" and past[3]["bin"] == ">= 40"
    assert past[0]["error_share"] == pytest.approx(1.0 / 10.0) and past[2]["error_share"] == pytest.approx(9.0 / 10.0)
    assert past[2]["position_rms_mm"] == pytest.approx(3.0)
    # a touch without its target or approach (teleoperation) is in no bin of those two
    bare = analyse("box", [dict(index=0, kind="contact", strategy="teleop", position_m=rows[0][0],
                                normal=np.array([0.0, 0.0, 1.0]), quality={}, target_m=None, approach_dir=None)])
    assert np.isnan(bare[0]["past_target_mm"]) and np.isnan(bare[0]["incidence_deg"]) and np.isnan(bare[0]["force_ratio"])
    assert sum(r["n"] for r in binned(bare, "past_target_mm", (-np.inf, 9, np.inf))) == 0
