"""The mushroom-body network of Zhu, Mangan & Webb (Science Robotics 2023) as a neurovpr graph.

Layers and connections (populations in the order they are added)::

    input  (SpikeSourceArray, n_pn)   binned event-camera spikes, one source per mega-pixel
      | one-to-one, static, ``input_weight``
    pn     (IF_curr_exp_ca2_adaptive, n_pn)   projection neurons with Ca2+-activated AHP
      | fixed in-degree round(N(5, 1)), weights N(0.3, 0.1) nA, the SAME list onto both
      v                                          compartments
    kc1    (IF_curr_exp, n_kc)   Kenyon cells, first compartment
    kc2    (IF_curr_exp, n_kc)   Kenyon cells, second compartment (axon)
      kc1 -> kc2  axo-axonic inhibition, 4 subgroups of n_kc/4 KCs, each KC onto half of
                  the others of its subgroup (no self), weights 0 at first, additive
                  pair STDP (tau+ 1.25 ms, tau- 0.1 ms, A+ 0.3, A- 0.15, w in [0, 0.5] nA)
      | all-to-all, static, ``kc_mbon_weight``
    mbon   (IF_curr_exp, 1)      mushroom-body output neuron: a low rate means "familiar"

A Kenyon cell is two leaky integrate-and-fire units with the same projection-neuron
input. When the first compartment of KC ``i`` fires shortly before the second
compartment of KC ``j`` (within ~tau+), STDP strengthens the inhibition ``i -> j``;
replaying the same sequence later silences ``j``'s output to the MBON. A new view
drives other KCs in other orders and the MBON keeps firing.

The values, and where each comes from ("paper" = the publication or the project's
design notes quoting it; "chosen" = chosen here because the exact Table 1 value was not
available, picked to be biologically plausible and to make the network work on the
event-camera recordings in ``../shared/datasets/mbsnn_routes``):

===============================  ==============  ======================================
quantity                         value           source
===============================  ==============  ======================================
projection neurons               one per         paper (840 for 8x8 mega-pixels;
                                 mega-pixel      210 for the 16x16 binning of the
                                                 published 2020 recordings)
PN model                         IF_curr_exp_    paper (sPyNNaker IFCurrExpCa2Adaptive)
                                 ca2_adaptive
PN i_alpha (Ca2+ jump per spike) 0.2 nA          paper (alpha = 0.2)
PN i_offset                      0.02 nA         paper
PN cm, tau_m                     0.25 nF, 10 ms  chosen
PN tau_syn_E / tau_syn_I         1 ms / 1 ms     chosen (one input bin)
PN v_rest, v_reset, v_thresh     -65, -70, -55   chosen (mV)
PN tau_refrac, tau_ca2           1 ms, 50 ms     chosen (tau_ca2 = sPyNNaker's default)
input -> PN weight               2.5 nA          chosen: one input spike fires a rested
                                                 PN; the Ca2+ current then makes PNs
                                                 report changes, not steady activity
Kenyon cells                     4000            paper (option ``n_kc``)
PN -> KC in-degree               round(N(5, 1))  paper (clipped to >= 1)
PN -> KC weight                  N(0.3, 0.1) nA  paper (clipped to >= 0)
KC cm, tau_m                     0.06 nF, 10 ms  chosen: about 3 coincident PN inputs
                                                 fire a KC (sparse coding)
KC tau_syn_E, tau_syn_I          1 ms, 2 ms      chosen
KC v_rest, v_reset, v_thresh     -65, -70, -50   chosen (mV)
KC tau_refrac                    2 ms            chosen
KC -> KC subgroups, targets      4 x 1000, 500   paper (options ``kc_groups``,
                                                 ``kc_targets``; half the subgroup)
KC -> KC STDP                    see above       paper
KC -> MBON weight                0.01 nA         paper (at 4000 KCs; scaled by
                                                 4000 / n_kc for other sizes: chosen)
MBON cm, tau_m, tau_syn_E        0.1 nF, 20 ms,  chosen: tens of KC spikes within a few
                                 5 ms            ms fire the MBON
MBON v_rest, v_reset, v_thresh   -65, -65, -55   chosen (mV); tau_refrac 1 ms
synaptic delays                  one step        chosen (PyNN's minimum delay)
time step                        0.1 ms          chosen, see below
===============================  ==============  ======================================

Time step: tau- = 0.1 ms and tau+ = 1.25 ms only make sense with a step well below a
millisecond; 0.1 ms (PyNN's default) resolves the order in which KCs fire within one
1-ms input bin, which is what the STDP learns. At SpiNNaker's 1-ms step tau- is below
one step: by the simulation semantics (docs/semantics.md) a presynaptic arrival at the
instant of the postsynaptic spike counts as ``dt = 0`` and is depressed by the full
``A-``, and ``exp(-1 ms / 0.1 ms) = 4.5e-5`` makes every other post-before-pre pair
negligible. With the one-step delay, a second compartment firing one step after the
presynaptic KC meets the arrival and is depressed; potentiation needs a lag of two
steps or more (``0.3 w_max exp(-1 / 1.25)`` at two). The order within a 1-ms input bin
is then lost and only the order across bins is learned (``MBSNNParameters(dt=1.0)``
runs this variant).

How the chosen values were picked: with the rule constants fixed at the paper's, the KC
capacitance and threshold, the KC inhibitory time constant, the PN calcium time constant
and the MBON capacitance were varied one at a time, learning 40-60 % of recording NB3 and
testing on NB4 (4000 KCs, 100 windows); the table's values gave the highest AUC-ROC
(0.93; KC cm 0.08 nF: 0.90; KC tau_syn_I 1 ms: 0.92; PN tau_ca2 100 ms: 0.90; MBON cm
0.2 nF: 0.90; a 1-ms step: 0.90). Other recording pairs are therefore the fairer test.

Neuron counts: the graph holds ``n_pn`` sources, ``n_pn`` PNs, ``2 n_kc`` KC compartments
and one MBON (840 + 840 + 8000 + 1 = 9681 units at the paper's size). The paper's
"4,841 neurons" on SpiNNaker are 840 PNs + 4000 KCs + 1 MBON, each two-compartment KC
counted once and the spike sources not counted (see :func:`paper_neuron_count`).
"""

from __future__ import annotations

from dataclasses import dataclass, field

import numpy as np

import neurovpr as nv
from neurovpr.data.events import PNSpikes
from neurovpr.errors import ValidationError
from neurovpr.ir.connectors import Connector
from neurovpr.ir.node import IRNode, param
from neurovpr.resources import estimate_network, format_bytes, require_memory

__all__ = [
    "MBSNNParameters",
    "POPULATIONS",
    "KC_KC",
    "build_network",
    "check_resources",
    "pn_kc_connections",
    "kc_kc_connections",
    "paper_neuron_count",
    "with_input",
]

#: Population names, in the order they are added.
POPULATIONS = ("input", "pn", "kc1", "kc2", "mbon")
#: Name of the plastic axo-axonic projection.
KC_KC = "kc1->kc2"

_KW = {"frozen": True, "slots": True, "kw_only": True, "eq": False}
#: The paper's Kenyon cell count and KC->MBON weight (nA).
PAPER_N_KC, PAPER_KC_MBON_WEIGHT = 4000, 0.01


def _pn_cell() -> nv.IF_curr_exp_ca2_adaptive:
    return nv.IF_curr_exp_ca2_adaptive(
        cm=0.25, tau_m=10.0, tau_syn_E=1.0, tau_syn_I=1.0, tau_refrac=1.0,
        v_rest=-65.0, v_reset=-70.0, v_thresh=-55.0, i_offset=0.02,
        tau_ca2=50.0, i_alpha=0.2, i_ca2=0.0,
    )  # fmt: skip


def _kc_cell() -> nv.IF_curr_exp:
    return nv.IF_curr_exp(
        cm=0.06, tau_m=10.0, tau_syn_E=1.0, tau_syn_I=2.0, tau_refrac=2.0,
        v_rest=-65.0, v_reset=-70.0, v_thresh=-50.0, i_offset=0.0,
    )  # fmt: skip


def _mbon_cell() -> nv.IF_curr_exp:
    return nv.IF_curr_exp(
        cm=0.1, tau_m=20.0, tau_syn_E=5.0, tau_syn_I=5.0, tau_refrac=1.0,
        v_rest=-65.0, v_reset=-65.0, v_thresh=-55.0, i_offset=0.0,
    )  # fmt: skip


@dataclass(**_KW)
class MBSNNParameters(IRNode):
    """Sizes, weights, neuron models and learning rule of the mushroom body (see the module table).

    ``kc_targets=None`` means half of a subgroup (500 of 1000 at the paper's size);
    ``kc_mbon_weight=None`` means the paper's 0.01 nA at 4000 KCs, scaled by
    ``4000 / n_kc`` for other sizes so the MBON's total input stays the same.
    """

    n_kc: int = param(4000, low=4, integer=True, doc="Kenyon cells")
    kc_groups: int = param(4, low=1, integer=True, doc="KC subgroups for the KC->KC connections")
    kc_targets: int | None = None
    pn_kc_degree_mean: float = param(5.0, low=0.0, doc="mean PN inputs per KC")
    pn_kc_degree_sd: float = param(1.0, low=0.0)
    pn_kc_weight_mean: float = param(0.3, unit="nA")
    pn_kc_weight_sd: float = param(0.1, unit="nA", low=0.0)
    input_weight: float = param(2.5, unit="nA", low=0.0, low_open=True)
    kc_mbon_weight: float | None = None
    tau_plus: float = param(1.25, unit="ms", low=0.0, low_open=True)
    tau_minus: float = param(0.1, unit="ms", low=0.0, low_open=True)
    A_plus: float = param(0.3, low=0.0)
    A_minus: float = param(0.15, low=0.0)
    w_max: float = param(0.5, unit="nA", low=0.0, low_open=True)
    dt: float = param(0.1, unit="ms", low=0.0, low_open=True, high=1.0, doc="simulation time step")
    pn: nv.IF_curr_exp_ca2_adaptive = field(default_factory=_pn_cell)
    kc: nv.IF_curr_exp = field(default_factory=_kc_cell)
    mbon: nv.IF_curr_exp = field(default_factory=_mbon_cell)

    def _validate(self) -> None:
        if self.n_kc % self.kc_groups:
            raise ValidationError(
                f"MBSNNParameters.n_kc={self.n_kc} is not divisible into kc_groups={self.kc_groups} equal subgroups."
            )
        size = self.group_size
        if size < 2:
            raise ValidationError(f"MBSNNParameters: subgroups of {size} KC leave no other KC to inhibit.")
        if self.kc_targets is not None:
            t = self.kc_targets
            if isinstance(t, bool) or not isinstance(t, (int, np.integer)) or not 1 <= t <= size - 1:
                raise ValidationError(
                    f"MBSNNParameters.kc_targets must be an integer in 1..{size - 1} (the other KCs of a "
                    f"subgroup of {size}), got {t!r}."
                )
            object.__setattr__(self, "kc_targets", int(t))
        w = self.kc_mbon_weight
        if w is not None:
            if isinstance(w, bool) or not isinstance(w, (int, float, np.integer, np.floating)) or not 0 < w < np.inf:
                raise ValidationError(f"MBSNNParameters.kc_mbon_weight must be None or a number > 0 nA, got {w!r}.")
            object.__setattr__(self, "kc_mbon_weight", float(w))
        for name, kind in (("pn", nv.IF_curr_exp_ca2_adaptive), ("kc", nv.IF_curr_exp), ("mbon", nv.IF_curr_exp)):
            if type(getattr(self, name)) is not kind:
                raise ValidationError(
                    f"MBSNNParameters.{name} must be a {kind.__name__}, got {type(getattr(self, name)).__name__}."
                )

    @property
    def group_size(self) -> int:
        """KCs per subgroup."""
        return self.n_kc // self.kc_groups

    @property
    def targets_per_kc(self) -> int:
        """Second compartments each KC's first compartment inhibits."""
        return self.kc_targets if self.kc_targets is not None else max(self.group_size // 2, 1)

    @property
    def mbon_weight(self) -> float:
        """KC->MBON weight (nA): ``kc_mbon_weight``, or 0.01 nA scaled by ``4000 / n_kc``."""
        return self.kc_mbon_weight if self.kc_mbon_weight is not None else PAPER_KC_MBON_WEIGHT * PAPER_N_KC / self.n_kc

    def summary(self) -> dict[str, object]:
        """JSON-ready sizes and rule constants (the neuron parameters live in the saved network)."""
        return {
            "n_kc": self.n_kc,
            "kc_groups": self.kc_groups,
            "kc_targets": self.targets_per_kc,
            "pn_kc_degree": [self.pn_kc_degree_mean, self.pn_kc_degree_sd],
            "pn_kc_weight_nA": [self.pn_kc_weight_mean, self.pn_kc_weight_sd],
            "input_weight_nA": self.input_weight,
            "kc_mbon_weight_nA": self.mbon_weight,
            "stdp": {
                "tau_plus_ms": self.tau_plus, "tau_minus_ms": self.tau_minus,
                "A_plus": self.A_plus, "A_minus": self.A_minus, "w_min_nA": 0.0, "w_max_nA": self.w_max,
            },
            "dt_ms": self.dt,
        }  # fmt: skip


def _rng(seed: int, purpose: int) -> np.random.Generator:
    return np.random.default_rng(np.random.SeedSequence(entropy=int(seed), spawn_key=(purpose,)))


def pn_kc_connections(n_pn: int, params: MBSNNParameters, seed: int) -> np.ndarray:
    """``(n, 3)`` rows ``(pn, kc, weight)``: each KC's ``round(N(5, 1))`` distinct PNs and their weights.

    In-degrees are clipped to ``1..n_pn`` and weights to ``>= 0``. Rows are sorted by KC,
    then PN. Both KC compartments use this same list.
    """
    if int(n_pn) < 1:
        raise ValidationError(f"pn_kc_connections: need at least one projection neuron, got n_pn={n_pn}.")
    rng = _rng(seed, 0)
    degree = np.clip(np.rint(rng.normal(params.pn_kc_degree_mean, params.pn_kc_degree_sd, params.n_kc)), 1, n_pn)
    degree = degree.astype(np.int64)
    # distinct random PNs per KC: the first `degree` entries of a random permutation
    keys = rng.random((params.n_kc, int(n_pn)))
    order = np.argsort(keys, axis=1)
    kc = np.repeat(np.arange(params.n_kc, dtype=np.int64), degree)
    pn = np.concatenate([np.sort(order[j, : degree[j]]) for j in range(params.n_kc)]).astype(np.int64)
    weight = np.clip(rng.normal(params.pn_kc_weight_mean, params.pn_kc_weight_sd, kc.size), 0.0, None)
    return np.column_stack([pn.astype(np.float64), kc.astype(np.float64), weight])


def kc_kc_connections(params: MBSNNParameters, seed: int) -> np.ndarray:
    """``(n, 2)`` rows ``(kc, kc)``: each KC onto ``targets_per_kc`` other KCs of its own subgroup.

    Subgroup ``g`` holds KCs ``g * group_size .. (g + 1) * group_size - 1``. Rows are
    sorted by presynaptic, then postsynaptic KC.
    """
    rng = _rng(seed, 1)
    size, k = params.group_size, params.targets_per_kc
    pre = np.repeat(np.arange(params.n_kc, dtype=np.int64), k)
    # random distinct others: sample offsets 1..size-1 within the subgroup, wrap around
    keys = rng.random((params.n_kc, size - 1))
    offsets = np.sort(np.argsort(keys, axis=1)[:, :k] + 1, axis=1)
    local = np.arange(params.n_kc, dtype=np.int64) % size
    base = np.arange(params.n_kc, dtype=np.int64) - local
    post = (base[:, None] + (local[:, None] + offsets) % size).ravel()
    rows = np.column_stack([pre, post])
    rows = rows[np.lexsort((rows[:, 1], rows[:, 0]))]
    return rows.astype(np.float64)


def build_network(n_pn: int, params: MBSNNParameters | None = None, *, seed: int = 0, name: str = "mbsnn") -> nv.Network:
    """The mushroom-body graph for ``n_pn`` projection neurons.

    The ``input`` population starts without spikes; give a recording's spikes with
    ``Simulation.run(..., inputs={"input": spikes.to_source()})``. ``seed`` draws the
    PN->KC and KC->KC wiring (the compile seed is not used for it), so the network is
    the same on every backend.
    """
    params = params if params is not None else MBSNNParameters()
    if isinstance(n_pn, bool) or not isinstance(n_pn, (int, np.integer)) or n_pn < 1:
        raise ValidationError(f"build_network: n_pn must be an integer >= 1, got {n_pn!r}.")
    n_pn = int(n_pn)
    check_resources(n_pn, params, what="build_network")
    empty = nv.SpikeSourceArray(times=np.zeros(0), offsets=np.zeros(n_pn + 1, dtype=np.int64))
    shared = nv.FromListConnector(conn_list=pn_kc_connections(n_pn, params, seed))
    return _assemble(n_pn, params, empty, shared, nv.FromListConnector(conn_list=kc_kc_connections(params, seed)), name)


def _assemble(
    n_pn: int, params: MBSNNParameters, source: nv.SpikeSourceArray | nv.SpikeSourcePoisson, pn_kc: Connector,
    kc_kc: Connector, name: str,
) -> nv.Network:  # fmt: skip
    """The graph with the given input cells and PN->KC and KC->KC connectors."""
    net = nv.Network(name)
    net.add_population("input", n_pn, source)
    net.add_population("pn", n_pn, params.pn)
    net.add_population("kc1", params.n_kc, params.kc)
    net.add_population("kc2", params.n_kc, params.kc)
    net.add_population("mbon", 1, params.mbon)
    net.connect("input", "pn", nv.OneToOneConnector(), nv.StaticSynapse(weight=params.input_weight))
    net.connect("pn", "kc1", pn_kc, nv.StaticSynapse())
    net.connect("pn", "kc2", pn_kc, nv.StaticSynapse())
    stdp = nv.STDPMechanism(
        timing_dependence=nv.SpikePairRule(
            tau_plus=params.tau_plus, tau_minus=params.tau_minus, A_plus=params.A_plus, A_minus=params.A_minus
        ),
        weight_dependence=nv.AdditiveWeightDependence(w_min=0.0, w_max=params.w_max),
        weight=0.0,
    )
    net.connect("kc1", "kc2", kc_kc, stdp, receptor_type="inhibitory", name=KC_KC)
    net.connect("kc2", "mbon", nv.AllToAllConnector(), nv.StaticSynapse(weight=params.mbon_weight))
    return net


def check_resources(n_pn: int | None, params: MBSNNParameters, *, what: str = "train") -> None:
    """Refuse, before anything is drawn or built, a mushroom body past the memory limit.

    Counts the random keys and their sort order that draw the PN->KC and KC->KC wiring
    (16 bytes per KC and candidate partner) and the network itself
    (:func:`neurovpr.resources.estimate_network` of the same graph with random
    connectors of the same in-degrees standing in for the drawn lists). ``n_pn=None``
    (the data decides it and is not read yet) counts one PN: the Kenyon-cell side alone.

    Raises
    ------
    neurovpr.resources.ResourceLimitError
        One sentence naming the sizes, the estimate and the limit.
    """
    n = 1 if n_pn is None else int(n_pn)
    wiring = 16.0 * params.n_kc * (n + params.group_size)
    pns = "PNs from the data" if n_pn is None else f"{n} PNs"
    what = f"{what}: the mushroom body with {params.n_kc} Kenyon cells in {params.kc_groups} subgroup(s) and {pns}"
    require_memory(wiring, what, " to draw its wiring")  # before the stand-in below is built
    degree = nv.Normal(mu=params.pn_kc_degree_mean, sigma=params.pn_kc_degree_sd)
    targets = nv.FixedNumberPreConnector(params.targets_per_kc)
    stand_in = _assemble(n, params, nv.SpikeSourcePoisson(rate=0.0), nv.FixedNumberPreConnector(degree), targets, "mbsnn")
    total = wiring + estimate_network(stand_in, dt=params.dt).memory
    require_memory(total, what, f" ({format_bytes(wiring)} of it to draw the wiring)")


def paper_neuron_count(network: nv.Network) -> dict[str, int]:
    """Neurons counted as the paper counts them, next to the units of the graph.

    Returns ``{"graph_units": all populations, sources included, "simulated_neurons":
    all but the sources, "paper_count": PNs + KCs (one per two-compartment KC) +
    MBONs}``; ``paper_count`` is 4,841 at the paper's size (840 PNs, 4000 KCs).
    """
    pops = network.populations
    missing = [p for p in POPULATIONS if p not in pops]
    if missing:
        raise ValidationError(f"paper_neuron_count: network {network.name!r} lacks population(s) {', '.join(missing)}.")
    sources = sum(p.size for p in pops.values() if p.is_source)
    return {
        "graph_units": network.n_neurons,
        "simulated_neurons": network.n_neurons - sources,
        "paper_count": pops["pn"].size + pops["kc1"].size + pops["mbon"].size,
    }



def with_input(network: nv.Network, spikes: PNSpikes) -> nv.Network:
    """A copy of ``network`` whose ``input`` population plays ``spikes`` (e.g. for mapping onto a chip)."""
    pop = network.populations["input"]
    if spikes.n_pn != pop.size:
        raise ValidationError(f"with_input: the recording has {spikes.n_pn} PNs but network {network.name!r} has {pop.size}.")
    net = network.copy()
    net.replace_population(pop.replace(cell_type=spikes.to_source()))  # type: ignore[arg-type]
    return net
