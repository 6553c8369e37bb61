"""neurovpr: declare a spiking network once, run it on any simulator or emulated chip.

The public API follows PyNN's vocabulary::

    import neurovpr as nv

    net = nv.Network("module")
    net.add_population("pixels", 784, nv.SpikeSourcePoisson(rate=0.0))
    net.add_population("exc", 400, nv.IF_cond_exp_adaptive(tau_m=100.0))
    net.connect("pixels", "exc", nv.AllToAllConnector(), nv.DiehlCookSTDP(weight=0.1))
    sim = nv.compile(net, backend="reference", dt=0.5, seed=1)
    sim.run(350.0, inputs={"pixels": rates_hz})
    sim.spike_counts("exc")
"""

from neurovpr.errors import (
    BackendUnavailableError,
    FileFormatError,
    NeurovprError,
    SimulationError,
    UnsupportedFeatureError,
    ValidationError,
)
from neurovpr.ir.cells import (
    INTEGRATIONS,
    NO_LEAK,
    IF_cond_exp,
    IF_cond_exp_adaptive,
    IF_curr_exp,
    IF_curr_exp_ca2_adaptive,
    SoftLIF,
    SpikeSourceArray,
    SpikeSourcePoisson,
)
from neurovpr.ir.connectivity import Connections, expand
from neurovpr.ir.connectors import (
    AllToAllConnector,
    ConvolutionConnector,
    FixedNumberPreConnector,
    FixedProbabilityConnector,
    FromListConnector,
    OneToOneConnector,
)
from neurovpr.ir.distributions import Normal, Uniform
from neurovpr.ir.network import Network, Population, Projection
from neurovpr.ir.serialization import load, save
from neurovpr.ir.synapses import (
    AdditiveWeightDependence,
    DiehlCookSTDP,
    MultiplicativeWeightDependence,
    SpikePairRule,
    StaticSynapse,
    STDPMechanism,
)
from neurovpr.runtime.batch import BatchResult
from neurovpr.runtime.compiler import compile
from neurovpr.runtime.registry import backend_infos, get_backend
from neurovpr.runtime.simulation import Simulation

__version__ = "0.1.0"

__all__ = [
    "AdditiveWeightDependence",
    "BatchResult",
    "INTEGRATIONS",
    "NO_LEAK",
    "AllToAllConnector",
    "BackendUnavailableError",
    "Connections",
    "ConvolutionConnector",
    "DiehlCookSTDP",
    "FileFormatError",
    "FixedNumberPreConnector",
    "FixedProbabilityConnector",
    "FromListConnector",
    "IF_cond_exp",
    "IF_cond_exp_adaptive",
    "IF_curr_exp",
    "IF_curr_exp_ca2_adaptive",
    "MultiplicativeWeightDependence",
    "Network",
    "NeurovprError",
    "Normal",
    "OneToOneConnector",
    "Population",
    "Projection",
    "STDPMechanism",
    "SimulationError",
    "Simulation",
    "SoftLIF",
    "SpikePairRule",
    "SpikeSourceArray",
    "SpikeSourcePoisson",
    "StaticSynapse",
    "Uniform",
    "UnsupportedFeatureError",
    "ValidationError",
    "backend_infos",
    "compile",
    "expand",
    "get_backend",
    "load",
    "save",
]
