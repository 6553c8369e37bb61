"""The wheel holds every package of the tree: pyproject.toml lists each one (setuptools' explicit list)."""

from __future__ import annotations

import tomllib
from pathlib import Path

ROOT = Path(__file__).resolve().parents[2]


def _config() -> dict:
    with (ROOT / "pyproject.toml").open("rb") as handle:
        return tomllib.load(handle)


def _packages_in_tree(package_dir: dict[str, str]) -> set[str]:
    """Every folder with an ``__init__.py`` under a mapped folder, named as it installs."""
    found: set[str] = set()
    for name, folder in package_dir.items():
        base = ROOT / folder
        for init in base.rglob("__init__.py"):
            if ".venv" in init.parts or "__pycache__" in init.parts:
                continue
            relative = init.parent.relative_to(base).parts
            found.add(".".join((name, *relative)))
    return found


def test_every_package_is_listed() -> None:
    setuptools = _config()["tool"]["setuptools"]
    listed = set(setuptools["packages"])
    in_tree = _packages_in_tree(setuptools["package-dir"])
    assert in_tree - listed == set(), "packages in the tree but not in pyproject.toml's list (left out of the wheel)"
    assert listed - in_tree == set(), "packages listed in pyproject.toml that the tree does not have"


def test_every_entry_point_module_is_packaged() -> None:
    config = _config()
    listed = set(config["tool"]["setuptools"]["packages"])
    for group, points in config["project"]["entry-points"].items():
        for name, target in points.items():
            module = target.split(":")[0]
            package = module if module in listed else module.rpartition(".")[0]
            assert package in listed, f"entry point {name!r} of {group!r} points into {module!r}, which the wheel does not hold"
