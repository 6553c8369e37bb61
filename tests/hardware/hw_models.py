"""Networks used by the hardware tests, built with the core API at the papers' sizes.

* :func:`modular_snn` - Hussaini et al. (T-RO 2024): per module 784 Poisson pixels ->
  400 ``IF_cond_exp_adaptive`` excitatory -> 400 ``IF_cond_exp`` inhibitory neurons
  (input all-to-all with Diehl & Cook STDP, E->I one-to-one, I->E all-to-all but self);
  Nordland at full size uses 3072 places / 25 places per module = 123 modules.
* :func:`mbsnn` - Zhu et al. (Sci. Robot. 2023): 840 event-camera mega-pixel spike trains
  (``SpikeSourceArray``) one-to-one onto 840 PNs (``IF_curr_exp_ca2_adaptive``)
  -> 4000 KCs as two compartments (two populations of 4000, each KC drawing
  round(N(5, 1)) PNs with weights N(0.3, 0.1)) -> 1 MBON; KC1 -> KC2 axo-axonic
  inhibition within 4 subgroups of 1000 KCs, 500 targets each, learnt by pair STDP.
* :func:`locsnet` - Akcal et al. (Front. Neurorobot. 2025): 56x56 input -> three 3x3,
  stride-2, unpadded convolutions of 8, 16 and 32 channels (27x27, 13x13 and 6x6 maps)
  -> a dense place layer of 3072 classes; all LIF (``IF_curr_exp``), 8-bit-like weights.
"""

from __future__ import annotations

import numpy as np

import neurovpr as nv


def modular_snn(n_modules: int = 1, *, plastic: bool = True, seed: int = 0) -> nv.Network:
    """``n_modules`` independent Modular-SNN modules, each with its own input.

    ``plastic=False`` gives the network used at query time: the learnt input weights as
    static synapses.
    """
    rng = np.random.default_rng(seed)
    net = nv.Network("modular_snn")
    for m in range(n_modules):
        p = f"m{m}." if n_modules > 1 else ""
        net.add_population(f"{p}pixels", 784, nv.SpikeSourcePoisson(rate=0.0))
        net.add_population(f"{p}exc", 400, nv.IF_cond_exp_adaptive(tau_m=100.0, v_rest=-65.0, v_reset=-65.0,
                                                                      v_thresh=-52.0, tau_syn_E=1.0, tau_syn_I=0.5,
                                                                      e_rev_I=-100.0))
        net.add_population(f"{p}inh", 400, nv.IF_cond_exp(tau_m=10.0, v_rest=-60.0, v_reset=-45.0, v_thresh=-40.0,
                                                          tau_syn_E=1.0, tau_syn_I=0.5, e_rev_I=-85.0))
        w_in = rng.uniform(0.0, 0.3, size=(784, 400))
        syn = nv.DiehlCookSTDP(weight=w_in, eta_pre=1e-4, eta_post=1e-2) if plastic else nv.StaticSynapse(weight=w_in)
        net.connect(f"{p}pixels", f"{p}exc", nv.AllToAllConnector(), syn)
        net.connect(f"{p}exc", f"{p}inh", nv.OneToOneConnector(), nv.StaticSynapse(weight=10.4))
        net.connect(f"{p}inh", f"{p}exc", nv.AllToAllConnector(allow_self_connections=False),
                    nv.StaticSynapse(weight=17.0), receptor_type="inhibitory", name=f"{p}lateral")
    return net


def mbsnn(*, n_kc: int = 4000, plastic: bool = True, seed: int = 0) -> nv.Network:
    """The mushroom body: 840 PN -> 2 x ``n_kc`` KC compartments -> 1 MBON.

    ``plastic=False`` gives the network used at test time: KC->KC weights as learnt
    (static, drawn in (0, 0.5]) instead of STDP synapses starting at 0.
    """
    rng = np.random.default_rng(seed)
    net = nv.Network("mbsnn")
    # Event-camera input: one spike train per mega-pixel (here 100 ms of random events).
    times = [np.sort(rng.uniform(0.0, 100.0, rng.poisson(5))) for _ in range(840)]
    net.add_population("events", 840, nv.SpikeSourceArray.from_lists(times))
    net.add_population("pn", 840, nv.IF_curr_exp_ca2_adaptive(i_offset=0.02, i_alpha=0.2))
    net.connect("events", "pn", nv.OneToOneConnector(), nv.StaticSynapse(weight=3.0))
    net.add_population("kc1", n_kc, nv.IF_curr_exp())
    net.add_population("kc2", n_kc, nv.IF_curr_exp())
    net.add_population("mbon", 1, nv.IF_curr_exp())
    # Each KC draws round(N(5, 1)) PNs; both compartments see the same PN input.
    counts = np.clip(np.rint(rng.normal(5.0, 1.0, n_kc)), 0, 840).astype(int)
    pre = np.concatenate([rng.choice(840, size=k, replace=False) for k in counts])
    post = np.repeat(np.arange(n_kc), counts)
    weight = np.clip(rng.normal(0.3, 0.1, size=pre.size), 0.0, None)
    rows = np.stack([pre, post, weight], axis=1)
    net.connect("pn", "kc1", nv.FromListConnector(conn_list=rows), nv.StaticSynapse(weight=0.3))
    net.connect("pn", "kc2", nv.FromListConnector(conn_list=rows), nv.StaticSynapse(weight=0.3))
    # KC1 -> KC2 inhibition: 4 subgroups, each KC targets 500 others of its subgroup.
    group = n_kc // 4
    src, dst = [], []
    for g in range(4):
        members = np.arange(g * group, (g + 1) * group)
        for k in members:
            others = members[members != k]
            src.append(np.full(min(500, others.size), k))
            dst.append(np.sort(rng.choice(others, size=min(500, others.size), replace=False)))
    kk = np.stack([np.concatenate(src), np.concatenate(dst)], axis=1)
    if plastic:
        syn = nv.STDPMechanism(timing_dependence=nv.SpikePairRule(tau_plus=1.25, tau_minus=0.1, A_plus=0.3,
                                                                  A_minus=0.15),
                               weight_dependence=nv.AdditiveWeightDependence(w_min=0.0, w_max=0.5), weight=0.0)
    else:
        syn = nv.StaticSynapse(weight=rng.uniform(0.01, 0.5, size=kk.shape[0]))
    net.connect("kc1", "kc2", nv.FromListConnector(conn_list=kk), syn, receptor_type="inhibitory")
    net.connect("kc2", "mbon", nv.AllToAllConnector(), nv.StaticSynapse(weight=0.01))
    return net


def locsnet(*, n_places: int = 3072, input_hw: int = 56, channels: tuple[int, int, int] = (8, 16, 32),
            seed: int = 0) -> nv.Network:
    """LoCS-Net: input -> 3 convolutions (3x3, stride 2) -> dense place layer."""
    rng = np.random.default_rng(seed)
    net = nv.Network("locsnet")
    shape = (1, input_hw, input_hw)
    net.add_population("input", int(np.prod(shape)), nv.SpikeSourcePoisson(rate=0.0))
    prev = "input"
    for k, ch in enumerate(channels, start=1):
        conv = nv.ConvolutionConnector(input_shape=shape, kernel_shape=(3, 3), out_channels=ch, stride=(2, 2))
        name = f"conv{k}"
        net.add_population(name, int(np.prod(conv.output_shape)), nv.IF_curr_exp(tau_m=20.0, tau_refrac=1.0))
        kernel = rng.normal(0.3, 0.3, size=conv.weight_shape) / np.sqrt(conv.input_shape[0])
        net.connect(prev, name, conv, nv.StaticSynapse(weight=kernel))
        prev, shape = name, conv.output_shape
    n_feat = int(np.prod(shape))
    net.add_population("places", n_places, nv.IF_curr_exp(tau_m=20.0, tau_refrac=1.0))
    net.connect(prev, "places", nv.AllToAllConnector(),
                nv.StaticSynapse(weight=rng.normal(0.0, 0.1, size=(n_feat, n_places))))
    return net


def small_net() -> nv.Network:
    """A small network: sources, three neuron populations, four connector kinds."""
    rng = np.random.default_rng(3)
    net = nv.Network("small")
    net.add_population("src", 60, nv.SpikeSourcePoisson(rate=10.0))
    net.add_population("a", 50, nv.IF_curr_exp())
    net.add_population("b", 30, nv.IF_curr_exp())
    net.add_population("c", 20, nv.IF_curr_exp())
    net.connect("src", "a", nv.AllToAllConnector(), nv.StaticSynapse(weight=rng.uniform(0, 1, size=(60, 50))))
    net.connect("a", "b", nv.FixedProbabilityConnector(p_connect=0.2, seed=4), nv.StaticSynapse(weight=0.5))
    net.connect("b", "c", nv.FixedNumberPreConnector(n=nv.Normal(mu=5.0, sigma=1.0), seed=5),
                nv.StaticSynapse(weight=nv.Normal(mu=0.3, sigma=0.1, low=0.0)))
    net.connect("c", "a", nv.AllToAllConnector(), nv.StaticSynapse(weight=0.2), receptor_type="inhibitory")
    net.connect("a", "a", nv.AllToAllConnector(allow_self_connections=False), nv.StaticSynapse(weight=0.1),
                receptor_type="inhibitory", name="lateral")
    return net


def sub_ms_net(*, shortest_delay: float = 0.5, longest_delay: float = 6.0) -> nv.Network:
    """A network for sub-millisecond steps, where sPyNNaker splits neuron and synapse cores.

    * ``drive`` -> ``p``: a Poisson source one-to-one onto a population of its size, its
      only projection (sPyNNaker simulates it on the chip of ``p``'s neuron cores);
    * ``lonely`` -> ``q``: the same, with ``q`` also fed by ``idle``;
    * ``idle``: no input at all (kept on a combined core);
    * ``p`` -> ``r``: random STDP synapses (more than one synapse core), ``q`` -> ``r``:
      weights of both signs (two sPyNNaker projections);
    * ``r`` -> ``p``: random delays from ``shortest_delay`` to ``longest_delay`` ms (with
      60 steps or so, a delay extension and delays of exactly the 32-step ring buffer).
    """
    rng = np.random.default_rng(1)
    net = nv.Network("sub_ms")
    net.add_population("drive", 300, nv.SpikeSourcePoisson(rate=20.0))
    net.add_population("p", 300, nv.IF_curr_exp())
    net.connect("drive", "p", nv.OneToOneConnector(), nv.StaticSynapse(weight=1.0))
    net.add_population("lonely", 100, nv.SpikeSourcePoisson(rate=5.0))
    net.add_population("q", 100, nv.IF_curr_exp())
    net.connect("lonely", "q", nv.OneToOneConnector(), nv.StaticSynapse(weight=1.0))
    net.add_population("idle", 50, nv.IF_cond_exp())
    net.add_population("r", 600, nv.IF_curr_exp())
    net.connect("p", "r", nv.FixedProbabilityConnector(p_connect=0.3, seed=2), nv.STDPMechanism(weight=0.1))
    net.connect("q", "r", nv.AllToAllConnector(), nv.StaticSynapse(weight=rng.normal(0, 0.2, (100, 600))))
    net.connect("r", "p", nv.FixedProbabilityConnector(p_connect=0.05, seed=3),
                nv.StaticSynapse(weight=0.1, delay=nv.Uniform(low=shortest_delay, high=longest_delay)))
    net.connect("idle", "q", nv.AllToAllConnector(), nv.StaticSynapse(weight=0.2, delay=0.5))
    return net


def synapse_bound_net() -> nv.Network:
    """A population whose synaptic input needs more synapse cores than a chip offers.

    3000 Poisson sources all-to-all with STDP onto 20 neurons: sPyNNaker estimates
    256 x 30 x 3000 events/s (rows as long as a full core's) for 1.4 M per synapse core,
    17 cores, and caps them at 15;
    with them on the chip a one-to-one Poisson source (``drive``) no longer fits, so it
    gets a core of its own.
    """
    net = nv.Network("synapse_bound")
    net.add_population("src", 3000, nv.SpikeSourcePoisson(rate=5.0))
    net.add_population("drive", 20, nv.SpikeSourcePoisson(rate=5.0))
    net.add_population("post", 20, nv.IF_curr_exp())
    net.connect("src", "post", nv.AllToAllConnector(), nv.STDPMechanism(weight=0.05))
    net.connect("drive", "post", nv.OneToOneConnector(), nv.StaticSynapse(weight=1.0))
    return net
