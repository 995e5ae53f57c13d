"""GNS-vs-MPM validation: agreement statistics, bootstrap CI, case summary, table and figures."""

from __future__ import annotations

import math
import warnings

import numpy as np
import pandas as pd
import pytest

from rgns.surrogates.validation import (
    METRICS,
    agreement,
    best_median_worst,
    case_agreement,
    r2_difference,
    r_squared,
    validation_table,
)
from rgns.surrogates.validation_plots import plot_energy_evolution, plot_histograms, plot_parity
from rgns.tables import markdown_table

MPM_RUNOUT_M = np.array([10.0, 12.0, 15.0, 11.0, 20.0, 18.0, 13.0, 16.0])


def _pairs(n: int, seed: int, statuses: list[str] | None = None) -> pd.DataFrame:
    """Synthetic per-realization table; GNS = MPM plus small noise, MSE grows with MPM runout."""
    rng = np.random.default_rng(seed)
    runout = rng.uniform(5.0, 50.0, n)
    volume = rng.uniform(10.0, 200.0, n)
    influence = rng.uniform(1.0, 20.0, n)
    return pd.DataFrame(
        {
            "index": np.arange(n) * 10,
            "gns_status": statuses if statuses is not None else ["ok"] * n,
            "runout_m_mpm": runout,
            "runout_m_gns": runout + rng.normal(0.0, 1.0, n),
            "volume_m2_mpm": volume,
            "volume_m2_gns": volume + rng.normal(0.0, 5.0, n),
            "influence_m_mpm": influence,
            "influence_m_gns": influence + rng.normal(0.0, 0.5, n),
            "final_position_mse_m2": 0.01 * runout**2,
        }
    )


def test_identical_predictions_agree_perfectly():
    result = agreement(MPM_RUNOUT_M, MPM_RUNOUT_M.copy(), "runout")
    assert result.n == MPM_RUNOUT_M.size
    assert result.r2 == 1.0
    assert result.nrmse == 0.0
    assert result.bias == 0.0
    assert result.bias_low == result.bias_high == 0.0
    assert result.relative_bias == 0.0
    assert result.mpm_mean == result.gns_mean == MPM_RUNOUT_M.mean()


def test_constant_offset_gives_exact_bias_zero_width_ci_and_hand_r2_nrmse():
    offset_m = 2.5  # exactly representable, so gns - mpm == offset exactly
    result = agreement(MPM_RUNOUT_M, MPM_RUNOUT_M + offset_m, "runout")
    ss_tot = float(np.sum((MPM_RUNOUT_M - MPM_RUNOUT_M.mean()) ** 2))
    assert result.bias == offset_m
    assert (result.bias_low, result.bias_high) == (offset_m, offset_m)
    assert result.r2 == pytest.approx(1.0 - MPM_RUNOUT_M.size * offset_m**2 / ss_tot, rel=1e-12)
    assert result.nrmse == pytest.approx(offset_m / (MPM_RUNOUT_M.max() - MPM_RUNOUT_M.min()), rel=1e-12)
    assert result.relative_bias == pytest.approx(offset_m / MPM_RUNOUT_M.mean(), rel=1e-12)


def test_predicting_the_mpm_mean_gives_zero_r2():
    result = agreement(MPM_RUNOUT_M, np.full_like(MPM_RUNOUT_M, MPM_RUNOUT_M.mean()), "runout")
    assert result.r2 == pytest.approx(0.0, abs=1e-12)


def test_degenerate_inputs_give_nan_not_errors():
    constant = agreement(np.full(4, 3.0), np.full(4, 3.0), "volume")
    assert math.isnan(constant.r2) and math.isnan(constant.nrmse)
    single = agreement(np.array([2.0]), np.array([3.0]), "volume")
    assert math.isnan(single.r2) and single.bias == 1.0
    zero_mean = agreement(np.array([-1.0, 1.0]), np.array([0.0, 2.0]), "volume")
    assert math.isnan(zero_mean.relative_bias)


def test_bootstrap_ci_covers_true_offset_with_normal_theory_width():
    rng = np.random.default_rng(42)
    n, offset_m, sigma_m = 200, 0.5, 1.0
    mpm = rng.uniform(5.0, 50.0, n)
    gns = mpm + offset_m + rng.normal(0.0, sigma_m, n)
    result = agreement(mpm, gns, "runout", bootstrap=2000, confidence=0.95, seed=7)
    assert result.bias_low < offset_m < result.bias_high
    expected_width_m = 2.0 * 1.96 * sigma_m / math.sqrt(n)
    assert result.bias_high - result.bias_low == pytest.approx(expected_width_m, rel=0.25)
    again = agreement(mpm, gns, "runout", bootstrap=2000, confidence=0.95, seed=7)
    assert (again.bias_low, again.bias_high) == (result.bias_low, result.bias_high)


def test_case_agreement_leaves_diverged_rows_out_but_counts_them():
    statuses = ["ok"] * 8 + ["diverged: NaN at step 40", "diverged: particles left domain"]
    pairs = _pairs(10, seed=1, statuses=statuses)
    pairs.loc[8:, ["runout_m_gns", "volume_m2_gns", "influence_m_gns"]] = 1e6  # garbage if counted
    agreements, summary = case_agreement(pairs, "case1", bootstrap=200)
    assert [item.metric for item in agreements] == list(METRICS)
    assert all(item.n == 8 for item in agreements)
    runout = agreements[0]
    ok = pairs.iloc[:8]
    assert runout.bias == pytest.approx(float((ok["runout_m_gns"] - ok["runout_m_mpm"]).mean()), rel=1e-12)
    assert summary["case"] == "case1"
    assert summary["realizations"] == 10 and summary["diverged"] == 2
    assert summary["spearman_runout_vs_mse"] == pytest.approx(1.0)  # MSE monotone in runout


def test_spearman_is_nan_without_warning_for_constant_or_too_few_rows():
    constant = _pairs(6, seed=2)
    constant["final_position_mse_m2"] = 0.3
    few = _pairs(2, seed=3)
    with warnings.catch_warnings():
        warnings.simplefilter("error")
        _, constant_summary = case_agreement(constant, "case2", bootstrap=50)
        _, few_summary = case_agreement(few, "case3", bootstrap=50)
    assert math.isnan(constant_summary["spearman_runout_vs_mse"])
    assert math.isnan(constant_summary["spearman_p"])
    assert math.isnan(few_summary["spearman_runout_vs_mse"])


def test_best_median_worst_picks_indices_by_final_position_mse_among_ok_rows():
    pairs = pd.DataFrame(
        {
            "index": [3, 7, 11, 19, 23, 31],
            "gns_status": ["ok", "ok", "diverged: NaN", "ok", "ok", "ok"],
            "final_position_mse_m2": [0.5, 0.1, 0.0, 2.0, 0.9, 0.3],
        }
    )
    # ok rows sorted by MSE: 7 (0.1), 31 (0.3), 3 (0.5), 23 (0.9), 19 (2.0); median at position 5 // 2 = 2
    assert best_median_worst(pairs) == {"best": 7, "median": 3, "worst": 19}


def test_validation_table_has_one_row_per_case_and_metric():
    agreements = {
        case: case_agreement(_pairs(6, seed), case, bootstrap=50)[0] for seed, case in enumerate(["case1", "case2"])
    }
    table = validation_table(agreements)
    assert list(table.columns) == [
        "case",
        "metric",
        "n",
        "r2",
        "r2_low",
        "r2_high",
        "nrmse",
        "bias",
        "bias_low",
        "bias_high",
        "relative_bias",
        "mpm_mean",
        "gns_mean",
    ]
    assert list(zip(table["case"], table["metric"])) == [(c, m) for c in ["case1", "case2"] for m in METRICS]
    assert (table["n"] == 6).all()


def test_markdown_table_has_header_separator_one_row_per_line_and_dash_for_nan():
    table = pd.DataFrame({"case": ["case1", "case2"], "n": [5, 7], "r2": [0.98765, math.nan]})
    lines = markdown_table(table, digits=2).splitlines()
    assert lines == [
        "| case | n | r2 |",
        "| --- | ---: | ---: |",
        "| case1 | 5 | 0.99 |",
        "| case2 | 7 | – |",
    ]


def test_each_plot_writes_a_non_empty_png(tmp_path):
    pairs_by_case = {"case1": _pairs(5, seed=4), "case2": _pairs(5, seed=5, statuses=["ok"] * 4 + ["diverged: x"])}
    time_s = np.linspace(0.0, 2.0, 20)
    decay = np.exp(-time_s)[None, :, None]
    mpm = np.concatenate([decay, 0.2 * (1 - decay), 0.8 * (1 - decay)], axis=2).repeat(5, axis=0)
    energies = {"time_s": time_s, "index": pairs_by_case["case1"]["index"].to_numpy(), "mpm": mpm, "gns": mpm * 1.05}
    paths = [tmp_path / name for name in ("histograms.png", "parity.png", "energy.png")]
    plot_histograms(pairs_by_case, paths[0])
    plot_parity(pairs_by_case, paths[1])
    plot_energy_evolution(energies, best_median_worst(pairs_by_case["case1"]), "case1", paths[2])
    for path in paths:
        assert path.read_bytes()[:8] == b"\x89PNG\r\n\x1a\n"
        assert path.stat().st_size > 5000


def test_the_figures_name_the_simulator_that_ran_and_show_no_path_it_has_not(tmp_path, monkeypatch):
    """With the end-state surrogate: its name on the parity axes and in the legends, and its energies
    as start and end points (NaN between), no dashed curve."""
    import rgns.surrogates.validation_plots as plots

    kept = []
    monkeypatch.setattr(plots.plt, "close", kept.append)
    pairs_by_case = {"case1": _pairs(5, seed=4)}
    time_s = np.linspace(0.0, 2.0, 20)
    mpm = np.repeat(np.stack([np.exp(-time_s), 0.1 + 0 * time_s, 1 - np.exp(-time_s)], axis=1)[None], 5, axis=0)
    ends = np.full_like(mpm, np.nan)
    ends[:, [0, -1]] = mpm[:, [0, -1]]
    energies = {"time_s": time_s, "index": pairs_by_case["case1"]["index"].to_numpy(), "mpm": mpm, "gns": ends}
    plot_parity(pairs_by_case, tmp_path / "parity.png", "end-state surrogate")
    plot_energy_evolution(
        energies, best_median_worst(pairs_by_case["case1"]), "case1", tmp_path / "energy.png", "end-state surrogate"
    )
    parity, energy = kept
    assert parity.axes[0].get_ylabel().startswith("end-state surrogate")
    labels = [text.get_text() for text in energy.axes[0].get_legend().get_texts()]
    assert labels == ["MPM (true)", "end-state surrogate (end state)"]
    surrogate_lines = [line for line in energy.axes[0].get_lines() if line.get_label().startswith("end-state")]
    assert len(surrogate_lines) == 1 and len(surrogate_lines[0].get_xdata()) == 2


def test_the_parity_and_histogram_figures_draw_each_cases_own_pairs_and_r2(tmp_path, monkeypatch):
    """Read back from the axes: per metric, each case's points are its ok rows' (MPM, simulator) values (a
    diverged rollout left out), its legend gives R² of exactly those pairs, the 1:1 line spans them all; each
    histogram counts every ok row once, the MPM's and the simulator's on common bins. Fails with the axes
    swapped, the diverged row drawn, or the bins apart."""
    import rgns.surrogates.validation_plots as plots

    kept = []
    monkeypatch.setattr(plots.plt, "close", kept.append)
    pairs_by_case = {"case1": _pairs(7, seed=4), "case2": _pairs(6, seed=5, statuses=["ok"] * 5 + ["diverged: x"])}
    plot_parity(pairs_by_case, tmp_path / "parity.png")
    plot_histograms(pairs_by_case, tmp_path / "histograms.png")
    parity, histograms = kept
    for axis, stem in zip(parity.axes, ("runout_m", "volume_m2", "influence_m")):
        everything = []
        for case, collection in zip(pairs_by_case, axis.collections):
            ok = pairs_by_case[case][pairs_by_case[case]["gns_status"] == "ok"]
            expected = ok[[f"{stem}_mpm", f"{stem}_gns"]].to_numpy(float)
            np.testing.assert_allclose(collection.get_offsets(), expected)
            assert collection.get_label() == f"{case} (R² = {r_squared(expected[:, 0], expected[:, 1]):.3f})"
            everything.append(expected)
        (diagonal,) = [line for line in axis.get_lines() if line.get_label() == "1:1"]
        stacked = np.concatenate(everything)
        np.testing.assert_allclose(diagonal.get_xdata(), [stacked.min(), stacked.max()])
    for row, case in zip(np.reshape(histograms.axes, (2, 3)), pairs_by_case):
        ok = (pairs_by_case[case]["gns_status"] == "ok").sum()
        for axis in row:
            mpm, simulator = axis.containers[0], axis.patches[-1]
            assert sum(bar.get_height() for bar in mpm) == ok
            edges = [bar.get_x() for bar in mpm] + [mpm[-1].get_x() + mpm[-1].get_width()]
            outline = simulator.get_path().vertices[:, 0]
            assert min(outline) == pytest.approx(edges[0]) and max(outline) == pytest.approx(edges[-1])


def test_r2_difference_is_paired_and_its_interval_excludes_zero_only_for_a_real_gain():
    """Two models with the same errors differ by exactly 0 with a zero-width interval (the resamples are paired);
    a model with half the error is better by 3/4 of the other's unexplained share, its interval above 0."""
    rng = np.random.default_rng(3)
    mpm = rng.normal(5.0, 1.0, 64)
    noise = rng.normal(0.0, 0.5, 64)
    same = r2_difference(mpm, mpm + noise, mpm + noise)
    assert same == (0.0, 0.0, 0.0)
    better, low, high = r2_difference(mpm, mpm + noise / 2, mpm + noise)
    assert better == pytest.approx(0.75 * (1 - r_squared(mpm, mpm + noise)))
    assert 0.0 < low < better < high
