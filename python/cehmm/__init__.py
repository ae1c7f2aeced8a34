"""cehmm: cross-entropic learning of hierarchical-HMM policies for partially observable worlds.

After F. Dambreville, "Cross-Entropic Learning of a Machine for the Decision in a Partially
Observable Universe". A policy is a hierarchical HMM with input (observations) and output
(decisions); its tables are optimised by Rubinstein's cross-entropy method. The engine is the
Rust crate ``ceworld`` (compiled here as the private module ``cehmm._core``).

Example:
    >>> import cehmm
    >>> world = cehmm.TargetTracking(case=1)
    >>> result = cehmm.optimize(world, levels=[4], samples=200, max_iterations=5, progress=False)
    >>> result.evaluation
    Evaluation(mean=1.596 ± 0.061, episodes=10000, ...)
    >>> result.policy.save("policy.json")
    >>> cehmm.Policy.load("policy.json").levels
    [4]
    >>> cehmm.TargetTracking(case=4)
    Traceback (most recent call last):
    ...
    cehmm.InvalidArgumentError: invalid case: 4 (expected 1, 2 or 3)

Errors: an argument of the wrong type raises ``TypeError`` (numpy integers and floats are taken
where Python ints and floats are); every other error of the engine is a :class:`CehmmError` (a
``ValueError``): :class:`InvalidArgumentError` (an argument out of its domain),
:class:`PolicyFormatError` (an invalid policy file or table), :class:`ModelFormatError` (an
invalid ``.pomdp`` file) and :class:`PolicyMismatchError` (a policy used with a world of other
sizes, or a model file that changed since the policy was made), :class:`WorldError` (a world
written in Python that returned an observation out of range or a reward that is not a finite
number; an exception raised by its own code propagates as itself). A file that cannot be read or written raises the
built-in ``OSError`` subclass of its errno (``FileNotFoundError``, ``PermissionError``, ...).
"""

from importlib.metadata import PackageNotFoundError, version

# The engine hands its tables over as numpy arrays: without numpy its module cannot load (a
# panic of the compiled module's initialisation, not an error one can read, would follow).
try:
    import numpy  # noqa: F401
except ImportError as e:
    raise ImportError(
        f"cehmm needs numpy, which cannot be imported here ({e}): install it with `python -m pip install numpy` "
        "(or reinstall cehmm with `python -m pip install cehmm`, which brings it)",
        name="numpy",
    ) from e

from . import callbacks
from ._core import (
    ENGINE_VERSION,
    CehmmError,
    InternalError,
    InvalidArgumentError,
    ModelFormatError,
    PolicyFormatError,
    PolicyMismatchError,
    WorldError,
)
from .controller import ControllerResult, optimize_controller
from .optimizer import OptimizeResult, optimize
from .outside import PythonWorld
from .policy import Policy
from .pomdp import PomdpWorld
from .qlearning import QLearner, WindowEvaluation, evaluate_windows, qlearning
from .ray_backend import RayBackend
from .results import Evaluation, ExactValue, Rollout
from .stepped import RunResult, run
from .tracking import TargetTracking
from .world import World

try:
    __version__ = version("cehmm")
except PackageNotFoundError:  # pragma: no cover - running from a source tree without metadata
    __version__ = ENGINE_VERSION

__all__ = [
    "CehmmError",
    "ControllerResult",
    "Evaluation",
    "ExactValue",
    "InternalError",
    "InvalidArgumentError",
    "ModelFormatError",
    "OptimizeResult",
    "Policy",
    "PolicyFormatError",
    "PolicyMismatchError",
    "PomdpWorld",
    "PythonWorld",
    "QLearner",
    "RayBackend",
    "RunResult",
    "Rollout",
    "TargetTracking",
    "WindowEvaluation",
    "World",
    "WorldError",
    "__version__",
    "callbacks",
    "evaluate_windows",
    "optimize",
    "optimize_controller",
    "qlearning",
    "run",
]
