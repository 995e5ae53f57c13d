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
