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

from analysis.data import TrialTable, read_trials
from analysis.errors import DataError
from analysis.logistic import LogisticFit, OddsRatioTable, fit_logistic
from analysis.pipeline import AnalysisOptions, AnalysisResult, analyze
from analysis.psychometric import FitSpec, fit_table
from analysis.report import write_report
from analysis.weibull import WeibullFit, fit_counts, fit_weibull, threshold_at

__all__ = [
    "DataError",
    "TrialTable",
    "read_trials",
    "WeibullFit",
    "fit_weibull",
    "fit_counts",
    "threshold_at",
    "FitSpec",
    "fit_table",
    "LogisticFit",
    "OddsRatioTable",
    "fit_logistic",
    "AnalysisOptions",
    "AnalysisResult",
    "analyze",
    "write_report",
]
