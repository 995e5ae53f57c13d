rule mc_chunk:
    """Draw, simulate (montecarlo.simulator) and measure one chunk of a case's Monte Carlo realizations."""
    input:
        model=mc_model,
        gate=mc_gate,
    output:
        "results/mc/{case}/chunk_{chunk}.csv",
    params:
        inputs=mc_case_params,
        run=mc_run_params,
        indices=mc_chunk_indices,
    log:
        "logs/mc_chunk/{case}/chunk_{chunk}.log",
    benchmark:
        "results/mc/{case}/chunk_{chunk}.benchmark.tsv"
    threads: config["montecarlo"]["threads"]
    resources:
        mem_mb=2000,
        gpu=gpus(config["montecarlo"]["device"]),
    conda:
        "../envs/rgns.yaml"
    script:
        "../workflow/scripts/mc_chunk.py"


rule mc_mean_field:
    """The deterministic mean-field realization of a case (mean geometry, uniform mean friction)."""
    input:
        model=mc_model,
        gate=mc_gate,
    output:
        "results/mc/{case}/mean_field.csv",
    params:
        inputs=mc_case_params,
        run=mc_run_params,
        indices=[-1],
    log:
        "logs/mc_mean_field/{case}.log",
    threads: config["montecarlo"]["threads"]
    resources:
        mem_mb=2000,
        gpu=gpus(config["montecarlo"]["device"]),
    conda:
        "../envs/rgns.yaml"
    script:
        "../workflow/scripts/mc_chunk.py"


rule mc_collect:
    """Concatenate a case's chunk tables into one table of every realization."""
    input:
        mc_chunks,
    output:
        "results/mc/{case}/realizations.csv",
    params:
        realizations=config["montecarlo"]["realizations"],
        chunk_size=config["montecarlo"]["chunk_size"],
    log:
        "logs/mc_collect/{case}.log",
    conda:
        "../envs/rgns.yaml"
    script:
        "../workflow/scripts/mc_collect.py"


rule mc_paired_chunk:
    """The chunk's realizations of those paired_plan chose, by the MPM at the accurate mesh (the same geometry
    and field): the high-fidelity half of the multi-fidelity pairs."""
    input:
        model=[],
        gate=[],
        plan="results/mc/{case}/paired_plan.json",
    output:
        "results/mc/{case}/paired/chunk_{chunk}.csv",
    params:
        inputs=mc_paired_case_params,
        run=mc_paired_run_params,
        indices=mc_paired_chunk_indices,
    log:
        "logs/mc_paired_chunk/{case}/chunk_{chunk}.log",
    benchmark:
        "results/mc/{case}/paired/chunk_{chunk}.benchmark.tsv"
    threads: config["montecarlo"]["threads"]
    resources:
        mem_mb=4000,
    conda:
        "../envs/rgns.yaml"
    script:
        "../workflow/scripts/mc_chunk.py"


rule mc_coarse_chunk:
    """With montecarlo.fidelity.mesh_order: the paired chunk's realizations once more, by the MPM at the
    Monte Carlo's own mesh (mesh.cell_size_m): the coarser of the two meshes whose paired difference, at
    the measured order, extrapolates the accurate MPM to the converged mesh."""
    input:
        model=[],
        gate=[],
        plan="results/mc/{case}/paired_plan.json",
    output:
        "results/mc/{case}/paired_coarse/chunk_{chunk}.csv",
    params:
        inputs=mc_coarse_case_params,
        run=mc_paired_run_params,
        indices=mc_paired_chunk_indices,
    log:
        "logs/mc_coarse_chunk/{case}/chunk_{chunk}.log",
    benchmark:
        "results/mc/{case}/paired_coarse/chunk_{chunk}.benchmark.tsv"
    threads: config["montecarlo"]["threads"]
    resources:
        mem_mb=2000,
    conda:
        "../envs/rgns.yaml"
    script:
        "../workflow/scripts/mc_chunk.py"


rule mc_control_chunk:
    """With montecarlo.fidelity.cheap tuned: the chunk's realizations by the end-state surrogate tuned to the
    accurate MPM, the control variate of the correction (no gate: a poor control widens the intervals, it
    cannot bias them)."""
    input:
        model=["results/model/endstate_tuned.pt"],
        gate=[],
    output:
        "results/mc/{case}/control/chunk_{chunk}.csv",
    params:
        inputs=mc_case_params,
        run=mc_control_run_params,
        indices=mc_chunk_indices,
    log:
        "logs/mc_control_chunk/{case}/chunk_{chunk}.log",
    benchmark:
        "results/mc/{case}/control/chunk_{chunk}.benchmark.tsv"
    threads: config["montecarlo"]["threads"]
    resources:
        mem_mb=2000,
    conda:
        "../envs/rgns.yaml"
    script:
        "../workflow/scripts/mc_chunk.py"


rule mc_control_collect:
    """Concatenate a case's control chunk tables."""
    input:
        lambda wildcards: [f"results/mc/{wildcards.case}/control/chunk_{k}.csv" for k in mc_chunk_ids(wildcards.case)],
    output:
        "results/mc/{case}/control.csv",
    params:
        realizations=config["montecarlo"]["realizations"],
        chunk_size=config["montecarlo"]["chunk_size"],
    log:
        "logs/mc_control_collect/{case}.log",
    conda:
        "../envs/rgns.yaml"
    script:
        "../workflow/scripts/mc_collect.py"


rule mc_coarse_collect:
    """Concatenate a case's coarse paired chunk tables (the same chunks as mc_paired_collect's)."""
    input:
        chunks=mc_coarse_chunks,
        plan="results/mc/{case}/paired_plan.json",
    output:
        "results/mc/{case}/paired_coarse.csv",
    log:
        "logs/mc_coarse_collect/{case}.log",
    conda:
        "../envs/rgns.yaml"
    script:
        "../workflow/scripts/mc_paired_collect.py"


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


rule mc_paired_collect:
    """Concatenate a case's paired chunk tables, checked against the plan."""
    input:
        chunks=mc_paired_chunks,
        plan="results/mc/{case}/paired_plan.json",
    output:
        "results/mc/{case}/paired.csv",
    log:
        "logs/mc_paired_collect/{case}.log",
    conda:
        "../envs/rgns.yaml"
    script:
        "../workflow/scripts/mc_paired_collect.py"


rule multifidelity:
    """A case's exceedance curves, zoning and means corrected towards the accurate MPM (control variates),
    and with montecarlo.fidelity.mesh_order carried to the converged mesh (rgns/fidelity/mesh_extrapolation.py)."""
    input:
        realizations=CHEAP_TABLE,
        simulator="results/mc/{case}/realizations.csv",
        paired="results/mc/{case}/paired.csv",
        coarse=mc_coarse_table,
        plan=mc_paired_plan,
    output:
        json="results/report/{case}/multifidelity.json",
        figure=report("results/report/{case}/multifidelity.png", caption="../docs/captions/multifidelity.rst",
                      category="Hazard"),
    params:
        multifidelity_params,
    log:
        "logs/multifidelity/{case}.log",
    conda:
        "../envs/rgns.yaml"
    script:
        "../workflow/scripts/multifidelity.py"
