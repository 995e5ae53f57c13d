rule mpm_input:
    """Write one realization's CB-Geo case directory (both engines read it)."""
    input:
        scene="results/geometry/{set}/{index}.json",
        field="results/fields/{set}/{index}.npz",
    output:
        directory("results/mpm/{set}/{index}/case"),
    params:
        mpm_input_params,
    log:
        "logs/mpm_input/{set}/{index}.log",
    conda:
        "../envs/rgns.yaml"
    script:
        "../workflow/scripts/mpm_input.py"


rule mpm_kernels:
    """Compile the embedded engine's CPU kernels once (numba's cache), before the MPM jobs load them."""
    output:
        "results/mpm/kernels.txt",
    log:
        "logs/mpm_kernels.log",
    conda:
        "../envs/rgns.yaml"
    script:
        "../workflow/scripts/mpm_kernels.py"


rule mpm_run:
    """Run a chunk of cases through the configured engine (mpm.engine) into trajectory files."""
    input:
        cases=chunk_cases,
        kernels=kernels_ready,
    output:
        directory("results/mpm/{set}/chunk_{chunk}"),
    params:
        settings=mpm_run_params,
        scratch="results/mpm/{set}/scratch_{chunk}",
        engine_logs="logs/mpm_run/{set}/chunk_{chunk}",
    log:
        "logs/mpm_run/{set}/chunk_{chunk}.log",
    threads: lambda wildcards: config["mpm"]["cbgeo"]["threads"] if config["mpm"]["engine"] == "cbgeo" else config["mpm"]["embedded"]["threads"]
    resources:
        mem_mb=lambda wildcards: 500 + 100 * config["mpm"]["chunk_size"],
    conda:
        "../envs/rgns.yaml"
    script:
        "../workflow/scripts/mpm_run.py"
