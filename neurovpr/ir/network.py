"""Populations, projections and the network that holds them.

:class:`Population` and :class:`Projection` are frozen IR dataclasses. A
:class:`Network` is the builder that collects them under unique names and checks
every addition against what is already there (sizes, names, receptor types), so an
invalid graph fails when it is built, not when it is run.
"""

from __future__ import annotations

import re
from dataclasses import dataclass
from types import MappingProxyType
from typing import Any, Literal, Mapping

import numpy as np

from neurovpr.errors import ValidationError
from neurovpr.ir.cells import CellType, NeuronType, SoftLIF
from neurovpr.ir.connectors import Connector, ConvolutionConnector, FromListConnector
from neurovpr.ir.distributions import Distribution
from neurovpr.ir.node import IRNode, freeze_array
from neurovpr.ir.synapses import StaticSynapse, Synapse

__all__ = ["Population", "Projection", "Network", "RECEPTOR_TYPES"]

_KW = {"frozen": True, "slots": True, "kw_only": True, "eq": False}
_NAME = re.compile(r"^[A-Za-z_][A-Za-z0-9_.:\->]*$")
RECEPTOR_TYPES = ("excitatory", "inhibitory")


def _check_name(kind: str, name: Any) -> str:
    if not isinstance(name, str) or not _NAME.match(name) or len(name) > 128:
        raise ValidationError(
            f"{kind} name {name!r} is invalid: use letters, digits, '_', '.', ':', '-', '>' "
            "(starting with a letter or '_', at most 128 characters)."
        )
    return name


@dataclass(**_KW)
class Population(IRNode):
    """A named group of ``size`` neurons (or spike sources) of one cell type.

    ``v_init`` is the initial membrane potential (mV), one value or one per neuron;
    ``None`` starts every neuron at ``v_rest`` (PyNN's default).
    """

    name: str
    size: int
    cell_type: CellType
    v_init: Any = None

    def _validate(self) -> None:
        _check_name("Population", self.name)
        if isinstance(self.size, bool) or not isinstance(self.size, (int, np.integer)) or self.size < 1:
            raise ValidationError(f"Population {self.name!r}: size must be an integer >= 1, got {self.size!r}.")
        object.__setattr__(self, "size", int(self.size))
        if not isinstance(self.cell_type, CellType):
            raise ValidationError(
                f"Population {self.name!r}: cell_type must be a neurovpr cell type, got {type(self.cell_type).__name__}."
            )
        object.__setattr__(self, "cell_type", self.cell_type.for_size(self.size))
        for fname, length in self.cell_type.array_sizes().items():
            if length != self.size:
                raise ValidationError(
                    f"Population {self.name!r}: {type(self.cell_type).__name__}.{fname} has {length} "
                    f"values for {self.size} neurons."
                )
        if self.v_init is not None:
            if not isinstance(self.cell_type, NeuronType):
                raise ValidationError(f"Population {self.name!r}: v_init applies to neurons only, not to sources.")
            arr = np.asarray(self.v_init, dtype=float)
            if arr.ndim > 1 or (arr.ndim == 1 and arr.size != self.size) or not np.all(np.isfinite(arr)):
                raise ValidationError(
                    f"Population {self.name!r}: v_init must be a finite number or {self.size} finite values."
                )
            object.__setattr__(self, "v_init", float(arr) if arr.ndim == 0 else freeze_array(arr))

    @property
    def is_source(self) -> bool:
        """True for spike sources."""
        return self.cell_type.is_source


@dataclass(**_KW)
class Projection(IRNode):
    """Connections from population ``pre`` to population ``post``.

    ``receptor_type`` is ``"excitatory"`` or ``"inhibitory"``.
    """

    name: str
    pre: str
    post: str
    connector: Connector
    synapse: Synapse
    receptor_type: Literal["excitatory", "inhibitory"] = "excitatory"

    def _validate(self) -> None:
        _check_name("Projection", self.name)
        if not isinstance(self.connector, Connector):
            raise ValidationError(
                f"Projection {self.name!r}: connector must be a neurovpr connector, got {type(self.connector).__name__}."
            )
        if not isinstance(self.synapse, Synapse):
            raise ValidationError(
                f"Projection {self.name!r}: synapse must be a neurovpr synapse type, got {type(self.synapse).__name__}."
            )
        if self.receptor_type not in RECEPTOR_TYPES:
            raise ValidationError(
                f"Projection {self.name!r}: receptor_type must be 'excitatory' or 'inhibitory', got {self.receptor_type!r}."
            )

    @property
    def plastic(self) -> bool:
        """True when the synapse type learns."""
        return self.synapse.plastic

    @property
    def zero_delay(self) -> bool:
        """True when some connection has a delay of exactly 0 ms (a zero-delay synapse, docs/semantics.md)."""
        cl = self.connector.conn_list if isinstance(self.connector, FromListConnector) else None
        if cl is not None and cl.shape[1] == 4:
            return bool(np.any(cl[:, 3] == 0))
        delay = self.synapse.delay
        return isinstance(delay, (float, np.ndarray)) and bool(np.any(np.asarray(delay) == 0))


class Network:
    """A spiking network: named populations and the projections between them.

    Parameters
    ----------
    name
        The network's name (stored in saved files and reports).

    Examples
    --------
    >>> import neurovpr as nv
    >>> net = nv.Network("demo")
    >>> _ = net.add_population("inp", 10, nv.SpikeSourcePoisson(rate=20.0))
    >>> _ = net.add_population("out", 2, nv.IF_curr_exp())
    >>> net.connect("inp", "out", nv.AllToAllConnector(), nv.StaticSynapse(weight=0.5)).name
    'inp->out'
    """

    __slots__ = ("_name", "_populations", "_projections")

    def __init__(self, name: str = "network") -> None:
        self._name = _check_name("Network", name)
        self._populations: dict[str, Population] = {}
        self._projections: dict[str, Projection] = {}

    @property
    def name(self) -> str:
        """The network's name."""
        return self._name

    @property
    def populations(self) -> Mapping[str, Population]:
        """Read-only view of the populations by name, in insertion order."""
        return MappingProxyType(self._populations)

    @property
    def projections(self) -> Mapping[str, Projection]:
        """Read-only view of the projections by name, in insertion order."""
        return MappingProxyType(self._projections)

    def add_population(self, name: str, size: int, cell_type: CellType, *, v_init: Any = None) -> Population:
        """Add a population of ``size`` neurons of ``cell_type`` and return it."""
        if name in self._populations:
            raise ValidationError(f"Network {self._name!r} already has a population named {name!r}.")
        pop = Population(name=name, size=size, cell_type=cell_type, v_init=v_init)
        self.add(pop)
        return pop

    def connect(
        self,
        pre: str,
        post: str,
        connector: Connector,
        synapse: Synapse | None = None,
        *,
        receptor_type: Literal["excitatory", "inhibitory"] = "excitatory",
        name: str | None = None,
    ) -> Projection:
        """Connect population ``pre`` to ``post``; the projection is named ``"pre->post"`` by default."""
        proj = Projection(
            name=name if name is not None else f"{pre}->{post}",
            pre=pre,
            post=post,
            connector=connector,
            synapse=synapse if synapse is not None else StaticSynapse(),
            receptor_type=receptor_type,
        )
        self.add(proj)
        return proj

    def add(self, item: Population | Projection) -> None:
        """Add an already-built population or projection (used by loaders and converters)."""
        if isinstance(item, Population):
            if item.name in self._populations:
                raise ValidationError(f"Network {self._name!r} already has a population named {item.name!r}.")
            self._populations[item.name] = item
        elif isinstance(item, Projection):
            self._check_projection(item)
            self._projections[item.name] = item
        else:
            raise ValidationError(f"Network {self._name!r}: cannot add a {type(item).__name__}.")

    def replace_projection(self, projection: Projection) -> None:
        """Replace the projection of the same name (e.g. with learned weights), checked again."""
        if projection.name not in self._projections:
            raise ValidationError(f"Network {self._name!r} has no projection named {projection.name!r}.")
        old = self._projections.pop(projection.name)
        try:
            self._check_projection(projection)
        except ValidationError:
            self._projections[old.name] = old
            raise
        self._projections[projection.name] = projection

    def replace_population(self, population: Population) -> None:
        """Replace the population of the same name (same size and kind), checked again."""
        old = self._populations.get(population.name)
        if old is None:
            raise ValidationError(f"Network {self._name!r} has no population named {population.name!r}.")
        if old.size != population.size or old.is_source != population.is_source:
            raise ValidationError(f"Population {population.name!r}: a replacement must keep size and kind.")
        self._populations[population.name] = population

    def copy(self, name: str | None = None) -> Network:
        """A new network holding the same (immutable) populations and projections."""
        net = Network(name or self._name)
        net._populations = dict(self._populations)
        net._projections = dict(self._projections)
        return net

    def _check_projection(self, proj: Projection) -> None:
        where = repr(proj.name)
        if proj.name in self._projections:
            raise ValidationError(f"Network {self._name!r} already has a projection named {proj.name!r}.")
        for side, pop_name in (("pre", proj.pre), ("post", proj.post)):
            if pop_name not in self._populations:
                known = ", ".join(self._populations) or "none"
                raise ValidationError(
                    f"Projection {where}: {side} population {pop_name!r} does not exist (known: {known})."
                )
        pre, post = self._populations[proj.pre], self._populations[proj.post]
        if post.is_source:
            raise ValidationError(
                f"Projection {where}: post population {post.name!r} is a spike source and cannot receive input."
            )
        if isinstance(pre.cell_type, SoftLIF) != isinstance(post.cell_type, SoftLIF):
            raise ValidationError(f"Projection {where}: SoftLIF (rate) and spiking populations cannot be connected.")
        proj.connector.check_sizes(pre.size, post.size, where)
        _check_weight_spec(proj, pre.size, post.size, conductance=post.cell_type.conductance_based)

    def __eq__(self, other: object) -> bool:
        if not isinstance(other, Network):
            return NotImplemented
        return (
            self._name == other._name
            and list(self._populations.items()) == list(other._populations.items())
            and list(self._projections.items()) == list(other._projections.items())
        )

    __hash__ = None  # type: ignore[assignment]

    def __repr__(self) -> str:
        return (
            f"Network({self._name!r}, populations={list(self._populations)}, "
            f"projections={list(self._projections)})"
        )

    @property
    def n_neurons(self) -> int:
        """Total number of neurons, sources included."""
        return sum(p.size for p in self._populations.values())


def _check_weight_spec(proj: Projection, n_pre: int, n_post: int, *, conductance: bool) -> None:
    """Check the weight and delay specs of a projection against its connector and target."""
    where = repr(proj.name)
    syn, conn = proj.synapse, proj.connector
    for attr in ("weight", "delay"):
        spec = getattr(syn, attr)
        if isinstance(conn, ConvolutionConnector):
            if attr == "weight":
                if not isinstance(spec, np.ndarray) or spec.shape != conn.weight_shape:
                    got = spec.shape if isinstance(spec, np.ndarray) else type(spec).__name__
                    raise ValidationError(
                        f"Projection {where}: a ConvolutionConnector needs a kernel weight of shape "
                        f"{conn.weight_shape}, got {got}."
                    )
            elif spec is not None and not isinstance(spec, float):
                raise ValidationError(f"Projection {where}: a ConvolutionConnector takes one delay for all synapses.")
            continue
        if isinstance(spec, np.ndarray):
            if spec.ndim == 2 and spec.shape != (n_pre, n_post):
                raise ValidationError(
                    f"Projection {where}: 2-D {attr} array must be ({n_pre}, {n_post}), got {spec.shape}."
                )
            if spec.ndim == 4:
                raise ValidationError(f"Projection {where}: a 4-D {attr} array needs a ConvolutionConnector.")
            if spec.ndim == 1 and (n := _fixed_count(conn, n_pre, n_post)) is not None and spec.size != n:
                raise ValidationError(
                    f"Projection {where}: 1-D {attr} array has {spec.size} values for {n} connections."
                )
    weight = syn.weight
    if isinstance(conn, FromListConnector) and conn.conn_list.shape[1] >= 3:
        weight = conn.conn_list[:, 2]
    negative_ok = not conductance and proj.receptor_type == "excitatory"
    if not negative_ok:
        low = weight.low if isinstance(weight, Distribution) and hasattr(weight, "low") else None
        if (isinstance(weight, (float, np.ndarray)) and np.min(weight) < 0) or (low is not None and low < 0):
            target = "a conductance-based" if conductance else "an inhibitory"
            got = f"{float(np.min(weight))!r}" if low is None else f"{type(weight).__name__} with low={low!r}"
            raise ValidationError(
                f"Projection {where}: weights onto {target} receptor must be >= 0 "
                f"(the receptor type gives the sign), got {got}."
            )


def _fixed_count(conn: Connector, n_pre: int, n_post: int) -> int | None:
    """Number of connections a deterministic connector makes, or ``None`` for random ones."""
    from neurovpr.ir.connectors import AllToAllConnector, OneToOneConnector

    if isinstance(conn, AllToAllConnector):
        return n_pre * n_post - (0 if conn.allow_self_connections else min(n_pre, n_post))
    if isinstance(conn, OneToOneConnector):
        return n_pre
    if isinstance(conn, FromListConnector):
        return int(conn.conn_list.shape[0])
    return None
