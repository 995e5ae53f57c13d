# Helpers shared by the rule files: which realizations exist, and the config slice each rule
# gets through params (so a config change re-runs only the rules that read the changed keys).
import json
from dataclasses import asdict
from pathlib import Path
from types import SimpleNamespace

from rgns.engines.mpm.backend import uses_kernels
from rgns.montecarlo.routes import PAIRED, chunk_labels, chunk_share, monte_carlo_routes
from rgns.scene.fields import FIELD_KEYS
from rgns.scene.geometry import DRAW_KEYS
from rgns.scene.realizations import CaseInputs, accurate_case_inputs, mean_vertices
from rgns.scene.sets import realization_group, realization_ids, test_cases
from rgns.trajectories import frame_count

SETS = list(config["sets"])


wildcard_constraints:
    set="|".join(SETS),
    index=r"[0-9]+",
    chunk=r"[0-9]+",


def gpus(device):
    """GPUs a job asks its cluster scheduler for: one on a cuda device, none on the CPU."""
    return 1 if str(device).startswith("cuda") else 0


def set_ids(set_name):
    """File-name ids of every realization of a set."""
    return realization_ids(config["sets"][set_name])


def preview_ids(set_name, count=6):
    """Up to ``count`` realization ids spread evenly over a set (so every group shows)."""
    ids = set_ids(set_name)
    step = max(1, -(-len(ids) // count))
    return ids[::step][:count]


def set_seed(set_name):
    """The seed a set's MPM realizations are drawn from: validation.seed for the test cases, whose
    runs the gate validates on (never the Monte Carlo's realizations, nor those a model was chosen
    on); the top-level seed for the GNS's training sets."""
    return config["validation"]["seed"] if set_name in TEST_CASES else config["seed"]


def group_of(wildcards):
    """The config group (family + field statistics) of one realization."""
    return realization_group(config["sets"][wildcards.set], int(wildcards.index))[1]


def geometry_params(wildcards):
    """Everything the geometry of one realization depends on, and nothing else."""
    family_name = group_of(wildcards)["family"]
    geometry = config["geometry"]
    return {
        "seed": set_seed(wildcards.set),
        "family_name": family_name,
        "family": geometry["families"][family_name],
        "domain": config["domain"],
        "mesh": config["mesh"],
        "geometry": {key: geometry[key] for key in DRAW_KEYS},
    }


def field_params(wildcards):
    """Everything the friction field of one realization depends on, beyond its scene."""
    group = group_of(wildcards)
    return {
        "seed": set_seed(wildcards.set),
        "group": {key: group[key] for key in FIELD_KEYS},
        "random_field": config["random_field"],
        "domain": config["domain"],
        "cell_size_m": config["mesh"]["cell_size_m"],
    }


CASE_KEYS_EXCLUDED = ("engine", "cbgeo")


def mpm_input_params(wildcards):
    """The soil, boundary and time-stepping settings a case directory is written from."""
    return {key: value for key, value in config["mpm"].items() if key not in CASE_KEYS_EXCLUDED}


def mpm_run_params(wildcards):
    """The engine and all MPM settings (recorded as the trajectory's provenance)."""
    return {"mpm": config["mpm"], "compression": config["dataset"]["compression"]}


def chunk_ids(set_name):
    """Chunk ids of a set ('000', '001', ...): realizations split by mpm.chunk_size."""
    return chunk_labels(len(set_ids(set_name)), config["mpm"]["chunk_size"])


def chunk_members(set_name, chunk):
    """Realization ids of one chunk."""
    return chunk_share(set_ids(set_name), int(chunk), config["mpm"]["chunk_size"])


def kernels_ready(wildcards):
    """The compiled MPM kernels, for a job that may run the embedded engine on them (mpm.embedded.backend)."""
    embedded = config["mpm"]["embedded"]
    kernels = uses_kernels(embedded["backend"], embedded["device"], embedded["dtype"])
    return ["results/mpm/kernels.txt"] if config["mpm"]["engine"] == "embedded" and kernels else []


def chunk_cases(wildcards):
    """The case directories of one chunk."""
    return [f"results/mpm/{wildcards.set}/{i}/case" for i in chunk_members(wildcards.set, wildcards.chunk)]


def set_chunks(wildcards):
    """Every chunk directory of one set."""
    return [f"results/mpm/{wildcards.set}/chunk_{k}" for k in chunk_ids(wildcards.set)]


def chunk_of(wildcards):
    """The chunk directory that holds one realization's trajectory."""
    chunk = int(wildcards.index) // config["mpm"]["chunk_size"]
    return f"results/mpm/{wildcards.set}/chunk_{chunk:03d}"


# Test cases, Monte Carlo and hazard: every set other than train/valid is a test case.
TEST_CASES = test_cases(SETS)
MC_CASES = list(config["montecarlo"]["cases"])
# the multi-fidelity correction's outputs per case, when montecarlo.fidelity.paired > 0
MULTIFIDELITY_FILES = ["multifidelity.json", "multifidelity.png"] if config["montecarlo"]["fidelity"]["paired"] else []
# the learned simulator the validation judges: the Monte Carlo's; none when the Monte Carlo runs MPM (nothing
# learned is trained, validated or shown then)
SURROGATE = config["montecarlo"]["simulator"] if config["montecarlo"]["simulator"] != "mpm" else None
SURROGATE_MODEL = f"results/model/{SURROGATE}.pt"
# what the report shows of it: its learning curve and its training summary
SURROGATE_CURVE = "results/model/endstate_curve.png" if SURROGATE == "endstate" else "results/model/learning_curve.png"
SURROGATE_EVALUATION = "results/model/endstate_evaluation.json" if SURROGATE == "endstate" else "results/model/evaluation.json"
# the sets a run simulates: with a shipped model, or the end-state surrogate, no training set is run; with
# no learned simulator, none
RUN_SETS = ([] if SURROGATE is None else TEST_CASES if SURROGATE == "endstate" or config["gns"]["model"] == "shipped"
            else SETS)


wildcard_constraints:
    case="|".join(TEST_CASES) or "no-test-case",


def mc_run_params(wildcards):
    """The simulator settings of the Monte Carlo runs (MPM settings too: GNS rollouts start from MPM frames)."""
    section = config["montecarlo"]
    return {
        "montecarlo": {key: section[key] for key in ("simulator", "batch_size", "duration_s", "device", "keep_frames",
                                                     "rollout", "screen")},
        "mpm": config["mpm"],
        "metrics": config["metrics"],
    }


def paired_plan_cheap(wildcards):
    """The cheap runs the pairs are stratified on: none for a simple random subsample (no strata)."""
    return [CHEAP_TABLE.format(case=wildcards.case)] if config["montecarlo"]["fidelity"]["strata"] else []


def paired_plan_params(wildcards):
    """What choosing the pairs depends on: how many, the strata, their floor, the seed, the realizations."""
    fidelity = config["montecarlo"]["fidelity"]
    return {key: fidelity[key] for key in ("paired", "strata", "min_per_stratum")} | {
        "seed": config["seed"],
        "realizations": config["montecarlo"]["realizations"],
    }


# the ways a case's realizations run (rgns/montecarlo/routes.py): the Monte Carlo and its mean field by
# montecarlo.simulator, the pairs by the MPM, the control variate by the tuned end-state surrogate
ROUTES = monte_carlo_routes(config)
EXTRAPOLATE = "paired_coarse" in ROUTES
CONTROL = "control" in ROUTES


def route_chunks(case, name):
    """Every chunk table of one route of a case."""
    return [f"results/mc/{case}/{name}/chunk_{k}.csv" for k in ROUTES[name].chunk_ids(config)]


def route_chunk_files(wildcards):
    """Every chunk table of the route a collecting job stands for."""
    return route_chunks(wildcards.case, wildcards.route)


def route_model(wildcards):
    """The trained model the route's simulator loads (none for the MPM)."""
    model = ROUTES[wildcards.route].model
    return [model] if model else []


def route_gate(wildcards):
    """The validation gate's verdicts, when the route is the learned simulator's and
    validation.acceptance.on_failure is stop (a case it fails stops); otherwise the gate decides nothing."""
    return report_gate(wildcards) if ROUTES[wildcards.route].gated else []


def route_plan(wildcards):
    """Rule paired_plan's choice, for the routes that run the pairs."""
    return [f"results/mc/{wildcards.case}/paired_plan.json"] if ROUTES[wildcards.route].realizations == PAIRED else []


def route_case_params(wildcards):
    """What drawing one of the route's realizations of a case depends on: group, family, domain, mesh, field."""
    return asdict(ROUTES[wildcards.route].case_inputs(config, wildcards.case))


def route_run_params(wildcards):
    """The Monte Carlo settings with the route's simulator."""
    params = mc_run_params(wildcards)
    params["montecarlo"]["simulator"] = ROUTES[wildcards.route].simulator
    return params


def route_listing(wildcards):
    """Which realizations the route runs, in chunk order (None: rule paired_plan's list), and its chunk size."""
    route = ROUTES[wildcards.route]
    return {"listed": route.listed(config), "chunk_size": route.chunk_size}


def route_gpu(wildcards):
    """A GPU for a learned simulator's route when montecarlo.device asks for one."""
    return gpus(config["montecarlo"]["device"]) if ROUTES[wildcards.route].model else 0


def route_mem_mb(wildcards):
    """Memory of one chunk job: more at a mesh finer than the Monte Carlo's."""
    return 4000 if ROUTES[wildcards.route].cell_size_m < config["mesh"]["cell_size_m"] else 2000


def mc_coarse_table(wildcards):
    """The pairs at the Monte Carlo's mesh, when the estimate is carried to the converged mesh."""
    return [f"results/mc/{wildcards.case}/paired_coarse.csv"] if EXTRAPOLATE else []


# the correction's cheap model: the Monte Carlo's own runs, or the tuned end-state surrogate's (route control)
CHEAP_TABLE = "results/mc/{case}/control.csv" if CONTROL else "results/mc/{case}/realizations.csv"
CHEAP_ROUTE = ("the end-state surrogate tuned to the accurate MPM" if CONTROL
               else f"the Monte Carlo's simulator ({config['montecarlo']['simulator']})")


def multifidelity_params(wildcards):
    """What the correction needs: the zoning profile and thresholds, the exceedance probabilities, the
    chunks' benchmark files (the cost of each route)."""
    hazard = config["hazard"]
    case = wildcards.case
    return zoning_params(wildcards) | config["montecarlo"]["fidelity"] | {
        "exceedance_probabilities": hazard["exceedance_probabilities"],
        "low_benchmarks": [path.replace(".csv", ".benchmark.tsv")
                           for path in route_chunks(case, "control" if CONTROL else "realizations")],
        "cheap_route": CHEAP_ROUTE,
        "coarse_cell_size_m": config["mesh"]["cell_size_m"],
        "high_benchmark_pattern": f"results/mc/{case}/paired/chunk_{{chunk:03d}}.benchmark.tsv",
        "chunk_size": config["montecarlo"]["fidelity"]["chunk_size"],
    }


def report_gate(wildcards):
    """The validation gate's verdicts for the report's top, whenever a learned simulator ran the Monte Carlo
    (whether or not the gate decides anything)."""
    return ["results/report/validation/gate.json"] if SURROGATE else []


def case_scenes(wildcards):
    """The scene files of every realization of a test case."""
    return [f"results/geometry/{wildcards.case}/{i}.json" for i in set_ids(wildcards.case)]


def zoning_params(wildcards):
    """The zoning thresholds and the cross-section the map is drawn on (the case's mean geometry)."""
    family = config["geometry"]["families"][config["sets"][wildcards.case][0]["family"]]
    hazard = config["hazard"]
    return {
        "thresholds": hazard["zoning_thresholds"],
        "resolution_m": hazard["zoning_resolution_m"],
        "confidence": hazard["confidence"],
        "vertices": mean_vertices(family).tolist(),
        "domain": config["domain"],
    }


def exceedance_params(wildcards):
    """Confidence, exceedance probabilities and the convergence criterion."""
    return {key: config["hazard"][key] for key in ("confidence", "exceedance_probabilities",
                                                    "convergence_tolerance", "convergence_window")}


def report_foundations(wildcards):
    """The tables and run folders the report rests on, asked for by hazard_map itself: Snakemake
    rebuilds a missing intermediate only when a target asks for it, so without this a deleted
    realizations.csv (or MPM chunk, validation table) stayed missing beside an up-to-date report."""
    files = []
    for case in RUN_SETS:
        files += set_chunks(SimpleNamespace(set=case))
    for case in TEST_CASES if SURROGATE else []:
        files += [f"results/validation/{case}/pairs.csv", f"results/validation/{case}/energies.npz"]
    for case in MC_CASES:
        for name in ROUTES:
            files += route_chunks(case, name) + [f"results/mc/{case}/{name}.csv"]
    return files
