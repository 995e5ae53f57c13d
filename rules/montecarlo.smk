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
