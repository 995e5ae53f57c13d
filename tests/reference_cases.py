"""Named cases for benchmarks and cross-engine checks, built through the normal pipeline."""

from __future__ import annotations

import copy
import dataclasses
from pathlib import Path

from rgns.config import DEFAULT_CONFIG_PATH, load_config
from rgns.engines.cbgeo.writer import save_case
from rgns.scene.build import case_from_scene
from rgns.scene.case import Case
from rgns.scene.fields import FieldGrid, friction_field
from rgns.scene.geometry import build_scene


def failing_slope(
    directory: str | Path | None = None,
    friction_mean_deg: float = 20.0,
    index: int = 0,
    config_path: str | Path = DEFAULT_CONFIG_PATH,
    **mpm_overrides,
) -> Case:
    """Training slope ``index`` of a config with a weak friction field (mean 20°), which fails.

    Geometry, field and case come from the same functions the workflow uses; ``mpm_overrides``
    replace keys of the config's ``mpm`` section. The case is built in memory and, when
    ``directory`` is given, also written there (for the CB-Geo binary).
    """
    config = load_config(config_path)
    group = dict(config["sets"]["train"][0], friction_mean_deg=friction_mean_deg)
    family = group["family"]
    scene = build_scene(
        "train",
        index,
        family,
        config["geometry"]["families"][family],
        config["domain"],
        config["mesh"],
        config["geometry"],
        config["seed"],
    )
    spacing = config["random_field"]["grid_spacing_m"] or config["mesh"]["cell_size_m"]
    grid = FieldGrid.covering(config["domain"]["length_m"], config["domain"]["height_m"], spacing)
    field = friction_field(
        config["seed"],
        "train",
        index,
        group,
        grid,
        config["random_field"]["method"],
        tuple(config["random_field"]["friction_bounds_deg"]),
        scene.positions,
    )
    settings = copy.deepcopy(config["mpm"])
    settings.update(mpm_overrides)
    case = case_from_scene(scene, field.friction_deg, settings)
    if directory is None:
        return case
    return dataclasses.replace(case, directory=save_case(directory, case))
