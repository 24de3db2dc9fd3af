"""The package roots export their public names lazily, and the README's library examples run."""
from __future__ import annotations

import importlib
import os
import re
import subprocess
import sys
from pathlib import Path

import pytest

ROOT = Path(__file__).resolve().parents[1]
PACKAGES = ("reconstruction", "explorer", "sensor", "robots", "objects")


@pytest.mark.parametrize("package", PACKAGES)
def test_every_exported_name_imports(package):
    module = importlib.import_module(package)
    assert module.__all__, f"{package} exports nothing"
    for name in module.__all__:
        assert getattr(module, name) is not None, f"{package}.{name}"
    with pytest.raises(AttributeError, match="no attribute"):
        getattr(module, "NoSuchName")


def test_from_reconstruction_import_gpis():
    from reconstruction import GPIS
    from reconstruction.gpis import GPIS as Direct

    assert GPIS is Direct


def test_importing_the_package_roots_loads_neither_torch_nor_pybullet():
    code = ("import sys, reconstruction, explorer, sensor, robots, objects; "
            "print(sorted(m for m in ('torch', 'pybullet') if m in sys.modules))")
    out = subprocess.run([sys.executable, "-c", code], cwd=ROOT, capture_output=True, text=True, check=True)
    assert out.stdout.strip() == "[]"


def readme_library_blocks() -> list[str]:
    text = (ROOT / "README.md").read_text()
    section = text.split("## Use as a library", 1)[1].split("\n## ", 1)[0]
    return re.findall(r"```python\n(.*?)```", section, flags=re.S)


def test_the_readme_library_examples_run(tmp_path):
    """All blocks in one interpreter, in order (the replay reads the run's session), in a scratch
    directory; the strategy registration must not leak into this test process."""
    blocks = readme_library_blocks()
    assert len(blocks) == 3
    script = tmp_path / "library_examples.py"
    script.write_text("import torch\ntorch.set_num_threads(1)\n" + "\n\n".join(blocks))
    out = subprocess.run([sys.executable, str(script)], cwd=tmp_path, capture_output=True, text=True,
                         env={**os.environ, "PYTHONPATH": str(ROOT)}, timeout=900)
    assert out.returncode == 0, out.stderr[-3000:]
    lines = out.stdout.strip().splitlines()
    assert lines[0].startswith("Chamfer L1 ")
    assert "contacts; outputs" in lines[1] and "start threshold" in lines[2]
    assert (tmp_path / "my_run" / "metrics.json").is_file() and (tmp_path / "my_replay" / "metrics.json").is_file()
