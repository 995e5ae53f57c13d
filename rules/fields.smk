rule random_field:
    """Draw one realization's friction-angle field and map it onto its material points."""
    input:
        scene="results/geometry/{set}/{index}.json",
    output:
        "results/fields/{set}/{index}.npz",
    params:
        field_params,
    log:
        "logs/random_field/{set}/{index}.log",
    conda:
        "../envs/rgns.yaml"
    script:
        "../workflow/scripts/random_field.py"


rule scene_preview:
    """A picture of realizations spread over a set: polygons, particles coloured by friction."""
    input:
        scenes=lambda wc: expand("results/geometry/{{set}}/{i}.json", i=preview_ids(wc.set)),
        fields=lambda wc: expand("results/fields/{{set}}/{i}.npz", i=preview_ids(wc.set)),
    output:
        report("results/plots/{set}/scenes.png", caption="../rgns/report/captions/scenes.rst", category="Scenes"),
    log:
        "logs/scene_preview/{set}.log",
    conda:
        "../envs/rgns.yaml"
    script:
        "../workflow/scripts/scene_preview.py"

