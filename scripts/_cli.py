"""Argument checks shared by the command-line tools.

A bad argument is a usage error: one line naming the option and the fix, exit status 2 (as
argparse's own errors), and nothing written. The checks here run before any output directory is
created or any simulation starts. ``docs/ERRORS.md`` lists what each tool refuses and the test that
covers it.
"""
from __future__ import annotations

import argparse
import os
from pathlib import Path

EXIT_USAGE = 2


def int_at_least(minimum: int):
    """An argparse ``type``: an integer >= ``minimum`` (argparse names the option in the error)."""

    def parse(text: str) -> int:
        try:
            value = int(text)
        except ValueError:
            raise argparse.ArgumentTypeError(f"expected an integer, got {text!r}") from None
        if value < minimum:
            raise argparse.ArgumentTypeError(f"must be at least {minimum}, got {value}")
        return value

    parse.__name__ = f"integer >= {minimum}"
    return parse


def float_above(minimum: float, inclusive: bool = False):
    """An argparse ``type``: a finite float > ``minimum`` (>= with ``inclusive``)."""

    def parse(text: str) -> float:
        try:
            value = float(text)
        except ValueError:
            raise argparse.ArgumentTypeError(f"expected a number, got {text!r}") from None
        if not (value >= minimum if inclusive else value > minimum) or value != value or value == float("inf"):
            raise argparse.ArgumentTypeError(f"must be a finite number {'>=' if inclusive else '>'} {minimum:g}, "
                                             f"got {text}")
        return value

    parse.__name__ = f"number > {minimum:g}"
    return parse


def check_object(parser: argparse.ArgumentParser, name: str | None, option: str = "--object") -> None:
    """Refuse an object that is neither a registry name nor an existing mesh file."""
    import objects

    if name is None or name in objects.names():
        return
    from objects import generated

    if generated.is_generated_name(name):
        return  # parsed, and refused with its own message, by objects.in_metres
    path = Path(name)
    if path.suffix.lower() in (".obj", ".stl", ".ply", ".off", ".glb", ".gltf"):
        if not path.is_file():
            parser.error(f"{option} {name}: mesh file not found")
        return
    parser.error(f"{option}: unknown object {name!r}; choose one of {', '.join(objects.names())}, "
                 f"generated:FAMILY/SEED, or give a mesh file (.obj, .stl, .ply)")


def check_robot(parser: argparse.ArgumentParser, name: str | None, option: str = "--robot") -> None:
    import robots

    if name is not None and name not in robots.names():
        parser.error(f"{option}: unknown robot {name!r}; choose one of {', '.join(robots.names())}")


def holds_run(path: Path) -> bool:
    """True when ``path`` holds the outputs of an earlier run (a session or metrics)."""
    return (path / "session").is_dir() or (path / "metrics.json").exists() or (path / "metadata.json").exists()


def check_out_dir(parser: argparse.ArgumentParser, path: Path, *, option: str = "--out",
                  resume: bool | None = None, reusable: bool = False) -> None:
    """Refuse an output directory that cannot or must not be written.

    ``path`` must be a directory (or not exist yet) under a writable parent. Unless ``resume`` is
    true it must be empty (or new): outputs of an earlier run are never overwritten. ``resume=None``
    means the tool has no ``--resume``; ``resume=True`` requires a run to continue. ``reusable``
    tools (a sweep, which keeps its finished runs) may write into a non-empty directory.
    """
    path = Path(path)
    if path.exists() and not path.is_dir():
        parser.error(f"{option} {path} is a file; give a directory")
    existing = path
    while not existing.exists() and existing != existing.parent:
        existing = existing.parent
    if existing.exists() and not existing.is_dir():
        parser.error(f"{option} {path}: {existing} is a file, so the directory cannot be created")
    if not os.access(existing, os.W_OK | os.X_OK):
        parser.error(f"{option} {path}: {existing} is not writable; choose another directory")
    if reusable:
        return
    if resume:
        if not holds_run(path):
            parser.error(f"{option} {path} holds no run to continue with --resume")
        return
    if path.is_dir() and any(path.iterdir()):
        what = "the outputs of an earlier run" if holds_run(path) else "files"
        fix = "continue it with --resume or choose" if resume is False and holds_run(path) else "choose"
        parser.error(f"{option} {path} already holds {what}; {fix} a new directory (nothing is overwritten)")


def check_input_file(parser: argparse.ArgumentParser, path: Path | None, option: str) -> None:
    """Refuse a missing or unreadable input file, naming the option."""
    if path is None:
        return
    if not Path(path).is_file():
        parser.error(f"{option} {path}: file not found")
    if not os.access(path, os.R_OK):
        parser.error(f"{option} {path}: file not readable")


def display_problem(environ=None) -> str | None:
    """Why a window cannot open here (None if it can, or if this is not an X11/Wayland system).

    PyBullet's GUI, without a reachable X server, prints "cannot connect to X server" and never
    returns; this check runs first.
    """
    import socket
    import sys

    environ = os.environ if environ is None else environ
    if not sys.platform.startswith("linux") or environ.get("WAYLAND_DISPLAY"):
        return None
    display = environ.get("DISPLAY", "")
    if not display:
        return "no display (DISPLAY is not set)"
    host, _, number = display.rpartition(":")
    number = number.split(".")[0]
    if not number.isdigit():
        return f"DISPLAY={display!r} is not a display name"
    if host in ("", "unix"):
        if Path(f"/tmp/.X11-unix/X{number}").exists():
            return None
        return f"no X server for DISPLAY={display} (/tmp/.X11-unix/X{number} is missing)"
    try:
        socket.create_connection((host, 6000 + int(number)), timeout=2.0).close()
    except OSError as error:
        return f"no X server reachable for DISPLAY={display}: {error}"
    return None


def check_gui(parser: argparse.ArgumentParser, option: str = "--gui", fix: str = "run without --gui") -> None:
    """Refuse a window request when no display can show it."""
    problem = display_problem()
    if problem is not None:
        parser.error(f"{option}: {problem}; {fix}")


def check_ray_address(parser: argparse.ArgumentParser, address: str | None, option: str = "--ray") -> None:
    """Refuse a ``host:port`` (or ``ray://host:port``) Ray address nobody answers at within seconds
    (``ray.init`` would retry for ever). ``local`` and ``auto`` are left to Ray."""
    import socket

    if address is None or address in ("local", "auto"):
        return
    host, _, port = address.removeprefix("ray://").rpartition(":")
    if not host or not port.isdigit():
        parser.error(f"{option} {address!r}: expected 'local', 'auto' or HOST:PORT (e.g. 10.0.0.5:6379)")
    try:
        socket.create_connection((host, int(port)), timeout=3.0).close()
    except OSError as error:
        parser.error(f"{option} {address}: no Ray cluster answers there ({error}); start one with "
                     f"'ray start --head' or use {option} local")


def _run_record(run) -> dict:
    """What the run in directory ``run`` recorded about itself: its ``metrics.json``, else its
    session's metadata; ``{}`` when neither reads (or ``run`` is None)."""
    import json
    from pathlib import Path

    if run is not None:
        for path in (Path(run) / "metrics.json", Path(run) / "session" / "metadata.json", Path(run) / "metadata.json"):
            try:
                return json.loads(path.read_text())
            except (OSError, ValueError):
                continue
    return {}


def recorded_object(prog: str, run, name: str):
    """The :class:`objects.ObjectModel` a recorded run names, or a usage error (exit 2) naming the
    run, the object and the fix: a mesh file named relative to where the run was made (runs
    recorded before 2026-11-28) loads only from that directory."""
    import sys

    import objects

    try:
        record = _run_record(run)
        return objects.load_as_recorded(name, record) if record else objects.load(name)
    except (ValueError, FileNotFoundError) as error:
        print(f"{prog}: error: {run}: its object {name!r} does not load ({error}); run this from the directory "
              "the run was made in (runs recorded since 2026-11-28 name a mesh file by its absolute path)",
              file=sys.stderr)
        raise SystemExit(EXIT_USAGE) from None
