"""The Ray backend (issue 21): the same tables as the local backend, on a local 2-CPU Ray.

Runs where Ray is installed (``pip install 'cehmm[ray]'``)."""

import numpy as np
import pytest

import cehmm

ray = pytest.importorskip("ray")

# Ray's own log files, left open by its processes at shutdown: not ours to close.
pytestmark = pytest.mark.filterwarnings("ignore::ResourceWarning", "ignore::pytest.PytestUnraisableExceptionWarning")


@pytest.fixture(scope="module")
def cluster():
    ray.init(num_cpus=2, include_dashboard=False, _node_ip_address="127.0.0.1", log_to_driver=False)
    yield
    ray.shutdown()


def test_episode_ce_on_ray_is_the_local_one(cluster):
    world = cehmm.TargetTracking(case=1)
    settings = dict(levels=[3, 2], samples=300, rho=0.2, max_iterations=4, eval_episodes=500, seed=3)
    local = cehmm.optimize(world, progress=False, init="random", **settings)
    for workers in (1, 3):
        remote = cehmm.optimize(world, progress=False, init="random", backend="ray", workers=workers, **settings)
        assert remote.policy.to_json() == local.policy.to_json()
        assert np.array_equal(remote.history["mean"], local.history["mean"])
        assert remote.evaluation.mean == local.evaluation.mean
    evaluation = local.policy.evaluate(world, episodes=2000, backend="ray", workers=2)
    assert evaluation.mean == local.policy.evaluate(world, episodes=2000).mean


def test_backend_errors_name_the_value():
    world = cehmm.TargetTracking(case=1)
    with pytest.raises(cehmm.InvalidArgumentError, match="backend: 'spark'"):
        cehmm.optimize(world, backend="spark", max_iterations=1, progress=False)
    with pytest.raises(cehmm.InvalidArgumentError, match="workers: 2 with backend='local'"):
        cehmm.optimize(world, workers=2, max_iterations=1, progress=False)
