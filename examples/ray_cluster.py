"""Episode CE of a world written in Python, its episodes sampled on a Ray cluster.

Run: ``pip install -e '.[ray]' && python examples/ray_cluster.py`` (a new local Ray of this
machine's CPUs, without a dashboard, on loopback with Ray 2.40: README; about fifteen seconds on
2 cores), or on a node of a running cluster ``python examples/ray_cluster.py --address auto``
(every node has cehmm installed: the engine runs there).

The world is the paper's target tracking written in Python (``cehmm.pyworlds.TrackingEpisodes``,
a step of Python code per episode-step): a module every node has, since it comes with cehmm. A
world of your own reaches the workers the same way (installed on every node), or in the job's
runtime environment: ``ray.init(address=..., runtime_env={"py_modules": [my_worlds]})``, where
``my_worlds`` is the imported module (or a folder) that defines it. The driver sends the
current tables each iteration and receives rewards and counts; with ``--check`` the same run is
done locally too and the two policies compared (they are the same, bit for bit).
"""

from __future__ import annotations

import argparse
import time

import ray

import cehmm
from cehmm.pyworlds import TrackingEpisodes

parser = argparse.ArgumentParser(description=__doc__.split("\n\n")[0])
parser.add_argument("--address", default=None, help="the cluster to join (default: start a local Ray)")
parser.add_argument("--workers", type=int, default=None, help="tasks per batch (default: the cluster's CPUs)")
parser.add_argument("--iterations", type=int, default=10)
parser.add_argument("--check", action="store_true", help="run locally too and compare")
parser.add_argument("--out", default="ray_policy.json")
args = parser.parse_args()

if args.address is None:
    ray.init(address="local", include_dashboard=False, _node_ip_address="127.0.0.1", log_to_driver=False)
else:
    ray.init(address=args.address)
print(f"Ray {ray.__version__}: {int(ray.cluster_resources().get('CPU', 0))} CPUs")

world = TrackingEpisodes(case=3)
settings = dict(levels=[4, 4], samples=1000, rho=0.1, max_iterations=args.iterations, eval_episodes=2000, seed=1)
start = time.perf_counter()
result = cehmm.optimize(world, backend=cehmm.RayBackend(workers=args.workers), **settings)
print(f"on Ray: mean reward {result.evaluation.mean:.3f} in {time.perf_counter() - start:.1f} s")
result.policy.save(args.out)
print(f"saved {args.out}")
if args.check:
    local = cehmm.optimize(world, progress=False, **settings)
    print("the local run's policy is the same:", local.policy.to_json() == result.policy.to_json())
ray.shutdown()
