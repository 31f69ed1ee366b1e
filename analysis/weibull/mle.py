"""Maximum-likelihood fit of a psychometric function (binomial, within the prior's box)."""

from __future__ import annotations

from dataclasses import asdict, dataclass
from typing import Any

import numpy as np
from scipy import optimize

from analysis.weibull.kernel import (
    Sigmoid,
    check_guess,
    check_sigmoid,
    log_likelihood,
    theta_params,
)
from analysis.weibull.priors import PsychometricPrior, default_prior

__all__ = ["MLEstimate", "fit_mle"]


@dataclass(frozen=True)
class MLEstimate:
    """Maximum-likelihood parameters of a psychometric function.

    Parameters
    ----------
    alpha : float
        Scale (Weibull) or midpoint (logistic), x units.
    beta : float
        Slope parameter.
    lapse : float
        Lapse rate.
    log_likelihood : float
        Binomial log-likelihood at the maximum (without the binomial coefficients).
    """

    alpha: float
    beta: float
    lapse: float
    log_likelihood: float

    def to_dict(self) -> dict[str, float]:
        """Return a JSON-ready dict."""
        return asdict(self)

    @classmethod
    def from_dict(cls, d: dict[str, Any]) -> MLEstimate:
        """Rebuild from :meth:`to_dict` output."""
        return cls(**{k: float(d[k]) for k in ("alpha", "beta", "lapse", "log_likelihood")})


def fit_mle(
    pixels: Any,
    k: Any,
    n: Any,
    *,
    guess: float = 0.0,
    sigmoid: Sigmoid = "weibull",
    prior: PsychometricPrior | None = None,
) -> MLEstimate:
    """Maximise the binomial likelihood within the prior's box (no prior density).

    Several L-BFGS-B starts across the box; the best is kept.

    Parameters
    ----------
    pixels, k, n : array_like of shape (n_levels,)
        Distinct stimulus values (pixels for the paper's data), number correct and number of
        trials (see :func:`aggregate`).
    guess : float
        Guess rate in [0, 1).
    sigmoid : {'weibull', 'logistic'}
    prior : PsychometricPrior, optional
        Only its box is used; :func:`default_prior` when omitted.

    Returns
    -------
    MLEstimate
    """
    check_sigmoid(sigmoid)
    check_guess(guess)
    x = np.asarray(pixels, float)
    k = np.asarray(k, float)
    n = np.asarray(n, float)
    prior = prior or default_prior(x, guess=guess, sigmoid=sigmoid)
    bounds = prior.bounds()

    def nll(theta: np.ndarray) -> float:
        return -float(log_likelihood(theta[None, :], x, k, n, guess, sigmoid)[0])

    # Coarse vectorised grid over the whole box, then local polishing: robust
    # against the flat regions and local optima of lapse-rate models, and cheap.
    (l0, l1), (b0, b1), (_, lmax) = bounds
    g = np.stack(
        np.meshgrid(
            np.linspace(l0, l1, 61),
            np.linspace(b0, b1, 25),
            np.linspace(0.0, lmax, 11),
            indexing="ij",
        ),
        axis=-1,
    ).reshape(-1, 3)
    ll = log_likelihood(g, x, k, n, guess, sigmoid)
    # The likelihood can be multimodal in the slope (a local maximum with lapse 0 and a ridge
    # towards steep curves with a lapse, as in the MPDiR staircase), so polish the best grid point
    # of each of several slopes and keep the best result.
    per_slope = ll.reshape(61, 25, 11).transpose(1, 0, 2).reshape(25, -1)
    best_in_row = per_slope.max(axis=1)
    starts = []
    for j in np.argsort(best_in_row)[::-1][:4]:
        i_loc, i_lapse = np.unravel_index(int(np.argmax(per_slope[j])), (61, 11))
        starts.append(g.reshape(61, 25, 11, 3)[i_loc, j, i_lapse])
    best = None
    for start in starts:
        # SLSQP: bounded, and much cheaper per call than L-BFGS-B here; Nelder-Mead as fallback.
        r = optimize.minimize(nll, start, method="SLSQP", bounds=bounds, options={"ftol": 1e-10})
        if not r.success or not np.isfinite(r.fun):
            r = optimize.minimize(nll, start, method="Nelder-Mead", bounds=bounds)
        if not np.isfinite(r.fun) or r.fun > nll(start):
            r = optimize.OptimizeResult(x=start, fun=nll(start))
        if best is None or r.fun < best.fun:
            best = r
    alpha, beta, lapse = theta_params(best.x[None, :], sigmoid)
    return MLEstimate(float(alpha[0]), float(beta[0]), float(lapse[0]), float(-best.fun))
