"""Assembling one family file: groups by (operation, conventions), tcIds, notes."""

from __future__ import annotations

import json
from typing import Any

from ._config import CORPUS_VERSION, DPS, GENERATOR, MPMATH_VERSION, SCHEMA_NAME
from ._json import arr, num
from ._notes import NOTES


class Family:
    def __init__(self, name: str, header: list[str]):
        self.name = name
        self.header = header
        self.groups: list[dict] = []
        self.next_id = 1

    def group(self, operation: str, conventions: dict, method: str = "high-precision", note: str = "") -> dict:
        key = (operation, json.dumps(conventions, sort_keys=True))
        for g in self.groups:
            if g["_key"] == key:
                return g
        src = {"name": "dynval-golden", "version": CORPUS_VERSION, "generator": GENERATOR, "method": method,
               "mpmath": MPMATH_VERSION, "digits": DPS}
        if note:
            src["description"] = note
        g = {"_key": key, "operation": operation, "conventions": conventions, "source": src, "tests": []}
        self.groups.append(g)
        return g

    def add(self, operation: str, conventions: dict, comment: str, flags: list[str], inputs: dict,
            expected: dict, tolerance: dict | None = None, result: str = "valid", method: str = "high-precision",
            note: str = "") -> None:
        for f in flags:
            if f not in NOTES:
                raise KeyError(f)
        g = self.group(operation, conventions, method, note)
        inputs = {k: (num(v) if isinstance(v, float) else v) for k, v in inputs.items()}
        test = {"tcId": self.next_id, "comment": comment, "flags": flags, "inputs": inputs,
                "expected": expected}
        if result != "invalid":
            test["tolerance"] = {k: num(v) if not isinstance(v, dict) else v for k, v in (tolerance or {}).items()}
        test["result"] = result
        g["tests"].append(test)
        self.next_id += 1

    def document(self) -> dict:
        used: list[str] = []
        for g in self.groups:
            for t in g["tests"]:
                for f in t["flags"]:
                    if f not in used:
                        used.append(f)
        groups = [{k: v for k, v in g.items() if k != "_key"} for g in self.groups]
        return {
            "family": self.name,
            "schema": SCHEMA_NAME,
            "numberOfTests": sum(len(g["tests"]) for g in groups),
            "header": self.header,
            "notes": {f: NOTES[f] for f in sorted(used)},
            "testGroups": groups,
        }


def out(v: Any) -> Any:
    """Expected value: list -> (m,) array, mpf -> scalar."""
    if isinstance(v, list):
        return arr(v, [len(v)])
    return num(v)
