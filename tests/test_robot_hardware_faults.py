"""Every injected controller-link fault: recovered, or the documented error with the arm left stopped."""
from __future__ import annotations

import pytest

from robots.emulators.fault_campaign import CASES, MAX_DRIFT_RAD, PORT, run_case


@pytest.mark.parametrize("case", CASES, ids=[case.name for case in CASES])
def test_fault_case(case):
    outcome = run_case(case)
    assert outcome.triggered > 0, "the fault never fired: the case proves nothing"
    assert outcome.stopped, "the emulated arm was still moving one watchdog period later"
    assert outcome.drift_rad <= MAX_DRIFT_RAD
    if case.expect is None:
        assert outcome.error is None, f"expected recovery, got {outcome.error!r}"
        assert outcome.value_ok
    else:
        assert isinstance(outcome.error, case.expect), f"expected {case.expect.__name__}, got {outcome.error!r}"
        message = str(outcome.error)
        assert message.startswith(f"arm on {PORT}: ")
        for fragment in case.message:
            assert fragment in message


def test_the_campaign_covers_recovery_and_failure_for_every_fault_kind():
    by_fault = {}
    for case in CASES:
        by_fault.setdefault(case.fault, set()).add(case.expect is None)
    transient = [fault for fault in by_fault if fault is not None and not fault.permanent
                 and fault.name not in ("DRIVE_FAULT", "EMERGENCY_STOP")]
    assert len(by_fault) == 11  # ten ArmFault kinds and the host stall
    for fault in transient:
        assert True in by_fault[fault], f"{fault.name}: no recovery case"
