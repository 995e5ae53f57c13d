"""The multi-fidelity correction's passages: speed-ups per cheap route, the tuned route, the mesh step, the chain."""

from __future__ import annotations

import math
from typing import Any

from evidence.formatting import ends, minutes, order_text, pct, true_minus
from evidence.sources import DocumentError, result


def tuned_least() -> str:
    """README: the tuned cheap route's least speed-up over the 0.5 m MPM alone, over every quantity and budget of
    docs/fidelity.md's table (hifi_surrogate.json)."""
    record = result("hifi_surrogate.json", legacy=True)
    least = least_tuned_speedup(record)
    return (
        f"With the tuned surrogate as cheap route it reaches a given error {least:.2f}× faster than the 0.5 m MPM "
        "alone at least, over the means of R, V and I and the exceedance probabilities at every budget measured, on "
        f"the pool the tuning was chosen on (`{record['command']}`, committed in {record['committed_in']}: "
        "`benchmarks/results/hifi_surrogate.md`)."
    )


def speedups(cheap: dict[str, Any], quantities: list[str], wanted: list[str], runs: list[int]) -> str:
    """'a / b×' of the measured speed-ups of ``wanted`` quantities at ``runs`` accurate runs' time."""
    at = {budget["high_runs"]: budget["speedup"] for budget in cheap["budgets"]}
    return " / ".join(f"{at[n][quantities.index(q)]:.2f}" for q in wanted for n in runs) + "×"


def speedup_cell(cheap: dict[str, Any], quantities: list[str], column: str) -> str:
    """'a / b / c× (ρ r)': one quantity's speed-ups at every budget a cheap route was measured at, and its
    correlation with the accurate route."""
    runs = [budget["high_runs"] for budget in cheap["budgets"]]
    return f"{speedups(cheap, quantities, [column], runs)} (ρ {cheap['correlation'][quantities.index(column)]:.3f})"


def bench_multifidelity() -> str:
    """docs/benchmarks.md: multi-fidelity against plain 0.5 m Monte Carlo at equal wall time, per cheap route
    (multifidelity.json), and with the surrogate tuned on 0.5 m runs (hifi_surrogate.json)."""
    plain = result("multifidelity.json", legacy=True)
    tuned = result("hifi_surrogate.json", legacy=True)
    q, cheap = plain["analysis"]["quantities"], plain["analysis"]["cheap"]
    one, shipped = cheap["MPM 1 m"], cheap["end-state surrogate (shipped)"]
    tq, tuned_cheap = tuned["analysis"]["quantities"], tuned["analysis"]["cheap"]["end-state surrogate, tuned on 0.5 m"]
    used = [i for i, name in enumerate(tq) if not name.startswith("P(") or name.endswith("regression")]
    tuned_least = min(budget["speedup"][i] for budget in tuned_cheap["budgets"] for i in used)
    figure = (
        f"with the 1 m MPM as cheap route ({one['s_per_realization']:.2f} vs "
        f"{plain['routes']['MPM 0.5 m']['s_per_realization']:.2f} s per realization), at 16 / 32 accurate runs' "
        f"time: mean R {speedups(one, q, ['mean R'], [16, 32])}, mean V {speedups(one, q, ['mean V'], [16, 32])}, "
        f"mean I {speedups(one, q, ['mean I'], [16, 32])}; P(R > r50), P(R > r10) "
        f"{speedups(one, q, ['P(R > r50), regression'], [16, 32])} and "
        f"{speedups(one, q, ['P(R > r10), regression'], [16, 32])} by the regression control variate "
        f"({speedups(one, q, ['P(R > r50)'], [16, 32])} and {speedups(one, q, ['P(R > r10)'], [16, 32])} by the "
        f"indicator one); with the shipped end-state surrogate ({shipped['s_per_realization']:.3f} s) mean R / V / I "
        f"{speedups(shipped, q, ['mean R', 'mean V', 'mean I'], [16])} at 16 runs' time, P(R > r50), P(R > r10) "
        f"{speedups(shipped, q, ['P(R > r50), regression', 'P(R > r10), regression'], [16])}; tuned on "
        f"{tuned['args']['train']} coarse-grained 0.5 m runs (`benchmarks/hifi_surrogate.py`): mean R / V / I "
        f"{speedups(tuned_cheap, tq, ['mean R', 'mean V', 'mean I'], [16])}, P(R > r50), P(R > r10) "
        f"{speedups(tuned_cheap, tq, ['P(R > r50), regression', 'P(R > r10), regression'], [16])} at 16 runs' time "
        f"(the least at 8, 16 and 32 over the means and the regression estimates of P, the estimators the pipeline "
        f"uses: {tuned_least:.2f}×, on the pool the tuning was chosen on)"
    )
    return "\n".join(
        [
            "| what | figure | command | made at |",
            "|---|---|---|---|",
            f"| multi-fidelity vs plain 0.5 m MC at equal wall time, {plain['n']} case-1 realizations | {figure} | "
            f"`{plain['command'].split(' (')[0]}`, then `--analyse`; `{tuned['command'].split(' (')[0]}` | "
            f"`multifidelity.json` committed in "
            f"{plain['committed_in']}, `hifi_surrogate.json` committed in {tuned['committed_in']} |",
        ]
    )


def lowest_work(candidates: list[dict[str, Any]], cheap: int) -> str:
    """Where an allocation's cost × half-width² is lowest among ``candidates`` with ``cheap`` cheap runs, and the
    range of pairs within 10 % of it."""
    rows = sorted((c for c in candidates if c["cheap"] == cheap), key=lambda c: c["pairs"])
    best = min(rows, key=lambda c: c["work_width"])
    near = [c["pairs"] for c in rows if c["work_width"] <= 1.1 * best["work_width"]]
    return f"{best['pairs']} pairs (within 10 % of it from {near[0]} to {near[-1]})"


def chain_gains(record: dict[str, Any]) -> dict[str, float]:
    """chain_coverage.json: per quantity, plain Monte Carlo's cost × variance over its default allocation's."""
    gains = {}
    for name, entry in record["allocation"].items():
        default = next(
            c for c in entry["candidates"] if c["pairs"] == record["pairs"] and c["cheap"] == record["cheap"]
        )
        gains[name] = entry["plain_work_variance"] / default["work_variance"]
    return gains


def bench_chain_coverage() -> str:
    """docs/benchmarks.md: the fidelity chain's coverage and allocation on the real runs (chain_coverage.json)."""
    record = result("chain_coverage.json", legacy=True)
    coverage, distances, allocation = record["coverage"], record["distances"], record["allocation"]
    gains = chain_gains(record)
    mean_name, p_name = list(allocation)
    figure = (
        f"converged mean runout covered in {pct(coverage['runout_m (sampling only)']['coverage'])} (sampling "
        f"interval; {pct(coverage['runout_m']['coverage'])} with the order's range), V "
        f"{pct(coverage['volume_m2']['coverage'])}, I {pct(coverage['influence_m']['coverage'])}; through the "
        f"pipeline's estimators over {distances['0.5']['replicates']} replicates the runout exceeded with P 0.5 and "
        f"0.1 covered in {pct(distances['0.5']['direct']['coverage_at_order'])} and "
        f"{pct(distances['0.1']['direct']['coverage_at_order'])} (sampling interval of the joint bootstrap; "
        f"{pct(distances['0.5']['direct']['coverage'])} and {pct(distances['0.1']['direct']['coverage'])} with the "
        f"order's range); at equal sampling error {gains[mean_name]:.0f}× cheaper than plain 0.25 m Monte Carlo "
        f"for the converged mean runout, {gains[p_name]:.0f}× for {p_name.split(',')[0]}; at {record['cheap']} "
        f"cheap realizations the interval's cost × half-width² is lowest at "
        f"{lowest_work(allocation[mean_name]['candidates'], record['cheap'])} for the mean, at "
        f"{lowest_work(allocation[p_name]['candidates'], record['cheap'])} for {p_name.split(',')[0]} (then "
        f"default {record['pairs']})"
    )
    return "\n".join(
        [
            "| what | figure | command | made at |",
            "|---|---|---|---|",
            f"| the fidelity chain on real runs: coverage over {record['replicates']} resampled replicates of the "
            f"{record['population']} case-1 realizations at 1 / 0.5 / 0.25 m, and its allocation from measured costs "
            f"and correlations | {figure} | `{record['command']}` | `chain_coverage.json` committed in "
            f"{record['committed_in']} |",
        ]
    )


def direct_reference(levels: dict[str, Any]) -> str:
    """Whether a default run's headline holds each quantity of a mesh-levels case's direct reference (its
    ``against`` comparisons other than the mesh steps): 'mean runout R 10.31 m [9.71, 11.35] holds its 10.61 m; …'."""
    return "; ".join(
        f"{entry['quantity']} {ends(entry['headline'])} {'holds' if entry['inside'] else 'DOES NOT hold'} "
        f"its {entry['reference'][0]:.2f} m"
        for entry in levels["against"]["comparisons"]
        if not entry["quantity"].startswith("mesh")
    )


def mesh_step() -> str:
    """README: the step to the converged mesh, its order measured on case 1, against the direct reference of the
    GPU's 0.25 m runs, and the chain's coverage on the real runs (mesh_levels.json, mesh_levels_gpu.json,
    chain_coverage.json)."""
    cpu, gpu = result("mesh_levels.json"), result("mesh_levels_gpu.json")
    independent_record = result("mesh_levels_independent.json")
    independent = independent_record["case1"]
    chain = result("chain_coverage.json", legacy=True)
    for name, record in (("mesh_levels.json", cpu), ("mesh_levels_gpu.json", gpu)):
        if "against" not in record["case1"]:
            raise DocumentError(f"benchmarks/results/{name}: no comparison with a default run (run it with --against)")
    order, own = independent["fits"]["runout_m"]["order"], cpu["case1"]["fits"]["runout_m"]["order"]
    finest = independent["finest"]["fits"]["runout_m"]["finest_minus_predicted"]
    compared = {entry["quantity"]: entry for entry in cpu["case1"]["against"]["comparisons"]}
    step = compared["mesh step of the mean runout (converged − 0.5 m; headline: over the order's interval)"]

    coverage, distances = chain["coverage"], chain["distances"]
    mean_name = list(chain["allocation"])[0]
    return (
        f"The step to the converged mesh uses the runout's order measured on "
        f"{len(independent['realizations'])} case-1 realizations of a seed of their own at 1, 0.5 and 0.25 m: "
        f"{order['value']:.2f} [{order['lower']:.2f}, {order['upper']:.2f}]; at 0.125 m their mean runout sits "
        f"{finest['value']:+.2f} m [{finest['lower']:+.2f}, {finest['upper']:+.2f}] from what the three coarser "
        f"meshes predict for it (`benchmarks/results/mesh_levels_independent.md`, at {independent_record['commit']}). "
        f"On the run's own {len(cpu['case1']['realizations'])} realizations the order is {own['value']:.2f} "
        f"[{own['lower']:.2f}, {own['upper']:.2f}], and with the configured order their 0.5 m mean runout is short "
        f"by {ends(step['reference'])}; the default run's step, {ends(step['headline'])} "
        f"({cpu['case1']['against']['headline']}), {'holds' if step['inside'] else 'DOES NOT hold'} it "
        f"(`benchmarks/results/mesh_levels.md`: `{cpu['command']}` at {cpu['commit']}). Its interval holds that "
        f"order's uncertainty, which is most of its width. Against a direct reference, the run's first "
        f"{len(gpu['case1']['realizations'])} realizations at 0.25 m plus their own Richardson step, run on a GPU "
        f"(`benchmarks/results/mesh_levels_gpu.md`, at {gpu['commit']}), the headline "
        + direct_reference(gpu["case1"])
        + f". Over {chain['replicates']} replicates resampled from the {chain['population']} realizations at three "
        f"meshes the mean runout's sampling interval covered the known converged answer in "
        f"{pct(coverage['runout_m (sampling only)']['coverage'])} and the mean V and I in "
        f"{pct(coverage['volume_m2']['coverage'])} and {pct(coverage['influence_m']['coverage'])}; R exceeded with "
        f"P 0.5 and 0.1, through the pipeline's estimators over {distances['0.5']['replicates']}, in "
        f"{pct(distances['0.5']['direct']['coverage_at_order'])} and "
        f"{pct(distances['0.1']['direct']['coverage_at_order'])} (sampling part); at equal sampling error the chain "
        f"is {chain_gains(chain)[mean_name]:.0f}× cheaper than plain 0.25 m Monte Carlo for the converged mean "
        f"runout (`{chain['command']}`, committed in {chain['committed_in']}, {chain['pairs']} pairs and "
        f"{chain['cheap']} cheap runs: the estimators as they were then)."
    )


# docs/fidelity.md's names of multifidelity.json's cheap routes, in its order
ROUTE_LABELS = {
    "MPM 1 m": "MPM 1 m",
    "MPM 1 m, cfl 0.8": "MPM 1 m, CFL 0.8 (rejected)",
    "MPM 2 m": "MPM 2 m",
    "GNS (shipped)": "GNS (shipped)",
    "end-state surrogate (shipped)": "end-state surrogate (shipped at 6d09908, 8,000 steps)",
}


def gpu_levels() -> str:
    """docs/fidelity.md: the mesh levels run on a GPU: their time per realization against the one-thread CPU runs',
    their runout against those runs, and the orders their realizations give against the configured ones."""
    gpu, cpu = result("mesh_levels_gpu.json")["case1"], result("mesh_levels.json")["case1"]
    cells = list(gpu["seconds"])
    agreement = gpu["cpu_agreement"]
    worst = max(agreement, key=lambda row: row["largest_m"])
    mean = max(abs(row["mean_difference_m"]) for row in agreement)

    names = {"runout_m": "runout", "volume_m2": "volume", "influence_m": "influence"}
    orders = "; ".join(
        f"the {name}'s {order_text(gpu['mesh_order'][key])} (on the CPU's {len(cpu['realizations'])}: "
        f"{order_text(cpu['mesh_order'][key])})"
        for key, name in names.items()
    )
    return (
        f"{sum(gpu['seconds'].values()):.1f} s per realization for all {len(cells)} meshes (h = "
        f"{' / '.join(f'{float(h):g}' for h in cells)} m) in batches of 64, against "
        f"{' + '.join(format(cpu['seconds'][h], '.0f') for h in cells)} s on one CPU thread of the 2-core machine; the runout "
        f"agrees with the one-thread CPU runs on the {agreement[0]['n']} realizations both ran to "
        f"{100 * worst['largest_m']:.1f} cm at most (at {worst['cell_size_m']:g} m), {100 * mean:.2f} cm on average "
        f"(`benchmarks/results/mesh_levels_gpu.md`). Its store, `mesh_levels_gpu_runs.jsonl`, holds the first "
        f"{len(gpu['realizations'])} realizations at every mesh; the orders they give, as `mesh_order` would take "
        f"them: {orders}."
    )


def multifidelity_routes() -> str:
    """docs/fidelity.md: every cheap route against plain 0.5 m Monte Carlo at equal wall time, speed-ups at 8 / 16 /
    32 accurate runs' time with each quantity's correlation, the exceedance probabilities by the indicator and the
    regression control variate (multifidelity.json)."""
    record = result("multifidelity.json", legacy=True)
    quantities, cheap = record["analysis"]["quantities"], record["analysis"]["cheap"]

    def cell(route: dict[str, Any], column: str) -> str:
        return speedup_cell(route, quantities, column)

    lines = [
        "| cheap route | s per realization | mean R | mean V | mean I | P(R > r50): indicator → regression | "
        "P(R > r10): indicator → regression |",
        "|---|---|---|---|---|---|---|",
    ]
    for name, label in ROUTE_LABELS.items():
        route = cheap[name]
        probabilities = [f"{cell(route, p)} → {cell(route, f'{p}, regression')}" for p in ("P(R > r50)", "P(R > r10)")]
        lines.append(
            f"| {label} | {route['s_per_realization']:.3g} | "
            + " | ".join([cell(route, q) for q in ("mean R", "mean V", "mean I")] + probabilities)
            + " |"
        )
    budgets = " / ".join(str(b["high_runs"]) for b in cheap["MPM 1 m"]["budgets"])
    lines += [
        "",
        f"The accurate route, the MPM at 0.5 m: {record['routes']['MPM 0.5 m']['s_per_realization']:.2f} s per "
        f"realization. Speed-ups at {budgets} accurate runs' time, on the {record['n']}-realization pool; "
        f"`{record['command']}`, `benchmarks/results/multifidelity.json` committed in {record['committed_in']} "
        f"({record['machine']}).",
    ]
    return "\n".join(lines)


def indicator_ceiling(rho: float) -> float:
    """The correlation of 1[h > median] with its exact conditional probability given l, for (l, h) bivariate
    normal with correlation ``rho``: the best any regression on a cheap runout can do for an exceedance
    probability at the median (Var Φ(aZ) = arcsin(a² / (1 + a²)) / 2π, a = ρ / √(1 − ρ²))."""
    a2 = rho**2 / (1 - rho**2)
    return math.sqrt(2 * math.asin(a2 / (1 + a2)) / math.pi)


def needed_cost_ratio(rho: float, speedup: float) -> float:
    """How many times cheaper than the accurate route a cheap route correlating ``rho`` must be for the MFMC
    optimum, 1 / (√(1 − ρ²) + ρ √(c_L / c_H))², to reach ``speedup``."""
    root = (1 / math.sqrt(speedup) - math.sqrt(1 - rho**2)) / rho
    return 1 / root**2 if root > 0 else math.inf


def measured_speedups(route: dict[str, Any], quantities: list[str], names: list[str]) -> list[float]:
    """Every measured speed-up of a cheap route for ``names``, at every budget."""
    return [budget["speedup"][quantities.index(name)] for budget in route["budgets"] for name in names]


def route_span(route: dict[str, Any], quantities: list[str], names: list[str]) -> str:
    """'a–b×': the lowest and highest measured speed-up of ``names`` over every budget."""
    values = measured_speedups(route, quantities, names)
    return f"{min(values):.1f}–{max(values):.1f}×"


# the quantities of docs/fidelity.md's table of the tuned cheap route (hifi_surrogate.json)
TUNED_COLUMNS = ["mean R", "mean V", "mean I", "P(R > r50), regression", "P(R > r10), regression"]


def least_tuned_speedup(record: dict[str, Any]) -> float:
    """hifi_surrogate.json: the tuned route's least speed-up over the table's quantities and budgets."""
    analysis = record["analysis"]
    return min(
        measured_speedups(
            analysis["cheap"]["end-state surrogate, tuned on 0.5 m"], analysis["quantities"], TUNED_COLUMNS
        )
    )


def multifidelity_levers() -> str:
    """docs/fidelity.md: what each lever of the correction did, from multifidelity.json (speed-ups, correlations,
    costs, the routes' means)."""
    record = result("multifidelity.json", legacy=True)
    quantities, cheap, routes = record["analysis"]["quantities"], record["analysis"]["cheap"], record["routes"]

    def rho(route: str, quantity: str) -> float:
        return cheap[route]["correlation"][quantities.index(quantity)]

    def mean(route: str, key: str) -> float:
        rows = [row[key] for row in routes[route]["rows"] if row["status"] == "ok"]
        return sum(rows) / len(rows)

    one, cfl, two = "MPM 1 m", "MPM 1 m, cfl 0.8", "MPM 2 m"
    accurate = routes["MPM 0.5 m"]["s_per_realization"]
    w = accurate / cheap[one]["s_per_realization"]
    regression = rho(one, "P(R > r50), regression")
    indicators = ["P(R > r50)", "P(R > r10)"]
    fitted = [f"{p}, regression" for p in indicators]
    ceiling = indicator_ceiling(rho(one, "mean R"))
    return "\n".join(
        [
            f"* **The regression control variate** lifted the exceedance probabilities from "
            f"{route_span(cheap[one], quantities, indicators)} to {route_span(cheap[one], quantities, fitted)} (its "
            f"correlation with 1[h > r] is {regression:.2f} and {rho(one, fitted[1]):.2f} instead of the indicators' "
            f"{rho(one, indicators[0]):.2f} and {rho(one, indicators[1]):.2f}). Its ceiling: with the runouts "
            f"correlating {rho(one, 'mean R'):.3f}, 1[h > r] stays uncertain given l near r; even the exact "
            f"conditional probability would correlate only {ceiling:.2f} with it "
            f"(bivariate normal at the median: at most {1 / (1 - ceiling**2):.1f}× "
            f"with infinitely many free cheap runs), the fitted one {regression:.2f}, so at most 1/(1 − ρ²) = "
            f"{1 / (1 - regression**2):.1f}× with free cheap runs and "
            f"{cheap[one]['predicted_speedup'][quantities.index(fitted[0])]:.1f}× at this cost ratio "
            f"(w = {w:.1f}, MFMC optimum).",
            f"* **The cost ratio** w = {w:.1f} is what limits the means: at ρ {rho(one, 'mean R'):.3f} the MFMC "
            f"optimum is {cheap[one]['predicted_speedup'][0]:.1f}×.",
            f"* **A larger time step** (CFL 0.8 instead of 0.2) made the 1 m route "
            f"{cheap[one]['s_per_realization'] / cheap[cfl]['s_per_realization']:.1f}× cheaper at the same runout "
            f"correlation ({rho(cfl, 'mean R'):.3f}), {max(b['speedup'][0] for b in cheap[cfl]['budgets']):.1f}× for "
            f"mean R, **but the deposit creeps**: V and I correlate {rho(cfl, 'mean V'):.2f} and "
            f"{rho(cfl, 'mean I'):.2f} with the 0.5 m runs (mean V {mean(cfl, 'volume_m2') / mean('MPM 0.5 m', 'volume_m2'):.1f}×, "
            f"mean I {mean(cfl, 'influence_m') / mean('MPM 0.5 m', 'influence_m'):.1f}× the 0.5 m runs'), and the "
            "zoning's back scarp with them. Rejected: the cheap route keeps CFL 0.2.",
            f"* **A coarser mesh** (2 m) is {cheap[one]['s_per_realization'] / cheap[two]['s_per_realization']:.1f}× "
            f"cheaper than 1 m but correlates {rho(two, 'mean R'):.3f} in R: no better.",
            f"* **The GNS** ({cheap['GNS (shipped)']['s_per_realization']:.1f} s per realization against the 0.5 m "
            f"MPM's {accurate:.1f} s on a CPU, R correlation {rho('GNS (shipped)', 'mean R'):.3f}) only costs.",
            "",
            f"Reaching 5× for the means at ρ {rho(one, 'mean R'):.3f} needs a cheap route "
            f"{needed_cost_ratio(rho(one, 'mean R'), 5.0):.0f}× cheaper than the accurate one (the MFMC optimum); no "
            f"MPM setting or the GNS was; the end-state surrogate is "
            f"{accurate / cheap['end-state surrogate (shipped)']['s_per_realization']:,.0f}× cheaper at ρ "
            f"{min(rho('end-state surrogate (shipped)', q) for q in ('mean R', 'mean V', 'mean I')):.3f}–"
            f"{max(rho('end-state surrogate (shipped)', q) for q in ('mean R', 'mean V', 'mean I')):.3f} "
            f"(`benchmarks/results/multifidelity.json`).",
        ]
    )


def hifi_tuning() -> str:
    """docs/fidelity.md: the tuned surrogate's fine-tune (time, held-out loss), its runout bias against the 0.5 m
    MPM on the pool beside the shipped model's, and when its tuning runs pay for themselves (hifi_surrogate.json)."""
    record = result("hifi_surrogate.json", legacy=True)
    quantities, cheap = record["analysis"]["quantities"], record["analysis"]["cheap"]
    tuned, shipped = cheap["end-state surrogate, tuned on 0.5 m"], cheap["end-state surrogate, shipped (1 m)"]
    smallest = least_tuned_speedup(record)
    runs = int(record["args"]["realizations"])
    bias = quantities.index("mean R")
    return (
        f"Fine-tuned {record['args']['steps']} steps on {record['train']} of the {runs} coarse-grained 0.5 m runs in "
        f"{minutes(record['fine_tune_s'])} (2 threads); held-out loss on the other {record['held_out']}: "
        f"{record['before']['valid_loss']:.4f} → {record['history'][-1]['valid_loss']:.5f}. On the "
        f"{record['n']}-realization pool its runout is {true_minus(format(tuned['bias'][bias], '.2f'))} m off the "
        f"0.5 m MPM's on average (the shipped model: {true_minus(format(shipped['bias'][bias], '.2f'))} m). The "
        f"{runs} tuning runs are paid once per case: at the smallest speed-up in the table above ({smallest:.2f}×) the tuned "
        f"route saves time from about {runs / (1 - 1 / smallest):.0f} accurate runs' worth of plain MC on "
        f"(`benchmarks/results/hifi_surrogate.json`, committed in {record['committed_in']})."
    )


def tuned_speedups() -> str:
    """docs/fidelity.md: the end-state surrogate, shipped and tuned on 0.5 m runs, as the cheap route against the
    0.5 m MPM: speed-ups at 8 / 16 / 32 accurate runs' time and correlations (hifi_surrogate.json)."""
    record = result("hifi_surrogate.json", legacy=True)
    quantities = record["analysis"]["quantities"]
    columns = TUNED_COLUMNS
    labels = {
        "end-state surrogate, shipped (1 m)": "end-state surrogate, shipped (learned from the 1 m MPM)",
        "end-state surrogate, tuned on 0.5 m": f"**the same, tuned on {record['args']['train']} coarse-grained "
        "0.5 m runs**",
    }
    lines = ["| cheap route | " + " | ".join(columns) + " |", "|---" * (len(columns) + 1) + "|"]
    for name, label in labels.items():
        cheap = record["analysis"]["cheap"][name]
        cells = [speedup_cell(cheap, quantities, column) for column in columns]
        lines.append(f"| {label} | " + " | ".join(cells) + " |")
    budgets = " / ".join(str(b["high_runs"]) for b in record["analysis"]["cheap"][next(iter(labels))]["budgets"])
    lines += [
        "",
        f"At {budgets} accurate runs' time, on the {record['n']}-realization pool; `{record['command'].split(' (')[0]}`, "
        f"`benchmarks/results/hifi_surrogate.json` committed in {record['committed_in']}.",
    ]
    return "\n".join(lines)
