"""Connection processes and process models the Lava backends run instead of Lava's slow ones.

- :class:`DelayConv` is Lava's ``Conv`` with an axonal delay: a spike received at
  step ``t`` reaches the postsynaptic neuron at ``t + 1 + delays`` (``delays = 0`` is
  ``Conv``'s own timing, ``DelayDense``'s with ``delays = 0``). Its models compute the
  convolution exactly in numpy (float64, or integers for ``fixed_pt``, where Lava's
  ``Conv`` models go through float32) and, in fixed point, apply the weight exponent
  exactly as Lava's bit-accurate ``DelayDense``/``DelaySparse`` do (the sum of 8-bit
  mantissas shifted by ``weight_exp``, no further clamping), so a convolution gives
  the same spikes as the ``DelaySparse`` holding its expanded connections.
- The ``DelayDense`` and ``DelaySparse`` models of Lava 0.10 rebuild their
  delay-stacked weight matrix at every step (for a sparse matrix this is seconds per
  step on LoCS-Net's layers). The models here compute the same sums from matrices
  split by delay once (weights are static: nothing here learns); fixed-point results
  are identical bit for bit, floating-point ones up to the order of summation.

The backend runs these models with a reset request added (:mod:`.resets`).
Importing this module imports Lava, through :func:`.compat.import_lava` (the
Python 3.11 fix).
"""

from __future__ import annotations

from typing import Any

import numpy as np
import scipy.sparse

from .compat import import_lava

import_lava()

from lava.magma.core.decorator import implements, requires, tag  # noqa: E402 - after the fix above
from lava.magma.core.model.py.ports import PyInPort, PyOutPort  # noqa: E402
from lava.magma.core.model.py.type import LavaPyType  # noqa: E402
from lava.magma.core.process.variable import Var  # noqa: E402
from lava.magma.core.resources import CPU  # noqa: E402
from lava.magma.core.sync.protocols.loihi_protocol import LoihiProtocol  # noqa: E402
from lava.proc.conv.models import AbstractPyConvModel  # noqa: E402
from lava.proc.conv.process import Conv  # noqa: E402
from lava.proc.dense.models import PyDelayDenseModelBitAcc, PyDelayDenseModelFloat  # noqa: E402
from lava.proc.sparse.models import PyDelaySparseModelBitAcc, PyDelaySparseModelFloat  # noqa: E402
from lava.utils.weightutils import SignMode, clip_weights, determine_sign_mode, truncate_weights  # noqa: E402

__all__ = [
    "DelayConv",
    "PyDelayConvModelFloat",
    "PyDelayConvModelFixed",
    "PyDelayDenseModelFloatCached",
    "PyDelayDenseModelFixedCached",
    "PyDelaySparseModelFloatCached",
    "PyDelaySparseModelFixedCached",
]


class DelayConv(Conv):
    """Lava's ``Conv`` process whose output reaches its target ``delays`` steps later.

    Parameters
    ----------
    delays
        Extra steps (``>= 0``): a spike received at step ``t`` acts on the target at
        ``t + 1 + delays``; ``0`` is ``Conv``'s timing.
    sign_mode
        Loihi's sign mode of the (fixed-point) kernel; ``None`` derives it from the kernel.
    **conv
        ``Conv``'s arguments (``weight`` in Lava's ``(C_out, W, H, C_in)`` layout,
        ``input_shape`` as ``(W, H, C)``, ``padding``, ``stride``, ``weight_exp``, ``name``);
        dilation and groups stay 1.
    """

    def __init__(self, *, delays: int, sign_mode: SignMode | None = None, **conv: Any) -> None:
        if isinstance(delays, bool) or not isinstance(delays, (int, np.integer)) or delays < 0:
            raise ValueError(f"DelayConv: delays must be an integer >= 0, got {delays!r}.")
        for name in ("dilation", "groups"):
            if np.any(np.asarray(conv.get(name, 1)) != 1):
                raise ValueError(f"DelayConv: {name} must be 1, got {conv[name]!r}.")
        super().__init__(**conv)
        self.proc_params["sign_mode"] = sign_mode
        self.a_ring = Var(shape=(*self.output_shape, int(delays) + 1), init=0)


def _correlate(spikes: np.ndarray, kernel: np.ndarray, stride: tuple[int, int], padding: tuple[int, int]) -> np.ndarray:
    """``spikes`` (W, H, C) correlated with ``kernel`` (C_out, KW, KH, C): the ``(W', H', C_out)`` input."""
    (sw, sh), (pw, ph) = stride, padding
    if pw or ph:
        spikes = np.pad(spikes, ((pw, pw), (ph, ph), (0, 0)))
    windows = np.lib.stride_tricks.sliding_window_view(spikes, kernel.shape[1:3], axis=(0, 1))[::sw, ::sh]
    return np.tensordot(windows, kernel, axes=([2, 3, 4], [3, 1, 2]))


class _AbstractDelayConvModel(AbstractPyConvModel):
    """One step: send the oldest slot of the ring, shift it, add this step's convolution to the newest."""

    a_ring: np.ndarray = None
    _kernel: np.ndarray | None = None

    def _prepare_kernel(self) -> np.ndarray:
        raise NotImplementedError

    def _scale(self, act: np.ndarray) -> np.ndarray:
        return act

    def run_spk(self) -> None:
        """Send the input due now, receive spikes, queue their input ``delays`` steps ahead."""
        if self._kernel is None:
            self._kernel = self._prepare_kernel()[:, ::-1, ::-1, :]  # Lava convolves: flip to correlate
        self.a_out.send(self.a_ring[..., 0])
        if self.num_message_bits.item() > 0:
            s_in = self.s_in.recv()
        else:
            s_in = self.s_in.recv().astype(bool)
        act = _correlate(s_in.astype(self._kernel.dtype), self._kernel, tuple(self.stride), tuple(self.padding))
        self.a_ring[..., 0] = 0
        self.a_ring = np.roll(self.a_ring, -1, axis=-1)
        self.a_ring[..., -1] += self._scale(act)


@implements(proc=DelayConv, protocol=LoihiProtocol)
@requires(CPU)
@tag("floating_pt")
class PyDelayConvModelFloat(_AbstractDelayConvModel):
    """``DelayConv`` in float64."""

    s_in: PyInPort = LavaPyType(PyInPort.VEC_DENSE, float, precision=24)
    a_out: PyOutPort = LavaPyType(PyOutPort.VEC_DENSE, float)
    a_buf: np.ndarray = LavaPyType(np.ndarray, float)
    a_ring: np.ndarray = LavaPyType(np.ndarray, float)
    weight: np.ndarray = LavaPyType(np.ndarray, float)

    def _prepare_kernel(self) -> np.ndarray:
        return np.asarray(self.weight, dtype=np.float64)


@implements(proc=DelayConv, protocol=LoihiProtocol)
@requires(CPU)
@tag("fixed_pt")
class PyDelayConvModelFixed(_AbstractDelayConvModel):
    """``DelayConv`` with Loihi's 8-bit weights and shared exponent, in integers (as bit-accurate ``DelayDense``)."""

    s_in: PyInPort = LavaPyType(PyInPort.VEC_DENSE, np.int32, precision=24)
    a_out: PyOutPort = LavaPyType(PyOutPort.VEC_DENSE, np.int32, precision=24)
    a_buf: np.ndarray = LavaPyType(np.ndarray, np.int32, precision=24)
    a_ring: np.ndarray = LavaPyType(np.ndarray, np.int32, precision=24)
    weight: np.ndarray = LavaPyType(np.ndarray, np.int32, precision=8)

    def _prepare_kernel(self) -> np.ndarray:
        weight = np.asarray(self.weight)
        sign_mode = self.proc_params.get("sign_mode") or determine_sign_mode(weight)
        weight = clip_weights(weight, sign_mode, num_bits=8)
        weight = truncate_weights(weight, sign_mode, int(self.num_weight_bits.item()))
        return weight.astype(np.int64)

    def _scale(self, act: np.ndarray) -> np.ndarray:
        exp = int(self.weight_exp.item())
        return np.left_shift(act, exp) if exp > 0 else np.right_shift(act, -exp)


class _CachedDelays:
    """``calc_act`` from the weight matrix split by delay once, instead of at every step."""

    weights: Any
    delays: Any
    a_buff: np.ndarray
    _split: list[tuple[int, Any]] | None = None
    _split_of: Any = None

    def _split_by_delay(self) -> list[tuple[int, Any]]:
        raise NotImplementedError

    def calc_act(self, s_in: np.ndarray) -> np.ndarray:
        """The input of ``s_in`` per target (rows) and delay (columns), as Lava's ``calc_act``."""
        if self._split is None or self._split_of is not self.weights:
            self._split, self._split_of = self._split_by_delay(), self.weights
        out = None
        for k, matrix in self._split:
            act = self._act(matrix, s_in)
            if out is None:
                out = np.zeros((act.shape[0], self.a_buff.shape[-1]), dtype=act.dtype)
            out[:, k] = act
        if out is None:
            out = np.zeros(self.a_buff.shape, dtype=self.a_buff.dtype)
        return out

    @staticmethod
    def _act(matrix: Any, s_in: np.ndarray) -> np.ndarray:
        raise NotImplementedError


class _DenseSplit(_CachedDelays):
    def _split_by_delay(self) -> list[tuple[int, Any]]:
        weights, delays = np.asarray(self.weights), np.asarray(self.delays)
        return [(int(k), np.where(delays == k, weights, 0)) for k in np.unique(delays)]

    @staticmethod
    def _act(matrix: Any, s_in: np.ndarray) -> np.ndarray:
        if s_in.dtype == bool:
            return matrix[:, s_in].sum(axis=1)
        return matrix @ s_in


class _SparseSplit(_CachedDelays):
    def _split_by_delay(self) -> list[tuple[int, Any]]:
        weights = scipy.sparse.coo_matrix(self.weights)
        delays = self.delays
        if scipy.sparse.issparse(delays):
            k_of = np.asarray(scipy.sparse.csr_matrix(delays)[weights.row, weights.col]).ravel().astype(np.int64)
        else:
            k_of = np.broadcast_to(np.asarray(delays, dtype=np.int64), weights.shape)[weights.row, weights.col]
        split = []
        for k in np.unique(k_of):
            sel = k_of == k
            part = scipy.sparse.csr_matrix((weights.data[sel], (weights.row[sel], weights.col[sel])), shape=weights.shape)
            split.append((int(k), part))
        return split

    @staticmethod
    def _act(matrix: Any, s_in: np.ndarray) -> np.ndarray:
        return matrix.dot(s_in)


class PyDelayDenseModelFloatCached(_DenseSplit, PyDelayDenseModelFloat):
    """Lava's float ``DelayDense`` model with its weights split by delay once."""


class PyDelayDenseModelFixedCached(_DenseSplit, PyDelayDenseModelBitAcc):
    """Lava's bit-accurate ``DelayDense`` model with its weights split by delay once."""


class PyDelaySparseModelFloatCached(_SparseSplit, PyDelaySparseModelFloat):
    """Lava's float ``DelaySparse`` model with its weights split by delay once."""


class PyDelaySparseModelFixedCached(_SparseSplit, PyDelaySparseModelBitAcc):
    """Lava's bit-accurate ``DelaySparse`` model with its weights split by delay once."""
