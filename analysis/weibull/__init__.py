"""Psychometric functions: maximum likelihood and posteriors, thresholds at any proportion correct.

The model (Jung et al. 2015, Sec. 3.2.2; Wichmann & Hill 2001) is
``P(x) = g + (1 - g - l) * F(beta * (s(x) - s(alpha)))``, with guess rate ``g``, a free lapse rate
``l`` and one of six sigmoids on a log or a linear stimulus axis. One module per job, each
importing only the ones above it in this list:

=============  ==================================================================================
module         what it does
=============  ==================================================================================
``kernel``     internal, not re-exported: the pieces the modules below share (sigmoid shapes,
               parameter vectors, (beta-)binomial likelihood, Beta density, data checks and
               warnings); no other module of the package imports a private name of a sibling
``model``      sigmoids, the curve, thresholds, counts per stimulus value (``pixels``)
``priors``     the box-and-Beta prior of the sampled parameters and its default
``mle``        the maximum-likelihood fit
``posterior``  emcee sampling chunk by chunk until converged (the reference sampler); the
               sampler constants
``threshold``  a threshold with its status (measured, censored, unidentified)
``summary``    ``WeibullFit``: posterior summaries, thresholds, goodness of fit, warnings
``batch``      the sampler every fit runs: many posteriors sampled together, one vectorised
               ensemble sampler (checked against emcee's in the tests)
``fit``        ``fit_weibull`` / ``fit_counts``: data checks, ML fit, then a posterior
=============  ==================================================================================

The names below are re-exported so that ``from analysis.weibull import fit_counts`` works.
"""

from __future__ import annotations

from analysis.weibull.fit import fit_counts, fit_weibull
from analysis.weibull.mle import MLEstimate, fit_mle
from analysis.weibull.model import (
    ETA_MAX,
    SIGMOIDS,
    FitWarning,
    aggregate,
    is_log_axis,
    psychometric,
    threshold_at,
)
from analysis.weibull.posterior import SamplerProgress, sample_posterior
from analysis.weibull.priors import PsychometricPrior, default_prior
from analysis.weibull.summary import WeibullFit
from analysis.weibull.threshold import STATUSES, Threshold

__all__ = [
    "SIGMOIDS",
    "ETA_MAX",
    "is_log_axis",
    "PsychometricPrior",
    "MLEstimate",
    "Threshold",
    "WeibullFit",
    "SamplerProgress",
    "psychometric",
    "threshold_at",
    "aggregate",
    "default_prior",
    "fit_mle",
    "sample_posterior",
    "fit_weibull",
    "fit_counts",
    "STATUSES",
    "FitWarning",
]
