"""Package roots that export their public names without importing them up front.

A root lists ``{name: module}`` and gets a module ``__getattr__`` (PEP 562) that imports the
module on first use, so ``import explorer`` stays light (no torch, no pybullet) while
``from explorer import GPIS``-style imports work.
"""
from __future__ import annotations

import importlib
import sys
from typing import Callable


def lazy_exports(package: str, names: dict[str, str]) -> tuple[Callable[[str], object], Callable[[], list[str]]]:
    """``(__getattr__, __dir__)`` for the package ``package`` whose public ``names`` live in the given modules."""

    def __getattr__(name: str):
        if name in names:
            return getattr(importlib.import_module(names[name]), name)
        raise AttributeError(f"module {package!r} has no attribute {name!r}")

    def __dir__() -> list[str]:
        return sorted(set(vars(sys.modules[package])) | set(names))

    return __getattr__, __dir__
