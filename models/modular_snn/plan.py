"""How a Modular SNN run splits its places into modules: the plan, calibration places and queries.

Plan. Each of the ``M`` members cuts the ``R`` reference places into modules of
``module_size`` places. ``place_order="shuffled"`` (default) is VPRSNN's split
(``tools/snn_model_utils.py: get_shuffled_indices``): ``n_calibration`` calibration
places, the first of a permutation drawn with seed 42 (the same for every member), in
an order shuffled with the member's seed, then the other places in an order shuffled
with it, so each member has its own random split of places into modules (the diversity
the ensemble relies on); modules take consecutive runs of that list, calibration places
and reported places never in one module. ``"route"`` takes the calibration places (the
same set) and the other places in route order (geographically contiguous regions).
When a part is not a multiple of ``module_size`` its remainder forms a last, smaller
module. Member ``m``'s split is drawn with ``derive_seed(seed, m, 1)``.

Seeds (``seeding``). Module ``k`` of member ``m`` has its own seed
``derive_seed(seed, m, 0, k)``, which always draws its presentation order. With
``seeding="module"`` (the default) it also draws the module's initial weights and
delays and its Poisson input spikes, so no two modules share any random draw.
``seeding="code"`` seeds as VPRSNN does: ``non_modular_snn/snn_model.py`` calls
``np.random.seed(args.seed)`` and ``b2.seed(args.seed)`` at the start of every module step
and then draws the input weights with NumPy (``np.random.random((n_input, n_e)) + 0.01``,
times 0.3, in training mode; the files of ``tools/random_connection_generator.py`` are not
read for them), the input delays with Brian2's ``rand()`` and the Poisson spikes with
Brian2's generator. So all modules of a member start from the same input weights and
delays and receive the same Poisson streams, and members differ in all three: here the
weights come from ``derive_seed(seed, m, 3)`` and the delays and Poisson spikes from
``derive_seed(seed, m, 2)``, for every module of member ``m``. For the queries, every
module of a member sees the same input spikes.

Calibration and reported places. The calibration modules and the calibration queries
(queries whose matches are all calibration places) choose each member's hyperactive
threshold (:func:`.inference.calibrate_threshold`, as the code's ``calibrate`` mode);
the other modules, places and queries are the ones evaluated and reported, as the code's
``test`` mode (:func:`.runs.member_similarities`). Without calibration places (or with a fixed
``theta``) nothing is calibrated and every place is reported.
"""

from __future__ import annotations

import math
from dataclasses import dataclass
from typing import Any

import numpy as np

import neurovpr as nv

from .training import derive_seed, module_seeds

__all__ = [
    "ModulePlan",
    "PLACE_ORDERS",
    "SEEDINGS",
    "query_seed",
    "place_split",
    "calibration_places",
    "default_calibration_places",
    "split_queries",
    "make_plan",
    "describe_plan",
]

PLACE_ORDERS = ("shuffled", "route")
#: How modules draw their random numbers (see the module docstring).
SEEDINGS = ("module", "code")
#: The seed of VPRSNN's draw of the calibration places (the same for every member).
_CALIBRATION_SEED = 42


@dataclass(frozen=True, slots=True)
class ModulePlan:
    """One module job: which member and module, its name, places and seeds, and whether it calibrates.

    ``seed`` draws the presentation order; ``network_seed`` the initial weights;
    ``stream_seed`` the input delays and Poisson spikes (``None``: everything from ``seed``,
    as ``seeding="module"``).
    """

    member: int
    module: int
    places: np.ndarray
    seed: int
    calibration: bool = False
    network_seed: int | None = None
    stream_seed: int | None = None

    @property
    def seeds(self) -> dict[str, int]:
        """The seeds a record and ``run.json`` store: ``seed``, ``network_seed``, ``stream_seed``."""
        network_seed, stream_seed = module_seeds(self.seed, self.network_seed, self.stream_seed)
        return {"seed": int(self.seed), "network_seed": network_seed, "stream_seed": stream_seed}

    @property
    def apart_seeds(self) -> tuple[int, ...]:
        """``(network_seed, stream_seed)`` when they are drawn apart from ``seed`` (``seeding="code"``), else ``()``."""
        if self.network_seed is None and self.stream_seed is None:
            return ()
        return module_seeds(self.seed, self.network_seed, self.stream_seed)

    @property
    def name(self) -> str:
        """File stem, ``m<member>_k<module>``."""
        return f"m{self.member:02d}_k{self.module:03d}"


def calibration_places(n_places: int, n_calibration: int) -> np.ndarray:
    """The calibration places, sorted: the first ``n_calibration`` of VPRSNN's seed-42 permutation."""
    n, c = int(n_places), int(n_calibration)
    if not 0 <= c < n:
        raise nv.ValidationError(f"calibration places: {c} of {n} places, expected 0..{n - 1}.")
    return np.sort(np.random.RandomState(_CALIBRATION_SEED).permutation(n)[:c])


def default_calibration_places(n_places: int, module_size: int) -> int:
    """About 20 % of the places in whole modules (VPRSNN: 600 of 3,300), none below three modules' worth."""
    n_cal = int(module_size) * math.floor(0.2 * int(n_places) / int(module_size) + 0.5)
    return n_cal if n_cal < int(n_places) and int(n_places) >= 3 * int(module_size) else 0


def place_split(n_places: int, n_calibration: int, seed: int) -> tuple[np.ndarray, np.ndarray]:
    """VPRSNN's ``get_shuffled_indices``: the calibration places and the other places, each in a shuffled order.

    Draws as that function does: the calibration places from a permutation with seed 42,
    then, from one generator seeded with ``seed``, a shuffle of them, a permutation of
    every place (which only advances the generator) and a shuffle of the other places.
    """
    cal = np.random.RandomState(_CALIBRATION_SEED).permutation(int(n_places))[: int(n_calibration)]
    rng = np.random.RandomState(int(seed))
    rng.shuffle(cal)
    rest = np.setdiff1d(rng.permutation(int(n_places)), cal)
    rng.shuffle(rest)
    return cal, rest


def make_plan(
    n_places: int,
    module_size: int,
    members: int,
    seed: int,
    place_order: str = "shuffled",
    n_calibration: int = 0,
    seeding: str = "module",
) -> list[ModulePlan]:
    """Every module of every member, member-major: calibration modules first (see the module docstring)."""
    if seeding not in SEEDINGS:
        raise nv.ValidationError(f"seeding is {seeding!r}, expected one of {', '.join(SEEDINGS)}.")
    if int(n_places) < 1:
        raise nv.ValidationError(f"the reference set has {n_places} places, expected at least 1.")
    if not 1 <= int(members) <= 100:
        raise nv.ValidationError(f"ensemble size is {members}, expected 1..100 members.")
    if place_order not in PLACE_ORDERS:
        raise nv.ValidationError(f"place order is {place_order!r}, expected one of {', '.join(PLACE_ORDERS)}.")
    cal_set = calibration_places(n_places, n_calibration)
    plan = []
    for m in range(int(members)):
        if place_order == "shuffled":
            cal, rest = place_split(n_places, n_calibration, derive_seed(seed, m, 1))
        else:
            cal, rest = cal_set, np.setdiff1d(np.arange(n_places), cal_set)
        chunks = [(cal[i : i + module_size], True) for i in range(0, cal.size, module_size)]
        chunks += [(rest[i : i + module_size], False) for i in range(0, rest.size, module_size)]
        shared = (derive_seed(seed, m, 3), derive_seed(seed, m, 2)) if seeding == "code" else (None, None)
        for k, (places, calibrates) in enumerate(chunks):
            plan.append(
                ModulePlan(
                    member=m, module=k, places=np.sort(places), seed=derive_seed(seed, m, 0, k), calibration=calibrates,
                    network_seed=shared[0], stream_seed=shared[1],
                )
            )
    return plan


def query_seed(module: dict[str, Any], run_seed: int = 0) -> int:
    """The Poisson seed of a module's queries, from its ``run.json`` entry.

    ``derive_seed(stream_seed, 2)`` (``stream_seed``: the module's own seed when the entry
    has none, as in runs written before it existed); a nonzero ``run_seed`` (``neurovpr
    compare --seed``) draws other input spikes, ``derive_seed(stream_seed, 2, run_seed)``.
    With ``seeding="code"`` every module of a member gets the same seed.
    """
    stream = int(module.get("stream_seed", module["seed"]))
    return derive_seed(stream, 2) if int(run_seed) == 0 else derive_seed(stream, 2, int(run_seed))


def describe_plan(n_places: int, module_size: int, n_calibration: int = 0) -> str:
    """One sentence: how the places split into modules (naming a smaller last module and the calibration part)."""

    def part(n: int) -> str:
        full, rest = divmod(int(n), int(module_size))
        if rest == 0:
            return f"{n} places in {full} module(s) of {module_size}"
        if full == 0:
            return f"{n} places in 1 module of {rest} (fewer than the module size {module_size})"
        return (
            f"{n} places in {full} module(s) of {module_size} and a last, smaller module of {rest} "
            f"({n} is not a multiple of {module_size})"
        )

    if not n_calibration:
        return part(n_places)
    return f"{part(int(n_places) - int(n_calibration))}, reported; {part(n_calibration)}, for calibration"


def split_queries(ground_truth: Any, calibration: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
    """``(calibration queries, reported queries)``: a query with matches, all among the calibration places, calibrates."""
    matrix = np.asarray(getattr(ground_truth, "matrix", ground_truth), dtype=bool)
    in_cal = np.zeros(matrix.shape[0], dtype=bool)
    in_cal[np.asarray(calibration, dtype=np.int64)] = True
    has = matrix.any(axis=0)
    only_cal = has & ~(matrix & ~in_cal[:, None]).any(axis=0)
    return np.flatnonzero(only_cal), np.flatnonzero(~only_cal)
