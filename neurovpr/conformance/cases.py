"""The conformance cases, by id.

A backend that cannot run a case names it in ``Capabilities.unsupported`` as
``{case_id: reason}``; the case then skips with that reason instead of failing.
"""

from __future__ import annotations

from types import MappingProxyType

__all__ = ["CASES"]

CASES = MappingProxyType(
    {
        "lif_rate_curr": "IF_curr_exp under constant i_offset fires at the closed-form rate (grid-exact spike times)",
        "lif_rate_cond": "IF_cond_exp under constant i_offset fires at the closed-form rate (grid-exact spike times)",
        "psp_curr": "IF_curr_exp membrane after one input spike equals the exact PSP at every step",
        "psp_curr_equal_tau": "the same PSP in the degenerate limit tau_syn == tau_m",
        "synaptic_trace": "recorded isyn/gsyn jump by the weight at an arrival and decay with tau_syn",
        "psp_cond": "IF_cond_exp membrane after one input spike matches a high-precision ODE solution",
        "poisson": "SpikeSourcePoisson mean count and Fano factor, start and duration respected",
        "stdp_additive": "one pre/post pair under STDPMechanism with AdditiveWeightDependence",
        "stdp_multiplicative": "one pre/post pair under STDPMechanism with MultiplicativeWeightDependence",
        "stdp_diehl_cook": "one pre/post pair under DiehlCookSTDP (pair form)",
        "stdp_same_instant": "for each rule, an arrival at the instant of a post spike counts as dt_pair = 0",
        "stdp_diehl_cook_triplet": "one pre spike and two post spikes under DiehlCookSTDP with tau_post2",
        "stdp_potentiating_pre": "DiehlCookSTDP with pre_term='potentiate' and the triplet post term (the Modular SNN "
        "authors' rule): post, pre, post",
        "winner_take_all": "lateral inhibition lets the most strongly driven neuron win",
        "delay_shift": "changing a projection's delay shifts the postsynaptic spikes by exactly that much",
        "delay_heterogeneous": "per-connection delays within one projection each shift their target's spike",
        "delay_rounding": "a delay that is not a multiple of dt is rounded to the nearest whole step",
        "zero_delay": "a zero-delay synapse between neurons acts from the step after the presynaptic spike (Brian2's "
        "zero delay): the postsynaptic spike comes exactly one step earlier than with a delay of dt",
        "spike_array_rounding": "SpikeSourceArray times are rounded to the nearest step",
        "ca2_adaptation": "IF_curr_exp_ca2_adaptive: I_ca2 jumps by i_alpha per spike, decays with tau_ca2, ISIs grow",
        "spike_lockout": "IF_cond_exp_adaptive with tau_lockout: intervals of max(lockout, refractory + time to threshold), "
        "the membrane free (above threshold) during the lockout",
        "euler_integration": "IF_cond_exp and IF_cond_exp_adaptive with integration='euler': spike times under "
        "constant current from the forward-Euler closed form, and the membrane and conductance after one input "
        "spike from the Euler difference equations (each unlike the exact ones)",
        "euler_theta": "IF_cond_exp_adaptive with integration='euler': theta falls by 1 - dt / tau_theta per step and "
        "grows by theta_plus per spike, with the spike times that follow",
        "theta_adaptation": "IF_cond_exp_adaptive: theta grows by theta_plus per spike, decays, survives reset()",
        "determinism": "the same seed gives identical spike trains; another seed gives other Poisson trains",
        "reset": "reset() returns time, state and spikes in flight to the start, keeps weights",
        "plasticity_off": "plasticity(False) freezes weights and thresholds while traces keep evolving",
    }
)
