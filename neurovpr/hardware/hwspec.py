"""Hardware specifications: loading and validating ``hwspecs/<name>.toml``.

A hwspec file describes one neuromorphic target: how many chips and cores it has, the
per-core limits, how synapses are encoded, its number formats, time step, energy per
operation and the features it can host. Every number in the file carries its source in
a comment; this module only reads and checks them. Nothing read from a file is executed.

The file is split into tables, each loaded into a frozen dataclass:

``[hardware]``
    name, title, partitioner (the architecture whose rules split populations onto
    cores: ``"loihi"``, ``"spinnaker"`` or any declared in the ``neurovpr.architectures``
    entry point, see :mod:`.architectures`), toolchain.
``[chip]``, ``[core]``
    chip and core counts and per-core limits.
``[formats]``, ``[timing]``, ``[energy]``, ``[features]``
    number formats (with ``arithmetic``, the integer arithmetic a backend emulates them
    in), time step and delays, energy per operation, hosted features.
the architecture's own table
    named by the architecture (``[synapse_encoding]`` for ``loihi``, ``[spinnaker]`` for
    ``spinnaker``) and loaded into its rules dataclass, ``HwSpec.rules``.
"""

from __future__ import annotations

import dataclasses
import math
import tomllib
from dataclasses import dataclass, field
from importlib import resources
from pathlib import Path
from typing import Any

from neurovpr.errors import ValidationError

from .architectures import get_architecture

__all__ = [
    "HwSpec",
    "HardwareInfo",
    "ChipSpec",
    "CoreSpec",
    "Formats",
    "Timing",
    "EnergySpec",
    "Features",
    "load_hwspec",
    "known_hwspecs",
    "spec_field",
]

_KW = {"frozen": True, "slots": True, "kw_only": True}


def spec_field(kind: str, *, optional: bool = False, low: float | None = None, default: Any = None) -> Any:
    """A hwspec field: ``kind`` is int, float, bool, str, int_list, int_rows or str_list.

    Every table's dataclass (an architecture's rules too) declares its fields with this,
    so that loading validates them the same way.
    """
    meta = {"kind": kind, "optional": optional, "low": low}
    if optional:
        return field(default=default, metadata=meta)
    return field(metadata=meta)


@dataclass(**_KW)
class HardwareInfo:
    """``[hardware]``: identity of the target and whose mapping rules apply."""

    name: str = spec_field("str")
    title: str = spec_field("str")
    partitioner: str = spec_field("str")
    toolchain: str = spec_field("str")


@dataclass(**_KW)
class ChipSpec:
    """``[chip]``: chips and cores."""

    n_chips: int = spec_field("int", low=1)
    cores_per_chip: int = spec_field("int", low=1)
    app_cores_per_chip: int = spec_field("int", low=1)


@dataclass(**_KW)
class CoreSpec:
    """``[core]``: per-core limits; ``None`` where the target has no such per-core limit."""

    max_neurons: int = spec_field("int", low=1)
    max_input_axons: int | None = spec_field("int", optional=True, low=1)
    max_output_axons: int | None = spec_field("int", optional=True, low=1)
    synapse_memory_bits: int | None = spec_field("int", optional=True, low=1)
    neuron_state_bits: int = spec_field("int", optional=True, low=0, default=0)


@dataclass(**_KW)
class Formats:
    """``[formats]``: number formats of weights and neuron state, and the arithmetic they are computed in."""

    weight_bits: int = spec_field("int", low=1)
    weight_signed: bool = spec_field("bool")
    weight_mantissa_bits: int = spec_field("int", low=1)
    weight_exponent_min: int = spec_field("int")
    weight_exponent_max: int = spec_field("int")
    weight_exponent_offset: int = spec_field("int")
    weight_scaling: str = spec_field("str")
    state_format: str = spec_field("str")
    fraction_bits: int = spec_field("int", low=0)
    voltage_bits: int = spec_field("int", low=1)
    current_bits: int = spec_field("int", low=1)
    decay_bits: int = spec_field("int", low=1)
    threshold_mantissa_bits: int = spec_field("int", low=1)
    threshold_exponent: int = spec_field("int", low=0)
    bias_mantissa_bits: int = spec_field("int", low=1)
    bias_exponent_max: int = spec_field("int", low=0)
    accumulator_bits: int = spec_field("int", low=1)
    #: Bits a mapping keeps in ``u`` and ``v`` above the threshold (Loihi 2: the largest threshold
    #: integer is ``2**(voltage_bits - 1 - threshold_exponent - voltage_headroom_bits)``).
    voltage_headroom_bits: int | None = spec_field("int", optional=True, low=0)
    #: The integer arithmetic these formats are computed in (its update order, rounding and
    #: overflow rules): ``"loihi1"`` (NengoLoihi 1.1's emulator), ``"loihi2"`` (Lava 0.10's
    #: bit-accurate models), ``"spinnaker"`` (sPyNNaker 7.4's LIF). A backend emulates a hwspec
    #: whose arithmetic it declares (``Capabilities.arithmetic``); without one the hwspec is
    #: checked but not emulated.
    arithmetic: str | None = spec_field("str", optional=True)


@dataclass(**_KW)
class Timing:
    """``[timing]``: time step (ms), real-time operation and the longest delay (steps)."""

    time_step_ms: float = spec_field("float", low=0.0)
    real_time: bool = spec_field("bool")
    max_delay_steps: int = spec_field("int", low=1)


@dataclass(**_KW)
class EnergySpec:
    """``[energy]``: energy per operation (pJ) and power (W); ``None`` where unpublished."""

    synaptic_op_pJ: float | None = spec_field("float", optional=True, low=0.0)
    synaptic_update_pJ: float | None = spec_field("float", optional=True, low=0.0)
    neuron_update_pJ: float | None = spec_field("float", optional=True, low=0.0)
    neuron_active_update_pJ: float | None = spec_field("float", optional=True, low=0.0)
    spike_within_chip_pJ: float | None = spec_field("float", optional=True, low=0.0)
    spike_between_chips_pJ: float | None = spec_field("float", optional=True, low=0.0)
    static_power_per_chip_W: float | None = spec_field("float", optional=True, low=0.0)
    board_static_power_W: float | None = spec_field("float", optional=True, low=0.0)
    active_core_power_W: float | None = spec_field("float", optional=True, low=0.0)
    wall_time_per_step_s: float = spec_field("float", low=0.0)
    basis: str = spec_field("str")


@dataclass(**_KW)
class Features:
    """``[features]``: IR type names the target can host."""

    neuron_models: tuple[str, ...] = spec_field("str_list")
    plasticity: tuple[str, ...] = spec_field("str_list")
    connectors: tuple[str, ...] = spec_field("str_list")


@dataclass(**_KW)
class HwSpec:
    """One hardware target, as read from its TOML file.

    Attributes
    ----------
    name : str
        The hwspec name (``[hardware].name``), e.g. ``"kapoho-bay"``.
    rules : object
        The architecture's own table (its :attr:`~.architectures.Architecture.rules` dataclass).
    source : str
        The file it was read from.
    """

    hardware: HardwareInfo
    chip: ChipSpec
    core: CoreSpec
    formats: Formats
    timing: Timing
    energy: EnergySpec
    features: Features
    rules: Any = None
    source: str = ""

    @property
    def name(self) -> str:
        """The target's name."""
        return self.hardware.name

    @property
    def title(self) -> str:
        """Human-readable name of the target."""
        return self.hardware.title

    @property
    def partitioner(self) -> str:
        """The architecture whose rules split populations onto cores (``"loihi"``, ``"spinnaker"``, ...)."""
        return self.hardware.partitioner

    @property
    def total_cores(self) -> int:
        """Application cores on all chips (an upper bound for SpiNNaker, see the placer)."""
        return self.chip.n_chips * self.chip.app_cores_per_chip


_SECTIONS: dict[str, type] = {
    "hardware": HardwareInfo,
    "chip": ChipSpec,
    "core": CoreSpec,
    "formats": Formats,
    "timing": Timing,
    "energy": EnergySpec,
    "features": Features,
}


def _hwspec_dir() -> Path:
    return Path(str(resources.files("neurovpr.hwspecs")))


def known_hwspecs() -> list[str]:
    """Names of the hwspecs shipped with neurovpr, sorted."""
    return sorted(p.stem for p in _hwspec_dir().glob("*.toml"))


def _convert(where: str, kind: str, value: Any, low: float | None) -> Any:
    def bad(expected: str) -> ValidationError:
        return ValidationError(f"{where} must be {expected}, got {value!r}.")

    if kind == "str":
        if not isinstance(value, str) or not value.strip():
            raise bad("a non-empty string")
        return value
    if kind == "bool":
        if not isinstance(value, bool):
            raise bad("true or false")
        return value
    if kind in ("int", "float"):
        ok = isinstance(value, int) if kind == "int" else isinstance(value, (int, float))
        if isinstance(value, bool) or not ok or not math.isfinite(value):
            raise bad("an integer" if kind == "int" else "a number")
        if low is not None and value < low:
            raise bad(f">= {low:g}")
        return int(value) if kind == "int" else float(value)
    if kind == "str_list":
        if not isinstance(value, list) or not all(isinstance(v, str) for v in value):
            raise bad("a list of strings")
        return tuple(value)
    if kind == "int_list":
        if not isinstance(value, list) or not value or not all(type(v) is int for v in value):
            raise bad("a non-empty list of integers")
        return tuple(value)
    if kind == "int_rows":
        if not isinstance(value, list) or not all(
            isinstance(r, list) and r and all(type(v) is int for v in r) for r in value
        ):
            raise bad("a list of lists of integers")
        return tuple(tuple(r) for r in value)
    raise AssertionError(kind)  # pragma: no cover - schema error


def _section(path: str, name: str, table: Any, cls: type) -> Any:
    if not isinstance(table, dict):
        raise ValidationError(f"hwspec file {path!r}: [{name}] must be a table.")
    names = {f.name for f in dataclasses.fields(cls)}
    unknown = sorted(set(table) - names)
    if unknown:
        raise ValidationError(
            f"hwspec file {path!r}: unknown field [{name}].{unknown[0]} (known: {', '.join(sorted(names))})."
        )
    values: dict[str, Any] = {}
    for f in dataclasses.fields(cls):
        meta = f.metadata
        if f.name not in table:
            if meta["optional"]:
                continue
            raise ValidationError(f"hwspec file {path!r}: missing field [{name}].{f.name}.")
        values[f.name] = _convert(f"hwspec file {path!r}: [{name}].{f.name}", meta["kind"], table[f.name], meta["low"])
    return cls(**values)


def _parse(path: Path) -> HwSpec:
    where = str(path)
    try:
        data = tomllib.loads(path.read_text(encoding="utf-8"))
    except tomllib.TOMLDecodeError as exc:
        raise ValidationError(f"hwspec file {where!r} is not valid TOML: {exc}.") from None
    except (OSError, UnicodeDecodeError) as exc:
        raise ValidationError(f"hwspec file {where!r} cannot be read: {exc}.") from None
    if "hardware" not in data:
        raise ValidationError(f"hwspec file {where!r}: missing table [hardware].")
    partitioner = _section(where, "hardware", data["hardware"], HardwareInfo).partitioner
    try:
        arch = get_architecture(partitioner)
    except ValidationError as exc:
        raise ValidationError(f"hwspec file {where!r}: [hardware].partitioner: {exc}") from None
    tables = {**_SECTIONS, arch.table: arch.rules}
    unknown = sorted(set(data) - set(tables))
    if unknown:
        raise ValidationError(
            f"hwspec file {where!r}: unknown table [{unknown[0]}] (known for the {arch.name} architecture: "
            f"{', '.join(tables)})."
        )
    parts: dict[str, Any] = {}
    for name, cls in tables.items():
        if name not in data:
            required = f" (required by the {arch.name} partitioner)" if name == arch.table else ""
            raise ValidationError(f"hwspec file {where!r}: missing table [{name}]{required}.")
        parts[name] = _section(where, name, data[name], cls)
    for key in arch.required_core:
        if getattr(parts["core"], key) is None:
            raise ValidationError(
                f"hwspec file {where!r}: missing field [core].{key} (required by the {arch.name} partitioner)."
            )
    rules = parts.pop(arch.table)
    fmt = parts["formats"]
    if fmt.weight_exponent_min > fmt.weight_exponent_max:
        raise ValidationError(
            f"hwspec file {where!r}: [formats].weight_exponent_min ({fmt.weight_exponent_min}) "
            f"exceeds weight_exponent_max ({fmt.weight_exponent_max})."
        )
    return HwSpec(**parts, rules=rules, source=where)


def load_hwspec(name_or_path: str | Path) -> HwSpec:
    """Load a hwspec by name (``"spinn5"``, ``"kapoho-bay"``, ``"loihi2"``) or from a file.

    Parameters
    ----------
    name_or_path
        A name from :func:`known_hwspecs`, or the path of a ``.toml`` file.

    Returns
    -------
    HwSpec
        The validated, immutable specification.

    Raises
    ------
    ValidationError
        For an unknown name (the message lists the known ones), an unreadable or
        malformed file, or a missing or invalid field (named in the message).
    """
    if isinstance(name_or_path, HwSpec):
        return name_or_path
    text = str(name_or_path)
    path = Path(text)
    if text.endswith(".toml") or path.is_file():
        if not path.is_file():
            raise ValidationError(f"hwspec file {text!r} does not exist.")
        return _parse(path)
    known = known_hwspecs()
    if text not in known:
        raise ValidationError(f"Unknown hardware {text!r}; known hwspecs: {', '.join(known)}.")
    return _parse(_hwspec_dir() / f"{text}.toml")
