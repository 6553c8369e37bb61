"""Small networks shared by several conformance cases."""

from __future__ import annotations

import neurovpr as nv

__all__ = ["DT", "DELAY", "PAIR", "pair_network"]

#: time step (ms) of the plasticity cases
DT = 0.1
#: delay (ms) of the plastic synapse in the plasticity cases
DELAY = 1.5
#: the spike-pair timing rule of the STDPMechanism cases
PAIR = nv.SpikePairRule(tau_plus=16.8, tau_minus=33.7, A_plus=0.05, A_minus=0.04)


def pair_network(synapse: nv.Synapse, t_pre: list[float], t_drive: list[float]) -> nv.Network:
    """``pre -(plastic, delay d)-> post <-(static, 100 nA)- drive``; each drive spike forces one post spike."""
    net = nv.Network("stdp_pair")
    net.add_population("pre", 1, nv.SpikeSourceArray.from_lists([t_pre]))
    net.add_population("drive", 1, nv.SpikeSourceArray.from_lists([t_drive]))
    net.add_population("post", 1, nv.IF_curr_exp(tau_m=10.0, tau_syn_E=1.0, tau_refrac=5.0, v_reset=-70.0))
    net.connect("pre", "post", nv.AllToAllConnector(), synapse, name="plastic")
    net.connect("drive", "post", nv.AllToAllConnector(), nv.StaticSynapse(weight=100.0, delay=DT), name="drive")
    return net
