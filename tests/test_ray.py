"""The Ray backend (issues 21 and 29): the same tables as the local backend, on a local 2-CPU Ray
without a dashboard, on loopback or behind token authentication; third-party environments that
keep numpy state (POPGym's, Gymnasium's CartPole) give the local result; a worker killed mid-run
changes nothing, a world's exception on a worker surfaces as itself (without Ray's colour
codes), Ctrl-C leaves no task running; an unreachable cluster, a task no node can run and a
model file changed since it was read are refused by name, within seconds.

Runs where Ray is installed (``pip install 'cehmm[ray]'``; the test extra brings it, in the
versions of the ``ray`` extra)."""

from __future__ import annotations

import json
import os
import pickle
import re
import shutil
import signal
import socket
import subprocess
import sys
import time
import traceback
from importlib import metadata
from pathlib import Path

import gymnasium as gym
import numpy as np
import pytest
import worlds
from worlds import CoarseCartPole, Corridor, KillsItsWorker, Raises, Slow

import cehmm

ray = pytest.importorskip("ray")

pytestmark = [
    # Ray's own log files, left open by its processes at shutdown: not ours to close.
    pytest.mark.filterwarnings("ignore::ResourceWarning", "ignore::pytest.PytestUnraisableExceptionWarning"),
    # A thread's timer: the Ctrl-C test sets SIGALRM itself.
    pytest.mark.timeout(300, method="thread"),
]

CPUS = 2


@pytest.fixture(scope="module")
def cluster():
    # The test worlds reach the workers as a module of the job's runtime environment (README,
    # "Running on a cluster").
    context = ray.init(
        address="local",  # a new cluster, even where one runs on this machine
        num_cpus=CPUS,
        include_dashboard=False,
        _node_ip_address="127.0.0.1",
        log_to_driver=False,
        runtime_env={"py_modules": [worlds]},
    )
    yield context
    ray.shutdown()


def test_the_test_cluster_is_on_loopback_or_behind_token_authentication_without_a_dashboard(cluster):
    # Ray < 2.54 binds where it is told (loopback); 2.59 and later bind every interface and
    # refuse a client without the cluster's token; the `ray` extra leaves out the Rays between,
    # which bind every interface with no authentication (pyproject.toml).
    (node,) = ray.nodes()
    gcs = cluster.address_info["gcs_address"]
    assert not cluster.dashboard_url
    if node["NodeManagerAddress"] == "127.0.0.1":
        assert gcs.startswith("127.0.0.1:")
        return
    import grpc
    from ray.core.generated import gcs_service_pb2, gcs_service_pb2_grpc

    with grpc.insecure_channel(gcs) as channel:
        stub = gcs_service_pb2_grpc.NodeInfoGcsServiceStub(channel)
        with pytest.raises(grpc.RpcError) as refused:
            stub.GetClusterId(gcs_service_pb2.GetClusterIdRequest(), timeout=10)
    assert refused.value.code() == grpc.StatusCode.UNAUTHENTICATED, refused.value


def test_the_ray_tested_is_one_the_ray_extra_takes():
    # CI tests the Ray users get: the test extra takes the `ray` extra's range.
    packaging = pytest.importorskip("packaging.requirements")
    try:
        requires = metadata.requires("cehmm") or []
    except metadata.PackageNotFoundError:
        pytest.skip("cehmm is not installed (no metadata to read its extras from)")
    extra = [r for r in map(packaging.Requirement, requires) if r.marker and r.marker.evaluate({"extra": "ray"})]
    (wanted,) = [r for r in extra if r.name == "ray"]
    assert "client" in wanted.extras
    assert wanted.specifier.contains(ray.__version__), (ray.__version__, str(wanted.specifier))


def _tables(result: cehmm.OptimizeResult | cehmm.ControllerResult) -> dict:
    """The policy's levels and tables (not its world's description nor its provenance)."""
    return {k: v for k, v in json.loads(result.policy.to_json()).items() if k not in ("world", "provenance")}


def _same_run(remote: cehmm.OptimizeResult, local: cehmm.OptimizeResult) -> None:
    assert _tables(remote) == _tables(local)
    assert np.array_equal(remote.history["mean"], local.history["mean"])
    assert remote.evaluation == local.evaluation


def test_episode_ce_on_an_engine_world_on_ray_is_the_local_one(cluster):
    world = cehmm.TargetTracking(case=1)
    settings = dict(levels=[3, 2], samples=300, rho=0.2, max_iterations=4, eval_episodes=500, seed=3)
    local = cehmm.optimize(world, progress=False, init="random", **settings)
    for workers in (1, 3):
        remote = cehmm.optimize(world, progress=False, init="random", backend="ray", workers=workers, **settings)
        assert remote.policy.to_json() == local.policy.to_json()
        _same_run(remote, local)
    evaluation = local.policy.evaluate(world, episodes=2000, backend="ray", workers=2)
    assert evaluation == local.policy.evaluate(world, episodes=2000)


CORRIDOR = dict(levels=[2, 2], samples=120, rho=0.2, max_iterations=3, eval_episodes=100, seed=5, progress=False)


def test_episode_ce_on_a_python_world_on_ray_is_the_local_one(cluster):
    local = cehmm.optimize(Corridor(), init="random", **CORRIDOR)
    for workers in (2, 5):
        remote = cehmm.optimize(Corridor(), init="random", backend="ray", workers=workers, **CORRIDOR)
        assert remote.policy.to_json() == local.policy.to_json()
        _same_run(remote, local)


def test_a_callback_on_ray_stops_and_raises_as_it_does_locally(cluster):
    # The iteration loop runs in the driver: its callback is called there, with the best policy.
    settings = {**CORRIDOR, "max_iterations": None}
    local = cehmm.optimize(Corridor(), init="random", **CORRIDOR)
    seen = []
    stop = lambda it: seen.append(it.best_policy().levels) or it["iteration"] < 2  # noqa: E731
    remote = cehmm.optimize(Corridor(), init="random", backend="ray", workers=2, callback=stop, **settings)
    assert remote.stop_reason == "callback" and seen == [[2, 2]] * 3
    assert _tables(remote) == _tables(local) and remote.evaluation == local.evaluation
    with pytest.raises(ZeroDivisionError):
        cehmm.optimize_controller(
            Corridor(), nodes=2, samples=16, progress=False, backend="ray", callback=lambda it: 1 / 0
        )


def test_a_scored_python_world_travels_as_what_it_was_made_from(cluster):
    world = cehmm.PythonWorld(Corridor(), score=worlds.reached, horizon=6, name="short corridor")
    local = cehmm.optimize(world, **CORRIDOR)
    remote = cehmm.optimize(world, backend="ray", workers=2, **CORRIDOR)
    assert remote.policy.to_json() == local.policy.to_json()
    _same_run(remote, local)


def test_the_controller_search_on_a_python_world_on_ray_is_the_local_one(cluster):
    settings = dict(nodes=2, samples=16, episodes=4, select_episodes=8, eval_episodes=50, max_iterations=3, seed=2)
    local = cehmm.optimize_controller(Corridor(), progress=False, **settings)
    remote = cehmm.optimize_controller(Corridor(), progress=False, backend=cehmm.RayBackend(workers=3), **settings)
    assert remote.policy.to_json() == local.policy.to_json()
    assert remote.value == local.value and list(remote.history["mean"]) == list(local.history["mean"])


def test_the_controller_search_on_exact_values_on_ray_is_the_local_one(cluster):
    tiger = cehmm.PomdpWorld(Path(__file__).parents[1] / "data" / "pomdp" / "tiger.95.POMDP")
    settings = dict(nodes=3, samples=200, max_iterations=4, seed=1, progress=False)
    local = cehmm.optimize_controller(tiger, **settings)
    remote = cehmm.optimize_controller(tiger, backend="ray", workers=3, **settings)
    assert remote.kind == local.kind == "exact"
    assert remote.policy.to_json() == local.policy.to_json()
    assert remote.value == local.value and list(remote.history["mean"]) == list(local.history["mean"])
    with pytest.raises(cehmm.InvalidArgumentError, match="exact values need a tabular world"):
        cehmm.optimize_controller(Corridor(), value="exact", backend="ray", **settings)


def test_an_optimiser_given_by_its_step_runs_on_ray_as_here(cluster):
    # Registered once (ceworld::run::OPTIMISERS), the random search gets the backend for free.
    settings = dict(nodes=3, samples=30, episodes=10, max_iterations=3, eval_episodes=200, progress=False)
    local = cehmm.run("random-search", Corridor(), **settings)
    remote = cehmm.run("random-search", Corridor(), backend="ray", workers=2, **settings)
    assert remote.policy.to_json() == local.policy.to_json()
    assert list(remote.history["mean"]) == list(local.history["mean"])


def test_a_worker_killed_mid_run_changes_nothing(cluster, tmp_path: Path):
    marker = tmp_path / "killed"
    remote = cehmm.optimize(KillsItsWorker(str(marker)), init="random", backend="ray", workers=2, **CORRIDOR)
    assert marker.exists(), "no worker was killed"
    _same_run(remote, cehmm.optimize(Corridor(), init="random", **CORRIDOR))


def test_a_world_raising_on_a_worker_raises_that_exception_with_its_traceback(cluster):
    with pytest.raises(ValueError, match="the corridor's third step") as raised:
        cehmm.optimize(Raises(), backend="ray", workers=2, **CORRIDOR)
    # Itself (not Ray's wrapper of it), the worker's traceback its cause, down to the world's line.
    assert type(raised.value) is ValueError
    remote = raised.value.__cause__
    assert isinstance(remote, cehmm.ray_backend.RemoteTraceback)
    assert "worlds.py" in str(remote) and "in step" in str(remote)
    # Without Ray's colour codes, wherever it is shown.
    shown = "".join(traceback.format_exception(type(raised.value), raised.value, raised.value.__traceback__))
    assert "the corridor's third step" in shown and "worlds.py" in shown
    assert "\x1b" not in shown and "\x1b" not in repr(getattr(raised.value, "__notes__", []))


def _idle(seconds: float = 20.0) -> bool:
    """Whether the cluster's CPUs are all free again within ``seconds``."""
    deadline = time.monotonic() + seconds
    while time.monotonic() < deadline:
        if ray.available_resources().get("CPU", 0) == CPUS:
            return True
        time.sleep(0.1)
    return False


def test_ctrl_c_leaves_no_task_running_and_resumes_to_the_local_run(cluster, tmp_path: Path):
    # About 0.5 s an iteration on Ray; the alarm comes in the second or so.
    settings = dict(levels=[2], samples=40, max_iterations=6, eval_episodes=20, patience=10**6, progress=False)
    reference = cehmm.optimize(Slow(), **settings)
    checkpoint = tmp_path / "ray.ckpt"

    def interrupt(signum: int, frame: object) -> None:
        # Ctrl-C once an iteration has ended (its checkpoint written), however slow the machine:
        # one before the first iteration ends keeps nothing and raises KeyboardInterrupt.
        if not checkpoint.exists():
            signal.setitimer(signal.ITIMER_REAL, 0.1)
            return
        raise KeyboardInterrupt

    previous = signal.signal(signal.SIGALRM, interrupt)
    signal.setitimer(signal.ITIMER_REAL, 0.5)
    try:
        first = cehmm.optimize(
            Slow(), backend="ray", workers=2, checkpoint=checkpoint, checkpoint_every=1e-3, resume=True, **settings
        )
    finally:
        signal.setitimer(signal.ITIMER_REAL, 0)
        signal.signal(signal.SIGALRM, previous)
    assert first.interrupted and 1 <= first.iterations < 6 and checkpoint.exists()
    assert _idle(), f"tasks still hold CPUs: {ray.available_resources()}"
    resumed = cehmm.optimize(Slow(), backend="ray", workers=2, checkpoint=checkpoint, resume=True, **settings)
    assert resumed.iterations == 6
    _same_run(resumed, reference)


def test_backend_errors_name_the_value():
    world = cehmm.TargetTracking(case=1)
    with pytest.raises(cehmm.InvalidArgumentError, match="backend: 'spark'"):
        cehmm.optimize(world, backend="spark", max_iterations=1, progress=False)
    with pytest.raises(cehmm.InvalidArgumentError, match="workers: 2 with backend='local'"):
        cehmm.optimize(world, workers=2, max_iterations=1, progress=False)
    with pytest.raises(cehmm.InvalidArgumentError, match="workers: 0"):
        cehmm.RayBackend(workers=0)


JOIN = """
import sys
import cehmm
result = cehmm.optimize(cehmm.TargetTracking(case=1), backend="ray", address=sys.argv[1], progress=False, **{})
print(result.policy.to_json())
"""


def _free_port() -> int:
    with socket.socket() as s:
        s.bind(("127.0.0.1", 0))
        return s.getsockname()[1]


def test_a_job_on_an_existing_cluster_is_the_local_one():
    # A cluster started apart (`ray start --head`, as on a cluster's head node), joined by a
    # driver of its own with address=.
    port = _free_port()
    head = subprocess.Popen(
        [sys.executable, "-m", "ray.scripts.scripts", "start", "--head", "--block", f"--port={port}",
         "--num-cpus=2", "--include-dashboard=false", "--disable-usage-stats",
         f"--ray-client-server-port={_free_port()}"],
        stdout=subprocess.DEVNULL, stderr=subprocess.DEVNULL, start_new_session=True,
    )  # fmt: skip
    try:
        deadline = time.monotonic() + 60
        while socket.socket().connect_ex(("127.0.0.1", port)) != 0:  # the head's GCS, once up
            assert time.monotonic() < deadline and head.poll() is None, "the head did not start"
            time.sleep(0.2)
        settings = dict(levels=[3, 2], samples=200, max_iterations=3, eval_episodes=200, seed=4)
        script = JOIN.replace("**{}", f"**{settings!r}")
        joined = subprocess.run(
            [sys.executable, "-c", script, f"127.0.0.1:{port}"], capture_output=True, text=True, timeout=120
        )
        assert joined.returncode == 0, joined.stderr[-2000:]
        local = cehmm.optimize(cehmm.TargetTracking(case=1), progress=False, **settings)
        assert joined.stdout.strip() == local.policy.to_json()
    finally:
        os.killpg(head.pid, signal.SIGTERM)
        head.wait(timeout=60)


# Short runs of environments written by others: a POPGym task (its cards kept in numpy arrays it
# resets in place) and Gymnasium's CartPole, cut to a finite observation.
THIRD_PARTY = dict(horizon=20, levels=[4, 4], samples=100, max_iterations=2, eval_episodes=50, seed=3, progress=False)
THIRD_PARTY_CONTROLLER = dict(
    horizon=20, nodes=2, samples=16, episodes=4, select_episodes=8, eval_episodes=50, max_iterations=2, seed=2
)


def _repeat_first() -> gym.Env:
    return pytest.importorskip("popgym.envs.repeat_first").RepeatFirst()


@pytest.mark.parametrize("make", [_repeat_first, CoarseCartPole], ids=["popgym-RepeatFirst", "CartPole"])
def test_environments_keeping_numpy_state_on_ray_give_the_local_result(cluster, make):
    # Each shard's reset failed on POPGym's RepeatFirst ("assignment destination is read-only":
    # the world came back from Ray's object store with read-only arrays).
    local = cehmm.optimize(make(), init="random", **THIRD_PARTY)
    remote = cehmm.optimize(make(), init="random", backend="ray", workers=2, **THIRD_PARTY)
    assert remote.policy.to_json() == local.policy.to_json()
    _same_run(remote, local)
    local = cehmm.optimize_controller(make(), progress=False, **THIRD_PARTY_CONTROLLER)
    remote = cehmm.optimize_controller(make(), progress=False, backend="ray", workers=2, **THIRD_PARTY_CONTROLLER)
    assert remote.policy.to_json() == local.policy.to_json()
    assert remote.value == local.value and list(remote.history["mean"]) == list(local.history["mean"])


def test_a_task_no_node_can_run_is_refused_before_it_is_sent(cluster):
    # Ray held it for ever, waiting for a node of 4 CPUs.
    start = time.monotonic()
    refused = r"invalid threads: 4 \(a task takes 4 CPUs on one node, and the largest node .* has 2 CPUs"
    with pytest.raises(cehmm.InvalidArgumentError, match=refused):
        cehmm.optimize(Corridor(), backend=cehmm.RayBackend(workers=1, threads=4), **CORRIDOR)
    with pytest.raises(cehmm.InvalidArgumentError, match=refused):
        cehmm.optimize_controller(Corridor(), backend=cehmm.RayBackend(threads=4), nodes=2, progress=False)
    assert time.monotonic() - start < 10
    assert _idle(), f"tasks still hold CPUs: {ray.available_resources()}"
    remote = cehmm.optimize(Corridor(), init="random", backend=cehmm.RayBackend(workers=1, threads=2), **CORRIDOR)
    _same_run(remote, cehmm.optimize(Corridor(), init="random", **CORRIDOR))


def test_a_model_file_changed_since_it_was_read_is_refused_as_locally(cluster, tmp_path: Path):
    # It was RayTaskError(RaySystemError): the world failed to unpickle inside Ray's own code.
    path = tmp_path / "tiger.POMDP"
    shutil.copy(Path(__file__).parents[1] / "data" / "pomdp" / "tiger.95.POMDP", path)
    tiger = cehmm.PomdpWorld(path, horizon=20)
    with path.open("a") as f:
        f.write("\n# changed\n")
    with pytest.raises(cehmm.PolicyMismatchError, match="the model changed since"):
        pickle.loads(pickle.dumps(tiger))  # what a worker does with it, here
    short = dict(backend="ray", workers=2, samples=20, max_iterations=2, progress=False)
    with pytest.raises(cehmm.PolicyMismatchError, match="the model changed since"):
        cehmm.optimize(tiger, levels=[2], **short)
    with pytest.raises(cehmm.PolicyMismatchError, match="the model changed since"):
        cehmm.optimize_controller(tiger, nodes=2, **short)


UNREACHABLE = """
import json, sys, time
import cehmm
refused = []
for address in sys.argv[1:]:
    start = time.monotonic()
    try:
        cehmm.optimize(cehmm.TargetTracking(case=1), backend="ray", address=address, max_iterations=1, progress=False)
    except (cehmm.CehmmError, TypeError) as e:
        refused.append([address, type(e).__name__, str(e), time.monotonic() - start])
print(json.dumps(refused))
"""


def test_an_unreachable_or_malformed_address_is_refused_by_name_within_seconds():
    # 'nonsense:1' and '127.0.0.1:1' hung (killed at 200 s; Ctrl-C took 31 s). A process of its
    # own: this one may have joined the test cluster already.
    unreachable = ["nonsense:1", "127.0.0.1:1", "localhost:1", "[::1]:1", "ray://127.0.0.1:1", "ray://nonsense"]
    malformed = ["", "127.0.0.1", "nonsense", "host:0", "host:65536", "http://host:1", "ray://", "ray://host:x",
                 " host:1", "host:1\n", "host:1/path", "user@host:1", "ho st:1"]  # fmt: skip
    done = subprocess.run(
        [sys.executable, "-c", UNREACHABLE, *unreachable, *malformed], capture_output=True, text=True, timeout=120
    )
    assert done.returncode == 0, done.stderr[-3000:]
    refused = json.loads(done.stdout.strip().splitlines()[-1])
    assert [address for address, *_ in refused] == unreachable + malformed
    for address, kind, message, seconds in refused:
        assert kind == "InvalidArgumentError" and message.startswith(f"invalid address: {address!r} ("), message
        assert seconds < cehmm.ray_backend.CONNECT_TIMEOUT + 2, (address, seconds)
        assert "\x1b" not in message
    messages = dict((address, message) for address, _, message, _ in refused)
    assert "nothing answers at" in messages["127.0.0.1:1"] and "expected" in messages["127.0.0.1"]
    assert re.search(r"nothing answers at nonsense:1\b", messages["nonsense:1"]), messages["nonsense:1"]
