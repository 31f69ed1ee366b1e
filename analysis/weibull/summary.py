"""A fitted psychometric function: posterior summaries, thresholds, fit checks and warnings."""

from __future__ import annotations

import math
from dataclasses import dataclass, field
from typing import Any

import numpy as np

from analysis.weibull.kernel import (
    EPS,
    ETA_MAX,
    V_MAX,
    axis_value,
    decreasing,
    is_log_axis,
    json_float,
    p_matrix,
    separated,
    sigmoid_cdf,
    sigmoid_ppf,
    theta_of_mle,
    theta_params,
)
from analysis.weibull.mle import MLEstimate
from analysis.weibull.model import psychometric, threshold_at
from analysis.weibull.posterior import TAU_MULTIPLE
from analysis.weibull.priors import PsychometricPrior
from analysis.weibull.threshold import Threshold, bracket

__all__ = ["WeibullFit", "POOR_FIT_PPP"]

#: Posterior-predictive p below which a fitted curve is named in the warnings as not describing
#: its data (ours; the deviance of data simulated from the posterior exceeds the observed
#: deviance in fewer than 1 % of draws).
POOR_FIT_PPP: float = 0.01


@dataclass(frozen=True)
class WeibullFit:
    """A fitted psychometric function: data, MLE, posterior samples and convergence.

    (Named for the paper's Weibull; any sigmoid of :data:`SIGMOIDS` is fitted the same way.)

    Parameters
    ----------
    label : str
        What was fitted (a condition, ``"<subject>/<condition>"``, ...).
    sigmoid : str
        One of :data:`SIGMOIDS`.
    guess : float
        Guess rate (fixed).
    pixels, k, n : tuple of float
        Distinct stimulus values (x units: pixels per object for the paper's data), number
        correct and number of trials at each.
    mle : MLEstimate
        Maximum-likelihood parameters (binomial likelihood).
    samples : ndarray of shape (n_samples, 4)
        Thinned posterior samples of (loc, log_beta, lapse, eta) (see the module docstring).
    converged : bool
        Whether the chain reached ``50 * tau_max`` steps.
    tau_max : float
        Largest integrated autocorrelation time, steps.
    n_steps : int
        Steps per walker.
    n_walkers : int
        Number of walkers.
    prior : PsychometricPrior
        The prior used.
    overdispersion : bool
        Whether the posterior is of the beta-binomial model.
    """

    label: str
    sigmoid: str
    guess: float
    pixels: tuple[float, ...]
    k: tuple[float, ...]
    n: tuple[float, ...]
    mle: MLEstimate
    samples: np.ndarray = field(repr=False, compare=False)
    converged: bool
    tau_max: float
    n_steps: int
    n_walkers: int
    prior: PsychometricPrior
    overdispersion: bool = False

    @property
    def n_trials(self) -> int:
        """Number of trials fitted."""
        return int(sum(self.n))

    @property
    def n_correct(self) -> int:
        """Number of correct (recognised) trials."""
        return int(sum(self.k))

    def parameter_samples(self) -> tuple[np.ndarray, np.ndarray, np.ndarray]:
        """Return posterior samples of (alpha, beta, lapse) in natural units."""
        return theta_params(self.samples, self.sigmoid)

    @property
    def alpha(self) -> float:
        """Posterior median of alpha, x units."""
        return float(np.median(self.parameter_samples()[0]))

    @property
    def beta(self) -> float:
        """Posterior median of beta."""
        return float(np.median(self.parameter_samples()[1]))

    @property
    def lapse(self) -> float:
        """Posterior median of the lapse rate."""
        return float(np.median(self.parameter_samples()[2]))

    @property
    def eta(self) -> float:
        """Posterior median of the overdispersion scale (0 without overdispersion)."""
        return float(np.median(self.samples[:, 3])) if self.samples.shape[1] > 3 else 0.0

    @property
    def eta_ci95(self) -> tuple[float, float]:
        """Central 95 % credible interval of the overdispersion scale."""
        if self.samples.shape[1] < 4:
            return (0.0, 0.0)
        q = np.quantile(self.samples[:, 3], [0.025, 0.975])
        return float(q[0]), float(q[1])

    def decreasing(self) -> bool:
        """Return True when proportion correct falls significantly with level (z < -1.96).

        Tested by a two-parameter binomial logistic regression of correct on the stimulus axis.
        """
        return decreasing(
            np.asarray(self.pixels), np.asarray(self.k), np.asarray(self.n), self.sigmoid
        )

    def threshold(self, pc: float = 0.5, *, midpoint: bool = False) -> Threshold:
        """Return the threshold at proportion correct ``pc`` with its status (see Threshold).

        With ``midpoint`` (psignifit's convention) the threshold is where the curve is midway
        between the guess rate and 1 - lapse, i.e. where the sigmoid itself is 0.5, for each
        posterior draw and the ML curve; ``pc`` is then ignored and the returned ``pc`` is that
        midpoint on the ML curve (used for the status and the bracket).

        A censored status must agree with the data: "below the lowest level tested" only when
        no tested level has a (monotone-smoothed) proportion correct below ``pc``, "above the
        highest" only when none is above it; otherwise the threshold is unidentified and given
        by the tested levels that bracket it. The bracket is widened, where needed, to the tested
        levels around the ML threshold, printed beside it, so that it contains the estimate.
        """
        a, b, lapse = self.parameter_samples()
        m = self.mle
        if midpoint:
            half = np.full(np.shape(a), 0.5)
            t = sigmoid_ppf(half, a, b, self.sigmoid)
            t_mle = float(sigmoid_ppf(np.array(0.5), m.alpha, m.beta, self.sigmoid))
            pc = self.guess + 0.5 * (1.0 - self.guess - m.lapse)
        else:
            t = threshold_at(pc, a, b, lapse, guess=self.guess, sigmoid=self.sigmoid)
            t_mle = float(
                threshold_at(pc, m.alpha, m.beta, m.lapse, guess=self.guess, sigmoid=self.sigmoid)
            )
        # 'inverted_cdf' does not interpolate, so +inf samples (curve never reaches pc) are safe.
        q = np.quantile(t, [0.025, 0.5, 0.975], method="inverted_cdf")
        lo, hi = min(self.pixels), max(self.pixels)
        br = bracket(self.pixels, self.k, self.n, pc)
        status, reason = self._status(pc, float(q[1]), (float(q[0]), float(q[2])), t_mle, br)
        if status == "unidentified" and "decreases" in reason:
            br = (math.nan, math.nan)
        else:
            br = _widen(br, self.pixels, t_mle)
        return Threshold(
            float(pc),
            float(q[1]),
            (float(q[0]), float(q[2])),
            t_mle,
            status,
            lo,
            hi,
            reason,
            br,
            midpoint,
        )

    def _status(
        self,
        pc: float,
        med: float,
        ci: tuple[float, float],
        t_mle: float,
        br: tuple[float, float] = (math.nan, math.nan),
    ) -> tuple[str, str]:
        k, n = np.asarray(self.k), np.asarray(self.n)
        lo, hi = min(self.pixels), max(self.pixels)
        if k.sum() == n.sum():
            return "censored_below", "every trial correct"
        if k.sum() == 0:
            return "censored_above", "no trial correct"
        if len(self.pixels) < 2:
            rate = k.sum() / n.sum()
            if rate > pc:
                return "censored_below", "one level tested, above pc there"
            if rate < pc:
                return "censored_above", "one level tested, below pc there"
            return "unidentified", "one level tested"
        if self.decreasing():
            return "unidentified", "proportion correct decreases with level"
        if not (med <= hi):  # also inf / NaN
            if math.isfinite(br[1]):  # a tested level is above pc: not censored above
                return "unidentified", (
                    f"posterior median above the highest level tested, but the data reach pc at "
                    f"{_num(br[1])}"
                )
            return "censored_above", "posterior median above the highest level tested"
        if med < lo:
            if math.isfinite(br[0]):  # a tested level is below pc: not censored below
                return "unidentified", (
                    f"posterior median below the lowest level tested, but the data are below pc "
                    f"at {_num(br[0])}"
                )
            return "censored_below", "posterior median below the lowest level tested"
        # Where the data do not identify the curve, an interval would be the prior's, not the
        # data's: each case below is reported by its bracketing levels, with no interval.
        if len(self.pixels) < 3:
            return "unidentified", f"{len(self.pixels)} levels with data"
        step = separated(k, n)
        if step is not None:
            x = self.pixels
            return "unidentified", (
                f"step response (none correct at {_num(x[step[0]])} or below, all from "
                f"{_num(x[step[1]])}): the data are separated and set no slope"
            )
        on_bound = self._on_prior_bound()
        if on_bound:
            return "unidentified", on_bound
        if ci[0] < lo or not (ci[1] <= hi):
            side = (
                f"down to {_num(ci[0])}, below the lowest level {_num(lo)}"
                if ci[0] < lo
                else f"up to {_num(ci[1])}, above the highest level {_num(hi)}"
            )
            return "unidentified", f"95 % interval runs beyond the tested range ({side})"
        a_lo, a_hi = (axis_value(c, self.sigmoid) for c in ci)
        prior_width = self.prior.loc_range[1] - self.prior.loc_range[0]
        if not math.isfinite(a_hi - a_lo) or (a_hi - a_lo) > 0.8 * prior_width:
            return "unidentified", "95 % interval spans most of the prior range"
        return "measured", ""

    def _on_prior_bound(self) -> str:
        """Return why the slope or lapse rate sits on its prior bound ('' when neither does).

        A parameter is on its bound when its ML value is there (within 0.1 % of the box) or more
        than 10 % of its posterior lies within 2 % of it, the test :meth:`diagnostics` warns on.
        The lapse rate's lower bound 0 is a natural limit, not a prior choice, and is not counted.
        """
        box = self.prior.bounds(3)
        theta_ml = theta_of_mle(self.mle, self.sigmoid)
        for j, name in ((1, "slope"), (2, "lapse rate")):
            lo, hi = box[j]
            w = hi - lo
            sides = (("upper", hi),) if j == 2 else (("lower", lo), ("upper", hi))
            for side, bound in sides:
                near = (
                    self.samples[:, j] < lo + 0.02 * w
                    if side == "lower"
                    else self.samples[:, j] > hi - 0.02 * w
                )
                if abs(theta_ml[j] - bound) <= 1e-3 * w or float(np.mean(near)) > 0.10:
                    value = math.exp(bound) if j == 1 else bound
                    return f"{name} on its prior {side} bound ({value:.3g})"
        return ""

    def diagnostics(self, pc: float = 0.5, *, midpoint: bool = False) -> list[str]:
        """Return one-line warnings about this fit (unconverged chain, binding prior bound, ...).

        Parameters
        ----------
        pc : float
            Proportion correct of the threshold checked for ML/posterior disagreement.
        midpoint : bool
            Check the midpoint threshold instead (:meth:`threshold`).

        Returns
        -------
        list of str
        """
        name = self.label or "fit"
        out: list[str] = []
        if not self.converged:
            out.append(
                f"{name}: MCMC not converged after {self.n_steps} steps "
                f"(tau_max {self.tau_max:.0f}; needs {TAU_MULTIPLE:.0f} tau)"
            )
        box = self.prior.bounds(4)
        names = ("threshold location", "slope", "lapse rate", "overdispersion")
        theta_ml = theta_of_mle(self.mle, self.sigmoid)
        for j in range(3):
            lo, hi = box[j]
            w = hi - lo
            if j == 2 and lo == 0.0:
                at_hi = theta_ml[j] >= hi - 1e-3 * w
                frac = float(np.mean(self.samples[:, j] > hi - 0.02 * w))
                if at_hi or frac > 0.10:
                    out.append(
                        f"{name}: the {names[j]} presses on its prior upper bound {hi:.3g} "
                        f"(ML {theta_ml[j]:.3g}; {100 * frac:.0f} % of the posterior within 2 % "
                        "of it); the fit is constrained by the prior, not the data"
                    )
                continue
            for side, bound in (("lower", lo), ("upper", hi)):
                at = abs(theta_ml[j] - bound) <= 1e-3 * w
                near = (
                    self.samples[:, j] < lo + 0.02 * w
                    if side == "lower"
                    else (self.samples[:, j] > hi - 0.02 * w)
                )
                frac = float(np.mean(near))
                if at or frac > 0.10:
                    val = math.exp(theta_ml[j]) if j == 1 else theta_ml[j]
                    bval = math.exp(bound) if j == 1 else bound
                    out.append(
                        f"{name}: the {names[j]} presses on its prior {side} bound "
                        f"{bval:.4g} (ML {val:.4g}; {100 * frac:.0f} % of the posterior within "
                        "2 % of it); the estimate is set by the prior box, not the data"
                    )
        if self.samples.shape[1] > 3:
            frac = float(np.mean(self.samples[:, 3] > ETA_MAX - 0.02))
            if frac > 0.10:
                out.append(f"{name}: the overdispersion scale presses on its upper bound")
        if len(self.pixels) >= 2 and self.decreasing():
            out.append(
                f"{name}: proportion correct decreases with level; an increasing psychometric "
                "function does not describe these data and its thresholds are not reported"
            )
        t = self.threshold(pc, midpoint=midpoint)
        if t.status == "measured" and not (t.ci95[0] <= t.mle <= t.ci95[1]):
            out.append(
                f"{name}: the ML threshold ({t.mle:.4g}) lies outside the 95 % credible interval "
                f"({t.ci95[0]:.4g}-{t.ci95[1]:.4g}); the data barely constrain it"
            )
        elif t.status == "measured" and is_log_axis(self.sigmoid) and t.mle > 0:
            ratio = t.median / t.mle
            if ratio > 1.25 or ratio < 0.8:
                out.append(
                    f"{name}: posterior median ({t.median:.4g}) and ML threshold ({t.mle:.4g}) "
                    f"differ by {100 * abs(ratio - 1):.0f} %; the data barely constrain it"
                )
        if 0 < len(self.pixels) < 3:
            out.append(
                f"{name}: only {len(self.pixels)} level(s) tested; the slope is not "
                "identified by the data"
            )
        g = self.goodness_of_fit()
        if g["deviance_df"] > 0 and g["ppp"] < POOR_FIT_PPP:
            out.append(
                f"{name}: the fitted curve does not describe the data (posterior-predictive "
                f"p = {g['ppp']:.3f} < {POOR_FIT_PPP:g}; deviance {g['deviance']:.1f} on "
                f"{g['deviance_df']} df): its thresholds and intervals rest on a model that "
                "misses the data"
            )
        return out

    def goodness_of_fit(
        self, *, n_draws: int = 2000, rng: np.random.Generator | int | None = 0
    ) -> dict[str, float]:
        """Return the deviance at the ML fit and a posterior-predictive p-value.

        The deviance is twice the log-likelihood ratio of the saturated model to the binomial ML
        fit. The posterior-predictive p-value is the fraction of posterior draws for which
        data simulated from the draw (beta-binomial when the fit has overdispersion) have a
        deviance at least as large as the observed data's (Gelman, Meng & Stern 1996); values
        near 0 mean the model misses the data.

        Parameters
        ----------
        n_draws : int
            Posterior draws used.
        rng : numpy.random.Generator or int or None
            Randomness of the simulated data.

        Returns
        -------
        dict
            ``deviance``, ``deviance_df`` (levels - 3), ``ppp``.

        With a seed (an int, as by default) the answer is computed once per fit and kept: the
        report, its warnings and the figures ask for the same one.
        """
        if isinstance(rng, int):
            cache = self.__dict__.setdefault("_gof_cache", {})  # frozen: no setattr
            if (n_draws, rng) not in cache:
                cache[n_draws, rng] = self._goodness_of_fit(n_draws, rng)
            return dict(cache[n_draws, rng])
        return self._goodness_of_fit(n_draws, rng)

    def _goodness_of_fit(self, n_draws: int, rng: np.random.Generator | int | None) -> dict:
        rng = np.random.default_rng(rng)
        x, k, n = (np.asarray(v, float) for v in (self.pixels, self.k, self.n))
        m = self.mle
        p_ml = psychometric(x, m.alpha, m.beta, m.lapse, guess=self.guess, sigmoid=self.sigmoid)
        dev = float(_deviance(k, n, np.clip(p_ml, EPS, 1 - EPS)))
        idx = np.linspace(0, len(self.samples) - 1, min(n_draws, len(self.samples))).astype(int)
        th = self.samples[idx]
        p = p_matrix(th[:, :3], x, self.guess, self.sigmoid)
        p_draw = p
        if th.shape[1] > 3 and self.overdispersion:
            v = np.minimum(1.0 / np.maximum(th[:, 3], 1e-6) ** 2 - 1.0, V_MAX)[:, None]
            p_draw = rng.beta(np.maximum(p * v, 1e-9), np.maximum((1 - p) * v, 1e-9))
        k_rep = rng.binomial(n.astype(int)[None, :], np.clip(p_draw, 0.0, 1.0))
        d_obs = _deviance(k[None, :], n[None, :], p)
        d_rep = _deviance(k_rep, n[None, :], p)
        return {
            "deviance": dev,
            "deviance_df": int(len(x) - 3),
            "ppp": float(np.mean(d_rep >= d_obs)),
        }

    def curve_band(
        self, x: Any, *, level: float = 0.95, max_samples: int = 1000
    ) -> tuple[np.ndarray, np.ndarray, np.ndarray]:
        """Return the pointwise posterior median and ``level`` band of P(correct) at ``x``."""
        a, b, lapse = self.parameter_samples()
        idx = np.linspace(0, len(a) - 1, min(max_samples, len(a))).astype(int)
        x = np.asarray(x, float)
        p = self.guess + (1 - self.guess - lapse[idx, None]) * sigmoid_cdf(
            x[None, :], a[idx, None], b[idx, None], self.sigmoid
        )
        lo, med, hi = np.quantile(p, [(1 - level) / 2, 0.5, (1 + level) / 2], axis=0)
        return med, lo, hi

    def summary(self, pc: float = 0.5) -> dict[str, Any]:
        """Return the results.json entry.

        ``p50_pixels``, ``ci95`` and ``mle_p50_pixels`` (the 50 % threshold's posterior median,
        interval and ML value) are set only when its ``status`` is ``measured`` (None
        otherwise); ``threshold_50`` keeps every number with its status. When ``pc`` differs
        from 0.5, ``threshold``, ``threshold_ci95``, ``mle_threshold`` and ``threshold_pc`` do
        the same at ``pc``.
        """
        t50 = self.threshold(0.5)
        ok = t50.measured
        d: dict[str, Any] = {
            "status": t50.status,
            "p50_pixels": json_float(t50.median) if ok else None,
            "ci95": [json_float(t50.ci95[0]), json_float(t50.ci95[1])] if ok else [None, None],
            "mle_p50_pixels": json_float(t50.mle) if ok else None,
            "threshold_50": t50.to_dict(),
            "alpha": self.alpha,
            "beta": self.beta,
            "lapse": self.lapse,
            "overdispersion": bool(self.overdispersion),
            "eta": self.eta,
            "eta_ci95": list(self.eta_ci95),
            "converged": bool(self.converged),
            "tau_max": json_float(self.tau_max),
            "n_trials": self.n_trials,
            "n_recognized": self.n_correct,
            "mle": self.mle.to_dict(),
            "goodness_of_fit": self.goodness_of_fit(),
            "warnings": self.diagnostics(pc),
        }
        if pc != 0.5:
            t = self.threshold(pc)
            ok = t.measured
            d.update(
                pc=pc,
                threshold=json_float(t.median) if ok else None,
                threshold_ci95=[json_float(t.ci95[0]), json_float(t.ci95[1])]
                if ok
                else [None, None],
                mle_threshold=json_float(t.mle) if ok else None,
                threshold_pc=t.to_dict(),
            )
        return d

    def to_dict(self) -> dict[str, Any]:
        """Return a JSON-ready dict (samples included, as lists)."""
        return {
            "label": self.label,
            "sigmoid": self.sigmoid,
            "guess": self.guess,
            "levels": list(self.pixels),  # the results.json key stays
            "k": list(self.k),
            "n": list(self.n),
            "mle": self.mle.to_dict(),
            "samples": self.samples.tolist(),
            "converged": self.converged,
            "tau_max": json_float(self.tau_max),
            "n_steps": self.n_steps,
            "n_walkers": self.n_walkers,
            "prior": self.prior.to_dict(),
            "overdispersion": self.overdispersion,
        }

    @classmethod
    def from_dict(cls, d: dict[str, Any]) -> WeibullFit:
        """Rebuild from :meth:`to_dict` output."""
        samples = np.asarray(d["samples"], dtype=float)
        samples = samples.reshape(-1, samples.shape[-1] if samples.ndim == 2 else 4)
        if samples.shape[1] == 3:
            samples = np.column_stack([samples, np.zeros(len(samples))])
        return cls(
            label=str(d["label"]),
            sigmoid=str(d["sigmoid"]),
            guess=float(d["guess"]),
            pixels=tuple(float(v) for v in d["levels"]),
            k=tuple(float(v) for v in d["k"]),
            n=tuple(float(v) for v in d["n"]),
            mle=MLEstimate.from_dict(d["mle"]),
            samples=samples,
            converged=bool(d["converged"]),
            tau_max=float(d["tau_max"]) if d["tau_max"] is not None else math.inf,
            n_steps=int(d["n_steps"]),
            n_walkers=int(d["n_walkers"]),
            prior=PsychometricPrior.from_dict(d["prior"]),
            overdispersion=bool(d.get("overdispersion", False)),
        )


def _widen(br: tuple[float, float], pixels: Any, t_mle: float) -> tuple[float, float]:
    """Widen a bracket to the tested levels around ``t_mle`` when it lies outside the bracket.

    A side that is NaN stays NaN only if ``t_mle`` lies on the bracket's open side; an ML
    threshold outside the tested range leaves that side open (NaN).
    """
    lo, hi = br
    if not math.isfinite(t_mle) or (math.isnan(lo) and math.isnan(hi)):
        return br
    x = np.asarray(pixels, float)
    if math.isfinite(lo) and t_mle < lo:
        below = x[x <= t_mle]
        lo = float(below.max()) if below.size else math.nan
    if math.isfinite(hi) and t_mle > hi:
        above = x[x >= t_mle]
        hi = float(above.min()) if above.size else math.nan
    return lo, hi


def _num(v: float) -> str:
    """Return a level or bound for a status reason: ``17,876``, ``2.35`` (no exponent for px)."""
    return f"{v:,.0f}" if abs(v) >= 1000 else f"{v:.3g}"


def _deviance(k: np.ndarray, n: np.ndarray, p: np.ndarray) -> np.ndarray:
    """Binomial deviance of counts k of n against probabilities p (summed over the last axis)."""
    with np.errstate(divide="ignore", invalid="ignore"):
        t1 = np.where(k > 0, k * np.log(k / (n * p)), 0.0)
        t2 = np.where(n - k > 0, (n - k) * np.log((n - k) / (n * (1 - p))), 0.0)
    return 2.0 * np.sum(t1 + t2, axis=-1)
