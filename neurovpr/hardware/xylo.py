"""Rockpool's rules for putting a network onto SynSense Xylo Audio 2 (SYNS61201).

Xylo is one digital core: up to 16 input channels, 1000 hidden neurons with two input
synapses each, and 8 output neurons with one synapse, connected by dense signed 8-bit
weight matrices (input -> hidden, hidden -> hidden, hidden -> output). The network is read
the way Rockpool's mapper (``rockpool/devices/xylo/syns61201/xylo_mapper.py``) reads the
equivalent Rockpool graph:

* spike-source populations are the input channels, in declaration order;
* neuron populations with no projection to another neuron population are the outputs
  (the mapper's network outputs); every other neuron population is hidden;
* hidden populations get hardware neuron ids ``0, 1, ...`` in declaration order, greedily,
  and output populations ids from ``max_hidden_neurons`` on, as the mapper's
  ``assign_ids_to_class`` does; a population that does not fit in what is left is refused
  as the mapper refuses it ("Exceeded number of available resources").

The mapper's design rules neurovpr checks, each named as the limit: at most 16 input
channels (``le_16_input_channels``) and 8 output neurons (``le_8_output_channels``), the
hidden and output neuron pools, at least two neuron layers
(``at_least_two_neuron_layers_needed``), no recurrent output neurons
(``output_neurons_cannot_be_recurrent``), inputs only onto hidden neurons (the input weight
matrix targets hidden neurons), and, from XyloSim, integer weights within int8 (its
``XyloSynapse`` refuses any other) and one synapse per output neuron. All numbers come from
the hwspec's ``[xylo]`` table.
"""

from __future__ import annotations

from dataclasses import dataclass

import numpy as np

from neurovpr.ir.network import Network, Projection

from .architectures import Architecture
from .cores import CoreSlice, Partition, Violation, expand_on_chip
from .hwspec import HwSpec, spec_field

__all__ = ["XyloRules", "XyloLayout", "xylo_layout", "partition_xylo", "XYLO"]


@dataclass(frozen=True, slots=True, kw_only=True)
class XyloRules:
    """``[xylo]``: Xylo's channel and neuron pools, synapses per neuron and weight range."""

    max_input_channels: int = spec_field("int", low=1)
    max_hidden_neurons: int = spec_field("int", low=1)
    max_output_neurons: int = spec_field("int", low=1)
    hidden_synapses: int = spec_field("int", low=1)
    output_synapses: int = spec_field("int", low=1)
    weight_min: int = spec_field("int")
    weight_max: int = spec_field("int")


@dataclass(frozen=True, slots=True, kw_only=True)
class XyloLayout:
    """Which populations are Xylo's inputs, hidden and output neurons, and where they start.

    ``first_id`` maps a population to its first input channel (inputs) or hardware neuron id
    (hidden: from 0; outputs: from ``max_hidden_neurons``), in the mapper's order.
    """

    inputs: tuple[str, ...]
    hidden: tuple[str, ...]
    outputs: tuple[str, ...]
    first_id: dict[str, int]


def xylo_layout(network: Network, rules: XyloRules) -> XyloLayout:
    """Inputs, hidden and output populations of ``network`` on Xylo (see the module docstring)."""
    pops = network.populations
    inputs = tuple(name for name, p in pops.items() if p.is_source)
    neurons = [name for name, p in pops.items() if not p.is_source]
    feeds = {name: set() for name in neurons}
    for proj in network.projections.values():
        if proj.pre in feeds and proj.post != proj.pre:
            feeds[proj.pre].add(proj.post)
    outputs = tuple(name for name in neurons if not feeds[name])
    hidden = tuple(name for name in neurons if name not in outputs)
    first: dict[str, int] = {}
    for group, start in ((inputs, 0), (hidden, 0), (outputs, rules.max_hidden_neurons)):
        at = start
        for name in group:
            first[name] = at
            at += pops[name].size
    return XyloLayout(inputs=inputs, hidden=hidden, outputs=outputs, first_id=first)


def _violation(limit: str, where: str, value: float, maximum: float, message: str) -> Violation:
    return Violation(limit=limit, where=where, value=value, maximum=maximum, message=message)


def _signed_weights(network: Network, proj: Projection, spec: HwSpec, seed: int) -> np.ndarray:
    """The projection's weights as Xylo holds them: summed per (pre, post), negative when inhibitory."""
    conns = expand_on_chip(network, proj, spec, seed)
    if not len(conns):
        return np.zeros(0)
    n_post = network.populations[proj.post].size
    _, inverse = np.unique(conns.pre.astype(np.int64) * n_post + conns.post, return_inverse=True)
    summed = np.zeros(int(inverse.max()) + 1)
    np.add.at(summed, inverse, conns.weight)
    return -summed if proj.receptor_type == "inhibitory" else summed


def _pool_violations(network: Network, layout: XyloLayout, rules: XyloRules, spec: HwSpec) -> list[Violation]:
    pops = network.populations
    out: list[Violation] = []
    n_in = sum(pops[n].size for n in layout.inputs)
    if n_in > rules.max_input_channels:
        out.append(_violation(
            "input channels", network.name, n_in, rules.max_input_channels,
            f"Network {network.name!r} has {n_in} input channels ({', '.join(layout.inputs)}) but {spec.name} "
            f"supports up to {rules.max_input_channels}.",
        ))
    for group, limit, pool, first in (
        (layout.hidden, "hidden neurons", rules.max_hidden_neurons, 0),
        (layout.outputs, "output neurons", rules.max_output_neurons, rules.max_hidden_neurons),
    ):
        for name in group:
            end = layout.first_id[name] - first + pops[name].size
            if end > pool:
                out.append(_violation(
                    limit, name, end, pool,
                    f"Population {name!r} ({pops[name].size} {limit}) exceeds the {pool} {limit} of {spec.name} "
                    f"({end} needed up to it).",
                ))
    n_neuron_layers = len(layout.hidden) + len(layout.outputs)
    if n_neuron_layers < 2 or not layout.hidden:
        out.append(_violation(
            "neuron layers", network.name, len(layout.hidden), 1,
            f"Network {network.name!r} needs at least one hidden and one output neuron population on {spec.name} "
            f"(it has {len(layout.hidden)} hidden, {len(layout.outputs)} output).",
        ))
    return out


def _projection_violations(network: Network, layout: XyloLayout, rules: XyloRules, spec: HwSpec,
                           seed: int) -> list[Violation]:
    out: list[Violation] = []
    receptors: dict[str, set[str]] = {}
    for proj in network.projections.values():
        if proj.post in layout.outputs:
            if proj.pre == proj.post:
                out.append(_violation(
                    "recurrent output", proj.name, 1, 0,
                    f"Projection {proj.name!r} makes output population {proj.post!r} recurrent; output neurons "
                    f"on {spec.name} may not be recurrent.",
                ))
            elif proj.pre in layout.inputs:
                out.append(_violation(
                    "input to output", proj.name, 1, 0,
                    f"Projection {proj.name!r} connects input {proj.pre!r} straight to output population "
                    f"{proj.post!r}; inputs on {spec.name} reach hidden neurons only.",
                ))
            receptors.setdefault(proj.post, set()).add(proj.receptor_type)
        w = _signed_weights(network, proj, spec, seed)
        if w.size and not np.array_equal(w, np.round(w)):
            bad = float(w[np.flatnonzero(w != np.round(w))[0]])
            out.append(_violation(
                "weight format", proj.name, bad, rules.weight_max,
                f"Projection {proj.name!r}: weight {bad:g} is not an integer; {spec.name} weights are signed "
                f"{spec.formats.weight_bits}-bit integers (quantise the network first).",
            ))
        elif w.size and (w.min() < rules.weight_min or w.max() > rules.weight_max):
            bad = float(w.max() if w.max() > rules.weight_max else w.min())
            out.append(_violation(
                "weight range", proj.name, bad, rules.weight_max if bad > 0 else rules.weight_min,
                f"Projection {proj.name!r}: weight {bad:g} is outside the {spec.name} range "
                f"[{rules.weight_min}, {rules.weight_max}].",
            ))
    for name, kinds in receptors.items():
        cell = network.populations[name].cell_type
        same_tau = np.array_equal(np.asarray(getattr(cell, "tau_syn_E", 0.0)), np.asarray(getattr(cell, "tau_syn_I", 0.0)))
        if len(kinds) > rules.output_synapses and not same_tau:
            out.append(_violation(
                "output synapses", name, len(kinds), rules.output_synapses,
                f"Output population {name!r} receives excitatory and inhibitory synapses with different time "
                f"constants; output neurons on {spec.name} have {rules.output_synapses} synapse.",
            ))
    return out


def partition_xylo(network: Network, spec: HwSpec, *, seed: int = 0) -> Partition:
    """Assign ``network`` to Xylo's input channels, hidden and output neurons (see the module docstring)."""
    rules = spec.rules
    assert isinstance(rules, XyloRules), "the xylo partitioner needs [xylo]"
    layout = xylo_layout(network, rules)
    pops = network.populations
    cores: list[CoreSlice] = []
    for group, kind, resource, pool in (
        (layout.inputs, "sources", "input_channels", rules.max_input_channels),
        (layout.hidden, "neurons", "hidden_neurons", rules.max_hidden_neurons),
        (layout.outputs, "neurons", "output_neurons", rules.max_output_neurons),
    ):
        for name in group:
            cores.append(CoreSlice(population=name, lo=0, hi=pops[name].size, kind=kind,
                                   location=(layout.first_id[name],), usage={resource: pops[name].size},
                                   limits={resource: pool}))
    violations = _pool_violations(network, layout, rules, spec) + _projection_violations(
        network, layout, rules, spec, seed)
    notes = (
        "Xylo is one core: `location` is a population's first input channel or hardware neuron id "
        f"(outputs from {rules.max_hidden_neurons}), assigned in declaration order as Rockpool's mapper does.",
        "Weights are Xylo integers (chip units); inhibitory projections are negative weights.",
    )
    return Partition(hardware=spec.name, cores=tuple(cores), chips=1, violations=tuple(violations), notes=notes)


#: Rockpool's Xylo Audio 2 rules, for hwspecs with ``partitioner = "xylo"`` (entry point ``neurovpr.architectures``).
XYLO = Architecture(name="xylo", table="xylo", rules=XyloRules, partition=partition_xylo)
