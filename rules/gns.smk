rule train:
    """Train the GNS on the packed train set (resumes from results/model/checkpoints after a kill)."""
    input:
        train="results/dataset/train.h5",
        valid="results/dataset/valid.h5",
    output:
        model="results/model/gns.pt",
        history="results/model/history.csv",
        curve=report("results/model/learning_curve.png", caption="../docs/captions/learning_curve.rst", category="GNS"),
        evaluation="results/model/evaluation.json",
    params:
        gns=lambda wildcards: config["gns"],
        cell_size_m=config["mesh"]["cell_size_m"],
    log:
        "logs/train/train.log",
    threads: config["gns"]["threads"]
    resources:
        mem_mb=4000,
        gpu=gpus(config["gns"]["device"]),
    conda:
        "../envs/rgns.yaml"
    script:
        "../workflow/scripts/train.py"
