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


rule mpm_run:
    """Run one case through the configured engine (mpm.engine) into a trajectory file."""
    input:
        case="results/mpm/{set}/{index}/case",
    output:
        "results/mpm/{set}/{index}/trajectory.h5",
    params:
        settings=mpm_run_params,
        scratch="results/mpm/{set}/{index}/scratch",
    log:
        script="logs/mpm_run/{set}/{index}.log",
        engine="logs/mpm_run/{set}/{index}.engine.log",
    threads: lambda wildcards: config["mpm"]["cbgeo"]["threads"] if config["mpm"]["engine"] == "cbgeo" else 1
    conda:
        "../envs/rgns.yaml"
    script:
        "../workflow/scripts/mpm_run.py"
