"""The layouts of the arrays the reference kernels read: codes, table columns, flags, bundles.

The kernels (:mod:`.kernels`) and the host code that fills their arrays
(:mod:`.translation`, :mod:`.convolution`, :mod:`.delivery`, :mod:`.simulation`) take these
from here. The compiled kernels read them as constants, so numba's cache of every kernel
whose code reads this file is keyed on it too (see :mod:`.kernel_cache`).
"""

from __future__ import annotations

from collections import namedtuple

import numpy as np

# Neuron kinds.
KIND_CURR, KIND_COND, KIND_POISSON, KIND_ARRAY = 0, 1, 2, 3

# Columns of the neuron parameter table.
(
    C_V_REST,
    C_V_RESET,
    C_V_THRESH,
    C_I_OFFSET,
    C_P22,  # exp(-dt/tau_m)
    C_P20,  # (tau_m/cm)(1 - P22): i_offset -> v
    C_P11E,  # exp(-dt/tau_syn_E)
    C_P11I,
    C_P21E,  # I_E(t) -> v over one step (current-based)
    C_P21I,
    C_FE,  # mean of a decaying conductance over one step, relative to its start value
    C_FI,
    C_GL,  # leak conductance cm/tau_m
    C_CM,
    C_E_REV_E,
    C_E_REV_I,
    C_THETA_PLUS,
    C_THETA_DECAY,  # exp(-dt/tau_theta)
    C_P11CA,  # exp(-dt/tau_ca2)
    C_P21CA,  # I_ca2 -> v
    C_I_ALPHA,
    C_REFRAC,  # refractory steps (membrane held at v_reset)
    C_LOCK,  # steps after the refractory ones in which the membrane integrates but may not fire (tau_lockout)
    C_V_INIT,
    C_I_CA_INIT,
    N_COLS,
) = range(26)

# Columns that hold initial values, not parameters of the dynamics.
INIT_COLS = (C_V_INIT, C_I_CA_INIT)

# Columns of the group table, and the group flags.
G_LO, G_HI, G_KIND, G_FLAGS, N_GROUP_COLS = range(5)
#: The group receives inhibitory synapses (otherwise its inhibitory current stays 0).
F_INH = 1
#: The group has the Ca2+ adaptation current (otherwise it stays 0).
F_CA = 2
#: The group has an adaptive threshold.
F_ADAPTIVE = 4
#: The group takes forward-Euler membrane steps (``IF_cond_exp_adaptive(integration="euler")``).
F_EULER = 8

# Rule kinds and columns of the plasticity rule table.
RULE_ADDITIVE, RULE_MULTIPLICATIVE, RULE_DIEHL_COOK = 0, 1, 2
(R_KIND, R_POT, R_DEP, R_W_MIN, R_W_MAX, R_TAU_PRE, R_TAU_POST, R_MU, R_X_TAR, R_TAU_POST2, N_RULE_COLS) = range(11)


# Columns of the per-projection parameter table ``cv_par``.
CV_PRE0, CV_C, CV_H, CV_W, CV_O, CV_OH, CV_OW, CV_KH, CV_KW = range(9)
CV_SH, CV_SW, CV_PH, CV_PW, CV_POST0, CV_DELAY, CV_REC, CV_WOFF, N_CV_COLS = range(9, 18)

#: Static arrivals are tracked per block of ``1 << BLOCK_SHIFT`` consecutive neurons.
BLOCK_SHIFT = 6

# Codes of the recordable variables (the kernel's recording step switches on them).
VAR_V, VAR_EXC, VAR_INH, VAR_THETA, VAR_CA = range(5)
VAR_CODES = {
    "v": VAR_V,
    "isyn_exc": VAR_EXC,
    "gsyn_exc": VAR_EXC,
    "isyn_inh": VAR_INH,
    "gsyn_inh": VAR_INH,
    "theta": VAR_THETA,
    "i_ca2": VAR_CA,
}

NEVER = np.int64(2**62)

# The arrays the kernels work on, bundled by role (numba passes a tuple of arrays as one
# argument; the simulation builds them, see :meth:`.simulation.ReferenceSimulation._run`).
#: Neurons: groups of identical parameters (``G_*`` columns), the parameter table (``C_*``
#: columns), and the state: membrane, synaptic state ``isyn`` (``ie``, ``ii`` are its rows),
#: adaptive threshold, Ca2+ current, refractory counters, spike flags (one byte per neuron,
#: all 0 between steps; ``flag_words`` is the same memory as 64-bit words) and spike counts;
#: scratch for the conductance-based updates (neuron indices ``todo``, two float rows).
Neurons = namedtuple("Neurons", "groups params v isyn ie ii theta ica refr flag flag_words counts todo scratch")
#: The spike record: which neurons are recorded, the spike steps and neurons, the count.
SpikeRecord = namedtuple("SpikeRecord", "mask t i n")
#: Static delivery (:func:`.delivery.static_delivery`): segments per neuron, their synapses and neuron blocks.
StaticTables = namedtuple("StaticTables", "seg_ptr seg_start seg post w blk_ptr blk")
#: The ring of arrivals: static sums, their block marks (also as 64-bit words), the rows
#: holding marks and the neuron range convolutions reached per row; the plastic events per
#: slot, each three words (segment | projection << ``EV_SHIFT``, first synapse, end) and
#: their number per slot; room to list the synapses of a slot's short plastic events
#: (:func:`.kernel_plasticity.arrive_slot`).
Arrivals = namedtuple("Arrivals", "buf dirty dirty_words row_any row_range ev ev_n listed")
#: A plastic event's first word holds its segment in the low ``EV_SHIFT`` bits, its projection above.
EV_SHIFT = 40
EV_SEG = (1 << EV_SHIFT) - 1
#: Structured convolutions (:mod:`.convolution`): per-neuron entries, parameters, transposed kernels.
ConvTables = namedtuple("ConvTables", "index par w")
#: Plastic synapses: per neuron its outgoing segments; per segment its first synapse, delay
#: and projection; per synapse its target and weight; per neuron its incoming synapses (their
#: positions, segments, and the one rule they all follow or -1); per projection its receptor.
PlasticTables = namedtuple(
    "PlasticTables", "row_seg_ptr seg_start seg_delay seg_proj p_post p_w post_ptr post_syn post_seg post_rule proj_inh"
)
#: STDP: the rule table (``R_*`` columns) and presynaptic decay table; the presynaptic trace
#: per segment and its last arrival; the postsynaptic traces (per projection their range,
#: per neuron its traces) and their decays; scratch for one neuron's presynaptic traces.
Traces = namedtuple(
    "Traces",
    "rules pre_table seg_xpre seg_last tr_lo tr_hi tr_shift post_tr_ptr post_tr_idx trace_proj post_decay1 post_decay2 "
    "xpost1 xpost2 x_pre",
)
#: Spike sources: Poisson neurons (index, log(1 - p), next spike step, window) and their
#: generator; the spike array events (steps, neurons) and the next one to emit; the float
#: loop's heap of the Poisson sources by next step (steps, sources, size) and room for the due ones.
Sources = namedtuple(
    "Sources", "pois_idx pois_logq pois_next pois_start pois_end arr_step arr_neuron arr_ptr rng queue_t queue_k queue_n due"
)
#: Recorded state variables: neuron, variable code (``VAR_*``), and the output rows per step.
VarRecord = namedtuple("VarRecord", "idx code out")

# Indices of the activity counters.
ST_STEPS, ST_NEURON_UPDATES, ST_SPIKES, ST_SYN_EVENTS, ST_PLASTIC_UPDATES = range(5)
