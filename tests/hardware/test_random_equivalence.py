"""Randomised equivalence of the chip-format emulation with the vendors' emulators, spike for spike.

Seeded random networks (``random_networks.py`` draws them and its docstring lists every range:
1-2 explicit spike sources of 5-60 neurons at 5-80 Hz; 1-3 ``IF_curr_exp`` populations of
3-40 neurons with ``tau_m`` 5-100 ms, ``tau_syn`` 1-20 ms, ``cm``, ``v_rest``, ``v_reset``,
``v_thresh``, ``v_init``, refractory periods 0-5 ms and bias currents drawn per population;
excitatory and inhibitory projections, mixed-sign weights, PSPs of 5-100 % of the threshold
gap, delays 1-16 ms; all-to-all, fixed-probability, fixed-number, one-to-one and explicit
lists; recurrent projections for Lava) run 250 ms at 1 ms:

* ``hardware="kapoho-bay"`` against NengoLoihi's emulator (the ``nengo-loihi`` backend): the
  integers of every core block and every spike. NengoLoihi has no synaptic delays, so
  only networks whose spikes line up are drawn (no recurrence; a second layer fed through
  1 ms delays only and starting from rest, compared one step later; every compartment
  starting at ``v_reset``);
* ``hardware="loihi2"`` against Lava's ``fixed_pt`` models (the ``lava-fixed`` backend,
  which maps the network with its own code): every population's integers, every synapse
  process's 8-bit weights and exponent, and every spike. A network whose weights need a
  weight exponent outside the hwspec's ``[formats]`` range is refused by the emulation with
  that reason (Lava's Python models do not check it); the test checks the refusal against
  the exponent Lava's processes get and counts it as excluded, never as compared.

The default run compares tens of networks (about a minute); ``-m slow`` hundreds. Each
mismatch names its seed (``random_network(seed, oracle)`` rebuilds the network) and the first
differing spike on each side. ``-s`` prints the counts the README reports.
"""

from __future__ import annotations

from dataclasses import dataclass, field

import numpy as np
import pytest
from chip_oracles import ORACLES, lava_integer_difference, nengo_integer_difference, oracle_backend, run_both
from random_networks import DURATION_MS, first_difference, random_network, spike_events

from neurovpr.errors import ValidationError
from neurovpr.hardware import load_hwspec

#: Seeds of the default run and of the slow run, per oracle.
DEFAULT_SEEDS = {"nengo-loihi": range(0, 24), "lava": range(0, 8)}
SLOW_SEEDS = {"nengo-loihi": range(1000, 1300), "lava": range(1000, 1200)}


@dataclass
class Sweep:
    """What one sweep compared."""

    oracle: str
    networks: int = 0
    populations: int = 0
    spikes: int = 0
    mismatches: list[str] = field(default_factory=list)
    excluded: list[str] = field(default_factory=list)

    def summary(self, seeds: range) -> str:
        hardware, backend = ORACLES[self.oracle]
        return (
            f"{hardware} vs {backend}: {self.networks} networks (seeds {seeds.start}-{seeds.stop - 1}), "
            f"{self.populations} populations, {self.spikes} spikes, {len(self.mismatches)} mismatches, "
            f"{len(self.excluded)} excluded"
        )


def _close(sim) -> None:
    if hasattr(sim, "close"):
        sim.close()


def _exponent_refusal(drawn, exc: ValidationError) -> str:
    """Check that Lava's mapping of the refused network gets a weight exponent outside the hwspec's range."""
    fmt = load_hwspec("loihi2").formats
    theirs = oracle_backend("lava-fixed").compile(drawn.network, dt=1.0, seed=3, hardware=None)
    try:
        exps = [int(p.proc_params.get("weight_exp", 0)) for ps in theirs._built.synapses.values() for p in ps]
    finally:
        _close(theirs)
    assert min(exps) < fmt.weight_exponent_min or max(exps) > fmt.weight_exponent_max, (drawn.seed, str(exc), exps)
    return f"seed {drawn.seed}: {exc}"


def _sweep(oracle: str, seeds: range) -> Sweep:
    out = Sweep(oracle)
    for seed in seeds:
        drawn = random_network(seed, oracle)
        pops = list(drawn.shift_steps)
        try:
            mine, theirs = run_both(drawn.network, oracle, DURATION_MS)
        except ValidationError as exc:
            if oracle == "lava" and "weight exponent" in str(exc):
                out.excluded.append(_exponent_refusal(drawn, exc))
                continue
            raise
        try:
            if oracle == "lava":
                problem = lava_integer_difference(mine, theirs)
            else:
                problem = nengo_integer_difference(mine, theirs, pops)
            shift = {name: float(steps) for name, steps in drawn.shift_steps.items()}
            ours = spike_events(mine, pops)
            spikes = first_difference(seed, ours, spike_events(theirs, pops, shift, DURATION_MS), ("reference", oracle))
        finally:
            _close(theirs)
        if problem is not None:
            out.mismatches.append(f"seed {seed}: integers: {problem}")
        if spikes is not None:
            out.mismatches.append(spikes)
        out.networks += 1
        out.populations += len(pops)
        out.spikes += len(ours)
    return out


def _check(oracle: str, seeds: range) -> None:
    result = _sweep(oracle, seeds)
    print(result.summary(seeds))
    for line in result.excluded:
        print(f"  excluded: {line}")
    assert not result.mismatches, "\n".join(result.mismatches)
    assert result.networks >= 0.9 * len(seeds), result.excluded
    assert result.spikes > 100 * result.networks  # the networks are not silent
    return None


def test_kapoho_bay_matches_nengo_loihi_on_random_networks():
    _check("nengo-loihi", DEFAULT_SEEDS["nengo-loihi"])


def test_loihi2_matches_lava_fixed_point_on_random_networks():
    _check("lava", DEFAULT_SEEDS["lava"])


@pytest.mark.slow
def test_kapoho_bay_matches_nengo_loihi_on_hundreds_of_random_networks():
    _check("nengo-loihi", SLOW_SEEDS["nengo-loihi"])


@pytest.mark.slow
def test_loihi2_matches_lava_fixed_point_on_hundreds_of_random_networks():
    _check("lava", SLOW_SEEDS["lava"])


def test_random_networks_cover_the_drawn_ranges():
    """The default seeds draw what the docstrings promise: both receptors into one population, mixed signs,
    several delays, refractory periods, bias currents, every connector and (Lava) recurrence."""
    for oracle, seeds in DEFAULT_SEEDS.items():
        seen: set[str] = set()
        for seed in seeds:
            net = random_network(seed, oracle).network
            for proj in net.projections.values():
                seen.add(type(proj.connector).__name__)
                weight = np.asarray(proj.synapse.weight)
                if weight.min() < 0 < weight.max():
                    seen.add("mixed signs")
                if np.unique(np.asarray(proj.synapse.delay)).size > 1:
                    seen.add("several delays")
                if not net.populations[proj.pre].is_source and proj.pre >= proj.post:  # popK -> popJ, K >= J
                    seen.add("recurrent")
            for pop in net.populations.values():
                if pop.is_source:
                    continue
                kinds = {p.receptor_type for p in net.projections.values() if p.post == pop.name}
                if kinds == {"excitatory", "inhibitory"}:
                    seen.add("both receptors")
                if pop.cell_type.tau_refrac > 0:
                    seen.add("refractory")
                if pop.cell_type.i_offset != 0:
                    seen.add("bias")
        expected = {"AllToAllConnector", "FixedProbabilityConnector", "FixedNumberPreConnector", "FromListConnector",
                    "OneToOneConnector", "mixed signs", "several delays", "both receptors", "refractory", "bias"}  # fmt: skip
        if oracle == "lava":
            expected |= {"recurrent"}
        else:
            assert "recurrent" not in seen
        assert expected <= seen, (oracle, expected - seen)


def test_a_mismatch_names_the_seed_and_the_first_differing_spike():
    mine = [(3.0, "pop0", 1), (22.0, "pop1", 4)]
    theirs = [(3.0, "pop0", 1), (21.0, "pop1", 4)]
    msg = first_difference(17, mine, theirs, ("reference", "lava"))
    assert msg == ("seed 17: 2 spikes in reference, 2 in lava; first difference (spike 1): pop1[4] at 22 ms in "
                   "reference, pop1[4] at 21 ms in lava")  # fmt: skip
    assert "no further spike in lava" in first_difference(5, mine, theirs[:1], ("reference", "lava"))
    assert first_difference(1, mine, list(mine), ("reference", "lava")) is None
