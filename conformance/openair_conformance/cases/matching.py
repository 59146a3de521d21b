"""Type and pattern cases (spec section 5): the whole wildcard vector table, over the wire.

Every row of `spec/vectors/wildcards/wildcards.json` is checked, grouped so that a case needs one
module per pattern, one post per type and one barrier per module: the patterns of a group are
registered as triggers, every type of the group is posted, and each row's answer is read off the
wakeups (trigger) and off a retrieve with the same pattern (retrieve, OA-MATCH-8).

Isolation: every pattern and type gets the case's prefix `<type_prefix>.` in front. Because the
prefix is literal text that ends in a dot, prefixing preserves each row's answer: a pattern
`*.A` becomes `Conf.R1a2b.MATCH001.*.A`, which matches `Conf.R1a2b.MATCH001.X.A` exactly when
`*.A` matches `X.A`; empty segments stay empty segments. Two kinds of rows cannot survive the
prefix and are handled otherwise: the OA-TYPE-4 length and segment rows (the prefix adds bytes
and segments; MATCH-009 builds types at the server's advertised limits instead) and rows with a
character XML 1.0 cannot carry (U+0000), which no peer can send at all (OA-MSG-14).
"""

from __future__ import annotations

import asyncio
import json
from collections import defaultdict
from dataclasses import dataclass
from functools import cache

from openair.catalogue import DEFAULT_CATALOGUE
from openair_conformance.cases._common import (
    check_error,
    esc,
    retrieved,
    setup_subscribe,
    trigger_ids,
    triggers_xml,
)
from openair_conformance.harness import CaseContext, TestModule
from openair_conformance.registry import case

_VECTORS = DEFAULT_CATALOGUE.parent / "vectors" / "wildcards" / "wildcards.json"
_MAX_REPORTED = 25
_XML_FORBIDDEN = {chr(c) for c in range(0x20) if chr(c) not in "\t\n\r"} | {"\ufffe", "\uffff"}


@dataclass(frozen=True, slots=True)
class Row:
    """One (pattern, type) row of the vector table, with Psyclone's observed answers."""

    pattern: str
    type: str
    expected: str
    psyclone: frozenset[str]
    source: str

    @property
    def group(self) -> str:
        """`run 1`, `run 2`, `run 3` (triggers and retrieves) or `own`."""
        for run in ("run 1", "run 2", "run 3"):
            if run in self.source:
                return run
        return "own"

    @property
    def deviates(self) -> bool:
        """Whether Psyclone answers differently (appendix A, DEV-1 to DEV-4)."""
        return self.psyclone != frozenset({self.expected})


def _sendable(text: str) -> bool:
    return not any(ch in _XML_FORBIDDEN or "\ud800" <= ch <= "\udfff" for ch in text)


def _limit_row(row: Row) -> bool:
    return "OA-TYPE-4" in row.source or any(
        len(s.encode()) > 200 or s.count(".") > 25 for s in (row.pattern, row.type)
    )


@cache
def vector_rows() -> tuple[Row, ...]:
    """Every distinct (pattern, type) row that can be sent with a prefix, in file order."""
    data = json.loads(_VECTORS.read_text(encoding="utf-8"))
    seen: dict[tuple[str, str], Row] = {}
    observed: dict[tuple[str, str], set[str]] = defaultdict(set)
    for item in data["rows"]:
        key = (item["pattern"], item["type"])
        observed[key].add(item["psyclone"])
        seen.setdefault(key, Row(key[0], key[1], item["expected"], frozenset(), item["source"]))
    rows = []
    for key, row in seen.items():
        full = Row(row.pattern, row.type, row.expected, frozenset(observed[key]), row.source)
        if _sendable(full.pattern) and _sendable(full.type) and not _limit_row(full):
            rows.append(full)
    return tuple(rows)


def _select(*, groups: tuple[str, ...], kind: str, deviating: bool | None = None) -> list[Row]:
    found = []
    for row in vector_rows():
        if row.group not in groups:
            continue
        if kind == "valid" and row.expected not in ("match", "nomatch"):
            continue
        if kind != "valid" and row.expected != kind:
            continue
        if deviating is not None and row.deviates != deviating:
            continue
        found.append(row)
    return found


# -- the engine ------------------------------------------------------------------------------


async def _subscribers(ctx: CaseContext, patterns: list[str]) -> dict[str, TestModule]:
    """Open one module per pattern and register the prefixed pattern as its only trigger."""
    modules = await asyncio.gather(*(ctx.module(f"P{i}") for i in range(len(patterns))))
    refused = []
    for pattern, module in zip(patterns, modules, strict=True):
        reply = await module.subscribe(triggers_xml(ctx.type(pattern)))
        if reply.type != "RECEIVE_ACCEPT":
            refused.append(f"{pattern!r}: {reply.type} {reply.content!r}")
    ctx.check(
        not refused,
        f"valid patterns were refused: {'; '.join(refused[:_MAX_REPORTED])}",
        expected="every valid pattern is accepted (OA-MATCH-7 refuses only invalid ones)",
    )
    return dict(zip(patterns, modules, strict=True))


async def _post_types(ctx: CaseContext, poster: TestModule, types: list[str]) -> dict[str, str]:
    """Post each prefixed type to WB1; return message id → unprefixed type."""
    by_id: dict[str, str] = {}
    for type_ in types:
        await poster.post("WB1", ctx.type(type_), f"row type {type_!r}")
        assert poster.last_sent is not None
        by_id[poster.last_sent.id] = type_
    return by_id


async def _woken(modules: dict[str, TestModule], by_id: dict[str, str]) -> dict[str, list[str]]:
    """Barrier every module; return pattern → the posted types that woke it (with repeats)."""
    pairs = list(modules.items())
    results = await asyncio.gather(*(module.barrier() for _, module in pairs))
    return {
        pattern: [by_id[i] for i in trigger_ids(wakeups) if i in by_id]
        for (pattern, _), wakeups in zip(pairs, results, strict=True)
    }


async def _retrieved(
    ctx: CaseContext, poster: TestModule, patterns: list[str], by_id: dict[str, str]
) -> dict[str, set[str]]:
    """Retrieve with each prefixed pattern (latest=0); return pattern → posted types returned."""
    found: dict[str, set[str]] = {}
    for pattern in patterns:
        spec = f'<retrieve from="WB1" type="{esc(ctx.type(pattern))}"><latest>0</latest></retrieve>'
        copies = await retrieved(ctx, poster, spec, req="OA-MATCH-8")
        found[pattern] = {by_id[m.id] for m in copies if m.id in by_id}
    return found


def _judge(
    rows: list[Row], woken: dict[str, list[str]], returned: dict[str, set[str]]
) -> list[str]:
    problems = []
    for row in rows:
        want = row.expected == "match"
        count = woken[row.pattern].count(row.type)
        got_trigger = count > 0
        got_retrieve = row.type in returned[row.pattern]
        if got_trigger != want or got_retrieve != want or count > 1:
            problems.append(
                f"pattern {row.pattern!r} type {row.type!r}: expected {row.expected}; "
                f"trigger woke {count} time(s), "
                f"retrieve {'returned' if got_retrieve else 'omitted'} it"
            )
    return problems


async def check_rows(ctx: CaseContext, rows: list[Row], *, expected: str) -> None:
    """Register every pattern of `rows`, post every type, and compare both matchers with rows."""
    patterns = sorted({r.pattern for r in rows})
    types = sorted({r.type for r in rows})
    ctx.note(f"{len(rows)} rows: {len(patterns)} patterns x {len(types)} types")
    modules = await _subscribers(ctx, patterns)
    poster = await ctx.module("Poster", bind=False)
    by_id = await _post_types(ctx, poster, types)
    woken = await _woken(modules, by_id)
    returned = await _retrieved(ctx, poster, patterns, by_id)
    problems = _judge(rows, woken, returned)
    ctx.check(
        not problems,
        f"{len(problems)} of {len(rows)} rows disagree: " + "; ".join(problems[:_MAX_REPORTED]),
        expected=expected,
    )


# -- valid rows on which the spec and Psyclone agree -----------------------------------------

_AGREE = (
    "trigger and retrieve answers as in the vector table: one wakeup per matching type, none "
    "for the others; the retrieve returns exactly the matching types"
)
_AGREE_REQS = (
    "OA-MATCH-1",
    "OA-MATCH-2",
    "OA-MATCH-3",
    "OA-MATCH-4",
    "OA-MATCH-5",
    "OA-MATCH-8",
    "OA-TRIG-1",
    "OA-TYPE-2",
)


@case(
    id="MATCH-001",
    title="Vector rows of Psyclone run 1 (19 patterns x 19 types) match as the table says",
    section="5.2",
    requirements=_AGREE_REQS,
    allowed=(_AGREE, "phase updates before the wakeups (ignored)"),
)
async def vectors_run1(ctx: CaseContext) -> None:
    """Check the run-1 rows on which OpenAIR 1.0 and Psyclone agree, as triggers and retrieves.

    Catches: prefix matching (`Test.Ping` waking for `Test.Ping.A`), case-sensitive matching,
    a `*` that stops at dots, a missing subtree-root rule, and a retrieve matcher that differs
    from the trigger matcher.
    """
    await check_rows(
        ctx, _select(groups=("run 1",), kind="valid", deviating=False), expected=_AGREE
    )


@case(
    id="MATCH-002",
    title="Vector rows of Psyclone run 2 (10 patterns x 23 types) match as the table says",
    section="5.2",
    requirements=_AGREE_REQS,
    allowed=(_AGREE,),
)
async def vectors_run2(ctx: CaseContext) -> None:
    """Check the run-2 rows (several stars, leading stars, `*.*`) on which both agree.

    Catches: stars matched greedily without backtracking (`Y*X*` against `YZX`), a leading star
    treated as "ends with", `*.*` matching a type without a dot.
    """
    await check_rows(
        ctx, _select(groups=("run 2",), kind="valid", deviating=False), expected=_AGREE
    )


@case(
    id="MATCH-003",
    title="Vector rows of Psyclone run 3 (triggers and retrieves) match as the table says",
    section="5.2",
    requirements=_AGREE_REQS,
    allowed=(_AGREE,),
)
async def vectors_run3(ctx: CaseContext) -> None:
    """Check the run-3 rows (observed as triggers and as retrieves) on which both agree.

    Catches: patterns whose literal parts overlap (`A*C*B`, `AB*BC`) answered wrongly, and a
    retrieve matcher that differs from the trigger matcher (OA-MATCH-8).
    """
    await check_rows(
        ctx, _select(groups=("run 3",), kind="valid", deviating=False), expected=_AGREE
    )


@case(
    id="MATCH-004",
    title="The kit's own vector rows (case folding, colons, subtree root, literals) match",
    section="5.2",
    requirements=(*_AGREE_REQS, "OA-MATCH-6"),
    allowed=(_AGREE,),
)
async def vectors_own(ctx: CaseContext) -> None:
    """Check the hand-written rows: ASCII-only case folding, `:` in segments, `?` and `[ ]` as
    literals, the subtree-root rule applied once, many-star patterns.

    Catches: Unicode case folding (`Straße` matching `STRASSE`), `?` or `[AB]` treated as glob
    syntax, the root rule applied to `A.*.*` twice, regex metacharacters left unescaped.
    """
    await check_rows(ctx, _select(groups=("own",), kind="valid"), expected=_AGREE)


@case(
    id="MATCH-005",
    title="Rows where Psyclone 1.1.7 deviates (DEV-1 to DEV-4) match as OpenAIR 1.0 says",
    section="5.2",
    requirements=("OA-MATCH-6", "OA-MATCH-3", "OA-MATCH-2", "OA-MATCH-8"),
    allowed=("the OpenAIR 1.0 answer of each row, for triggers and retrieves",),
)
async def vectors_deviations(ctx: CaseContext) -> None:
    """Check every observed row on which Psyclone answered differently from the spec.

    Catches: Psyclone's prefix quirk (`Test.Ping.*` matching `Test`), the leading-star quirk,
    overlapping prefix and suffix (`Test.*.A` matching `Test.A`) and the first-occurrence suffix
    test (`*.A` not matching `X.A.A`).
    """
    rows = _select(groups=("run 1", "run 2", "run 3"), kind="valid", deviating=True)
    await check_rows(ctx, rows, expected="the OpenAIR 1.0 column of the table (OA-MATCH-6)")


# -- invalid types and patterns --------------------------------------------------------------


@case(
    id="MATCH-006",
    title="Posts whose type is invalid are refused TYPE_INVALID, not stored and wake no one",
    section="5.1",
    requirements=("OA-TYPE-1", "OA-TYPE-3", "OA-WB-3"),
    allowed=("RECEIVE_ERROR with content 'TYPE_INVALID: detail' for each invalid type",),
)
async def invalid_types(ctx: CaseContext) -> None:
    """Register `<prefix>.*`, post every invalid-type row's type (empty segments, white space,
    control characters, `*`), then check the refusals, the barrier and a retrieve.

    Catches: a server that stores `Test.Ping.` or `A*B` (Psyclone, DEV-5), one that refuses
    with the wrong condition, and one that refuses but still wakes or stores.
    """
    types = sorted(
        {r.type for r in _select(groups=("run 1", "run 2", "run 3", "own"), kind="invalid-type")}
    )
    watcher = await ctx.module("Watch")
    await setup_subscribe(watcher, triggers_xml(ctx.type("*")))
    poster = await ctx.module("Poster", bind=False)
    ids = set()
    for type_ in types:
        reply = await poster.post("WB1", ctx.type(type_), "invalid", check=False)
        check_error(
            ctx, reply, names=("TYPE_INVALID",), what=f"the post of type {type_!r}", req="OA-TYPE-3"
        )
        assert poster.last_sent is not None
        ids.add(poster.last_sent.id)
    woken = [i for i in trigger_ids(await watcher.barrier()) if i in ids]
    ctx.check(not woken, f"{len(woken)} refused post(s) woke a subscriber", expected="OA-WB-3")
    spec = f'<retrieve from="WB1" type="{esc(ctx.type("*"))}"><latest>0</latest></retrieve>'
    stored = [m.type for m in await retrieved(ctx, poster, spec) if m.id in ids]
    ctx.check(
        not stored, f"refused posts were stored: {stored}", expected="nothing stored (OA-WB-3)"
    )


def _invalid_patterns() -> list[str]:
    return sorted({r.pattern for r in vector_rows() if r.expected == "invalid-pattern"})


@case(
    id="MATCH-007",
    title="A registration with an invalid pattern is refused PATTERN_INVALID and changes nothing",
    section="5.2",
    requirements=("OA-MATCH-7", "OA-REG-8"),
    allowed=(
        "RECEIVE_ERROR with content 'PATTERN_INVALID: detail'; the earlier registration stays",
    ),
)
async def invalid_trigger_patterns(ctx: CaseContext) -> None:
    """Register `<prefix>.Keep`; then, for each invalid-pattern row, try a registration with a
    valid trigger followed by the invalid one. Post Keep and the valid types: only Keep wakes.

    Catches: `**`, empty segments or white space accepted (Psyclone, DEV-6), a registration
    applied in part (the valid trigger of a refused registration firing), and a refusal that
    still drops the previous registration.
    """
    module = await ctx.module("Sub")
    await setup_subscribe(module, triggers_xml(ctx.type("Keep")))
    patterns = _invalid_patterns()
    for index, pattern in enumerate(patterns):
        reply = await module.subscribe(triggers_xml(ctx.type(f"Valid.{index}"), ctx.type(pattern)))
        check_error(
            ctx,
            reply,
            names=("PATTERN_INVALID",),
            what=f"a registration with pattern {ctx.type(pattern)!r}",
            req="OA-MATCH-7, OA-REG-8",
        )
    poster = await ctx.module("Poster", bind=False)
    await poster.post("WB1", ctx.type("Keep"), "keep")
    keep = poster.last_sent
    assert keep is not None
    for index in range(len(patterns)):
        await poster.post("WB1", ctx.type(f"Valid.{index}"), "valid")
    got = trigger_ids(await module.barrier())
    ctx.check(
        got == [keep.id],
        f"after the refusals the module was woken by {len(got)} message(s), Keep: {keep.id in got}",
        expected="exactly one wakeup, for Keep: the earlier registration stays (OA-REG-8)",
    )


@case(
    id="MATCH-008",
    title="A retrieve with an invalid pattern is answered AIR.Retrieve.Failed PATTERN_INVALID",
    section="5.2",
    requirements=("OA-MATCH-7",),
    allowed=("AIR.Retrieve.Failed with content 'PATTERN_INVALID: detail'",),
)
async def invalid_retrieve_patterns(ctx: CaseContext) -> None:
    """Retrieve from WB1 with each invalid-pattern row's pattern (prefixed).

    Catches: a retrieve matcher that accepts `**` or empty segments (Psyclone, DEV-6), and a
    retrieve that fails with the wrong reply type or condition.
    """
    client = await ctx.module("R", bind=False)
    for pattern in _invalid_patterns():
        spec = f'<retrieve from="WB1" type="{esc(ctx.type(pattern))}"><latest>0</latest></retrieve>'
        reply = await client.retrieve(spec)
        check_error(
            ctx,
            reply,
            types=("AIR.Retrieve.Failed",),
            names=("PATTERN_INVALID",),
            what=f"a retrieve with pattern {ctx.type(pattern)!r}",
            req="OA-MATCH-7",
        )


# -- the OA-TYPE-4 limits --------------------------------------------------------------------


def _fill(prefix: str, size: int, unit: str) -> str:
    """Return `prefix.<unit…>` of exactly `size` UTF-8 bytes (ASCII `A` pads an odd rest)."""
    room = size - len(prefix.encode()) - 1
    width = len(unit.encode())
    text = unit * (room // width) + "A" * (room % width)
    return f"{prefix}.{text}"


@case(
    id="MATCH-009",
    title="Types at the advertised max-type-bytes and max-type-segments are accepted and matched",
    section="5.1",
    requirements=("OA-TYPE-4", "OA-TYPE-1", "OA-TYPE-3"),
    allowed=(
        "types at the limits: RECEIVE_ACCEPT and one wakeup each",
        "one byte or one segment beyond: RECEIVE_ACCEPT or RECEIVE_ERROR TYPE_INVALID",
    ),
)
async def type_limits(ctx: CaseContext) -> None:
    """Build types of exactly max-type-bytes (ASCII and two-byte characters) and of exactly
    max-type-segments segments; post them and one beyond each limit.

    Catches: limits counted in characters instead of UTF-8 bytes, off-by-one limits that refuse
    a type at the limit, and refusals with a condition other than TYPE_INVALID.
    """
    max_bytes = ctx.server.limit("max-type-bytes", 255)
    max_segments = ctx.server.limit("max-type-segments", 32)
    prefix = ctx.type_prefix()
    base_segments = prefix.count(".") + 1
    at_limit = [
        _fill(prefix, max_bytes, "A"),
        _fill(prefix, max_bytes, "\u00e9"),
        ".".join([prefix, *["S"] * (max_segments - base_segments)]),
    ]
    beyond = [_fill(prefix, max_bytes + 1, "A"), f"{at_limit[2]}.S"]
    watcher = await ctx.module("Watch")
    await setup_subscribe(watcher, triggers_xml(f"{prefix}.*"))
    poster = await ctx.module("Poster", bind=False)
    ids = {}
    for type_ in at_limit:
        await poster.post("WB1", type_, "at the limit")
        assert poster.last_sent is not None
        ids[poster.last_sent.id] = type_
    for type_ in beyond:
        reply = await poster.post("WB1", type_, "beyond the limit", check=False)
        if reply.type != "RECEIVE_ACCEPT":
            check_error(
                ctx, reply, names=("TYPE_INVALID",), what="a post beyond a limit", req="OA-TYPE-4"
            )
        ctx.note(f"a type beyond the limits ({len(type_.encode())} bytes) got {reply.type}")
    got = trigger_ids(await watcher.barrier())
    missing = [ids[i] for i in ids if i not in got]
    ctx.check(not missing, f"no wakeup for types at the limits: {missing}", expected="OA-TYPE-1")
