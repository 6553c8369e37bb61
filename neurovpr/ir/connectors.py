"""Connectors: which presynaptic neuron connects to which postsynaptic neuron.

PyNN's connector names and arguments. Random connectors draw from a generator
derived from ``seed`` when given, otherwise from the compile seed and the
projection's name, so that all backends build the same connections. The expansion
of a connector into explicit index arrays lives in :mod:`neurovpr.ir.connectivity`.
"""

from __future__ import annotations

from dataclasses import KW_ONLY, dataclass, field
from typing import Any

import numpy as np

from neurovpr.errors import ValidationError
from neurovpr.ir.distributions import Distribution
from neurovpr.ir.node import IRNode, freeze_array, param

__all__ = [
    "Connector",
    "AllToAllConnector",
    "OneToOneConnector",
    "FixedProbabilityConnector",
    "FixedNumberPreConnector",
    "FromListConnector",
    "ConvolutionConnector",
    "CONNECTORS",
]

_KW = {"frozen": True, "slots": True, "kw_only": True, "eq": False}
#: As PyNN, the first parameter may be given by position (``FixedProbabilityConnector(0.1)``), the rest by keyword.
_FIRST_POSITIONAL = {"frozen": True, "slots": True, "eq": False}


class Connector(IRNode):
    """Base of the connectors."""

    __slots__ = ()

    #: True when the connections depend on a random draw.
    random = False

    def check_sizes(self, pre_size: int, post_size: int, where: str) -> None:
        """Raise :class:`ValidationError` if the connector cannot join these sizes."""


@dataclass(**_FIRST_POSITIONAL)
class AllToAllConnector(Connector):
    """Every presynaptic neuron to every postsynaptic neuron.

    ``allow_self_connections=False`` leaves out ``i -> i`` (e.g. lateral inhibition
    between a population and its partner population of the same size).
    """

    allow_self_connections: bool = True
    _: KW_ONLY

    def _validate(self) -> None:
        if not isinstance(self.allow_self_connections, bool):
            raise ValidationError("AllToAllConnector.allow_self_connections must be True or False.")


@dataclass(**_KW)
class OneToOneConnector(Connector):
    """Neuron ``i`` to neuron ``i``; both populations must have the same size."""

    def check_sizes(self, pre_size: int, post_size: int, where: str) -> None:
        if pre_size != post_size:
            raise ValidationError(
                f"Projection {where}: OneToOneConnector needs equal sizes, got {pre_size} and {post_size}."
            )


@dataclass(**_FIRST_POSITIONAL)
class FixedProbabilityConnector(Connector):
    """Each pair connects independently with probability ``p_connect``."""

    random = True

    p_connect: float = param(low=0.0, high=1.0)
    _: KW_ONLY
    allow_self_connections: bool = True
    seed: int | None = None

    def _validate(self) -> None:
        _check_seed(self)


@dataclass(**_FIRST_POSITIONAL)
class FixedNumberPreConnector(Connector):
    """Each postsynaptic neuron receives ``n`` connections from random presynaptic neurons.

    ``n`` is an integer or a :class:`~neurovpr.ir.distributions.Distribution`, drawn per
    postsynaptic neuron, rounded to the nearest integer and clipped to
    ``[0, n_pre]`` (for example ``round(N(5, 1))`` PN inputs per Kenyon cell).
    """

    random = True

    n: Any = 1
    _: KW_ONLY
    allow_self_connections: bool = True
    with_replacement: bool = False
    seed: int | None = None

    def _validate(self) -> None:
        if isinstance(self.n, Distribution):
            pass
        elif isinstance(self.n, (int, np.integer)) and not isinstance(self.n, bool) and self.n >= 0:
            object.__setattr__(self, "n", int(self.n))
        else:
            raise ValidationError(
                f"FixedNumberPreConnector.n must be a non-negative integer or a distribution, got {self.n!r}."
            )
        _check_seed(self)

    def check_sizes(self, pre_size: int, post_size: int, where: str) -> None:
        if isinstance(self.n, int) and not self.with_replacement and self.n > pre_size:
            raise ValidationError(
                f"Projection {where}: FixedNumberPreConnector.n={self.n} exceeds the {pre_size} "
                "presynaptic neurons (use with_replacement=True)."
            )


@dataclass(**_FIRST_POSITIONAL)
class FromListConnector(Connector):
    """Explicit connections: ``conn_list`` rows are ``(i, j)``, ``(i, j, weight)`` or
    ``(i, j, weight, delay)``; given weights and delays override the synapse's."""

    conn_list: np.ndarray = field(default_factory=lambda: np.zeros((0, 2)))
    _: KW_ONLY

    def __post_init__(self) -> None:
        try:
            arr = freeze_array(self.conn_list)
        except (TypeError, ValueError):
            raise ValidationError("FromListConnector.conn_list must be a numeric (n, 2..4) array.") from None
        if arr.size == 0:
            arr = freeze_array(np.zeros((0, 2)))
        if arr.ndim != 2 or arr.shape[1] not in (2, 3, 4):
            raise ValidationError(f"FromListConnector.conn_list must have 2, 3 or 4 columns, got shape {arr.shape}.")
        if not np.all(np.isfinite(arr)):
            raise ValidationError("FromListConnector.conn_list contains NaN or infinite values.")
        idx = arr[:, :2]
        if np.any(idx < 0) or np.any(idx != np.round(idx)):
            row = int(np.flatnonzero(np.any((idx < 0) | (idx != np.round(idx)), axis=1))[0])
            raise ValidationError(
                f"FromListConnector.conn_list row {row} has a negative or non-integer index {idx[row].tolist()}."
            )
        if arr.shape[1] == 4 and np.any(arr[:, 3] < 0):
            raise ValidationError("FromListConnector.conn_list delays (column 4) must be >= 0 ms.")
        object.__setattr__(self, "conn_list", arr)

    def check_sizes(self, pre_size: int, post_size: int, where: str) -> None:
        if self.conn_list.shape[0] == 0:
            return
        for col, size, side in ((0, pre_size, "presynaptic"), (1, post_size, "postsynaptic")):
            top = int(self.conn_list[:, col].max())
            if top >= size:
                raise ValidationError(
                    f"Projection {where}: FromListConnector {side} index {top} is outside 0..{size - 1}."
                )


@dataclass(**_KW)
class ConvolutionConnector(Connector):
    """A 2-D convolution between channel-major feature maps.

    The presynaptic population is an ``input_shape = (channels, height, width)`` map
    flattened in C order; the postsynaptic population is ``(out_channels, out_h,
    out_w)`` with ``out_h = (height + 2 * padding_h - kernel_h) // stride_h + 1``.
    The kernel (``(out_channels, channels, kernel_h, kernel_w)``) is the synapse's
    weight. Zero padding adds no connections.
    """

    input_shape: tuple[int, int, int] = (1, 1, 1)
    kernel_shape: tuple[int, int] = (1, 1)
    out_channels: int = 1
    stride: tuple[int, int] = (1, 1)
    padding: tuple[int, int] = (0, 0)

    def _validate(self) -> None:
        for name, length, low in (
            ("input_shape", 3, 1),
            ("kernel_shape", 2, 1),
            ("stride", 2, 1),
            ("padding", 2, 0),
        ):
            value = getattr(self, name)
            try:
                tup = tuple(int(v) for v in value)
            except (TypeError, ValueError):
                raise ValidationError(f"ConvolutionConnector.{name} must be {length} integers, got {value!r}.") from None
            if len(tup) != length or any(v < low for v in tup) or any(int(v) != v for v in value):
                raise ValidationError(
                    f"ConvolutionConnector.{name} must be {length} integers >= {low}, got {value!r}."
                )
            object.__setattr__(self, name, tup)
        if isinstance(self.out_channels, bool) or not isinstance(self.out_channels, (int, np.integer)) or self.out_channels < 1:
            raise ValidationError(f"ConvolutionConnector.out_channels must be an integer >= 1, got {self.out_channels!r}.")
        object.__setattr__(self, "out_channels", int(self.out_channels))
        oh, ow = self.output_hw
        if oh < 1 or ow < 1:
            raise ValidationError(
                f"ConvolutionConnector: kernel {self.kernel_shape} with padding {self.padding} "
                f"does not fit the input {self.input_shape[1:]}."
            )

    @property
    def output_hw(self) -> tuple[int, int]:
        """Height and width of each output feature map."""
        (_, h, w), (kh, kw), (sh, sw), (ph, pw) = self.input_shape, self.kernel_shape, self.stride, self.padding
        return ((h + 2 * ph - kh) // sh + 1, (w + 2 * pw - kw) // sw + 1)

    @property
    def output_shape(self) -> tuple[int, int, int]:
        """``(out_channels, out_h, out_w)``."""
        return (self.out_channels, *self.output_hw)

    @property
    def weight_shape(self) -> tuple[int, int, int, int]:
        """Shape of the kernel array the synapse must carry."""
        return (self.out_channels, self.input_shape[0], *self.kernel_shape)

    def check_sizes(self, pre_size: int, post_size: int, where: str) -> None:
        n_in = int(np.prod(self.input_shape))
        n_out = int(np.prod(self.output_shape))
        if pre_size != n_in:
            raise ValidationError(
                f"Projection {where}: ConvolutionConnector input_shape {self.input_shape} has {n_in} "
                f"neurons but the presynaptic population has {pre_size}."
            )
        if post_size != n_out:
            raise ValidationError(
                f"Projection {where}: ConvolutionConnector output {self.output_shape} has {n_out} "
                f"neurons but the postsynaptic population has {post_size}."
            )


def _check_seed(conn: Connector) -> None:
    seed = conn.seed  # type: ignore[attr-defined]
    if seed is not None and (isinstance(seed, bool) or not isinstance(seed, (int, np.integer)) or seed < 0):
        raise ValidationError(f"{type(conn).__name__}.seed must be None or a non-negative integer, got {seed!r}.")
    if seed is not None:
        object.__setattr__(conn, "seed", int(seed))


CONNECTORS: dict[str, type[Connector]] = {
    c.__name__: c
    for c in (
        AllToAllConnector,
        OneToOneConnector,
        FixedProbabilityConnector,
        FixedNumberPreConnector,
        FromListConnector,
        ConvolutionConnector,
    )
}
