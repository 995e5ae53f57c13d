SHIPPED_MODEL = os.path.join(workflow.basedir, "rgns/models")

if config["gns"]["model"] == "shipped":

    rule shipped_model:
        """Take the pretrained GNS shipped with the package (its card: rgns/models/card.md)."""
        input:
            model=os.path.join(SHIPPED_MODEL, "gns.pt"),
            card=os.path.join(SHIPPED_MODEL, "card.json"),
            curve=os.path.join(SHIPPED_MODEL, "learning_curve.png"),
        output:
            model="results/model/gns.pt",
            curve=report("results/model/learning_curve.png", caption="../rgns/report/captions/learning_curve.rst", category="GNS"),
            evaluation="results/model/evaluation.json",
        params:
            config=lambda wildcards: {key: config[key] for key in ("domain", "mesh", "mpm")},
        log:
            "logs/train/shipped.log",
        conda:
            "../envs/rgns.yaml"
        script:
            "../workflow/scripts/shipped_model.py"

else:

    rule train:
        """Train the GNS on the packed train set (resumes from results/model/checkpoints after a kill);
        gns.model finetune starts from the shipped model's weights."""
        input:
            train="results/dataset/train.h5",
            valid="results/dataset/valid.h5",
            init=[os.path.join(SHIPPED_MODEL, "gns.pt")] if config["gns"]["model"] == "finetune" else [],
        output:
            model="results/model/gns.pt",
            history="results/model/history.csv",
            curve=report("results/model/learning_curve.png", caption="../rgns/report/captions/learning_curve.rst", category="GNS"),
            evaluation="results/model/evaluation.json",
        params:
            gns=lambda wildcards: config["gns"],
            cell_size_m=config["mesh"]["cell_size_m"],
            warmup_s=config["montecarlo"]["rollout"]["warmup_s"],
            frame_interval_s=config["mpm"]["frame_interval_s"],
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

    rule model_card:
        """The trained model's card (config, data fingerprint, steps, time, held-out scores): what
        ships in rgns/models/ with the weights when this is the pretraining run."""
        input:
            data=["results/dataset/train.h5", "results/dataset/valid.h5"],
            history="results/model/history.csv",
            evaluation="results/model/evaluation.json",
        output:
            card="results/model/card.json",
            markdown="results/model/card.md",
        params:
            config=lambda wildcards: config,
        log:
            "logs/train/model_card.log",
        conda:
            "../envs/rgns.yaml"
        script:
            "../workflow/scripts/model_card.py"
