"""Chip architectures, found by name through the ``neurovpr.architectures`` entry point.

An architecture is what a hwspec's ``[hardware].partitioner`` names: the vendor rules
that cut a network onto its cores (:attr:`Architecture.partition`), the table of the
hwspec those rules read (:attr:`Architecture.table`, loaded into
:attr:`Architecture.rules`), the ``[core]`` limits they need, and the time step the
vendor toolchain really runs. neurovpr declares ``loihi`` (NengoLoihi's block
splitting, :mod:`.loihi`) and ``spinnaker`` (sPyNNaker and PACMAN, :mod:`.spinnaker`);
another package adds one with an entry point, without touching neurovpr::

    [project.entry-points."neurovpr.architectures"]
    mychip = "mypackage.mychip:ARCHITECTURE"

docs/hardware_architectures.md walks through adding one.
"""

from __future__ import annotations

from collections.abc import Callable
from dataclasses import dataclass
from typing import TYPE_CHECKING

from neurovpr import entrypoints
from neurovpr.errors import ValidationError

if TYPE_CHECKING:

    from .cores import Partition
    from .hwspec import HwSpec

__all__ = ["Architecture", "ENTRY_POINT_GROUP", "get_architecture", "known_architectures"]

ENTRY_POINT_GROUP = "neurovpr.architectures"


def _as_run(spec: HwSpec) -> tuple[HwSpec, tuple[str, ...]]:
    return spec, ()


@dataclass(frozen=True, slots=True, kw_only=True)
class Architecture:
    """One chip architecture: its partitioner and what it reads from a hwspec.

    Attributes
    ----------
    name
        The name a hwspec gives in ``[hardware].partitioner``.
    table
        The hwspec table holding the architecture's own constants (e.g. ``"synapse_encoding"``).
    rules
        The frozen dataclass that table is loaded into (``HwSpec.rules``); its fields are
        declared with :func:`neurovpr.hardware.hwspec.spec_field`.
    partition
        ``partition(network, spec, *, seed) -> Partition``: the vendor's slicing and
        placement with the per-core usage and the limits it breaks. It receives the spec
        :attr:`runs_at` returns.
    required_core
        ``[core]`` fields the partitioner needs (optional in the schema, required here).
    runs_at
        ``runs_at(spec) -> (spec, notes)``: the spec at the step the toolchain really runs
        (sPyNNaker: whole microseconds), and a note for each change; the spec as given by default.
    """

    name: str
    table: str
    rules: type
    partition: Callable[..., Partition]
    required_core: tuple[str, ...] = ()
    runs_at: Callable[[HwSpec], tuple[HwSpec, tuple[str, ...]]] = _as_run


def known_architectures() -> list[str]:
    """Names of the declared architectures, sorted."""
    return entrypoints.declared_names(ENTRY_POINT_GROUP)


def get_architecture(name: str) -> Architecture:
    """The architecture declared under ``name``.

    Raises
    ------
    ValidationError
        If none is declared under that name (the message lists the known ones), or its
        entry point does not load an :class:`Architecture`.
    """
    arch = entrypoints.load_declared(
        ENTRY_POINT_GROUP, name, Architecture, what="architecture", unknown=ValidationError, broken=ValidationError
    )
    if arch.name != name:
        raise ValidationError(f"Architecture {name!r} is declared, but its entry point provides {arch.name!r}.")
    return arch
