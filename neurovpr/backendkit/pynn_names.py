"""Names and units of neurovpr's IR types in PyNN and sPyNNaker (pure data).

The IR already uses PyNN's names and units (ms, mV, nA, nF, uS, Hz), so every
scale factor here is 1; the tables exist so that a PyNN-based backend translates
by looking names up instead of by assuming them, and so that the places where
PyNN and sPyNNaker differ are written down once. Nothing here imports PyNN.

Each parameter table row is ``(ir_name, pynn_name, scale)``: the PyNN value is
``scale * ir_value``.
"""

from __future__ import annotations

from types import MappingProxyType
from typing import Mapping

__all__ = [
    "ParameterRow",
    "CELL_TYPES",
    "SPYNNAKER_CELL_TYPES",
    "CELL_PARAMETERS",
    "INITIAL_VALUES",
    "RECORDABLES",
    "SYNAPSE_TYPES",
    "TIMING_DEPENDENCES",
    "WEIGHT_DEPENDENCES",
    "NOT_STANDARD_PYNN",
]

ParameterRow = tuple[str, str, float]

_LIF: tuple[ParameterRow, ...] = (
    ("cm", "cm", 1.0),
    ("tau_m", "tau_m", 1.0),
    ("tau_refrac", "tau_refrac", 1.0),
    ("tau_syn_E", "tau_syn_E", 1.0),
    ("tau_syn_I", "tau_syn_I", 1.0),
    ("v_rest", "v_rest", 1.0),
    ("v_reset", "v_reset", 1.0),
    ("v_thresh", "v_thresh", 1.0),
    ("i_offset", "i_offset", 1.0),
)

#: IR cell type -> PyNN standard cell type (in ``pyNN.<simulator>``).
CELL_TYPES: Mapping[str, str] = MappingProxyType(
    {
        "IF_curr_exp": "IF_curr_exp",
        "IF_cond_exp": "IF_cond_exp",
        "SpikeSourcePoisson": "SpikeSourcePoisson",
        "SpikeSourceArray": "SpikeSourceArray",
    }
)

#: IR cell type -> sPyNNaker class; names with a dot live in ``spynnaker.pyNN.extra_models``.
SPYNNAKER_CELL_TYPES: Mapping[str, str] = MappingProxyType(
    {**CELL_TYPES, "IF_curr_exp_ca2_adaptive": "extra_models.IFCurrExpCa2Adaptive"}
)

#: Parameters of each cell type, IR name -> PyNN name with the scale factor.
CELL_PARAMETERS: Mapping[str, tuple[ParameterRow, ...]] = MappingProxyType(
    {
        "IF_curr_exp": _LIF,
        "IF_cond_exp": (*_LIF, ("e_rev_E", "e_rev_E", 1.0), ("e_rev_I", "e_rev_I", 1.0)),
        "IF_curr_exp_ca2_adaptive": (*_LIF, ("tau_ca2", "tau_ca2", 1.0), ("i_alpha", "i_alpha", 1.0)),
        "SpikeSourcePoisson": (("rate", "rate", 1.0), ("start", "start", 1.0), ("duration", "duration", 1.0)),
        "SpikeSourceArray": (),
    }
)

#: Initial values: IR field (``Population.v_init`` is ``v_init``) -> PyNN state variable.
INITIAL_VALUES: Mapping[str, tuple[ParameterRow, ...]] = MappingProxyType(
    {
        "IF_curr_exp": (("v_init", "v", 1.0),),
        "IF_cond_exp": (("v_init", "v", 1.0),),
        "IF_curr_exp_ca2_adaptive": (("v_init", "v", 1.0), ("i_ca2", "i_ca2", 1.0)),
    }
)

#: State variables PyNN's standard cell types record (IR name -> PyNN name).
#: PyNN 0.13's ``IF_curr_exp`` records only ``v`` (and spikes).
RECORDABLES: Mapping[str, Mapping[str, str]] = MappingProxyType(
    {
        "IF_curr_exp": MappingProxyType({"v": "v"}),
        "IF_cond_exp": MappingProxyType({"v": "v", "gsyn_exc": "gsyn_exc", "gsyn_inh": "gsyn_inh"}),
    }
)

#: IR synapse type -> PyNN synapse type.
SYNAPSE_TYPES: Mapping[str, str] = MappingProxyType({"StaticSynapse": "StaticSynapse", "STDPMechanism": "STDPMechanism"})

#: Timing dependences: IR type -> (PyNN type, parameter rows).
TIMING_DEPENDENCES: Mapping[str, tuple[str, tuple[ParameterRow, ...]]] = MappingProxyType(
    {
        "SpikePairRule": (
            "SpikePairRule",
            (("tau_plus", "tau_plus", 1.0), ("tau_minus", "tau_minus", 1.0), ("A_plus", "A_plus", 1.0),
             ("A_minus", "A_minus", 1.0)),
        ),
    }
)

#: Weight dependences: IR type -> (PyNN type, parameter rows).
WEIGHT_DEPENDENCES: Mapping[str, tuple[str, tuple[ParameterRow, ...]]] = MappingProxyType(
    {
        "AdditiveWeightDependence": ("AdditiveWeightDependence", (("w_min", "w_min", 1.0), ("w_max", "w_max", 1.0))),
        "MultiplicativeWeightDependence": (
            "MultiplicativeWeightDependence",
            (("w_min", "w_min", 1.0), ("w_max", "w_max", 1.0)),
        ),
    }
)

#: IR types with no PyNN standard equivalent, and why.
NOT_STANDARD_PYNN: Mapping[str, str] = MappingProxyType(
    {
        "IF_cond_exp_adaptive": "PyNN has no standard cell type with Diehl & Cook's adaptive threshold (theta)",
        "IF_curr_exp_ca2_adaptive": "it is sPyNNaker's own model (IFCurrExpCa2Adaptive), not a PyNN standard "
        "cell type, and neither NEST nor Brian2 under PyNN has an exact equivalent",
        "SoftLIF": "it is a rate approximation used only for training",
        "DiehlCookSTDP": "PyNN has no standard weight or timing dependence for Diehl & Cook's rule",
        "zero delay": "PyNN's minimum delay (min_delay) is one time step",
        "euler integration": "PyNN's standard cells take no integration method (NEST solves iaf_cond_exp with "
        "its own adaptive Runge-Kutta solver, pyNN.brian2 fixes its own method)",
    }
)
