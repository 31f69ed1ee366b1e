"""Psychometric functions for any table: ``confocal analyze fit``, the general command.

Reads a CSV table that is either per trial (one row per trial, a 0/1 ``--y`` column) or aggregated
(``--k`` correct of ``--n`` trials per row, or a proportion ``--p`` of ``--n``), splits it by
``--group`` columns, and fits each group with the same core as the study command
(:func:`analysis.weibull.fit_mle` for the ML estimate, :func:`analysis.weibull.batch.sample_batch`
for all posteriors at once). For each group it reports thresholds at any proportions correct with
their status (measured / censored / unidentified), posterior medians and 95 % credible intervals
beside ML values, deviance and a posterior-predictive p-value, and draws one plot.

Columns are named by header, or by 1-based number for a file without a header (a first row of
numbers only is taken as data, as in psignifit's example files).

=========== ======================================================================
option      column meaning
=========== ======================================================================
``--x``     stimulus level (any unit; > 0 for the log-axis sigmoids)
``--y``     per-trial outcome, 1 = correct (also ``true``/``yes``), 0 = not
``--k``     number correct in the row
``--n``     number of trials in the row (> 0)
``--p``     proportion correct in the row (0-1, or 0-100 when any value exceeds 1; a column
            with values above 1 and fractions between 0 and 1 is refused as mixed)
``--group`` comma-separated columns whose value combinations are fitted separately
=========== ======================================================================
"""

from __future__ import annotations

import math
import re
import warnings
from collections.abc import Iterator, Sequence
from dataclasses import dataclass, field
from pathlib import Path
from typing import Any

import numpy as np
import pandas as pd

from analysis.errors import DataError
from analysis.weibull import SIGMOIDS, WeibullFit, default_prior, fit_mle, is_log_axis
from analysis.weibull.batch import FitJob, sample_batch
from analysis.weibull.kernel import data_warnings, json_float
from analysis.weibull.threshold import unmeasured_text

__all__ = [
    "FitSpec",
    "GroupFit",
    "TableFit",
    "read_table",
    "resolve_sigmoid",
    "counts_by_group",
    "fit_table",
    "iter_fit_table",
    "threshold_md",
    "write_fit_report",
    "render_fit_markdown",
    "threshold_name",
    "y_label",
    "COMBINED_PLOT",
]

_SHAPE_AXIS_TO_SIGMOID = {(shape, axis): name for name, (shape, axis) in SIGMOIDS.items()}


def resolve_sigmoid(sigmoid: str, axis: str, x: np.ndarray | None = None) -> str:
    """Return the sigmoid name for a shape and an axis.

    Parameters
    ----------
    sigmoid : {'auto', 'weibull', 'loglogistic', 'lognormal', 'gumbel', 'logistic', 'normal'}
        ``auto``: the Weibull when every level is > 0, the logistic otherwise.
    axis : {'auto', 'log', 'linear'}
        ``auto`` keeps the sigmoid's own axis; ``log``/``linear`` moves its shape to that axis
        (``logistic`` on ``log`` is the ``loglogistic``, ``weibull`` on ``linear`` the ``gumbel``).
    x : ndarray, optional
        Levels, for ``auto``.

    Returns
    -------
    str
        A key of :data:`analysis.weibull.SIGMOIDS`.

    Examples
    --------
    >>> resolve_sigmoid("logistic", "log")
    'loglogistic'
    """
    if sigmoid == "auto":
        sigmoid = "weibull" if x is None or np.all(np.asarray(x) > 0) else "logistic"
    if sigmoid not in SIGMOIDS:
        raise ValueError(f"sigmoid must be auto or one of {', '.join(SIGMOIDS)}, got {sigmoid!r}")
    if axis not in ("auto", "log", "linear"):
        raise ValueError(f"axis must be 'auto', 'log' or 'linear', got {axis!r}")
    if axis == "auto":
        return sigmoid
    return _SHAPE_AXIS_TO_SIGMOID[(SIGMOIDS[sigmoid][0], axis)]


@dataclass(frozen=True)
class FitSpec:
    """What to fit in a table.

    Parameters
    ----------
    x : str
        Stimulus-level column.
    y, k, n, p : str or None
        Outcome columns: ``y`` alone (per trial), or ``k`` and ``n``, or ``p`` and ``n``.
    group : tuple of str
        Columns to split by (empty: one fit).
    sigmoid : str
        ``auto`` or a key of :data:`analysis.weibull.SIGMOIDS`.
    axis : {'auto', 'log', 'linear'}
        See :func:`resolve_sigmoid`.
    guess : float
        Guess rate in [0, 1) (0.5 for 2AFC, 1/m for m-AFC).
    pcs : tuple of float
        Proportions correct of the thresholds, each in (guess, 1). Empty (the default):
        psignifit's threshold, where the curve is midway between the guess rate and 1 - lapse,
        whatever the guess rate.
    overdispersion : bool
        Beta-binomial posteriors (free scale eta); off by default, as ``analyze run``.
    seed : int or None
        Seed of the sampler.
    """

    x: str
    y: str | None = None
    k: str | None = None
    n: str | None = None
    p: str | None = None
    group: tuple[str, ...] = ()
    sigmoid: str = "auto"
    axis: str = "auto"
    guess: float = 0.0
    pcs: tuple[float, ...] = ()
    overdispersion: bool = False
    seed: int | None = None

    def __post_init__(self) -> None:
        self._check_outcome()
        self._check_guess_pcs()
        if self.sigmoid != "auto" and self.sigmoid not in SIGMOIDS:
            raise ValueError(
                f"`sigmoid` must be auto or one of {', '.join(SIGMOIDS)}, got {self.sigmoid!r}"
            )
        if self.axis not in ("auto", "log", "linear"):
            raise ValueError(f"`axis` must be auto, log or linear, got {self.axis!r}")

    def _check_outcome(self) -> None:
        if self.y is not None:
            if self.k is not None or self.n is not None or self.p is not None:
                raise ValueError("give either `y`, or `k` with `n`, or `p` with `n`; not both")
        elif self.n is None or (self.k is None) == (self.p is None):
            raise ValueError("give either `y`, or `k` with `n`, or `p` with `n`")

    def _check_guess_pcs(self) -> None:
        if not (0.0 <= self.guess < 1.0):
            raise ValueError(f"`guess` must be in [0, 1), got {self.guess!r}")
        for pc in self.pcs:
            if not (self.guess < pc < 1.0):
                raise ValueError(f"`pcs` values must be in (guess {self.guess:g}, 1), got {pc!r}")


def read_table(path: str | Path) -> pd.DataFrame:
    """Read a CSV table; a first row of numbers only means there is no header.

    Without a header the columns are named ``"1"``, ``"2"``, ... (1-based numbers); empty
    trailing columns (a trailing comma) are dropped. A SQLite session database or a Parquet trial
    table gives its tidy trials (:func:`analysis.data.read_trials`); sessions answered by a
    simulated observer are listed in ``attrs["simulated_sessions"]``.

    Parameters
    ----------
    path : str or Path

    Returns
    -------
    pandas.DataFrame
        All cells as text.

    Raises
    ------
    DataError
        Missing, empty or unreadable file.
    """
    path = Path(path)
    if not path.exists():
        raise DataError(f"{path}: file not found")
    if path.is_dir():
        raise DataError(f"{path}: is a folder, expected a CSV table")
    with open(path, "rb") as fh:
        head = fh.read(16)
    if head.startswith(b"SQLite format 3\x00") or head.startswith(b"PAR1"):
        # A session database or Parquet trial table: its tidy trials (main part only).
        from analysis.data import read_trials

        table = read_trials([path], include_simulated=True)
        df = table.trials.astype(str)
        df.attrs["simulated_sessions"] = tuple(table.simulated_sessions)
        return df
    from analysis.logreader import MAX_INPUT_ROWS, check_input_size

    check_input_size(path)  # one input is bounded, as every trial file is
    try:
        raw = pd.read_csv(
            path,
            header=None,
            dtype=str,
            keep_default_na=False,
            skipinitialspace=True,
            nrows=MAX_INPUT_ROWS + 2,
        )
    except pd.errors.EmptyDataError as exc:
        raise DataError(f"{path}: file is empty") from exc
    except (pd.errors.ParserError, UnicodeDecodeError) as exc:
        raise DataError(f"{path}: not a readable CSV table ({' '.join(str(exc).split())})") from exc
    if len(raw) > MAX_INPUT_ROWS + 1:
        raise DataError(f"{path}: more than {MAX_INPUT_ROWS:,} rows, the most one input may have")
    from analysis.tables import unescape_frame

    raw = unescape_frame(raw)
    first = [str(v).strip() for v in raw.iloc[0]]
    if all(_is_number(v) or v == "" for v in first):
        df = raw
        df.columns = [str(i + 1) for i in range(df.shape[1])]
    else:
        df = raw.iloc[1:].reset_index(drop=True)
        df.columns = [c.strip() if c.strip() else str(i + 1) for i, c in enumerate(first)]
    empty = [c for c in df.columns if (df[c].astype(str).str.strip() == "").all()]
    df = df.drop(columns=empty)
    if len(df) == 0:
        raise DataError(f"{path}: no data rows")
    return df


def _is_number(v: str) -> bool:
    try:
        float(v)
    except ValueError:
        return False
    return True


def _numeric(df: pd.DataFrame, col: str, source: str, option: str) -> np.ndarray:
    if col not in df.columns:
        raise DataError(
            f"{source}: {option} column {col!r} not found (columns: {', '.join(df.columns)})"
        )
    s = df[col].astype(str).str.strip()
    words = s.str.lower().map({"true": "1", "false": "0", "yes": "1", "no": "0"})
    s = words.fillna(s)
    v = pd.to_numeric(s, errors="coerce").to_numpy(float)
    bad = ~np.isfinite(v)
    if bad.any():
        i = int(np.flatnonzero(bad)[0])
        raise DataError(
            f"{source}: {option} column {col!r} must be numeric, got {df[col].iloc[i]!r} at data "
            f"row {i + 1}"
        )
    return v


def counts_by_group(
    df: pd.DataFrame, spec: FitSpec, source: str = "table"
) -> list[tuple[dict[str, str], np.ndarray, np.ndarray, np.ndarray]]:
    """Return ``(group values, x values, k, n)`` per group, x values merged and sorted.

    Parameters
    ----------
    df : pandas.DataFrame
        The table (:func:`read_table`).
    spec : FitSpec
    source : str
        File name for messages.

    Returns
    -------
    list of (dict, ndarray, ndarray, ndarray)

    Raises
    ------
    DataError
        Unknown column, non-numeric values, outcomes out of range.
    """
    x = _numeric(df, spec.x, source, "`x`")
    if spec.y is not None:
        k = _numeric(df, spec.y, source, "`y`")
        if not np.all((k == 0) | (k == 1)):
            i = int(np.flatnonzero((k != 0) & (k != 1))[0])
            raise DataError(
                f"{source}: `y` column {spec.y!r} must be 0 or 1 per trial, got "
                f"{df[spec.y].iloc[i]!r} at data row {i + 1} (aggregated counts: use `k` and `n`)"
            )
        n = np.ones_like(k)
    else:
        n = _numeric(df, spec.n, source, "`n`")
        if np.any(n <= 0):
            i = int(np.flatnonzero(n <= 0)[0])
            raise DataError(
                f"{source}: `n` column {spec.n!r} must be > 0, got {n[i]:g} at row {i + 1}"
            )
        if spec.k is not None:
            k = _numeric(df, spec.k, source, "`k`")
        else:
            p = _numeric(df, spec.p, source, "`p`")
            if np.any(p < 0) or np.any(p > 100):
                raise DataError(f"{source}: `p` column {spec.p!r} must be in 0-1 or 0-100")
            above, inside = p > 1, (p > 0) & (p < 1)
            if above.any() and inside.any():  # 1.5 among proportions: a typo, not 1.5 %
                i, j = int(np.flatnonzero(above)[0]), int(np.flatnonzero(inside)[0])
                raise DataError(
                    f"{source}: `p` column {spec.p!r} mixes proportions and percentages "
                    f"({p[i]:g} at data row {i + 1} is above 1, {p[j]:g} at data row {j + 1} is "
                    "a fraction): give proportions in 0-1 or percentages in 0-100"
                )
            # Percentages when any value exceeds 1; k need not be an integer (rounded percents).
            k = (p / 100.0 if np.any(p > 1) else p) * n
        bad = (k < 0) | (k > n + 1e-9)
        if bad.any():
            i = int(np.flatnonzero(bad)[0])
            raise DataError(
                f"{source}: need 0 <= correct <= trials, got {k[i]:g} of {n[i]:g} at data row "
                f"{i + 1}"
            )
    for g in spec.group:
        if g not in df.columns:
            raise DataError(
                f"{source}: `group` column {g!r} not found (columns: {', '.join(df.columns)})"
            )
    keys = (
        df[list(spec.group)].astype(str).apply(lambda r: tuple(r), axis=1)
        if spec.group
        else pd.Series([()] * len(df))
    )
    out = []
    for key in _natural(set(keys)):
        m = (keys == key).to_numpy()
        lv, inv = np.unique(x[m], return_inverse=True)
        out.append(
            (
                dict(zip(spec.group, key, strict=True)),
                lv,
                np.bincount(inv, weights=k[m]).astype(float),
                np.bincount(inv, weights=n[m]).astype(float),
            )
        )
    return out


def _natural(keys: set[tuple[str, ...]]) -> list[tuple[str, ...]]:
    def conv(s: str) -> tuple[int, float, str]:
        return (0, float(s), s) if _is_number(s) else (1, 0.0, s)

    return sorted(keys, key=lambda t: tuple(conv(s) for s in t))


def _label(group: dict[str, str]) -> str:
    return ", ".join(f"{k}={v}" for k, v in group.items()) or "all"


@dataclass(frozen=True)
class GroupFit:
    """One group's fit and what to report about it.

    Parameters
    ----------
    group : dict of str to str
        The group's column values.
    fit : WeibullFit
    warnings : tuple of str
    """

    group: dict[str, str]
    fit: WeibullFit
    warnings: tuple[str, ...] = ()

    @property
    def label(self) -> str:
        """``col=value, ...`` (``all`` without groups)."""
        return _label(self.group)

    def thresholds(self, pcs: Sequence[float]) -> list[Any]:
        """Return the thresholds at ``pcs``, or the midpoint threshold when ``pcs`` is empty."""
        if not pcs:
            return [self.fit.threshold(midpoint=True)]
        return [self.fit.threshold(pc) for pc in pcs]

    def to_json(self, pcs: Sequence[float]) -> dict[str, Any]:
        """Return the results.json entry of this group (``pcs`` empty: the midpoint threshold)."""
        f = self.fit
        a, b, lapse = f.parameter_samples()

        def par(samples: np.ndarray, ml: float) -> dict[str, Any]:
            q = np.quantile(samples, [0.025, 0.5, 0.975])
            return {
                "median": float(q[1]),
                "ci95": [float(q[0]), float(q[2])],
                "mle": json_float(ml),
            }

        return {
            "group": dict(self.group),
            "label": self.label,
            "n_trials": float(sum(f.n)),
            "levels": list(f.pixels),  # the fit table's JSON key stays
            "k": list(f.k),
            "n": list(f.n),
            "thresholds": [t.to_dict() for t in self.thresholds(pcs)],
            "parameters": {
                "alpha": par(a, f.mle.alpha),
                "beta": par(b, f.mle.beta),
                "lapse": par(lapse, f.mle.lapse),
                "eta": par(f.samples[:, 3], math.nan) if f.overdispersion else None,
            },
            "mle_log_likelihood": f.mle.log_likelihood,
            "goodness_of_fit": f.goodness_of_fit(),
            "converged": f.converged,
            "tau_max": json_float(f.tau_max),
            "n_steps": f.n_steps,
            "prior": f.prior.to_dict(),
            "warnings": list(self.warnings),
        }


@dataclass(frozen=True)
class TableFit:
    """All groups of a table, fitted.

    Parameters
    ----------
    source : str
    spec : FitSpec
    sigmoid : str
        The sigmoid used (``spec.sigmoid`` resolved).
    groups : tuple of GroupFit
    warnings : tuple of str
    """

    source: str
    spec: FitSpec
    sigmoid: str
    groups: tuple[GroupFit, ...]
    warnings: tuple[str, ...] = field(default_factory=tuple)

    def results_json(self) -> dict[str, Any]:
        """Return the ``results.json`` content."""
        s = self.spec
        return {
            **_source_record(self.source),
            "columns": {"x": s.x, "y": s.y, "k": s.k, "n": s.n, "p": s.p, "group": list(s.group)},
            "sigmoid": self.sigmoid,
            "axis": SIGMOIDS[self.sigmoid][1],
            "guess": s.guess,
            "pcs": list(s.pcs),
            "threshold_rule": _rule_text(s),
            "overdispersion": s.overdispersion,
            "seed": s.seed,
            "groups": [g.to_json(s.pcs) for g in self.groups],
            "warnings": list(self.warnings),
        }


def _rule_text(spec: FitSpec) -> str:
    """Say in words where the thresholds are taken."""
    if not spec.pcs:
        return (
            "midpoint between the guess rate and 1 - lapse (psignifit's convention; --pc for "
            "fixed proportions correct)"
        )
    return "proportion correct " + ", ".join(f"{pc:g}" for pc in spec.pcs) + " (--pc)"


def threshold_name(t: dict[str, Any]) -> str:
    """Name a threshold of results.json: ``midpoint threshold`` or ``75% threshold``."""
    if t.get("midpoint"):
        return "midpoint threshold"
    return f"{100 * t['pc']:g}% threshold"


def _source_record(source: str) -> dict[str, Any]:
    """``source`` (the file's name, no host path) and ``source_sha256`` for ``results.json``."""
    from analysis.data import file_record

    rec = file_record(source)
    return {"source": rec["file"], "source_sha256": rec["sha256"]}


def iter_fit_table(
    df: pd.DataFrame, spec: FitSpec, source: str = "table"
) -> Iterator[tuple[int, int, TableFit | None]]:
    """Fit every group of a table; yield ``(fits done, fits, result or None)`` as it goes.

    Parameters
    ----------
    df : pandas.DataFrame
    spec : FitSpec
    source : str
        File name for messages.

    Yields
    ------
    (int, int, TableFit or None)
        The last yield carries the result.

    Raises
    ------
    DataError
        Bad columns or values; x values <= 0 for a log-axis sigmoid.
    """
    groups = counts_by_group(df, spec, source)
    all_x = np.concatenate([g[1] for g in groups])
    sigmoid = resolve_sigmoid(spec.sigmoid, spec.axis, all_x)
    if is_log_axis(sigmoid) and np.any(all_x <= 0):
        raise DataError(
            f"{source}: `x` column {spec.x!r} has values <= 0 ({all_x.min():g}), which the "
            f"{sigmoid} (log axis) cannot take; use `sigmoid='logistic'`, 'normal' or 'gumbel' "
            "(linear axis)"
        )
    jobs, per_group = [], []
    sim = tuple(df.attrs.get("simulated_sessions", ()))
    notes: list[str] = [f"SIMULATED data (no person answered): {'; '.join(sim)}"] if sim else []
    for gv, lv, k, n in groups:
        label = _label(gv)
        with warnings.catch_warnings(record=True) as caught:
            warnings.simplefilter("always")
            data_warnings(label, k, n)
            prior = default_prior(lv, guess=spec.guess, sigmoid=sigmoid)
            mle = fit_mle(lv, k, n, guess=spec.guess, sigmoid=sigmoid, prior=prior)
        per_group.append([" ".join(str(w.message).split()) for w in caught])
        jobs.append(FitJob(label, lv, k, n, spec.guess, prior, mle, spec.overdispersion))
    fits: list[WeibullFit] = []
    for prog in sample_batch(jobs, sigmoid=sigmoid, rng=spec.seed):
        if prog.fits is None:
            yield prog.n_done, len(jobs), None
        else:
            fits = prog.fits
    out = []
    for (gv, *_), fit, w in zip(groups, fits, per_group, strict=True):
        diag = (
            [d for pc in spec.pcs for d in fit.diagnostics(pc)]
            if spec.pcs
            else fit.diagnostics(midpoint=True)
        )
        ws = tuple(dict.fromkeys([*w, *diag]))
        notes += ws
        out.append(GroupFit(gv, fit, ws))
    yield len(jobs), len(jobs), TableFit(source, spec, sigmoid, tuple(out), tuple(notes))


def fit_table(df: pd.DataFrame, spec: FitSpec, source: str = "table") -> TableFit:
    """Fit every group of a table (runs :func:`iter_fit_table` to the end).

    Parameters
    ----------
    df : pandas.DataFrame
    spec : FitSpec
    source : str

    Returns
    -------
    TableFit
    """
    result = None
    for _, _, r in iter_fit_table(df, spec, source):
        result = r
    return result


def _fmt(v: float | None) -> str:
    return "n/a" if v is None else f"{v:.4g}"


def threshold_md(t: dict[str, Any]) -> str:
    """Return one threshold of a fit table's JSON as a Markdown cell (median, CrI, ML or status)."""
    if t["status"] == "measured":
        return (
            f"{_fmt(t['median'])} ({_fmt(t['ci95'][0])}-{_fmt(t['ci95'][1])}); ML {_fmt(t['mle'])}"
        )
    text = unmeasured_text(t, "{:.4g}", below="censored", above="censored", with_reason=True)
    if t["status"] == "unidentified" and t.get("mle") is not None:
        text += f"; ML {_fmt(t['mle'])}"
    return text


def render_fit_markdown(r: dict[str, Any], plots: Sequence[str]) -> str:
    """Return report.md for a :meth:`TableFit.results_json` dict and its plot file names."""
    heads = [threshold_name(t) for t in r["groups"][0]["thresholds"]] if r["groups"] else []
    lines = [
        "# Psychometric functions",
        "",
        f"Data: `{Path(r['source']).name}`; x = `{r['columns']['x']}`; sigmoid {r['sigmoid']} "
        f"({r['axis']} axis); guess rate {r['guess']:g}; lapse rate free; "
        + (
            "beta-binomial overdispersion (free scale eta, psignifit 4 style)."
            if r["overdispersion"]
            else "binomial likelihood (--overdispersion for beta-binomial)."
        ),
        "",
        f"Thresholds at the {r['threshold_rule']}: posterior median (95 % credible interval); "
        "ML = maximum likelihood. A threshold outside the tested levels is given as a bound, "
        "an unidentified one by the tested levels that bracket it and its ML value, not as a "
        "measurement.",
        "",
        "Fit quality: deviance of the ML curve against the saturated model (df = levels - 3) and "
        "the posterior-predictive p (PPP) of that deviance; a curve with PPP < 0.01 is named in "
        "the warnings as not describing its data.",
        "",
        "| group | trials | " + " | ".join(heads) + " | deviance (df) | PPP | converged |",
        "|---|---|" + "---|" * len(heads) + "---|---|---|",
    ]
    for g in r["groups"]:
        gof = g["goodness_of_fit"]
        cells = [threshold_md(t) for t in g["thresholds"]]
        lines.append(
            f"| {g['label']} | {g['n_trials']:g} | "
            + " | ".join(cells)
            + " | "
            + (
                f"{gof['deviance']:.2f} ({gof['deviance_df']})"
                if gof["deviance_df"] > 0
                else "n/a (df <= 0)"
            )
            + f" | {gof['ppp']:.2f} | "
            + ("yes" if g["converged"] else "NO")
            + " |"
        )
    if r["warnings"]:
        lines += ["", "## Warnings", ""] + [f"- {w}" for w in r["warnings"]]
    if plots:
        lines += ["", "## Plots", ""] + [f"- [{p}]({p})" for p in plots]
    return "\n".join(lines) + "\n"


def _plot_name(i: int, label: str) -> str:
    slug = re.sub(r"[^A-Za-z0-9]+", "_", label).strip("_")[:40] or "all"
    return f"fit_{i + 1:02d}_{slug}.png"


def y_label(spec: FitSpec) -> str:
    """Say what the plotted proportion is, from the column that holds it."""
    if spec.y is not None:
        return f"proportion of trials with {spec.y} = 1"
    if spec.k is not None:
        return f"{spec.k} / {spec.n}"
    return f"{spec.p} (proportion)"


#: The combined plot of every group (drawn when there are two or more).
COMBINED_PLOT = "fit_all_groups.png"


def write_fit_report(result: TableFit, out_dir: str | Path, *, plots: bool = True) -> Path:
    """Write ``results.json``, ``report.md`` and the plots to ``out_dir``, atomically.

    Like :func:`analysis.report.write_report` (the folder is replaced if it exists, and returned
    resolved), for a :class:`TableFit`; ``plots`` draws a PNG (300 dpi) per group: data with
    95 % binomial intervals, the fitted curve with its 95 % band, the measured thresholds, and
    the fit's deviance and posterior-predictive p in the title; with two or more groups also
    :data:`COMBINED_PLOT`, every group on one axis. The y axis says what the column holds.
    """
    from analysis.data import json_safe
    from analysis.report import atomic_folder, results_json_text

    r = result.results_json()
    names = [_plot_name(i, g.label) for i, g in enumerate(result.groups)] if plots else []
    if plots and len(result.groups) > 1:
        names.append(COMBINED_PLOT)
    with atomic_folder(out_dir) as tmp:
        (tmp / "results.json").write_text(results_json_text(json_safe(r)), encoding="utf-8")
        (tmp / "report.md").write_text(render_fit_markdown(r, names), encoding="utf-8")
        if plots:
            _draw_plots(result, r, names, tmp)
    return Path(out_dir).resolve()


def _draw_plots(result: TableFit, r: dict[str, Any], names: list[str], tmp: Path) -> None:
    """Draw one plot per group and the combined plot into ``tmp``."""
    from analysis.figures import mark_simulated, plot_recognition
    from analysis.weibull.summary import POOR_FIT_PPP

    spec = result.spec
    pc = spec.pcs[0] if spec.pcs else 0.5
    sim = any(w.startswith("SIMULATED data") for w in result.warnings)
    pairs = zip(result.groups, r["groups"], strict=True)
    jobs = [({g.label: g.fit}, g.label, [gj]) for g, gj in pairs]
    if len(result.groups) > 1:
        jobs.append(({g.label: g.fit for g in result.groups}, "all groups", r["groups"]))
    for name, (fits, title, gjs) in zip(names, jobs, strict=True):
        ax = plot_recognition(fits, pc=pc, midpoint=not spec.pcs, legend=len(fits) < 8)
        ax.set_xlabel(spec.x)
        ax.set_ylabel(y_label(spec))
        if len(gjs) == 1:
            gof = gjs[0]["goodness_of_fit"]
            poor = gof["deviance_df"] > 0 and gof["ppp"] < POOR_FIT_PPP
            title += (
                f"\ndeviance {gof['deviance']:.1f} ({gof['deviance_df']} df), PPP "
                f"{gof['ppp']:.2f}" + (": POOR FIT" if poor else "")
            )
        ax.set_title(title, fontsize="small")
        if sim:
            mark_simulated(ax.figure)
        ax.figure.savefig(tmp / name, dpi=300, bbox_inches="tight", pad_inches=0.04)
