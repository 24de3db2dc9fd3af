"""Autonomous sessions: the recorded press spans and the older joint-state-gap split agree."""
import json
import shutil

import numpy as np
import pytest

from explorer.replay import ReplaySettings, press_spans, replay
from explorer.run import RunSettings, explore
from explorer.session import read_session


@pytest.fixture(scope="module")
def sphere_run(tmp_path_factory):
    out = tmp_path_factory.mktemp("recorded")
    return explore(RunSettings(object="sphere", touches=3, seed=1, eval_every=0, mesh_resolution=24, reach_samples=0), out)


def test_recorded_press_spans_are_the_dense_joint_state_runs(sphere_run):
    session = read_session(sphere_run.out_dir / "session")
    recorded = [e.fields["press_t_s"] for e in session.events if "press_t_s" in e.fields]
    spans = press_spans(session.joint_states.t_s)
    assert len(recorded) == len(spans) >= 3
    assert [[s.t_start_s, s.t_end_s] for s in spans] == recorded


def test_a_session_without_press_spans_replays_the_same(sphere_run, tmp_path):
    copy = tmp_path / "session"
    shutil.copytree(sphere_run.out_dir / "session", copy)
    events = [json.loads(line) for line in (copy / "events.jsonl").read_text().splitlines()]
    assert sum(e.pop("press_t_s", None) is not None for e in events) >= 3
    (copy / "events.jsonl").write_text("".join(json.dumps(e) + "\n" for e in events))
    with_spans = replay(sphere_run.out_dir / "session", ReplaySettings(figures=False))
    from_gaps = replay(copy, ReplaySettings(figures=False))
    assert [t.kind for t in from_gaps.touches] == [t.kind for t in with_spans.touches]
    assert len(with_spans.contacts) == sphere_run.metrics["contacts"] >= 2
    np.testing.assert_array_equal(from_gaps.points_m, with_spans.points_m)
    np.testing.assert_array_equal(from_gaps.normals, with_spans.normals)
