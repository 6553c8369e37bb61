"""What the ``nengo`` and ``nengo-loihi`` backends can run, and why not the rest.

Both run the inference subset of the IR: ``IF_curr_exp`` populations with fixed
weights, every connector (convolutions with zero
or Nengo's ``"same"`` padding), Poisson and array sources. Nothing learns, and the
conductance-based and adaptive cell types have no Nengo equivalent. NengoLoihi adds
the restrictions of Loihi as it uses it: one synaptic filter per neuron, no
synaptic delays beyond one step between neuron populations (spike sources are
delayed by the host, which replays them), initial voltage at ``v_reset``, one gain
per convolution target.
"""

from __future__ import annotations

import dataclasses
from types import MappingProxyType

import numpy as np

from neurovpr.backendkit.capabilities import CURRENT_LIF_INFERENCE
from neurovpr.backendkit.lif import normalised_lif
from neurovpr.backendkit.timing import delay_steps
from neurovpr.ir.cells import IF_curr_exp
from neurovpr.ir.connectivity import Connections
from neurovpr.ir.connectors import ConvolutionConnector
from neurovpr.ir.network import Network
from neurovpr.runtime.backend import ToleranceOverride

from .translation import conv_padding_mode, lif_problems

__all__ = ["NENGO_CAPABILITIES", "NENGO_LOIHI_CAPABILITIES", "network_problems", "delay_problems"]

#: Conformance cases (neurovpr.conformance) the ``nengo`` backend cannot pass, with the reason.
_NENGO_UNSUPPORTED = {
    "lif_rate_curr": (
        "Nengo's LIF places a spike inside its step (linear interpolation of the threshold crossing) and starts "
        "the refractory period there, so it fires at the continuous-time LIF rate, not on the step grid this "
        "case checks"
    ),
}

#: Looser conformance bounds of ``nengo-loihi``: NengoLoihi's emulator computes in Loihi's formats.
_NENGO_LOIHI_TOLERANCES = {
    "psp_curr": ToleranceOverride(
        changes={"trace_rel": 0.02},
        reason="NengoLoihi's emulator computes in Loihi's formats (12-bit decays, 8-bit weight "
        "mantissas); measured 0.58 % of the PSP peak",
    ),
    "psp_curr_equal_tau": ToleranceOverride(
        changes={"trace_rel": 0.03},
        reason="NengoLoihi's 12-bit decays compound in the alpha-shaped PSP; measured 1.08 % of the peak",
    ),
}

NENGO_CAPABILITIES = dataclasses.replace(CURRENT_LIF_INFERENCE, unsupported=MappingProxyType(_NENGO_UNSUPPORTED))

NENGO_LOIHI_CAPABILITIES = dataclasses.replace(
    NENGO_CAPABILITIES,
    arithmetic=frozenset({"loihi1"}),
    unsupported=MappingProxyType({}),
    tolerances=MappingProxyType(_NENGO_LOIHI_TOLERANCES),
)


def network_problems(network: Network, *, loihi: bool) -> list[str]:
    """Features of ``network`` the backend cannot express (beyond the capability table).

    Each entry names the feature, the object and the value.
    """
    problems: list[str] = []
    for pop in network.populations.values():
        problems.extend(lif_problems(pop, loihi=loihi))
    if problems:
        return problems
    mappings = {name: normalised_lif(pop) for name, pop in network.populations.items() if isinstance(pop.cell_type, IF_curr_exp)}
    receptors: dict[str, set[str]] = {}
    for proj in network.projections.values():
        receptors.setdefault(proj.post, set()).add(proj.receptor_type)
        conn = proj.connector
        if isinstance(conn, ConvolutionConnector):
            if conv_padding_mode(conn) is None:
                problems.append(
                    f"ConvolutionConnector padding {conn.padding} (projection {proj.name!r}; Nengo pads 0 or 'same' only)"
                )
            gain = mappings[proj.post].gain if proj.post in mappings else None
            if loihi and gain is not None and not np.allclose(gain, gain[0], rtol=1e-9):
                problems.append(
                    f"convolution onto neurons with different (tau_m / cm) / (v_thresh - v_reset) "
                    f"(projection {proj.name!r}; NengoLoihi shares one kernel)"
                )
    if loihi:
        for post, kinds in receptors.items():
            m = mappings.get(post)
            if m is not None and len(kinds) == 2 and not np.isclose(m.tau_syn_e, m.tau_syn_i):
                problems.append(
                    f"tau_syn_E {m.tau_syn_e:g} ms != tau_syn_I {m.tau_syn_i:g} ms with both receptors used "
                    f"(population {post!r}; a Loihi compartment has one synaptic filter)"
                )
    return problems


def delay_problems(network: Network, connections: dict[str, Connections], dt: float) -> list[str]:
    """Projections between neuron populations whose delays NengoLoihi cannot run (anything but one step).

    Spikes of a source are replayed by the host, which delays them before sending.
    """
    problems = []
    for name, conns in connections.items():
        if network.populations[network.projections[name].pre].is_source:
            continue
        steps = delay_steps(conns.delay, dt)
        if steps.size and steps.max() > 1:
            problems.append(
                f"delay {steps.max() * dt:g} ms between neuron populations (projection {name!r}; NengoLoihi "
                "delivers every on-chip spike after one step)"
            )
    return problems
