rule mc_chunk:
    """One chunk of one route of a case's realizations (rgns/montecarlo/routes.py): drawn, simulated and
    measured. The routes: realizations (every Monte Carlo realization, by montecarlo.simulator) and
    mean_field (the deterministic mean-field one); with montecarlo.fidelity.paired, paired (the realizations
    paired_plan chose, by the MPM at the accurate mesh) and with mesh_order paired_coarse (the same, at the
    Monte Carlo's mesh); with cheap tuned, control (every realization by the tuned end-state surrogate, no
    gate: a poor control widens the intervals, it cannot bias them)."""
    input:
        model=route_model,
        gate=route_gate,
        plan=route_plan,
        kernels=kernels_ready,
    output:
        "results/mc/{case}/{route}/chunk_{chunk}.csv",
    params:
        inputs=route_case_params,
        run=route_run_params,
        listing=route_listing,
    wildcard_constraints:
        route="|".join(ROUTES),
    log:
        "logs/mc_chunk/{case}/{route}/chunk_{chunk}.log",
    benchmark:
        "results/mc/{case}/{route}/chunk_{chunk}.benchmark.tsv"
    threads: config["montecarlo"]["threads"]
    resources:
        mem_mb=route_mem_mb,
        gpu=route_gpu,
    conda:
        "../envs/rgns.yaml"
    script:
        "../workflow/scripts/mc_chunk.py"


rule mc_collect:
    """One route's chunk tables of a case as one table in the route's order, each chunk checked to hold
    exactly its share (rgns.montecarlo.runs.collect_listed)."""
    input:
        chunks=route_chunk_files,
        plan=route_plan,
    output:
        "results/mc/{case}/{route}.csv",
    params:
        listing=route_listing,
    wildcard_constraints:
        route="|".join(ROUTES),
    log:
        "logs/mc_collect/{case}/{route}.log",
    conda:
        "../envs/rgns.yaml"
    script:
        "../workflow/scripts/mc_collect.py"


rule paired_plan:
    """Which realizations the MPM re-runs: strata of the cheap route's runout, pairs allocated over them (more
    in the tail) and drawn at random within each (rgns.fidelity.pair_design). Without strata (the default) a
    simple random subsample of the realization indices, which needs no cheap answer: a cheap chunk run again
    (a deleted file, a retrained model) then re-runs no MPM pair."""
    input:
        realizations=paired_plan_cheap,
    output:
        "results/mc/{case}/paired_plan.json",
    params:
        settings=paired_plan_params,
    log:
        "logs/paired_plan/{case}.log",
    conda:
        "../envs/rgns.yaml"
    script:
        "../workflow/scripts/paired_plan.py"


rule multifidelity:
    """A case's exceedance curves, zoning and means corrected towards the accurate MPM (control variates),
    and with montecarlo.fidelity.mesh_order carried to the converged mesh (rgns/fidelity/mesh_extrapolation.py)."""
    input:
        realizations=CHEAP_TABLE,
        simulator="results/mc/{case}/realizations.csv",
        paired="results/mc/{case}/paired.csv",
        coarse=mc_coarse_table,
        plan="results/mc/{case}/paired_plan.json",
    output:
        json="results/report/{case}/multifidelity.json",
        figure=report("results/report/{case}/multifidelity.png", caption="../rgns/report/captions/multifidelity.rst",
                      category="Hazard"),
    params:
        multifidelity_params,
    log:
        "logs/multifidelity/{case}.log",
    conda:
        "../envs/rgns.yaml"
    script:
        "../workflow/scripts/multifidelity.py"
