"""The vendors' emulators as oracles of the reference backend's chip formats.

* ``kapoho-bay`` against NengoLoihi's emulator (``nengo_loihi.Simulator(target="sim")``,
  through the ``nengo-loihi`` backend): :func:`nengo_integer_difference` compares the
  integers of every core block (threshold, bias, decays, refractory delay, weights).
* ``loihi2`` against Lava's ``fixed_pt`` process models (``LIF``/``LIFRefractory``,
  ``Dense``/``Sparse`` and their delayed versions, through the ``lava-fixed`` backend,
  which maps the network with its own code): :func:`lava_integer_difference` compares
  each population's integers and each synapse process's 8-bit weights and exponent.

Both return ``None`` when everything agrees, else one line naming the first difference.
"""

from __future__ import annotations

import warnings

import numpy as np
import pytest
import scipy.sparse

import neurovpr as nv

__all__ = ["ORACLES", "oracle_backend", "run_both", "nengo_integer_difference", "lava_integer_difference"]

#: Per oracle: the emulated hwspec, the backend holding the vendor's emulator, the integer check.
ORACLES = {
    "nengo-loihi": ("kapoho-bay", "nengo-loihi"),
    "lava": ("loihi2", "lava-fixed"),
}


def oracle_backend(name: str):
    """The oracle backend, or a skip naming what is missing."""
    module = {"nengo-loihi": "nengo_loihi", "lava-fixed": "lava"}[name]
    pytest.importorskip(module)
    from neurovpr.runtime.registry import get_backend

    try:
        return get_backend(name)
    except nv.NeurovprError as exc:
        pytest.skip(f"backend {name!r} is not available: {exc}")


def run_both(network: nv.Network, oracle: str, duration: float, *, seed: int = 3):
    """``(reference in the chip's formats, the oracle backend)``, both compiled and run for ``duration`` ms."""
    hardware, backend = ORACLES[oracle]
    theirs_backend = oracle_backend(backend)
    mine = nv.compile(network, backend="reference", dt=1.0, seed=seed, hardware=hardware)
    mine.run(duration)
    with warnings.catch_warnings():
        warnings.simplefilter("ignore")  # NengoLoihi warns about the nengo version
        theirs = theirs_backend.compile(network, dt=1.0, seed=seed, hardware=None)
        theirs.run(duration)
    return mine, theirs


def _nengo_blocks(sim, population: str) -> list:
    """NengoLoihi's discretised blocks of ``population`` (the emulator's model)."""
    model = sim._sim.model  # the nengo_loihi.Simulator the backend runs
    return [b for b in model.blocks if f"'{population}'" in str(b.label)]


def nengo_integer_difference(mine, theirs, populations) -> str | None:
    """The first integer of a core block that differs between the emulation and NengoLoihi, or ``None``."""
    q, lay = mine.quantised, mine._lay
    for name in populations:
        blocks = [b for b in q.blocks if b["population"] == name]
        nengo = _nengo_blocks(theirs, name)
        if len(blocks) != len(nengo):
            return f"{name}: {len(blocks)} core blocks here, {len(nengo)} in NengoLoihi"
        for b, nb in zip(blocks, nengo, strict=True):
            c = nb.compartment
            for key, value in (("vth", c.vth), ("bias", c.bias), ("du", c.decay_u), ("dv", c.decay_v),
                               ("ref", c.refract_delay)):  # fmt: skip
                if not np.array_equal(b[key], value):
                    return f"{name} neurons {b['lo']}..{b['hi'] - 1}: {key} {b[key]} here, {value} in NengoLoihi"
            lo, hi = lay.offsets[name][0] + b["lo"], lay.offsets[name][0] + b["hi"]
            ours = np.sort(q.s_val[(lay.s_post >= lo) & (lay.s_post < hi)])
            them = np.sort(np.concatenate([np.zeros(0)] + [w.ravel() for s in nb.synapses for w in s.weights]))
            if any(s.pop_type for s in nb.synapses):  # shared (convolutional) weights: each kernel value once
                ours, them = np.unique(ours), np.unique(them)
            if not np.array_equal(ours[ours != 0], them[them != 0]):
                return f"{name} neurons {b['lo']}..{b['hi'] - 1}: the synaptic weights differ from NengoLoihi's"
    return None


def _lava_matrices(theirs, projection: str) -> dict[int, tuple[scipy.sparse.csr_matrix, int]]:
    """Per Lava delay (``delays``; 0 for ``Dense``/``Sparse``), the process's integer weights and exponent."""
    out = {}
    for process in theirs._built.synapses[projection]:
        delays = getattr(process, "delays", None)
        k = 0 if delays is None else int(np.max(delays.init.data if scipy.sparse.issparse(delays.init) else delays.init))
        out[k] = (scipy.sparse.csr_matrix(process.weights.init), int(process.proc_params.get("weight_exp", 0)))
    return out


def lava_integer_difference(mine, theirs) -> str | None:
    """The first integer that differs between the emulation and the Lava processes, or ``None``."""
    q, lay, net = mine.quantised, mine._lay, mine.network
    for b in q.blocks:
        name = b["population"]
        lif, proc = theirs._built.params[name], theirs._built.lifs[name]  # the integers the Lava process was given
        pairs = (("vth_man", proc.vth.init), ("bias_man", proc.bias_mant.init), ("bias_exp", proc.bias_exp.init),
                 ("du", proc.du.init), ("dv", proc.dv.init), ("ref", lif.refractory_steps + 1))  # fmt: skip
        for key, value in pairs:
            if not np.array_equal(b[key], np.broadcast_to(value, np.shape(b[key]))):
                return f"{name}: {key} {np.unique(b[key])} here, {np.unique(value)} in Lava"
    for pname, proj in net.projections.items():
        pos = lay.proj_static[pname]
        from_source = net.populations[proj.pre].is_source
        matrices = _lava_matrices(theirs, pname)
        value, exponent = q.weights[pname]["value"], q.weights[pname]["exponent"]
        for d in np.unique(lay.s_delay[pos]):
            k = int(d) - 1 if from_source else int(d)
            sel = lay.s_delay[pos] == d
            if k not in matrices:
                return f"{pname}: no Lava process for its {d}-step delay"
            post, pre = lay.proj_post[pname][sel], lay.proj_pre[pname][sel]
            ours = scipy.sparse.coo_matrix((value[sel], (post, pre)), shape=matrices[k][0].shape).tocsr()
            if int(exponent[sel][0]) != matrices[k][1]:
                return f"{pname} (delay {d} steps): weight exponent {exponent[sel][0]} here, {matrices[k][1]} in Lava"
            if (ours != matrices[k][0]).nnz:
                return f"{pname} (delay {d} steps): the 8-bit weights differ from Lava's"
    return None
