rule exceedance:
    """Convergence of the running statistics and exceedance curves of I and R for one case."""
    input:
        realizations="results/mc/{case}/realizations.csv",
        mean_field="results/mc/{case}/mean_field.csv",
    output:
        curve=report("results/report/{case}/exceedance.png", caption="../rgns/report/captions/exceedance.rst", category="Hazard"),
        curve_csv="results/report/{case}/exceedance.csv",
        curve_json="results/report/{case}/exceedance.json",
        convergence=report("results/report/{case}/convergence.png", caption="../rgns/report/captions/convergence.rst", category="Hazard"),
        convergence_csv="results/report/{case}/convergence.csv",
        convergence_json="results/report/{case}/convergence.json",
    params:
        exceedance_params,
    log:
        "logs/exceedance/{case}.log",
    conda:
        "../envs/rgns.yaml"
    script:
        "../workflow/scripts/exceedance.py"


rule zoning:
    """Five-level hazard zoning along the slope cross-section for one case."""
    input:
        realizations="results/mc/{case}/realizations.csv",
    output:
        map=report("results/report/{case}/zoning.png", caption="../rgns/report/captions/zoning.rst", category="Hazard"),
        csv="results/report/{case}/zoning.csv",
        json="results/report/{case}/zoning.json",
    params:
        zoning_params,
    log:
        "logs/zoning/{case}.log",
    conda:
        "../envs/rgns.yaml"
    script:
        "../workflow/scripts/zoning.py"


rule report:
    """One self-contained HTML page with every figure, table and caption."""
    input:
        scenes=expand("results/plots/{set}/scenes.png", set=RUN_SETS),
        curve=[SURROGATE_CURVE] if SURROGATE else [],
        evaluation=[SURROGATE_EVALUATION] if SURROGATE else [],
        validation_table=["results/report/validation/table.csv"] if SURROGATE else [],
        validation_summary=["results/report/validation/summary.json"] if SURROGATE else [],
        gate=report_gate,
        validation_figures=["results/report/validation/histograms.png", "results/report/validation/parity.png"]
        + expand("results/report/validation/energy_{case}.png", case=TEST_CASES) if SURROGATE else [],
        hazard=expand("results/report/{case}/{name}", case=MC_CASES,
                      name=["exceedance.png", "exceedance.json", "convergence.png", "convergence.json",
                            "zoning.png", "zoning.json"] + MULTIFIDELITY_FILES)
        + ([f"results/site/{SITE['name']}/map.png"] if "map.png" in SITE_FILES else []),
    output:
        "results/report/report.html",
    params:
        cases=MC_CASES,
        sets=RUN_SETS,
        surrogate=SURROGATE,
        config_summary=lambda wildcards: {key: config[key] for key in ("seed", "domain", "mesh", "montecarlo", "hazard", "metrics")},
        config=lambda wildcards: config,
    log:
        "logs/report/report.log",
    conda:
        "../envs/rgns.yaml"
    script:
        "../workflow/scripts/report.py"
