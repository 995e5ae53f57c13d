rule pack:
    """Pack a set's trajectories into one HDF5 file with per-frame motion statistics."""
    input:
        set_chunks,
    output:
        "results/dataset/{set}.h5",
    params:
        compression=config["dataset"]["compression"],
        realizations=lambda wildcards: len(set_ids(wildcards.set)),
    log:
        "logs/pack/{set}.log",
    conda:
        "../envs/rgns.yaml"
    script:
        "../workflow/scripts/pack.py"


rule gns_export:
    """Export the packed sets to the geoelements/gns layout (npz + metadata.json)."""
    input:
        train="results/dataset/train.h5",
        valid="results/dataset/valid.h5",
    output:
        train="results/dataset/gns/train.npz",
        valid="results/dataset/gns/valid.npz",
        metadata="results/dataset/gns/metadata.json",
    params:
        radius_m=config["gns"]["connectivity_radius_cells"] * config["mesh"]["cell_size_m"],
    log:
        "logs/gns_export/export.log",
    conda:
        "../envs/rgns.yaml"
    script:
        "../workflow/scripts/gns_export.py"


rule paraview_series:
    """A ParaView time series (VTU frames + .pvd) of one realization's trajectory."""
    input:
        chunk_of,
    output:
        directory("results/paraview/{set}/{index}"),
    params:
        every_nth_frame=config["paraview"]["every_nth_frame"],
    log:
        "logs/paraview_series/{set}/{index}.log",
    conda:
        "../envs/rgns.yaml"
    script:
        "../workflow/scripts/paraview_series.py"
