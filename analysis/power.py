"""Simulation-based power: how many subjects are needed to detect an effect of a given size.

Two effects, each simulated in the paper's design (20 objects x 8 levels x 2 conditions per
subject) and tested at level ``alpha``:

* ``odds_ratio``: data from :class:`analysis.simulate.LogisticObserver` with the given background
  odds ratio (random subject and object intercepts); detected when the background term of the
  fixed-effects logistic model (object and subject dummies, log10 pixels) has a Wald p < alpha and
  OR > 1;
* ``threshold_ratio``: Weibull observers whose cluttered 50 % threshold is ``ratio`` times the
  de-cluttered one (shared slope and lapse; per-subject spread of thresholds); detected by a
  likelihood-ratio test (chi-square, 1 df) of separate vs common thresholds, with the de-cluttered
  threshold lower.
"""

from __future__ import annotations

import contextlib
import math
import warnings
from collections.abc import Callable, Iterator, Sequence
from dataclasses import asdict, dataclass
from typing import Any, Literal

import numpy as np
import pandas as pd
from scipy import optimize, stats

from analysis.jung2015 import PIXEL_COUNTS, THRESHOLD_P50_PX
from analysis.simulate import (
    LogisticObserver,
    WeibullObserver,
    simulate_logistic_trials,
    simulate_weibull_trials,
)
from analysis.weibull.kernel import log_likelihood

__all__ = [
    "CLUSTER_CONNECT_TIMEOUT_S",
    "MAX_SIMS",
    "MIN_POOL_STUDIES",
    "PowerPoint",
    "PowerResult",
    "GridPoint",
    "iter_power",
    "power_analysis",
    "power_grid",
    "level_pixels",
    "chunk_tasks",
    "collect_grid",
    "execute_chunks",
    "quiet_statsmodels",
]

Effect = Literal["odds_ratio", "threshold_ratio"]

#: Weibull shape and lapse of the simulated observers for threshold ratios (ours: close to fits
#: of the paper's Fig. 8 curves, which rise over about one decade of pixels).
SIM_BETA: float = 1.2
SIM_LAPSE: float = 0.05
#: Per-subject SD of log10 threshold (ours; Fig. 9 spreads subjects over ~0.3 log units).
SIM_SUBJECT_LOG10_SD: float = 0.15


class _PowerEstimate:
    """The JSON form shared by the power records, each with its power's ``ci95``."""

    def to_dict(self) -> dict[str, Any]:
        """Return a JSON-ready dict."""
        return {**asdict(self), "ci95": list(self.ci95)}


@dataclass(frozen=True)
class PowerPoint(_PowerEstimate):
    """Estimated power at one number of subjects.

    Parameters
    ----------
    n_subjects : int
    power : float
        Fraction of simulations in which the effect was detected.
    ci95 : (float, float)
        Clopper-Pearson 95 % interval of that fraction.
    n_sims : int
    """

    n_subjects: int
    power: float
    ci95: tuple[float, float]
    n_sims: int

    @classmethod
    def from_dict(cls, d: dict[str, Any]) -> PowerPoint:
        """Inverse of :meth:`to_dict`."""
        return cls(int(d["n_subjects"]), float(d["power"]), tuple(d["ci95"]), int(d["n_sims"]))


@dataclass(frozen=True)
class PowerResult:
    """A power curve and the smallest number of subjects reaching the target power.

    Parameters
    ----------
    effect : {'odds_ratio', 'threshold_ratio'}
    size : float
        The effect size simulated.
    alpha : float
        Test level.
    target_power : float
    points : tuple of PowerPoint
    n_required : int or None
        Smallest simulated number of subjects whose power >= target (None: none reached it).
    """

    effect: str
    size: float
    alpha: float
    target_power: float
    points: tuple[PowerPoint, ...]
    n_required: int | None

    def to_dict(self) -> dict[str, Any]:
        """Return a JSON-ready dict."""
        return {
            "effect": self.effect,
            "size": self.size,
            "alpha": self.alpha,
            "target_power": self.target_power,
            "points": [p.to_dict() for p in self.points],
            "n_required": self.n_required,
        }

    @classmethod
    def from_dict(cls, d: dict[str, Any]) -> PowerResult:
        """Rebuild from :meth:`to_dict` output."""
        points = tuple(PowerPoint.from_dict(p) for p in d["points"])
        return cls(
            effect=str(d["effect"]),
            size=float(d["size"]),
            alpha=float(d["alpha"]),
            target_power=float(d["target_power"]),
            points=points,
            n_required=None if d["n_required"] is None else int(d["n_required"]),
        )


def _clopper_pearson(k: int, n: int) -> tuple[float, float]:
    lo = 0.0 if k == 0 else float(stats.beta.ppf(0.025, k, n - k + 1))
    hi = 1.0 if k == n else float(stats.beta.ppf(0.975, k + 1, n - k))
    return lo, hi


def _detect(
    effect: str,
    size: float,
    n_subjects: int,
    alpha: float,
    rng,
    n_objects: int = 20,
    pixels: tuple[float, ...] = PIXEL_COUNTS,
) -> bool:
    """Simulate one study of ``effect`` at ``size`` and return whether its test detects it."""
    design = {"n_subjects": n_subjects, "n_objects": n_objects, "pixels": pixels}
    if effect == "odds_ratio":
        d = simulate_logistic_trials(LogisticObserver(background_or=size), **design, rng=rng)
        return _odds_ratio_detected(d, alpha)
    t_d = THRESHOLD_P50_PX["decluttered"]
    # alpha_px from the 50 % threshold: x50 = a * (-ln(1 - 0.5 / (1 - l))) ** (1 / b)
    scale = (-math.log(1 - 0.5 / (1 - SIM_LAPSE))) ** (1 / SIM_BETA)
    obs = {
        "cluttered": WeibullObserver(size * t_d / scale, SIM_BETA, SIM_LAPSE),
        "decluttered": WeibullObserver(t_d / scale, SIM_BETA, SIM_LAPSE),
    }
    d = simulate_weibull_trials(obs, **design, subject_log10_sd=SIM_SUBJECT_LOG10_SD, rng=rng)
    return _threshold_ratio_detected(d, alpha)


def _odds_ratio_detected(d: pd.DataFrame, alpha: float) -> bool:
    """Return whether the fixed-effects logistic model finds the background odds ratio > 1."""
    import statsmodels.api as sm

    y = d["recognized"].to_numpy()
    if y.min() == y.max():
        return False
    obj = np.asarray(d["object"].astype(int))
    subj = d["subject"].to_numpy()
    cols = [
        np.ones(len(d)),
        (d["condition"] == "decluttered").to_numpy(float),
        np.log10(d["pixels"].to_numpy()),
    ]
    cols += [(obj == o).astype(float) for o in np.unique(obj)[1:]]
    cols += [(subj == s).astype(float) for s in np.unique(subj)[1:]]
    X = np.column_stack(cols)
    try:
        res = sm.Logit(y, X).fit(method="newton", disp=False, maxiter=100)
    except Exception:  # noqa: BLE001 - separation in a small simulated data set: not detected
        return False
    return bool(res.pvalues[1] < alpha and res.params[1] > 0)


def _nll_joint(theta, xs, ks, ns, shared_loc: bool) -> float:
    if shared_loc:
        loc_c = loc_d = theta[0]
        lb, lapse = theta[1], theta[2]
    else:
        loc_c, loc_d, lb, lapse = theta
    total = 0.0
    for loc, x, k, n in ((loc_c, xs[0], ks[0], ns[0]), (loc_d, xs[1], ks[1], ns[1])):
        total += float(log_likelihood(np.array([[loc, lb, lapse]]), x, k, n, 0.0, "weibull")[0])
    return -total


def _threshold_ratio_detected(d: pd.DataFrame, alpha: float) -> bool:
    """Return whether the likelihood-ratio test finds a lower de-cluttered threshold."""
    xs, ks, ns = [], [], []
    for c in ("cluttered", "decluttered"):
        g = d[d["condition"] == c].groupby("pixels")["recognized"].agg(["sum", "size"])
        xs.append(g.index.to_numpy(float))
        ks.append(g["sum"].to_numpy(float))
        ns.append(g["size"].to_numpy(float))
    lo, hi = math.log10(min(PIXEL_COUNTS)) - 1, math.log10(max(PIXEL_COUNTS)) + 1
    b_sep = [(lo, hi), (lo, hi), (math.log(0.05), math.log(20)), (0.0, 0.5)]
    b_com = [(lo, hi), (math.log(0.05), math.log(20)), (0.0, 0.5)]
    best_sep = min(
        (
            optimize.minimize(
                _nll_joint, s, args=(xs, ks, ns, False), method="L-BFGS-B", bounds=b_sep
            )
            for s in ([3.5, 3.5, 0.0, 0.05], [4.0, 3.0, 0.3, 0.05])
        ),
        key=lambda r: r.fun,
    )
    best_com = optimize.minimize(
        _nll_joint, [3.7, 0.0, 0.05], args=(xs, ks, ns, True), method="L-BFGS-B", bounds=b_com
    )
    lr = 2 * (best_com.fun - best_sep.fun)
    p = float(stats.chi2.sf(max(lr, 0.0), 1))
    return bool(p < alpha and best_sep.x[0] > best_sep.x[1])


def iter_power(
    effect: Effect,
    size: float,
    n_subjects: Sequence[int],
    *,
    n_sims: int = 200,
    alpha: float = 0.05,
    rng: np.random.Generator | int | None = None,
) -> Iterator[PowerPoint | None]:
    """Simulate and test, yielding ``None`` after each simulation and a PowerPoint per size.

    Parameters
    ----------
    effect : {'odds_ratio', 'threshold_ratio'}
    size : float
        Odds ratio (> 0) or cluttered / de-cluttered threshold ratio (> 0).
    n_subjects : sequence of int
        Numbers of subjects to try (each >= 1).
    n_sims : int
        Simulations per number of subjects.
    alpha : float
        Test level in (0, 1).
    rng : numpy.random.Generator or int or None

    Yields
    ------
    PowerPoint or None
    """
    if effect not in ("odds_ratio", "threshold_ratio"):
        raise ValueError(f"effect must be 'odds_ratio' or 'threshold_ratio', got {effect!r}")
    if not size > 0:
        raise ValueError(f"size must be > 0, got {size!r}")
    if not 1 <= n_sims <= MAX_SIMS:
        raise ValueError(f"n_sims must be in [1, {MAX_SIMS}], got {n_sims!r}")
    if not (0 < alpha < 1):
        raise ValueError(f"alpha must be in (0, 1), got {alpha!r}")
    if not n_subjects or min(n_subjects) < 1:
        raise ValueError(
            f"n_subjects must be a non-empty list of integers >= 1, got {n_subjects!r}"
        )
    rng = np.random.default_rng(rng)
    for n in n_subjects:
        hits = 0
        for _ in range(n_sims):
            hits += _detect(effect, size, int(n), alpha, rng)
            yield None
        yield PowerPoint(int(n), hits / n_sims, _clopper_pearson(hits, n_sims), n_sims)


def power_analysis(
    effect: Effect,
    size: float,
    n_subjects: Sequence[int] = (1, 2, 3, 4, 6, 8),
    *,
    target_power: float = 0.8,
    n_sims: int = 200,
    alpha: float = 0.05,
    rng: np.random.Generator | int | None = None,
) -> PowerResult:
    """Estimate power at each number of subjects and the smallest number reaching the target.

    Parameters
    ----------
    effect : {'odds_ratio', 'threshold_ratio'}
    size : float
        Effect size (see :func:`iter_power`).
    n_subjects : sequence of int
        Numbers of subjects to try.
    target_power : float
        Power wanted, in (0, 1).
    n_sims : int
        Simulations per number of subjects.
    alpha : float
        Test level.
    rng : numpy.random.Generator or int or None

    Returns
    -------
    PowerResult
    """
    if not (0 < target_power < 1):
        raise ValueError(f"target_power must be in (0, 1), got {target_power!r}")
    points = [
        p
        for p in iter_power(effect, size, sorted(n_subjects), n_sims=n_sims, alpha=alpha, rng=rng)
        if p is not None
    ]
    n_req = next((p.n_subjects for p in points if p.power >= target_power), None)
    return PowerResult(effect, float(size), float(alpha), float(target_power), tuple(points), n_req)


def level_pixels(n_levels: int) -> tuple[float, ...]:
    """Return the pixel counts of a design with ``n_levels`` resolution levels.

    The paper's eight levels (:data:`analysis.jung2015.PIXEL_COUNTS`) when ``n_levels`` is 8;
    otherwise ``n_levels`` log-spaced counts over the same range.

    Parameters
    ----------
    n_levels : int
        Number of levels, >= 2.

    Returns
    -------
    tuple of float
    """
    if n_levels < 2:
        raise ValueError(f"n_levels must be >= 2, got {n_levels!r}")
    px = sorted(float(p) for p in PIXEL_COUNTS)
    if n_levels == len(px):
        return tuple(px)
    return tuple(float(round(v)) for v in np.geomspace(px[0], px[-1], n_levels))


@dataclass(frozen=True)
class GridPoint(_PowerEstimate):
    """Power at one design and effect size.

    Parameters
    ----------
    size : float
        Effect size simulated.
    n_subjects, n_objects, n_levels : int
        Design.
    power : float
    ci95 : (float, float)
        Clopper-Pearson 95 % interval.
    n_sims : int
    """

    size: float
    n_subjects: int
    n_objects: int
    n_levels: int
    power: float
    ci95: tuple[float, float]
    n_sims: int


@contextlib.contextmanager
def quiet_statsmodels() -> Iterator[None]:
    """Import statsmodels, then ignore warnings inside the block (a worker's chunk of studies)."""
    # statsmodels adds "always" filters for its warnings when first imported: import it before
    # the filters below, or they would be overridden in a fresh worker process.
    import statsmodels.api  # noqa: F401

    with warnings.catch_warnings():
        warnings.simplefilter("ignore")
        yield


def _run_chunk(
    effect: str,
    size: float,
    n_subjects: int,
    n_objects: int,
    n_levels: int,
    alpha: float,
    seeds: list[np.random.SeedSequence],
) -> list[bool]:
    """Simulate and test one chunk of studies; each study has its own seed (picklable task)."""
    pixels = level_pixels(n_levels)
    out = []
    with quiet_statsmodels():
        for ss in seeds:
            rng = np.random.default_rng(ss)
            out.append(bool(_detect(effect, size, n_subjects, alpha, rng, n_objects, pixels)))
    return out


#: Studies per task sent to a worker (ours): large enough to hide the task overhead.
CHUNK_SIMS: int = 10

#: Most simulated studies per grid point (ours): at 10^6 the power's 95 % interval is about
#: +-0.001 wide, and every study costs seeds and a task before any work, so more only hangs.
MAX_SIMS: int = 1_000_000

#: Fewest simulated studies worth a pool of worker processes (ours): each spawned worker
#: imports NumPy, SciPy and statsmodels afresh (about 2 s of CPU on a 2-core machine, the cost
#: of some 20 studies), so a smaller job runs in this process, whatever ``processes`` says. The
#: results are the same either way (every study has its own seed).
MIN_POOL_STUDIES: int = 100

#: Seconds to wait for a Dask scheduler (ours): a reachable scheduler answers in well under a
#: second; an unreachable address otherwise waits Dask's 30 s default.
CLUSTER_CONNECT_TIMEOUT_S: float = 5.0


def power_grid(
    effect: Effect,
    sizes: Sequence[float],
    n_subjects: Sequence[int],
    *,
    n_objects: Sequence[int] = (20,),
    n_levels: Sequence[int] = (8,),
    n_sims: int = 200,
    alpha: float = 0.05,
    seed: int | None = None,
    processes: int | None = None,
    cluster: str | None = None,
) -> Iterator[GridPoint | int]:
    """Estimate power over a grid of effect sizes and designs, in parallel.

    Every simulated study has its own seed, spawned from ``seed`` by its position in the grid
    (``SeedSequence(seed).spawn`` per grid point, then per study), so the results are identical
    for the same seed whether the studies run here, in local processes or on a Dask cluster,
    and in whatever order they finish.

    Parameters
    ----------
    effect : {'odds_ratio', 'threshold_ratio'}
    sizes : sequence of float
        Effect sizes (each finite and > 0).
    n_subjects, n_objects, n_levels : sequence of int
        Designs to try (subjects >= 1, objects >= 1, levels >= 2).
    n_sims : int
        Studies per grid point.
    alpha : float
        Test level in (0, 1).
    seed : int or None
        Root seed (None: fresh entropy, printed nowhere; give one to reproduce).
    processes : int or None
        Local worker processes (None: one per CPU; 1: run here).
    cluster : str or None
        Address of a running Dask distributed scheduler (``tcp://host:8786``); needs the
        ``dask`` extra. Overrides ``processes``.

    Yields
    ------
    int or GridPoint
        The number of studies finished so far (progress), and each grid point when all its
        studies are in, in grid order.

    Raises
    ------
    ValueError
        Bad arguments.
    ImportError
        ``cluster`` given without Dask installed.
    """
    if effect not in ("odds_ratio", "threshold_ratio"):
        raise ValueError(f"effect must be 'odds_ratio' or 'threshold_ratio', got {effect!r}")
    if not sizes or not all(math.isfinite(v) and v > 0 for v in sizes):
        raise ValueError(f"effect sizes must be finite and > 0, got {list(sizes)!r}")
    if not 1 <= n_sims <= MAX_SIMS:
        raise ValueError(f"n_sims must be in [1, {MAX_SIMS}], got {n_sims!r}")
    if not (0 < alpha < 1):
        raise ValueError(f"alpha must be in (0, 1), got {alpha!r}")
    for name, vals, low in (
        ("subjects", n_subjects, 1),
        ("objects", n_objects, 1),
        ("levels", n_levels, 2),
    ):
        if not vals or min(vals) < low:
            raise ValueError(f"numbers of {name} must be integers >= {low}, got {list(vals)!r}")
    grid = [
        (float(z), int(s), int(o), int(lv))
        for z in sizes
        for lv in n_levels
        for o in n_objects
        for s in n_subjects
    ]
    tasks = chunk_tasks([(effect, *g, alpha) for g in grid], n_sims, seed, CHUNK_SIMS)

    def point(gi: int, hits: int) -> GridPoint:
        z, s, o, lv = grid[gi]
        return GridPoint(z, s, o, lv, hits / n_sims, _clopper_pearson(hits, n_sims), n_sims)

    results = execute_chunks(_run_chunk, tasks, processes, cluster)
    yield from collect_grid(results, len(grid), n_sims, point)


def chunk_tasks(
    point_args: Sequence[tuple], n_sims: int, seed: int | None, chunk_sims: int
) -> list[tuple[int, tuple]]:
    """Split each grid point's ``n_sims`` studies into tasks of at most ``chunk_sims`` seeds.

    Every study's seed is spawned from ``seed`` by its position in the grid
    (``SeedSequence(seed).spawn`` per grid point, then per study), so a study's result does not
    depend on which task, worker or order ran it.

    Parameters
    ----------
    point_args : sequence of tuple
        Per grid point, the arguments of the chunk function before its list of seeds.
    n_sims : int
        Studies per grid point.
    seed : int or None
        Root seed.
    chunk_sims : int
        Most studies per task.

    Returns
    -------
    list of (int, tuple)
        ``(grid index, chunk function arguments)``, the seeds last.
    """
    roots = np.random.SeedSequence(seed).spawn(len(point_args))
    tasks = []
    for gi, args in enumerate(point_args):
        seeds = roots[gi].spawn(n_sims)
        for c in range(0, n_sims, chunk_sims):
            tasks.append((gi, (*args, seeds[c : c + chunk_sims])))
    return tasks


def collect_grid(
    results: Iterator[tuple[int, list[bool]]],
    n_points: int,
    n_sims: int,
    make_point: Callable[[int, int], Any],
) -> Iterator[Any]:
    """Count finished studies per grid point; yield progress and the points in grid order.

    Parameters
    ----------
    results : iterator of (int, list of bool)
        Per finished task, its grid index and whether each of its studies detected the effect
        (from :func:`execute_chunks`, in any order).
    n_points, n_sims : int
        Grid points, and studies per grid point.
    make_point : callable
        ``make_point(grid_index, hits)`` builds a finished grid point's result.

    Yields
    ------
    int or point
        The number of studies finished so far, and each grid point when all its studies are in,
        in grid order.
    """
    hits = [0] * n_points
    left = [n_sims] * n_points
    done_points: dict[int, Any] = {}
    next_point = 0
    finished = 0
    for gi, res in results:
        hits[gi] += sum(res)
        left[gi] -= len(res)
        finished += len(res)
        yield finished
        if left[gi] == 0:
            done_points[gi] = make_point(gi, hits[gi])
        while next_point in done_points:
            yield done_points.pop(next_point)
            next_point += 1


def execute_chunks(
    run_chunk: Callable[..., list[bool]],
    tasks: Sequence[tuple[int, tuple]],
    processes: int | None,
    cluster: str | None,
) -> Iterator[tuple[int, list[bool]]]:
    """Run ``run_chunk(*args)`` for every ``(grid index, args)`` task; yield results as they end.

    Parameters
    ----------
    run_chunk : callable
        A module-level (picklable) function simulating and testing one chunk of studies.
    tasks : sequence of (int, tuple)
        From :func:`chunk_tasks`.
    processes : int or None
        Local worker processes (None: one per CPU; 1: run here). Fewer than
        :data:`MIN_POOL_STUDIES` studies in all run here, whatever the number.
    cluster : str or None
        Address of a running Dask scheduler; needs the ``dask`` extra. Overrides ``processes``.

    Yields
    ------
    (int, list of bool)
        A task's grid index and its chunk's result, in the order the tasks finish.

    Raises
    ------
    ImportError
        ``cluster`` given without Dask installed.
    OptionError
        ``cluster`` not reachable within :data:`CLUSTER_CONNECT_TIMEOUT_S`.
    """
    if cluster:
        try:
            from dask.distributed import Client, as_completed
        except ImportError as exc:
            raise ImportError(
                "--cluster needs Dask: install the 'dask' extra (pip install .[dask])"
            ) from exc
        from analysis.errors import OptionError

        try:
            client = Client(cluster, timeout=f"{CLUSTER_CONNECT_TIMEOUT_S}s")
        except (OSError, ValueError) as exc:  # unreachable (a timeout) or not an address
            raise OptionError(
                f"--cluster {cluster}: cannot reach the Dask scheduler within "
                f"{CLUSTER_CONNECT_TIMEOUT_S:g} s ({exc}); start it or check the address"
            ) from None
        with client:
            futs = {client.submit(run_chunk, *args, pure=False): gi for gi, args in tasks}
            for fut in as_completed(list(futs)):
                yield futs[fut], fut.result()
        return
    import os

    n = processes or len(os.sched_getaffinity(0))
    studies = sum(len(args[-1]) for _, args in tasks)
    if n <= 1 or len(tasks) == 1 or studies < MIN_POOL_STUDIES:
        for gi, args in tasks:
            yield gi, run_chunk(*args)
        return
    import multiprocessing as mp
    from concurrent.futures import ProcessPoolExecutor, as_completed

    from analysis.workers import stop_pool, worker_init

    # Workers die with this process even when it is SIGKILLed (no finally runs then). Ended
    # early (a stop signal, an error, or the consumer closing this generator), the pool's
    # workers are ended at once and the chunks not started are dropped: no result is kept.
    ex = ProcessPoolExecutor(
        max_workers=n,
        mp_context=mp.get_context("spawn"),
        initializer=worker_init,
        initargs=(os.getpid(),),
    )
    finished = False
    try:
        futs = {ex.submit(run_chunk, *args): gi for gi, args in tasks}
        for fut in as_completed(futs):
            yield futs[fut], fut.result()
        finished = True
    finally:
        if finished:
            ex.shutdown(wait=True)
        else:
            stop_pool(ex)
