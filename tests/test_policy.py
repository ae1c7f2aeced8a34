"""Policies: tables as numpy arrays, policy files (model §6), construction from tables."""

from __future__ import annotations

import json
import os
import pickle
import stat
from pathlib import Path

import numpy as np
import pytest

import cehmm


def assert_same_tables(a: dict, b: dict) -> None:
    assert a.keys() == b.keys()
    assert np.array_equal(a["h0"], b["h0"]) and np.array_equal(a["h1"], b["h1"])
    assert len(a["upper"]) == len(b["upper"])
    for x, y in zip(a["upper"], b["upper"]):
        assert np.array_equal(x["start"], y["start"]) and np.array_equal(x["step"], y["step"])


def write_policy(path: Path, mutate) -> Path:
    """A valid policy file for levels [4, 3] in case 1, changed by ``mutate(document)``."""
    document = json.loads(cehmm.Policy.uniform(cehmm.TargetTracking(case=1), [4, 3]).to_json())
    mutate(document)
    path.write_text(json.dumps(document))
    return path


def test_table_shapes_follow_spec_6(case3: cehmm.TargetTracking) -> None:
    policy = cehmm.Policy.uniform(case3, [5, 4, 3])
    tables = policy.tables
    assert set(tables) == {"h0", "h1", "upper"}
    assert tables["h0"].shape == (5, 16)  # (|M_1|, D)
    assert tables["h1"].shape == (16, 4, 5)  # (Y, |M_2|, |M_1|)
    assert [u["start"].shape for u in tables["upper"]] == [(3, 4), (1, 3)]  # (U, |M_l|)
    assert [u["step"].shape for u in tables["upper"]] == [(5, 3, 4), (4, 1, 3)]  # (|M_l-1|, U, |M_l|)
    for array in [tables["h0"], tables["h1"], *(a for u in tables["upper"] for a in u.values())]:
        assert isinstance(array, np.ndarray) and array.dtype == np.float64


def test_single_level_has_no_upper_tables(case2: cehmm.TargetTracking) -> None:
    tables = cehmm.Policy.uniform(case2, [16]).tables
    assert tables["h1"].shape == (1, 1, 16)
    assert tables["upper"] == []


def test_uniform_rows_are_uniform(case3: cehmm.TargetTracking) -> None:
    policy = cehmm.Policy.uniform(case3, [16, 2, 3])
    tables = policy.tables
    arrays = [tables["h0"], tables["h1"], *(a for u in tables["upper"] for a in u.values())]
    for array in arrays:
        assert np.all(array == 1.0 / array.shape[-1])
    assert policy.levels == [16, 2, 3]
    assert (policy.n_obs, policy.n_actions) == (16, 16)
    assert policy.world == case3.to_dict()


def test_random_rows_are_distributions_drawn_from_the_seed(case3: cehmm.TargetTracking) -> None:
    a = cehmm.Policy.random(case3, [6, 2], seed=3).tables
    assert_same_tables(a, cehmm.Policy.random(case3, [6, 2], seed=3).tables)
    assert not np.array_equal(a["h0"], cehmm.Policy.random(case3, [6, 2], seed=4).tables["h0"])
    assert np.allclose(a["h1"].sum(axis=-1), 1.0) and np.all(a["h1"] > 0)


@pytest.mark.parametrize(("levels", "count"), [([16, 16], 4320), ([16, 2, 2, 2], 758), ([16], 15 * 16 + 15 * 16)])
def test_parameter_count_is_the_papers(case3: cehmm.TargetTracking, levels: list[int], count: int) -> None:
    assert cehmm.Policy.uniform(case3, levels).parameter_count == count


def test_tables_are_copies(case1: cehmm.TargetTracking) -> None:
    policy = cehmm.Policy.uniform(case1, [4])
    policy.tables["h0"][:] = 0.0
    assert np.all(policy.tables["h0"] == 1.0 / 16)


def test_save_load_round_trip_is_exact(tmp_path: Path, trained: cehmm.OptimizeResult) -> None:
    policy = trained.policy
    path = tmp_path / "policy.json"
    policy.save(path)
    loaded = cehmm.Policy.load(path)
    assert_same_tables(policy.tables, loaded.tables)
    assert loaded.levels == policy.levels == [4, 3]
    assert loaded.world == policy.world
    assert loaded.provenance == policy.provenance
    loaded_str = cehmm.Policy.load(str(path))
    assert_same_tables(policy.tables, loaded_str.tables)


def test_file_is_the_documented_json(tmp_path: Path, trained: cehmm.OptimizeResult) -> None:
    path = tmp_path / "policy.json"
    trained.policy.save(path)
    document = json.loads(path.read_text())
    assert document["format"] == "cehmm-policy" and document["version"] == 1
    assert (document["n_obs"], document["n_actions"], document["levels"]) == (16, 16, [4, 3])
    assert document["world"]["name"] == "target-tracking" and document["world"]["case"] == 1
    assert np.array_equal(np.array(document["policy"]["h1"]), trained.policy.tables["h1"])
    provenance = document["provenance"]
    for key in ["seed", "samples", "rho", "alpha", "iterations", "mean_reward", "version"]:
        assert key in provenance
    assert provenance["seed"] == 7 and provenance["samples"] == 200


def test_json_text_and_pickle_round_trips(trained: cehmm.OptimizeResult) -> None:
    policy = trained.policy
    assert_same_tables(policy.tables, cehmm.Policy.from_json(policy.to_json()).tables)
    assert_same_tables(policy.tables, pickle.loads(pickle.dumps(policy)).tables)


def test_from_tables_round_trip(case1: cehmm.TargetTracking, trained: cehmm.OptimizeResult) -> None:
    tables = trained.policy.tables
    rebuilt = cehmm.Policy.from_tables(tables, world=case1, provenance={"note": "copy"})
    assert_same_tables(tables, rebuilt.tables)
    assert rebuilt.levels == [4, 3]
    assert rebuilt.world == case1.to_dict()
    assert rebuilt.provenance == {"note": "copy"}
    # Nested lists are accepted too; without a world the policy has none.
    as_lists = {
        "h0": tables["h0"].tolist(),
        "h1": tables["h1"].tolist(),
        "upper": [{k: v.tolist() for k, v in u.items()} for u in tables["upper"]],
    }
    bare = cehmm.Policy.from_tables(as_lists)
    assert_same_tables(tables, bare.tables)
    assert bare.world == {}


@pytest.mark.parametrize(
    ("mutate", "message"),
    [
        (lambda d: d["policy"].update(h0=[[1 / 16] * 16] * 3), r"policy\.h0 has length 3 \(expected 4\)"),
        (lambda d: d["policy"]["upper"][0].update(start=[[0.5, 0.5]]), r"policy\.upper\[0\]\.start\[0\] has length 2"),
        (lambda d: d["policy"]["h0"][2].__setitem__(0, -0.0625), r"h0\[2\]\[0\] = -0\.0625 .*>= 0"),
        (lambda d: d["policy"]["h1"][5][1].__setitem__(0, 0.5), r"row h1\[5\]\[1\] sums to 1\.25"),
        (
            lambda d: d["policy"]["upper"][0]["step"][3][0].__setitem__(2, 0.0),
            r"row upper\[0\]\.step\[3\]\[0\] sums to",
        ),
        (lambda d: d.update(format="something-else"), r"format"),
        (lambda d: d.update(version=2), r"version"),
        (lambda d: d["policy"].pop("h1"), r"policy\.h1 is missing"),
    ],
)
def test_load_rejects_bad_files_with_clear_messages(tmp_path: Path, mutate, message: str) -> None:
    path = write_policy(tmp_path / "bad.json", mutate)
    with pytest.raises(cehmm.PolicyFormatError, match=message) as error:
        cehmm.Policy.load(path)
    assert "bad.json" in str(error.value)


def test_load_ignores_unknown_keys(tmp_path: Path) -> None:
    path = write_policy(tmp_path / "extra.json", lambda d: d.update(comment="hello", policy={**d["policy"], "x": 1}))
    assert cehmm.Policy.load(path).levels == [4, 3]


def test_load_rejects_non_json_and_missing_files(tmp_path: Path) -> None:
    path = tmp_path / "text.json"
    path.write_text("not json")
    with pytest.raises(cehmm.PolicyFormatError, match="not JSON"):
        cehmm.Policy.load(path)
    with pytest.raises(FileNotFoundError) as error:
        cehmm.Policy.load(tmp_path / "missing.json")
    assert error.value.filename.endswith("missing.json")


def test_from_tables_names_the_table_and_its_expected_shape(case1: cehmm.TargetTracking) -> None:
    tables = cehmm.Policy.uniform(case1, [4, 3]).tables
    wrong = {**tables, "h1": tables["h1"][:, :2, :]}
    with pytest.raises(cehmm.PolicyFormatError, match=r"h1 has shape \(16, 2, 4\) \(expected \(16, 3, 4\)\)"):
        cehmm.Policy.from_tables(wrong)
    wrong = {**tables, "upper": [{"start": tables["upper"][0]["start"], "step": np.full((4, 3), 1 / 3)}]}
    with pytest.raises(cehmm.PolicyFormatError, match=r"upper\[0\]\.step has shape \(4, 3\)"):
        cehmm.Policy.from_tables(wrong)
    with pytest.raises(cehmm.PolicyFormatError, match="h0 is missing"):
        cehmm.Policy.from_tables({"h1": tables["h1"]})


def test_from_tables_rejects_bad_rows(case1: cehmm.TargetTracking) -> None:
    tables = cehmm.Policy.uniform(case1, [4]).tables
    tables["h0"][1, :2] = [np.nan, 2 / 16]
    with pytest.raises(cehmm.PolicyFormatError, match=r"h0\[1\]\[0\] = NaN"):
        cehmm.Policy.from_tables(tables)


def test_from_tables_checks_the_world(case1: cehmm.TargetTracking, case2: cehmm.TargetTracking) -> None:
    tables = cehmm.Policy.uniform(case1, [4]).tables
    with pytest.raises(cehmm.PolicyMismatchError):
        cehmm.Policy.from_tables(tables, world=case2)


def test_evaluate_summarises_fresh_episodes(trained: cehmm.OptimizeResult, case1: cehmm.TargetTracking) -> None:
    evaluation = trained.policy.evaluate(case1, episodes=300, seed=1)
    assert isinstance(evaluation, cehmm.Evaluation)
    assert evaluation.episodes == 300
    assert evaluation.min <= evaluation.quantiles[0.5] <= evaluation.max
    assert set(evaluation.quantiles) == {0.05, 0.25, 0.5, 0.75, 0.95}
    assert evaluation.std_error == pytest.approx(evaluation.std / np.sqrt(300))
    assert 0 <= evaluation.min and evaluation.max <= 100
    # Reproducible whatever the thread count; the stored world is the default.
    assert trained.policy.evaluate(case1, episodes=300, seed=1, threads=1) == evaluation
    assert trained.policy.evaluate(episodes=300, seed=1, threads=2) == evaluation
    assert "Evaluation(mean=" in repr(evaluation)


def test_policy_for_case_2_does_not_fit_case_3(case2: cehmm.TargetTracking, case3: cehmm.TargetTracking) -> None:
    policy = cehmm.Policy.uniform(case2, [16, 16])
    with pytest.raises(cehmm.PolicyMismatchError, match="1 observations"):
        policy.evaluate(case3, episodes=10)
    with pytest.raises(cehmm.PolicyMismatchError):
        policy.rollout(case3)


def test_repr_is_readable(trained: cehmm.OptimizeResult) -> None:
    text = repr(trained.policy)
    assert text.startswith("Policy(levels=[4, 3]") and "case 1" in text and "mean_reward=" in text


def test_odd_policy_files_are_format_errors_never_panics(tmp_path, case1) -> None:
    good = json.loads(cehmm.Policy.uniform(case1, [2]).to_json())
    for key, value in [("format", "é" * 50), ("version", "ü" * 60), ("format", ["x"] * 30)]:
        path = tmp_path / f"{key}.json"
        path.write_text(json.dumps({**good, key: value}), encoding="utf-8")
        with pytest.raises(cehmm.PolicyFormatError, match=key):
            cehmm.Policy.load(path)
    path = tmp_path / "latin1.json"
    path.write_bytes(json.dumps(good).encode().replace(b'"levels"', b'"l\xe9vels"'))
    with pytest.raises(cehmm.PolicyFormatError, match="not UTF-8"):
        cehmm.Policy.load(path)


def test_saving_never_replaces_what_is_not_a_regular_file(tmp_path, case1) -> None:
    policy = cehmm.Policy.uniform(case1, [2])
    with pytest.raises(cehmm.InvalidArgumentError, match="is a directory"):
        policy.save(tmp_path)
    if os.path.exists("/dev/null"):
        with pytest.raises(cehmm.InvalidArgumentError, match="not a regular file"):
            policy.save("/dev/null")
        assert stat.S_ISCHR(os.stat("/dev/null").st_mode)
    real = tmp_path / "real.json"
    policy.save(real)
    link = tmp_path / "link.json"
    link.symlink_to("real.json")
    cehmm.Policy.uniform(case1, [3]).save(link, overwrite=True)
    assert link.is_symlink() and cehmm.Policy.load(real).levels == [3]
    assert sorted(p.name for p in tmp_path.iterdir()) == ["link.json", "real.json"]


def test_unknown_keys_are_skipped_however_large(tmp_path, case1) -> None:
    doc = json.loads(cehmm.Policy.uniform(case1, [2]).to_json())
    doc["padding"] = {"notes": ["x" * 1000] * 5000, "deep": [[[1, 2, 3]] * 100] * 100}
    path = tmp_path / "padded.json"
    path.write_text(json.dumps(doc))
    loaded = cehmm.Policy.load(path)
    assert loaded.levels == [2] and "padding" not in json.loads(loaded.to_json())
    assert cehmm.Policy.from_json(json.dumps(doc)).levels == [2]
    with pytest.raises(cehmm.PolicyFormatError, match="expected an object"):
        cehmm.Policy.from_json("[1, 2]")
    with pytest.raises(cehmm.PolicyFormatError, match="not JSON"):
        cehmm.Policy.from_json('{"format": ')


def test_a_policy_file_with_an_invalid_world_is_refused_when_loaded(tmp_path, case1) -> None:
    doc = json.loads(cehmm.Policy.uniform(case1, [2]).to_json())
    for world, named in [
        ({**doc["world"], "speed": 3}, 'unknown parameter "speed"'),
        ({**doc["world"], "case": "3"}, "case"),
        ({**doc["world"], "name": "cart-pole"}, "cart-pole"),
        ({"case": 1}, "world.name"),
    ]:
        path = tmp_path / "w.json"
        path.write_text(json.dumps({**doc, "world": world}))
        with pytest.raises(cehmm.PolicyFormatError, match=named):
            cehmm.Policy.load(path)
    # A policy without a world still loads (its world is given when it is used).
    path.write_text(json.dumps({**doc, "world": {}}))
    assert cehmm.Policy.load(path).world == {}
