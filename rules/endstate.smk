SHIPPED_ENDSTATE = os.path.join(workflow.basedir, "rgns/models")
# the shipped model's file stem: the test-case model (endstate.model: shipped) or the geometry-general one
SHIPPED_ENDSTATE_STEM = {"shipped": "endstate", "general": "endstate_general"}.get(config["endstate"]["model"])

if SHIPPED_ENDSTATE_STEM:

    rule shipped_endstate:
        """Take a pretrained end-state surrogate shipped with the package (its card:
        rgns/models/endstate_card.md, or endstate_general_card.md), checked to serve this config."""
        input:
            model=os.path.join(SHIPPED_ENDSTATE, f"{SHIPPED_ENDSTATE_STEM}.pt"),
            card=os.path.join(SHIPPED_ENDSTATE, f"{SHIPPED_ENDSTATE_STEM}_card.json"),
            curve=os.path.join(SHIPPED_ENDSTATE, f"{SHIPPED_ENDSTATE_STEM}_curve.png"),
        output:
            model="results/model/endstate.pt",
            curve=report("results/model/endstate_curve.png", caption="../rgns/report/captions/endstate_curve.rst", category="End-state surrogate"),
            evaluation="results/model/endstate_evaluation.json",
        params:
            config=lambda wildcards: {key: config[key] for key in ("domain", "mesh", "mpm")},
        log:
            "logs/endstate/shipped.log",
        conda:
            "../envs/rgns.yaml"
        script:
            "../workflow/scripts/shipped_endstate.py"

else:

    rule endstate_data:
        """One chunk of a test case's training realizations (drawn from endstate.data_seed), run by
        the embedded MPM as one batch; their first and last frames."""
        output:
            "results/endstate/data/{case}/chunk_{chunk}.h5",
        params:
            endstate_data_params,
        log:
            "logs/endstate_data/{case}/chunk_{chunk}.log",
        resources:
            mem_mb=2000,
        conda:
            "../envs/rgns.yaml"
        script:
            "../workflow/scripts/endstate_data.py"

    rule train_endstate:
        """Train the end-state surrogate on every test case's training chunks (resumes from
        results/model/endstate_checkpoints after a kill)."""
        input:
            expand("results/endstate/data/{case}/chunk_{chunk}.h5", case=ENDSTATE_SETS, chunk=endstate_chunk_ids()),
        output:
            model="results/model/endstate.pt",
            history="results/model/endstate_history.csv",
            curve=report("results/model/endstate_curve.png", caption="../rgns/report/captions/endstate_curve.rst", category="End-state surrogate"),
            evaluation="results/model/endstate_evaluation.json",
        params:
            endstate=ENDSTATE_TRAINING,
            threshold_m=config["metrics"]["displacement_threshold_m"],
            domain=config["domain"],
            mesh=config["mesh"],
            checkpoints="results/model/endstate_checkpoints",
        log:
            "logs/train/endstate.log",
        threads: config["endstate"]["threads"]
        resources:
            mem_mb=4000,
        conda:
            "../envs/rgns.yaml"
        script:
            "../workflow/scripts/train_endstate.py"

    rule endstate_validation_data:
        """One chunk of a validation set's realizations (drawn from endstate.validation.data_seed), run
        by the embedded MPM as one batch; their first and last frames."""
        output:
            "results/endstate/validation/{case}/chunk_{chunk}.h5",
        params:
            endstate_validation_params,
        log:
            "logs/endstate_validation_data/{case}/chunk_{chunk}.log",
        resources:
            mem_mb=2000,
        conda:
            "../envs/rgns.yaml"
        script:
            "../workflow/scripts/endstate_data.py"

    rule endstate_ood:
        """The trained end-state surrogate against the validation sets' MPM end states: R², NRMSE and
        bias per set and metric with bootstrap intervals."""
        input:
            model="results/model/endstate.pt",
            data=expand("results/endstate/validation/{case}/chunk_{chunk}.h5", case=ENDSTATE_VALIDATION_SETS,
                        chunk=endstate_validation_chunk_ids()),
        output:
            table="results/model/endstate_ood.json",
            markdown="results/model/endstate_ood.md",
        params:
            inputs=lambda wildcards: {case: asdict(CaseInputs.from_config(
                config | {"seed": config["endstate"]["validation"]["data_seed"]}, case)) for case in ENDSTATE_VALIDATION_SETS},
            metrics=config["metrics"],
        log:
            "logs/train/endstate_ood.log",
        conda:
            "../envs/rgns.yaml"
        script:
            "../workflow/scripts/endstate_ood.py"

    rule endstate_card:
        """The trained end-state surrogate's card: config, data fingerprint, steps, time, learning
        curve, what it serves and its validation table: on the endstate.validation sets when there
        are any, else against fresh MPM runs of the test cases."""
        input:
            data=expand("results/endstate/data/{case}/chunk_{chunk}.h5", case=ENDSTATE_SETS, chunk=endstate_chunk_ids()),
            history="results/model/endstate_history.csv",
            validation="results/model/endstate_ood.md" if ENDSTATE_VALIDATION_SETS else "results/report/validation/table.md",
        output:
            card="results/model/endstate_card.json",
            markdown="results/model/endstate_card.md",
        params:
            config=lambda wildcards: config,
            cases=ENDSTATE_SETS,
            title="Validation on slopes and soils it never saw" if ENDSTATE_VALIDATION_SETS else
                "Validation against fresh MPM runs of the test cases",
        log:
            "logs/train/endstate_card.log",
        conda:
            "../envs/rgns.yaml"
        script:
            "../workflow/scripts/endstate_card.py"


# The end-state surrogate tuned to the accurate MPM: the multi-fidelity correction's control variate.
if config["endstate"]["tuned"]["model"] == "shipped":

    rule shipped_tuned_endstate:
        """Take the tuned end-state surrogate shipped with the package (its card:
        rgns/models/endstate_tuned_card.md), checked to serve this config's Monte Carlo cases."""
        input:
            model=os.path.join(SHIPPED_ENDSTATE, "endstate_tuned.pt"),
            card=os.path.join(SHIPPED_ENDSTATE, "endstate_tuned_card.json"),
        output:
            model="results/model/endstate_tuned.pt",
            card="results/model/endstate_tuned_card.json",
        params:
            config=lambda wildcards: {key: config[key] for key in ("domain", "mesh", "mpm")} | {
                "sets": {case: config["sets"][case] for case in MC_CASES},
                "montecarlo": {"cases": MC_CASES, "fidelity": {"high_cell_size_m": config["montecarlo"]["fidelity"]["high_cell_size_m"]}}},
        log:
            "logs/endstate/shipped_tuned.log",
        conda:
            "../envs/rgns.yaml"
        script:
            "../workflow/scripts/shipped_tuned_endstate.py"

else:

    rule tuned_data:
        """One chunk of a Monte Carlo case's tuning realizations (drawn from endstate.tuned.data_seed), run
        by the embedded MPM at montecarlo.fidelity.high_cell_size_m as one batch, coarse-grained."""
        output:
            "results/endstate/tuned/{case}/chunk_{chunk}.h5",
        params:
            tuned_data_params,
        log:
            "logs/tuned_data/{case}/chunk_{chunk}.log",
        benchmark:
            "results/endstate/tuned/{case}/chunk_{chunk}.benchmark.tsv"
        resources:
            mem_mb=4000,
        conda:
            "../envs/rgns.yaml"
        script:
            "../workflow/scripts/tuned_data.py"

    rule tune_endstate:
        """This run's end-state surrogate trained further on the tuning chunks; its card with the held-out
        agreement before and after."""
        input:
            model="results/model/endstate.pt",
            data=expand("results/endstate/tuned/{case}/chunk_{chunk}.h5", case=MC_CASES, chunk=tuned_chunk_ids()),
        output:
            model="results/model/endstate_tuned.pt",
            curve="results/model/endstate_tuned_curve.png",
            card="results/model/endstate_tuned_card.json",
            markdown="results/model/endstate_tuned_card.md",
        params:
            config=lambda wildcards: config,
            cases=MC_CASES,
        log:
            "logs/train/tune_endstate.log",
        threads: config["endstate"]["threads"]
        resources:
            mem_mb=4000,
        conda:
            "../envs/rgns.yaml"
        script:
            "../workflow/scripts/tune_endstate.py"
