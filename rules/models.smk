# The rules that make the models: the GNS trained on the training sets' MPM runs, the end-state surrogate's
# training runs, training, validation and card, and its tuning to the accurate mesh, with the pretrain* targets
# (config/pretrain*.yaml make the shipped models). Each group is defined only where the config asks for that
# model to be made (gns.model train or finetune, endstate.model train, endstate.tuned.model train); the default
# takes the shipped models and none of these rules exists for it.


def endstate_chunk_ids():
    """Chunk ids of the end-state training realizations of each test case (the held-out ones last)."""
    section = config["endstate"]
    return chunk_labels(section["realizations"] + section["held_out"], section["chunk_size"])


ENDSTATE_SETS = config["endstate"]["sets"] or TEST_CASES
ENDSTATE_VALIDATION_SETS = config["endstate"]["validation"]["sets"]
# what training depends on: not the model choice, the validation or the tuning
ENDSTATE_TRAINING = {key: value for key, value in config["endstate"].items() if key not in ("model", "validation", "tuned")}


def endstate_validation_chunk_ids():
    """Chunk ids of the validation realizations of each endstate.validation set."""
    section = config["endstate"]["validation"]
    return chunk_labels(section["realizations"], section["chunk_size"])


def end_state_chunk_params(case, seed, chunk, chunk_size, total):
    """A set's inputs drawn from ``seed``, and the MPM run of chunk ``chunk`` of its ``total`` realizations."""
    return {"inputs": asdict(CaseInputs.from_config(config | {"seed": seed}, case)),
            "indices": chunk_share(list(range(total)), int(chunk), chunk_size), "mpm": config["mpm"],
            "frames": frame_count(config["mpm"]["duration_s"], config["mpm"]["frame_interval_s"])}


def endstate_validation_params(wildcards):
    """A validation set's inputs drawn from endstate.validation.data_seed, and the MPM run of one chunk of them."""
    section = config["endstate"]["validation"]
    return end_state_chunk_params(wildcards.case, section["data_seed"], wildcards.chunk, section["chunk_size"],
                                  section["realizations"])


def endstate_data_params(wildcards):
    """A test case's inputs drawn from endstate.data_seed, and the MPM run of one chunk of them."""
    section = config["endstate"]
    return end_state_chunk_params(wildcards.case, section["data_seed"], wildcards.chunk, section["chunk_size"],
                                  section["realizations"] + section["held_out"])


def tuned_chunk_ids():
    """Chunk ids of the tuning realizations of each Monte Carlo case (the held-out ones last)."""
    section = config["endstate"]["tuned"]
    return chunk_labels(section["realizations"] + section["held_out"], section["chunk_size"])


def tuned_data_params(wildcards):
    """A case drawn from endstate.tuned.data_seed at the mesh and at the accurate mesh, and one chunk of it."""
    section = config["endstate"]["tuned"]
    first = int(wildcards.chunk) * section["chunk_size"]
    last = min(first + section["chunk_size"], section["realizations"] + section["held_out"])
    seeded = config | {"seed": section["data_seed"]}
    fine = accurate_case_inputs(seeded, wildcards.case, config["montecarlo"]["fidelity"]["high_cell_size_m"])
    return {"coarse": asdict(CaseInputs.from_config(seeded, wildcards.case)), "fine": asdict(fine),
            "indices": list(range(first, last)), "mpm": config["mpm"],
            "frames": frame_count(config["mpm"]["duration_s"], config["mpm"]["frame_interval_s"])}


if config["gns"]["model"] != "shipped":

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

    rule pretrain:
        """The training sets' MPM runs and the GNS trained on them (config/pretrain.yaml makes the shipped model)."""
        input:
            "results/model/gns.pt",
            "results/model/card.md",


ENDSTATE_START = {"model": os.path.join(SHIPPED_ENDSTATE, "endstate_general.pt"),
                  "card": os.path.join(SHIPPED_ENDSTATE, "endstate_general_card.json")}

if config["endstate"]["model"] in ("train", "finetune"):
    # finetune: training starts from the shipped general model (and its card names it)
    start = ENDSTATE_START if config["endstate"]["model"] == "finetune" else {}

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
        results/model/endstate_checkpoints after a kill); endstate.model finetune starts from the shipped model."""
        input:
            data=expand("results/endstate/data/{case}/chunk_{chunk}.h5", case=ENDSTATE_SETS, chunk=endstate_chunk_ids()),
            start=start.get("model", []),
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
            start=list(start.values()),
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

    rule pretrain_endstate:
        """The end-state surrogate's training runs, its training and its card with the validation table
        (config/pretrain_general.yaml makes the shipped geometry-general one)."""
        input:
            "results/model/endstate.pt",
            "results/model/endstate_card.md",


# The end-state surrogate tuned to the accurate MPM: the multi-fidelity correction's control variate.
if config["endstate"]["tuned"]["model"] == "train":

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

    rule pretrain_tuned:
        """The accurate MPM runs of the Monte Carlo's cases and the end-state surrogate tuned on them, with its
        card (config/pretrain_tuned.yaml makes the shipped one)."""
        input:
            "results/model/endstate_tuned.pt",
            "results/model/endstate_tuned_card.md",
