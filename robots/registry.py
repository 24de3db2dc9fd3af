"""Named robot specs: the built-in arms plus any a user registers.

``robots.load(name)`` looks a name up in the default registry; a path to a ``.json`` spec file
(see :meth:`RobotSpec.to_json`) is loaded and checked against its URDF instead.
"""
from __future__ import annotations

import math
from pathlib import Path
from typing import Callable

from robots import armar3, armar6
from robots.generate import urdf_path
from robots.spec import RobotSpec
from robots.urdf_check import check_spec_against_urdf


ARMAR3_HOME_Q_RAD = tuple(math.radians(d) for d in (-15.0, 30.0, 15.0, -90.0, 35.0, 5.0, 40.0))
ARMAR6_HOME_Q_RAD = tuple(math.radians(d) for d in (15.0, -15.0, 45.0, 25.0, -95.0, 20.0, 50.0, 40.0))


def armar3_spec() -> RobotSpec:
    """ARMAR-III right arm, fixed torso at the world origin facing +x (shoulder 1.30 m high).

    Workspace centre: (0.38, -0.33, 0.90) m, the middle of a ~0.3 m object on a 0.75 m table,
    where the most approach directions are reachable (the ARMAR-III wrist is short of range:
    pointing straight down works only in a small region).
    Home: elbow flexed, pad at about (0.44, -0.28, 1.00) m pointing forward and down.
    """
    return RobotSpec(
        name=armar3.NAME,
        urdf_path=urdf_path(armar3.NAME),
        joint_names=armar3.JOINT_NAMES,
        home_q_rad=ARMAR3_HOME_Q_RAD,
        workspace_center_m=(0.38, -0.33, 0.90),
    )


def armar6_spec() -> RobotSpec:
    """ARMAR-6-style 8-DOF right arm, fixed torso at the world origin facing +x (shoulder 1.40 m).

    Workspace centre: (0.40, -0.25, 0.90) m; most approach directions are reachable there.
    Home: pad at about (0.51, -0.28, 1.03) m pointing mostly down.
    """
    return RobotSpec(
        name=armar6.NAME,
        urdf_path=urdf_path(armar6.NAME),
        joint_names=armar6.JOINT_NAMES,
        home_q_rad=ARMAR6_HOME_Q_RAD,
        workspace_center_m=(0.40, -0.25, 0.90),
    )


class RobotRegistry:
    """A name -> RobotSpec table; built-in specs are created on first use."""

    def __init__(self, builtins: dict[str, Callable[[], RobotSpec]] | None = None):
        self._factories: dict[str, Callable[[], RobotSpec]] = dict(builtins or {})
        self._specs: dict[str, RobotSpec] = {}

    def names(self) -> list[str]:
        """Every registered name, sorted."""
        return sorted(set(self._factories) | set(self._specs))

    def register(self, spec: RobotSpec, replace: bool = False) -> RobotSpec:
        """Add ``spec`` after checking its URDF; a taken name needs ``replace=True``."""
        if not isinstance(spec, RobotSpec):
            raise TypeError(f"register() takes a RobotSpec, got {type(spec).__name__}")
        if spec.name in self.names() and not replace:
            raise ValueError(f"a robot named {spec.name!r} is already registered (pass replace=True)")
        check_spec_against_urdf(spec)
        self._factories.pop(spec.name, None)
        self._specs[spec.name] = spec
        return spec

    def load(self, name_or_path: str | Path) -> RobotSpec:
        """The spec registered as ``name_or_path``, or the one stored in that ``.json`` file."""
        key = str(name_or_path)
        if key in self._specs:
            return self._specs[key]
        if key in self._factories:
            self._specs[key] = self._factories.pop(key)()
            return self._specs[key]
        path = Path(name_or_path)
        if path.suffix == ".json":
            spec = RobotSpec.from_json(path)
            check_spec_against_urdf(spec)
            return spec
        raise ValueError(
            f"unknown robot {key!r}; valid names: {', '.join(self.names())} "
            "(or a path to a robot spec .json file)"
        )


DEFAULT_REGISTRY = RobotRegistry({armar3.NAME: armar3_spec, armar6.NAME: armar6_spec})


def names() -> list[str]:
    """Names of the robots in the default registry."""
    return DEFAULT_REGISTRY.names()


def load(name_or_path: str | Path) -> RobotSpec:
    """A robot spec by registered name, or from a ``.json`` spec file (checked against its URDF)."""
    return DEFAULT_REGISTRY.load(name_or_path)


def register(spec: RobotSpec, replace: bool = False) -> RobotSpec:
    """Register ``spec`` in the default registry (its URDF must carry the named fingertip)."""
    return DEFAULT_REGISTRY.register(spec, replace=replace)
