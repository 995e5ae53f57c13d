rule validation_rollout:
    """Run the learned simulator (the GNS, or the end-state surrogate when it is the Monte Carlo's) on
    every MPM realization of a test case; pair the metrics and energies."""
    input:
        packed="results/dataset/{case}.h5",
        scenes=case_scenes,
        model=SURROGATE_MODEL,
    output:
        pairs="results/validation/{case}/pairs.csv",
        energies="results/validation/{case}/energies.npz",
    params:
        metrics=config["metrics"],
        gravity_m_s2=config["mpm"]["gravity_m_s2"],
        batch_size=config["validation"]["batch_size"],
        device=config["montecarlo"]["device"],
        rollout=config["montecarlo"]["rollout"],
        surrogate=SURROGATE,
    log:
        "logs/validation_rollout/{case}.log",
    threads: config["montecarlo"]["threads"]
    resources:
        mem_mb=2000,
        gpu=gpus(config["montecarlo"]["device"]),
    conda:
        "../envs/rgns.yaml"
    script:
        "../workflow/scripts/validation_rollout.py"


rule validate:
    """The learned simulator against MPM over all test cases: the Table-3 agreement table, histograms,
    parity, energies, and the gate's verdict per case (validation.acceptance) that the Monte Carlo obeys."""
    input:
        pairs=expand("results/validation/{case}/pairs.csv", case=TEST_CASES),
        energies=expand("results/validation/{case}/energies.npz", case=TEST_CASES),
    output:
        table="results/report/validation/table.csv",
        markdown="results/report/validation/table.md",
        summary="results/report/validation/summary.json",
        gate="results/report/validation/gate.json",
        histograms=report("results/report/validation/histograms.png", caption="../rgns/report/captions/histograms.rst", category="Validation"),
        parity=report("results/report/validation/parity.png", caption="../rgns/report/captions/parity.rst", category="Validation"),
        energy=report(expand("results/report/validation/energy_{case}.png", case=TEST_CASES), caption="../rgns/report/captions/energy.rst", category="Validation"),
    params:
        cases=TEST_CASES,
        validation=config["validation"],
        cell_size_m=config["mesh"]["cell_size_m"],
        surrogate=SURROGATE,
    log:
        "logs/validate/validate.log",
    conda:
        "../envs/rgns.yaml"
    script:
        "../workflow/scripts/validate.py"
