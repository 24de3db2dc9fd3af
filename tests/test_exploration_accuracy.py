"""Full-pipeline accuracy targets (slow: about a minute per object; run with `pytest -m slow`).

Targets with normals and default sensor noise, at most 100 touches (issue 4): box <= 2.7 mm,
sphere <= 0.5 mm, cylinder <= 3.2 mm, banana <= 1.8 mm position RMSE.
"""
import pytest

from explorer.run import RunSettings, explore

TARGETS_MM = {"box": 2.7, "sphere": 0.5, "cylinder": 3.2, "banana": 1.8}


@pytest.mark.slow
@pytest.mark.parametrize("name", sorted(TARGETS_MM))
def test_reference_object_reaches_its_target(name, tmp_path):
    result = explore(RunSettings(object=name, touches=100, seed=0, eval_every=0), tmp_path)
    assert result.metrics["position_rmse_mm"] <= TARGETS_MM[name]
