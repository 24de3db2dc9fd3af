"""``tactile-teleop``: explore an object by hand with the simulated arm (keyboard or SpaceMouse).

    tactile-teleop --object sphere --device keyboard --out results/teleop
    tactile-teleop --object sphere --headless --script touches.json --out results/teleop

Keyboard (PyBullet window): arrows jog the pad in x / y, page up / down in z, ``r`` saves a
reconstruction snapshot, ``q`` quits. Contacts are recorded when the pad rests in contact; the red
cross marks the suggested next touch (the most uncertain point of the reconstruction).
A script is a JSON list of ``{"duration_s", "linear_mps", "angular_radps", "buttons"}`` steps:
each holds the pad velocity (world frame: m/s and rad/s; buttons from ``record``, ``quit``) for its
duration. The pad starts at the ready pose: on the line through the centre of the object's rough
box along the world direction (0.9, 0, -0.45) (normalised; away from the robot and down), 2 cm
outside the box's bounding sphere, its face towards the object (``explorer/teleop/simulated.py``).
"""
from __future__ import annotations

import argparse
import json
from pathlib import Path


def main(argv: list[str] | None = None) -> None:
    import objects
    from explorer.rerun_view import add_rerun_argument, check_rerun_argument, observer_from_argument
    from scripts._cli import check_gui, check_object, check_out_dir, check_robot

    parser = argparse.ArgumentParser(prog="tactile-teleop", description=__doc__.splitlines()[0])
    parser.add_argument("--object", required=True,
                        help=f"registry name ({', '.join(objects.names())}), generated:FAMILY/SEED or a mesh file")
    parser.add_argument("--units", choices=("m", "cm", "mm", "in"), default="m",
                        help="length unit of a mesh file given as the object (default m)")
    parser.add_argument("--device", default="keyboard", choices=("keyboard", "spacemouse"))
    parser.add_argument("--out", type=Path, default=Path("results/teleop"))
    parser.add_argument("--robot", default="armar3")
    parser.add_argument("--headless", action="store_true", help="no window; needs --script")
    parser.add_argument("--script", type=Path, help="JSON script of timed commands (replaces the device)")
    add_rerun_argument(parser)
    args = parser.parse_args(argv)
    if args.headless and args.script is None:
        parser.error("--headless needs --script (nobody can steer without a window)")
    if args.script is not None and not args.script.is_file():
        parser.error(f"script file {args.script} does not exist")
    check_object(parser, args.object)
    check_robot(parser, args.robot)
    check_out_dir(parser, args.out)
    if args.script is not None:
        from explorer.teleop.devices import ScriptedDevice

        try:  # read it now: a bad script must fail before the scene is built or --out is created
            ScriptedDevice.from_json(args.script, lambda: 0.0)
        except ValueError as err:
            parser.error(str(err))

    check_rerun_argument(parser, args.rerun)
    if not args.headless:
        check_gui(parser, "the window", "pass --headless with --script")
    observer = observer_from_argument(parser, args.rerun, "tactile-teleop")  # opened once all checks passed

    import torch

    from explorer.teleop.devices import KeyboardDevice, ScriptedDevice, SpaceMouseDevice
    from explorer.teleop.simulated import run_simulated_teleop

    torch.set_num_threads(1)  # small tensors: extra threads only add synchronisation

    def device(context):
        if args.script is not None:
            return ScriptedDevice.from_json(args.script, context.clock)
        if args.device == "spacemouse":
            return SpaceMouseDevice()
        return KeyboardDevice(context.key_events)

    try:
        object_name = objects.in_metres(args.object, args.units)
        result = run_simulated_teleop(object_name, device, args.out, robot=args.robot, gui=not args.headless,
                                      observer=observer)
    except ValueError as err:
        parser.error(str(err))
    suggestion = None if result.suggestion_m is None else [round(float(v), 4) for v in result.suggestion_m]
    print(json.dumps({"contacts": len(result.contacts), "suggested_touch_m": suggestion}))
    print(f"outputs in {args.out}")


if __name__ == "__main__":
    main()
