"""Agreement of GNS rollouts with MPM on the test cases (paper §5, Table 3).

Each realization was simulated by MPM (the truth) and rolled out by the GNS. For each runout
metric in ``METRICS`` the paired values give R², NRMSE and the mean signed error (bias) with a
percentile-bootstrap confidence interval over realizations. Rollouts whose ``gns_status`` is not
``"ok"`` (diverged) are left out of the statistics but counted.
"""

from __future__ import annotations

import math
import warnings
from dataclasses import asdict, dataclass, fields

import numpy as np
import pandas as pd
from scipy import stats

# metric name -> (column stem in ``pairs``, axis label)
METRICS: dict[str, tuple[str, str]] = {
    "runout": ("runout_m", "runout distance R (m)"),
    "volume": ("volume_m2", "sliding volume V (m²)"),
    "influence": ("influence_m", "influence distance I (m)"),
}
OK_STATUS = "ok"


@dataclass
class Agreement:
    """Paired agreement of one metric between GNS and MPM over the ok realizations of one case."""

    metric: str
    n: int
    r2: float
    r2_low: float  # bootstrap confidence interval of R² over realizations (NaN where R² is undefined)
    r2_high: float
    nrmse: float
    bias: float  # mean(gns - mpm), in the metric's unit
    bias_low: float  # lower bound of the bootstrap confidence interval of the bias
    bias_high: float
    relative_bias: float  # bias / mean(MPM); NaN if that mean is 0
    mpm_mean: float
    gns_mean: float


def r_squared(mpm: np.ndarray, gns: np.ndarray) -> float:
    """Paired coefficient of determination 1 - SS_res/SS_tot; NaN if SS_tot = 0 or n < 2."""
    mpm, gns = np.asarray(mpm, dtype=float), np.asarray(gns, dtype=float)
    if mpm.size < 2:
        return math.nan
    ss_tot = float(np.sum((mpm - mpm.mean()) ** 2))
    if ss_tot == 0.0:
        return math.nan
    return 1.0 - float(np.sum((gns - mpm) ** 2)) / ss_tot


def nrmse(mpm: np.ndarray, gns: np.ndarray) -> float:
    """Root-mean-square error divided by the MPM range; NaN if the range is 0 or empty."""
    mpm, gns = np.asarray(mpm, dtype=float), np.asarray(gns, dtype=float)
    if mpm.size == 0:
        return math.nan
    value_range = float(mpm.max() - mpm.min())
    if value_range == 0.0:
        return math.nan
    return float(np.sqrt(np.mean((gns - mpm) ** 2))) / value_range


def _r2_along(mpm: np.ndarray, gns: np.ndarray, axis: int = -1) -> np.ndarray:
    """R² of resampled pairs along ``axis`` (one per bootstrap resample); NaN where MPM is constant."""
    ss_tot = np.sum((mpm - mpm.mean(axis=axis, keepdims=True)) ** 2, axis=axis)
    ss_res = np.sum((gns - mpm) ** 2, axis=axis)
    with np.errstate(divide="ignore", invalid="ignore"):
        return np.where(ss_tot > 0, 1.0 - ss_res / ss_tot, np.nan)


def _nrmse_along(mpm: np.ndarray, gns: np.ndarray, axis: int = -1) -> np.ndarray:
    spread = np.ptp(mpm, axis=axis)
    with np.errstate(divide="ignore", invalid="ignore"):
        return np.where(spread > 0, np.sqrt(np.mean((gns - mpm) ** 2, axis=axis)) / spread, np.nan)


PAIRED_STATISTICS = {"r2": _r2_along, "nrmse": _nrmse_along}


def _percentile_interval(values: np.ndarray, confidence: float) -> tuple[float, float]:
    """The central ``confidence`` percentile interval of bootstrap ``values``."""
    tail_pct = 50.0 * (1.0 - confidence)
    low, high = np.percentile(values, [tail_pct, 100.0 - tail_pct])
    return float(low), float(high)


def paired_interval(
    statistic: str, mpm: np.ndarray, gns: np.ndarray, bootstrap: int = 2000, confidence: float = 0.95, seed: int = 0
) -> tuple[float, float]:
    """Percentile-bootstrap interval of a paired statistic (``r2`` or ``nrmse``) over realizations,
    resampling (MPM, surrogate) pairs together; resamples where it is undefined are left out. NaN
    with fewer than 3 pairs or the statistic undefined on most resamples."""
    mpm, gns = np.asarray(mpm, dtype=float), np.asarray(gns, dtype=float)
    if mpm.size < 3:
        return math.nan, math.nan
    rng = np.random.default_rng(seed)
    pick = rng.integers(0, mpm.size, size=(bootstrap, mpm.size))
    values = PAIRED_STATISTICS[statistic](mpm[pick], gns[pick])
    values = values[np.isfinite(values)]
    if values.size < bootstrap / 2:
        return math.nan, math.nan
    return _percentile_interval(values, confidence)


def r2_difference(
    mpm: np.ndarray,
    first: np.ndarray,
    second: np.ndarray,
    bootstrap: int = 2000,
    confidence: float = 0.95,
    seed: int = 0,
) -> tuple[float, float, float]:
    """R² of ``first`` minus R² of ``second``, both against the same MPM values, and its percentile-bootstrap
    interval, resampling realizations (the MPM's and both models' values together); NaN where undefined."""
    mpm, first, second = (np.asarray(values, dtype=float) for values in (mpm, first, second))
    difference = r_squared(mpm, first) - r_squared(mpm, second)
    if mpm.size < 3 or not math.isfinite(difference):
        return difference, math.nan, math.nan
    pick = np.random.default_rng(seed).integers(0, mpm.size, size=(bootstrap, mpm.size))
    values = _r2_along(mpm[pick], first[pick]) - _r2_along(mpm[pick], second[pick])
    return difference, *_percentile_interval(values[np.isfinite(values)], confidence)


def bootstrap_mean_interval(values: np.ndarray, bootstrap: int, confidence: float, seed: int) -> tuple[float, float]:
    """Percentile-bootstrap interval of the mean, resampling ``values`` with replacement."""
    values = np.asarray(values, dtype=float)
    if values.size == 0:
        return math.nan, math.nan
    rng = np.random.default_rng(seed)
    means = values[rng.integers(0, values.size, size=(bootstrap, values.size))].mean(axis=1)
    return _percentile_interval(means, confidence)


def agreement(
    mpm: np.ndarray, gns: np.ndarray, metric: str, bootstrap: int = 2000, confidence: float = 0.95, seed: int = 0
) -> Agreement:
    """R², NRMSE and bias (with bootstrap CI) of paired GNS predictions against MPM."""
    mpm, gns = np.asarray(mpm, dtype=float), np.asarray(gns, dtype=float)
    if mpm.shape != gns.shape or mpm.ndim != 1:
        raise ValueError(f"{metric}: need paired 1-D arrays, got {mpm.shape} and {gns.shape}")
    n = int(mpm.size)
    errors = gns - mpm
    bias = float(errors.mean()) if n else math.nan
    mpm_mean = float(mpm.mean()) if n else math.nan
    low, high = bootstrap_mean_interval(errors, bootstrap, confidence, seed)
    r2 = r_squared(mpm, gns)
    r2_low, r2_high = (
        paired_interval("r2", mpm, gns, bootstrap, confidence, seed) if math.isfinite(r2) else (math.nan, math.nan)
    )
    return Agreement(
        metric=metric,
        n=n,
        r2=r2,
        r2_low=r2_low,
        r2_high=r2_high,
        nrmse=nrmse(mpm, gns),
        bias=bias,
        bias_low=low,
        bias_high=high,
        relative_bias=bias / mpm_mean if n and mpm_mean != 0.0 else math.nan,
        mpm_mean=mpm_mean,
        gns_mean=float(gns.mean()) if n else math.nan,
    )


def ok_rows(pairs: pd.DataFrame) -> pd.DataFrame:
    """The realizations whose GNS rollout did not diverge."""
    return pairs[pairs["gns_status"] == OK_STATUS]


def spearman(x: np.ndarray, y: np.ndarray) -> tuple[float, float]:
    """Spearman rho and p-value; NaN (without a warning) for fewer than 3 points or constant input."""
    if len(x) < 3:
        return math.nan, math.nan
    with warnings.catch_warnings():
        warnings.simplefilter("ignore", stats.ConstantInputWarning)
        result = stats.spearmanr(x, y)
    return float(result.statistic), float(result.pvalue)


def case_agreement(
    pairs: pd.DataFrame, case: str, bootstrap: int = 2000, confidence: float = 0.95, seed: int = 0
) -> tuple[list[Agreement], dict]:
    """Agreement of every metric over the ok rows of one case, plus divergence and error-vs-runout summary.

    The Spearman correlation between MPM runout and final-position MSE tells whether the GNS
    errs more on long runouts.
    """
    ok = ok_rows(pairs)
    agreements = [
        agreement(ok[f"{stem}_mpm"].to_numpy(), ok[f"{stem}_gns"].to_numpy(), metric, bootstrap, confidence, seed)
        for metric, (stem, _) in METRICS.items()
    ]
    rho, p_value = spearman(ok["runout_m_mpm"].to_numpy(), ok["final_position_mse_m2"].to_numpy())
    summary = {
        "case": case,
        "realizations": len(pairs),
        "diverged": len(pairs) - len(ok),
        "spearman_runout_vs_mse": rho,
        "spearman_p": p_value,
    }
    return agreements, summary


def validation_table(agreements: dict[str, list[Agreement]]) -> pd.DataFrame:
    """One row per (case, metric) with every Agreement field, like the paper's Table 3."""
    columns = ["case"] + [field.name for field in fields(Agreement)]
    rows = [{"case": case, **asdict(item)} for case, items in agreements.items() for item in items]
    return pd.DataFrame(rows, columns=columns)


def best_median_worst(pairs: pd.DataFrame) -> dict[str, int]:
    """Realization ``index`` of the lowest, median (position len//2) and highest final-position MSE among ok rows."""
    ok = ok_rows(pairs).sort_values("final_position_mse_m2", kind="mergesort")
    if ok.empty:
        raise ValueError("no realization with gns_status 'ok'")
    indices = ok["index"].to_numpy()
    return {"best": int(indices[0]), "median": int(indices[len(indices) // 2]), "worst": int(indices[-1])}
