"""Modular SNN seeding: every module its own random draws, or the authors' code's (one set per member)."""

from __future__ import annotations

import json
from pathlib import Path

import numpy as np
import pytest
from modular_tiny import TINY, synthetic_dataset, tiny_images

import neurovpr as nv
from neurovpr.models.modular_snn import MODEL, derive_seed, make_plan, query_responses, train_module, train_run
from neurovpr.models.modular_snn.parallel import read_npz
from neurovpr.models.modular_snn.plan import query_seed


def test_code_seeding_gives_every_module_of_a_member_the_same_weights_delays_and_streams() -> None:
    plan = make_plan(110, 25, members=3, seed=4, seeding="code")
    # VPRSNN: np.random.seed(args.seed) and b2.seed(args.seed) at the start of every module step of a member
    weights = {m: {p.network_seed for p in plan if p.member == m} for m in range(3)}
    streams = {m: {p.stream_seed for p in plan if p.member == m} for m in range(3)}
    assert all(len(s) == 1 for s in (*weights.values(), *streams.values()))
    firsts = [next(iter(s)) for s in (*weights.values(), *streams.values())]
    assert len(set(firsts)) == 6  # members differ in both, and weights and streams are drawn apart
    assert len({p.seed for p in plan}) == len(plan)  # the presentation order stays the module's own
    assert plan[0].apart_seeds == (plan[0].network_seed, plan[0].stream_seed)
    # the default draws everything from the module's seed, as before the option existed
    own = make_plan(110, 25, members=3, seed=4)
    assert [p.seeds for p in own] == [{"seed": p.seed, "network_seed": p.seed, "stream_seed": p.seed} for p in own]
    assert all(p.apart_seeds == () for p in own)  # nothing joins the fingerprint: older runs stay resumable
    assert [p.places.tolist() for p in own] == [p.places.tolist() for p in plan]  # the split does not depend on it
    with pytest.raises(nv.ValidationError, match="seeding is 'brian2'"):
        make_plan(110, 25, members=1, seed=0, seeding="brian2")


def test_query_seed_comes_from_the_stream_seed_and_old_entries_keep_theirs() -> None:
    assert query_seed({"seed": 11}) == derive_seed(11, 2)  # a run.json written before stream seeds existed
    assert query_seed({"seed": 11, "stream_seed": 11}) == derive_seed(11, 2)
    assert query_seed({"seed": 11, "stream_seed": 30}) == derive_seed(30, 2)
    assert query_seed({"seed": 11, "stream_seed": 30}, 7) == derive_seed(30, 2, 7) != derive_seed(30, 2)


def test_train_module_draws_weights_from_one_seed_and_delays_and_spikes_from_the_other() -> None:
    ref = tiny_images(2, seed=1)
    place = np.array([0])  # one place: the presentation order (from ``seed``) cannot differ

    def trained(seed: int, network_seed: int | None, stream_seed: int | None) -> tuple[np.ndarray, ...]:
        net, _, responses, _ = train_module(ref, place, TINY, seed, network_seed=network_seed, stream_seed=stream_seed)
        syn = net.projections["pixels->exc"].synapse
        return np.asarray(syn.weight), np.asarray(syn.delay), responses

    a = trained(1, 7, 8)
    b = trained(2, 7, 8)  # another module seed, the same shared seeds: the same module
    for x, y in zip(a, b, strict=True):
        np.testing.assert_array_equal(x, y)
    other_stream, other_weights = trained(1, 7, 9), trained(1, 6, 8)
    assert not np.array_equal(a[0], other_stream[0])  # other Poisson spikes, other learned weights
    assert not np.array_equal(a[1], other_stream[1])  # ... and other delays (the code draws them with Brian2)
    np.testing.assert_array_equal(a[1], other_weights[1])  # other initial weights, the same delays
    assert not np.array_equal(a[0], other_weights[0])
    # without shared seeds everything comes from the module's seed, weights and delays from one generator
    own = trained(1, None, None)
    start = TINY.network("m", 1).projections["pixels->exc"].synapse
    np.testing.assert_array_equal(own[1], np.asarray(start.delay))
    assert not np.array_equal(own[1], trained(1, 1, 1)[1])


def test_a_code_seeded_run_stores_its_seeds_resumes_and_refuses_the_other_seeding(tmp_path: Path) -> None:
    ref, query = tiny_images(6, seed=1), tiny_images(6, seed=2)
    kw = {"members": 2, "seed": 5, "workers": 1, "progress": False}
    part = train_run(tmp_path / "run", ref, TINY, seeding="code", max_modules=1, **kw)
    assert not part["complete"]
    done = train_run(tmp_path / "run", ref, TINY, seeding="code", resume=True, **kw)
    assert done["complete"] and done["skipped_finished"] == 1 and done["trained_now"] == 3
    info = json.loads((tmp_path / "run" / "run.json").read_text())
    assert info["seeding"] == "code"
    plan = make_plan(6, TINY.module_size, 2, 5, seeding="code")
    assert [{k: m[k] for k in ("seed", "network_seed", "stream_seed")} for m in info["modules"]] == [p.seeds for p in plan]
    for mod in info["modules"]:
        record = read_npz(tmp_path / "run" / "modules" / f"{mod['name']}.npz")
        assert (int(record["network_seed"]), int(record["stream_seed"])) == (mod["network_seed"], mod["stream_seed"])
    by_member = {m: {query_seed(mod) for mod in info["modules"] if mod["member"] == m} for m in (0, 1)}
    assert all(len(s) == 1 for s in by_member.values()) and by_member[0] != by_member[1]
    counts = query_responses(tmp_path / "run", info, query, workers=1, progress=False)
    assert set(counts) == {mod["name"] for mod in info["modules"]}
    with pytest.raises(nv.ValidationError, match="other settings"):
        train_run(tmp_path / "run", ref, TINY, resume=True, **kw)  # per-module seeding: other modules


def test_the_command_line_trains_with_the_codes_seeding(tmp_path: Path) -> None:
    from neurovpr.cli.train_cmd import train_request

    data = synthetic_dataset(tmp_path, 4)
    argv = ["--model", "modular", "--data", str(data), "--out", str(tmp_path / "run"), "--seed", "3", "--members", "2",
            "--epochs", "1", "--module-size", "2", "--neurons", "10", "--workers", "1", "--no-progress",
            "--seeding", "code"]  # fmt: skip
    assert MODEL.train(train_request(MODEL, argv)[1])["complete"]
    info = json.loads((tmp_path / "run" / "run.json").read_text())
    assert info["seeding"] == "code" and len({m["network_seed"] for m in info["modules"]}) == 2  # one per member
    with pytest.raises(SystemExit) as bad:
        train_request(MODEL, [*argv[:-1], "brian2"])
    assert bad.value.code == 2
