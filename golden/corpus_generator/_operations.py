"""The operations file (golden/operations.json): every vector must agree with it."""

from __future__ import annotations

import json
import pathlib
from typing import Any

from ._config import GOLDEN

OPERATIONS_FILE = GOLDEN / "operations.json"


def load_operations(path: pathlib.Path = OPERATIONS_FILE) -> dict:
    return json.loads(path.read_text(encoding="utf-8"))


def _json_kind(value: Any) -> str:
    if value is None:
        return "none"
    if isinstance(value, bool):
        return "boolean"
    if isinstance(value, int):
        return "integer"
    if isinstance(value, float) or value in ("NaN", "Infinity", "-Infinity"):
        return "real"
    if isinstance(value, str):
        return "string"
    if isinstance(value, list):
        return "list"
    if isinstance(value, dict) and set(value) == {"shape", "values"}:
        return "array"
    return type(value).__name__


def _output_ok(kind: str, value: Any) -> bool:
    values = value["values"] if _json_kind(value) == "array" else [value]
    if kind == "integer":
        return all(_json_kind(v) == "integer" for v in values)
    if kind == "bool":
        return all(_json_kind(v) == "boolean" for v in values)
    return all(_json_kind(v) in ("real", "integer") for v in values)


def _convention_ok(kind: str, value: Any) -> bool:
    got = _json_kind(value)
    if kind == "segments":
        return got == "none" or (got == "list" and all(_json_kind(v) == "integer" for v in value))
    if kind == "lengths":
        return got == "list" and len(value) > 0 and all(_json_kind(v) == "integer" and v > 0 for v in value)
    if kind == "string or none":
        return got in ("string", "none")
    return got == {"string": "string", "integer": "integer", "boolean": "boolean", "real": "real"}[kind]


def operations_problems(doc: dict, spec: dict) -> list[str]:
    """Where a family document disagrees with golden/operations.json (empty when it agrees).

    Valid and acceptable vectors must use declared inputs, accepted convention values and
    declared outputs of the declared types; invalid vectors may carry anything in their inputs
    and conventions (that is their point) but only declared names.
    """
    family = doc["family"]
    problems = []
    if family not in spec["families"]:
        return [f"{family}: family not in operations.json"]
    for group in doc["testGroups"]:
        name = group["operation"]
        op = spec["operations"].get(name)
        where = f"{family}/{name}"
        if op is None:
            problems.append(f"{where}: operation not in operations.json")
            continue
        if family != "errors" and name not in spec["families"][family]:
            problems.append(f"{where}: operations.json lists {name} under family {op['family']}")
        if set(group["conventions"]) != set(op["conventions"]):
            problems.append(f"{where}: conventions {sorted(group['conventions'])} differ from operations.json's "
                            f"{sorted(op['conventions'])}")
        for test in group["tests"]:
            tag = f"{family}-{test['tcId']} ({name})"
            strict = test["result"] != "invalid"
            unknown = set(test["inputs"]) - set(op["data"]) - set(op.get("optional_data", ())) - set(op["scalars"])
            if unknown:
                problems.append(f"{tag}: inputs {sorted(unknown)} not in operations.json")
            outputs = {k for k in test["expected"] if k != "error"}
            if set(outputs) - set(op["outputs"]):
                problems.append(f"{tag}: outputs {sorted(set(outputs) - set(op['outputs']))} not in operations.json")
            if not strict:
                continue
            for key, value in group["conventions"].items():
                if key not in op["conventions"] or key not in spec["conventions"]:
                    continue  # reported once for the group
                shared = spec["conventions"][key]
                accepted = op["conventions"][key].get("values", shared.get("values"))
                if not _convention_ok(shared["type"], value) or (accepted is not None and value not in accepted):
                    problems.append(f"{tag}: convention {key}={value!r} is not accepted by operations.json")
            for data in op["data"]:
                if _json_kind(test["inputs"].get(data)) != "array":
                    problems.append(f"{tag}: data input {data} missing or not an array")
            for data in op.get("optional_data", ()):
                if data in test["inputs"] and _json_kind(test["inputs"][data]) != "array":
                    problems.append(f"{tag}: data input {data} not an array")
            for scalar in op["scalars"]:
                if scalar in test["inputs"] or scalar == "n_joints":
                    continue
                problems.append(f"{tag}: scalar input {scalar} missing")
            if test["result"] == "valid":
                required = {k for k, v in op["outputs"].items() if not v.get("optional")}
                if required - outputs:
                    problems.append(f"{tag}: outputs {sorted(required - outputs)} missing")
                for scalar, info in op["scalars"].items():
                    if scalar in test["inputs"]:
                        value = test["inputs"][scalar]
                        kinds = {"integer": ("integer",), "integers": ("integer", "list"), "real": ("real", "integer")}
                        if _json_kind(value) not in kinds[info["type"]]:
                            problems.append(f"{tag}: scalar input {scalar}={value!r} is not {info['type']}")
            for key in outputs & set(op["outputs"]):
                if not _output_ok(op["outputs"][key]["type"], test["expected"][key]):
                    problems.append(f"{tag}: output {key} is not of type {op['outputs'][key]['type']}")
    return problems
