"""The validation gate: which Monte Carlo cases may be drawn from the GNS, and what happens otherwise."""

from __future__ import annotations

import copy

import numpy as np
import pandas as pd
import pytest

from rgns.surrogates.gate import GateError, judge, read_verdict, simulator_for, write_verdicts
from rgns.surrogates.validation import case_agreement, validation_table

ACCEPTANCE = {
    "metrics": {
        "runout": {"r2_min": 0.9, "relative_bias_max": 0.05},
        "volume": {"r2_min": 0.9, "relative_bias_max": 0.1},
        "influence": {"r2_min": 0.9, "relative_bias_max": 0.1},
    },
    "diverged_fraction_max": 0.0,
    "on_failure": "report",
    "min_realizations": 16,
}


def _pairs(mpm: dict[str, np.ndarray], gns: dict[str, np.ndarray], status: list[str] | None = None) -> pd.DataFrame:
    n = len(mpm["runout_m"])
    frame = pd.DataFrame({"index": range(n), "gns_status": status or ["ok"] * n, "final_position_mse_m2": 0.1})
    for stem in ("runout_m", "volume_m2", "influence_m"):
        frame[f"{stem}_mpm"], frame[f"{stem}_gns"] = mpm[stem], gns[stem]
    return frame


def _verdicts(cases: dict[str, pd.DataFrame], acceptance=ACCEPTANCE):
    agreements, summaries = {}, []
    for case, pairs in cases.items():
        agreements[case], summary = case_agreement(pairs, case, bootstrap=200)
        summaries.append(summary)
    return judge(validation_table(agreements), summaries, acceptance, cell_size_m=1.0)


RNG = np.random.default_rng(0)
MPM = {"runout_m": RNG.uniform(3, 9, 24), "volume_m2": RNG.uniform(20, 50, 24), "influence_m": RNG.uniform(2, 6, 24)}


def test_a_model_that_matches_mpm_closely_passes():
    close = {key: value * (1 + 0.01 * RNG.standard_normal(24)) for key, value in MPM.items()}
    verdict = _verdicts({"case1": _pairs(MPM, close)})["case1"]
    assert verdict.passed and verdict.simulator == "gns" and verdict.failures == []


def test_a_biased_or_uncorrelated_model_fails_naming_the_metric():
    biased = dict(MPM, runout_m=MPM["runout_m"] * 0.8)  # 20 % short, still correlated
    shuffled = dict(MPM, volume_m2=RNG.permutation(MPM["volume_m2"]))
    verdicts = _verdicts({"case1": _pairs(MPM, biased), "case2": _pairs(MPM, shuffled)})
    assert not verdicts["case1"].passed and verdicts["case1"].simulator == "gns"  # reported; it decides nothing
    assert any(f.startswith("runout |relative bias| 0.200") for f in verdicts["case1"].failures)
    assert any(f.startswith("volume R²") for f in verdicts["case2"].failures)
    assert "failed the validation gate" in verdicts["case2"].sentence()


def test_standing_slopes_must_stand_in_the_gns_too():
    standing = {key: np.zeros(24) for key in MPM}
    sliding = dict(standing, runout_m=np.full(24, 4.0))  # MPM: nothing moves; GNS: 4 m runouts
    assert _verdicts({"case4": _pairs(standing, standing)})["case4"].passed
    verdict = _verdicts({"case4": _pairs(standing, sliding)})["case4"]
    assert not verdict.passed and "where every MPM realization is 0" in verdict.failures[0]


def test_diverged_rollouts_fail_the_gate():
    status = ["ok"] * 23 + ["diverged: a particle left the domain"]
    verdict = _verdicts({"case3": _pairs(MPM, MPM, status)})["case3"]
    assert not verdict.passed and verdict.failures[0].startswith("diverged fraction 0.04")


def test_on_failure_stop_raises_naming_case_and_metric(tmp_path):
    acceptance = copy.deepcopy(ACCEPTANCE) | {"on_failure": "stop"}
    verdicts = _verdicts({"case1": _pairs(MPM, dict(MPM, runout_m=MPM["runout_m"] * 0.8))}, acceptance)
    path = tmp_path / "gate.json"
    write_verdicts(verdicts, path)
    with pytest.raises(
        GateError,
        match=r"case1: the GNS failed the validation gate \(runout R² 0.582 \[[-0-9.]+, [-0-9.]+\]: lower bound < 0.9; "
        r"runout \|relative bias\| 0.200",
    ):
        simulator_for(path, "case1")
    reported = _verdicts({"case1": _pairs(MPM, dict(MPM, runout_m=MPM["runout_m"] * 0.8))})
    assert (
        not reported["case1"].passed and reported["case1"].simulator == "gns"
    )  # on_failure report: it runs all the same
    with pytest.raises(GateError, match="no verdict for case9"):
        read_verdict(path, "case9")


def _with_r2(mpm: np.ndarray, r2: float, rng: np.random.Generator) -> np.ndarray:
    """Predictions whose R² against ``mpm`` is exactly ``r2`` (unbiased noise scaled to fit)."""
    noise = rng.standard_normal(mpm.size)
    noise -= noise.mean()
    ss_tot = np.sum((mpm - mpm.mean()) ** 2)
    return mpm + noise * np.sqrt((1 - r2) * ss_tot / np.sum(noise**2))


@pytest.mark.parametrize("n, passes", [(16, False), (400, True)])
def test_the_same_point_r2_fails_on_a_small_sample_and_passes_on_a_large_one(n, passes):
    """R² 0.94 on every metric: on 16 pairs the interval reaches below 0.9, on 400 it does not."""
    rng = np.random.default_rng(3)
    mpm = {"runout_m": rng.uniform(3, 9, n), "volume_m2": rng.uniform(20, 50, n), "influence_m": rng.uniform(2, 6, n)}
    model = {key: _with_r2(value, 0.94, rng) for key, value in mpm.items()}
    agreements, summary = case_agreement(_pairs(mpm, model), "case1", bootstrap=2000)
    assert [round(a.r2, 6) for a in agreements] == [0.94] * 3
    verdict = judge(validation_table({"case1": agreements}), [summary], ACCEPTANCE, cell_size_m=1.0)["case1"]
    assert verdict.passed is passes
    if not passes:
        assert all("lower bound < 0.9" in failure for failure in verdict.failures if "R²" in failure)


def test_too_few_pairs_fail_whatever_their_r2():
    few = {key: value[:8] for key, value in MPM.items()}
    verdict = _verdicts({"case1": _pairs(few, few)})["case1"]
    assert not verdict.passed
    assert "8 finished pairs, fewer than the 16" in verdict.failures[0]
