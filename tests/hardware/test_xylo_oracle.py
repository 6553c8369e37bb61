"""The Xylo checker against Rockpool's own Xylo Audio 2 mapper and XyloSim, network by network.

For each network, neurovpr's verdict, the hardware neuron ids it assigns to each
population and the limit it names agree with what Rockpool's mapper (and XyloSim, for
weights) says. The networks sit just inside and just outside each limit.
"""

from __future__ import annotations

import pytest

from neurovpr.errors import BackendUnavailableError
from neurovpr.hardware import check_network

try:
    from neurovpr.backends.xylo.compat import import_xylo

    import_xylo()
except BackendUnavailableError as exc:  # pragma: no cover - depends on the install
    pytest.skip(f"Rockpool/XyloSim not importable: {exc}", allow_module_level=True)

from synsense_oracles import rockpool_xylo, xylo_chain

CASES = {
    # name: (network, limit neurovpr and Rockpool must both name, or None when it fits)
    "fits_16_in_8_out": (xylo_chain(16, [40], 8), None),
    "fits_1000_hidden_two_layers": (xylo_chain(16, [600, 400], 8), None),
    "fits_recurrent": (xylo_chain(8, [30, 20], 4, recurrent=(0,)), None),
    "fits_recurrent_both": (xylo_chain(4, [12, 10], 2, recurrent=(0, 1)), None),
    "fits_weight_extremes": (xylo_chain(4, [10], 2, extreme=-128.0), None),
    "too_many_inputs": (xylo_chain(17, [20], 4), "input channels"),
    "too_many_outputs": (xylo_chain(8, [20], 9), "output neurons"),
    "too_many_hidden": (xylo_chain(8, [600, 401], 4), "hidden neurons"),
    "too_many_hidden_one_layer": (xylo_chain(8, [1001], 4), "hidden neurons"),
    "recurrent_output": (xylo_chain(4, [10], 3, out_recurrent=True), "recurrent output"),
    "weight_above_int8": (xylo_chain(4, [10], 2, extreme=128.0), "weight range"),
}


@pytest.mark.parametrize("case", sorted(CASES))
def test_xylo_verdict_assignment_and_limit_agree_with_rockpool(case):
    network, limit = CASES[case]
    report = check_network(network, "xylo")
    oracle = rockpool_xylo(network)
    assert oracle.refused == limit, oracle.message
    assert report.fits == (limit is None)
    if limit is not None:
        assert limit in {v.limit for v in report.partition.violations}, report.table()
    if oracle.first_id:
        mine = {c.population: c.location[0] for c in report.partition.cores}
        assert mine == oracle.first_id


def test_xylo_check_names_the_limit_in_one_sentence():
    report = check_network(xylo_chain(17, [20], 9), "xylo")
    messages = {v.limit: v.message for v in report.partition.violations}
    assert set(messages) == {"input channels", "output neurons"}
    assert "17 input channels" in messages["input channels"] and "up to 16" in messages["input channels"]
    assert all(m.count(". ") == 0 and m.endswith(".") for m in messages.values())
