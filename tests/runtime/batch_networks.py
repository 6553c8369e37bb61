"""Small networks for the batched-presentation tests: every cell type, connector family and delays."""

from __future__ import annotations

import numpy as np

import neurovpr as nv


def diehl_cook_like(*, poisson: bool = True, n_in: int = 30, n_exc: int = 12, integration: str = "exact") -> nv.Network:
    """Input (Poisson or array) -> adaptive conductance neurons with a lockout <-> inhibitory conductance neurons
    (both with ``integration`` steps)."""
    net = nv.Network("batch-dc")
    source = nv.SpikeSourcePoisson(rate=0.0) if poisson else nv.SpikeSourceArray(spike_times=[[] for _ in range(n_in)])
    net.add_population("pixels", n_in, source)
    theta = np.linspace(0.0, 3.0, n_exc)
    net.add_population(
        "exc",
        n_exc,
        nv.IF_cond_exp_adaptive(tau_m=20.0, v_rest=-65.0, v_reset=-65.0, v_thresh=-55.0, tau_refrac=1.0,
                                tau_lockout=4.0, tau_syn_E=1.0, tau_syn_I=2.0, e_rev_I=-100.0, theta_init=theta,
                                integration=integration),
    )  # fmt: skip
    net.add_population(
        "inh", n_exc,
        nv.IF_cond_exp(tau_m=10.0, v_rest=-60.0, v_reset=-45.0, v_thresh=-40.0, tau_syn_E=1.0, integration=integration),
    )  # fmt: skip
    rng = np.random.default_rng(3)
    net.connect("pixels", "exc", nv.AllToAllConnector(),
                nv.StaticSynapse(weight=rng.uniform(0.0, 0.12, n_in * n_exc), delay=nv.Uniform(0.1, high=2.0)))  # fmt: skip
    net.connect("exc", "inh", nv.OneToOneConnector(), nv.StaticSynapse(weight=2.0, delay=0.5))
    net.connect("inh", "exc", nv.AllToAllConnector(allow_self_connections=False), nv.StaticSynapse(weight=0.4),
                receptor_type="inhibitory")  # fmt: skip
    return net


def conv_current(*, poisson: bool = False) -> nv.Network:
    """Array (or Poisson) source map -> convolution -> IF_curr_exp map -> sparse -> Ca2+-adaptive neurons."""
    net = nv.Network("batch-conv")
    shape = (2, 6, 6)
    n_in = int(np.prod(shape))
    source = nv.SpikeSourcePoisson(rate=0.0) if poisson else nv.SpikeSourceArray(spike_times=[[] for _ in range(n_in)])
    net.add_population("image", n_in, source)
    conv = nv.ConvolutionConnector(input_shape=shape, kernel_shape=(3, 3), out_channels=3, stride=(1, 1), padding=(1, 1))
    out_h, out_w = conv.output_hw
    net.add_population("maps", 3 * out_h * out_w, nv.IF_curr_exp(tau_m=10.0, tau_syn_E=2.0, tau_syn_I=4.0, v_thresh=-60.0))
    net.add_population("places", 5, nv.IF_curr_exp_ca2_adaptive(tau_m=15.0, v_thresh=-62.0, i_alpha=0.3, tau_refrac=1.0))
    kernel = np.random.default_rng(5).uniform(-0.5, 2.5, (3, 2, 3, 3))
    net.connect("image", "maps", conv, nv.StaticSynapse(weight=kernel, delay=1.0))
    net.connect("maps", "places", nv.FixedProbabilityConnector(0.3, seed=4),
                nv.StaticSynapse(weight=nv.Uniform(0.5, high=1.5), delay=nv.Uniform(0.1, high=3.0)))  # fmt: skip
    net.connect("maps", "places", nv.FixedProbabilityConnector(0.1, seed=6), nv.StaticSynapse(weight=0.6),
                receptor_type="inhibitory", name="maps_inh")  # fmt: skip
    return net


def array_items(n_items: int, n_neurons: int, *, duration: float, rate_hz: float, seed: int) -> list[list[list[float]]]:
    """Explicit spike times for ``n_items`` items: one list of times (ms) per neuron."""
    rng = np.random.default_rng(seed)
    items = []
    for _ in range(n_items):
        per = []
        for _ in range(n_neurons):
            k = rng.poisson(rate_hz * duration / 1000.0)
            per.append(np.unique(np.round(rng.uniform(0.0, duration - 1.0, k), 1)).tolist())
        items.append(per)
    return items
