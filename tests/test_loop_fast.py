"""The exploration loop's logic on in-memory fakes (tests/fakes.py): no simulator, milliseconds.

A scripted strategy asks for two head-on touches, an oblique one (the loop must set it aside and
repeat it along the measured normal: the point pad's contacts are all doubtful when oblique, and
the realign budget is the whole budget), one beside the sphere (a miss that sweeps free space)
and one the planner cannot reach.
"""
from dataclasses import replace

import numpy as np
import pytest

from explorer.loop import ExplorationLoop, LoopConfig
from explorer.recording import RunRecorder, read_contacts_csv
from explorer.resume import load_recorded_run
from explorer.session import read_session
from explorer.touch import Touch
from fakes import FakePlanner, ScriptedStrategy, sphere_rig
from reconstruction.gpis import GPIS

RADIUS_M = 0.04


def scripted_touches(radius_m: float = RADIUS_M) -> list[Touch]:
    oblique = np.array([-np.sin(np.radians(40.0)), 0.0, -np.cos(np.radians(40.0))])
    return [
        Touch(np.array([radius_m, 0.0, 0.0]), np.array([-1.0, 0.0, 0.0]), strategy="scripted"),
        Touch(np.array([0.0, -radius_m, 0.0]), np.array([0.0, 1.0, 0.0]), strategy="scripted"),
        Touch(np.array([0.0, 0.0, radius_m]), oblique, strategy="scripted"),
        Touch(np.array([0.0, 1.25 * radius_m, 0.0]), np.array([-1.0, 0.0, 0.0]), strategy="scripted"),
        Touch(np.array([0.0, 0.0, -radius_m]), np.array([0.0, 0.0, 1.0]), strategy="scripted"),
    ]


@pytest.fixture
def finished(tmp_path):
    world, rig = sphere_rig(RADIUS_M)
    planner = FakePlanner(rig.positioner, unreachable=lambda target: target[2] < -0.5 * RADIUS_M)
    gpis = GPIS(bounds=rig.prior.bounds())
    recorder = RunRecorder(tmp_path, dict(rig.description, seed=0, configuration={}))
    loop = ExplorationLoop(rig, planner, ScriptedStrategy(scripted_touches()), gpis,
                           LoopConfig(touches=6, proposal_rounds=1, max_realign_fraction=1.0,
                                      doubt_rim_margin_m=1.0, repress_force_n=0.0), recorder)
    records = loop.run()
    recorder.close()
    return loop, records, tmp_path


def test_touches_misses_realigns_and_unreachable_targets_are_told_apart(finished):
    loop, records, _ = finished
    assert [r.kind for r in records] == ["contact", "contact", "realign", "contact", "miss", "unreachable"]
    assert [r.strategy for r in records[:4]] == ["scripted", "scripted", "scripted", "realign"]
    repeat = records[3]
    np.testing.assert_allclose(repeat.approach_dir, -records[2].normal, atol=1e-12)


def test_contacts_lie_on_the_sphere_with_radial_normals(finished):
    loop, records, _ = finished
    for record in records:
        if record.kind not in ("contact", "realign"):
            continue
        assert abs(np.linalg.norm(record.position_m) - RADIUS_M) < 1e-9
        np.testing.assert_allclose(record.normal, record.position_m / RADIUS_M, atol=1e-9)
        assert record.quality.force_n == pytest.approx(record.contact.force_n)
        assert record.baseline_pa is not None


def test_the_realign_is_set_aside_and_only_contacts_reach_the_gpis(finished):
    loop, records, _ = finished
    assert loop.gpis.n_contacts == 3
    oblique = records[2]
    assert oblique.quality.approach_angle_rad > loop.config.realign_angle_rad
    assert records[3].quality.approach_angle_rad < 1e-6


def test_a_miss_sweeps_free_space_outside_the_sphere(finished):
    loop, records, _ = finished
    miss = records[4]
    assert miss.free_space_m is not None and len(miss.free_space_m) > 0
    assert np.all(np.linalg.norm(miss.free_space_m, axis=1) > RADIUS_M)
    lo, hi = loop.gpis.bounds
    assert np.all((miss.free_space_m > lo) & (miss.free_space_m < hi))


def test_the_recording_holds_every_touch_and_the_contacts(finished):
    loop, records, out = finished
    points, normals = read_contacts_csv(out / "contacts.csv")
    contacts = [r for r in records if r.kind == "contact"]
    np.testing.assert_array_equal(points, [r.position_m for r in contacts])
    np.testing.assert_array_equal(normals, [r.normal for r in contacts])
    session = read_session(out / "session")
    results = [e.fields["result"] for e in session.events if "result" in e.fields]
    assert results == [r.kind for r in records]
    assert len(session.contacts) == len(contacts)
    assert len(session.readings) > 0 and len(session.joint_states) > 0


class SwervingPlanner(FakePlanner):
    """Plans the fake's straight line, but the joints (the fake's pad) drift sideways (+z) once
    they are ``after_m`` along it, ``slope`` metres per metre: an arm pushed around the object."""

    def __init__(self, positioner, after_m: float = 0.02, slope: float = 1.0):
        super().__init__(positioner)
        self.after_m, self.slope = after_m, slope

    def plan(self, touch, seed_q=None, touched_m=None):
        plan = super().plan(touch, seed_q, touched_m)
        along = (plan.path_world_m - plan.path_world_m[0]) @ plan.approach_world
        drift = self.slope * np.clip(along - self.after_m, 0.0, None)
        return replace(plan, path_q=plan.path_world_m + drift[:, None] * np.array([0.0, 0.0, 1.0]))


@pytest.mark.parametrize("tolerance_m, stop", [(0.005, False), (0.005, True), (None, False)])
def test_a_miss_pushed_off_its_line_claims_only_the_line_it_followed(tmp_path, tolerance_m, stop):
    """A miss beside the sphere whose pad leaves the planned line 20 mm after the standoff. With
    ``line_tolerance_m`` the tick it is that far off is logged (``left_line``) and the miss's free
    space ends the pad's half width before that point, whether the approach goes on to its end or
    (``stop_off_line``) stops there; without (the loop before), the whole line is recorded as free
    although the pad never followed it past 20 mm. The touch records where the pad left its line
    (``left_line_m``, object frame), and resume reads it back."""
    _, rig = sphere_rig(RADIUS_M)
    planner = SwervingPlanner(rig.positioner)
    touch = Touch(np.array([0.0, 1.25 * RADIUS_M, 0.0]), np.array([-1.0, 0.0, 0.0]), strategy="scripted")
    recorder = RunRecorder(tmp_path, dict(rig.description, seed=0, configuration={}))
    config = LoopConfig(touches=1, proposal_rounds=1, line_tolerance_m=tolerance_m, stop_off_line=stop)
    loop = ExplorationLoop(rig, planner, ScriptedStrategy([touch]), GPIS(bounds=rig.prior.bounds()), config, recorder)
    [record] = loop.run()
    recorder.close()
    assert record.kind == "miss"
    plan = planner.plan(touch)
    line_along = (record.free_space_m - touch.target_m) @ touch.approach_dir
    full = (plan.path_world_m[-1] - plan.target_world_m) @ plan.approach_world
    left = [e for e in read_session(tmp_path / "session").events if e.kind == "left_line"]
    [restored] = load_recorded_run(tmp_path).touches
    if tolerance_m is None:
        assert not left and line_along.max() == pytest.approx(full, abs=1e-9)
        assert record.left_line_m is None and restored.left_line_m is None
        return
    assert len(left) == 1 and tolerance_m < left[0].fields["lateral_m"] < tolerance_m + 0.001
    offset = record.left_line_m - touch.target_m
    lateral = np.linalg.norm(offset - (offset @ touch.approach_dir) * touch.approach_dir)
    assert lateral == pytest.approx(left[0].fields["lateral_m"], abs=1e-9)
    np.testing.assert_array_equal(restored.left_line_m, record.left_line_m)
    standoff_along = (plan.path_world_m[0] - plan.target_world_m) @ plan.approach_world
    departure_along = standoff_along + planner.after_m + tolerance_m / planner.slope
    assert line_along.max() <= departure_along + config.free_space_value + 1e-9
    assert line_along.max() < full - 0.01
    assert (left[0].t_s < record.press_t_s[1] - 0.5) != stop   # stopped at once, or went on along its path


def test_a_restored_loop_has_the_field_of_the_finished_one(finished):
    loop, records, _ = finished
    _, rig = sphere_rig(RADIUS_M)
    fresh = ExplorationLoop(rig, FakePlanner(rig.positioner), ScriptedStrategy([]), GPIS(bounds=rig.prior.bounds()),
                            LoopConfig(touches=6))
    fresh.restore(records)
    points = np.random.default_rng(0).uniform(*loop.gpis.bounds, size=(100, 3))
    np.testing.assert_allclose(fresh.gpis.mean(points), loop.gpis.mean(points), rtol=0, atol=1e-12)


def test_a_miss_held_back_short_of_its_line_sweeps_only_what_the_pad_passed(finished):
    """Another link met the object and held the arm back: the pad never reached the line's end, so
    free space stops the pad's half width behind where it stopped; a full miss sweeps the line."""
    from explorer.planner import ApproachPlan
    from explorer.positioner import StandPose

    loop, _, _ = finished
    line = np.column_stack([np.zeros(7), np.zeros(7), np.linspace(0.1, 0.04, 7)])   # 1 cm steps, down
    plan = ApproachPlan(Touch(line[3], np.array([0.0, 0.0, -1.0])), StandPose(), line[3],
                        np.array([0.0, 0.0, -1.0]), line, line)
    np.testing.assert_array_equal(loop._swept(plan, line[-1]), line)
    held = loop._swept(plan, np.array([0.0, 0.0, 0.065]))                # stopped 3.5 cm along
    np.testing.assert_array_equal(held, line[:3])
    assert held[-1, 2] - 0.065 >= -loop.config.free_space_value


def test_a_probe_through_a_guessed_surface_is_remembered_and_a_restore_keeps_it():
    """The pad went 45 mm past where the strategy expected the surface: the line it passed (up to a
    pad's half width before the contact) is kept for the strategy, after a resume too."""
    world, rig = sphere_rig(RADIUS_M)
    guessed = Touch(np.array([0.0, 0.0, RADIUS_M + 0.045]), np.array([0.0, 0.0, -1.0]), strategy="scripted",
                    depth_m=0.08)
    loop = ExplorationLoop(rig, FakePlanner(rig.positioner), ScriptedStrategy(scripted_touches()[:2] + [guessed]),
                           GPIS(bounds=rig.prior.bounds()), LoopConfig(touches=3, proposal_rounds=1,
                                                                       repress_force_n=0.0))
    records = loop.run()
    assert [r.kind for r in records] == ["contact", "contact", "contact"]
    passed = np.array(loop.state.passed_m)
    assert len(passed) >= 3
    assert np.all(passed[:, 2] >= RADIUS_M - loop.config.free_space_value - 1e-9)
    assert np.all(passed[:, 2] <= guessed.target_m[2] + 1e-12)
    _, fresh_rig = sphere_rig(RADIUS_M)
    fresh = ExplorationLoop(fresh_rig, FakePlanner(fresh_rig.positioner), ScriptedStrategy([]),
                            GPIS(bounds=fresh_rig.prior.bounds()), LoopConfig(touches=3))
    fresh.restore(records)
    np.testing.assert_array_equal(np.array(fresh.state.passed_m), passed)



def _a_probe_past_the_guessed_surface():
    """Two recorded contacts near the sphere's +x face: head-on at the face, and one from above
    whose approach line ends 4 mm inside the sphere's radius, where the field of the first alone
    puts surface nearer than the pad allows."""
    from explorer.touch import TouchOutcome

    x = np.array([1.0, 0.0, 0.0])
    first = TouchOutcome(0, "contact", np.array([RADIUS_M, 0.0, 0.0]), -x, position_m=np.array([RADIUS_M, 0.0, 0.0]),
                         normal=x, strategy="scripted")
    inside = RADIUS_M - 0.004
    second = TouchOutcome(1, "contact", np.array([inside, 0.0, 0.05]), np.array([0.0, 0.0, -1.0]),
                          position_m=np.array([inside, 0.0, 0.0]), normal=np.array([0.0, 0.0, 1.0]), strategy="scripted")
    return first, second


def test_the_reconstruction_adds_the_swept_free_space_and_the_loops_field_does_not():
    """Two recorded contacts near the sphere's +x face; the end of the second touch's approach line
    lies where the field puts surface nearer than the pad allows (about -6 mm against the -9 mm
    bound at its last point; a probe past a guessed surface). A restored loop's
    field (the strategy's) has the contacts' rows only, whatever ``swept_free_space``; the
    reconstruction's field adds rows for that line, equal to the evidence built directly."""
    from explorer.evidence import SurfaceEvidence, with_swept_free_space

    first, second = _a_probe_past_the_guessed_surface()
    _, rig = sphere_rig(RADIUS_M)
    config = LoopConfig(touches=2)
    assert config.swept_free_space
    fresh = ExplorationLoop(rig, FakePlanner(rig.positioner), ScriptedStrategy([]), GPIS(bounds=rig.prior.bounds()),
                            config)
    fresh.restore([first, second])
    assert fresh.gpis.n_rows == 8
    field, rows = with_swept_free_space(fresh.gpis, fresh.records, config.free_space_value, config.free_space_noise)
    assert fresh.gpis.n_rows == 8 and rows > 0 and field.n_rows == 8 + rows
    direct = SurfaceEvidence(GPIS(bounds=rig.prior.bounds()), config.free_space_value, config.free_space_noise)
    for record in (first, second):
        direct.add_contact(record.position_m, record.normal)
    direct.add_swept(np.vstack([r.swept_points(-config.free_space_value) for r in (first, second)]))
    points = np.random.default_rng(0).uniform(*fresh.gpis.bounds, size=(100, 3))
    np.testing.assert_allclose(field.mean(points), direct.gpis.mean(points), rtol=0, atol=1e-12)
    line = second.swept_points(-config.free_space_value)
    solid = fresh.gpis.mean(line) > config.free_space_value   # where the rows went
    assert solid.sum() == rows
    assert np.all(field.mean(line[solid]) < fresh.gpis.mean(line[solid]))   # pushed out along the probe


def test_the_reconstruction_holds_the_swept_line_firmer_than_the_loops_free_space():
    """The two contacts of the test above: the reconstruction's rows on the second touch's line
    (``LoopConfig.reconstruction_field``) have ``reconstruction_free_space_noise``, firmer than
    the loop's ``free_space_noise``, so they hold the field further out on that line than rows at
    the loop's noise (the reconstruction of sessions recorded before, ``None``) on the same points.
    Without ``swept_free_space`` the loop's field is meshed as it is."""
    from explorer.evidence import with_swept_free_space

    first, second = _a_probe_past_the_guessed_surface()
    _, rig = sphere_rig(RADIUS_M)
    config = LoopConfig(touches=2)
    assert config.reconstruction_free_space_noise < config.free_space_noise
    loop = ExplorationLoop(rig, FakePlanner(rig.positioner), ScriptedStrategy([]), GPIS(bounds=rig.prior.bounds()),
                           config)
    loop.restore([first, second])
    firm, rows = config.reconstruction_field(loop.gpis, loop.records, rig.pad)
    legacy_config = replace(config, reconstruction_free_space_noise=None)
    legacy, legacy_rows = legacy_config.reconstruction_field(loop.gpis, loop.records, rig.pad)
    assert rows == legacy_rows > 0   # the same gate, the same points
    line = second.swept_points(-config.free_space_value)
    solid = loop.gpis.mean(line) > config.free_space_value
    assert np.all(firm.mean(line[solid]) < legacy.mean(line[solid]))
    same, _ = with_swept_free_space(loop.gpis, loop.records, config.free_space_value, config.free_space_noise)
    points = np.random.default_rng(1).uniform(*loop.gpis.bounds, size=(50, 3))
    np.testing.assert_allclose(legacy.mean(points), same.mean(points), rtol=0, atol=1e-12)
    off, off_rows = replace(config, swept_free_space=False).reconstruction_field(loop.gpis, loop.records, rig.pad)
    assert off is loop.gpis and off_rows == 0


def test_the_reconstruction_offers_the_misses_free_space_through_the_gate_instead_of_the_loops_rows():
    """The two contacts of the tests above and a miss beside the sphere. The loop's field holds the
    miss's rows; the reconstruction (``reconstruction_gates_misses``) is that field rebuilt from the
    records without them, plus the gated rows of the swept lines and of the miss. Sessions recorded
    before the setting mesh the loop's field plus the swept rows, as they did."""
    from explorer.evidence import with_swept_free_space
    from explorer.touch import TouchOutcome

    first, second = _a_probe_past_the_guessed_surface()
    line = np.column_stack([np.zeros(6), np.linspace(-0.058, -0.033, 6), np.zeros(6)])
    miss = TouchOutcome(2, "miss", line[0], np.array([0.0, 1.0, 0.0]), free_space_m=line, strategy="scripted")
    _, rig = sphere_rig(RADIUS_M)
    config = LoopConfig(touches=3)
    assert config.reconstruction_gates_misses
    loop = ExplorationLoop(rig, FakePlanner(rig.positioner), ScriptedStrategy([]), GPIS(bounds=rig.prior.bounds()),
                           config)
    loop.restore([first, second, miss])
    assert loop.gpis.n_rows == 8 + len(line)
    field, rows = config.reconstruction_field(loop.gpis, loop.records, rig.pad)
    assert loop.gpis.n_rows == 8 + len(line)   # the loop's field is left as it is
    contacts_only = config.evidence(GPIS(bounds=rig.prior.bounds()))
    for record in (first, second):
        contacts_only.add_contact(record.position_m, record.normal)
    direct, direct_rows = with_swept_free_space(contacts_only.gpis, loop.records, config.free_space_value,
                                                config.reconstruction_free_space_noise, misses=True)
    assert rows == direct_rows and field.n_rows == 8 + rows
    points = np.random.default_rng(2).uniform(*loop.gpis.bounds, size=(100, 3))
    np.testing.assert_allclose(field.mean(points), direct.mean(points), rtol=0, atol=1e-12)
    legacy_config = replace(config, reconstruction_gates_misses=False)
    legacy, legacy_rows = legacy_config.reconstruction_field(loop.gpis, loop.records, rig.pad)
    same, same_rows = with_swept_free_space(loop.gpis, loop.records, config.free_space_value,
                                            config.reconstruction_free_space_noise)
    assert legacy_rows == same_rows and legacy.n_rows == 8 + len(line) + same_rows
    np.testing.assert_allclose(legacy.mean(points), same.mean(points), rtol=0, atol=1e-12)
    # the contacts' field has the whole line 25-55 mm outside; the loop's rows hold it near -9 mm
    assert np.all(field.mean(line) < config.free_space_value - 0.01)
    assert np.all(legacy.mean(line) > field.mean(line) + 0.01)


def test_a_surface_at_the_very_end_of_the_line_is_still_pressed():
    """The sphere lies 0.4 mm before the end of the touch's depth: the press needs the planner's
    reserve beyond it. Without one (as before the reserve) the pad stops short of the press force
    (on the simulated arm, a press the side-press rule then rejects)."""
    from explorer.planner import PlannerConfig

    at_end = Touch(np.array([0.0, 0.0, RADIUS_M + 0.0196]), np.array([0.0, 0.0, -1.0]), strategy="scripted",
                   depth_m=0.02)
    loop_config = LoopConfig(touches=1, proposal_rounds=1, repress_force_n=0.0)

    def run(reserve_m):
        world, rig = sphere_rig(RADIUS_M)
        planner = FakePlanner(rig.positioner)
        loop = ExplorationLoop(rig, planner, ScriptedStrategy([at_end]), GPIS(bounds=rig.prior.bounds()), loop_config)
        planner.config = replace(planner.config, press_reserve_m=reserve_m)  # past the loop's own check
        return loop.run()[0]

    reserved, cut_short = run(PlannerConfig().press_reserve_m), run(0.0)
    assert reserved.kind == cut_short.kind == "contact"
    assert reserved.quality.peak_force_n >= loop_config.press_force_n > cut_short.quality.peak_force_n
    too_short = replace(PlannerConfig(), press_reserve_m=1.5 * loop_config.press_depth_m)
    world, rig = sphere_rig(RADIUS_M)
    with pytest.raises(ValueError, match="press_reserve_m"):
        ExplorationLoop(rig, FakePlanner(rig.positioner, config=too_short), ScriptedStrategy([at_end]),
                        GPIS(bounds=rig.prior.bounds()), loop_config)


def test_a_press_that_looks_like_one_on_the_pads_side_is_pressed_on_and_kept_if_it_reaches_the_force():
    """The side-contact force set between the press force and the second press's: the first press
    of each head-on touch ends below it (a soft pad whose depth ran out), so the side test would
    throw it away. Pressed on, the second press reaches it and the contact is kept, measured from
    that press; without ``repress_side_contacts`` both are side presses, as before."""
    def run(repress_side_contacts):
        world, rig = sphere_rig(RADIUS_M)
        config = LoopConfig(touches=2, proposal_rounds=1, press_force_n=1.5, repress_force_n=3.0,
                            side_contact_force_n=2.2, side_contact_tilt_rad=np.pi,
                            repress_side_contacts=repress_side_contacts)
        loop = ExplorationLoop(rig, FakePlanner(rig.positioner), ScriptedStrategy(scripted_touches()[:2]),
                               GPIS(bounds=rig.prior.bounds()), config)
        return loop.run()

    pressed_on, thrown_away = run(True), run(False)
    assert [r.kind for r in thrown_away] == ["no_normal", "no_normal"]
    assert all(r.repress_t_s is None for r in thrown_away)
    assert [r.kind for r in pressed_on] == ["contact", "contact"]
    for record in pressed_on:
        assert record.repress_t_s is not None and record.contact.t_s > record.repress_t_s
        assert record.quality.peak_force_n >= 2.2
        assert abs(np.linalg.norm(record.position_m) - RADIUS_M) < 1e-9


def test_side_presses_are_pressed_on_only_where_the_depth_is_too_short_for_the_pads_compliance():
    """1.3 N on one corner of a pad that sinks c m/N flat takes 1.3 x 4 x c of travel: the 2 mm
    depth covers the default simulated pad (0.136 mm/N: 0.71 mm) and the nominal hardware pad (0.33
    mm/N: 1.7 mm), not the hardware-like one (0.76 mm/N: 4.0 mm). An explicit setting wins."""
    config = LoopConfig()
    assert config.repress_side_contacts is None and config.press_depth_m == 0.002
    assert not config.presses_on_side_contacts(0.136e-3)
    assert not config.presses_on_side_contacts(0.33e-3)
    assert config.presses_on_side_contacts(0.76e-3)
    assert config.presses_on_side_contacts(0.40e-3) and not config.presses_on_side_contacts(0.38e-3)  # 2 mm / 5.2 N
    assert replace(config, press_depth_m=0.005).presses_on_side_contacts(0.76e-3) is False
    assert replace(config, repress_side_contacts=True).presses_on_side_contacts(0.0)
    assert not replace(config, repress_side_contacts=False).presses_on_side_contacts(1.0)


def test_a_press_on_the_pads_side_tells_the_gpis_where_the_pad_was_and_a_resume_keeps_it(tmp_path):
    """A press that never reaches the side-press force (here set out of reach) gives no normal; the
    pad-face centre is kept (``side_m``: in the recording, after a resume) and becomes one value row
    of the GPIS, held back until the first contact."""
    from explorer.resume import load_recorded_run

    world, rig = sphere_rig(RADIUS_M)
    config = LoopConfig(touches=2, proposal_rounds=1, repress_force_n=0.0, side_contact_force_n=100.0,
                        side_contact_tilt_rad=np.pi)
    recorder = RunRecorder(tmp_path, dict(rig.description, seed=0, configuration={}))
    touches = scripted_touches()[:2]
    loop = ExplorationLoop(rig, FakePlanner(rig.positioner), ScriptedStrategy(touches), GPIS(bounds=rig.prior.bounds()),
                           config, recorder)
    records = loop.run()
    recorder.close()
    assert [r.kind for r in records] == ["no_normal", "no_normal"]
    assert loop.gpis.n_rows == 0
    for record, touch in zip(records, touches):
        # the pad pressed into the sphere at the target: its centre lies on the target's ray, at
        # most the press depth inside the surface
        direction = record.side_m / np.linalg.norm(record.side_m)
        np.testing.assert_allclose(direction, touch.target_m / RADIUS_M, atol=1e-9)
        assert RADIUS_M - config.press_depth_m - 1e-9 <= np.linalg.norm(record.side_m) <= RADIUS_M
    recorded = load_recorded_run(tmp_path).touches
    np.testing.assert_array_equal([r.side_m for r in recorded], [r.side_m for r in records])
    _, fresh_rig = sphere_rig(RADIUS_M)
    fresh = ExplorationLoop(fresh_rig, FakePlanner(fresh_rig.positioner), ScriptedStrategy([]),
                            GPIS(bounds=fresh_rig.prior.bounds()), config)
    fresh.restore(recorded)
    top = np.array([0.0, 0.0, RADIUS_M])
    for evidence in (loop.evidence, fresh.evidence):   # the first contact brings in the side rows
        evidence.add_contact(top, np.array([0.0, 0.0, 1.0]))
        assert evidence.gpis.n_rows == 4 + len(records)
    side = np.array([r.side_m for r in records])
    np.testing.assert_allclose(fresh.gpis.mean(side), loop.gpis.mean(side), rtol=0, atol=1e-12)
    assert np.all(np.abs(loop.gpis.mean(side) - config.side_press_value) < config.side_press_noise)
