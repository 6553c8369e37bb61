"""NengoLoihi specifics: the emulator simulator, its reset, voltage units and core usage.

NengoLoihi builds a Nengo network into Loihi *blocks*, splits each block so that it
fits one core (its ``split_blocks`` pass, steered by ``BlockShape``), discretises
every block to Loihi's number formats (``discretize``) and checks the limits
(``validate``). The emulator (``target="sim"``) then runs those integer blocks. The
report here reads the blocks after that whole pipeline: it is NengoLoihi's own
mapping, which neurovpr's hardware checker must agree with.
"""

from __future__ import annotations

from typing import TYPE_CHECKING, Any

import nengo
import numpy as np

if TYPE_CHECKING:
    from .build import BuiltNetwork

__all__ = ["new_loihi_simulator", "reset_loihi_simulator", "loihi_voltage_scale", "block_report"]


def new_loihi_simulator(net: nengo.Network, *, dt: float, seed: int) -> Any:
    """NengoLoihi's emulator for ``net`` (``dt`` in ms), inputs precomputed on the host."""
    import nengo_loihi

    return nengo_loihi.Simulator(net, dt=dt / 1000.0, seed=seed % 2**31, target="sim", precompute=True, progress_bar=False)


def reset_loihi_simulator(sim: Any, *, seed: int) -> None:
    """Return a NengoLoihi emulator simulation to time 0 without rebuilding it.

    NengoLoihi 1.1's ``Simulator.reset`` is not implemented. The built and discretised
    model is static, so a fresh ``EmulatorInterface`` on the same model is the initial
    state; the host simulators reset themselves, pending host-to-chip spikes are
    dropped and the step runner is rebuilt around the new objects (it holds the host
    queues).
    """
    from nengo_loihi.emulator import EmulatorInterface
    from nengo_loihi.simulator import StepRunner

    for spike_input in sim.model.inputs:
        for ti in [ti for ti in spike_input.spikes if ti not in spike_input.permanent]:
            del spike_input.spikes[ti]
    old = sim.sims["emulator"]
    sim.sims["emulator"] = EmulatorInterface(sim.model, seed=seed % 2**31)
    old.close()
    for key in ("host_pre", "host"):
        if key in sim.sims:
            sim.sims[key].reset(seed=seed % 2**31)
    sim._runner = StepRunner(sim.model, sim.sims, sim.precompute, sim.timers)
    sim._n_steps = 0
    sim._time = 0.0


def _blocks_of(sim: Any, ens: nengo.Ensemble) -> list[Any]:
    """The on-chip blocks holding ``ens`` after NengoLoihi's splitting (it records them in ``model.objs``)."""
    out = sim.model.objs[ens]["out"]
    return list(out) if isinstance(out, (list, tuple)) else [out]


def loihi_voltage_scale(sim: Any, ens: nengo.Ensemble) -> np.ndarray:
    """Per neuron, the integer voltage of the threshold (probed voltages divided by it are in [.., 1])."""
    blocks = _blocks_of(sim, ens)
    scale = np.empty(ens.n_neurons)
    for block in blocks:
        idx = np.asarray(list(sim.model.block_comp_map[block]), dtype=np.int64)
        scale[idx] = block.compartment.vth
    return scale


def block_report(
    sim: Any, built: BuiltNetwork, *, max_chips: int | None = None, cores_per_chip: int | None = None
) -> dict[str, Any]:
    """Cores (one per block), chips and per-block resources of NengoLoihi's mapping.

    Parameters
    ----------
    sim
        A built ``nengo_loihi.Simulator``.
    built
        The Nengo objects of each population.
    max_chips
        Chips available (a hwspec's count); ``None`` allows as many as needed.
    cores_per_chip
        Cores per chip (a hwspec's count); ``None`` uses NengoLoihi's allocator default.

    Returns
    -------
    dict
        ``cores``, ``chips`` (``None`` when ``max_chips`` chips are not enough),
        ``blocks`` (population, block, compartments, in_axons, out_axons,
        synapse_bits, limits) and ``inputs`` (off-chip spike inputs: population, axons).
    """
    from nengo_loihi.hardware.allocators import Greedy

    owner: dict[int, str] = {}
    for name, ens in built.ensembles.items():
        for block in _blocks_of(sim, ens):
            owner[id(block)] = name
    blocks = []
    for block in sim.model.blocks:
        use = block.utilization()  # NengoLoihi's own counts: {quantity: (used, limit)}
        blocks.append(
            {
                "population": owner.get(id(block)),
                "block": block.label,
                "compartments": int(use["compartments"][0]),
                "in_axons": int(use["in-axons"][0]),
                "out_axons": int(use["out-axons"][0]),
                "synapse_bits": int(use["synapses"][0]),
                "limits": {
                    "compartments": int(use["compartments"][1]),
                    "in_axons": int(use["in-axons"][1]),
                    "out_axons": int(use["out-axons"][1]),
                    "synapse_bits": int(use["synapses"][1]),
                },
            }
        )
    inputs = [
        {"input": spike_input.label, "axons": int(sum(a.axon_slots() for a in spike_input.axons))}
        for spike_input in sim.model.inputs
    ]
    allowed = max_chips if max_chips is not None else max(1, len(blocks))
    allocator = Greedy() if cores_per_chip is None else Greedy(cores_per_chip=cores_per_chip)
    try:  # NengoLoihi's allocator
        chips: int | None = int(allocator(sim.model, n_chips=allowed).n_chips)
    except AssertionError:
        chips = None
    return {"cores": len(blocks), "chips": chips, "blocks": blocks, "inputs": inputs}
