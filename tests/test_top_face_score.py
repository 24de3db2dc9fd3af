"""The flat surface scored as a real one is measured: the top face's height map."""
import numpy as np
import pytest
import trimesh

from explorer.evaluation import top_face_height_error

PLATE = trimesh.creation.box(extents=[0.1, 0.08, 0.01])       # top face at z = +5 mm


def test_the_truth_scores_zero_and_a_lifted_copy_its_lift():
    assert top_face_height_error(PLATE, PLATE, spacing_m=0.004)["top_face_rmse_mm"] < 1e-9
    lifted = PLATE.copy()
    lifted.apply_translation([0.0, 0.0, 0.0015])
    score = top_face_height_error(lifted, PLATE, spacing_m=0.004)
    assert score["top_face_rmse_mm"] == pytest.approx(1.5)
    assert score["top_face_missed_fraction"] == 0.0


def test_a_bump_counts_over_its_footprint_and_a_missing_half_by_distance():
    bump = trimesh.util.concatenate([PLATE, trimesh.creation.box(extents=[0.02, 0.02, 0.01],
                                                                  transform=trimesh.transformations.translation_matrix([0, 0, 0.007]))])
    score = top_face_height_error(bump, PLATE, inset_m=0.0, spacing_m=0.002)
    share = 0.02 * 0.02 / (0.1 * 0.08)                            # footprint fraction 2 mm / 7 mm high
    assert score["top_face_max_mm"] == pytest.approx(7.0, abs=1e-6)
    assert score["top_face_rmse_mm"] == pytest.approx(7.0 * np.sqrt(share), rel=0.15)
    half = trimesh.creation.box(extents=[0.05, 0.08, 0.01], transform=trimesh.transformations.translation_matrix([-0.025, 0, 0]))
    missed = top_face_height_error(half, PLATE, spacing_m=0.004)
    assert 0.3 < missed["top_face_missed_fraction"] < 0.7 and missed["top_face_rmse_mm"] > 5.0
    with pytest.raises(ValueError, match="no upward face"):
        top_face_height_error(PLATE, trimesh.creation.icosphere(subdivisions=0, radius=0.05).apply_translation([0, 0, 0]))
