"""The simulated pad's compliance, measured on a flat plate, is what the contact pipeline assumes:
a compression proportional to the force, the same at other forces, and the scene's pad calibration."""
from __future__ import annotations

import dataclasses

import numpy as np
import pytest

import robots
from robots import pad_compliance
from robots.pad_compliance import measure_pad_compliance_m_per_n


def test_the_compression_grows_in_proportion_to_the_force_and_with_a_softer_pad(monkeypatch):
    spec = robots.load("armar3")
    stiff = dataclasses.replace(spec, pad_contact_stiffness_n_per_m=3000.0)
    soft = dataclasses.replace(spec, pad_contact_stiffness_n_per_m=500.0)
    compliance = measure_pad_compliance_m_per_n(stiff)
    # the physics, not the formula: four corner contacts of k each would give 1 / (4 k)
    assert 0.5 / (4 * 3000.0) < compliance < 3.0 / (4 * 3000.0)
    assert 3.0 < measure_pad_compliance_m_per_n(soft) / compliance < 9.0  # a 6x softer contact
    # proportional: other forces give the same slope (the pipeline adds force x compliance back)
    pad_compliance._slope.cache_clear()
    monkeypatch.setattr(pad_compliance, "PRESS_FORCES_N", (2.0, 4.0))
    assert measure_pad_compliance_m_per_n(stiff) == pytest.approx(compliance, rel=0.15)
    pad_compliance._slope.cache_clear()


def test_the_scene_corrects_contacts_with_the_measured_compliance():
    from explorer.simulation import build_scene

    with build_scene("sphere", "armar3", seed=0, profile="hardware-like") as scene:
        measured = measure_pad_compliance_m_per_n(scene.kinematics.spec)
        assert scene.pad.compliance_m_per_n == measured
        assert np.isclose(scene.kinematics.spec.pad_contact_stiffness_n_per_m, 500.0)
