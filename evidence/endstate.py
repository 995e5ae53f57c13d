"""The end-state surrogates' passages: their training, their agreement with the MPM, and the cheap route's choice."""

from __future__ import annotations

from typing import Any

from evidence.formatting import bracketed, minutes, r2_interval, signed_percent, true_minus
from evidence.sources import card, made_note, result


def general_training() -> str:
    """docs/surrogates.md: what the geometry-general end-state model learned from and how long it trained, from its
    card."""
    record = card("endstate_general_card.json")
    sets = len(record["cases"])
    evaluation = record["evaluation"]
    start = record.get("started_from")
    where = "on the GPU" if record["config"]["endstate"].get("device", "cpu") != "cpu" else "on one CPU thread"
    runs = (
        f"{sets * record['realizations_per_case']:,} MPM runs (plus {sets * record['held_out_per_case']:,} held out; "
        f"{record['realizations_per_case']} + {record['held_out_per_case']} per set of {sets}), "
        f"{record['steps']:,} steps in {minutes(record['wall_s'])} {where}"
    )
    how = (
        f"It was trained on {runs}"
        if start is None
        else f"A first model was trained {start['steps']:,} steps in {minutes(start['wall_s'])} ({start['hardware']}) "
        f"on {start['sets']} sets, then fine-tuned on {runs}"
    )
    return (
        f"{how}; its held-out loss ends at {evaluation['valid_loss']:.4f} against the mean predictor's "
        f"{evaluation['valid_mean_predictor_loss']:.3f} (`rgns/models/endstate_general_card.json`)."
    )


def untouched_subset(record: dict[str, Any]) -> tuple[str, dict[str, Any]]:
    """cheap_route.json's subset of realizations no choice touched: its range ("64-127") and its rows per model."""
    name = next(name for name in record["subsets"] if name.startswith("untouched"))
    return name.split("(")[1].rstrip(")"), record["subsets"][name]


def cheap_route_choice() -> str:
    """README: which surrogate is the correction's cheap route, by its correlation with the 0.5 m MPM on
    realizations no choice touched."""
    record = result("cheap_route.json")
    realizations, models = untouched_subset(record)
    best, second = record["best"]["model"], record["best"]["second"]
    r_best, r_general = models[best]["runout_m"]["r_0.5"], models["endstate_general"]["runout_m"]["r_0.5"]
    return (
        f"The correction's cheap route, {best}, against the 0.5 m MPM: runout r {bracketed(r_best)} against the "
        f"general model's {bracketed(r_general)} on realizations {realizations} of seed {record['seed']}, which no "
        f"choice touched; the best by a paired bootstrap of the difference from the next, {second} "
        f"({bracketed(record['best']['r_difference'], sign='+')}): `{record['command']}` at {record['commit']}, "
        "`benchmarks/results/cheap_route.md`."
    )


def tuned_untouched() -> str:
    """The tuned model's card: its agreement with the 0.5 m MPM itself on realizations no choice touched."""
    record = result("cheap_route.json")
    realizations, models = untouched_subset(record)
    rows = models["endstate_tuned"]
    first, last = realizations.split("-")
    lines = [
        f"Case 1, realizations {first}–{last} of seed {record['seed']} (the default Monte Carlo's), which no training "
        "or choice of this model touched (0–63 were the pool it was judged on), against the MPM at 0.5 m cells "
        "measured on the MPM's own points, as every report's pairs are (made on a GPU: "
        "`benchmarks/results/mesh_levels_gpu_runs.jsonl`), with 95 % bootstrap intervals over the "
        f"{int(last) - int(first) + 1} realizations; `{record['command']}` at {record['commit']}. In distribution: "
        "the family and field the model was tuned on, fresh realizations. The correction removes any bias; the "
        "correlation sets its gain.",
        "",
        "| metric | r with the 0.5 m MPM | R² | bias (model − MPM) |",
        "| --- | --- | --- | --- |",
    ]
    for metric in ("runout_m", "volume_m2", "influence_m"):
        row = rows[metric]
        cells = [bracketed(row[key], digits) for key, digits in (("r_0.5", 3), ("R2_0.5", 3), ("bias_0.5", 2))]
        lines.append(f"| {metric.split('_')[0]} | " + " | ".join(cells) + " |")
    return "\n".join(lines)


# the README's names of the out-of-distribution sets, in its order
OOD_SETS = {
    "ood_bench": "benched slope",
    "ood_concave": "concave slope",
    "hillside": "DEM section (`config/site.yaml`)",
    "ood_field": "a field model outside the training draws",
}


def standing(runout: dict[str, Any]) -> int:
    """How many of an ood_surrogate.json set's realizations the MPM left standing (its runout row)."""
    return runout["stood_both"] + runout["failed_model_only"]


def stood(runout: dict[str, Any]) -> str:
    """' (54 of 64 stand)' for a set the MPM mostly left standing, else ''."""
    return f" ({standing(runout)} of {runout['n']} stand)" if standing(runout) > runout["n"] / 2 else ""


def ood_table() -> str:
    """README: the geometry-general surrogate's R² on sets it never trained on, and on the test cases."""
    record = result("ood_surrogate.json", legacy=True)
    rows = {(row["set"], row["metric"]): row for row in record["model"]}
    metrics = ("runout", "volume", "influence")
    cases = [name for name in ("case1", "case2", "case3", "case4") if (name, "runout") in rows]
    return "\n".join(
        [
            "| set (its realizations never trained on) | runout R | volume V | influence I |",
            "|---|---|---|---|",
            *(
                f"| {label}{stood(rows[name, 'runout'])} | "
                + " | ".join(r2_interval(rows[name, m]) for m in metrics)
                + " |"
                for name, label in OOD_SETS.items()
                if (name, "runout") in rows
            ),
            "| test cases "
            + " / ".join(c.removeprefix("case") for c in cases)
            + " (their families, `long_slope` and `column`, are in the training, `config/pretrain_general.yaml`; "
            "the rows above are not) | "
            + " | ".join(" / ".join(f"{rows[c, m]['r2']:.3f}" for c in cases) for m in metrics)
            + " |",
            "",
            f"Seed {record['data_seed']}; `{record['command']}` ({made_note(record)}).",
            "",
            ood_bias_and_cost(record, rows),
        ]
    )


# docs/surrogates.md's notes on the out-of-distribution sets' names
OOD_NOTES = {"hillside": " (DEM section)", "ood_field": " (field outside training)"}


def ood_bias_table() -> str:
    """docs/surrogates.md: the geometry-general surrogate's R² and relative bias of R, V and I per set it never
    trained on and per test case (ood_surrogate.json)."""
    record = result("ood_surrogate.json", legacy=True)
    rows = {(row["set"], row["metric"]): row for row in record["model"]}
    sets = list(dict.fromkeys(row["set"] for row in record["model"]))
    lines = ["| set | runout R | volume V | influence I |", "|---|---|---|---|"]
    for name in sets:
        runout = rows[name, "runout"]
        cells = []
        for metric in ("runout", "volume", "influence"):
            row = rows[name, metric]
            cell = f"{r2_interval(row)}, {signed_percent(row['relative_bias'])}"
            if metric == "runout" and stood(runout):
                cell += true_minus(f" ({row['bias']:+.2f} m)")
            cells.append(cell)
        lines.append(f"| {name}{OOD_NOTES.get(name, '')}{stood(runout)} | " + " | ".join(cells) + " |")
    lines += ["", f"Seed {record['data_seed']}; `{record['command']}` ({made_note(record)})."]
    return "\n".join(lines)


def endstate_speed() -> str:
    """docs/surrogates.md: the geometry-general end-state model's cost per realization beside the 1 m MPM's, timed
    side by side on the same realizations (ood_surrogate.json's cost)."""
    record = result("ood_surrogate.json", legacy=True)
    cost = record["cost"]
    return (
        f"{1000 * cost['model_s']:.1f} ms per realization against {cost['mpm_s']:.2f} s for the 1 m MPM "
        f"({cost['ratio']:.0f}× faster; {cost['realizations']} {cost['case'].replace('case', 'case-')} realizations, "
        f"one thread each, side by side; `{record['command']}`, committed in {record['committed_in']})."
    )


def ood_targets() -> str:
    """docs/surrogates.md: the geometry-general surrogate against its targets (R² ≥ 0.9 for R, V and I and |relative
    bias of R| ≤ 5 % on every unseen set; R² ≥ 0.95 for R and V on the test cases), beside the model it replaced
    (ood_surrogate.json's "compare" rows, the same realizations)."""
    record = result("ood_surrogate.json", legacy=True)
    new, old = ({(row["set"], row["metric"]): row for row in record[key]} for key in ("model", "compare"))
    sets = list(dict.fromkeys(row["set"] for row in record["model"]))
    cases = [name for name in sets if name.startswith("case")]
    unseen = [name for name in sets if name not in cases]

    def span(rows: dict[tuple[str, str], dict[str, Any]], metrics: tuple[str, ...]) -> str:
        values = [rows[name, metric]["r2"] for name in cases for metric in metrics]
        return f"{min(values):.3f}–{max(values):.3f}"

    missed = []
    for name in unseen:
        for metric in ("runout", "volume", "influence"):
            row = new[name, metric]
            if row["r2"] < 0.9:
                missed.append(
                    f"{name}'s {metric} (R² {row['r2']:.3f}; the replaced model {old[name, metric]['r2']:.3f})"
                )
        if abs(new[name, "runout"]["relative_bias"]) > 0.05 and not stood(new[name, "runout"]):
            missed.append(f"{name}'s runout bias ({signed_percent(new[name, 'runout']['relative_bias'])})")
    met = [name for name in unseen if not any(text.startswith(f"{name}'s") for text in missed)]
    cases_met = all(new[name, metric]["r2"] >= 0.95 for name in cases for metric in ("runout", "volume"))
    return (
        f"Against the targets (R² ≥ 0.9 for R, V and I and |relative bias of R| ≤ 5 % on every unseen set; R² ≥ 0.95 "
        f"for R and V on the test cases): the test cases {'meet' if cases_met else 'miss'} theirs (R and V R² "
        f"{span(new, ('runout', 'volume'))}, where the replaced model had {span(old, ('runout', 'volume'))}); "
        + (f"{', '.join(met)} {'meets' if len(met) == 1 else 'meet'} every one. " if met else "")
        + ("Not met: " + "; ".join(missed) + "." if missed else "Every target is met.")
        + f" (`benchmarks/results/ood_surrogate.json`, {made_note(record)}.)"
    )


def ood_bias_and_cost(record: dict[str, Any], rows: dict[tuple[str, str], dict[str, Any]]) -> str:
    """The runout's bias on each unseen set (relative, or in metres on a set the MPM mostly left standing), and the
    model's cost per realization against the 1 m MPM's."""

    def bias(name: str) -> str:
        row = rows[name, "runout"]
        if stood(row):
            return true_minus(f"{row['bias']:+.2f} m of a {row['mpm_mean']:.2f} m mean")
        return signed_percent(row["relative_bias"])

    cost = record["cost"]
    return (
        "Runout's bias on the sets above, model − MPM: "
        + "; ".join(f"{label} {bias(name)}" for name, label in OOD_SETS.items() if (name, "runout") in rows)
        + f". Per realization the model costs {1000 * cost['model_s']:.1f} ms against the 1 m MPM's "
        f"{cost['mpm_s']:.2f} s ({cost['ratio']:.0f}×, one thread each, {cost['realizations']} realizations of "
        f"{cost['case'].replace('case', 'case ')})."
    )


def ood_floor() -> str:
    """docs/surrogates.md: R² of I and V, the geometry-general surrogate against the 1 m MPM beside the same MPM at a
    smaller time step against it (what an exact surrogate of either run would score), per set, on the development
    seed (ood_surrogate_floor_dev.json)."""
    record = result("ood_surrogate_floor_dev.json")
    cfl = float(record["command"].split("--mpm-floor ")[1].split()[0])
    model, floor = ({(row["set"], row["metric"]): row for row in record[key]} for key in ("model", "mpm_floor"))
    sets = list(dict.fromkeys(row["set"] for row in record["model"]))
    lines = [
        f"| set | I: model | I: MPM at CFL {cfl:g} | V: model | V: MPM at CFL {cfl:g} |",
        "|---|---|---|---|---|",
    ]
    for name in sets:
        cells = [
            f"{r2_interval(rows[name, metric])}, {signed_percent(rows[name, metric]['relative_bias'])}"
            for metric in ("influence", "volume")
            for rows in (model, floor)
        ]
        lines.append(f"| {name} | " + " | ".join(cells) + " |")
    lines += ["", f"Seed {record['data_seed']}; `{record['command']}` ({made_note(record)})."]
    return "\n".join(lines)
