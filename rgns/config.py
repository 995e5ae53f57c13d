"""Load and check a workflow configuration, with errors that name the key and the value.

The JSON schema (``config/schema.yaml``) types, ranges and defaults every key; the checks here
cover what a schema cannot say: [min, max] order, polygons inside the domain, references from
sets to geometry families, a mesh that tiles the domain.
"""

from __future__ import annotations

import difflib
from collections.abc import Iterator
from pathlib import Path
from typing import Any

import jsonschema
import numpy as np
import yaml

from rgns.scene.sets import test_cases
from rgns.scene.site import apply_site

REPO_ROOT = Path(__file__).resolve().parent.parent
SCHEMA_PATH = REPO_ROOT / "config" / "schema.yaml"
DEFAULT_CONFIG_PATH = REPO_ROOT / "config" / "config.yaml"


# libyaml's loader where PyYAML has it (every snakemake start reads the schema: 0.19 s in Python, 0.02 s in C)
SAFE_LOADER = getattr(yaml, "CSafeLoader", yaml.SafeLoader)


class ConfigError(ValueError):
    """A configuration value is missing, of the wrong type, out of range or inconsistent."""


def load_yaml(path: str | Path) -> dict[str, Any]:
    """Read a YAML file into a dict, naming the file if it is missing or not a mapping."""
    try:
        with open(path) as handle:
            data = yaml.load(handle, Loader=SAFE_LOADER)
    except OSError as error:
        raise ConfigError(f"{path}: cannot read the config file ({error.strerror})") from error
    if not isinstance(data, dict):
        raise ConfigError(f"{path}: expected a mapping at the top level, got {type(data).__name__}")
    return data


def key_path(parts: Iterator[Any] | list[Any]) -> str:
    """Render a JSON path as ``a.b[0].c``."""
    text = ""
    for part in parts:
        text += f"[{part}]" if isinstance(part, int) else (f".{part}" if text else str(part))
    return text or "<top level>"


def _nearest(error: jsonschema.ValidationError) -> str:
    """'; did you mean ...' for each unexpected key with a close valid name at its level."""
    valid = list(error.schema.get("properties", {}))
    hints = [
        f"'{match[0]}' for '{key}'"
        for key in error.instance
        if key not in valid
        for match in [difflib.get_close_matches(key, valid, n=1, cutoff=0.6)]
        if match
    ]
    return f"; did you mean {', '.join(hints)}?" if hints else ""


def _describe(error: jsonschema.ValidationError) -> str:
    where = key_path(list(error.absolute_path))
    if error.validator == "additionalProperties":
        return f"config key '{where}': {error.message}{_nearest(error)}"
    if error.validator == "required":
        return f"config key '{where}': {error.message}"
    reason = error.message
    if error.context:  # oneOf / anyOf: explain with the branch whose type the value has
        matching_type = [sub for sub in error.context if sub.validator != "type"]
        reason = jsonschema.exceptions.best_match(matching_type or error.context).message
    return f"config key '{where}' = {error.instance!r}: {reason}"


SCALAR_TYPES: dict[str, type | tuple[type, ...]] = {"integer": int, "number": (int, float), "boolean": bool}


def coerce_text_values(config: dict[str, Any], schema: dict[str, Any]) -> None:
    """Turn text where the schema expects a number or a boolean into one, in place: Snakemake's
    ``--config 'montecarlo={realizations: 320}'`` hands nested values over as text ('320')."""
    validator = jsonschema.Draft202012Validator(schema)
    for error in list(validator.iter_errors(config)):
        for sub in [error, *(error.context or [])]:
            expected = sub.validator_value if sub.validator == "type" else None
            if not isinstance(sub.instance, str) or expected is None:
                continue
            value = yaml.safe_load(sub.instance)
            kinds = [expected] if isinstance(expected, str) else expected
            if (
                any(
                    isinstance(value, SCALAR_TYPES.get(kind, ()))
                    and not (kind != "boolean" and isinstance(value, bool))
                    for kind in kinds
                )
                and sub.absolute_path
            ):
                *parents, last = list(sub.absolute_path)
                target = config
                for part in parents:
                    target = target[part]
                target[last] = value
                break


def schema_errors(config: dict[str, Any], schema: dict[str, Any]) -> list[str]:
    """Every schema violation in ``config``, one readable line each."""
    validator = jsonschema.Draft202012Validator(schema)
    errors = sorted(validator.iter_errors(config), key=lambda e: list(map(str, e.absolute_path)))
    return [_describe(error) for error in errors]


def _ranges(config: dict[str, Any]) -> Iterator[tuple[str, Any]]:
    """Every value that may be a [min, max] range, with its key path."""
    for fam_name, family in config["geometry"]["families"].items():
        for name, value in family.get("params", {}).items():
            yield f"geometry.families.{fam_name}.params.{name}", value
        for k, vertex in enumerate(family.get("vertices", [])):
            for axis in ("x_m", "y_m"):
                yield f"geometry.families.{fam_name}.vertices[{k}].{axis}", vertex[axis]
    for set_name, groups in config["sets"].items():
        for g, group in enumerate(groups):
            yield f"sets.{set_name}[{g}].friction_mean_deg", group["friction_mean_deg"]
    yield "random_field.friction_bounds_deg", config["random_field"]["friction_bounds_deg"]


def as_range(value: float | list[float]) -> tuple[float, float]:
    """A fixed number as the degenerate range (v, v); a [min, max] pair as a tuple."""
    if isinstance(value, (int, float)):
        return float(value), float(value)
    return float(value[0]), float(value[1])


def consistency_errors(config: dict[str, Any]) -> list[str]:
    """Cross-key errors that the schema cannot express, one readable line each."""
    from rgns.engines.mpm.backend import uses_kernels  # local, as geometry: it imports nothing from here
    from rgns.scene.geometry import polygon_problems  # local: geometry imports nothing from here

    errors: list[str] = []
    for where, value in _ranges(config):
        low, high = as_range(value)
        if low > high:
            errors.append(f"config key '{where}' = {value!r}: min {low} > max {high}")

    length, height = config["domain"]["length_m"], config["domain"]["height_m"]
    cell = config["mesh"]["cell_size_m"]
    for name, extent in (("length_m", length), ("height_m", height)):
        cells = extent / cell
        if abs(cells - round(cells)) > 1e-9 * max(cells, 1.0):
            errors.append(
                f"config key 'domain.{name}' = {extent!r}: not a whole number of cells of mesh.cell_size_m = {cell!r}"
            )

    for fam_name, family in config["geometry"]["families"].items():
        if "generator" in family:
            errors += _generator_errors(fam_name, family)
            continue
        for k, vertex in enumerate(family["vertices"]):
            for axis, limit in (("x_m", length), ("y_m", height)):
                low, high = as_range(vertex[axis])
                if low < 0.0 or high > limit:
                    errors.append(
                        f"config key 'geometry.families.{fam_name}.vertices[{k}].{axis}' = "
                        f"{vertex[axis]!r}: outside the domain [0, {limit}] "
                        f"(domain.{'length_m' if axis == 'x_m' else 'height_m'})"
                    )
        centre = np.array([[np.mean(as_range(v["x_m"])), np.mean(as_range(v["y_m"]))] for v in family["vertices"]])
        room = config["geometry"]["runout_room_m"]
        for problem in polygon_problems(centre, length, height, room=room, headroom=cell):
            errors.append(
                f"config key 'geometry.families.{fam_name}.vertices': the polygon through the "
                f"range centres {centre.tolist()} {problem}"
            )

    mpm = config["mpm"]
    for name, numerator, denominator in (
        ("frame_interval_s", mpm["frame_interval_s"], mpm["dt_s"]),
        ("duration_s", mpm["duration_s"], mpm["frame_interval_s"]),
    ):
        ratio = numerator / denominator
        if abs(ratio - round(ratio)) > 1e-6 * ratio:
            other = "dt_s" if name == "frame_interval_s" else "frame_interval_s"
            errors.append(
                f"config key 'mpm.{name}' = {numerator!r}: not a whole number of mpm.{other} = {denominator!r}"
            )

    if not config["sets"]:
        errors.append("config key 'sets': no set and no site: give sets, or a site (config key 'site')")
    missing = [name for name in ("train", "valid") if name not in config["sets"]]
    if config["gns"]["model"] != "shipped" and missing:
        errors.append(
            f"config key 'sets': no {' and no '.join(missing)} set, which gns.model = "
            f"{config['gns']['model']!r} trains on (gns.model: shipped needs none)"
        )
    embedded = config["mpm"]["embedded"]
    try:
        uses_kernels(embedded["backend"], embedded["device"], embedded["dtype"])
    except ValueError as error:
        errors.append(f"config key {error}")
    families = config["geometry"]["families"]
    for set_name, groups in config["sets"].items():
        for g, group in enumerate(groups):
            if group["family"] not in families:
                errors.append(
                    f"config key 'sets.{set_name}[{g}].family' = {group['family']!r}: no such "
                    f"family under geometry.families (have: {', '.join(sorted(families))})"
                )
    return errors + _montecarlo_errors(config) + _hazard_errors(config) + _shipped_model_errors(config)


def _shipped_model_errors(config: dict[str, Any]) -> list[str]:
    """What the shipped models the config selects say against it (rgns.surrogates.shipped.config_errors)."""
    from rgns.surrogates.shipped import config_errors  # local: only needed here

    return config_errors(config)


def _generator_errors(fam_name: str, family: dict[str, Any]) -> list[str]:
    """A generated family's parameters: every one its kind needs, none it does not know."""
    from rgns.scene.slope_generator import REQUIRED  # local: only needed here

    known = set(REQUIRED[family["generator"]])
    given = set(family["params"])
    errors = [
        f"config key 'geometry.families.{fam_name}.params': lacks {name!r}, which generator "
        f"{family['generator']!r} needs"
        for name in sorted(known - given)
    ]
    return errors + [
        f"config key 'geometry.families.{fam_name}.params.{name}': generator "
        f"{family['generator']!r} has no such parameter (it has: {', '.join(sorted(known))})"
        for name in sorted(given - known)
    ]


def _montecarlo_errors(config: dict[str, Any]) -> list[str]:
    errors = []
    section = config["montecarlo"]
    cases = test_cases(config["sets"])
    for k, case in enumerate(section["cases"]):
        if case not in cases:
            errors.append(
                f"config key 'montecarlo.cases[{k}]' = {case!r}: not a test-case set "
                f"(test cases: {', '.join(cases) or 'none'})"
            )
        elif len(config["sets"][case]) != 1:
            errors.append(
                f"config key 'montecarlo.cases[{k}]' = {case!r}: set {case!r} has "
                f"{len(config['sets'][case])} groups; a Monte Carlo case needs exactly one"
            )
    if section["chunk_size"] % section["batch_size"]:
        errors.append(
            f"config key 'montecarlo.chunk_size' = {section['chunk_size']!r}: not a multiple of "
            f"montecarlo.batch_size = {section['batch_size']!r} (batches must not straddle chunks)"
        )
    fidelity = section["fidelity"]
    if fidelity["paired"] and not 2 <= fidelity["paired"] <= section["realizations"]:
        errors.append(
            f"config key 'montecarlo.fidelity.paired' = {fidelity['paired']!r}: 0 (off) or between 2 "
            f"and montecarlo.realizations = {section['realizations']}"
        )
    if fidelity["paired"] and 2 * (len(fidelity["strata"]) + 1) > fidelity["paired"]:
        errors.append(
            f"config key 'montecarlo.fidelity.paired' = {fidelity['paired']!r}: fewer than 2 pairs for each of the "
            f"{len(fidelity['strata']) + 1} strata of montecarlo.fidelity.strata"
        )
    if fidelity["paired"] and fidelity["high_cell_size_m"] >= config["mesh"]["cell_size_m"]:
        errors.append(
            f"config key 'montecarlo.fidelity.high_cell_size_m' = {fidelity['high_cell_size_m']!r}: "
            f"must be finer than mesh.cell_size_m = {config['mesh']['cell_size_m']!r}"
        )
    return errors


def _hazard_errors(config: dict[str, Any]) -> list[str]:
    thresholds = config["hazard"]["zoning_thresholds"]
    if any(high <= low for high, low in zip(thresholds, thresholds[1:])):
        return [
            f"config key 'hazard.zoning_thresholds' = {thresholds!r}: must be strictly decreasing "
            "(extremely high, high, moderate, low)"
        ]
    return []


def validate_config(config: dict[str, Any], schema_path: str | Path = SCHEMA_PATH) -> dict[str, Any]:
    """Check ``config`` against the schema and the cross-key rules, fill defaults, add the site, return it.

    Schema violations are reported first, all of them and readably; only a config that passes
    goes through ``snakemake.utils.validate``, which inserts the defaults.

    Raises :class:`ConfigError` listing every problem, each naming the key and the value.
    """
    from snakemake.utils import validate  # fills the schema defaults in place

    schema = load_yaml(schema_path)
    coerce_text_values(config, schema)
    errors = schema_errors(config, schema)
    if not errors:
        derive_domain = "domain" not in config  # a site without a domain section sizes its own
        validate(config, str(schema_path))
        errors = apply_site(config, derive_domain) or consistency_errors(config)
    if errors:
        raise ConfigError("invalid configuration:\n  " + "\n  ".join(errors))
    return config


def load_config(path: str | Path = DEFAULT_CONFIG_PATH, schema_path: str | Path = SCHEMA_PATH) -> dict[str, Any]:
    """Read, validate and default-fill a config file."""
    return validate_config(load_yaml(path), schema_path)
