"""Regenerate the committed robot URDFs from their Python data: ``python -m robots.generate``."""
from __future__ import annotations

import argparse
from pathlib import Path
from typing import Callable

from robots import armar3, armar6
from robots.urdf_model import RobotModel, to_urdf

DATA_DIR = Path(__file__).resolve().parent / "data"

MODELS: dict[str, Callable[[], RobotModel]] = {
    armar3.NAME: armar3.model,
    armar6.NAME: armar6.model,
}


def urdf_text(name: str) -> str:
    """The URDF text generated for the built-in robot ``name``."""
    if name not in MODELS:
        raise ValueError(f"no generated robot named {name!r}; known: {sorted(MODELS)}")
    source = f"robots/{name}.py"
    return to_urdf(MODELS[name](), comment=f"Generated from {source} by 'python -m robots.generate'. Do not edit.")


def urdf_path(name: str, directory: Path = DATA_DIR) -> Path:
    """Where the URDF of built-in robot ``name`` is stored."""
    return Path(directory) / f"{name}.urdf"


def write_all(directory: Path = DATA_DIR) -> list[Path]:
    """Write every built-in robot's URDF into ``directory``; returns the paths written."""
    directory = Path(directory)
    directory.mkdir(parents=True, exist_ok=True)
    written = []
    for name in MODELS:
        path = urdf_path(name, directory)
        path.write_text(urdf_text(name))
        written.append(path)
    return written


def main(argv: list[str] | None = None) -> None:
    parser = argparse.ArgumentParser(description=__doc__)
    parser.add_argument("--out", type=Path, default=DATA_DIR, help="output directory")
    args = parser.parse_args(argv)
    for path in write_all(args.out):
        print(path)


if __name__ == "__main__":
    main()
