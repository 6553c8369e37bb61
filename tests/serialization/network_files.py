"""The network every save/load test uses (every IR type, every kind of array) and checks on load errors."""

from __future__ import annotations

import traceback
from pathlib import Path

import h5py
import numpy as np
import pytest

import neurovpr as nv
from neurovpr.errors import FileFormatError


def full_network() -> nv.Network:
    """A network that uses every registered IR type and every kind of array."""
    rng = np.random.default_rng(0)
    net = nv.Network("every_type")
    net.add_population("poisson", 6, nv.SpikeSourcePoisson(rate=np.linspace(0.0, 50.0, 6), start=5.0))
    net.add_population("array", 3, nv.SpikeSourceArray.from_lists([[1.0, 2.5], [], [0.1, 7.0, 9.25]]))
    net.add_population(
        "curr",
        4,
        nv.IF_curr_exp(tau_m=np.array([10.0, 12.5, 15.0, 20.0]), i_offset=0.1),
        v_init=np.array([-65.0, -64.0, -63.0, -62.0]),
    )
    net.add_population("cond", 5, nv.IF_cond_exp(e_rev_I=-80.0), v_init=-60.0)
    net.add_population(
        "adaptive",
        5,
        nv.IF_cond_exp_adaptive(
            theta_init=rng.uniform(0.0, 1.0, 5), tau_theta=1e6, tau_lockout=np.array([0.0, 5.0, 50.0, 50.0, 7.5])
        ),
    )
    net.add_population("ca2", 3, nv.IF_curr_exp_ca2_adaptive(i_alpha=0.2, i_offset=0.02, tau_m=np.array([5.0, 6.0, 7.0])))
    net.add_population("soft_in", 4, nv.SoftLIF(sigma=0.05))
    net.add_population("soft_out", 2, nv.SoftLIF())
    net.add_population("image", 50, nv.SpikeSourcePoisson(rate=10.0, duration=200.0))
    net.add_population("feature", 27, nv.IF_curr_exp())

    net.connect(
        "poisson",
        "curr",
        nv.AllToAllConnector(),
        nv.StaticSynapse(weight=rng.normal(0.0, 1.0, (6, 4)), delay=nv.Uniform(low=1.0, high=2.0)),
    )
    net.connect(
        "curr",
        "curr",
        nv.AllToAllConnector(allow_self_connections=False),
        nv.StaticSynapse(weight=nv.Normal(mu=0.5, sigma=0.1, low=0.0), delay=np.full(12, 1.5)),
        receptor_type="inhibitory",
        name="lateral",
    )
    net.connect("adaptive", "cond", nv.OneToOneConnector(), nv.StaticSynapse(weight=np.linspace(0.1, 0.5, 5)))
    net.connect(
        "poisson",
        "adaptive",
        nv.FixedProbabilityConnector(p_connect=0.5, seed=7),
        nv.DiehlCookSTDP(weight=nv.Uniform(low=0.0, high=0.3), x_tar=0.1, mu=0.5),
    )
    net.connect(
        "poisson",
        "ca2",
        nv.FixedNumberPreConnector(n=nv.Normal(mu=3.0, sigma=1.0), seed=11),
        nv.STDPMechanism(
            timing_dependence=nv.SpikePairRule(tau_plus=1.25, tau_minus=0.1, A_plus=0.3, A_minus=0.15),
            weight_dependence=nv.AdditiveWeightDependence(w_min=0.0, w_max=0.5),
            weight=0.25,
            delay=2.0,
        ),
    )
    net.connect(
        "array",
        "ca2",
        nv.FixedNumberPreConnector(n=2),
        nv.STDPMechanism(
            weight_dependence=nv.MultiplicativeWeightDependence(w_min=0.0, w_max=1.0),
            weight=nv.Uniform(low=0.1, high=0.9),
        ),
    )
    net.connect(
        "array",
        "cond",
        nv.FromListConnector(conn_list=[[0, 1, 0.5, 1.0], [2, 3, 0.25, 2.5]]),
        receptor_type="inhibitory",
    )
    net.connect("soft_in", "soft_out", nv.AllToAllConnector(), nv.StaticSynapse(weight=rng.normal(size=(4, 2))))
    net.connect(
        "image",
        "feature",
        nv.ConvolutionConnector(input_shape=(2, 5, 5), kernel_shape=(3, 3), out_channels=3, stride=(2, 2), padding=(1, 1)),
        nv.StaticSynapse(weight=rng.normal(size=(3, 2, 3, 3)), delay=1.0),
    )
    return net


def types_in(data: object) -> set[str]:
    if isinstance(data, dict):
        found = {data["type"]} if "type" in data and "fields" in data else set()
        return found.union(*(types_in(v) for v in data.values()))
    if isinstance(data, list):
        return set().union(*(types_in(v) for v in data))
    return set()


def contents(path: Path) -> tuple[dict, dict]:
    with h5py.File(path, "r") as f:
        attrs = {k: f.attrs[k] for k in f.attrs}
        arrays = {k: f["arrays"][k][()] for k in f["arrays"]}
        dtypes = {k: f["arrays"][k].dtype for k in f["arrays"]}
    return attrs, {k: (dtypes[k], np.asarray(v)) for k, v in arrays.items()}


def load_error(path: Path) -> FileFormatError:
    with pytest.raises(FileFormatError) as info:
        nv.load(path)
    exc = info.value
    text = str(exc)
    assert str(path) in text and "\n" not in text and text.endswith(".")
    rendered = "".join(traceback.format_exception(exc))
    assert "h5py" not in rendered and "During handling" not in rendered and "direct cause" not in rendered
    return exc
