"""Lava processes that return to their initial state on one message.

Lava sets a ``Var`` of a running network one element per message, so putting
LoCS-Net's membranes, currents and synaptic buffers back to their initial values
through ``Var.set`` takes tens of thousands of messages per query (most of a
query's time). Each process here is a Lava process with one more ``Var``,
``reset_request`` (one element): setting it to 1 makes the process model restore
its state variables, copied before its first step, at the start of its next step,
before it sends or computes anything; so the next run starts exactly as after
setting those variables.

The models are Lava's own (and the backend's in :mod:`.connections` and
:mod:`.models`) with that one addition; the backend selects them through the run
configuration's ``exception_proc_model_map``. Importing this module imports Lava,
through :func:`.compat.import_lava` (the Python 3.11 fix).
"""

from __future__ import annotations

from typing import Any

import numpy as np

from .compat import import_lava

import_lava()

from lava.magma.core.model.py.model import PyLoihiProcessModel  # noqa: E402 - after the fix above
from lava.magma.core.model.py.type import LavaPyType  # noqa: E402
from lava.magma.core.process.variable import Var  # noqa: E402
from lava.proc.dense.models import PyDenseModelBitAcc, PyDenseModelFloat  # noqa: E402
from lava.proc.dense.process import DelayDense, Dense  # noqa: E402
from lava.proc.lif.models import PyLifModelBitAcc, PyLifModelFloat, PyLifRefractoryModelFloat  # noqa: E402
from lava.proc.lif.process import LIF, LIFRefractory  # noqa: E402
from lava.proc.sparse.models import PySparseModelBitAcc, PySparseModelFloat  # noqa: E402
from lava.proc.sparse.process import DelaySparse, Sparse  # noqa: E402

from . import connections  # noqa: E402
from .models import PyLifRefractoryModelFixed  # noqa: E402

__all__ = [
    "ResettableLIF",
    "ResettableLIFRefractory",
    "ResettableDense",
    "ResettableSparse",
    "ResettableDelayDense",
    "ResettableDelaySparse",
    "ResettableDelayConv",
    "model_map",
]


def _add_request(process: Any) -> None:
    process.reset_request = Var(shape=(1,), init=0)


class ResettableLIF(LIF):
    """Lava's ``LIF`` with a ``reset_request``."""

    kind = "LIF"

    def __init__(self, **kwargs: Any) -> None:
        super().__init__(**kwargs)
        _add_request(self)


class ResettableLIFRefractory(LIFRefractory):
    """Lava's ``LIFRefractory`` with a ``reset_request``."""

    kind = "LIFRefractory"

    def __init__(self, **kwargs: Any) -> None:
        super().__init__(**kwargs)
        _add_request(self)


class ResettableDense(Dense):
    """Lava's ``Dense`` with a ``reset_request``."""

    kind = "Dense"

    def __init__(self, **kwargs: Any) -> None:
        super().__init__(**kwargs)
        _add_request(self)


class ResettableSparse(Sparse):
    """Lava's ``Sparse`` with a ``reset_request``."""

    kind = "Sparse"

    def __init__(self, **kwargs: Any) -> None:
        super().__init__(**kwargs)
        _add_request(self)


class ResettableDelayDense(DelayDense):
    """Lava's ``DelayDense`` with a ``reset_request``."""

    kind = "DelayDense"

    def __init__(self, **kwargs: Any) -> None:
        super().__init__(**kwargs)
        _add_request(self)


class ResettableDelaySparse(DelaySparse):
    """Lava's ``DelaySparse`` with a ``reset_request``."""

    kind = "DelaySparse"

    def __init__(self, **kwargs: Any) -> None:
        super().__init__(**kwargs)
        _add_request(self)


class ResettableDelayConv(connections.DelayConv):
    """:class:`~.connections.DelayConv` (Lava's ``Conv`` with a delay) with a ``reset_request``."""

    kind = "Conv"

    def __init__(self, **kwargs: Any) -> None:
        super().__init__(**kwargs)
        _add_request(self)


class _ResetOnRequest:
    """Model mixin: restore the state variables ``_state`` when ``reset_request`` is set."""

    reset_request: np.ndarray = LavaPyType(np.ndarray, np.int32, precision=1)
    _state: tuple[str, ...] = ()
    _initial: dict[str, np.ndarray] | None = None

    def run_spk(self) -> None:
        """Restore the initial state if asked to, then Lava's step."""
        if self._initial is None:
            self._initial = {name: np.array(getattr(self, name), copy=True) for name in self._state}
        if self.reset_request[0]:
            for name, value in self._initial.items():
                setattr(self, name, value.copy())
            self.reset_request[0] = 0
        super().run_spk()  # type: ignore[misc]


_NEURON = ("u", "v")
_REFRACTORY = ("u", "v", "refractory_period_end")
_SYNAPSE = ("a_buff",)


class PyLifModelFloatReset(_ResetOnRequest, PyLifModelFloat):
    """Lava's float LIF model, resettable."""

    _state = _NEURON


class PyLifModelFixedReset(_ResetOnRequest, PyLifModelBitAcc):
    """Lava's bit-accurate LIF model, resettable."""

    _state = _NEURON


class PyLifRefractoryModelFloatReset(_ResetOnRequest, PyLifRefractoryModelFloat):
    """Lava's float LIFRefractory model, resettable."""

    _state = _REFRACTORY


class PyLifRefractoryModelFixedReset(_ResetOnRequest, PyLifRefractoryModelFixed):
    """The backend's fixed-point LIFRefractory model, resettable."""

    _state = _REFRACTORY


class PyDenseModelFloatReset(_ResetOnRequest, PyDenseModelFloat):
    """Lava's float Dense model, resettable."""

    _state = _SYNAPSE


class PyDenseModelFixedReset(_ResetOnRequest, PyDenseModelBitAcc):
    """Lava's bit-accurate Dense model, resettable."""

    _state = _SYNAPSE


class PySparseModelFloatReset(_ResetOnRequest, PySparseModelFloat):
    """Lava's float Sparse model, resettable."""

    _state = _SYNAPSE


class PySparseModelFixedReset(_ResetOnRequest, PySparseModelBitAcc):
    """Lava's bit-accurate Sparse model, resettable."""

    _state = _SYNAPSE


class PyDelayDenseModelFloatReset(_ResetOnRequest, connections.PyDelayDenseModelFloatCached):
    """Float DelayDense (weights split by delay once), resettable."""

    _state = _SYNAPSE


class PyDelayDenseModelFixedReset(_ResetOnRequest, connections.PyDelayDenseModelFixedCached):
    """Bit-accurate DelayDense (weights split by delay once), resettable."""

    _state = _SYNAPSE


class PyDelaySparseModelFloatReset(_ResetOnRequest, connections.PyDelaySparseModelFloatCached):
    """Float DelaySparse (weights split by delay once), resettable."""

    _state = _SYNAPSE


class PyDelaySparseModelFixedReset(_ResetOnRequest, connections.PyDelaySparseModelFixedCached):
    """Bit-accurate DelaySparse (weights split by delay once), resettable."""

    _state = _SYNAPSE


class PyDelayConvModelFloatReset(_ResetOnRequest, connections.PyDelayConvModelFloat):
    """Float DelayConv, resettable."""

    _state = ("a_ring",)


class PyDelayConvModelFixedReset(_ResetOnRequest, connections.PyDelayConvModelFixed):
    """Fixed-point DelayConv, resettable."""

    _state = ("a_ring",)


_FLOAT: dict[type, type[PyLoihiProcessModel]] = {
    ResettableLIF: PyLifModelFloatReset,
    ResettableLIFRefractory: PyLifRefractoryModelFloatReset,
    ResettableDense: PyDenseModelFloatReset,
    ResettableSparse: PySparseModelFloatReset,
    ResettableDelayDense: PyDelayDenseModelFloatReset,
    ResettableDelaySparse: PyDelaySparseModelFloatReset,
    ResettableDelayConv: PyDelayConvModelFloatReset,
}
_FIXED: dict[type, type[PyLoihiProcessModel]] = {
    ResettableLIF: PyLifModelFixedReset,
    ResettableLIFRefractory: PyLifRefractoryModelFixedReset,
    ResettableDense: PyDenseModelFixedReset,
    ResettableSparse: PySparseModelFixedReset,
    ResettableDelayDense: PyDelayDenseModelFixedReset,
    ResettableDelaySparse: PyDelaySparseModelFixedReset,
    ResettableDelayConv: PyDelayConvModelFixedReset,
}


def model_map(fixed: bool) -> dict[type, type[PyLoihiProcessModel]]:
    """The process model of each resettable process class, ``fixed_pt`` or ``floating_pt``."""
    return dict(_FIXED if fixed else _FLOAT)
