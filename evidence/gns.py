"""docs/gns-training.md's and docs/surrogates.md's passages on the graph network simulator."""

from __future__ import annotations

import statistics

from evidence.formatting import bracketed, minutes, power
from evidence.sources import RESULTS, card, made_note, result


def gns_training() -> str:
    """docs/surrogates.md: how the shipped GNS was trained and how far its one-step loss fell, from its card."""
    record = card("card.json")
    sets = record["config"]["sets"]
    train, valid = (sum(entry["count"] for entry in sets[name]) for name in ("train", "valid"))
    last, kept = record["last_validation"], record["kept_validation"]
    mean = last["valid_mean_predictor_loss"]
    return (
        f"{train} training and {valid} held-out runs of the embedded MPM, then {record['steps']:,} training steps in "
        f"{minutes(record['wall_s'])} on one thread. Its one-step loss on the held-out windows ends "
        f"{mean / last['valid_one_step_loss']:.1f}× below the mean predictor's (the kept step-"
        f"{record['selected_step']:,} checkpoint: {mean / kept['valid_one_step_loss']:.1f}×; "
        "`rgns/models/card.json`)."
    )


# gns_recipe.py's variants as docs/gns-training.md names them, and those rolled out after the paper's 6-frame
# hand-over (the others after 2 s of MPM); the file predates recording either
RECIPE_LABELS = {
    "recipe": "recipe: smoothed targets, padded frames dropped, noise 5·10⁻⁵ folded into the normalisation, "
    "targets clipped at ±25, lr annealed 1e-3 → 1e-5",
    "no_smoothing": "raw targets (σ = 0)",
    "noise_2e-4": "noise 2·10⁻⁴",
    "with_padding": "padded early-stop frames drawn too",
    "acceleration_features": "acceleration features (below)",
    "old": "the recipe before issue 15 (raw, padding, noise 2·10⁻⁴ not folded, no clip, lr 1e-3 decaying 0.1 per "
    "5,000)",
}
SIX_FRAME_HANDOVER = {"recipe", "acceleration_features", "old"}


def gns_recipe() -> str:
    """docs/gns-training.md: each ingredient of the GNS's training recipe changed alone (gns_recipe.json)."""
    record = result("gns_recipe.json", legacy=True)
    lines = [
        "| variant (the recipe with one change) | loss / mean predictor, smoothed windows | raw windows | "
        "mean abs R error (m) |",
        "|---|---:|---:|---:|",
    ]
    for row in record["variants"]:
        mark = " ᵃ" if row["variant"] in SIX_FRAME_HANDOVER else ""
        lines.append(
            f"| {RECIPE_LABELS.get(row['variant'], row['variant'])} | {row['smoothed_loss_over_mean_predictor']:.3f} | "
            f"{row['raw_loss_over_mean_predictor']:.3f} | {row['valid_runout_error_m']:.2f}{mark} |"
        )
    steps = {row["steps"] for row in record["variants"]}
    lines += [
        "",
        f"{' / '.join(str(s) for s in sorted(steps))} training steps each; ᵃ rolled out after the paper's 6-frame MPM "
        "hand-over, the other rows after 2 s (81 frames). `" + record["command"] + "`, "
        f"`benchmarks/results/gns_recipe.json` {made_note(record)}.",
    ]
    return "\n".join(lines)


def gns_jitter() -> str:
    """docs/gns-training.md: how much of the per-frame acceleration the smoothing removes (gns_jitter.json)."""
    record = result("gns_jitter.json")
    raw, smooth, removed = record["raw_std"], record["smoothed_std"], record["variance_removed"]
    return (
        f"On the {record['runs']} held-out runs the per-frame acceleration has standard deviation "
        f"{raw[0] * 1e3:.2f}·10⁻³ (x) and {raw[1] * 1e3:.2f}·10⁻³ (y) m/frame²; after a Gaussian filter in time of "
        f"σ = {record['smoothing_frames']:g} frames, {smooth[0] * 1e3:.2f}·10⁻³ and {smooth[1] * 1e3:.2f}·10⁻³: the "
        f"filter removes {removed[0]:.0%} (x) and {removed[1]:.0%} (y) of its variance (`{record['command']}`, "
        f"made at {record['commit']})."
    ).replace("%", " %")


def gns_handover() -> str:
    """docs/gns-training.md: R of held-out runs in MPM and in the GNS per hand-over (gns_handover.json)."""
    record = result("gns_handover.json")
    handovers = record["handovers"]
    runs = len(handovers[0]["runs"])
    stands = [all(entry["runs"][k]["mpm_runout_m"] == 0.0 for entry in handovers) for k in range(runs)]
    lines = [
        "| hand-over after | "
        + " | ".join(f"run {k + 1}" + (" (stands)" if stands[k] else "") for k in range(runs))
        + " |",
        "|---" * (runs + 1) + "|",
    ]
    for entry in handovers:
        seconds = (entry["warmup_frames"] - 1) * record["frame_interval_s"]  # frame 0 is the start
        cells = [
            f"{row['mpm_runout_m']:.2f} → {row['gns_runout_m']:.2f}"
            + ("" if row["status"] == "ok" else f" ({row['status']})")
            for row in entry["runs"]
        ]
        lines.append(f"| {entry['warmup_frames']} frames ({seconds:g} s) | " + " | ".join(cells) + " |")
    lines += ["", f"`{record['command']}`, made at {record['commit']}."]
    return "\n".join(lines)


def gns_shipped() -> str:
    """docs/gns-training.md: how the shipped GNS was trained and which checkpoint was kept, from its card."""
    record = card("card.json")
    last, kept = record["last_validation"], record["kept_validation"]
    mean = last["valid_mean_predictor_loss"]
    schedule = record["config"]["gns"]
    return (
        f"{record['steps']:,} steps ({minutes(record['wall_s'])} on one thread, in two runs: killed at step "
        f"{record['evaluation']['resumed_from']:,} and resumed from its checkpoint), learning rate "
        f"{power(schedule['learning_rate'])} annealed towards {power(schedule['learning_rate'] * schedule['decay_rate'])} "
        "over "
        f"{schedule['decay_steps']:,} steps. "
        f"On the held-out windows the one-step loss ends at {last['valid_one_step_loss']:.3f} against the mean "
        f"predictor's {mean:.2f} ({mean / last['valid_one_step_loss']:.1f}× below); the model kept is step "
        f"{record['selected_step']:,} ({kept['valid_one_step_loss']:.3f}, {mean / kept['valid_one_step_loss']:.1f}× "
        f"below), whose {schedule['selection_trajectories']} held-out rollouts had the best R, V, I score (mean |R error| "
        f"{kept['valid_runout_error_m']:.2f} m; the last step's: {last['valid_runout_error_m']:.2f} m) "
        "(`rgns/models/card.json`)."
    )


def runout_cells(entry: dict) -> list[str]:
    """A gns_cpu evaluation's runout R² with its interval, and R's relative bias, as two table cells."""
    return [bracketed([entry["r2"], entry["r2_low"], entry["r2_high"]], 2), f"{entry['relative_bias']:+.0%}"]


def curve_rows(rows: list[dict]) -> list[str]:
    """A gns_cpu learning curve as table rows: per evaluation, the pooled and each test case's runout R² and bias."""
    sets = [name for name in rows[-1]["dev"] if name != "all"]
    lines = [
        "| steps | wall | all 64: R² | " + " | ".join(f"{name}: R² | bias" for name in sets) + " |",
        "|---:|---:|---|" + "---|---:|" * len(sets),
    ]
    for row in rows:
        cells = [cell for name in sets for cell in runout_cells(row["dev"][name]["runout_m"])]
        pooled = row["dev"].get("all", {}).get("runout_m")
        overall = runout_cells(pooled)[0] if pooled else "—"
        lines.append(f"| {row['step']:,} | {minutes(row['wall_s'])} | {overall} | " + " | ".join(cells) + " |")
    return lines


VARIANTS = (  # gns_cpu.json with one change each, or a change and the data
    "gns_cpu_moving.json",
    "gns_cpu_push.json",
    "gns_cpu_radius.json",
    "gns_cpu_data.json",
    "gns_cpu_data_lr.json",
    "gns_cpu_data_ema.json",
    "gns_cpu_data_anneal.json",
    "gns_cpu_data_noise.json",
    "gns_cpu_roll8.json",
    "gns_cpu_roll16.json",
    "gns_cpu_late8.json",
    "gns_cpu_mp10.json",
    "gns_cpu_roll4.json",
    "gns_cpu_roll4_8k.json",
    "gns_cpu_1000.json",
    "gns_cpu_rest.json",
)
RANKED = (
    "gns_cpu_data.json",
    "gns_cpu_mp10.json",
    "gns_cpu_roll4.json",
    "gns_cpu_roll4_8k.json",
    "gns_cpu_1000.json",
    "gns_cpu_rest.json",
)  # variants whose ranking the page shows
UNRECORDED = {  # what a record made before a key existed ran with
    "ema_decay": 0.0,
    "rollout_steps": 0,
    "rollout_from_frame": 0,
    "train_data": {"config": "config/pretrain.yaml", "runs": 168},
    "rest_head": False,
}
CHANGES = {  # a spec key: how the sentence names its value
    "radius_m": lambda v: f"radius {v:g} m",
    "message_passing_steps": lambda v: f"{v} message-passing steps",
    "moving_weight": lambda v: f"each moving particle weighing 1 + {v:g} in the one-step loss",
    "pushforward_steps": lambda v: f"each window's input the model's own rollout over {v} steps (push-forward)",
    "learning_rate": lambda v: f"learning rate {v:g}",
    "ema_decay": lambda v: f"the weights' moving average (decay {v:g} a step) evaluated",
    "decay_steps": lambda v: f"the learning rate annealed a hundredfold over {v:,} steps",
    "noise_std": lambda v: f"input noise {v:g} m",
    "rollout_steps": lambda v: f"the loss over {v} of the model's own steps, gradients through them (rollout loss)",
    "rollout_from_frame": lambda v: f"that loss on windows from frame {v} on, the one-step loss on all beside it",
    "batch_graphs": lambda v: f"{v} window{'s' if v != 1 else ''} a step",
    "train_data": lambda v: f"{v['runs']} training runs (`{v['config']}`)",
    "rest_head": lambda v: "a rest head (a displaced node it calls at rest held in place)" if v else "no rest head",
}


def ranking_rows(rows: list[dict]) -> list[str]:
    """A gns_cpu learning curve's ranking against its calibration, as table rows: per evaluation and test case, the
    correlation of the GNS's runouts with the MPM's and the ratio of their spreads (1 and 1 with no bias: R² 1)."""
    sets = [name for name in rows[-1]["dev"] if name != "all"]
    lines = [
        "| steps | " + " | ".join(f"{name}: r | spread ratio" for name in sets) + " |",
        "|---:|" + "---:|---:|" * len(sets),
    ]
    for row in rows:
        cells = []
        for name in sets:
            runs = row["dev"][name]["runs"]
            mpm, gns = [run[0] for run in runs["mpm"]], [run[0] for run in runs["gns"]]
            cells += [
                f"{statistics.correlation(mpm, gns):.2f}",
                f"{statistics.pstdev(gns) / statistics.pstdev(mpm):.2f}",
            ]
        lines.append(f"| {row['step']:,} | " + " | ".join(cells) + " |")
    return lines


def spec_changes(record: dict, variant: dict) -> str:
    """How a variant's spec differs from the record's, in words (the keys of CHANGES that differ)."""
    spec, changed = (
        UNRECORDED | one["model"] | one["training"] | {key: one[key] for key in ("train_data",) if key in one}
        for one in (record, variant)
    )
    return ", ".join(words(changed[key]) for key, words in CHANGES.items() if changed.get(key) != spec.get(key))


def gns_cpu() -> str:
    """docs/gns-training.md: the lean GNS's learning curve on one CPU thread, rolled out from the first frames
    (gns_cpu.json), each variant's (VARIANTS) after it, and why it runs on the particles, not on 1 m nodes."""
    record = result("gns_cpu.json")
    model, training = record["model"], record["training"]
    lines = [
        f"Latent {model['latent_size']}, {model['message_passing_steps']} message-passing steps, radius "
        f"{model['radius_m']:g} m, history {model['history']}"
        + (", where each particle started (height, depth)" if model["static_features"] else "")
        + f"; {training['batch_graphs']} windows a step, noise {training['noise_std']:g} m, learning rate "
        f"{training['learning_rate']:g} annealed over {training['decay_steps']:,} steps; one thread. Runout R² of "
        "each test case's 16 development runs against the MPM's, rolled out from their first "
        f"{model['history'] + 1} frames (95 % bootstrap interval), and R's relative bias (wall: the training's elapsed "
        "time, evaluations included, and any pause while the machine measured something else):",
        "",
        *curve_rows(record["curve"]),
    ]
    variant_lines = []
    for name in VARIANTS:
        if not (RESULTS / name).exists():
            continue
        variant = result(name)
        variant_lines += [
            "",
            f"The same spec with {spec_changes(record, variant)}, "
            + (f"fine-tuned from `{variant['init']}`" if variant.get("init") else "trained from scratch")
            + f" (`{variant['train_command']}`; "
            f"`benchmarks/results/{name}` {made_note(variant)}):",
            "",
            *curve_rows(variant["curve"]),
        ]
    coarse = record["coarser_nodes_vs_particles"]
    case3 = coarse["sets"]["case3"]["runout_m"]
    lines += [
        "",
        f"`{record['train_command']}`, then `{record['command']}`: `benchmarks/results/gns_cpu.json` "
        f"{made_note(record)}. A node per particle: "
        f"{coarse['spacing_m']:g} m nodes (the mass centre of a cell's points) measure a runout of their own, R² "
        f"{coarse['runout_m']['r2']:.2f} [{coarse['runout_m']['r2_low']:.2f}, {coarse['runout_m']['r2_high']:.2f}] "
        f"against the particles' over the {coarse['runs']} runs, case 3's {-case3['bias']:.1f} m short.",
    ]
    rule = record["decision_rule"]
    rates = rule["pass_rate_by_true_r2"]
    lines += [
        "",
        f"The decision rule: runout R² ≥ {rule['bar']:g} in every test case ({' / '.join(map(str, rule['runs']))} "
        "development runs) at two evaluations in a row (the pooled R² over all cases measures mostly how their "
        'runouts differ: the column "all" passes it where the cases\' own R² are near zero). A model whose true R² '
        f"is 0.9 in every case passes it in {rates['0.9']['twice']:.0%} of development sets, one of 0.85 in "
        f"{rates['0.85']['twice']:.0%}, one of 0.8 in {rates['0.8']['twice']:.1%} ({rule['trials']:,} simulated sets "
        "of unbiased normal errors).",
    ]
    for name in RANKED:
        if not (RESULTS / name).exists():
            continue
        variant_lines += [
            "",
            f"What the runout R² of `{name}` is made of: per test case, the correlation r of the GNS's 16 runouts with "
            "the MPM's (how well it ranks the realizations) and the ratio of their spreads (how far its runouts swing "
            "with the soil against the MPM's); R² is near 1 only where both are near 1 and the bias is small:",
            "",
            *ranking_rows(result(name)["curve"]),
        ]
    return "\n".join(lines + variant_lines)


TIMELINE_S = (2.0, 4.0, 6.0, 8.0, 10.0)  # the times gns_cpu_timeline's table shows


def timeline_mean(runs: list[list[float]], index: int) -> float:
    """The mean over runs of each run's value at record ``index``."""
    return statistics.fmean(run[index] for run in runs)


def gns_timeline() -> str:
    """docs/gns-training.md: one checkpoint's rollouts over time against the MPM's (gns_cpu_timeline.json): the mean
    runout and the fastest node of each test case's development runs at TIMELINE_S."""
    record = result("gns_cpu_timeline.json")
    sets = record["sets"]
    lines = [
        "| case | " + " | ".join(f"{t:g} s: R MPM / GNS (m)" for t in TIMELINE_S) + " | fastest node at "
        f"{TIMELINE_S[3]:g} s, MPM / GNS (m/s) |",
        "|---|" + "---:|" * (len(TIMELINE_S) + 1),
    ]
    for name, run in sets.items():
        step = run["frame_interval_s"]
        at = {round(frame * step, 6): k for k, frame in enumerate(run["frames"])}
        runout = [[timeline_mean(run[who]["runout_m"], at[t]) for who in ("mpm", "gns")] for t in TIMELINE_S]
        cells = [f"{mpm:.1f} / {gns:.1f}" for mpm, gns in runout]
        late = at[TIMELINE_S[3]]
        fastest = [timeline_mean(run[who]["fastest_m_per_frame"], late) / step for who in ("mpm", "gns")]
        lines.append(f"| {name} | " + " | ".join(cells) + f" | {fastest[0]:.2f} / {fastest[1]:.2f} |")
    runs = len(next(iter(sets.values()))["mpm"]["runout_m"])
    lines += [
        "",
        f"Mean over each case's {runs} development runs, rolled out from the first frames without early stop "
        f"(`{record['command']}`; `benchmarks/results/gns_cpu_timeline.json` {made_note(record)}).",
    ]
    return "\n".join(lines)


def evaluations_table(file: str, heading: str, columns: list[str], cells, label) -> str:
    """A gns_cpu ``checkpoints`` record (``file``) as a table: a row per evaluated model (``label(name)``), per
    development set the ``columns`` that ``cells(evaluation of the set)`` fills; the command and record below."""
    record = result(file)
    models = record["models"]
    sets = [name for name in next(iter(models.values())) if name != "all"]
    lines = [
        f"| {heading} | " + " | ".join(" | ".join([f"{name}: {columns[0]}", *columns[1:]]) for name in sets) + " |",
        "|---|" + ("---|" + "---:|" * (len(columns) - 1)) * len(sets),
    ]
    for name, evaluated in models.items():
        row = [cell for case in sets for cell in cells(evaluated[case])]
        lines.append(f"| {label(name)} | " + " | ".join(row) + " |")
    lines += ["", f"`{record['command']}`; `benchmarks/results/{file}` {made_note(record)}."]
    return "\n".join(lines)


def gns_checkpoints() -> str:
    """docs/gns-training.md: checkpoints of one training and their weights' average on the development sets
    (gns_cpu_checkpoints.json): runout R² and relative bias per set."""
    return evaluations_table(
        "gns_cpu_checkpoints.json",
        "checkpoint",
        ["R²", "bias"],
        lambda evaluated: runout_cells(evaluated["runout_m"]),
        lambda name: "their weights' average" if name == "average" else f"`{name.rsplit('/', 1)[-1]}`",
    )


def gns_rest_gate() -> str:
    """docs/gns-training.md: one checkpoint of the rest-head training rolled out with its rest head holding deposits
    and with the head ignored (gns_cpu_rest_gate.json): per set, runout R², R's and the moved volume's relative bias."""
    return evaluations_table(
        "gns_cpu_rest_gate.json",
        "rollout",
        ["R²", "R bias", "V bias"],
        lambda evaluated: [
            *runout_cells(evaluated["runout_m"]),
            f"{evaluated['volume_m2']['relative_bias']:+.0%}",
        ],
        lambda name: (
            f"`{name.split(' ')[0].rsplit('/', 1)[-1]}`, "
            + ("rest head ignored" if name.endswith("without the rest gate") else "rest head holding")
        ),
    )
