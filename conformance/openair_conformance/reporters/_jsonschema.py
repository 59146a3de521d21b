"""A small JSON Schema (2020-12) validator for the subset the report schema uses.

The `jsonschema` package is not a dependency of the kit, and reading a report back (the
comparison page, the tests) must check it against `schemas/report.schema.json`. The subset:
`$ref` (to `#/$defs/…` only), `type`, `enum`, `const`, `properties`, `required`,
`additionalProperties`, `propertyNames`, `items`, `minItems`, `minimum`, `maximum`, `minLength`
and `pattern` (Python `re.search`). A schema using any other assertion keyword is refused with
`SchemaError`, so an extension of the schema cannot be silently ignored.
"""

from __future__ import annotations

import math
import re
from collections.abc import Callable, Mapping
from typing import Any

__all__ = ["SchemaError", "SchemaValidationError", "errors", "validate"]

_ANNOTATIONS = frozenset(
    {"$schema", "$id", "$defs", "$comment", "title", "description", "examples", "default"}
)


class SchemaError(ValueError):
    """The schema uses something this validator does not understand."""


class SchemaValidationError(ValueError):
    """The instance does not conform; `problems` lists every violation (path: what)."""

    def __init__(self, problems: list[str]) -> None:
        shown = "; ".join(problems[:5]) + (
            f"; … {len(problems) - 5} more" if len(problems) > 5 else ""
        )
        super().__init__(shown)
        self.problems = problems


def _is_type(value: Any, name: str) -> bool:
    if name == "integer":
        if isinstance(value, bool):
            return False
        return isinstance(value, int) or (isinstance(value, float) and value.is_integer())
    checks: dict[str, Callable[[Any], bool]] = {
        "null": lambda v: v is None,
        "boolean": lambda v: isinstance(v, bool),
        "number": lambda v: isinstance(v, int | float) and not isinstance(v, bool),
        "string": lambda v: isinstance(v, str),
        "array": lambda v: isinstance(v, list),
        "object": lambda v: isinstance(v, dict),
    }
    if name not in checks:
        raise SchemaError(f"unknown type {name!r}")
    return checks[name](value)


def _same(a: Any, b: Any) -> bool:
    """JSON equality: 1 == 1.0, but True is not 1."""
    if isinstance(a, bool) or isinstance(b, bool):
        return type(a) is type(b) and a == b
    return bool(a == b)


class _Validator:
    def __init__(self, root: Mapping[str, Any]) -> None:
        self.root = root
        self.problems: list[str] = []

    def resolve(self, ref: str) -> Mapping[str, Any]:
        if not ref.startswith("#/$defs/"):
            raise SchemaError(f"only #/$defs/ references are supported, not {ref!r}")
        target = self.root.get("$defs", {}).get(ref[len("#/$defs/") :])
        if not isinstance(target, Mapping):
            raise SchemaError(f"unresolvable reference {ref!r}")
        return target

    def fail(self, path: str, text: str) -> None:
        self.problems.append(f"{path or '/'}: {text}")

    def check(self, value: Any, schema: Mapping[str, Any] | bool, path: str) -> None:
        if schema is True:
            return
        if schema is False:
            self.fail(path, "no value is allowed here")
            return
        for keyword, argument in schema.items():
            if keyword in _ANNOTATIONS:
                continue
            handler = _KEYWORDS.get(keyword)
            if handler is None:
                raise SchemaError(f"unsupported keyword {keyword!r}")
            handler(self, value, argument, schema, path)


def _k_ref(v: _Validator, value: Any, arg: Any, schema: Mapping[str, Any], path: str) -> None:
    v.check(value, v.resolve(arg), path)


def _k_type(v: _Validator, value: Any, arg: Any, schema: Mapping[str, Any], path: str) -> None:
    names = [arg] if isinstance(arg, str) else list(arg)
    if not any(_is_type(value, name) for name in names):
        v.fail(path, f"{type(value).__name__} is not of type {' or '.join(names)}")


def _k_enum(v: _Validator, value: Any, arg: Any, schema: Mapping[str, Any], path: str) -> None:
    if not any(_same(value, option) for option in arg):
        v.fail(path, f"{value!r} is not one of {arg!r}")


def _k_const(v: _Validator, value: Any, arg: Any, schema: Mapping[str, Any], path: str) -> None:
    if not _same(value, arg):
        v.fail(path, f"{value!r} is not {arg!r}")


def _k_properties(
    v: _Validator, value: Any, arg: Any, schema: Mapping[str, Any], path: str
) -> None:
    if isinstance(value, dict):
        for name, sub in arg.items():
            if name in value:
                v.check(value[name], sub, f"{path}/{name}")


def _k_required(v: _Validator, value: Any, arg: Any, schema: Mapping[str, Any], path: str) -> None:
    if isinstance(value, dict):
        for name in arg:
            if name not in value:
                v.fail(path, f"{name!r} is missing")


def _k_additional(
    v: _Validator, value: Any, arg: Any, schema: Mapping[str, Any], path: str
) -> None:
    if isinstance(value, dict):
        known = schema.get("properties", {})
        for name in value:
            if name not in known:
                if arg is False:
                    v.fail(path, f"unexpected property {name!r}")
                else:
                    v.check(value[name], arg, f"{path}/{name}")


def _k_names(v: _Validator, value: Any, arg: Any, schema: Mapping[str, Any], path: str) -> None:
    if isinstance(value, dict):
        for name in value:
            v.check(name, arg, f"{path}/{name}")


def _k_items(v: _Validator, value: Any, arg: Any, schema: Mapping[str, Any], path: str) -> None:
    if isinstance(value, list):
        for index, item in enumerate(value):
            v.check(item, arg, f"{path}/{index}")


def _k_min_items(v: _Validator, value: Any, arg: Any, schema: Mapping[str, Any], path: str) -> None:
    if isinstance(value, list) and len(value) < arg:
        v.fail(path, f"fewer than {arg} items")


def _number(value: Any) -> bool:
    return isinstance(value, int | float) and not isinstance(value, bool)


def _k_minimum(v: _Validator, value: Any, arg: Any, schema: Mapping[str, Any], path: str) -> None:
    if _number(value) and (math.isnan(value) or value < arg):
        v.fail(path, f"{value!r} is less than {arg!r}")


def _k_maximum(v: _Validator, value: Any, arg: Any, schema: Mapping[str, Any], path: str) -> None:
    if _number(value) and (math.isnan(value) or value > arg):
        v.fail(path, f"{value!r} is more than {arg!r}")


def _k_min_length(
    v: _Validator, value: Any, arg: Any, schema: Mapping[str, Any], path: str
) -> None:
    if isinstance(value, str) and len(value) < arg:
        v.fail(path, f"shorter than {arg} characters")


def _k_pattern(v: _Validator, value: Any, arg: Any, schema: Mapping[str, Any], path: str) -> None:
    if isinstance(value, str) and re.search(arg, value) is None:
        v.fail(path, f"{value!r} does not match {arg!r}")


_Handler = Callable[[_Validator, Any, Any, Mapping[str, Any], str], None]
_KEYWORDS: dict[str, _Handler] = {
    "$ref": _k_ref,
    "type": _k_type,
    "enum": _k_enum,
    "const": _k_const,
    "properties": _k_properties,
    "required": _k_required,
    "additionalProperties": _k_additional,
    "propertyNames": _k_names,
    "items": _k_items,
    "minItems": _k_min_items,
    "minimum": _k_minimum,
    "maximum": _k_maximum,
    "minLength": _k_min_length,
    "pattern": _k_pattern,
}


def errors(instance: Any, schema: Mapping[str, Any]) -> list[str]:
    """Return every violation of `schema` by `instance` as "json/pointer: what" (empty: valid)."""
    validator = _Validator(schema)
    validator.check(instance, schema, "")
    return validator.problems


def validate(instance: Any, schema: Mapping[str, Any]) -> None:
    """Raise SchemaValidationError unless `instance` conforms to `schema`."""
    problems = errors(instance, schema)
    if problems:
        raise SchemaValidationError(problems)
