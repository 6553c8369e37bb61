"""Seeded random networks for the chip-format equivalence suites, and the spike comparison they use.

:func:`random_network` draws one network from a seed over the ranges below (:data:`RANGES`),
for one of two oracles:

* ``"lava"`` (``hardware="loihi2"`` against the ``lava-fixed`` backend, Lava's own ``fixed_pt``
  models): any projection between populations, recurrent ones included, any delay.
* ``"nengo-loihi"`` (``hardware="kapoho-bay"`` against NengoLoihi's emulator): NengoLoihi has
  no synaptic delays, so a spike between two on-chip populations acts one step earlier
  there than in docs/semantics.md (and on the chip with its synaptic delay). Only networks
  whose spikes still line up are drawn, each exclusion for that reason: populations fed by
  other populations form a second layer, fed through delays of 1 ms only, with no bias
  current and ``v_rest == v_reset`` (so they rest until input arrives and shifting their
  input shifts their spikes: they are compared one step later), and no recurrent projection
  (a loop runs one step faster in NengoLoihi). NengoLoihi also starts every compartment at
  ``v_reset`` (the ``nengo-loihi`` backend refuses another ``v_init``).

Drawn for every network (``RANGES``; times and delays in whole ms, the chips' 1 ms step):

* 1-2 ``SpikeSourceArray`` populations of 5-60 neurons, each neuron 5-80 Hz of explicit
  spike times at integer ms in [1, 240) ms (no Poisson source anywhere);
* 1-3 ``IF_curr_exp`` populations of 3-40 neurons (a quarter of them as large as the first
  source), per population ``tau_m`` 5-100 ms and ``tau_syn`` 1-20 ms (log-uniform), ``cm``
  0.25-2 nF, ``v_rest`` -70..-60 mV, ``v_reset`` -75..-60 mV, ``v_thresh`` 5-20 mV above
  both, ``tau_refrac`` 0 or 0-5 ms, ``i_offset`` 0 or -0.5..2 times the rheobase
  ``(v_thresh - v_rest) cm / tau_m``, ``v_init`` at rest or anywhere between ``v_reset`` and
  ``v_thresh``; ``tau_syn_E == tau_syn_I`` where both receptors are used (a Loihi
  compartment has one synaptic current), else each drawn;
* 1-3 incoming projections per population, the first excitatory, each further one
  inhibitory with probability 0.4, from a source or a population: all-to-all, fixed
  probability (0.1-0.5), fixed number of presynaptic neurons (1-10), one-to-one (equal
  sizes), an explicit list (distinct pairs, up to a tenth of them repeated: duplicates are
  summed) or, for a recurrent projection (Lava only), all-to-all without self-connections;
  weights in nA scaled so that one spike's PSP peaks at 5-100 % of ``v_thresh - v_reset``
  (log-uniform per projection), times U(0.1, 1) per connection, and in 40 % of excitatory
  projections 10-50 % of the connections negative (mixed signs; the IR, as PyNN, refuses
  negative weights onto an inhibitory receptor); delays 1-16 ms, one per projection or 2-3
  distinct values per connection. Half of the populations of a Lava network get a recurrent
  projection (onto themselves or from a later population).
"""

from __future__ import annotations

from dataclasses import dataclass

import numpy as np

import neurovpr as nv

__all__ = ["RANGES", "DURATION_MS", "Drawn", "random_network", "spike_events", "first_difference"]

#: Length of every comparison run (ms).
DURATION_MS = 250.0


@dataclass(frozen=True)
class Ranges:
    """The ranges :func:`random_network` draws from (see the module docstring)."""

    sources: tuple[int, int] = (1, 2)
    source_size: tuple[int, int] = (5, 60)
    source_rate_hz: tuple[float, float] = (5.0, 80.0)
    last_input_ms: int = 240
    populations: tuple[int, int] = (1, 3)
    size: tuple[int, int] = (3, 40)
    tau_m_ms: tuple[float, float] = (5.0, 100.0)
    tau_syn_ms: tuple[float, float] = (1.0, 20.0)
    cm_nf: tuple[float, float] = (0.25, 2.0)
    v_rest_mv: tuple[float, float] = (-70.0, -60.0)
    v_reset_mv: tuple[float, float] = (-75.0, -60.0)
    threshold_gap_mv: tuple[float, float] = (5.0, 20.0)
    tau_refrac_ms: tuple[float, float] = (0.0, 5.0)
    bias_rheobases: tuple[float, float] = (-0.5, 2.0)
    projections: tuple[int, int] = (1, 3)
    psp_fraction: tuple[float, float] = (0.05, 1.0)
    negative_fraction: tuple[float, float] = (0.1, 0.5)
    p_connect: tuple[float, float] = (0.1, 0.5)
    n_pre: tuple[int, int] = (1, 10)
    delay_ms: tuple[int, int] = (1, 16)


RANGES = Ranges()
_ORACLES = ("lava", "nengo-loihi")


@dataclass(frozen=True)
class Drawn:
    """A drawn network and, per neuron population, how many steps later than the oracle's its spikes are."""

    seed: int
    network: nv.Network
    shift_steps: dict[str, int]


def _log_uniform(rng: np.random.Generator, bounds: tuple[float, float]) -> float:
    return float(np.exp(rng.uniform(np.log(bounds[0]), np.log(bounds[1]))))


def _int(rng: np.random.Generator, bounds: tuple[int, int]) -> int:
    return int(rng.integers(bounds[0], bounds[1] + 1))


def _sources(rng: np.random.Generator, net: nv.Network, r: Ranges) -> list[str]:
    names = []
    for k in range(_int(rng, r.sources)):
        size = _int(rng, r.source_size)
        trains = []
        for rate in rng.uniform(*r.source_rate_hz, size):
            count = min(rng.poisson(rate * r.last_input_ms / 1000.0), r.last_input_ms - 1)
            trains.append(np.sort(rng.choice(np.arange(1, r.last_input_ms), count, replace=False)).astype(float))
        names.append(f"src{k}")
        net.add_population(names[-1], size, nv.SpikeSourceArray.from_lists(trains))
    return names


@dataclass
class _Plan:
    pre: str
    post: str
    receptor: str
    recurrent: bool


def _plan(rng: np.random.Generator, sources: list[str], pops: list[str], oracle: str, r: Ranges) -> list[_Plan]:
    """Who projects to whom; for NengoLoihi a second layer fed only by the first."""
    plans: list[_Plan] = []
    second = set()
    if oracle == "nengo-loihi" and len(pops) > 1 and rng.random() < 0.6:
        second = set(pops[-int(rng.integers(1, len(pops))) :])
    first = [p for p in pops if p not in second]
    for k, post in enumerate(pops):
        if post in second:
            allowed = first
        elif oracle == "lava":
            allowed = sources + pops[:k]
        else:
            allowed = sources
        for j in range(_int(rng, r.projections)):
            pre = sources[0] if j == 0 and post not in second else allowed[int(rng.integers(len(allowed)))]
            inhibitory = j > 0 and rng.random() < 0.4  # the first is excitatory: a population that can fire
            plans.append(_Plan(pre, post, "inhibitory" if inhibitory else "excitatory", False))
        if oracle == "lava" and rng.random() < 0.5:  # recurrent: onto itself, or back from a later population
            pre = post if k == len(pops) - 1 or rng.random() < 0.6 else pops[int(rng.integers(k + 1, len(pops)))]
            plans.append(_Plan(pre, post, "inhibitory" if rng.random() < 0.6 else "excitatory", True))
    return plans


def _cell(rng: np.random.Generator, both: bool, quiet: bool, oracle: str, r: Ranges) -> tuple[nv.IF_curr_exp, float | None]:
    tau_m = _log_uniform(rng, r.tau_m_ms)
    tau_e, tau_i = _log_uniform(rng, r.tau_syn_ms), _log_uniform(rng, r.tau_syn_ms)
    cm = float(rng.uniform(*r.cm_nf))
    v_rest = float(rng.uniform(*r.v_rest_mv))
    v_reset = v_rest if quiet else float(rng.uniform(*r.v_reset_mv))
    v_thresh = max(v_rest, v_reset) + float(rng.uniform(*r.threshold_gap_mv))
    refrac = 0.0 if rng.random() < 0.4 else float(rng.uniform(*r.tau_refrac_ms))
    rheobase = (v_thresh - v_rest) * cm / tau_m
    bias = 0.0 if quiet or rng.random() < 0.4 else float(rng.uniform(*r.bias_rheobases)) * rheobase
    v_init = None if quiet or rng.random() < 0.6 else float(rng.uniform(v_reset, v_thresh))
    if oracle == "nengo-loihi":
        v_init = v_reset  # NengoLoihi starts every compartment at 0, which stands for v_reset
    cell = nv.IF_curr_exp(tau_m=tau_m, tau_syn_E=tau_e, tau_syn_I=tau_e if both else tau_i, cm=cm, v_rest=v_rest,
                          v_reset=v_reset, v_thresh=v_thresh, tau_refrac=refrac, i_offset=bias)  # fmt: skip
    return cell, v_init


def _psp_peak(cell: nv.IF_curr_exp, tau_syn: float) -> float:
    """Peak (mV) of the membrane's response to one 1 nA synaptic current decaying with ``tau_syn``."""
    tau_m = cell.tau_m
    if abs(tau_m - tau_syn) < 1e-9 * tau_m:
        return tau_m / cell.cm * np.exp(-1.0)
    t_peak = np.log(tau_m / tau_syn) * tau_m * tau_syn / (tau_m - tau_syn)
    return tau_syn * tau_m / (cell.cm * (tau_m - tau_syn)) * (np.exp(-t_peak / tau_m) - np.exp(-t_peak / tau_syn))


def _connector(rng: np.random.Generator, plan: _Plan, n_pre: int, n_post: int, r: Ranges):
    if plan.recurrent and plan.pre == plan.post:
        if rng.random() < 0.5:
            return nv.AllToAllConnector(allow_self_connections=False)
        return nv.FixedProbabilityConnector(p_connect=float(rng.uniform(*r.p_connect)), seed=int(rng.integers(2**31)))
    kinds = ["all", "probability", "number", "list"] + (["one"] if n_pre == n_post else [])
    kind = kinds[int(rng.integers(len(kinds)))]
    if kind == "all":
        return nv.AllToAllConnector()
    if kind == "probability":
        return nv.FixedProbabilityConnector(p_connect=float(rng.uniform(*r.p_connect)), seed=int(rng.integers(2**31)))
    if kind == "number":
        return nv.FixedNumberPreConnector(n=min(_int(rng, r.n_pre), n_pre), seed=int(rng.integers(2**31)))
    if kind == "one":
        return nv.OneToOneConnector()
    count = max(1, int(n_pre * n_post * rng.uniform(*r.p_connect)))
    pairs = rng.choice(n_pre * n_post, count, replace=False)
    pairs = np.concatenate([pairs, rng.choice(pairs, int(rng.integers(0, count // 10 + 2)))])  # some pairs twice
    return nv.FromListConnector(conn_list=np.stack([pairs // n_post, pairs % n_post], axis=1))


def _delays(rng: np.random.Generator, shape: tuple[int, int], r: Ranges) -> float | np.ndarray:
    if rng.random() < 0.5:
        return float(_int(rng, r.delay_ms))
    values = rng.choice(np.arange(r.delay_ms[0], r.delay_ms[1] + 1), int(rng.integers(2, 4)), replace=False)
    return rng.choice(values, shape).astype(float)


def random_network(seed: int, oracle: str, ranges: Ranges = RANGES) -> Drawn:
    """Draw one network for ``oracle`` (``"lava"`` or ``"nengo-loihi"``) from ``seed`` (see the module docstring)."""
    if oracle not in _ORACLES:
        raise ValueError(f"oracle must be one of {_ORACLES}, got {oracle!r}")
    r = ranges
    rng = np.random.default_rng(seed)
    net = nv.Network(f"random{seed}")
    sources = _sources(rng, net, r)
    pops = [f"pop{k}" for k in range(_int(rng, r.populations))]
    sizes = {name: net.populations[name].size for name in sources}
    # a quarter of the populations as large as the first source, so that one-to-one connectors occur
    sizes.update({name: sizes[sources[0]] if rng.random() < 0.25 else _int(rng, r.size) for name in pops})
    plans = _plan(rng, sources, pops, oracle, r)
    layer2 = {p.post for p in plans if p.pre in pops} if oracle == "nengo-loihi" else set()
    cells = {}
    for name in pops:
        both = len({p.receptor for p in plans if p.post == name}) == 2
        cell, v_init = _cell(rng, both, name in layer2, oracle, r)
        cells[name] = cell
        net.add_population(name, sizes[name], cell, v_init=v_init)
    for k, plan in enumerate(plans):
        cell = cells[plan.post]
        n_pre, n_post = sizes[plan.pre], sizes[plan.post]
        tau_syn = cell.tau_syn_E if plan.receptor == "excitatory" else cell.tau_syn_I
        scale = _log_uniform(rng, r.psp_fraction) * (cell.v_thresh - cell.v_reset) / _psp_peak(cell, tau_syn)
        weights = scale * rng.uniform(0.1, 1.0, (n_pre, n_post))
        if plan.receptor == "excitatory" and rng.random() < 0.4:
            weights *= np.where(rng.random((n_pre, n_post)) < rng.uniform(*r.negative_fraction), -1.0, 1.0)
        delay = 1.0 if plan.pre in layer2 or plan.post in layer2 else _delays(rng, (n_pre, n_post), r)
        connector = _connector(rng, plan, n_pre, n_post, r)
        net.connect(plan.pre, plan.post, connector, nv.StaticSynapse(weight=weights, delay=delay),
                    receptor_type=plan.receptor, name=f"p{k}:{plan.pre}->{plan.post}")  # fmt: skip
    return Drawn(seed=seed, network=net, shift_steps={name: int(name in layer2) for name in pops})


def spike_events(sim, populations: list[str], shift_ms: dict[str, float] | None = None,
                 until_ms: float = np.inf) -> list[tuple[float, str, int]]:  # fmt: skip
    """``(time, population, neuron)`` of every spike of ``populations`` (times plus ``shift_ms``, up to ``until_ms``), sorted."""
    out = []
    for name in populations:
        t, i = sim.spike_trains(name)
        t = np.asarray(t, dtype=float) + (shift_ms or {}).get(name, 0.0)
        keep = t <= until_ms + 1e-9
        out.extend(zip(np.round(t[keep], 6).tolist(), [name] * int(keep.sum()), np.asarray(i)[keep].tolist(), strict=True))
    return sorted(out, key=lambda e: (e[0], e[1], e[2]))


def first_difference(seed: int, mine: list, theirs: list, names: tuple[str, str]) -> str | None:
    """``None`` when the spike lists are equal, else one line naming the seed and the first differing spike."""
    if mine == theirs:
        return None
    k = next((k for k, (a, b) in enumerate(zip(mine, theirs, strict=False)) if a != b), min(len(mine), len(theirs)))

    def at(events: list) -> str:
        if k >= len(events):
            return "no further spike"
        t, pop, i = events[k]
        return f"{pop}[{i}] at {t:g} ms"

    return (
        f"seed {seed}: {len(mine)} spikes in {names[0]}, {len(theirs)} in {names[1]}; first difference (spike {k}): "
        f"{at(mine)} in {names[0]}, {at(theirs)} in {names[1]}"
    )
