"""Modular SNN and Ensembles of Modular SNNs (Hussaini, Milford & Fischer, IEEE T-RO 2024).

- :mod:`.network` -- the graph of one module
- :mod:`.training` -- training one module, presenting images
- :mod:`.inference` -- assignment, hyperactive neurons, fusion, ensembles
- :mod:`.anatomy` -- the neurons behind each place's score, and behind the most-chosen places
- :mod:`.deployment` -- the current-based approximation for backends without conductance synapses
- :mod:`.parallel` -- process pool / Dask execution of module jobs
- :mod:`.plan` -- the plan: places split into modules, calibration places and queries
- :mod:`.runs` -- run directories: training with resume, query responses, similarities
- :mod:`.report` -- metrics at several sequence lengths and plots
- :mod:`.plugin` -- ``neurovpr train/eval --model modular``; :data:`MODEL` is its entry point

Where the paper's text and the authors' published code (QVPR/VPRSNN, branches main,
modularSNN, Ens_seq) differ, the defaults follow the code; each choice, with the option
that gives the paper's text where a user may want it:

- excitatory neurons: membrane clamped 5 ms, no spike for 50 ms (``timer > refrac_e``,
  ``dtimer/dt = 0.1``); paper: 5 ms refractory (``ModuleParameters(lockout_e=0)``).
- learning rule: triplet STDP, potentiating at a presynaptic arrival (``w += nu_pre *
  post1``), ``w += nu_post * pre * post2_before`` at a postsynaptic spike, traces set to 1;
  paper: depression at a presynaptic spike, ``(w_max - w)^mu`` at a postsynaptic one
  (``--stdp paper``).
- presentation order: one random order per module, repeated every epoch; paper: not stated.
- assignment: from the spike counts of the last 250 training presentations, while
  learning (``--update_interval``); paper: after training (``--assignment-presentations``
  sets the window). A neuron that fired equally for several places goes to the one shown
  first in training (the code's ``get_new_assignments``); paper: not stated.
- place score: spikes of a place's neurons divided by all neurons assigned to it,
  hyperactive ones zeroed but counted (the "standard" assignment); paper: the sum
  (``--place-score sum``).
- hyperactive neurons: reference images a neuron fired for, threshold chosen from 0, 5,
  10, 20, 40, ..., 200 by Recall@1 on calibration places held out of the reported ones
  (VPRSNN's calibrate mode); paper: total spikes against a threshold drawn from U(40, 100)
  or U(600, 800) (``--hyperactive spikes --theta VALUE`` fixes a threshold instead).
  The code leaves the choice to its user; here ties go to the stricter threshold, 0 (none
  hyperactive) last (:func:`.inference.best_threshold`).
- places of a module: a random split per member (VPRSNN's ``get_shuffled_indices``,
  calibration places drawn with seed 42); paper: geographically separate regions
  (``--place-order route``).
- hyperactive activity counted over the first reference traverse (the code's record mode).
- ensemble: sum of the members' standard-scored similarity matrices (``ens_seq/process_ensembles.py``).
- weights above ``w_max`` after the per-image normalisation are clipped at once (the code
  clips them at the synapse's next update).

- recurrent synapses: E->I and I->E without delay, as the code's Brian2 synapses (zero-delay
  synapses, docs/semantics.md), so the inhibition loop closes in two steps as there; with a
  delay of one step each (``ModuleParameters(delay_recurrent=dt)``) it takes four and the
  excitatory layer fires about 1.5 times as often per image as the code's; paper: not stated.
- time step: 0.1 ms, Brian2's default in the code, so the loop closes in 0.2 ms; at 0.5 ms
  (``--dt 0.5``, cheaper) it closes in 1 ms, and with the 50 ms lockout every neuron then
  fires at the lockout's pace (about 7 spikes per image instead of about 1, all neurons of a
  module on one place; ``tests/models/test_modular_snn_statistics.py``); paper: not stated.
- integration: forward-Euler steps of every cell variable, as the code's ``method='euler'``
  (``IF_cond_exp(integration="euler")``); paper: not stated (``--integration exact``, the
  exact step, fires 10-13 % more often per image than the code, see :mod:`.network`); the
  150 ms rest after each image is replaced by a reset of the state (``--simulate-rest``
  simulates it).

Not reproduced: the code's evaluation gives a row only to the labels some neuron holds
(-1, unassigned, included), here every place has a row and one without neurons scores 0.
Random draws: the code seeds NumPy and Brian2 with the member's seed at the start of every
module step (``non_modular_snn/snn_model.py``), so all modules of a member start from the same
input weights and delays and receive the same Poisson streams; by default each module here draws
its own from its seed (:func:`.training.derive_seed`), ``--seeding code`` draws as the code does
(:mod:`.plan`); measured on 150 places it brings the ensembles no closer to the code's (README),
so it is not the default.

Epochs: the published code trains one epoch count per run, 30 in its Nordland configuration,
the default here (``--epochs``); the authors' README calls the count a hyperparameter chosen
on the calibration data, and their released Nordland members (trained on two reference
traverses) use 60 and 70. A member trained with several counts takes the count and threshold
with the best calibration Recall@1 (:func:`.inference.calibrate_epochs`;
``benchmarks/modular_snn_nordland.py --epochs 20,30,60``).
"""

from .anatomy import hub_anatomy, place_anatomy
from .inference import (
    THRESHOLDS,
    assign_neurons,
    best_threshold,
    calibrate_epochs,
    calibrate_threshold,
    ensemble_similarity,
    fuse_modules,
    hyperactive_neurons,
    module_similarity,
    reference_activity,
)
from .network import ModuleParameters, build_module
from .plan import make_plan
from .plugin import MODEL, ModularSNNPlugin
from .runs import MemberSimilarities, member_similarities, query_responses, record_assignments, train_run
from .training import TrainingSettings, derive_seed, presentation_order, train_module

__all__ = [
    "MODEL",
    "THRESHOLDS",
    "MemberSimilarities",
    "ModularSNNPlugin",
    "ModuleParameters",
    "TrainingSettings",
    "assign_neurons",
    "best_threshold",
    "build_module",
    "calibrate_epochs",
    "calibrate_threshold",
    "derive_seed",
    "ensemble_similarity",
    "fuse_modules",
    "hub_anatomy",
    "hyperactive_neurons",
    "make_plan",
    "member_similarities",
    "module_similarity",
    "place_anatomy",
    "presentation_order",
    "query_responses",
    "record_assignments",
    "reference_activity",
    "train_module",
    "train_run",
]
