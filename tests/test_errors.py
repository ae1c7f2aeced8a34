"""Bad arguments raise the documented exceptions, naming the argument and its value."""

from __future__ import annotations

import os
import resource
import shutil
import signal
import subprocess
import sys
from pathlib import Path

import pytest
from worlds import Corridor

import cehmm

FAST = dict(samples=20, max_iterations=1, eval_episodes=10, progress=False)


def test_hierarchy() -> None:
    for error in [
        cehmm.InvalidArgumentError,
        cehmm.PolicyFormatError,
        cehmm.PolicyMismatchError,
        cehmm.ModelFormatError,
        cehmm.InternalError,
    ]:
        assert issubclass(error, cehmm.CehmmError)
    assert issubclass(cehmm.CehmmError, ValueError)
    assert cehmm.CehmmError.__module__ == "cehmm"


@pytest.mark.parametrize(
    ("arguments", "named"),
    [
        ({"rho": 0}, r"rho: 0\b"),
        ({"rho": 1}, r"rho: 1\b"),
        ({"rho": 1.5}, r"rho: 1\.5"),
        ({"rho": float("nan")}, r"rho: NaN"),
        ({"samples": 0}, r"samples: 0\b"),
        ({"samples": -5}, r"samples: -5\b"),
        ({"levels": [16, 0]}, r"levels: \[16, 0\]"),
        ({"levels": []}, r"levels: \[\]"),
        ({"levels": [16, -1]}, r"levels: \[16, -1\]"),
        ({"levels": [70000]}, r"levels: \[70000\]"),
        ({"smoothing": 0}, r"smoothing: 0\b"),
        ({"smoothing": 1.01}, r"smoothing: 1\.01"),
        ({"decision_smoothing": 0}, r"decision_smoothing: 0\b"),
        ({"threads": 0}, r"threads: 0\b"),
        ({"threads": -1}, r"threads: -1\b"),
        ({"patience": 0}, r"patience: 0\b"),
        ({"max_iterations": 0}, r"max_iterations: 0\b"),
        ({"time_limit": 0}, r"time_limit: 0\b"),
        ({"time_limit": -1.0}, r"time_limit: -1\b"),
        ({"eval_episodes": 0}, r"eval_episodes: 0\b"),
        ({"seed": -1}, r"seed: -1\b"),
        ({"seed": 2**64}, r"seed: 18446744073709551616"),
        ({"init": "zeros"}, r'init: "zeros"'),
    ],
)
def test_bad_optimize_arguments(case1: cehmm.TargetTracking, arguments: dict, named: str) -> None:
    settings = {**FAST, **arguments}
    with pytest.raises(cehmm.InvalidArgumentError, match=named):
        cehmm.optimize(case1, **settings)


@pytest.mark.parametrize(
    ("arguments", "named"),
    [
        ({"rho": "half"}, r"rho: 'half' \(expected a number\)"),
        ({"rho": True}, r"rho: True \(expected a number\)"),
        ({"samples": 2.5}, r"samples: 2\.5 \(expected a non-negative int\)"),
        ({"samples": "10"}, r"samples: '10'"),
        ({"levels": [16, 2.0]}, r"levels: \[16, 2\.0\]: level 2 is 2\.0"),
        ({"levels": [16, True]}, r"levels: \[16, True\]: level 2 is True"),
        ({"levels": 16}, r"levels: 16\b"),
        ({"levels": "16"}, r"levels: '16'"),
        ({"progress": "yes"}, r"progress: 'yes'"),
        ({"progress": 1}, r"progress: 1\b"),
        ({"init": 3}, r"init: 3\b"),
        ({"memory_update": None}, r"memory_update: None"),
        ({"time_limit": "1"}, r"time_limit: '1'"),
    ],
)
def test_arguments_of_the_wrong_type_are_type_errors(case1: cehmm.TargetTracking, arguments: dict, named: str) -> None:
    with pytest.raises(TypeError, match=named) as raised:
        cehmm.optimize(case1, **{**FAST, **arguments})
    assert not isinstance(raised.value, cehmm.CehmmError)


def test_numpy_numbers_are_taken_where_python_numbers_are(case1: cehmm.TargetTracking) -> None:
    np = pytest.importorskip("numpy")
    settings = dict(samples=np.int64(20), rho=np.float32(0.5), smoothing=np.float64(1.0), seed=np.uint64(3))
    a = cehmm.optimize(case1, levels=np.array([4, 2]), max_iterations=2, progress=np.bool_(False), **settings)
    b = cehmm.optimize(
        case1, levels=[4, 2], samples=20, rho=0.5, smoothing=1.0, seed=3, max_iterations=2, progress=False
    )
    assert a.policy.to_json() == b.policy.to_json()
    assert a.policy.evaluate(case1, episodes=np.int32(10), seed=np.int64(1)) == b.policy.evaluate(
        case1, episodes=10, seed=1
    )
    assert cehmm.TargetTracking(case=np.int8(1), horizon=np.uint16(40)) == cehmm.TargetTracking(case=1, horizon=40)


def test_world_must_be_a_world() -> None:
    with pytest.raises(TypeError, match="world"):
        cehmm.optimize("case 1", **FAST)  # type: ignore[arg-type]
    with pytest.raises(TypeError, match="world"):
        cehmm.Policy.uniform(None, [4])  # type: ignore[arg-type]


@pytest.mark.parametrize(
    ("episodes", "error"), [(0, cehmm.InvalidArgumentError), (-1, cehmm.InvalidArgumentError), (1.5, TypeError)]
)
def test_bad_evaluation_arguments(case1: cehmm.TargetTracking, episodes: object, error: type) -> None:
    policy = cehmm.Policy.uniform(case1, [4])
    with pytest.raises(error, match="episodes"):
        policy.evaluate(case1, episodes=episodes)  # type: ignore[arg-type]
    with pytest.raises(cehmm.InvalidArgumentError, match="threads: 0"):
        policy.evaluate(case1, episodes=10, threads=0)


def test_policy_without_world_needs_one(case1: cehmm.TargetTracking) -> None:
    policy = cehmm.Policy.from_tables(cehmm.Policy.uniform(case1, [4]).tables)
    with pytest.raises(cehmm.InvalidArgumentError, match="no stored world"):
        policy.evaluate(episodes=10)
    assert policy.evaluate(case1, episodes=10).episodes == 10


def test_policies_are_made_by_factories() -> None:
    with pytest.raises(TypeError, match="Policy.uniform"):
        cehmm.Policy(object())  # type: ignore[arg-type]


def test_exported_names() -> None:
    for name in cehmm.__all__:
        assert hasattr(cehmm, name), name
    assert cehmm.__version__ == "0.1.0"


def test_an_unwritable_checkpoint_is_refused_before_the_run(case1: cehmm.TargetTracking, tmp_path: Path) -> None:
    # The runs would last a minute (their time limit) if the refusal came at the first save.
    path = tmp_path / "missing" / "run.ckpt"
    long = dict(max_iterations=10**9, time_limit=60.0)
    with pytest.raises(FileNotFoundError) as raised:
        cehmm.optimize(case1, checkpoint=path, **{**FAST, **long})
    assert raised.value.filename == str(path)
    with pytest.raises(FileNotFoundError) as raised:
        cehmm.optimize_controller(case1, search="ce", nodes=2, samples=10, checkpoint=path, progress=False, **long)
    assert raised.value.filename == str(path)
    assert not path.parent.exists()


class LosesTheDisk(Corridor):
    """The corridor, whose 300th step removes the checkpoint's folder (a disk gone full or lost)."""

    def __init__(self, folder: Path) -> None:
        self.folder, self.steps = folder, 0

    def step(self, decision: int) -> tuple[int, float, bool]:
        self.steps += 1
        if self.steps == 300:
            shutil.rmtree(self.folder)
        return super().step(decision)


@pytest.mark.parametrize("search", ["optimize", "optimize_controller"])
def test_a_checkpoint_that_cannot_be_written_does_not_cost_the_result(tmp_path: Path, search: str) -> None:
    run = getattr(cehmm, search)
    settings = dict(samples=20, max_iterations=4, eval_episodes=20, progress=False)
    if search == "optimize_controller":
        settings.update(nodes=4, episodes=2, select_episodes=5)
    reference = run(Corridor(), **settings)
    folder = tmp_path / "disk"
    folder.mkdir()
    with pytest.warns(RuntimeWarning, match=r"checkpoint could not be written \(.*run\.ckpt.*the run went on"):
        result = run(LosesTheDisk(folder), checkpoint=folder / "run.ckpt", checkpoint_every=1e-6, **settings)
    assert list(result.history["mean"]) == list(reference.history["mean"])
    assert result.evaluation == reference.evaluation
    assert not folder.exists()


class Hang(Exception):
    """An entry point that did not return within its time."""


def _path_kinds(tmp: Path) -> dict[str, str]:
    """Paths that are not a regular file one may read or write, by kind."""
    fifo = tmp / "fifo"
    os.mkfifo(fifo)
    (tmp / "dir").mkdir()
    (tmp / "zero-link").symlink_to("/dev/zero")
    (tmp / "fifo-link").symlink_to(fifo)
    return {
        "device": "/dev/zero",
        "fifo": str(fifo),
        "link to a device": str(tmp / "zero-link"),
        "link to a fifo": str(tmp / "fifo-link"),
        "directory": str(tmp / "dir"),
        "missing folder": str(tmp / "missing" / "file"),
    }


#: Every entry point that takes a path, reading or writing it.
ENTRY_POINTS = {
    "Policy.load": lambda p: cehmm.Policy.load(p),
    "Policy.save": lambda p: cehmm.Policy.uniform(cehmm.TargetTracking(case=1), [2]).save(p),
    "PomdpWorld.from_file": lambda p: cehmm.PomdpWorld.from_file(p),
    "optimize(checkpoint, resume)": lambda p: cehmm.optimize(
        cehmm.TargetTracking(case=1), checkpoint=p, resume=True, **FAST
    ),
    "optimize(checkpoint)": lambda p: cehmm.optimize(cehmm.TargetTracking(case=1), checkpoint=p, **FAST),
    "optimize_controller(checkpoint, resume)": lambda p: cehmm.optimize_controller(
        cehmm.TargetTracking(case=1), nodes=2, samples=10, max_iterations=1, checkpoint=p, resume=True, progress=False
    ),
    "QLearner.load": lambda p: cehmm.QLearner.load(p),
}


@pytest.mark.skipif(not Path("/dev/zero").exists(), reason="needs /dev/zero and FIFOs")
@pytest.mark.parametrize("entry", sorted(ENTRY_POINTS))
def test_every_path_that_is_not_a_regular_file_is_refused_at_once(tmp_path: Path, entry: str) -> None:
    # Devices were read to exhaustion and FIFOs blocked forever on open; each is now refused in
    # well under a second, naming the path, with a CehmmError or the OSError of its errno.
    def hang(signum: int, frame: object) -> None:
        raise Hang(entry)

    previous = signal.signal(signal.SIGALRM, hang)
    try:
        for kind, path in _path_kinds(tmp_path).items():
            signal.setitimer(signal.ITIMER_REAL, 10.0)
            try:
                with pytest.raises((cehmm.CehmmError, OSError)) as raised:
                    ENTRY_POINTS[entry](path)
            finally:
                signal.setitimer(signal.ITIMER_REAL, 0)
            assert not isinstance(raised.value, cehmm.InternalError), (entry, kind, raised.value)
            named = str(raised.value) + str(getattr(raised.value, "filename", ""))
            assert path in named or os.path.dirname(path) in named, (entry, kind, raised.value)
    finally:
        signal.signal(signal.SIGALRM, previous)


@pytest.mark.skipif(sys.platform != "linux", reason="RLIMIT_AS as Linux has it")
def test_a_model_too_large_for_the_process_limits_is_refused_not_an_abort(tmp_path: Path) -> None:
    # 57 bytes, 2^26 actions (tables within the entries a world allows): over 3 GiB of tables
    # and rows. Under a 3 GB address-space limit the allocation used to abort the interpreter;
    # it is refused by name before it is made.
    model = tmp_path / "huge.pomdp"
    model.write_text("states: 1\nactions: 67108864\nobservations: 1\nO: * uniform\n")
    code = (
        "import cehmm, sys\n"
        "try:\n"
        f"    cehmm.PomdpWorld.from_file({str(model)!r})\n"
        "except cehmm.ModelFormatError as e:\n"
        "    print(e); sys.exit(3)\n"
    )

    def limit() -> None:
        resource.setrlimit(resource.RLIMIT_AS, (3 << 30, 3 << 30))

    out = subprocess.run([sys.executable, "-c", code], capture_output=True, text=True, preexec_fn=limit, timeout=120)
    assert out.returncode == 3, out.stderr
    assert "the tables T and O" in out.stdout and "needs" in out.stdout


def test_backend_ray_without_ray_says_how_to_install_it(monkeypatch: pytest.MonkeyPatch) -> None:
    # `import ray` fails as it does where Ray is not installed.
    monkeypatch.setitem(sys.modules, "ray", None)
    with pytest.raises(ImportError, match=r"pip install 'cehmm\[ray\]'"):
        cehmm.optimize(Corridor(), backend="ray", **FAST)


def test_exact_values_and_graphs_of_a_world_written_in_python_are_refused_by_name() -> None:
    # Was: TypeError: 'OutsideWorld' object is not an instance of 'World'.
    from worlds import Corridor

    policy = cehmm.Policy.uniform(Corridor(), [2])
    for world in (Corridor(), cehmm.PythonWorld(Corridor())):
        with pytest.raises(cehmm.InvalidArgumentError, match="outside the engine.*needs a tabular world"):
            policy.evaluate_exact(world)
        with pytest.raises(cehmm.InvalidArgumentError, match="outside the engine.*needs a tabular world"):
            policy.graph(world)
    with pytest.raises(cehmm.InvalidArgumentError, match="target-tracking.*needs a tabular world"):
        cehmm.Policy.uniform(cehmm.TargetTracking(case=1), [2]).evaluate_exact()
