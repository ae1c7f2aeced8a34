"""Property tests of the encodings of Gymnasium spaces (Hypothesis, issue 45): spaces of every
kind (Discrete, MultiDiscrete, MultiBinary, Box of every dtype and of no dimension, Tuples of
them, and the kinds no encoding takes: Dict, Text, Sequence, Graph, OneOf), sizes from one to
past 4300 digits, encodings asked with arguments of every kind (Bins' bins, edges, fit, warm-up
and seed; Grid's values; Hashed's size), warm-ups with values beside the space, values inside
and beside each space, and the records a policy file holds of them, edited. An encoding is
either made, of 1 to 65535 indices (a flattening: to 2**63 - 1), or refused with
:class:`cehmm.InvalidArgumentError` (``TypeError`` for a choice that is no encoding,
:class:`cehmm.WorldError` for a warm-up value beside the space) in a second and without building
what it refuses; a made one takes every value of its space (and only those) to an index in
range, answers values of its space, and reads back from its record the same; an edited record
is read or refused with :class:`cehmm.PolicyFormatError`. Never another exception.

Example counts: conftest.py's profiles (``HYPOTHESIS_PROFILE=long``; ``SPACES_FUZZ_STATS=1``
prints what the examples tried and what came of them)."""

from __future__ import annotations

import collections
import copy
import json
import os
import time
from typing import Any

import gymnasium as gym
import numpy as np
import pytest
from gymnasium import spaces
from hypothesis import event, given
from hypothesis import strategies as st

import cehmm
from cehmm.encoded import from_record, policy_encodings
from cehmm.spaces import Bins, Flat, Grid, Hashed, encoding

#: What the examples came to, by test (printed at the end with SPACES_FUZZ_STATS=1).
OUTCOMES: dict[str, collections.Counter[str]] = collections.defaultdict(collections.Counter)

FLOATS = [np.float16, np.float32, np.float64]
INTEGERS = [np.int8, np.uint8, np.int16, np.int64]


def _refusal(message: str) -> str:
    """What a refusal named: the space, the encoding's arguments, or the encoding of the space."""
    named = message.split(":")[0]
    if named.startswith(("invalid Bins", "invalid Grid", "invalid Hashed")):
        return "its arguments"
    return "the space" if named.endswith("space") else "the encoding for the space"


def _tally(test: str, outcome: str) -> None:
    OUTCOMES[test][outcome] += 1
    event(outcome)


@pytest.fixture(scope="module", autouse=True)
def _print_stats() -> Any:
    yield
    if os.environ.get("SPACES_FUZZ_STATS"):
        for test, counts in OUTCOMES.items():
            print(f"\n{test}: {sum(counts.values())} examples: {dict(counts.most_common())}")


@st.composite
def boxes(draw: st.DrawFn) -> spaces.Box:
    """Boxes of every dtype, of 0 to 3 dimensions (now and then an image's), bounded or not."""
    shape = draw(
        st.one_of(
            st.lists(st.integers(0, 4), max_size=3).map(tuple),
            st.sampled_from([(84, 84, 3), (20,), (1, 17)]),
        )
    )
    dtype = np.dtype(draw(st.sampled_from([*FLOATS, *INTEGERS, np.bool_])))
    if dtype.kind == "b":
        return spaces.Box(np.zeros(shape, dtype=dtype), np.ones(shape, dtype=dtype), shape=shape, dtype=dtype)
    if dtype.kind == "f":
        finite = st.floats(-1e4, 1e4, width=16)
        bound = st.one_of(finite, st.sampled_from([np.inf, -np.inf])) if draw(st.booleans()) else finite
    else:
        info = np.iinfo(dtype)
        bound = st.integers(max(int(info.min), -1000), min(int(info.max), 1000))
    # Bounds of each value (one pair for them all in a large Box), each pair sorted, never both
    # infinite of one sign.
    size = int(np.prod(shape))
    pairs = (
        draw(st.lists(st.tuples(bound, bound), min_size=size, max_size=size))
        if size <= 8
        else [draw(st.tuples(bound, bound))] * size
    )
    # (+ 0: no bound -0.0, whose Box(0.0, -0.0) gymnasium cannot sample.)
    pairs = [(a + 0, b + 0) if a <= b else (b + 0, a + 0) for a, b in pairs]
    pairs = [(a if a < np.inf else -1, b if b > -np.inf else 1) for a, b in pairs]
    low = np.array([a for a, _ in pairs], dtype=dtype).reshape(shape)
    high = np.array([b for _, b in pairs], dtype=dtype).reshape(shape)
    return spaces.Box(low, high, shape=shape, dtype=dtype)


@st.composite
def multi_discretes(draw: st.DrawFn) -> spaces.MultiDiscrete:
    dtype = np.dtype(draw(st.sampled_from([np.int8, np.int64])))
    shape = draw(st.sampled_from([(1,), (2,), (3,), (2, 2), (70,)]))
    big = 100 if dtype == np.int8 else 2**40
    nvec = draw(
        st.lists(
            st.integers(1, draw(st.sampled_from([1, 2, 5, big]))),
            min_size=int(np.prod(shape)),
            max_size=int(np.prod(shape)),
        )
    )
    starts = [draw(st.integers(-20, 20)) for _ in nvec]
    return spaces.MultiDiscrete(
        np.reshape(nvec, shape).astype(dtype), dtype=dtype, start=np.reshape(starts, shape).astype(dtype)
    )


FINITE = st.one_of(
    st.builds(spaces.Discrete, st.one_of(st.integers(1, 8), st.integers(1, 2**62)), start=st.integers(-3, 3)),
    multi_discretes(),
    st.builds(spaces.MultiBinary, st.one_of(st.integers(1, 80), st.lists(st.integers(1, 5), min_size=1, max_size=3))),
)
#: Every kind of space: Boxes, the finite kinds nested in Tuples (Boxes among them), and the kinds
#: no encoding takes, or too large for any.
SPACES = st.one_of(
    boxes(),
    FINITE,
    st.recursive(
        st.one_of(FINITE, boxes()),
        lambda inner: st.lists(inner, max_size=3).map(lambda s: spaces.Tuple(tuple(s))),
        max_leaves=4,
    ),
    st.sampled_from(
        [
            spaces.Dict({"a": spaces.Discrete(2)}),
            spaces.Text(5),
            spaces.Sequence(spaces.Discrete(2)),
            spaces.Graph(spaces.Discrete(2), None),
            spaces.OneOf([spaces.Discrete(2), spaces.Discrete(3)]),
            spaces.MultiBinary([10**5, 10**5]),
            spaces.MultiDiscrete([10] * 5000),
        ]
    ),
)

#: Values of every kind, that may or may not belong to a space.
JUNK = st.one_of(
    st.none(),
    st.booleans(),
    st.integers(-5, 300),
    st.floats(allow_nan=True, allow_infinity=True),
    st.text(max_size=3),
    st.lists(st.integers(-2, 5), max_size=4).map(np.array),
    st.lists(st.floats(-2, 5), max_size=4),
    st.lists(st.floats(allow_nan=True, allow_infinity=True, width=32), max_size=4).map(
        lambda x: np.array(x, dtype=np.float32)
    ),
    st.lists(st.sampled_from([0.0, 1.0]), min_size=1, max_size=4).map(np.array),
    st.tuples(st.integers(-1, 3), st.integers(-1, 3)),
    st.just([[1, 2], [3]]),
)

#: Lists of lists of numbers, any (unsorted, NaN, outside a space's bounds).
NUMBER_LISTS = st.lists(
    st.lists(st.one_of(st.floats(-3, 3), st.sampled_from([np.nan, np.inf, 1e40, 300.0, -1.0, 0.5])), max_size=5),
    max_size=4,
)
#: Arguments of Bins, each valid or not.
BINS = st.fixed_dictionaries(
    {},
    optional={
        "bins": st.one_of(
            st.integers(1, 8),
            st.integers(-1, 17),
            st.sampled_from([10**7, 2.5, True, "8", [0, 2], [2, 3, 4]]),
            st.lists(st.integers(1, 5), max_size=4),
        ),
        "fit": st.sampled_from(["quantiles", "bounds", "quantiles", "bounds", "median", 3]),
        "edges": st.one_of(NUMBER_LISTS, st.sampled_from([5, "ab", [[0.0], "ab"], [range(70000)]])),
        "warmup": st.one_of(st.integers(1, 40), st.sampled_from([0, -1, 2.5, True])),
        "seed": st.one_of(st.integers(0, 5), st.sampled_from(["x", None])),
    },
)
#: What a user may pass as observations= / actions=, with arguments of every kind.
CHOICES = st.one_of(
    st.none(),
    st.sampled_from(["flat", "bins", 5, Flat]),
    st.tuples(st.just(Hashed), st.one_of(st.integers(1, 300), st.sampled_from([0, 70000, 2.5, True]))),
    st.tuples(st.just(Bins), BINS),
    st.tuples(
        st.just(Grid),
        st.one_of(st.integers(1, 9), st.sampled_from([0, -1, 10**8, True, 2.5, "ab"]), NUMBER_LISTS),
    ),
)


def _inside(box: spaces.Box, i: int) -> st.SearchStrategy[float]:
    """Values of dimension ``i`` of ``box`` (integers for an integer Box)."""
    lo, hi = float(np.ravel(box.low)[i]), float(np.ravel(box.high)[i])
    if box.dtype.kind in "biu":
        return st.integers(int(lo), int(hi)).map(float)
    top = float(np.finfo(box.dtype).max)
    lo, hi = max(lo, -top), min(hi, top)
    if hi <= lo:  # one value (0.0 and -0.0 among them)
        return st.just(lo)
    return st.floats(lo, hi, allow_nan=False).map(lambda x: float(box.dtype.type(x)))


def _suited(space: gym.Space, role: str) -> st.SearchStrategy[Any]:
    """Choices made for ``space``: a Box's edges sorted and one list a dimension, its grid's values
    inside its bounds (now and then one beside them)."""
    if not isinstance(space, spaces.Box) or int(np.prod(space.shape)) > 6:
        return CHOICES
    dims = int(np.prod(space.shape))
    if role == "observation":
        edges = st.lists(st.floats(-1e3, 1e3), max_size=4, unique=True).map(sorted)
        return st.tuples(st.just(Bins), st.fixed_dictionaries({"edges": st.lists(edges, min_size=dims, max_size=dims)}))
    value = [st.one_of(_inside(space, i), _inside(space, i), st.sampled_from([-1e5, 0.5, 300.0])) for i in range(dims)]
    return st.tuples(st.just(Grid), st.tuples(*[st.lists(v, min_size=1, max_size=3) for v in value]).map(list))


def _choice(drawn: Any) -> Any:
    """The encoding of a drawn choice (its constructor may refuse its arguments)."""
    if drawn is Flat:
        return Flat(spaces.Discrete(1))
    if isinstance(drawn, tuple):
        kind, args = drawn
        return kind(**args) if kind is Bins else kind(args)
    return drawn


def _warm_up(space: gym.Space, data: st.DataObject) -> Any:
    """A warm-up's sample: values of the space, now and then one beside it."""

    def sample(steps: int, seed: int) -> list[Any]:
        space.seed(seed)
        values = [space.sample() for _ in range(steps)]
        if data.draw(st.booleans(), label="warm-up beside the space"):
            values[data.draw(st.integers(0, steps - 1))] = data.draw(JUNK, label="warm-up value")
        return values

    return sample


def _in_space(encoded: Any, value: Any) -> bool:
    """Whether ``value`` is one the encoding must take: ``space.contains``; a Box's list or array
    of numbers, whatever its dtype (``Bins.check``): its numbers within the shape and the bounds,
    whole numbers for an integer Box."""
    space = encoded.space
    numbers = not isinstance(value, (np.ndarray, np.generic)) or np.asarray(value).dtype.kind in "biuf"
    if isinstance(space, spaces.Box) and numbers:
        try:
            x = np.asarray(value)
        except ValueError:
            return False
        if x.dtype.kind not in "biuf":
            return False
        x = x.astype(float)
        whole = not np.issubdtype(space.dtype, np.integer) or bool(np.all(x == np.round(x)))
        return x.shape == space.shape and whole and bool(np.all((x >= space.low) & (x <= space.high)))
    try:
        return bool(space.contains(value))
    except Exception:  # noqa: BLE001 - what contains() cannot read is not in the space
        return False


def _components(space: gym.Space) -> int:
    """The numbers in a value of a space."""
    if isinstance(space, spaces.Tuple):
        return sum(_components(s) for s in space.spaces)
    return int(np.prod(space.shape)) if space.shape else 1


def _check_made(encoded: Any, role: str, data: st.DataObject) -> None:
    """A made encoding: in range, of its space both ways, the same read back from its record."""
    limit = 2**63 - 1 if isinstance(encoded, Flat) else 65535
    assert 1 <= encoded.size <= limit, encoded.size
    space = encoded.space
    if _components(space) > 10**4:  # a Hashed MultiBinary of 10**10 bits: no value of it fits in memory
        return
    space.seed(data.draw(st.integers(0, 2**32 - 1), label="space seed"))
    values = [space.sample() for _ in range(3)]
    indices = [encoded.index(v) for v in values]
    assert all(0 <= i < encoded.size for i in indices), indices
    back = from_record(json.loads(json.dumps(encoded.record())), role)
    assert back.size == encoded.size and [back.index(v) for v in values] == indices
    world = {"spaces": {role: encoded.record(), "observation" if role == "action" else "action": encoded.record()}}
    assert [e.size for e in policy_encodings(world, encoded.size, encoded.size)] == [encoded.size] * 2
    with pytest.raises(cehmm.PolicyFormatError, match=r"(?s)world\.spaces\.observation: .*expected the policy's n_obs"):
        policy_encodings(world, encoded.size + 1, encoded.size)
    if isinstance(encoded, (Flat, Grid)):
        for i in data.draw(st.lists(st.integers(0, encoded.size - 1), min_size=1, max_size=3), label="indices"):
            value = encoded.value(i)
            assert space.contains(value), (space, value)
            if isinstance(encoded, Flat):
                assert encoded.index(value) == i
            else:
                assert np.array_equal(encoded.value(encoded.index(value)), value)
                assert np.array_equal(back.value(i), value)
    beside = data.draw(JUNK, label="value beside")
    expected = _in_space(encoded, beside) and not (isinstance(encoded, Grid))
    if isinstance(encoded, Grid):
        return
    try:
        index = encoded.index(beside)
    except cehmm.WorldError as e:
        assert not expected, (space, beside, e)
        assert "is not in the space" in str(e), e
        return
    assert expected, (space, beside)
    assert 0 <= index < encoded.size


@given(st.one_of(SPACES, boxes()), st.sampled_from(["observation", "action"]), st.data())
def test_every_space_is_encoded_or_refused_by_name(space: gym.Space, role: str, data: st.DataObject) -> None:
    drawn = data.draw(st.one_of(CHOICES, _suited(space, role)), label="choice")
    started = time.perf_counter()
    try:
        encoded = encoding(space, role, _choice(drawn), _warm_up(space, data))
    except cehmm.InvalidArgumentError as e:
        assert str(e).startswith("invalid "), e
        _tally("encodings", f"refused: {type(space).__name__}, {_refusal(str(e))}")
    except TypeError as e:
        assert str(e).startswith(f"invalid {role}s: "), e
        _tally("encodings", "refused: not an encoding")
    except cehmm.WorldError as e:
        assert "warm-up observation" in str(e) and "is not in the space" in str(e), e
        _tally("encodings", "refused: a warm-up value beside the space")
    else:
        _check_made(encoded, role, data)
        _tally("encodings", f"made: {type(encoded).__name__} of {type(space).__name__}")
    assert time.perf_counter() - started < 2.0


@given(boxes().filter(lambda b: int(np.prod(b.shape)) <= 6), st.data())
def test_grid_values_are_taken_only_where_the_box_holds_them(box: spaces.Box, data: st.DataObject) -> None:
    values = data.draw(st.one_of(_suited(box, "action").map(lambda c: c[1]), NUMBER_LISTS), label="values")
    dims = int(np.prod(box.shape))
    low, high = np.ravel(box.low).tolist(), np.ravel(box.high).tolist()
    if box.dtype.kind == "f":
        top = float(np.finfo(box.dtype).max)
        fits = [lambda x, lo=lo, hi=hi: max(lo, -top) <= x <= min(hi, top) for lo, hi in zip(low, high)]
    else:
        fits = [lambda x, lo=lo, hi=hi: x == round(x) and int(lo) <= round(x) <= int(hi) for lo, hi in zip(low, high)]
    valid = (
        len(values) == dims
        and all(len(v) > 0 and all(np.isfinite(x) for x in v) for v in values)
        and all(fit(x) for fit, v in zip(fits, values) for x in v)
    )
    try:
        grid = encoding(box, "action", Grid(values))
    except cehmm.InvalidArgumentError as e:
        assert not valid, (box, values, e)
        assert str(e).startswith("invalid Grid values"), e
        _tally("grid values", "refused")
        return
    assert valid, (box, values)
    assert all(box.contains(grid.value(i)) for i in range(grid.size))
    _tally("grid values", f"taken ({box.dtype})")


#: What an edit writes at one place of a record.
EDITS = st.one_of(
    st.sampled_from(
        [
            0,
            -1,
            1,
            2,
            3,
            65536,
            2**40,
            2**70,
            1e308,
            -1e308,
            0.5,
            "inf",
            "-inf",
            "x",
            None,
            True,
            [],
            {},
            [[]],
            [0.0],
            [[0.0, 1.0]],
            "Box",
            "Discrete",
            "MultiBinary",
            "Tuple",
            "float32",
            "int8",
            "object",
        ]
    ),
    st.integers(-(2**65), 2**65),
    st.floats(allow_nan=False),
)
#: Encodings whose records the edits start from.
MADE = st.sampled_from(
    [
        ("observation", spaces.Discrete(5, start=-2), None),
        ("action", spaces.MultiDiscrete([[2, 3], [2, 2]]), None),
        ("observation", spaces.MultiBinary(3), None),
        ("observation", spaces.Tuple((spaces.Discrete(2), spaces.MultiDiscrete([3, 2]))), None),
        ("observation", spaces.MultiDiscrete([3] * 20), Hashed(64)),
        ("observation", spaces.Box(-1.0, 1.0, shape=(3,), dtype=np.float32), Bins(3, fit="bounds")),
        (
            "observation",
            spaces.Box(np.array([-np.inf, 0.0]), np.array([np.inf, 1.0]), dtype=np.float64),
            Bins(edges=[[0.0, 1.5], [0.5]]),
        ),
        ("action", spaces.Box(-2.0, 2.0, shape=(2,), dtype=np.float32), Grid(3)),
        ("action", spaces.Box(0, 255, shape=(1,), dtype=np.uint8), Grid(values=[[0, 7, 255]])),
    ]
)


def _nudged(value: Any, data: st.DataObject) -> Any:
    """A number nudged (changed a little, or a lot), anything else replaced."""
    if isinstance(value, (int, float)) and not isinstance(value, bool) and data.draw(st.booleans(), label="nudge"):
        return data.draw(st.sampled_from([value + 1, value - 1, value * 2, -value, value + 0.5]), label="nudged")
    return copy.deepcopy(data.draw(EDITS, label="value"))


def _leaves(node: Any, path: tuple = ()) -> list[tuple]:
    """The paths of every place of a JSON document (its containers' too)."""
    found = [path]
    if isinstance(node, dict):
        for key, child in node.items():
            found += _leaves(child, (*path, key))
    elif isinstance(node, list):
        for k, child in enumerate(node):
            found += _leaves(child, (*path, k))
    return found


@given(MADE, st.data())
def test_an_edited_record_is_read_or_refused_as_a_format_error(made: tuple[str, Any, Any], data: st.DataObject) -> None:
    role, space, choice = made
    record = json.loads(json.dumps(encoding(space, role, choice).record()))
    for _ in range(data.draw(st.integers(1, 2), label="edits")):
        path = data.draw(st.sampled_from(_leaves(record)), label="place")
        if not path:
            record = data.draw(EDITS, label="record")
            break
        parent = record
        for key in path[:-1]:
            parent = parent[key]
        if data.draw(st.integers(0, 3), label="delete") == 0:
            del parent[path[-1]]
        else:
            parent[path[-1]] = _nudged(parent[path[-1]], data)
    started = time.perf_counter()
    try:
        back = from_record(record, role)
    except cehmm.PolicyFormatError as e:
        assert str(e).startswith(f"invalid {role} encoding record: "), e
        _tally("records", "refused")
    else:
        _tally("records", f"read: {type(back).__name__}")
        back.space.seed(0)
        value = back.space.sample()
        # (A 0-d space's own samples may not be in it, for gymnasium: np.int64, not an array.)
        if not isinstance(value, np.generic) and back.space.contains(value):
            assert 0 <= back.index(value) < back.size
        if isinstance(back, (Flat, Grid)):
            assert back.space.contains(back.value(back.size - 1))
    assert time.perf_counter() - started < 2.0
