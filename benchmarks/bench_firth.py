"""Speed and accuracy of Firth's profile penalised-likelihood interval (``analysis.firth``).

Times, in one process, :func:`analysis.firth.profile_interval` against a baseline: the profile as
``logistf`` computes it (Heinze & Schemper 2002), Fisher scoring on Firth's modified score over
the trial-by-trial design, at most 100 iterations a point, the same bracket and Brent root. The
ratio baseline / ours is what the exact Hessian and the merged binomial rows buy on this machine,
whatever its load. Each end of both intervals is then checked by a third computation: the
profile deviance there, maximised by BFGS (scipy) from two starts; a correct end has 3.84.

Simulated data (labelled so in the output): the paper's logistic observer, 1,920 trials, as is
("ml": no separation) and with every cluttered trial missed and every de-cluttered one recognised
("separated": the ML odds ratio of background is infinite).

Usage::

    python benchmarks/bench_firth.py [--repeats 3]
"""

from __future__ import annotations

import argparse
import math
import os
import time
import warnings

import numpy as np
import statsmodels.formula.api as smf
from scipy import optimize, special

from analysis.firth import firth_logit, profile_interval
from analysis.logistic import design_frame
from analysis.simulate import LogisticObserver, simulate_logistic_trials

CHI2_95 = 3.841458820694124


def penalised_ll(b: np.ndarray, X: np.ndarray, y: np.ndarray) -> float:
    eta = X @ b
    p = special.expit(eta)
    sign, logdet = np.linalg.slogdet(X.T @ ((p * (1 - p))[:, None] * X))
    ll = float(np.sum(y * eta - np.logaddexp(0, eta)))
    return ll + 0.5 * logdet if sign > 0 else -math.inf


def scoring_profile(y: np.ndarray, X: np.ndarray, j: int, bj: float, b0: np.ndarray) -> float:
    """Max of the penalised log-likelihood with b_j = bj by Fisher scoring (the baseline)."""
    free = np.arange(X.shape[1]) != j
    b = b0.copy()
    b[j] = bj
    best = penalised_ll(b, X, y)
    for _ in range(100):
        p = special.expit(X @ b)
        w = p * (1 - p)
        xw = X * np.sqrt(w)[:, None]
        hat = np.sum((xw @ np.linalg.inv(xw.T @ xw)) * xw, axis=1)
        score = X[:, free].T @ (y - p + hat * (0.5 - p))
        delta = np.zeros_like(b)
        delta[free] = np.linalg.solve(X[:, free].T @ (w[:, None] * X[:, free]), score)
        frac = 1.0
        while (new := penalised_ll(b + frac * delta, X, y)) < best - 1e-12 and frac > 1e-8:
            frac /= 2
        b += frac * delta
        gain, best = new - best, new
        if np.abs(frac * delta).max() < 1e-10 or abs(gain) < 1e-13:
            break
    return best


def scoring_interval(y, X, j, b_hat, se) -> tuple[float, float]:
    """Bracket and Brent root as :func:`profile_interval`, on the scoring profile."""
    top = scoring_profile(y, X, j, b_hat[j], b_hat)

    def excess(bj: float) -> float:
        return 2.0 * (top - scoring_profile(y, X, j, bj, b_hat)) - CHI2_95

    out = []
    for sign in (-1.0, 1.0):
        near, far = b_hat[j], b_hat[j] + 2.0 * sign * se
        while excess(far) < 0 and abs(far) <= 50.0:
            near, far = far, far + 2.0 * (far - near)
        out.append(sign * math.inf if abs(far) > 50.0 else optimize.brentq(excess, near, far))
    return out[0], out[1]


def brute_deviance(y, X, j, bj, b_hat) -> float:
    """Profile deviance at ``bj``: BFGS over the other coefficients from two starts."""
    free = np.arange(X.shape[1]) != j

    def nll(c):
        b = b_hat.copy()
        b[j], b[free] = bj, c
        return -penalised_ll(b, X, y)

    best = max(
        -optimize.minimize(nll, s, method="BFGS").fun for s in (b_hat[free], 0 * b_hat[free])
    )
    return 2.0 * (penalised_ll(b_hat, X, y) - best)


def _ends(interval, *args, **kwargs) -> tuple[float, float] | None:
    try:
        return interval(*args, **kwargs)
    except np.linalg.LinAlgError:
        return None


def cases():
    trials = simulate_logistic_trials(LogisticObserver(lapse=0.03), rng=2015)
    yield "ml", trials
    sep = trials.copy()
    sep["recognized"] = (sep["condition"] == "decluttered").astype(int)
    yield "separated", sep


def main(argv: list[str] | None = None) -> int:
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("--repeats", type=int, default=3)
    args = ap.parse_args(argv)
    warnings.simplefilter("ignore")
    print(f"SIMULATED DATA. load average {os.getloadavg()[0]:.2f}")
    for name, trials in cases():
        model = smf.logit(
            "recognized ~ C(object) + background + log10_pixels", design_frame(trials)
        )
        y, X = np.asarray(model.endog, float), np.asarray(model.exog, float)
        b_hat, se, _ = firth_logit(y, X)
        for term in ("background", "log10_pixels"):
            j = model.exog_names.index(term)
            ours, base = [], []
            for _ in range(args.repeats):
                t0 = time.perf_counter()
                new = _ends(profile_interval, y, X, j, params=b_hat, bse=se, penalized=True)
                t1 = time.perf_counter()
                old = _ends(scoring_interval, y, X, j, b_hat, se[j])
                t2 = time.perf_counter()
                ours.append(t1 - t0)
                base.append(t2 - t1)
            print(
                f"{name:9s} {term:12s} ours {np.median(ours):6.3f} s  scoring"
                f" {np.median(base):6.3f} s  ratio {np.median(base) / np.median(ours):5.1f}x"
            )
            for label, ends in (("ours", new), ("scoring", old)):
                if ends is None:
                    print(f"    {label:8s} no interval: the information matrix became singular")
                    continue
                devs = [
                    f"{brute_deviance(y, X, j, e, b_hat):.4f}" if math.isfinite(e) else "-"
                    for e in ends
                ]
                print(
                    f"    {label:8s} log OR interval ({ends[0]:.4f}, {ends[1]:.4f});"
                    f" brute-force deviance at the ends {devs} (3.8415 expected)"
                )
    return 0


if __name__ == "__main__":
    raise SystemExit(main())
