"""What the ``lava`` and ``lava-fixed`` backends can run, and why not the rest.

Both run the inference subset: ``IF_curr_exp`` populations with fixed weights,
every connector, Poisson and array sources, delays of whole steps. Lava's LIF
has one synaptic current per neuron, so a population fed through both receptor
types needs ``tau_syn_E == tau_syn_I``. ``lava-fixed`` adds Loihi 2's limits:
delays that fit the 6-bit delay field (:func:`max_fixed_delay_steps`) and a bias
that fits its 13-bit mantissa and 3-bit exponent.
"""

from __future__ import annotations

import dataclasses
from types import MappingProxyType

import numpy as np

from neurovpr.backendkit.capabilities import CURRENT_LIF_INFERENCE
from neurovpr.backendkit.timing import delay_steps
from neurovpr.hardware.hwspec import load_hwspec
from neurovpr.ir.cells import IF_curr_exp
from neurovpr.ir.connectivity import Connections
from neurovpr.ir.network import Network
from neurovpr.runtime.backend import ToleranceOverride

from .translation import lava_lif, lif_problems

__all__ = ["LAVA_CAPABILITIES", "LAVA_FIXED_CAPABILITIES", "network_problems", "compile_problems", "max_fixed_delay_steps"]



def max_fixed_delay_steps() -> int:
    """The longest delay ``lava-fixed`` runs, in steps: all of the ``loihi2`` hwspec's delay field.

    ``2**delay_bits - 1`` from ``[synapse_encoding]`` (6 bits: 63 steps), the range Lava's
    bit-accurate ``DelayDense`` accepts (lava/proc/dense/models.py, PyDelayDenseModelBitAcc:
    "a spike can be delayed by 0 to 63 time steps"). A neuron's ``K``-step delay is ``delays = K``
    there (:mod:`.build`). It differs from the hwspec's ``[timing] max_delay_steps`` (62), which
    is Loihi 1's chip-level figure (Davies 2018 p. 92) used as a proxy for Loihi 2 by
    ``neurovpr check``: this backend emulates Lava's process models, and Lava enforces the field.
    """
    return 2 ** load_hwspec("loihi2").rules.delay_bits - 1


_DELAY_LIMIT = "the case uses a 7.3 ms delay, 73 steps at dt = 0.1 ms; Loihi 2 synaptic delays are 6-bit (at most 63 steps)"
#: Conformance cases (neurovpr.conformance) ``lava-fixed`` cannot run, with the reason.
_FIXED_UNSUPPORTED = {"delay_shift": _DELAY_LIMIT, "delay_heterogeneous": _DELAY_LIMIT}

#: Looser conformance bounds of ``lava-fixed``: Lava's bit-accurate models compute in Loihi 2's formats.
_FIXED_TOLERANCES = {
    "psp_curr": ToleranceOverride(
        changes={"trace_rel": 0.02},
        reason="Lava's fixed_pt models (bit-accurate Loihi 2): 12-bit du/dv, 8-bit weight mantissas, "
        "u and v truncated every step; measured 0.77 % of the PSP peak",
    ),
    "psp_curr_equal_tau": ToleranceOverride(
        changes={"trace_rel": 0.03},
        reason="Loihi 2's 12-bit du and dv compound in the alpha-shaped PSP; measured 1.6 % of the peak",
    ),
    "lif_rate_curr": ToleranceOverride(
        changes={"trace_rel": 0.02, "spike_time_ms": 3.0},
        reason="the 12-bit membrane decay moves the steady state by up to 0.6 %: near rheobase "
        "(0.3 nA) each interval grows by about 0.3 ms, 2.4 ms over 8 spikes",
    ),
}

LAVA_CAPABILITIES = CURRENT_LIF_INFERENCE

LAVA_FIXED_CAPABILITIES = dataclasses.replace(
    LAVA_CAPABILITIES,
    arithmetic=frozenset({"loihi2"}),
    unsupported=MappingProxyType(_FIXED_UNSUPPORTED),
    tolerances=MappingProxyType(_FIXED_TOLERANCES),
)


def network_problems(network: Network) -> list[str]:
    """Features of ``network`` Lava's LIF cannot express (beyond the capability table)."""
    problems: list[str] = []
    for pop in network.populations.values():
        problems.extend(lif_problems(pop))
    receptors: dict[str, set[str]] = {}
    for proj in network.projections.values():
        receptors.setdefault(proj.post, set()).add(proj.receptor_type)
    for post, kinds in receptors.items():
        cell = network.populations[post].cell_type
        if isinstance(cell, IF_curr_exp) and len(kinds) == 2:
            tau_e, tau_i = np.asarray(cell.tau_syn_E), np.asarray(cell.tau_syn_I)
            if not np.allclose(tau_e, tau_i, rtol=1e-9):
                problems.append(
                    f"tau_syn_E {np.ravel(tau_e)[0]:g} ms != tau_syn_I {np.ravel(tau_i)[0]:g} ms with both receptors "
                    f"used (population {post!r}; Lava's LIF has one synaptic current)"
                )
    return problems


def compile_problems(network: Network, connections: dict[str, Connections], dt: float, *, fixed: bool) -> list[str]:
    """Problems that depend on the time step: delays and (fixed point) the bias format."""
    problems: list[str] = []
    if fixed:
        limit = max_fixed_delay_steps()
        for name, conns in connections.items():
            steps = delay_steps(conns.delay, dt)
            if steps.size and steps.max() > limit:
                problems.append(
                    f"delay {steps.max() * dt:g} ms = {steps.max()} steps (projection {name!r}; "
                    f"Loihi 2 delays are at most {limit} steps)"
                )
        fmt = load_hwspec("loihi2").formats
        for pop in network.populations.values():
            if isinstance(pop.cell_type, IF_curr_exp):
                try:
                    lava_lif(pop, dt, fmt)
                except ValueError as exc:
                    problems.append(str(exc))
    return problems
