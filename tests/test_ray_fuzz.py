"""Property tests of the Ray backend's arguments (Hypothesis): whatever ``workers``, ``threads``,
``retries`` and ``address`` (of every shape: host and port, ``ray://``, ``auto``, malformed text,
other types) are given to ``cehmm.RayBackend`` or with ``backend=`` to ``cehmm.optimize``, each is
either accepted or refused with ``TypeError`` or :class:`cehmm.CehmmError` naming the value, within
seconds: never a hang on a cluster that is not there. The example count is kept small for CI;
``HYPOTHESIS_PROFILE=long`` runs many more (profiles: conftest.py)."""

from __future__ import annotations

import re
import time
from typing import Any

import numpy as np
import pytest
from hypothesis import given
from hypothesis import strategies as st
from worlds import Corridor

import cehmm
from cehmm.ray_backend import CONNECT_TIMEOUT, MAX_RETRIES

ray = pytest.importorskip("ray")

pytestmark = pytest.mark.timeout(300)

#: Counts of every kind: ints in and out of range, numpy ints, and values of other types.
COUNTS = st.one_of(
    st.none(),
    st.booleans(),
    st.integers(min_value=-3, max_value=12),
    st.integers(min_value=2**31 - 2, max_value=2**70),
    st.integers(min_value=0, max_value=8).map(np.int64),
    st.floats(allow_nan=True, allow_infinity=True),
    st.text(max_size=3),
    st.lists(st.integers(), max_size=2),
)

#: Hosts of every shape: names, addresses, and text that is neither.
HOSTS = st.one_of(
    st.sampled_from(["127.0.0.1", "localhost", "nonsense", "[::1]", "::1", "", "a..b", "-x", "x y", "ray://"]),
    st.from_regex(r"[A-Za-z0-9.\-_\[\]:@/ %]{0,12}", fullmatch=True),
)
PORTS = st.one_of(st.integers(min_value=-2, max_value=70_000).map(str), st.text(max_size=4))

#: Addresses of every shape (valid or not) and type.
ADDRESSES = st.one_of(
    st.none(),
    st.sampled_from(["auto", "local", "ray://", "ray://:1", "auto:1", "LOCAL", "ray:/host:1", "ray://host:1:2"]),
    st.builds("{}:{}".format, HOSTS, PORTS),
    st.builds("ray://{}:{}".format, HOSTS, PORTS),
    st.builds("ray://{}".format, HOSTS),
    st.text(max_size=24),
    st.integers(),
    st.binary(max_size=6),
    st.lists(st.text(max_size=3), max_size=2),
)

#: Well-formed addresses where nothing answers: loopback ports no one may listen on (1, root's),
#: names that do not resolve.
UNREACHABLE = st.one_of(
    st.builds("{}:1".format, st.sampled_from(["127.0.0.1", "localhost", "[::1]", "nonsense.invalid", "nonsense"])),
    st.builds("127.{}.{}.{}:1".format, *[st.integers(0, 255)] * 3),
    st.builds("ray://{}:1".format, st.sampled_from(["127.0.0.1", "localhost", "nonsense.invalid"])),
)


def _names_its_value(e: BaseException, given: dict[str, Any]) -> None:
    """``e`` names one of the arguments given, with its value."""
    text = str(e)
    assert "\x1b" not in text, text
    assert any(f"invalid {name}: {value!r}" in text for name, value in given.items()), (
        f"{type(e).__name__}: {text} names none of {given}"
    )


def _shaped(address: str) -> bool:
    """Whether ``address`` is of a shape RayBackend documents (an oracle of its own)."""
    if address in ("auto", "local"):
        return True
    rest = address[len("ray://") :] if address.startswith("ray://") else address
    host, colon, port = rest.rpartition(":") if not rest.endswith("]") and ":" in rest else (rest, "", "")
    if not colon and not address.startswith("ray://"):
        return False
    if colon and not (port.isascii() and port.isdigit() and 1 <= int(port) <= 65535):
        return False
    bracketed = host.startswith("[") and host.endswith("]") and len(host) > 2
    return bool(host) and (bracketed or re.fullmatch(r"[A-Za-z0-9._-]+", host) is not None)


@given(workers=COUNTS, threads=COUNTS, retries=COUNTS, address=ADDRESSES)
def test_ray_backend_arguments(workers: Any, threads: Any, retries: Any, address: Any) -> None:
    given_ = {"workers": workers, "threads": threads, "retries": retries, "address": address}
    arguments = {k: v for k, v in given_.items() if v is not None}
    start = time.monotonic()
    try:
        backend = cehmm.RayBackend(**arguments)
    except (TypeError, cehmm.CehmmError) as e:
        assert not isinstance(e, cehmm.InternalError), e
        _names_its_value(e, arguments)
    else:
        # Accepted: ints in their ranges, an address of a documented shape.
        assert backend.threads >= 1 and 0 <= backend.retries <= MAX_RETRIES
        assert address is None or _shaped(address), address
    assert time.monotonic() - start < 1.0


@pytest.fixture(scope="module")
def no_ray_joined() -> None:
    # An address is only dialled by a process that has not joined a Ray yet.
    if ray.is_initialized():
        pytest.skip("this process joined a Ray already (an address given now is not dialled)")


@given(backend=st.one_of(st.sampled_from(["ray", "local", "Ray", ""]), COUNTS), workers=COUNTS, address=UNREACHABLE)
def test_optimize_on_an_unreachable_cluster_is_refused_within_seconds(
    no_ray_joined: None, backend: Any, workers: Any, address: str
) -> None:
    given_ = {"backend": backend, "workers": workers, "address": address}
    start = time.monotonic()
    with pytest.raises((TypeError, cehmm.CehmmError)) as refused:
        cehmm.optimize(Corridor(), backend=backend, workers=workers, address=address, max_iterations=1, progress=False)
    assert not isinstance(refused.value, cehmm.InternalError), refused.value
    _names_its_value(refused.value, given_)
    assert time.monotonic() - start < CONNECT_TIMEOUT + 2
    assert not ray.is_initialized()
