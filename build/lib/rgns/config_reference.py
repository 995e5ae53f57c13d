"""Render config/schema.yaml as a Markdown reference: one row per key, with type, default, range."""

from __future__ import annotations

from collections.abc import Iterator
from typing import Any

from rgns.config import SCHEMA_PATH, load_yaml


def _resolve(node: dict[str, Any], schema: dict[str, Any]) -> dict[str, Any]:
    while "$ref" in node:
        node = schema["$defs"][node["$ref"].rsplit("/", 1)[-1]]
    return node


def _type(node: dict[str, Any], schema: dict[str, Any]) -> str:
    if "oneOf" in node:
        return " or ".join(_type(_resolve(option, schema), schema) for option in node["oneOf"])
    kind = node.get("type", "")
    if kind == "array" and "items" in node:
        inner = _type(_resolve(node["items"], schema), schema)
        size = f"{node['minItems']}" if "minItems" in node and node.get("minItems") == node.get("maxItems") else ""
        return f"[{inner}]×{size}" if size else f"list of {inner}"
    if "enum" in node:
        return " \\| ".join(f"`{value}`" for value in node["enum"])
    return " or ".join(kind) if isinstance(kind, list) else kind


def _range(node: dict[str, Any]) -> str:
    bounds = []
    for key, symbol in (("minimum", "≥"), ("exclusiveMinimum", ">"), ("maximum", "≤"), ("exclusiveMaximum", "<")):
        if key in node:
            bounds.append(f"{symbol} {node[key]}")
    return ", ".join(bounds)


def _rows(node: dict[str, Any], schema: dict[str, Any], path: str, required: bool = False) -> Iterator[tuple[str, ...]]:
    description = " ".join(node.get("description", "").split())  # a $ref's own text wins
    node = _resolve(node, schema)
    if path:
        default = "required" if required else ""
        if "default" in node and node.get("type") != "object":
            default = f"`{node['default']}`"
        description = description or " ".join(node.get("description", "").split())
        options = [_resolve(option, schema) for option in node.get("oneOf", [])]
        ranged = " or ".join(dict.fromkeys(filter(None, (_range(o) or _range(o.get("items", {})) for o in options))))
        ranged = _range(node) or _range(_resolve(node.get("items", {}), schema)) or ranged
        yield path, _type(node, schema), default, ranged, description
    for name, child in node.get("properties", {}).items():
        yield from _rows(child, schema, f"{path}.{name}" if path else name, name in node.get("required", []))
    extra = node.get("additionalProperties")
    if isinstance(extra, dict):
        yield from _rows(extra, schema, f"{path}.<name>")
    items = _resolve(node.get("items", {}), schema) if node.get("type") == "array" else {}
    if items.get("type") == "object":
        yield from _rows(items, schema, f"{path}[]")


def config_reference(schema: dict[str, Any] | None = None) -> str:
    """The Markdown reference of every configuration key."""
    schema = schema or load_yaml(SCHEMA_PATH)
    lines = [
        "# Configuration reference",
        "",
        "Generated from `config/schema.yaml` by `rgns config-reference`; do not edit by hand.",
        "",
        " ".join(schema["description"].split()),
        "",
        "| key | type | default | range | description |",
        "|---|---|---|---|---|",
    ]
    for row in _rows(schema, schema, ""):
        lines.append(
            "| " + " | ".join(cell.replace("|", "\\|") if i != 1 else cell for i, cell in enumerate(row)) + " |"
        )
    return "\n".join(lines) + "\n"
