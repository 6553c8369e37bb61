"""The reference backend's numba cache cannot go stale: every cached kernel is keyed on every file its code comes from.

numba invalidates a cached compiled function only when its own source file changes; a helper
or a constant it takes from another module is compiled into it, so a change to that module
would run the old machine code. The kernels whose code spans several files close over a hash
of all of them (``backends/reference/kernel_cache.py``), which numba puts in the cache key.
These tests check, for every cached kernel of the package, that the files its code comes
from (followed through every helper it calls and every name it reads) are its own or are in
the hash it closes over, and that numba does compile such a kernel anew when another of its
files changes.
"""

from __future__ import annotations

import ast
import importlib
import os
import pkgutil
import subprocess
import sys
import textwrap
import types
from functools import cache
from pathlib import Path

import pytest

pytest.importorskip("numba")
reference = pytest.importorskip("neurovpr.backends.reference")
from neurovpr.backends.reference import kernel_cache  # noqa: E402

PACKAGE = reference.__name__
HERE = Path(reference.__file__).parent


def _modules() -> list[types.ModuleType]:
    return [importlib.import_module(f"{PACKAGE}.{m.name}") for m in pkgutil.iter_modules([str(HERE)])]


@cache
def _definitions(module: str) -> dict[str, str | None]:
    """Top-level names of ``module`` (a module of the package) and the module each is defined in (None: outside)."""
    tree = ast.parse((HERE / f"{module}.py").read_text())
    out: dict[str, str | None] = {}
    for node in tree.body:
        if isinstance(node, ast.FunctionDef | ast.ClassDef):
            out[node.name] = module
        elif isinstance(node, ast.Assign | ast.AnnAssign):
            targets = node.targets if isinstance(node, ast.Assign) else [node.target]
            out.update({n.id: module for t in targets for n in ast.walk(t) if isinstance(n, ast.Name)})
        elif isinstance(node, ast.ImportFrom):
            for alias in node.names:
                local = alias.asname or alias.name
                if node.level == 1 and node.module:
                    out[local] = _definitions(node.module).get(alias.name)
                elif node.level == 0 and node.module and node.module.startswith(PACKAGE + "."):
                    out[local] = _definitions(node.module.removeprefix(PACKAGE + ".")).get(alias.name)
                else:
                    out[local] = None
    return out


def _global_names(code: types.CodeType) -> set[str]:
    names = set(code.co_names)
    for const in code.co_consts:
        if isinstance(const, types.CodeType):
            names |= _global_names(const)
    return names


def _sources(func: types.FunctionType) -> set[str]:
    """The modules of the package whose code or constants a compiled ``func`` is made of, through every call."""
    seen: set[types.FunctionType] = set()
    found: set[str] = set()
    todo = [func]
    while todo:
        f = todo.pop()
        if f in seen:
            continue
        seen.add(f)
        module = f.__module__.removeprefix(PACKAGE + ".")
        found.add(module)
        table = _definitions(module)
        for name in _global_names(f.__code__):
            if name not in f.__globals__:
                continue
            value = f.__globals__[name]
            if isinstance(value, types.ModuleType):  # attributes of a module of the package are read from its file
                if value.__name__.startswith(PACKAGE + "."):
                    found.add(value.__name__.removeprefix(PACKAGE + "."))
                continue
            owner = table.get(name)
            if owner is not None:
                found.add(owner)
            if hasattr(value, "py_func"):  # a numba dispatcher: its code is compiled in too
                todo.append(value.py_func)
    return found


def _cached_kernels() -> list[tuple[types.ModuleType, object]]:
    out = []
    for module in _modules():
        for value in vars(module).values():
            if hasattr(value, "py_func") and value.py_func.__module__ == module.__name__:
                if type(value._cache).__name__ != "NullCache":  # njit(cache=True)
                    out.append((module, value))
    return out


def _stamped_modules(module: types.ModuleType, kernel: object) -> set[str]:
    """The modules whose hash ``kernel`` closes over (checked against the files as they are now)."""
    closure = kernel.py_func.__closure__  # type: ignore[attr-defined]
    if not closure:
        return set()
    unit = module.CACHE_UNIT
    stamp = kernel_cache.source_stamp(module.__file__, unit)
    assert [c.cell_contents for c in closure] == [stamp], f"{kernel}: its closure is not the stamp of {unit}"
    return set(unit)


def test_every_cached_kernel_is_keyed_on_every_file_its_code_comes_from() -> None:
    kernels = _cached_kernels()
    names = {k.py_func.__name__ for _, k in kernels}  # type: ignore[attr-defined]
    assert {"run_steps", "draw_poisson", "run_loihi", "run_spinnaker", "extend_pre_table"} <= names
    uncovered = {}
    for module, kernel in kernels:
        own = module.__name__.removeprefix(PACKAGE + ".")
        missing = _sources(kernel.py_func) - {own} - _stamped_modules(module, kernel)  # type: ignore[attr-defined]
        if missing:
            uncovered[f"{own}.{kernel.py_func.__name__}"] = sorted(missing)  # type: ignore[attr-defined]
    assert not uncovered, f"cached kernels whose cache key does not see these modules change: {uncovered}"


def test_the_step_loops_span_several_files_and_close_over_all_of_them() -> None:
    from neurovpr.backends.reference import kernels, kernels_fixed

    assert _sources(kernels.run_steps.py_func) == set(kernels.CACHE_UNIT)
    assert _sources(kernels_fixed.run_loihi.py_func) == set(kernels_fixed.CACHE_UNIT)
    assert _stamped_modules(kernels_fixed, kernels_fixed.run_spinnaker) == set(kernels_fixed.CACHE_UNIT)


def test_the_walk_finds_a_constant_taken_from_another_module() -> None:
    from neurovpr.backends.reference import kernel_neurons

    assert {"kernel_neurons", "kernel_layout"} <= _sources(kernel_neurons.update_cond.py_func)  # C_* columns, F_ADAPTIVE


def test_source_stamp_changes_with_any_file() -> None:
    a = kernel_cache.source_stamp(__file__, ["test_reference_kernel_cache"])
    b = kernel_cache.source_stamp(__file__, ["test_reference_kernel_cache", "test_reference"])
    assert a != b and 0 <= a < 2**60
    assert b == kernel_cache.source_stamp(__file__, ["test_reference", "test_reference_kernel_cache", "test_reference"])


_HELPER = "from numba import njit\nK = {k}\n\n\n@njit(_nrt=False)\ndef helper(x):\n    return x + K\n"
_KERNELS = """
import importlib.util
import os

from numba import njit

from helper import helper

spec = importlib.util.spec_from_file_location("kernel_cache", os.environ["KERNEL_CACHE"])
kernel_cache = importlib.util.module_from_spec(spec)
spec.loader.exec_module(kernel_cache)


def _make(stamp):
    @njit(cache=True, _nrt=False)
    def stamped(x):
        stamp  # noqa: B018
        return helper(x)

    return stamped


@njit(cache=True, _nrt=False)
def plain(x):
    return helper(x)


stamped = _make(kernel_cache.source_stamp(__file__, ["kernels", "helper"]))
print(stamped(1), plain(1))
"""


def test_numba_compiles_a_stamped_kernel_anew_when_another_of_its_files_changes(tmp_path: Path) -> None:
    """Two files, as in the backend: after a change to the helper's file, the stamped kernel computes with the new helper."""
    (tmp_path / "kernels.py").write_text(textwrap.dedent(_KERNELS))
    env = {**os.environ, "NUMBA_DEBUG_CACHE": "1", "PYTHONPATH": str(tmp_path), "KERNEL_CACHE": kernel_cache.__file__}
    env.pop("NUMBA_DISABLE_JIT", None)

    def run(k: int) -> tuple[str, str]:
        (tmp_path / "helper.py").write_text(_HELPER.format(k=k))
        done = subprocess.run(
            [sys.executable, "-c", "import kernels"], cwd=tmp_path, env=env, capture_output=True, text=True, check=True
        )
        lines = done.stdout.splitlines()
        return lines[-1], "\n".join(lines[:-1])

    assert run(1)[0] == "2 2"
    result, log = run(1)
    assert result == "2 2" and "data loaded" in log  # the cache is in use
    result, log = run(5)
    # the stamped kernel sees the new helper; the unstamped one, keyed on its own file only, runs the old code
    assert result == "6 2", log
