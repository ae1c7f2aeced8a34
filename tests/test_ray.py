"""The Ray backend (issues 21, 29 and 45): the same tables as the local backend, on a local 2-CPU
Ray without a dashboard, on loopback only, its files in the suite's own temporary directory
(tests/conftest.py), the machine's own Ray directory left as it was; third-party environments that
keep numpy state (POPGym's, Gymnasium's CartPole) give the local result; a worker killed mid-run
changes nothing, a world's exception on a worker surfaces as itself (without Ray's colour
codes), Ctrl-C leaves no task running; an unreachable cluster, a task no node can run and a
model file changed since it was read are refused by name, within seconds.

Runs where Ray is installed (``pip install 'cehmm[ray]'``; the test extra brings it, in the
versions of the ``ray`` extra)."""

from __future__ import annotations

import ipaddress
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


def test_the_test_cluster_listens_on_loopback_only_without_a_dashboard(cluster):
    # Ray 2.54 and later bind every interface, whatever _node_ip_address says, unless told that
    # this machine is the whole cluster (RAY_ENABLE_WINDOWS_OR_OSX_CLUSTER=0: tests/conftest.py).
    (node,) = ray.nodes()
    assert node["NodeManagerAddress"] == "127.0.0.1"
    assert cluster.address_info["gcs_address"].startswith("127.0.0.1:")
    assert not cluster.dashboard_url
    _on_loopback_only(os.getpid(), cluster.address_info["gcs_address"])


def _on_loopback_only(root: int, gcs: str) -> None:
    """Every TCP socket that process ``root`` and its descendants listen on is on loopback (the
    GCS at ``gcs`` among them), as Linux's ``/proc`` shows them."""
    if not Path("/proc/net/tcp").exists():
        return  # pragma: no cover - the suite runs on Linux
    listening = _listening(root)
    host, port = gcs.rsplit(":", 1)
    assert any(p == int(port) for _, p in listening), (gcs, listening)
    wide = sorted(f"{a}:{p}" for a, p in listening if not a.is_loopback)
    assert not wide, f"listening beyond loopback: {wide}"


def _listening(root: int) -> set[tuple[ipaddress.IPv4Address | ipaddress.IPv6Address, int]]:
    """The (address, port) of every listening TCP socket of process ``root`` and its descendants
    (IPv4 addresses mapped into IPv6 read as IPv4)."""
    proc = Path("/proc")
    children: dict[int, list[int]] = {}
    for stat in proc.glob("[0-9]*/stat"):
        try:
            parent = int(stat.read_text().rsplit(")", 1)[1].split()[1])
        except (OSError, IndexError, ValueError):
            continue  # a process that has just ended
        children.setdefault(parent, []).append(int(stat.parent.name))
    inodes, pids = set(), [root]
    while pids:
        pid = pids.pop()
        pids.extend(children.get(pid, []))
        try:
            links = [os.readlink(fd) for fd in (proc / str(pid) / "fd").iterdir()]
        except OSError:
            continue
        inodes.update(link[len("socket:[") : -1] for link in links if link.startswith("socket:["))
    found = set()
    for table in ("tcp", "tcp6"):
        for line in (proc / "net" / table).read_text().splitlines()[1:]:
            fields = line.split()
            if fields[3] == "0A" and fields[9] in inodes:  # TCP_LISTEN
                address, port = fields[1].split(":")
                raw = bytes.fromhex(address)  # 32-bit words in the host's (little-endian) order
                ip = ipaddress.ip_address(b"".join(raw[k : k + 4][::-1] for k in range(0, len(raw), 4)))
                mapped = getattr(ip, "ipv4_mapped", None)
                found.add((mapped or ip, int(port, 16)))
    return found


def _address_file(temp_dir: str) -> Path:
    """Where Ray records the cluster that ``ray start`` started (``address="auto"`` reads it)."""
    return Path(temp_dir) / "ray" / "ray_current_cluster"


def _state(path: Path) -> tuple[bytes, int] | None:
    """A file's content and modification time (``None`` where there is none)."""
    try:
        return path.read_bytes(), path.stat().st_mtime_ns
    except FileNotFoundError:
        return None


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
    # The world's steps, counted on the workers, are the local count.
    assert (remote.env_steps, remote.eval_env_steps) == (local.env_steps, local.eval_env_steps)
    assert np.array_equal(remote.history["env_steps"], local.history["env_steps"])


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
            Corridor(), nodes=2, samples=16, progress=False, backend="ray", callback=lambda it: 1 / 0, search="ce"
        )


def test_a_scored_python_world_travels_as_what_it_was_made_from(cluster):
    world = cehmm.PythonWorld(Corridor(), score=worlds.reached, horizon=6, name="short corridor")
    local = cehmm.optimize(world, **CORRIDOR)
    remote = cehmm.optimize(world, backend="ray", workers=2, **CORRIDOR)
    assert remote.policy.to_json() == local.policy.to_json()
    _same_run(remote, local)


def test_the_controller_search_on_a_python_world_on_ray_is_the_local_one(cluster):
    settings = dict(nodes=2, samples=16, episodes=4, select_episodes=8, eval_episodes=50, max_iterations=3, seed=2)
    local = cehmm.optimize_controller(Corridor(), progress=False, **settings, search="ce")
    remote = cehmm.optimize_controller(
        Corridor(), progress=False, backend=cehmm.RayBackend(workers=3), **settings, search="ce"
    )
    assert remote.policy.to_json() == local.policy.to_json()
    assert remote.value == local.value and list(remote.history["mean"]) == list(local.history["mean"])
    assert (remote.env_steps, remote.eval_env_steps) == (local.env_steps, local.eval_env_steps)


def test_a_budget_in_steps_on_ray_is_the_local_one(cluster):
    budget = {**CORRIDOR, "max_iterations": None, "max_env_steps": 5000}
    local = cehmm.optimize(Corridor(), init="random", **budget)
    remote = cehmm.optimize(Corridor(), init="random", backend="ray", workers=3, **budget)
    assert local.stop_reason == remote.stop_reason == "max_env_steps"
    _same_run(remote, local)
    settings = dict(nodes=2, samples=16, episodes=4, select_episodes=8, eval_episodes=50, max_env_steps=2000)
    local_search = cehmm.optimize_controller(Corridor(), progress=False, **settings, search="ce")
    remote_search = cehmm.optimize_controller(
        Corridor(), progress=False, backend="ray", workers=2, **settings, search="ce"
    )
    assert remote_search.policy.to_json() == local_search.policy.to_json()
    assert remote_search.env_steps == local_search.env_steps and remote_search.stop_reason == "max_env_steps"


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


def test_memory_from_every_step_on_ray_is_the_local_one(cluster):
    # The workers send every step back; the model is learnt here from the same steps in order.
    settings = dict(samples=6, episodes=3, memories=20, rounds=2, max_iterations=3, eval_episodes=100, progress=False)
    local = cehmm.run("model-search", Corridor(), **settings)
    remote = cehmm.run("model-search", Corridor(), backend="ray", workers=2, **settings)
    assert remote.policy.to_json() == local.policy.to_json()
    assert (remote.env_steps, list(remote.history["best"])) == (local.env_steps, list(local.history["best"]))


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
    # driver of its own with address=. It listened on the machine's network address and left
    # /tmp/ray/ray_current_cluster behind, after which every ray.init(num_cpus=...) on the machine
    # failed: it is on loopback only, its state in the suite's temporary directory (RAY_TMPDIR:
    # tests/conftest.py), the machine's own left as it was.
    machine = _address_file(os.environ.get("TMPDIR", "/tmp"))
    before = _state(machine)
    port = _free_port()
    head = subprocess.Popen(
        [sys.executable, "-m", "ray.scripts.scripts", "start", "--head", "--block", f"--port={port}",
         "--node-ip-address=127.0.0.1", "--num-cpus=2", "--include-dashboard=false", "--disable-usage-stats",
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
        _on_loopback_only(head.pid, f"127.0.0.1:{port}")
        assert _address_file(os.environ["RAY_TMPDIR"]).read_text().strip() == f"127.0.0.1:{port}"
    finally:
        os.killpg(head.pid, signal.SIGTERM)
        head.wait(timeout=60)
    assert _state(machine) == before, f"{machine} changed"


SUITE = """
import os, ray._private.utils
def test_ray_writes_here():
    path = ray._private.utils.get_ray_address_file(None)
    os.makedirs(os.path.dirname(path), exist_ok=True)
    with open(path, "w") as f:
        f.write("127.0.0.1:1")
    print("RAY_ADDRESS_FILE", path)
"""


def test_the_suite_keeps_rays_state_in_a_directory_of_its_own_and_removes_it(tmp_path: Path):
    # A session of this suite's conftest.py: Ray's files go to a temporary directory of its own,
    # gone when the session ends; the machine's own Ray directory is left as it was.
    shutil.copy(Path(__file__).with_name("conftest.py"), tmp_path / "conftest.py")
    (tmp_path / "test_suite.py").write_text(SUITE)
    machine = _address_file(os.environ.get("TMPDIR", "/tmp"))
    before = _state(machine)
    environment = {k: v for k, v in os.environ.items() if not k.startswith("RAY_")}
    done = subprocess.run(
        [sys.executable, "-m", "pytest", "-q", "-s", "-p", "no:cacheprovider", str(tmp_path / "test_suite.py")],
        cwd=tmp_path, env=environment, capture_output=True, text=True, timeout=120,
    )  # fmt: skip
    assert done.returncode == 0, done.stdout[-3000:] + done.stderr[-3000:]
    (written,) = [Path(line.split()[1]) for line in done.stdout.splitlines() if line.startswith("RAY_ADDRESS_FILE ")]
    assert written != machine and not written.exists() and not written.parent.parent.exists(), written
    assert _state(machine) == before, f"{machine} changed"


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
    local = cehmm.optimize_controller(make(), progress=False, **THIRD_PARTY_CONTROLLER, search="ce")
    remote = cehmm.optimize_controller(
        make(), progress=False, backend="ray", workers=2, **THIRD_PARTY_CONTROLLER, search="ce"
    )
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
