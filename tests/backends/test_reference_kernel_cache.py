"""The reference kernels' numba cache cannot go stale: everything they read is defined in kernels.py.

numba invalidates a cached compiled function only when its own source file changes, so a
constant a kernel reads from another module would be baked into the cached machine code
and a change to that module would run the old value.
"""

from __future__ import annotations

import ast
import inspect
import types

import pytest

kernels = pytest.importorskip("neurovpr.backends.reference.kernels")

#: Names a kernel may take from another module: the prefetch hint cannot change a result.
_HINTS = {"prefetch"}


def _top_level_names(tree: ast.Module) -> set[str]:
    names: set[str] = set()
    for node in tree.body:
        if isinstance(node, ast.FunctionDef | ast.ClassDef):
            names.add(node.name)
        elif isinstance(node, ast.Assign | ast.AnnAssign):
            targets = node.targets if isinstance(node, ast.Assign) else [node.target]
            for target in targets:
                names.update(n.id for n in ast.walk(target) if isinstance(n, ast.Name))
    return names


def _global_names(code: types.CodeType) -> set[str]:
    names = set(code.co_names)
    for const in code.co_consts:
        if isinstance(const, types.CodeType):
            names |= _global_names(const)
    return names


def _kernels() -> list:
    return [f for f in vars(kernels).values() if hasattr(f, "py_func") and f.__module__ == kernels.__name__]


def test_kernels_import_only_the_prefetch_hint_from_the_package() -> None:
    tree = ast.parse(inspect.getsource(kernels))
    relative = {a.asname or a.name for node in tree.body if isinstance(node, ast.ImportFrom) and node.level for a in node.names}
    assert relative == _HINTS


def test_every_global_a_kernel_reads_is_defined_in_kernels_py() -> None:
    defined = _top_level_names(ast.parse(inspect.getsource(kernels)))
    compiled = _kernels()
    assert {"run_steps", "emit", "arrive"} <= {f.__name__ for f in compiled}
    foreign = {
        f"{f.__name__}: {name}"
        for f in compiled
        for name in _global_names(f.py_func.__code__)
        if name in vars(kernels)
        and name not in defined
        and name not in _HINTS
        and not isinstance(vars(kernels)[name], types.ModuleType)
    }
    assert not foreign, (
        f"kernels read names defined in other modules (numba's cache would not see them change): {sorted(foreign)}"
    )


def test_layout_modules_take_their_constants_from_the_kernels() -> None:
    from neurovpr.backends.reference import convolution, delivery, translation

    assert translation.C_V_THRESH is kernels.C_V_THRESH and translation.N_RULE_COLS == kernels.N_RULE_COLS
    assert convolution.CV_WOFF is kernels.CV_WOFF
    assert delivery.BLOCK_SHIFT is kernels.BLOCK_SHIFT
