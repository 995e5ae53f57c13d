rule geometry:
    """Draw one realization's perturbed slope polygon and seed its material points."""
    output:
        "results/geometry/{set}/{index}.json",
    params:
        geometry_params,
    log:
        "logs/geometry/{set}/{index}.log",
    conda:
        "../envs/rgns.yaml"
    script:
        "../workflow/scripts/geometry.py"
