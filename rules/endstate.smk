SHIPPED_ENDSTATE = os.path.join(workflow.basedir, "rgns/models")

if config["endstate"]["model"] == "general":

    rule shipped_endstate:
        """Take the geometry-general end-state surrogate shipped with the package (its card:
        rgns/models/endstate_general_card.md), checked to serve this config."""
        input:
            model=os.path.join(SHIPPED_ENDSTATE, "endstate_general.pt"),
            card=os.path.join(SHIPPED_ENDSTATE, "endstate_general_card.json"),
            curve=os.path.join(SHIPPED_ENDSTATE, "endstate_general_curve.png"),
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
