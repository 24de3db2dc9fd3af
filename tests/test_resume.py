"""Resuming a stopped run: the restored loop equals the stopped one, the resumed run keeps every
recorded contact and goes on to its budget with a session clock that never runs backwards."""
from __future__ import annotations

from types import SimpleNamespace

import numpy as np
import pytest

import objects

from explorer.loop import ExplorationLoop, LoopConfig
from explorer.planner import PlannerConfig
from explorer.positioner import FixedStand
from explorer.recording import read_contacts_csv
from explorer.resume import (check_resumable, load_recorded_run, resume_time_offset,
                             rewrite_contacts_csv)
from explorer.rig import Rig, object_prior
from explorer.run import RunSettings, explore
from explorer.session import read_session
from explorer.strategies import make_strategy
from reconstruction.gpis import GPIS

SPHERE = dict(object="sphere", eval_every=0, mesh_resolution=24, reach_samples=0)  # no reach breakdown: 9 s each


@pytest.fixture(scope="module")
def stopped_run(tmp_path_factory):
    """A 3-touch sphere run (the part before a stop)."""
    out = tmp_path_factory.mktemp("stopped")
    result = explore(RunSettings(touches=3, **SPHERE), out)
    return out, result


def _restored_loop(recorded, settings: RunSettings, prior):
    """A fresh loop (no devices: restore() needs none) restored from ``recorded``."""
    gpis = GPIS(bounds=prior.bounds(), use_normals=settings.use_normals)
    rig = Rig(None, None, None, FixedStand(np.zeros(3)), prior, None, {})
    loop = ExplorationLoop(rig, SimpleNamespace(config=PlannerConfig()), make_strategy(settings.strategy, settings.seed),
                           gpis, LoopConfig(touches=settings.touches))
    loop.restore(recorded.touches)
    return loop


def test_a_restored_loop_has_the_field_and_the_touches_the_stopped_run_had(stopped_run):
    out, result = stopped_run
    recorded = load_recorded_run(out)
    prior = object_prior(objects.load("sphere").mesh)
    loop = _restored_loop(recorded, RunSettings(touches=3, **SPHERE), prior)

    assert [r.kind for r in loop.records] == [r.kind for r in result.records]
    for restored, original in zip(loop.records, result.records):
        np.testing.assert_array_equal(restored.target_m, original.target_m)
        if original.kind == "contact":
            np.testing.assert_array_equal(restored.position_m, original.position_m)
            np.testing.assert_array_equal(restored.normal, original.normal)
            assert restored.contact.force_n == original.contact.force_n
    assert loop.state.touches == 3 and loop.gpis.n_contacts == result.gpis.n_contacts
    points = np.random.default_rng(0).uniform(*prior.bounds(), size=(200, 3))
    np.testing.assert_allclose(loop.gpis.mean(points), result.gpis.mean(points), rtol=0, atol=1e-12)


def test_restore_refuses_a_used_loop_and_misnumbered_touches(stopped_run):
    out, _ = stopped_run
    recorded = load_recorded_run(out)
    prior = object_prior(objects.load("sphere").mesh)
    loop = _restored_loop(recorded, RunSettings(touches=3, **SPHERE), prior)
    with pytest.raises(RuntimeError, match="fresh loop"):
        loop.restore(recorded.touches)
    shuffled = list(reversed(recorded.touches))
    gpis = GPIS(bounds=prior.bounds())
    fresh = ExplorationLoop(Rig(None, None, None, FixedStand(np.zeros(3)), prior, None, {}),
                            SimpleNamespace(config=PlannerConfig()), make_strategy("variance"), gpis)
    with pytest.raises(ValueError, match="numbered"):
        fresh.restore(shuffled)


def test_a_resumed_run_keeps_every_recorded_contact_and_goes_on_to_its_budget(stopped_run, tmp_path):
    import shutil

    source, first = stopped_run
    out = tmp_path / "run"
    shutil.copytree(source, out)
    before_csv = (out / "contacts.csv").read_text()
    before = read_session(out / "session")
    end_before = max(before.readings.t_s[-1], before.events[-1].t_s)

    result = explore(RunSettings(touches=6, **SPHERE), out, resume=True)

    assert len(result.records) == 6
    assert [r.kind for r in result.records[:3]] == [r.kind for r in first.records]
    assert (out / "contacts.csv").read_text().startswith(before_csv)
    points, _ = read_contacts_csv(out / "contacts.csv")
    assert len(points) == len([r for r in result.records if r.kind == "contact"]) == result.metrics["contacts"]
    session = read_session(out / "session")  # the reader checks that times never go backwards
    assert session.closed_cleanly and len(session.metadata["resumed"]) == 1
    (resumed,) = [e for e in session.events if e.kind == "resumed"]
    assert resumed.fields["restored_touches"] == 3 and resumed.fields["touches"] == 6
    assert resumed.fields["time_offset_s"] > 0.0  # the simulator's clock started again at zero
    after = session.readings.t_s[len(before.readings):]
    assert len(after) > 0 and after[0] > end_before
    assert len(session.contacts) == len([r for r in result.records if r.kind == "contact"])
    touch_indices = [e.fields["index"] for e in session.events if "index" in e.fields]
    assert touch_indices == list(range(6))


def test_an_interrupted_run_is_resumed_to_the_same_budget(tmp_path):
    def stop_after_two(record):
        if record.index == 1:
            raise KeyboardInterrupt

    with pytest.raises(KeyboardInterrupt):
        explore(RunSettings(touches=4, **SPHERE), tmp_path, progress=stop_after_two)
    stopped = read_session(tmp_path / "session")
    assert stopped.metadata["end_status"] == "aborted"
    assert [e.fields["source"] for e in stopped.events if e.kind == "error"] == ["KeyboardInterrupt"]

    result = explore(RunSettings(touches=4, **SPHERE), tmp_path, resume=True)
    assert len(result.records) == 4 and result.metrics["completed"]
    assert read_session(tmp_path / "session").metadata["end_status"] == "closed"


def test_resuming_with_other_settings_or_without_a_run_is_refused(stopped_run, tmp_path):
    source, _ = stopped_run
    with pytest.raises(ValueError, match="strategy: recorded 'variance', now 'random'"):
        explore(RunSettings(touches=4, strategy="random", **SPHERE), source, resume=True)
    with pytest.raises(FileNotFoundError, match="no run to resume"):
        explore(RunSettings(touches=4, **SPHERE), tmp_path / "empty", resume=True)
    check_resumable(dict(touches=3, seed=0), dict(touches=9, seed=0))  # the budget may change
    with pytest.raises(ValueError, match="seed"):
        check_resumable(dict(touches=3, seed=0), dict(touches=3, seed=1))


def test_a_setting_recorded_in_its_old_place_is_compared_at_its_new_place():
    now = dict(seed=0, loop=dict(realign=True), pad=dict(compliance_m_per_n=3e-4))
    older = dict(seed=0, loop=dict(realign=True, pad_compliance_m_per_n=3e-4), pad={})
    check_resumable(older, now)  # the same experiment, recorded before the setting moved
    changed = dict(seed=0, loop=dict(realign=True, pad_compliance_m_per_n=5e-4), pad={})
    with pytest.raises(ValueError, match="pad: recorded"):
        check_resumable(changed, now)


def test_the_time_offset_continues_after_the_stopped_part():
    assert resume_time_offset(100.0, 0.5, gap_s=1.0) == pytest.approx(100.5)
    assert resume_time_offset(100.0, 500.0) == 0.0  # a clock that did not restart is left alone
    assert resume_time_offset(float("-inf"), 3.0) == 0.0  # nothing recorded yet


def test_contacts_csv_is_rebuilt_from_the_session(stopped_run, tmp_path):
    out, result = stopped_run
    recorded = load_recorded_run(out)
    rewrite_contacts_csv(tmp_path, recorded.touches)
    assert (tmp_path / "contacts.csv").read_text() == (out / "contacts.csv").read_text()
