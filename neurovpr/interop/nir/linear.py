"""NIR's linear nodes (Affine, Linear, Conv2d, pooling, Scale, Flatten, Delay) as maps.

Between two neuron nodes of a NIR graph lies a chain of linear nodes. Each node here
becomes an :class:`Op` with its input and output shapes, a sparse matrix on the
C-order flattened signal and a bias; a chain becomes one projection, with the
connector that keeps the NIR arrays bit for bit where one node does the work.
"""

from __future__ import annotations

from dataclasses import dataclass, field
from typing import Any

import numpy as np
import scipy.sparse as sp

from neurovpr.errors import ValidationError
from neurovpr.resources import require_memory

__all__ = ["Op", "op_from_node", "compose"]

#: Node types with no weights: they reshape, delay or pass the signal through.
IDENTITY_KINDS = ("Flatten", "pass", "Delay")


@dataclass(frozen=True, slots=True)
class Op:
    """One linear NIR node applied to a signal of ``in_shape``."""

    name: str
    kind: str
    in_shape: tuple[int, ...]
    out_shape: tuple[int, ...]
    node: Any = None
    #: Delay in seconds per element (``Delay`` nodes only).
    delay: np.ndarray | None = None
    #: ``(top, bottom, left, right)`` padding of a convolution or pooling.
    pads: tuple[int, int, int, int] = (0, 0, 0, 0)
    extra: dict[str, Any] = field(default_factory=dict)

    @property
    def n_in(self) -> int:
        return int(np.prod(self.in_shape))

    @property
    def n_out(self) -> int:
        return int(np.prod(self.out_shape))

    def matrix(self) -> sp.csr_matrix:
        """The ``(n_out, n_in)`` sparse matrix of the map."""
        if self.kind in IDENTITY_KINDS:
            return sp.identity(self.n_in, format="csr", dtype=np.float64)
        if self.kind in ("Affine", "Linear"):
            return sp.csr_matrix(np.asarray(self.node.weight, dtype=np.float64))
        if self.kind == "Scale":
            return sp.diags(self.extra["scale"], format="csr")
        rows, cols, vals = _window_entries(self)
        return sp.csr_matrix((vals, (rows, cols)), shape=(self.n_out, self.n_in))

    def bias(self) -> np.ndarray:
        """The ``n_out`` constant output of the map for zero input."""
        if self.kind == "Affine":
            return np.asarray(self.node.bias, dtype=np.float64).reshape(-1)
        if self.kind == "Conv2d":
            b = np.broadcast_to(np.asarray(self.node.bias, dtype=np.float64).reshape(-1), (self.out_shape[0],))
            return np.repeat(b, self.n_out // self.out_shape[0])
        return np.zeros(self.n_out)

    @property
    def convolution_ready(self) -> bool:
        """True when a ConvolutionConnector holds this Conv2d node exactly."""
        top, bottom, left, right = self.pads
        return (
            self.kind == "Conv2d"
            and self.extra["groups"] == 1
            and self.extra["dilation"] == (1, 1)
            and top == bottom
            and left == right
        )


def _pair(value: Any, where: str, what: str, *, low: int) -> tuple[int, int]:
    try:
        arr = np.asarray(value, dtype=np.float64).reshape(-1)
    except (TypeError, ValueError):
        raise ValidationError(f"{where}: {what} must be one or two integers >= {low}, got {value!r}.") from None
    if arr.size == 1:
        arr = np.repeat(arr, 2)
    if arr.size != 2 or not np.all(np.isfinite(arr)) or np.any(arr != np.round(arr)) or np.any(arr < low) or np.any(arr > 2**31):
        raise ValidationError(f"{where}: {what} must be one or two integers >= {low}, got {value!r}.")
    return int(arr[0]), int(arr[1])


def _conv_shape(where: str, in_shape: tuple[int, ...]) -> tuple[int, int, int]:
    if len(in_shape) == 4 and in_shape[0] == 1:  # a batch dimension some exporters keep
        in_shape = in_shape[1:]
    if len(in_shape) != 3:
        raise ValidationError(f"{where} needs a (channels, height, width) input, got shape {in_shape}.")
    return in_shape  # type: ignore[return-value]


def _window_op(name: str, kind: str, node: Any, in_shape: tuple[int, ...]) -> Op:
    where = f"NIR node {name!r} ({kind})"
    c_in, h, w = _conv_shape(where, in_shape)
    if kind == "Conv2d":
        weight = np.asarray(node.weight, dtype=np.float64)
        if weight.ndim != 4:
            raise ValidationError(f"{where}: weight must be 4-D (out, in/groups, kh, kw), got shape {weight.shape}.")
        groups = int(np.asarray(node.groups).reshape(-1)[0])
        c_out, c_group, kh, kw = weight.shape
        if groups < 1 or c_in != c_group * groups or c_out % groups:
            raise ValidationError(f"{where}: {c_in} input channels do not match weight {weight.shape} with groups={groups}.")
        stride = _pair(node.stride, where, "stride", low=1)
        dilation = _pair(node.dilation, where, "dilation", low=1)
        padding = node.padding
        if isinstance(padding, bytes):
            padding = padding.decode()
        if isinstance(padding, str) or (isinstance(padding, np.ndarray) and padding.dtype.kind in "SUO"):
            mode = str(np.asarray(padding).reshape(-1)[0] if isinstance(padding, np.ndarray) else padding)
            if isinstance(mode, bytes):
                mode = mode.decode()
            if mode == "valid":
                pads = (0, 0, 0, 0)
            elif mode == "same":
                th, tw = dilation[0] * (kh - 1), dilation[1] * (kw - 1)
                pads = (th // 2, th - th // 2, tw // 2, tw - tw // 2)
            else:
                raise ValidationError(f"{where}: padding must be 'same', 'valid' or integers, got {mode!r}.")
        else:
            ph, pw = _pair(padding, where, "padding", low=0)
            pads = (ph, ph, pw, pw)
        bias = np.asarray(node.bias, dtype=np.float64).reshape(-1)
        if bias.size not in (1, c_out):
            raise ValidationError(f"{where}: bias has {bias.size} values for {c_out} output channels.")
        extra = {"groups": groups, "dilation": dilation, "stride": stride, "kernel": (kh, kw), "weight": weight}
    else:
        kh, kw = _pair(node.kernel_size, where, "kernel_size", low=1)
        stride = _pair(node.stride, where, "stride", low=1)
        ph, pw = _pair(node.padding, where, "padding", low=0)
        pads, c_out, dilation = (ph, ph, pw, pw), c_in, (1, 1)
        extra = {"groups": c_in, "dilation": dilation, "stride": stride, "kernel": (kh, kw)}
    oh = (h + pads[0] + pads[1] - dilation[0] * (kh - 1) - 1) // stride[0] + 1
    ow = (w + pads[2] + pads[3] - dilation[1] * (kw - 1) - 1) // stride[1] + 1
    if oh < 1 or ow < 1 or min(stride) < 1 or min(dilation) < 1 or min(pads) < 0:
        raise ValidationError(f"{where}: kernel {(kh, kw)}, stride {stride} and padding do not fit the input {(h, w)}.")
    declared = getattr(node, "input_shape", None)
    if kind == "Conv2d" and declared is not None and tuple(int(v) for v in np.asarray(declared).reshape(-1)) != (h, w):
        raise ValidationError(f"{where} declares input_shape {tuple(np.asarray(declared).reshape(-1))}, but receives {(h, w)}.")
    return Op(name, kind, (c_in, h, w), (c_out, oh, ow), node, pads=pads, extra=extra)


def _window_entries(op: Op) -> tuple[np.ndarray, np.ndarray, np.ndarray]:
    """Row (output), column (input) and value of every connection of a conv or pooling op."""
    c_in, h, w = op.in_shape
    c_out, oh, ow = op.out_shape
    kh, kw = op.extra["kernel"]
    (sh, sw), (dh, dw) = op.extra["stride"], op.extra["dilation"]
    top, left = op.pads[0], op.pads[2]
    per_out_entry = (c_in // op.extra["groups"] if op.kind == "Conv2d" else 1) * kh * kw
    entries = float(c_out) * per_out_entry * oh * ow
    require_memory(entries * 64, f"NIR node {op.name!r} ({op.kind}): {entries:.3g} connections")
    if op.kind == "Conv2d":
        groups = op.extra["groups"]
        per_in, per_out = c_in // groups, c_out // groups
        o, c, ky, kx, y, x = np.meshgrid(
            np.arange(c_out), np.arange(per_in), np.arange(kh), np.arange(kw), np.arange(oh), np.arange(ow), indexing="ij"
        )
        c_abs = (o // per_out) * per_in + c
        vals = op.extra["weight"][o, c, ky, kx]
    else:
        o, ky, kx, y, x = np.meshgrid(np.arange(c_out), np.arange(kh), np.arange(kw), np.arange(oh), np.arange(ow), indexing="ij")
        c_abs = o
        vals = np.full(o.shape, 1.0 if op.kind == "SumPool2d" else 1.0 / (kh * kw))
    iy = y * sh - top + ky * dh
    ix = x * sw - left + kx * dw
    ok = (iy >= 0) & (iy < h) & (ix >= 0) & (ix < w)
    rows = (o * oh * ow + y * ow + x)[ok]
    cols = (c_abs * h * w + iy * w + ix)[ok]
    return rows.astype(np.int64), cols.astype(np.int64), vals[ok].astype(np.float64)


def _flatten_shape(where: str, node: Any, in_shape: tuple[int, ...]) -> tuple[int, ...]:
    nd = len(in_shape)
    start = int(np.asarray(getattr(node, "start_dim", 0)).reshape(-1)[0])
    end = int(np.asarray(getattr(node, "end_dim", -1)).reshape(-1)[0])
    start, end = start + nd if start < 0 else start, end + nd if end < 0 else end
    if nd == 0 or not 0 <= start <= end < nd:
        raise ValidationError(f"{where}: start_dim/end_dim do not fit an input of shape {in_shape}.")
    return (*in_shape[:start], int(np.prod(in_shape[start:end + 1])), *in_shape[end + 1:])


def op_from_node(name: str, node: Any, in_shape: tuple[int, ...]) -> Op:
    """The :class:`Op` of NIR node ``node`` (named ``name``) fed a signal of ``in_shape``."""
    kind = type(node).__name__
    where = f"NIR node {name!r} ({kind})"
    n_in = int(np.prod(in_shape))
    if kind in ("Affine", "Linear"):
        weight = np.asarray(node.weight)
        if weight.ndim != 2:
            raise ValidationError(f"{where}: weight must be 2-D (out, in), got shape {weight.shape}.")
        if weight.shape[1] != n_in:
            raise ValidationError(f"{where}: weight {weight.shape} does not take an input of shape {in_shape}.")
        if len(in_shape) > 1 and in_shape[-1] == weight.shape[1] != n_in:
            raise ValidationError(f"{where} applies to the last axis of a {in_shape} signal, which neurovpr cannot map.")
        if kind == "Affine" and np.asarray(node.bias).size != weight.shape[0]:
            raise ValidationError(f"{where}: bias has {np.asarray(node.bias).size} values for {weight.shape[0]} outputs.")
        return Op(name, kind, in_shape, (int(weight.shape[0]),), node)
    if kind in ("Conv2d", "SumPool2d", "AvgPool2d"):
        return _window_op(name, kind, node, in_shape)
    if kind == "Flatten":
        return Op(name, kind, in_shape, _flatten_shape(where, node, in_shape), node)
    if kind == "Scale":
        scale = np.asarray(node.scale, dtype=np.float64)
        if scale.size not in (1, n_in):
            raise ValidationError(f"{where}: scale has {scale.size} values for a signal of shape {in_shape}.")
        return Op(name, kind, in_shape, in_shape, node, extra={"scale": np.broadcast_to(scale.reshape(-1), (n_in,)).copy()})
    if kind == "Delay":
        delay = np.asarray(node.delay, dtype=np.float64).reshape(-1)
        if delay.size not in (1, n_in):
            raise ValidationError(f"{where}: delay must be 1 or {n_in} values (seconds), got {delay.size} values.")
        bad = np.flatnonzero(~np.isfinite(delay) | (delay < 0))
        if bad.size:
            raise ValidationError(
                f"{where}: delay[{int(bad[0])}] is {float(delay[bad[0]])!r} s; every delay must be a finite number >= 0 s."
            )
        return Op(name, kind, in_shape, in_shape, node, delay=np.broadcast_to(delay, (n_in,)).copy())
    if kind in ("Input", "Output"):  # the ports of a flattened subgraph
        return Op(name, "pass", in_shape, in_shape, node)
    raise ValidationError(f"NIR node {name!r} is a {kind}, which has no neurovpr equivalent.")


def compose(ops: list[Op]) -> tuple[sp.csr_matrix, np.ndarray]:
    """The matrix ``(n_out, n_in)`` and bias of a chain of ops applied in order."""
    matrix = sp.identity(ops[0].n_in, format="csr", dtype=np.float64)
    bias = np.zeros(ops[0].n_in)
    for op in ops:
        m = op.matrix()
        matrix = (m @ matrix).tocsr()
        bias = m @ bias + op.bias()
    matrix.eliminate_zeros()
    return matrix, bias
