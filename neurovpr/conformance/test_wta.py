"""Winner-take-all through lateral inhibition."""

from __future__ import annotations

import numpy as np

import neurovpr as nv

DT = 0.1
T_STOP = 500.0
#: Poisson input rate of each excitatory neuron (Hz). With w = 0.1 nA, tau_syn_E = 5 ms
#: and R = 20 MOhm the mean drive is 10 mV per kHz: 5, 10, 15, 20 and 40 mV against a
#: 15 mV threshold distance.
RATES = np.array([500.0, 1000.0, 1500.0, 2000.0, 4000.0])
#: Lateral weight (nA, tau_syn_I = 10 ms). The winner (about 70 Hz) holds each other
#: neuron's mean potential about 29 mV down, far below threshold; the runner-up alone
#: (about 30 Hz) would hold the winner only about 12 mV down, so the winner breaks
#: through whichever neuron fires first: the outcome does not hinge on the first spike.
LATERAL_WEIGHT = 2.0


def wta_network(lateral: bool) -> nv.Network:
    """Input -> exc (one-to-one); exc -> inh (one-to-one, every exc spike makes its partner
    fire); inh -> exc (all-to-all but self, strong, slow inhibition)."""
    n = RATES.size
    net = nv.Network("wta")
    net.add_population("input", n, nv.SpikeSourcePoisson(rate=RATES))
    net.add_population("exc", n, nv.IF_curr_exp(tau_m=20.0, tau_syn_E=5.0, tau_syn_I=10.0, tau_refrac=2.0))
    net.add_population("inh", n, nv.IF_curr_exp(tau_m=10.0, tau_syn_E=1.0, tau_refrac=2.0))
    net.connect("input", "exc", nv.OneToOneConnector(), nv.StaticSynapse(weight=0.1))
    net.connect("exc", "inh", nv.OneToOneConnector(), nv.StaticSynapse(weight=50.0))
    if lateral:
        net.connect(
            "inh", "exc", nv.AllToAllConnector(allow_self_connections=False), nv.StaticSynapse(weight=LATERAL_WEIGHT),
            receptor_type="inhibitory", name="lateral",
        )
    return net


def test_winner_take_all(backend):
    """The neuron with the highest input rate wins and the others are silenced.

    Control (no lateral projection): the neurons driven above threshold fire (the
    runner-up at least 5 times). With lateral inhibition:
    the strongest still fires at least 80 % of its control count, and all the others
    together fire at most 10 % of that. Every inhibitory partner fires with its
    excitatory neuron.
    """
    case = "winner_take_all"
    counts = {}
    for lateral in (False, True):
        sim = backend.compile(wta_network(lateral), case=case, dt=DT, seed=5)
        sim.run(T_STOP)
        counts[lateral] = (sim.spike_counts("exc"), sim.spike_counts("inh"))
    control, _ = counts[False]
    exc, inh = counts[True]
    winner = int(np.argmax(RATES))
    assert control[winner] >= 10, f"control counts {control.tolist()}"
    assert control[winner - 1] >= 5, f"control counts {control.tolist()}"
    assert int(np.argmax(exc)) == winner, f"with inhibition {exc.tolist()}, control {control.tolist()}"
    assert exc[winner] >= 0.8 * control[winner], f"with inhibition {exc.tolist()}, control {control.tolist()}"
    losers = np.delete(exc, winner)
    assert losers.sum() <= 0.1 * exc[winner], f"with inhibition {exc.tolist()}, control {control.tolist()}"
    assert inh[winner] >= exc[winner], f"inhibitory {inh.tolist()}, excitatory {exc.tolist()}"
