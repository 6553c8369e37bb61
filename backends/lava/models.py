"""A fixed-point process model for Lava's ``LIFRefractory``, which Lava 0.10 ships in floating point only.

It combines Lava's own bit-accurate LIF arithmetic (``AbstractPyLifModelFixed``:
12-bit decays, 24-bit ``u`` and ``v``, ``vth << 6``, bias mantissa and exponent) with
the refractory rule of Lava's float ``PyLifRefractoryModelFloat``: after a spike at
step ``t`` the voltage stays at 0 for ``refractory_period`` steps while the current
``u`` keeps integrating. The backend runs it with a reset request added
(:mod:`.resets`).

Importing it imports Lava, through :func:`.compat.import_lava` (the Python 3.11 fix).
"""

from __future__ import annotations

import numpy as np

from .compat import import_lava

import_lava()

from lava.magma.core.decorator import implements, requires, tag  # noqa: E402 - after the fix above
from lava.magma.core.model.py.ports import PyOutPort  # noqa: E402
from lava.magma.core.model.py.type import LavaPyType  # noqa: E402
from lava.magma.core.resources import CPU  # noqa: E402
from lava.magma.core.sync.protocols.loihi_protocol import LoihiProtocol  # noqa: E402
from lava.proc.lif.models import AbstractPyLifModelFixed  # noqa: E402
from lava.proc.lif.process import LIFRefractory  # noqa: E402

__all__ = ["PyLifRefractoryModelFixed"]


@implements(proc=LIFRefractory, protocol=LoihiProtocol)
@requires(CPU)
@tag("fixed_pt")
class PyLifRefractoryModelFixed(AbstractPyLifModelFixed):
    """Bit-accurate LIF dynamics with a refractory period, in Loihi's fixed-point formats."""

    s_out: PyOutPort = LavaPyType(PyOutPort.VEC_DENSE, np.int32, precision=24)
    vth: int = LavaPyType(int, np.int32, precision=17)
    refractory_period_end: np.ndarray = LavaPyType(np.ndarray, int)

    def __init__(self, proc_params: dict) -> None:
        super().__init__(proc_params)
        self.effective_vth = 0
        self.refractory_period = proc_params["refractory_period"]

    def scale_threshold(self) -> None:
        """Loihi left-shifts the threshold by 6 bits to align it with ``v``."""
        self.effective_vth = np.left_shift(self.vth, self.vth_shift)
        self.isthrscaled = True

    def spiking_activation(self) -> np.ndarray:
        """Spike where the voltage exceeds the threshold."""
        return self.v > self.effective_vth

    def subthr_dynamics(self, activation_in: np.ndarray) -> None:
        """Lava's fixed-point update, with the voltage frozen while refractory."""
        refractory = self.refractory_period_end >= self.time_step
        held = self.v[refractory].copy()
        super().subthr_dynamics(activation_in)
        self.v[refractory] = held

    def run_spk(self) -> None:
        """One step: receive input, integrate, spike, reset and start refractoriness."""
        a_in_data = self.a_in.recv()
        self.scale_bias()
        if not self.isthrscaled:
            self.scale_threshold()
        self.subthr_dynamics(activation_in=a_in_data)
        spikes = self.spiking_activation()
        self.refractory_period_end[spikes] = self.time_step + self.refractory_period
        self.reset_voltage(spike_vector=spikes)
        self.s_out.send(spikes)
