"""The condition language of plans (OA-WM-10): a tokenizer and a recursive-descent parser.

Grammar (spec 16.4)::

    condition   = disjunction
    disjunction = conjunction { "or" conjunction }
    conjunction = negation { "and" negation }
    negation    = "not" negation | primary
    primary     = "(" condition ")" | "true" | "false" | comparison
    comparison  = operand op operand
    operand     = field | number | string | ref
    field       = name "." attribute "." ( "value" | "accuracy" | "confidence" | "timestamp" )

An object name may contain dots (`R1.Pose.x.value`: object `R1.Pose`); the last two segments
are always the attribute and the field. Nothing is ever passed to `eval`. A condition is
evaluated against a lookup of packets: a comparison with a missing or stale attribute, or of
operands of different kinds, is false (OA-WM-10).
"""

from __future__ import annotations

import math
import re
from collections.abc import Callable
from dataclasses import dataclass

from openair.protocol.errors import ContentInvalidError
from openair_worldmodel.packets import Packet, Ref, Value, value_kind

__all__ = [
    "FIELDS",
    "MAX_CONDITION_CHARS",
    "MAX_CONDITION_DEPTH",
    "And",
    "Compare",
    "Condition",
    "ConditionSyntaxError",
    "Const",
    "Field",
    "Literal",
    "Lookup",
    "Not",
    "Or",
    "evaluate",
    "fields_of",
    "parse_condition",
    "to_text",
    "to_tree",
]

FIELDS = ("value", "accuracy", "confidence", "timestamp")
OPERATORS = ("==", "!=", "<=", ">=", "<", ">")
KEYWORDS = ("and", "or", "not", "true", "false")
MAX_CONDITION_CHARS = 4096  # OA-WM-10: bounded input
MAX_CONDITION_DEPTH = 32

_TOKEN = re.compile(
    r"""(?P<space>\s+)
      | (?P<number>-?[0-9]+(?:\.[0-9]+)?(?:[eE][+-]?[0-9]+)?)
      | (?P<string>"(?:[^"\\]|\\["\\])*")
      | (?P<ref>@[A-Za-z_][A-Za-z0-9_:-]*(?:\.[A-Za-z_][A-Za-z0-9_:-]*)*)
      | (?P<name>[A-Za-z_][A-Za-z0-9_:-]*)
      | (?P<op>==|!=|<=|>=|<|>)
      | (?P<punct>[().])""",
    re.VERBOSE,
)


class ConditionSyntaxError(ContentInvalidError):
    """A condition that is not a sentence of the grammar (OA-WM-10); `position` is 0-based."""

    def __init__(self, detail: str, position: int) -> None:
        super().__init__(f"condition: {detail} at {position}")
        self.position = position


@dataclass(frozen=True, slots=True, kw_only=True)
class Field:
    """`object.attribute.field`: one field of an attribute's packet."""

    object: str
    attribute: str
    field: str


@dataclass(frozen=True, slots=True, kw_only=True)
class Literal:
    """A number, string or reference literal."""

    value: Value


Operand = Field | Literal


@dataclass(frozen=True, slots=True, kw_only=True)
class Compare:
    """`left op right`."""

    op: str
    left: Operand
    right: Operand


@dataclass(frozen=True, slots=True, kw_only=True)
class Const:
    """`true` or `false`."""

    value: bool


@dataclass(frozen=True, slots=True, kw_only=True)
class Not:
    """`not operand`."""

    operand: Condition


@dataclass(frozen=True, slots=True, kw_only=True)
class And:
    """A conjunction of two or more conditions."""

    operands: tuple[Condition, ...]


@dataclass(frozen=True, slots=True, kw_only=True)
class Or:
    """A disjunction of two or more conditions."""

    operands: tuple[Condition, ...]


Condition = Compare | Const | Not | And | Or
Lookup = Callable[[str, str], Packet | None]


@dataclass(frozen=True, slots=True)
class _Token:
    kind: str
    text: str
    pos: int


def _tokenize(text: str) -> list[_Token]:
    if len(text) > MAX_CONDITION_CHARS:
        raise ConditionSyntaxError(f"longer than {MAX_CONDITION_CHARS} characters", 0)
    tokens: list[_Token] = []
    pos = 0
    while pos < len(text):
        match = _TOKEN.match(text, pos)
        if match is None:
            raise ConditionSyntaxError(f"unexpected character {text[pos]!r}", pos)
        kind = match.lastgroup or ""
        if kind != "space":
            tokens.append(_Token(kind, match.group(), pos))
        pos = match.end()
    tokens.append(_Token("end", "", len(text)))
    return tokens


class _Parser:
    def __init__(self, text: str) -> None:
        self.tokens = _tokenize(text)
        self.i = 0
        self.depth = 0

    def peek(self) -> _Token:
        return self.tokens[self.i]

    def take(self) -> _Token:
        token = self.tokens[self.i]
        self.i += 1
        return token

    def fail(self, what: str) -> ConditionSyntaxError:
        token = self.peek()
        found = "end of input" if token.kind == "end" else repr(token.text)
        return ConditionSyntaxError(f"expected {what}, found {found}", token.pos)

    def is_word(self, word: str) -> bool:
        token = self.peek()
        return token.kind == "name" and token.text == word

    def enter(self) -> None:
        self.depth += 1
        if self.depth > MAX_CONDITION_DEPTH:
            raise ConditionSyntaxError(f"nested deeper than {MAX_CONDITION_DEPTH}", self.peek().pos)

    def condition(self) -> Condition:
        self.enter()
        try:
            return self.junction("or", Or, self.conjunction)
        finally:
            self.depth -= 1

    def conjunction(self) -> Condition:
        return self.junction("and", And, self.negation)

    def junction(
        self, word: str, kind: type[And] | type[Or], item: Callable[[], Condition]
    ) -> Condition:
        parts = [item()]
        while self.is_word(word):
            self.take()
            parts.append(item())
        return parts[0] if len(parts) == 1 else kind(operands=tuple(parts))

    def negation(self) -> Condition:
        if self.is_word("not"):
            self.take()
            self.depth += 1
            if self.depth > MAX_CONDITION_DEPTH:
                raise ConditionSyntaxError(
                    f"nested deeper than {MAX_CONDITION_DEPTH}", self.peek().pos
                )
            try:
                return Not(operand=self.negation())
            finally:
                self.depth -= 1
        return self.primary()

    def primary(self) -> Condition:
        token = self.peek()
        if token.kind == "punct" and token.text == "(":
            self.take()
            inner = self.condition()
            if not (self.peek().kind == "punct" and self.peek().text == ")"):
                raise self.fail("')'")
            self.take()
            return inner
        if self.is_word("true") or self.is_word("false"):
            return Const(value=self.take().text == "true")
        left = self.operand()
        if self.peek().kind != "op":
            raise self.fail("a comparison operator")
        op = self.take().text
        return Compare(op=op, left=left, right=self.operand())

    def operand(self) -> Operand:
        token = self.peek()
        if token.kind == "number":
            self.take()
            number = float(token.text)
            if not math.isfinite(number):
                raise ConditionSyntaxError("number out of range", token.pos)
            return Literal(value=number)
        if token.kind == "string":
            self.take()
            return Literal(value=re.sub(r"\\([\"\\])", r"\1", token.text[1:-1]))
        if token.kind == "ref":
            self.take()
            return Literal(value=Ref(name=token.text[1:]))
        if token.kind == "name" and token.text not in KEYWORDS:
            return self.field()
        raise self.fail("a field or a literal")

    def field(self) -> Field:
        start = self.peek().pos
        names = [self.take().text]
        while self.peek().kind == "punct" and self.peek().text == ".":
            self.take()
            if self.peek().kind != "name":
                raise self.fail("a name after '.'")
            names.append(self.take().text)
        if len(names) < 3:
            raise ConditionSyntaxError("a field is object.attribute.field", start)
        if names[-1] not in FIELDS:
            raise ConditionSyntaxError(f"unknown field {names[-1]!r}", start)
        return Field(object=".".join(names[:-2]), attribute=names[-2], field=names[-1])


def parse_condition(text: str) -> Condition:
    """Parse a condition (OA-WM-10); raise ConditionSyntaxError (CONTENT_INVALID) if invalid."""
    parser = _Parser(text)
    result = parser.condition()
    if parser.peek().kind != "end":
        raise parser.fail("end of input")
    return result


# -- printing ------------------------------------------------------------------------------------


def _literal_text(value: Value) -> str:
    if isinstance(value, Ref):
        return "@" + value.name
    if isinstance(value, str):
        return '"' + value.replace("\\", "\\\\").replace('"', '\\"') + '"'
    return repr(float(value))


def _operand_text(operand: Operand) -> str:
    if isinstance(operand, Field):
        return f"{operand.object}.{operand.attribute}.{operand.field}"
    return _literal_text(operand.value)


def to_text(cond: Condition) -> str:
    """Print a condition so that `parse_condition(to_text(c)) == c` (fully parenthesised)."""
    if isinstance(cond, Const):
        return "true" if cond.value else "false"
    if isinstance(cond, Compare):
        return f"{_operand_text(cond.left)} {cond.op} {_operand_text(cond.right)}"
    if isinstance(cond, Not):
        return f"not ({to_text(cond.operand)})"
    word = " and " if isinstance(cond, And) else " or "
    return word.join(f"({to_text(part)})" for part in cond.operands)


def _operand_tree(operand: Operand) -> list[object]:
    if isinstance(operand, Field):
        return ["field", operand.object, operand.attribute, operand.field]
    value = operand.value
    return [value_kind(value), value.name if isinstance(value, Ref) else value]


def to_tree(cond: Condition) -> list[object] | bool:
    """Return the parse tree as JSON-ready lists (the form of spec/vectors/worldmodel)."""
    if isinstance(cond, Const):
        return cond.value
    if isinstance(cond, Compare):
        return [cond.op, _operand_tree(cond.left), _operand_tree(cond.right)]
    if isinstance(cond, Not):
        return ["not", to_tree(cond.operand)]
    word = "and" if isinstance(cond, And) else "or"
    return [word, *(to_tree(part) for part in cond.operands)]


# -- evaluation ----------------------------------------------------------------------------------


def _operand_value(operand: Operand, lookup: Lookup) -> Value | None:
    if isinstance(operand, Literal):
        return operand.value
    packet = lookup(operand.object, operand.attribute)
    if packet is None:
        return None
    if operand.field == "value":
        return packet.value
    return float(getattr(packet, operand.field))


def _compare(op: str, left: Value, right: Value) -> bool:
    if value_kind(left) != value_kind(right):
        return False  # OA-WM-10: operands of different kinds never compare
    if isinstance(left, Ref) or isinstance(right, Ref):
        if op not in ("==", "!="):
            return False
        return (left == right) == (op == "==")
    a, b = left, right
    table: dict[str, Callable[[], bool]] = {
        "==": lambda: a == b,
        "!=": lambda: a != b,
        "<": lambda: a < b,  # type: ignore[operator]
        "<=": lambda: a <= b,  # type: ignore[operator]
        ">": lambda: a > b,  # type: ignore[operator]
        ">=": lambda: a >= b,  # type: ignore[operator]
    }
    return table[op]()


def evaluate(cond: Condition, lookup: Lookup) -> bool:
    """Evaluate `cond` with packets from `lookup(object, attribute)` (OA-WM-10)."""
    if isinstance(cond, Const):
        return cond.value
    if isinstance(cond, Compare):
        left = _operand_value(cond.left, lookup)
        right = _operand_value(cond.right, lookup)
        return left is not None and right is not None and _compare(cond.op, left, right)
    if isinstance(cond, Not):
        return not evaluate(cond.operand, lookup)
    if isinstance(cond, And):
        return all(evaluate(part, lookup) for part in cond.operands)
    return any(evaluate(part, lookup) for part in cond.operands)


def fields_of(cond: Condition) -> frozenset[tuple[str, str]]:
    """Return the (object, attribute) pairs a condition reads."""
    if isinstance(cond, Compare):
        return frozenset(
            (o.object, o.attribute) for o in (cond.left, cond.right) if isinstance(o, Field)
        )
    if isinstance(cond, Not):
        return fields_of(cond.operand)
    if isinstance(cond, (And, Or)):
        return frozenset().union(*(fields_of(part) for part in cond.operands))
    return frozenset()
