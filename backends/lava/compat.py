"""Importing Lava (lava-nc 0.10.0) on Python 3.11.

lava-nc 0.10.0 declares Python 3.10 only. On 3.11 one of its modules,
``lava/magma/compiler/var_model.py``, fails to import: its dataclasses
``CoreEncoder``, ``ChipEncoder`` and ``AxonEncoder`` give fields the default
``ByteEncoder()``, an instance of another (unhashable) dataclass, which Python
3.11's ``dataclasses`` rejects ("mutable default ... is not allowed: use
default_factory"). The fix is ``field(default_factory=ByteEncoder)``.

A second module, ``lava/magma/runtime/message_infrastructure/multiprocessing.py``,
calls ``multiprocessing.set_start_method('fork')`` when imported, which raises
"context has already been set" whenever anything in the process used
multiprocessing first (a process pool, a queue): Lava then fails to import
depending on import order. Lava needs the ``fork`` start method, so the call gets
``force=True``; a process that already uses another start method is refused with
a clear message instead.

This module applies both fixes without touching the installed files: a meta-path
finder, installed before Lava is imported, loads *those two modules* from their
installed source, rewrites the syntax tree (each field default that calls a
dataclass defined in the same module with no arguments becomes
``field(default_factory=ThatClass)``; the ``set_start_method('fork')`` call gets
``force=True``) and compiles the result. Nothing else is changed, no bytecode is
cached, and no other module is affected. The rewrite only ever sees Lava's own
source files, never user data.
"""

from __future__ import annotations

import ast
import importlib
import importlib.abc
import importlib.machinery
import importlib.metadata
import multiprocessing
import sys
from collections.abc import Callable
from types import ModuleType, SimpleNamespace
from typing import Any

from neurovpr.errors import BackendUnavailableError

__all__ = [
    "LAVA_VERSION",
    "TARGET_MODULE",
    "START_METHOD_MODULE",
    "INSTALL_HINT",
    "LavaFix",
    "install_fix",
    "rewrite_mutable_defaults",
    "rewrite_start_method",
    "import_lava",
]

#: The lava-nc release the backends are written and tested for.
LAVA_VERSION = "0.10.0"
#: The module with the mutable dataclass defaults.
TARGET_MODULE = "lava.magma.compiler.var_model"
#: The module that sets the multiprocessing start method when imported.
START_METHOD_MODULE = "lava.magma.runtime.message_infrastructure.multiprocessing"
#: How to (re)install Lava so that it imports here.
INSTALL_HINT = (
    "install it with scripts/install_lava.sh from the neurovpr source tree (Lava's dependencies, then "
    f"`pip install --no-deps --ignore-requires-python lava-nc=={LAVA_VERSION}`; the 'lava' extra "
    "installs the dependencies only)"
)
_FIELD_ALIAS = "_neurovpr_dataclass_field"


def _is_dataclass_decorator(node: ast.expr) -> bool:
    target = node.func if isinstance(node, ast.Call) else node
    if isinstance(target, ast.Name):
        return target.id == "dataclass"
    return isinstance(target, ast.Attribute) and target.attr == "dataclass"


def rewrite_mutable_defaults(source: str | bytes, filename: str) -> tuple[ast.Module, int]:
    """Rewrite ``x: T = T()`` dataclass field defaults into ``field(default_factory=T)``.

    Only fields of ``@dataclass`` classes whose default is a call, without arguments,
    of a ``@dataclass`` class defined at the top level of the same module are
    rewritten: exactly the defaults Python 3.11 rejects as mutable.

    Parameters
    ----------
    source
        The module's source text.
    filename
        Its path (for error messages and tracebacks).

    Returns
    -------
    tree : ast.Module
        The rewritten syntax tree, ready for :func:`compile`.
    count : int
        How many field defaults were rewritten.
    """
    tree = ast.parse(source, filename=filename)
    classes = [
        node
        for node in tree.body
        if isinstance(node, ast.ClassDef) and any(_is_dataclass_decorator(d) for d in node.decorator_list)
    ]
    dataclass_names = {cls.name for cls in classes}
    count = 0
    for cls in classes:
        for stmt in cls.body:
            value = stmt.value if isinstance(stmt, ast.AnnAssign) else None
            if (
                isinstance(value, ast.Call)
                and isinstance(value.func, ast.Name)
                and value.func.id in dataclass_names
                and not value.args
                and not value.keywords
            ):
                factory = ast.Name(id=value.func.id, ctx=ast.Load())
                stmt.value = ast.Call(  # type: ignore[union-attr]
                    func=ast.Name(id=_FIELD_ALIAS, ctx=ast.Load()),
                    args=[],
                    keywords=[ast.keyword(arg="default_factory", value=factory)],
                )
                ast.copy_location(stmt.value, value)  # type: ignore[union-attr]
                count += 1
    if count:
        # after the docstring and ``from __future__`` imports, which must come first
        at = 0
        while at < len(tree.body) and (
            (isinstance(tree.body[at], ast.ImportFrom) and tree.body[at].module == "__future__")  # type: ignore[attr-defined]
            or (at == 0 and isinstance(tree.body[0], ast.Expr) and isinstance(tree.body[0].value, ast.Constant))  # type: ignore[attr-defined]
        ):
            at += 1
        imp = ast.ImportFrom(module="dataclasses", names=[ast.alias(name="field", asname=_FIELD_ALIAS)], level=0)
        tree.body.insert(at, imp)
    ast.fix_missing_locations(tree)
    return tree, count


def rewrite_start_method(source: str | bytes, filename: str) -> tuple[ast.Module, int]:
    """Add ``force=True`` to every ``<module>.set_start_method('fork')`` call.

    Returns
    -------
    tree : ast.Module
        The rewritten syntax tree.
    count : int
        How many calls were rewritten (1 for lava-nc 0.10.0).
    """
    tree = ast.parse(source, filename=filename)
    count = 0
    for node in ast.walk(tree):
        if (
            isinstance(node, ast.Call)
            and isinstance(node.func, ast.Attribute)
            and node.func.attr == "set_start_method"
            and len(node.args) == 1
            and isinstance(node.args[0], ast.Constant)
            and node.args[0].value == "fork"
            and not node.keywords
        ):
            node.keywords.append(ast.keyword(arg="force", value=ast.Constant(value=True)))
            count += 1
    ast.fix_missing_locations(tree)
    return tree, count


#: The rewrite applied to each module the finder handles.
_REWRITES: dict[str, Callable[[str | bytes, str], tuple[ast.Module, int]]] = {
    TARGET_MODULE: rewrite_mutable_defaults,
    START_METHOD_MODULE: rewrite_start_method,
}


class _RewritingLoader(importlib.machinery.SourceFileLoader):
    """Loads one module from source through its rewrite, without bytecode caching."""

    def __init__(self, fullname: str, path: str, fix: LavaFix) -> None:
        super().__init__(fullname, path)
        self._fix = fix

    def get_code(self, fullname: str) -> Any:
        source = self.get_data(self.path)
        tree, count = _REWRITES[fullname](source, self.path)
        self._fix.rewritten[fullname] = count
        return compile(tree, self.path, "exec", dont_inherit=True)


class LavaFix(importlib.abc.MetaPathFinder):
    """A meta-path finder that routes :data:`TARGET_MODULE` and :data:`START_METHOD_MODULE` through their rewrites.

    Attributes
    ----------
    rewritten
        For each module loaded through this finder, the number of places rewritten
        (8 defaults and 1 call for lava-nc 0.10.0).
    """

    def __init__(self) -> None:
        self.rewritten: dict[str, int] = {}

    def find_spec(self, fullname: str, path: Any = None, target: ModuleType | None = None) -> Any:
        """Find one of the two modules as usual, then give it the rewriting loader."""
        if fullname not in _REWRITES:
            return None
        spec = importlib.machinery.PathFinder.find_spec(fullname, path)
        if spec is None or not isinstance(spec.loader, importlib.machinery.SourceFileLoader) or spec.origin is None:
            return None
        spec.loader = _RewritingLoader(fullname, spec.origin, self)
        return spec


def install_fix() -> LavaFix:
    """Put the :class:`LavaFix` finder first on ``sys.meta_path`` (once) and return it."""
    for finder in sys.meta_path:
        if isinstance(finder, LavaFix):
            return finder
    finder = LavaFix()
    sys.meta_path.insert(0, finder)
    return finder


def _installed_version() -> str | None:
    try:
        return importlib.metadata.version("lava-nc")
    except importlib.metadata.PackageNotFoundError:
        return None


def import_lava(*, apply_fix: bool = True) -> SimpleNamespace:
    """Import the parts of Lava the backends use.

    Parameters
    ----------
    apply_fix
        Install the :class:`LavaFix` first (``False`` imports Lava as installed,
        e.g. to check whether it needs the fix).

    Returns
    -------
    types.SimpleNamespace
        ``LIF``, ``LIFRefractory``, ``Dense``, ``DelayDense``, ``Sparse``,
        ``DelaySparse``, ``Conv``, ``SignMode``, ``Injector``, ``Extractor``, ``Loihi2SimCfg``,
        ``RunSteps`` and ``version``.

    Raises
    ------
    BackendUnavailableError
        With the underlying error, whether the Python 3.11 fix was applied and how
        to reinstall.
    """
    version = _installed_version()
    if version is None:
        raise BackendUnavailableError(f"lava-nc is not installed; {INSTALL_HINT}.")
    method = multiprocessing.get_start_method(allow_none=True)
    if method not in (None, "fork") and START_METHOD_MODULE not in sys.modules:
        raise BackendUnavailableError(
            f"Lava's runtime needs the multiprocessing start method 'fork', but this process already uses {method!r}"
        )
    fix = install_fix() if apply_fix else None
    try:
        from lava.magma.core.run_conditions import RunSteps
        from lava.magma.core.run_configs import Loihi2SimCfg
        from lava.proc.conv.process import Conv
        from lava.proc.dense.process import DelayDense, Dense
        from lava.proc.io.extractor import Extractor
        from lava.proc.io.injector import Injector
        from lava.proc.lif.process import LIF, LIFRefractory
        from lava.proc.sparse.process import DelaySparse, Sparse
        from lava.utils.weightutils import SignMode
    except Exception as exc:
        cause = f"{type(exc).__name__}: {exc}"
        mutable = "mutable default" in str(exc)
        if fix is None and mutable:
            what = (
                f"lava-nc {version} does not import on Python {sys.version_info[0]}.{sys.version_info[1]} "
                f"({cause}) and the Python 3.11 fix for {TARGET_MODULE.replace('.', '/')}.py is not applied"
            )
        elif fix is not None and mutable and not fix.rewritten.get(TARGET_MODULE):
            what = (
                f"lava-nc {version} does not import ({cause}): neurovpr's Python 3.11 fix for "
                f"{TARGET_MODULE.replace('.', '/')}.py found none of the expected `= ByteEncoder()` field "
                f"defaults (written for lava-nc {LAVA_VERSION})"
            )
        else:
            what = f"lava-nc {version} failed to import ({cause})"
        raise BackendUnavailableError(f"{what}; {INSTALL_HINT}.") from exc
    return SimpleNamespace(
        LIF=LIF,
        LIFRefractory=LIFRefractory,
        Dense=Dense,
        DelayDense=DelayDense,
        DelaySparse=DelaySparse,
        Sparse=Sparse,
        Conv=Conv,
        SignMode=SignMode,
        Injector=Injector,
        Extractor=Extractor,
        Loihi2SimCfg=Loihi2SimCfg,
        RunSteps=RunSteps,
        version=version,
    )
