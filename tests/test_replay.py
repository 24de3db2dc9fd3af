"""Offline replay of a recorded exploration: exact reproduction, new thresholds, cut-off sessions."""
import json
import shutil

import numpy as np
import pytest

from explorer.loop import LoopConfig
from explorer.recording import read_contacts_csv
from explorer.replay import ReplaySettings, SessionReplay, press_spans, replay
from explorer.run import RunSettings, explore
from explorer.session import read_session


@pytest.fixture(scope="module")
def sphere_run(recorded_sphere_run):
    return recorded_sphere_run


@pytest.fixture(scope="module")
def session(sphere_run):
    return SessionReplay(sphere_run.out_dir / "session")


@pytest.fixture(scope="module")
def recorded_replay(session):
    return session.run(ReplaySettings(figures=False))


def test_recorded_settings_reproduce_the_contacts(sphere_run, recorded_replay):
    points, normals = read_contacts_csv(sphere_run.out_dir / "contacts.csv")
    assert len(points) == sphere_run.metrics["contacts"] >= 4
    assert [t.index for t in recorded_replay.contacts] == [r.index for r in sphere_run.records if r.kind == "contact"]
    np.testing.assert_allclose(recorded_replay.points_m, points, rtol=0, atol=1e-9)
    np.testing.assert_allclose(recorded_replay.normals, normals, rtol=0, atol=1e-9)
    recorded = read_session(sphere_run.out_dir / "session").contacts
    for replayed, original in zip(recorded_replay.contacts, recorded):  # world frame, readings used
        assert replayed.contact.t_s == original.t_s
        assert len(replayed.contact.readings) == len(original.readings)
        np.testing.assert_allclose(replayed.contact.position_m, original.position_m, rtol=0, atol=1e-9)


def test_recorded_settings_reproduce_the_reconstruction(sphere_run, recorded_replay):
    rng = np.random.default_rng(0)
    samples = rng.uniform(-0.07, 0.07, size=(2000, 3))
    np.testing.assert_allclose(recorded_replay.gpis.mean(samples), sphere_run.gpis.mean(samples),
                               rtol=0, atol=1e-6)


def test_press_spans_split_at_free_moves():
    tick = 1 / 120
    dense = lambda t0, n: t0 + tick * np.arange(n)  # noqa: E731
    t = np.concatenate([dense(0.0, 50), [0.9], dense(2.0, 30), dense(2.0 + 30 * tick + tick, 20)])
    spans = press_spans(t)
    assert [(s.first, s.last) for s in spans] == [(0, 49), (51, 100)]  # a two-tick gap is no split
    assert spans[1].t_start_s == 2.0


def test_a_higher_start_threshold_starts_later_on_a_larger_rise(session, recorded_replay):
    raised = session.run(ReplaySettings(start_threshold_pa=200.0, figures=False))
    assert len(raised.touches) == len(recorded_replay.touches)
    compared = 0
    for high, default in zip(raised.touches, recorded_replay.touches):
        if high.contact is None:
            continue
        first = high.contact.readings[0]
        assert first.t_s >= default.contact.readings[0].t_s
        assert first.pressure_pa - high.baseline_pa > 200.0
        compared += 1
    assert compared >= 1


def test_a_threshold_above_every_rise_finds_no_contact(session, tmp_path):
    pressure = session.readings.pressure_pa
    above_all = float(pressure.max() - pressure.min()) + 1.0
    result = session.run(ReplaySettings(start_threshold_pa=above_all, end_threshold_pa=1.0, figures=False),
                         tmp_path)
    assert [t.kind for t in result.touches] == ["miss"] * len(result.touches)
    assert result.metrics["contacts"] == 0 and result.gpis.n_contacts == 0
    assert (tmp_path / "contacts.csv").read_text().count("\n") == 1  # the header only
    assert not (tmp_path / "reconstruction.ply").exists()


def test_a_lower_threshold_never_starts_later(session, recorded_replay):
    lowered = session.run(ReplaySettings(start_threshold_pa=30.0, end_threshold_pa=20.0, figures=False))
    assert len(lowered.contacts) == len(recorded_replay.contacts)
    for low, default in zip(lowered.contacts, recorded_replay.contacts):
        assert low.contact.readings[0].t_s <= default.contact.readings[0].t_s
        assert low.contact.readings[0].pressure_pa - low.baseline_pa > 30.0


def test_a_session_cut_mid_write_is_replayed_up_to_its_last_complete_reading(sphere_run, recorded_replay,
                                                                              tmp_path):
    copy = tmp_path / "session"
    shutil.copytree(sphere_run.out_dir / "session", copy)
    spans = press_spans(read_session(copy).joint_states.t_s)
    cut_time = 0.5 * (spans[3].t_start_s + spans[3].t_end_s)  # halfway through the fourth press
    path = copy / "readings.csv"
    lines = path.read_bytes().split(b"\n")
    keep = 1 + sum(float(line.split(b",")[0]) <= cut_time for line in lines[1:] if line)
    path.write_bytes(b"\n".join(lines[:keep]) + b"\n" + lines[keep][:17])  # a partial last line
    result = replay(copy, ReplaySettings(figures=False))
    assert [t.index for t in result.touches] == [0, 1, 2]
    np.testing.assert_array_equal(result.points_m, recorded_replay.points_m[:3])
    assert any("readings.csv" in note and "cut off" in note for note in result.notes)
    assert sum("ends before its press" in note for note in result.notes) == 2


def test_the_command_writes_the_run_outputs(sphere_run, tmp_path, capsys):
    from scripts.reconstruct import main

    main([str(sphere_run.out_dir), "--out", str(tmp_path), "--resolution", "24", "--kernel",
          "thin_plate", "--noise", "0.001", "--normal-noise", "0.1"])
    metrics = json.loads((tmp_path / "metrics.json").read_text())
    assert metrics["replay"]["noise"] == 0.001 and metrics["replay"]["normal_noise"] == 0.1
    assert metrics["contacts"] == sphere_run.metrics["contacts"]
    assert metrics["position_rmse_mm"] < 2.0
    for name in ("contacts.csv", "reconstruction.ply", "reconstruction_error.png", "potential_slice.png"):
        assert (tmp_path / name).stat().st_size > 500, name
    assert '"contacts"' in capsys.readouterr().out


def test_bad_settings_are_refused():
    with pytest.raises(ValueError, match="kernel"):
        ReplaySettings(kernel="cubic")
    with pytest.raises(ValueError, match="mesh_resolution"):
        ReplaySettings(mesh_resolution=2)


def test_the_gpis_settings_are_applied(session, recorded_replay):
    samples = np.random.default_rng(1).uniform(-0.06, 0.06, size=(500, 3))
    squared = session.run(ReplaySettings(kernel="squared_exponential", figures=False))
    without = session.run(ReplaySettings(use_normals=False, figures=False))
    assert squared.gpis.kernel_spec == "squared_exponential" and not without.gpis.use_normals
    for other in (squared, without):
        np.testing.assert_array_equal(other.points_m, recorded_replay.points_m)
        assert np.max(np.abs(other.gpis.mean(samples) - recorded_replay.gpis.mean(samples))) > 1e-3


def test_replay_with_the_recorded_settings_keeps_the_realign_repeats_the_loop_kept(tmp_path):
    """A strict realign rule (every oblique contact doubtful, the whole budget for realigns) sets
    most first contacts aside; the repeats (strategy ``realign``) are kept by the loop whatever
    their angle, and replay applies the rule as the loop did."""

    strict = LoopConfig(realign_angle_rad=float(np.radians(0.5)), max_realign_fraction=1.0,
                        doubt_rim_margin_m=1.0, doubt_approach_angle_rad=float(np.radians(0.5)))
    run = explore(RunSettings(object="sphere", touches=4, eval_every=0, mesh_resolution=24, reach_samples=0, loop=strict), tmp_path)
    kinds = [r.kind for r in run.records]
    assert "realign" in kinds, kinds
    result = SessionReplay(run.out_dir).run(ReplaySettings(figures=False))
    assert [t.kind for t in result.touches] == kinds
    assert result.notes == []
    np.testing.assert_array_equal(result.points_m, read_contacts_csv(run.out_dir / "contacts.csv")[0])


def test_a_difference_from_the_recording_is_a_note(session):
    pressure = session.readings.pressure_pa
    result = session.run(ReplaySettings(start_threshold_pa=float(pressure.max() - pressure.min()) + 1.0,
                                        end_threshold_pa=1.0, figures=False))
    assert sum("recorded contact, replayed miss" in note for note in result.notes) == result.metrics["recorded_contacts"]


def test_a_truth_that_does_not_load_is_a_note_not_a_silent_gap(sphere_run, recorded_replay, tmp_path):
    """A session naming a mesh file that is not there (moved, or named relative to another
    directory): the replay still reconstructs, and says why it has no errors against the truth."""
    copy = tmp_path / "session"
    shutil.copytree(sphere_run.out_dir / "session", copy)
    metadata = json.loads((copy / "metadata.json").read_text())
    metadata["object"] = "elsewhere/cup.stl"
    (copy / "metadata.json").write_text(json.dumps(metadata))
    replay = SessionReplay(copy)
    result = replay.run(ReplaySettings(figures=False))
    notes = [note for note in result.notes if "not loaded" in note]
    assert len(notes) == 1 and notes[0].startswith("object 'elsewhere/cup.stl' not loaded")
    assert replay.truth is None and SessionReplay(sphere_run.out_dir / "session").truth is not None
    assert result.metrics["n_contacts_fitted"] == recorded_replay.metrics["n_contacts_fitted"]
    assert not any("not loaded" in note for note in recorded_replay.notes)

def test_a_press_replayed_as_one_on_the_pads_side_keeps_where_the_pad_was(sphere_run):
    """With a side-press force out of reach every press is one on the pad's side: replay keeps the
    pad-face centre (encoders' forward kinematics, object frame), within the spring's tilt of the
    pad the loop measured from the IMU."""
    from explorer.contact import DoubtRule, ObjectFrame

    replaying = SessionReplay(sphere_run.out_dir / "session")
    replaying.pipeline.doubt = DoubtRule(side_force_n=100.0, side_tilt_rad=np.pi)
    touches = replaying.run(ReplaySettings(figures=False)).touches
    originals = {r.index: r for r in sphere_run.records if r.kind == "contact"}
    sided = [t for t in touches if t.index in originals]
    assert sided and all(t.kind == "no_normal" for t in sided)
    for touch in sided:
        original = originals[touch.index]
        frame = ObjectFrame.of_stand(replaying.stand_centre_m, original.stand_yaw_rad, original.stand_tilt_rad)
        pad = frame.to_object(original.contact.position_m[None])[0]
        assert np.linalg.norm(touch.side_m - pad) < 0.005


def test_side_presses_give_the_replayed_gpis_one_value_row_each_when_asked(sphere_run):
    """The presses whose peak force lies below the run's median count as presses on the pad's side:
    ``side_presses`` on adds one GPIS row per such press, off none, and the contacts stay the same."""
    from explorer.contact import DoubtRule

    peaks = [r.quality.peak_force_n for r in sphere_run.records if r.kind == "contact"]
    replaying = SessionReplay(sphere_run.out_dir / "session")
    replaying.pipeline.doubt = DoubtRule(side_force_n=float(np.median(peaks)), side_tilt_rad=np.pi)
    on = replaying.run(ReplaySettings(figures=False, side_presses=True))
    off = replaying.run(ReplaySettings(figures=False, side_presses=False))
    sides = sum(t.kind == "no_normal" for t in on.touches)
    assert sides >= 1 and len(on.contacts) >= 1
    assert [t.index for t in on.contacts] == [t.index for t in off.contacts]
    assert off.gpis.n_rows == 4 * len(off.contacts)
    assert on.gpis.n_rows == off.gpis.n_rows + sides


def test_a_dip_below_the_end_threshold_mid_press_does_not_cut_the_contact(sphere_run, session, recorded_replay,
                                                                          tmp_path):
    """The loop measures a contact from every reading between the press's start and its end, also
    those after the pressure dipped below the detector's end threshold (the pad slipping while it
    settles); replay must keep them too, or it measures a different contact than the loop did."""
    from sensor.contact_detection import PressureContactDetector

    def kinds_in(readings, span):
        detector = PressureContactDetector()
        events = [(i, detector.update(readings[i])) for i in span]
        return [(i, e.kind) for i, e in events if e is not None]

    copy = tmp_path / "session"
    shutil.copytree(sphere_run.out_dir / "session", copy)
    record = next(r for r in sphere_run.records if r.kind == "contact")
    t = session.readings.t_s
    span = np.flatnonzero((t > record.press_t_s[0]) & (t <= record.press_t_s[1]))
    started = kinds_in(session.readings, span)[0][0]
    dip = range(started + 5, started + 9)  # 40 ms back at the pressure before the press
    assert dip[-1] < (started + span[-1]) // 2  # early in the contact: the settled window comes later
    lines = (copy / "readings.csv").read_text().splitlines()
    column = lines[0].split(",").index("pressure_pa")
    rows = [line.split(",") for line in lines[1:]]
    for i in dip:
        rows[i][column] = rows[span[0]][column]
    (copy / "readings.csv").write_text("\n".join([lines[0]] + [",".join(row) for row in rows]) + "\n")
    replaying = SessionReplay(copy)
    assert [kind for _, kind in kinds_in(replaying.readings, span)][:3] == ["start", "end", "start"]

    replayed = replaying.run(ReplaySettings(figures=False))
    assert not replayed.notes
    np.testing.assert_allclose(replayed.points_m, recorded_replay.points_m, rtol=0, atol=1e-9)
    np.testing.assert_allclose(replayed.normals, recorded_replay.normals, rtol=0, atol=1e-9)


def test_a_press_that_let_go_is_replayed_as_no_contact_and_no_side_press(sphere_run, tmp_path):
    """The run recorded the release test, so replay applies it at the detector's start threshold; a
    press the pipeline finds released (forced here for the first contact) adds nothing to the GPIS,
    neither a contact nor a side-press row. A session recorded before the test replays without it."""
    from explorer.contact import PressReleased

    replaying = SessionReplay(sphere_run.out_dir / "session")
    assert replaying.loop_config.drop_released_presses
    measure, calls = replaying.pipeline.measure, []

    def release_the_first(*args, **kwargs):
        calls.append(1)
        if len(calls) == 1:
            raise PressReleased("forced")
        return measure(*args, **kwargs)

    replaying.pipeline.measure = release_the_first
    result = replaying.run(ReplaySettings(figures=False, side_presses=True))
    assert replaying.pipeline.release_threshold_pa == replaying._detector_config(ReplaySettings()).start_threshold_pa
    released = [t for t in result.touches if t.kind == "no_normal"]
    assert len(released) == 1 and released[0].side_m is None
    contacts = [r for r in sphere_run.records if r.kind == "contact"]
    assert len(result.contacts) == len(contacts) - 1
    assert result.gpis.n_rows == 4 * len(result.contacts)  # no side-press row for it

    old = tmp_path / "old-session"  # the recorded run is shared: copies go elsewhere
    shutil.copytree(sphere_run.out_dir / "session", old)
    metadata = json.loads((old / "metadata.json").read_text())
    del metadata["configuration"]["loop"]["release_at_contact_threshold"]
    (old / "metadata.json").write_text(json.dumps(metadata))
    end_rule = SessionReplay(old)   # recorded when the release test asked the end threshold
    end_rule.run(ReplaySettings(figures=False))
    assert end_rule.pipeline.release_threshold_pa == end_rule._detector_config(ReplaySettings()).end_threshold_pa
    del metadata["configuration"]["loop"]["drop_released_presses"]
    metadata["configuration"]["loop"]["swept_free_space"] = True   # a run that had it on ...
    (old / "metadata.json").write_text(json.dumps(metadata))
    before = SessionReplay(old)
    before.run(ReplaySettings(figures=False))
    assert not before.loop_config.drop_released_presses and before.pipeline.release_threshold_pa is None
    assert before.loop_config.swept_free_space   # ... is replayed with it on
    assert SessionReplay(sphere_run.out_dir / "session").loop_config.swept_free_space   # the default
    legacy = json.loads((old / "metadata.json").read_text())
    del legacy["configuration"]["loop"]["swept_free_space"]
    (old / "metadata.json").write_text(json.dumps(legacy))
    assert not SessionReplay(old).loop_config.swept_free_space   # recorded before it existed
    assert before.loop_config.reconstruction_free_space_noise == LoopConfig().reconstruction_free_space_noise
    del legacy["configuration"]["loop"]["reconstruction_free_space_noise"]
    (old / "metadata.json").write_text(json.dumps(legacy))
    assert SessionReplay(old).loop_config.reconstruction_free_space_noise is None   # meshed as it was then
    assert before.loop_config.reconstruction_gates_misses
    del legacy["configuration"]["loop"]["reconstruction_gates_misses"]
    (old / "metadata.json").write_text(json.dumps(legacy))
    assert not SessionReplay(old).loop_config.reconstruction_gates_misses   # with the loop's miss rows


def test_a_touch_recorded_as_pushed_off_its_line_is_counted_as_such(sphere_run, recorded_replay, tmp_path):
    """A touch event's ``left_line_m`` (the pad left its approach line before the contact) is read
    back onto the replayed touch and counted in the metrics; the recorded run had none."""
    assert recorded_replay.metrics["left_line"] == recorded_replay.metrics["contacts_after_left_line"] == 0
    assert sphere_run.metrics["left_line"] == 0
    copy = tmp_path / "session"
    shutil.copytree(sphere_run.out_dir / "session", copy)
    lines = (copy / "events.jsonl").read_text().splitlines()
    first = next(i for i, line in enumerate(lines) if json.loads(line).get("result") == "contact")
    event = json.loads(lines[first])
    event["left_line_m"] = [0.01, 0.02, 0.03]
    lines[first] = json.dumps(event)
    (copy / "events.jsonl").write_text("\n".join(lines) + "\n")
    result = SessionReplay(copy).run(ReplaySettings(figures=False))
    [pushed] = [t for t in result.touches if t.left_line_m is not None]
    assert pushed.index == event["index"] and pushed.kind == "contact"
    np.testing.assert_array_equal(pushed.left_line_m, [0.01, 0.02, 0.03])
    assert result.metrics["left_line"] == result.metrics["contacts_after_left_line"] == 1


def test_a_run_on_an_arm_calibrated_with_link_lengths_replays_its_own_contacts(tmp_path):
    """The recorded joint angles are corrected by the calibration's offsets but not by its link
    lengths: the replay must rebuild the run's model from the calibration in the metadata, or every
    contact moves by the lengths (1.5 mm here)."""
    calibration = tmp_path / "joint_calibration.json"
    calibration.write_text(json.dumps({"robot": "armar3", "profile": "hardware-like", "seed": 0,
                                       "fitted_offset_deg": [0.0] * 7,
                                       "fitted_link_length_error_mm": {"elbow": 1.5}}))
    run = explore(RunSettings(object="sphere", touches=3, seed=0, eval_every=0, mesh_resolution=24, reach_samples=0,
                              profile="hardware-like", calibration=str(calibration)), tmp_path / "run")
    recorded = read_session(run.out_dir / "session").contacts
    assert recorded
    replayed = SessionReplay(run.out_dir / "session").run(ReplaySettings(figures=False)).contacts
    assert len(replayed) == len(recorded)
    for again, original in zip(replayed, recorded):
        np.testing.assert_allclose(again.contact.position_m, original.position_m, rtol=0, atol=1e-9)
