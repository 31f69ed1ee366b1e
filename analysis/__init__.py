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

import importlib
from typing import Any

#: Where each public name lives. The package imports a module only when one of its names is
#: first used, so ``import analysis.errors`` (or ``confocal analyze --help``) does not load
#: pandas, scipy and emcee.
_HOME = {
    "DataError": "analysis.errors",
    "TrialTable": "analysis.data",
    "read_trials": "analysis.data",
    "WeibullFit": "analysis.weibull",
    "fit_weibull": "analysis.weibull",
    "fit_counts": "analysis.weibull",
    "threshold_at": "analysis.weibull",
    "FitSpec": "analysis.psychometric",
    "fit_table": "analysis.psychometric",
    "LogisticFit": "analysis.logistic",
    "OddsRatioTable": "analysis.logistic",
    "fit_logistic": "analysis.logistic",
    "AnalysisOptions": "analysis.pipeline",
    "AnalysisResult": "analysis.pipeline",
    "analyze": "analysis.pipeline",
    "write_report": "analysis.report",
}

__all__ = list(_HOME)


def __getattr__(name: str) -> Any:
    """Import the module that holds ``name`` on first use (PEP 562)."""
    if name not in _HOME:
        raise AttributeError(f"module 'analysis' has no attribute {name!r}")
    value = getattr(importlib.import_module(_HOME[name]), name)
    globals()[name] = value
    return value


def __dir__() -> list[str]:
    return sorted(set(globals()) | set(_HOME))


