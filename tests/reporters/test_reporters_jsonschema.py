"""The small JSON Schema validator the report reader uses: each keyword, refs, refusals."""

from __future__ import annotations

from typing import Any

import pytest

from openair_conformance.reporters._jsonschema import (
    SchemaError,
    SchemaValidationError,
    errors,
    validate,
)

_SCHEMA: dict[str, Any] = {
    "$schema": "https://json-schema.org/draft/2020-12/schema",
    "type": "object",
    "required": ["n", "kind"],
    "additionalProperties": False,
    "properties": {
        "n": {"type": "integer", "minimum": 0, "maximum": 10},
        "kind": {"enum": ["a", "b"]},
        "fixed": {"const": 1},
        "name": {"type": "string", "minLength": 2, "pattern": "^[A-Z]+-[0-9]{3}$"},
        "items": {"type": "array", "minItems": 1, "items": {"$ref": "#/$defs/item"}},
        "map": {
            "type": "object",
            "propertyNames": {"pattern": "^[a-z]+$"},
            "additionalProperties": {"type": ["number", "null"]},
        },
    },
    "$defs": {"item": {"type": "boolean"}},
}


@pytest.mark.parametrize(
    "instance",
    [
        {"n": 0, "kind": "a"},
        {"n": 10, "kind": "b", "fixed": 1.0, "name": "AB-123"},
        {"n": 3.0, "kind": "a", "items": [True, False], "map": {"x": 1.5, "y": None}},
    ],
)
def test_valid_instances_pass(instance: Any) -> None:
    assert errors(instance, _SCHEMA) == []
    validate(instance, _SCHEMA)


@pytest.mark.parametrize(
    ("instance", "where"),
    [
        ([], "/: list is not of type object"),
        ({"kind": "a"}, "/: 'n' is missing"),
        ({"n": 1, "kind": "a", "extra": 1}, "/: unexpected property 'extra'"),
        ({"n": True, "kind": "a"}, "/n: bool is not of type integer"),
        ({"n": 1.5, "kind": "a"}, "/n: float is not of type integer"),
        ({"n": -1, "kind": "a"}, "/n: -1 is less than 0"),
        ({"n": 11, "kind": "a"}, "/n: 11 is more than 10"),
        ({"n": 1, "kind": "c"}, "/kind: 'c' is not one of"),
        ({"n": 1, "kind": "a", "fixed": True}, "/fixed: True is not 1"),
        ({"n": 1, "kind": "a", "name": "A"}, "/name: shorter than 2"),
        ({"n": 1, "kind": "a", "name": "AB-12"}, "/name: 'AB-12' does not match"),
        ({"n": 1, "kind": "a", "items": []}, "/items: fewer than 1 items"),
        ({"n": 1, "kind": "a", "items": [1]}, "/items/0: int is not of type boolean"),
        ({"n": 1, "kind": "a", "map": {"X": 1}}, "/map/X: 'X' does not match"),
        ({"n": 1, "kind": "a", "map": {"x": "1"}}, "/map/x: str is not of type number or null"),
    ],
)
def test_violations_are_found_with_their_path(instance: Any, where: str) -> None:
    problems = errors(instance, _SCHEMA)
    assert any(p.startswith(where) for p in problems), problems
    with pytest.raises(SchemaValidationError):
        validate(instance, _SCHEMA)


def test_every_violation_is_listed() -> None:
    problems = errors({"n": -1, "kind": "z", "extra": 0}, _SCHEMA)
    assert len(problems) == 3
    with pytest.raises(SchemaValidationError) as caught:
        validate({"n": -1, "kind": "z", "extra": 0}, _SCHEMA)
    assert caught.value.problems == problems


@pytest.mark.parametrize(
    "schema",
    [
        {"oneOf": [{"type": "string"}]},
        {"type": "text"},
        {"$ref": "https://example.com/other.json"},
        {"$ref": "#/$defs/missing"},
    ],
)
def test_what_the_validator_does_not_understand_is_refused(schema: dict[str, Any]) -> None:
    with pytest.raises(SchemaError):
        errors("x", schema)


def test_boolean_schemas() -> None:
    assert errors(1, {"properties": {"a": False}}) == []
    assert errors({"a": 1}, {"properties": {"a": False}}) == ["/a: no value is allowed here"]
    assert errors({"a": 1}, {"properties": {"a": True}}) == []
