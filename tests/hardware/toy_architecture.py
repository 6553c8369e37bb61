"""A chip architecture declared outside neurovpr, for the tests of the hardware route (never installed).

``test_hardware_route.py`` copies this module next to a ``.dist-info`` folder whose entry point
declares ``TOY`` in the ``neurovpr.architectures`` group, as a third-party package would. Its
partitioner cuts every neuron population into slices of ``[core].max_neurons`` neurons, one core
each, filling ``[chip].cores_per_chip`` cores per chip, and checks one limit of its own table,
``[toy].max_cores_per_population``.
"""

from __future__ import annotations

from dataclasses import dataclass

from neurovpr.hardware.architectures import Architecture
from neurovpr.hardware.cores import CoreSlice, Partition, Violation
from neurovpr.hardware.hwspec import HwSpec, spec_field
from neurovpr.ir.network import Network


@dataclass(frozen=True, slots=True, kw_only=True)
class ToyRules:
    """``[toy]``: the architecture's own constants."""

    max_cores_per_population: int = spec_field("int", low=1)


def partition_toy(network: Network, spec: HwSpec, *, seed: int = 0) -> Partition:
    """Slices of ``max_neurons`` per neuron population, one core each; sources stay on the host."""
    rules = spec.rules
    assert isinstance(rules, ToyRules)
    per_core = spec.core.max_neurons
    cores: list[CoreSlice] = []
    violations: list[Violation] = []
    for pop in network.populations.values():
        if pop.is_source:
            continue
        slices = [(lo, min(lo + per_core, pop.size)) for lo in range(0, pop.size, per_core)]
        if len(slices) > rules.max_cores_per_population:
            violations.append(Violation(limit="cores per population", where=pop.name, value=len(slices),
                                        maximum=rules.max_cores_per_population,
                                        message=f"Population {pop.name!r} needs {len(slices)} cores, more than "
                                                f"{rules.max_cores_per_population}."))  # fmt: skip
        for lo, hi in slices:
            chip = len(cores) // spec.chip.cores_per_chip
            cores.append(CoreSlice(population=pop.name, lo=lo, hi=hi, kind="neurons", chip=chip,
                                   usage={"neurons": hi - lo}, limits={"neurons": per_core}))  # fmt: skip
    host = tuple(name for name, pop in network.populations.items() if pop.is_source)
    chips = max(1, -(-len(cores) // spec.chip.cores_per_chip))
    return Partition(hardware=spec.name, cores=tuple(cores), chips=chips, violations=tuple(violations), host=host)


TOY = Architecture(name="toychip", table="toy", rules=ToyRules, partition=partition_toy)
