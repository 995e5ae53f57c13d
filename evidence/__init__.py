"""Figures in the repository's documents, rendered from the committed result files that measured them.

A document marks a rendered passage with ``<!-- rendered: NAME -->`` … ``<!-- end rendered -->`` (both indented
alike, inside a list item); NAME is one of :data:`RENDERERS`, which reads its result file(s) under
``benchmarks/results`` and writes the passage. Each result file records the command and the commit that made it,
and the passage says both; a file made before results recorded their commit is read with ``legacy=True`` and its
passage names the commit that committed it (its ``committed_in``) instead, as such. ``python -m
evidence`` rewrites every marked passage; ``--check`` lists those that differ from their rendering
(tests/test_documents.py runs it), so a figure edited by hand, or a result re-measured without its documents,
fails the tests.

The renderers live in one module per theme: ``sources`` reads the result files and cards, ``formatting`` writes
numbers, and ``runs``, ``fidelity``, ``engine``, ``endstate``, ``gns`` and ``benchmarks`` write the passages.
"""

from __future__ import annotations

import argparse
import re
from collections.abc import Callable
from pathlib import Path

from evidence.benchmarks import bench_current, bench_fields
from evidence.endstate import (
    cheap_route_choice,
    endstate_speed,
    general_training,
    ood_bias_table,
    ood_floor,
    ood_table,
    ood_targets,
    tuned_untouched,
)
from evidence.engine import (
    bench_convergence,
    convergence_column,
    convergence_default_error,
    convergence_orders,
    convergence_table,
    locking_bspline,
    locking_routes,
    time_step,
    time_step_mesh,
)
from evidence.fidelity import (
    bench_chain_coverage,
    bench_multifidelity,
    gpu_levels,
    hifi_tuning,
    mesh_step,
    multifidelity_levers,
    multifidelity_routes,
    tuned_least,
    tuned_speedups,
)
from evidence.gns import (
    gns_checkpoints,
    gns_cpu,
    gns_handover,
    gns_jitter,
    gns_recipe,
    gns_rest_gate,
    gns_shipped,
    gns_timeline,
    gns_training,
)
from evidence.runs import (
    default_headline,
    default_run,
    influence_growth,
    pair_coverage,
    site_run,
    strata_spread,
)
from evidence.sources import REPO, DocumentError

__all__ = ["BLOCK", "DOCUMENTS", "RENDERERS", "DocumentError", "REPO", "documents", "main", "rendered", "stale"]

BLOCK = re.compile(
    r"^(?P<indent> *)<!-- rendered: (?P<name>[\w-]+) -->\n(?P<body>.*?)^(?P=indent)<!-- end rendered -->",
    re.DOTALL | re.MULTILINE,
)

# the documents that may hold rendered passages
DOCUMENTS = ("README.md", "docs/*.md", "rgns/models/*.md")

RENDERERS: dict[str, Callable[[], str]] = {
    "ood-table": ood_table,
    "ood-bias-table": ood_bias_table,
    "ood-targets": ood_targets,
    "ood-floor": ood_floor,
    "endstate-speed": endstate_speed,
    "general-training": general_training,
    "gns-training": gns_training,
    "gns-recipe": gns_recipe,
    "gns-jitter": gns_jitter,
    "gns-handover": gns_handover,
    "gns-shipped": gns_shipped,
    "gns-cpu": gns_cpu,
    "gns-timeline": gns_timeline,
    "gns-checkpoints": gns_checkpoints,
    "gns-rest-gate": gns_rest_gate,
    "default-run": default_run,
    "default-headline": default_headline,
    "site-run": site_run,
    "pair-coverage": pair_coverage,
    "strata-spread": strata_spread,
    "influence-growth": influence_growth,
    "tuned-least": tuned_least,
    "cheap-route": cheap_route_choice,
    "tuned-untouched": tuned_untouched,
    "bench-fields": bench_fields,
    "bench-current": bench_current,
    "bench-convergence": bench_convergence,
    "bench-multifidelity": bench_multifidelity,
    "bench-chain-coverage": bench_chain_coverage,
    "tuned-speedups": tuned_speedups,
    "hifi-tuning": hifi_tuning,
    "multifidelity-routes": multifidelity_routes,
    "multifidelity-levers": multifidelity_levers,
    "mesh-step": mesh_step,
    "gpu-levels": gpu_levels,
    "convergence-table": convergence_table,
    "convergence-orders": convergence_orders,
    "convergence-column": convergence_column,
    "convergence-default-error": convergence_default_error,
    "locking-routes": locking_routes,
    "locking-bspline": locking_bspline,
    "time-step": time_step,
    "time-step-mesh": time_step_mesh,
}


def documents() -> list[Path]:
    return sorted({path for pattern in DOCUMENTS for path in REPO.glob(pattern)})


def rendered(text: str, where: str, only: set[str] | None = None) -> str:
    """``text`` with every marked passage (``only`` these names; None: all) replaced by its rendering."""

    def replace(match: re.Match[str]) -> str:
        name = match["name"]
        if name not in RENDERERS:
            raise DocumentError(f"{where}: rendered passage {name!r} has no renderer (known: {sorted(RENDERERS)})")
        if only is not None and name not in only:
            return match[0]
        indent = match["indent"]
        body = "\n".join(f"{indent}{line}" if line else "" for line in RENDERERS[name]().rstrip().split("\n"))
        return f"{indent}<!-- rendered: {name} -->\n{body}\n{indent}<!-- end rendered -->"

    return BLOCK.sub(replace, text)


def stale(paths: list[Path] | None = None) -> list[Path]:
    """The documents (``paths``; None: every one that may hold rendered passages) whose marked passages differ
    from their rendering."""
    return [path for path in paths or documents() if (text := path.read_text()) != rendered(text, str(path))]


def main(argv: list[str] | None = None) -> int:
    parser = argparse.ArgumentParser(description=__doc__.split("\n")[0])
    parser.add_argument("--check", action="store_true", help="list the documents that differ; write nothing")
    parser.add_argument("--only", nargs="+", choices=sorted(RENDERERS), help="rewrite only these passages")
    args = parser.parse_args(argv)
    if args.check:
        differing = stale()
        for path in differing:
            print(f"{path}: a rendered passage differs from its result files (rewrite: python -m evidence)")
        return 1 if differing else 0
    for path in documents():
        text = path.read_text()
        new = rendered(text, str(path), None if args.only is None else set(args.only))
        if new != text:
            path.write_text(new)
            print(f"rewrote {path.relative_to(REPO)}")
    return 0
