"""Teleop input devices: key mapping, scripted timing, validation (no simulator, no hardware)."""
import json

import numpy as np
import pytest

from explorer.teleop.devices import (KeyboardDevice, ScriptedDevice, SpaceMouseDevice, TeleopCommand,
                                     TimedCommand)


def test_key_codes_are_pybullets():
    import pybullet as pb

    assert KeyboardDevice.AXES.keys() == {pb.B3G_LEFT_ARROW, pb.B3G_RIGHT_ARROW, pb.B3G_UP_ARROW,
                                          pb.B3G_DOWN_ARROW, pb.B3G_PAGE_UP, pb.B3G_PAGE_DOWN}


def test_keyboard_maps_held_keys_to_velocity_and_triggered_keys_to_buttons():
    import pybullet as pb

    events = [{pb.B3G_RIGHT_ARROW: pb.KEY_IS_DOWN, pb.B3G_PAGE_DOWN: pb.KEY_IS_DOWN,
               ord("r"): pb.KEY_WAS_TRIGGERED | pb.KEY_IS_DOWN},
              {pb.B3G_RIGHT_ARROW: pb.KEY_WAS_RELEASED, ord("q"): pb.KEY_WAS_TRIGGERED}]
    with KeyboardDevice(lambda: events.pop(0), speed_mps=0.02) as device:
        first, second = device.poll(), device.poll()
    np.testing.assert_array_equal(first.linear_mps, [0.02, 0.0, -0.02])
    assert first.buttons == {"record"}
    assert second.is_still and second.buttons == {"quit"}


def test_scripted_device_follows_its_clock_and_reports_buttons_once():
    now = [0.0]
    steps = [TimedCommand(0.5, TeleopCommand([0.01, 0, 0], buttons={"record"})),
             TimedCommand(1.0, TeleopCommand([0, 0, -0.01]))]
    with ScriptedDevice(steps, lambda: now[0]) as device:
        seen = []
        for t in (10.0, 10.2, 10.5, 11.4, 11.5):  # starts at the first poll
            now[0] = t
            seen.append(device.poll())
    assert [c.linear_mps[0] for c in seen[:2]] == [0.01, 0.01] and seen[2].linear_mps[2] == -0.01
    assert [c.buttons for c in seen] == [{"record"}, set(), set(), set(), {"quit"}]
    assert device.duration_s == 1.5


def test_a_closed_device_refuses_to_poll():
    with pytest.raises(RuntimeError, match="not open"):
        ScriptedDevice([TimedCommand(1.0, TeleopCommand())], lambda: 0.0).poll()


def test_script_files_are_read_and_bad_steps_named(tmp_path):
    good = tmp_path / "good.json"
    good.write_text(json.dumps([{"duration_s": 2, "linear_mps": [0, 0.01, 0]}, {"duration_s": 1, "buttons": ["quit"]}]))
    device = ScriptedDevice.from_json(good, lambda: 0.0)
    assert device.duration_s == 3.0 and device.steps[1].command.buttons == {"quit"}
    bad = tmp_path / "bad.json"
    bad.write_text(json.dumps([{"duration_s": 1}, {"duration_s": -1}]))
    with pytest.raises(ValueError, match="step 1"):
        ScriptedDevice.from_json(bad, lambda: 0.0)


def test_commands_are_validated():
    with pytest.raises(ValueError, match="linear_mps"):
        TeleopCommand([0.0, np.nan, 0.0])
    with pytest.raises(ValueError, match="unknown buttons"):
        TeleopCommand(buttons={"jump"})


def test_spacemouse_without_its_package_says_what_to_install(monkeypatch):
    import builtins

    real_import = builtins.__import__

    def no_pyspacemouse(name, *args, **kwargs):
        if name == "pyspacemouse":
            raise ImportError("No module named 'pyspacemouse'")
        return real_import(name, *args, **kwargs)

    monkeypatch.setattr(builtins, "__import__", no_pyspacemouse)
    with pytest.raises(ImportError, match="pip install pyspacemouse") as error:
        SpaceMouseDevice().open()
    assert "pip install -e .[teleop]" in str(error.value)  # the extra in setup.cfg
