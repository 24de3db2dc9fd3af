"""The plain-Python reading example in docs/SESSION_FORMAT.md works, without this package."""
from __future__ import annotations

import json
import re
import subprocess
import sys
from pathlib import Path

import numpy as np
import pytest

from explorer.session import SessionWriter
from explorer.session.layout import READINGS_COLUMNS
from sensor.oriented_contact import OrientedContact
from sensor.reading import Reading

DOC = Path(__file__).resolve().parents[1] / "docs" / "SESSION_FORMAT.md"
PROJECT_PACKAGES = ("common", "robots", "objects", "sensor", "explorer", "reconstruction", "scripts")

# Runs the example as a script, then reports what it read and which project packages got imported.
HARNESS = """
import json, runpy, sys
example, session_dir = sys.argv[1], sys.argv[2]
sys.argv = [example, session_dir]
found = runpy.run_path(example)
print(json.dumps({
    "columns": found["columns"],
    "readings": found["readings"].tolist(),
    "joints": found["joints"].tolist(),
    "metadata": found["metadata"],
    "contacts": found["contacts"],
    "events": found["events"],
    "snapshots": found["snapshots"],
    "project_modules": sorted({m.split(".")[0] for m in sys.modules} & set(%r)),
}))
""" % (PROJECT_PACKAGES,)


def documented_example() -> str:
    text = DOC.read_text()
    match = re.search(r"<!-- tested-example[^>]*-->\s*```python\n(.*?)```", text, re.DOTALL)
    assert match, f"{DOC} has no ```python block after a '<!-- tested-example -->' marker"
    return match.group(1)


def test_the_example_is_at_most_a_dozen_lines_and_does_not_import_the_package():
    code = documented_example()
    assert len([line for line in code.splitlines() if line.strip()]) <= 12
    assert not re.search(r"^\s*(import|from)\s+(%s)\b" % "|".join(PROJECT_PACKAGES), code, re.MULTILINE)


@pytest.mark.parametrize("crashed", [False, True])
def test_the_documented_example_reads_a_written_session(tmp_path, crashed):
    readings = [
        Reading(i / 100.0, 101325.0 + i / 3.0, np.array([0.0, 0.6, 0.0, 0.8]),
                np.array([0.1, 0.2, i / 7.0]), np.array([0.0, 0.0, -9.81]), 24.5)
        for i in range(8)
    ]
    writer = SessionWriter(tmp_path / "run", {"robot": "panda", "sensor": "sim", "object": "cube", "seed": 3})
    for reading in readings:
        writer.write_reading(reading)
    for i in range(4):
        writer.write_joint_state(i / 50.0, np.arange(7) / (i + 1.0))
    writer.write_contact(
        OrientedContact(0.05, np.array([0.1, 0.2, 0.3]), np.array([1.0, 0.0, 0.0]), 2.0, tuple(readings[2:5]))
    )
    writer.write_event("touch", 0.01, target_m=[0.1, 0.2, 0.3], approach_dir=[-1.0, 0.0, 0.0])
    writer.write_reconstruction((np.eye(3), np.array([[0, 1, 2]])), 1, 0.08)
    if crashed:  # killed while writing the last reading: the example must skip the cut line
        path = tmp_path / "run" / "readings.csv"
        path.write_bytes(path.read_bytes()[:-9])
    else:
        writer.close()

    example = tmp_path / "example.py"
    example.write_text(documented_example())
    result = subprocess.run(
        [sys.executable, "-c", HARNESS, str(example), str(tmp_path / "run")],
        capture_output=True, text=True, timeout=60, check=True,
    )
    found = json.loads(result.stdout)

    assert found["project_modules"] == []
    assert found["columns"] == list(READINGS_COLUMNS)
    kept = readings[:-1] if crashed else readings
    expected = [
        [r.t_s, r.pressure_pa, *r.quat_wxyz, *r.lin_acc_mps2, *r.gravity_mps2, r.temperature_c] for r in kept
    ]
    assert found["readings"] == expected
    assert found["joints"] == [[i / 50.0, *(np.arange(7) / (i + 1.0))] for i in range(4)]
    assert found["metadata"]["seed"] == 3
    assert found["metadata"]["end_status"] == ("open" if crashed else "closed")
    contact, = found["contacts"]
    assert contact["position_m"] == [0.1, 0.2, 0.3] and contact["readings_t_s"] == [0.02, 0.04]
    assert [(e["kind"], e["approach_dir"]) for e in found["events"]] == [("touch", [-1.0, 0.0, 0.0])]
    assert found["snapshots"][0]["n_contacts"] == 1
    assert (tmp_path / "run" / found["snapshots"][0]["path"]).is_file()
