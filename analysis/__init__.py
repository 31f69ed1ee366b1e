"""Analysis of logged trials: Weibull posteriors, thresholds, logistic regression, figures, reports.

Reads data files only (SQLite trial logs and CSV/Parquet trial tables); imports neither
``stimuli`` nor ``experiment`` (house style H1). Heavy pieces (statsmodels, matplotlib) are
imported where used.

Typical use::

    from analysis import read_trials, analyze, write_report
    steps = list(analyze(read_trials(["session.sqlite"])))
    write_report(steps[-1].result, "report/")
"""

from __future__ import annotations

import lazy_loader

#: Where each public name lives. The package imports a module only when one of its names is
#: first used (``lazy_loader``, as scikit-image does), so ``import analysis.errors`` (or
#: ``confocal analyze --help``) does not load pandas, scipy and emcee.
__getattr__, __dir__, __all__ = lazy_loader.attach(
    __name__,
    submod_attrs={
        "errors": ["DataError"],
        "data": ["TrialTable", "read_trials"],
        "weibull": ["WeibullFit", "fit_weibull", "fit_counts", "threshold_at"],
        "psychometric": ["FitSpec", "fit_table"],
        "logistic": ["LogisticFit", "OddsRatioTable", "fit_logistic"],
        "pipeline": ["AnalysisOptions", "AnalysisResult", "analyze"],
        "report": ["write_report"],
    },
)
