"""A plain numpy implementation of the cehmm algorithm, for comparison with the Rust engine.

Same algorithm as ``cehmm.optimize`` (model §2–4), written independently from the spec:

* the target-tracking world of model §4 (cases 1–3, every constant a parameter),
* the hierarchical HMM policy of model §2 with any number of levels (top-down sampling),
* Rubinstein's cross-entropy loop of model §3 (elite ``ceil(rho·N)`` with random tie-breaks,
  count refit, rows without counts kept, smoothing, patience stopping rule).

The N episodes of one iteration are simulated together: every world and policy quantity is an
array over episodes, with a Python loop over the T time steps and over the levels. Random numbers
come from ``numpy.random.default_rng(seed)``, so runs are reproducible but not bit-identical to
the Rust engine (which has its own streams); rewards are statistically comparable.

Usage::

    python benches/numpy_ce.py --check                 # case 3, [16], N=1000, 250 iterations, vs cehmm
    python benches/numpy_ce.py --case 3 --levels 16,16 --max-iterations 50
"""

from __future__ import annotations

import argparse
import math
import sys
import time
from collections.abc import Sequence
from dataclasses import dataclass

import numpy as np

# Heading h (0 up, 1 right, 2 down, 3 left) -> one forward step (di, dj); "up" decreases j.
HEAD_DI = np.array([0, 1, 0, -1])
HEAD_DJ = np.array([-1, 0, 1, 0])

# The target's 3×3 neighbourhood, staying put included (index 4).
NEIGH_DI = np.array([-1, 0, 1, -1, 0, 1, -1, 0, 1])
NEIGH_DJ = np.array([-1, -1, -1, 0, 0, 0, 1, 1, 1])

STEP3 = np.array([-1, 0, 1])

TURN_LEFT, TURN_RIGHT, FORWARD, NO_MOVE = 0, 1, 2, 3
# Heading change of each move: turn left −1, turn right +1, forward and no move 0.
TURN = np.array([-1, 1, 0, 0])


# --------------------------------------------------------------------------------------------
# The world (model §4)
# --------------------------------------------------------------------------------------------


@dataclass(frozen=True)
class Tracking:
    """The target-tracking world; the defaults are model §4's."""

    case: int = 3
    width: int = 20
    height: int = 20
    horizon: int = 100
    start_b: tuple[int, int] = (0, 19)
    start_c: tuple[int, int] = (19, 19)
    start_heading: int = 2  # down
    reward_radius: int = 3
    observe_radius: int = 3
    target_cell: tuple[int, int] = (10, 10)  # case 1
    target_rows: tuple[int, int] = (0, 9)  # cases 2 and 3: R_1 uniform on every column, these rows

    def __post_init__(self) -> None:
        if self.case not in (1, 2, 3):
            raise ValueError(f"case must be 1, 2 or 3, not {self.case}")

    @property
    def n_observations(self) -> int:
        return 1 if self.case == 2 else 16

    @property
    def n_decisions(self) -> int:
        return 16

    def reset(self, n: int, rng: np.random.Generator) -> dict[str, np.ndarray]:
        """The states ``x_1`` of ``n`` episodes. Mobiles are stacked on axis 0 (0 = B, 1 = C)."""
        mi = np.repeat(np.array([[self.start_b[0]], [self.start_c[0]]]), n, axis=1)
        mj = np.repeat(np.array([[self.start_b[1]], [self.start_c[1]]]), n, axis=1)
        mh = np.full((2, n), self.start_heading)
        if self.case == 1:
            ri = np.full(n, self.target_cell[0])
            rj = np.full(n, self.target_cell[1])
        else:
            rows = self.target_rows[1] - self.target_rows[0] + 1
            cell = rng.integers(0, rows * self.width, size=n)
            ri = cell % self.width
            rj = self.target_rows[0] + cell // self.width
        return {"mi": mi, "mj": mj, "mh": mh, "ri": ri, "rj": rj}

    def observe_and_reward(self, s: dict[str, np.ndarray]) -> tuple[np.ndarray, np.ndarray]:
        """``y_t`` of every episode, and whether step ``t`` is rewarded (counted before the move)."""
        dx = s["ri"] - s["mi"]  # (2, n): target minus mobile, per mobile
        dy = s["rj"] - s["mj"]
        cheb = np.maximum(np.abs(dx), np.abs(dy))
        rewarded = (cheb <= self.reward_radius).any(axis=0)
        if self.case == 2:
            return np.zeros(dx.shape[1], dtype=np.intp), rewarded
        # "Strictly ahead" is a positive component of (R - mobile) along the heading: facing up
        # it is j_R < j, right i_R > i, down j_R > j, left i_R < i.
        h = s["mh"]
        ahead = HEAD_DI[h] * dx + HEAD_DJ[h] * dy > 0
        obs = ahead.astype(np.intp) + 2 * (cheb < self.observe_radius)
        return obs[0] + 4 * obs[1], rewarded

    def step(self, s: dict[str, np.ndarray], d: np.ndarray, u: np.ndarray) -> None:
        """Moves the target (from the mobiles' cells before they move), then applies ``d``.

        ``u`` holds one uniform draw in [0, 1) per episode for the target's move.
        """
        if self.case != 1:
            self._move_target(s, u)
        a = np.stack((d >> 2, d & 3))  # (2, n): a_B, a_C
        h = s["mh"]
        fwd = a == FORWARD
        # Forward changes one coordinate by one, so clipping to the grid is exactly "stay put
        # when the cell ahead is off the grid" (and other moves leave an in-grid cell).
        s["mi"] = np.minimum(np.maximum(s["mi"] + HEAD_DI[h] * fwd, 0), self.width - 1)
        s["mj"] = np.minimum(np.maximum(s["mj"] + HEAD_DJ[h] * fwd, 0), self.height - 1)
        s["mh"] = (h + TURN[a]) & 3

    def _move_target(self, s: dict[str, np.ndarray], u: np.ndarray) -> None:
        # The weight |r' − B|² + |r' − C|² of r' = (i', j') splits into a column part and a row
        # part, so it is built from two (3, n) arrays instead of (9, n) ones; off-grid columns
        # and rows get a zero factor.
        ri, rj, mi, mj = s["ri"], s["rj"], s["mi"], s["mj"]
        ci = ri + STEP3[:, None]  # (3, n) candidate columns i - 1, i, i + 1
        cj = rj + STEP3[:, None]
        wi = (ci - mi[0]) ** 2 + (ci - mi[1]) ** 2
        wj = (cj - mj[0]) ** 2 + (cj - mj[1]) ** 2
        vi = (ci >= 0) & (ci < self.width)
        vj = (cj >= 0) & (cj < self.height)
        # weight[3·a + b] for row offset a and column offset b: the order of NEIGH_DI / NEIGH_DJ.
        weight = ((wj[:, None] + wi[None, :]) * (vj[:, None] & vi[None, :])).reshape(9, -1)
        # Cumulative sums by rows: on a (9, n) array np.cumsum(axis=0) is several times slower.
        cum = weight
        for k in range(1, 9):
            cum[k] += cum[k - 1]
        total = cum[-1]
        # Integer arithmetic keeps the draw exact: x in 0..total-1, and the first cumulative
        # weight above x belongs to a cell of positive weight (never an off-grid one).
        x = np.minimum((u * total).astype(np.int64), total - 1)
        k = (cum <= x).sum(axis=0)
        # total == 0 only if every candidate cell is both mobiles' cell (a 1×1 grid): stay put.
        k[total == 0] = 4
        s["ri"] = ri + NEIGH_DI[k]
        s["rj"] = rj + NEIGH_DJ[k]


# --------------------------------------------------------------------------------------------
# The policy (model §2)
# --------------------------------------------------------------------------------------------


class Hhmm:
    """An HHMM policy: ``h0 (M1, D)``, ``h1 (Y, U1, M1)``, then per level l = 2..Λ
    ``start (U_l, M_l)`` and ``step (M_{l-1}, U_l, M_l)``, with ``U_l = |M_{l+1}|`` or 1 at the top
    (the layout of the model §6 policy file)."""

    def __init__(self, n_obs: int, n_actions: int, levels: Sequence[int]) -> None:
        self.levels = [int(m) for m in levels]
        if not self.levels or min(self.levels) < 1:
            raise ValueError(f"levels must be non-empty positive sizes, not {levels}")
        self.n_obs, self.n_actions = n_obs, n_actions
        shapes = [(self.levels[0], n_actions), (n_obs, self.upper(1), self.levels[0])]
        for lv in range(2, len(self.levels) + 1):
            shapes.append((self.upper(lv), self.levels[lv - 1]))
            shapes.append((self.levels[lv - 2], self.upper(lv), self.levels[lv - 1]))
        self.tables = [np.full(shape, 1.0 / shape[-1]) for shape in shapes]  # uniform start

    def upper(self, lv: int) -> int:
        """``|M_{lv+1}|`` for the 1-based level ``lv``, or 1 at the top."""
        return self.levels[lv] if lv < len(self.levels) else 1

    def copy(self) -> Hhmm:
        other = Hhmm.__new__(Hhmm)
        other.levels, other.n_obs, other.n_actions = self.levels, self.n_obs, self.n_actions
        other.tables = [t.copy() for t in self.tables]
        return other

    def cumulated(self) -> list[np.ndarray]:
        """Each table as 2-D (rows, outcomes) cumulative sums, divided by the row total.

        The division makes every row end at exactly 1.0 (x / x is exact), and so do the entries
        after its last positive probability: with u in [0, 1), the drawn index (the first k with
        ``cum[k] > u``) always has positive probability, even when rounding left the row
        summing to 1 ± ε.
        """
        out = []
        for t in self.tables:
            c = np.cumsum(t.reshape(-1, t.shape[-1]), axis=1)
            out.append(c / c[:, -1:])
        return out


def draw(cum: np.ndarray, rows: np.ndarray, u: np.ndarray) -> np.ndarray:
    """One categorical draw per episode from the rows ``rows`` of a cumulated table: the first
    outcome whose cumulative probability exceeds ``u`` (argmax of a boolean is its first True;
    there always is one, since every row ends at 1.0 > u)."""
    return (np.take(cum, rows, axis=0) > u[:, None]).argmax(axis=1)


# --------------------------------------------------------------------------------------------
# Episodes: N at once
# --------------------------------------------------------------------------------------------


@dataclass
class Batch:
    """N recorded episodes: ``y[t, k]``, ``d[t, k]``, ``m[l-1, t, k]`` and rewards ``V[k]``."""

    y: np.ndarray
    d: np.ndarray
    m: np.ndarray
    reward: np.ndarray


def run_episodes(world: Tracking, policy: Hhmm, n: int, rng: np.random.Generator) -> Batch:
    """Draws ``n`` episodes of world × policy (model §4 step order, model §2 top-down sampling)."""
    horizon, depth = world.horizon, len(policy.levels)
    cum = policy.cumulated()
    s = world.reset(n, rng)
    ys = np.empty((horizon, n), dtype=np.intp)
    ds = np.empty((horizon, n), dtype=np.intp)
    ms = np.empty((depth, horizon, n), dtype=np.intp)
    reward = np.zeros(n, dtype=np.int64)
    zero = np.zeros(n, dtype=np.intp)
    # Per step: one uniform per level, one for d, one for the target's move.
    uniforms = rng.random((horizon, depth + 2, n))
    for t in range(horizon):
        u = uniforms[t]
        y, rewarded = world.observe_and_reward(s)
        reward += rewarded
        above = zero  # m_{lv+1}[t]; the top level has a single (index 0) upper condition
        for lv in range(depth, 1, -1):  # top-down: level Λ first
            if t == 0:  # start table of level lv: condition (∅, m_{lv+1}[1])
                m = draw(cum[2 * lv - 2], above, u[lv - 1])
            else:  # step table: condition (m_{lv-1}[t-1], m_{lv+1}[t])
                m = draw(cum[2 * lv - 1], ms[lv - 2, t - 1] * policy.upper(lv) + above, u[lv - 1])
            ms[lv - 1, t] = m
            above = m
        m1 = draw(cum[1], y * policy.upper(1) + above, u[0])
        d = draw(cum[0], m1, u[depth])
        ms[0, t], ys[t], ds[t] = m1, y, d
        world.step(s, d, u[depth + 1])
    return Batch(ys, ds, ms, reward.astype(np.float64))


def count(policy: Hhmm, batch: Batch, elite: np.ndarray) -> list[np.ndarray]:
    """The (condition, outcome) counts of the ``elite`` episodes, one array per table."""
    y, d, m = batch.y[:, elite], batch.d[:, elite], batch.m[:, :, elite]
    depth, levels = len(policy.levels), policy.levels
    out = []

    def tally(index: np.ndarray, shape: tuple[int, ...]) -> np.ndarray:
        return np.bincount(index.ravel(), minlength=math.prod(shape)).reshape(shape)

    out.append(tally(m[0] * policy.n_actions + d, policy.tables[0].shape))
    above = m[1] if depth >= 2 else 0
    out.append(tally((y * policy.upper(1) + above) * levels[0] + m[0], policy.tables[1].shape))
    for lv in range(2, depth + 1):
        size, u_size = levels[lv - 1], policy.upper(lv)
        outcome = m[lv - 1]
        above = m[lv] if lv < depth else np.zeros_like(outcome)
        out.append(tally(above[0] * size + outcome[0], policy.tables[2 * lv - 2].shape))  # t = 1
        rows = m[lv - 2, :-1] * u_size + above[1:]  # (m_{lv-1}[t-1], m_{lv+1}[t]) for t >= 2
        out.append(tally(rows * size + outcome[1:], policy.tables[2 * lv - 1].shape))
    return out


def update(policy: Hhmm, counts: list[np.ndarray], smoothing: float) -> None:
    """``h := α·counts/total + (1 − α)·h`` on rows with counts; other rows keep their values."""
    for k, (table, c) in enumerate(zip(policy.tables, counts)):
        total = c.sum(axis=-1, keepdims=True)
        refit = c / np.maximum(total, 1)
        policy.tables[k] = np.where(total > 0, smoothing * refit + (1.0 - smoothing) * table, table)


# --------------------------------------------------------------------------------------------
# The cross-entropy loop (model §3)
# --------------------------------------------------------------------------------------------


@dataclass
class Result:
    policy: Hhmm  # the policy that drew the best iteration
    last_policy: Hhmm
    history: dict[str, np.ndarray]
    best_iteration: int
    stop_reason: str
    seconds: float


def optimize(
    world: Tracking,
    levels: Sequence[int] = (16, 16),
    samples: int = 1000,
    rho: float = 0.5,
    smoothing: float = 1.0,
    patience: int = 100,
    max_iterations: int | None = None,
    seed: int = 0,
    progress: bool = False,
) -> Result:
    """Rubinstein's cross-entropy method over HHMM policies, the numpy way."""
    if not (0 < rho < 1 and 0 < smoothing <= 1 and samples >= 1 and patience >= 1):
        raise ValueError("expected 0 < rho < 1, 0 < smoothing <= 1, samples >= 1, patience >= 1")
    rng = np.random.default_rng(seed)
    policy = Hhmm(world.n_observations, world.n_decisions, levels)
    n_elite = min(max(math.ceil(rho * samples), 1), samples)
    rows: dict[str, list] = {k: [] for k in ("mean", "best", "elite_threshold", "elite_mean", "seconds", "successful")}
    best: tuple[float, int, Hhmm] | None = None
    unsuccessful = 0
    started = time.perf_counter()
    while True:
        iteration = len(rows["mean"])
        batch = run_episodes(world, policy, samples, rng)
        v = batch.reward
        # Sort by reward, highest first, ties broken by uniform random keys.
        order = np.lexsort((rng.random(samples), -v))
        elite = order[:n_elite]
        mean = float(v.mean())
        successful = best is None or mean > best[0]
        if successful:
            best = (mean, iteration, policy.copy())
            unsuccessful = 0
        else:
            unsuccessful += 1
        update(policy, count(policy, batch, elite), smoothing)
        seconds = time.perf_counter() - started
        for key, value in (
            ("mean", mean),
            ("best", v[order[0]]),
            ("elite_threshold", v[elite[-1]]),
            ("elite_mean", v[elite].mean()),
            ("seconds", seconds),
            ("successful", successful),
        ):
            rows[key].append(value)
        if progress:
            print(
                f"iteration {iteration:4d}  mean {mean:6.2f}  elite threshold {v[elite[-1]]:5.1f}  "
                f"best mean {best[0]:6.2f}  {seconds:6.2f} s",
                file=sys.stderr,
            )
        if unsuccessful >= patience:
            stop = "patience"
            break
        if max_iterations is not None and iteration + 1 >= max_iterations:
            stop = "max_iterations"
            break
    assert best is not None
    history = {k: np.asarray(val) for k, val in rows.items()}
    history["iteration"] = np.arange(len(rows["mean"]))
    return Result(best[2], policy, history, best[1], stop, time.perf_counter() - started)


# --------------------------------------------------------------------------------------------
# Command line
# --------------------------------------------------------------------------------------------


def _check(iterations: int, every: int) -> None:
    """Case 3, levels [16], N = 1000, the paper's settings, side by side with cehmm when it imports.

    From uniform tables both engines sit near a mean reward of 2 for a long while: most episodes
    score 0, so with rho = 0.5 the elite threshold is 0 and the elite is half noise. The means
    creep up, the threshold leaves 0 after roughly 100–200 iterations, and then they climb fast
    to 60+. Thirty iterations show no learning in either engine; the default of 250 does.
    """
    world = Tracking(case=3)
    settings = dict(levels=[16], samples=1000, rho=0.5, max_iterations=iterations, patience=10**9, seed=0)
    started = time.perf_counter()
    result = optimize(world, **settings)
    seconds = time.perf_counter() - started
    print(f"numpy_ce self-check: case 3, levels [16], N=1000, rho=0.5, alpha=1, {iterations} iterations, seed 0")
    rust = None
    try:
        import cehmm

        rust = cehmm.optimize(cehmm.TargetTracking(case=3), **settings, progress=False, eval_episodes=1000).history
    except ImportError:
        print("(cehmm does not import: numpy_ce alone)")
    h = result.history
    print("iteration  numpy mean  threshold" + ("  cehmm mean  threshold" if rust is not None else ""))
    shown = sorted(set(range(0, iterations, every)) | {iterations - 1})
    for k in shown:
        line = f"{k:9d}  {h['mean'][k]:10.2f}  {h['elite_threshold'][k]:9.0f}"
        if rust is not None:
            line += f"  {rust['mean'][k]:10.2f}  {rust['elite_threshold'][k]:9.0f}"
        print(line)
    rate = iterations * 1000 * world.horizon / seconds
    print(f"numpy_ce: {seconds:.1f} s for {iterations} iterations ({rate / 1e6:.2f} M episode-steps/s)")
    for name, hist in (("numpy_ce", h), ("cehmm", rust)):
        if hist is None:
            continue
        above = np.flatnonzero(hist["mean"] >= 10)
        first = f"iteration {above[0]}" if above.size else "never"
        print(f"{name}: first mean {hist['mean'][0]:.2f}, last {hist['mean'][-1]:.2f}; mean >= 10 first at {first}")


def main(argv: Sequence[str] | None = None) -> None:
    parser = argparse.ArgumentParser(description=__doc__, formatter_class=argparse.RawDescriptionHelpFormatter)
    parser.add_argument("--check", action="store_true", help="run the self-check and exit")
    parser.add_argument("--check-iterations", type=int, default=250, help="iterations of the self-check")
    parser.add_argument("--check-every", type=int, default=10, help="print every this many iterations")
    parser.add_argument("--case", type=int, default=3)
    parser.add_argument("--levels", default="16,16", help="memory sizes, bottom first, e.g. 16 or 16,2,2,2")
    parser.add_argument("--samples", type=int, default=1000)
    parser.add_argument("--rho", type=float, default=0.5)
    parser.add_argument("--smoothing", type=float, default=1.0)
    parser.add_argument("--patience", type=int, default=100)
    parser.add_argument("--max-iterations", type=int, default=None)
    parser.add_argument("--seed", type=int, default=0)
    args = parser.parse_args(argv)
    if args.check:
        _check(args.check_iterations, args.check_every)
        return
    levels = [int(x) for x in args.levels.split(",")]
    result = optimize(
        Tracking(case=args.case), levels=levels, samples=args.samples, rho=args.rho, smoothing=args.smoothing,
        patience=args.patience, max_iterations=args.max_iterations, seed=args.seed, progress=True,
    )  # fmt: skip
    h = result.history
    print(
        f"stopped ({result.stop_reason}) after {len(h['mean'])} iterations in {result.seconds:.1f} s; "
        f"best iteration {result.best_iteration} with mean {h['mean'][result.best_iteration]:.2f}"
    )


if __name__ == "__main__":
    main()
