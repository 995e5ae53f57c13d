"""Where each realization runs (rgns.montecarlo.routes): the MPM only on the pairs, every realization by
the learned simulator, chunks that together hold each realization once."""

import copy

import pandas as pd
import pytest

from rgns.config import load_config
from rgns.montecarlo.routes import PAIRED, chunk_share, monte_carlo_routes
from rgns.montecarlo.tables import COLUMNS, collect_listed
from rgns.scene.realizations import MEAN_FIELD
from rgns.tables import TableError, write_csv


def test_the_default_runs_every_realization_by_the_surrogate_and_only_the_pairs_by_the_mpm():
    config = load_config()
    routes = monte_carlo_routes(config)
    fidelity = config["montecarlo"]["fidelity"]
    assert set(routes) == {"realizations", "mean_field", "paired", "paired_coarse", "control"}
    assert {name for name, route in routes.items() if route.simulator == "mpm"} == {"paired", "paired_coarse"}
    assert all(route.realizations == PAIRED for route in routes.values() if route.simulator == "mpm")
    assert routes["paired"].cell_size_m == fidelity["high_cell_size_m"] < config["mesh"]["cell_size_m"]
    assert routes["paired_coarse"].cell_size_m == config["mesh"]["cell_size_m"]
    assert routes["realizations"].listed(config) == list(range(config["montecarlo"]["realizations"]))
    assert routes["mean_field"].listed(config) == [MEAN_FIELD] and routes["paired"].listed(config) is None
    # a pair is the same slope and soil at both meshes: both drawn as the accurate mesh draws them
    fine, coarse = (routes[name].case_inputs(config, "case1") for name in ("paired", "paired_coarse"))
    assert fine.random_field == coarse.random_field and fine.geometry == coarse.geometry
    assert (fine.mesh["cell_size_m"], coarse.mesh["cell_size_m"]) == (0.5, config["mesh"]["cell_size_m"])


def test_without_pairs_only_the_monte_carlo_and_its_mean_field_run():
    config = copy.deepcopy(load_config())
    config["montecarlo"]["simulator"] = "mpm"
    config["montecarlo"]["fidelity"]["paired"] = 0
    routes = monte_carlo_routes(config)
    assert set(routes) == {"realizations", "mean_field"}
    assert routes["realizations"].model is None and not routes["realizations"].gated


def test_the_chunks_of_a_route_hold_each_listed_realization_once_in_order():
    listed = [7, 3, 9, 1, 4, 8, 2]
    shares = [chunk_share(listed, k, 3) for k in range(3)]
    assert shares == [[7, 3, 9], [1, 4, 8], [2]]
    config = load_config()
    route = monte_carlo_routes(config)["realizations"]
    chunks = route.chunk_ids(config)
    indices = [i for k in range(len(chunks)) for i in chunk_share(route.listed(config), k, route.chunk_size)]
    assert indices == route.listed(config)


def test_a_routes_table_is_its_chunks_in_the_listed_order_and_a_stray_chunk_is_named(tmp_path):
    listed = [5, 1, 3]
    paths = []
    for k, share in enumerate([chunk_share(listed, k, 2) for k in range(2)]):
        path = tmp_path / f"chunk_{k:03d}.csv"
        write_csv(pd.DataFrame({"index": sorted(share), "status": "ok"}).reindex(columns=COLUMNS), path)
        paths.append(str(path))
    assert collect_listed(paths, listed, 2)["index"].tolist() == listed
    with pytest.raises(TableError, match="chunk_001.csv.*holds realizations \\[3\\], not \\[2\\]"):
        collect_listed(paths, [5, 1, 2], 2)
    with pytest.raises(TableError, match="2 chunk tables for 3 realizations in chunks of 1"):
        collect_listed(paths, listed, 1)
