"""Analysis of logged trials: Weibull posteriors, thresholds, logistic regression, figures, reports.

Reads data files only (SQLite trial logs and CSV/Parquet trial tables); imports neither
``stimuli`` nor ``experiment`` (house style H1).
"""

from __future__ import annotations

from analysis.errors import DataError

__all__ = ["DataError"]
