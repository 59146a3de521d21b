"""Type matching (spec section 5): the spec matcher, a Psyclone 1.1.7 model and a pattern index.

- `matches(pattern, type_)` is the OpenAIR 1.0 matcher (OA-MATCH-1..6). Triggers and retrieves
  use it alike (OA-MATCH-8).
- `psyclone_matches(pattern, type_)` is a model of what Psyclone 1.1.7 does, fitted to the
  wakeups and retrieve results observed on the wire. It is an inference, not CMLabs code; it
  exists so that tools can show what changes when a system moves from Psyclone to OpenAIR 1.0.
- `PatternIndex` holds many (pattern, key) pairs and answers "which keys match this type?"
  without scanning every pattern; it agrees exactly with `matches()`.

All three compare ASCII case-insensitively (OA-MATCH-1): only `A`-`Z` fold, so `É` and `é`
differ. None of them validates its input; validate with `openair.protocol.types` first. On invalid
input they still answer deterministically (and the index still agrees with `matches()`), but the
answer means nothing in the spec.
"""

from __future__ import annotations

import enum
import string
from collections.abc import Callable, Hashable
from typing import Generic, TypeVar

K = TypeVar("K", bound=Hashable)

_ASCII_LOWER = str.maketrans(string.ascii_uppercase, string.ascii_lowercase)

# A compiled pattern: its folded text split on `*`, and the same for the pattern without its
# final `.*` (the subtree-root alternative of OA-MATCH-4), or None when it has no such ending.
_Parts = tuple[str, ...]
_Compiled = tuple[_Parts, _Parts | None]


def ascii_fold(text: str) -> str:
    """Return `text` with `A`-`Z` lowered and every other character unchanged (OA-MATCH-1)."""
    # str.lower() also folds non-ASCII letters and can change the length; use it only when safe.
    return text.lower() if text.isascii() else text.translate(_ASCII_LOWER)


# --- the spec matcher ---------------------------------------------------------------------------


def _compile(folded: str) -> _Compiled:
    """Split a folded pattern into its literal parts, with the subtree-root alternative.

    The root alternative is the pattern without its final `.*`, compared literally (OA-MATCH-4):
    `Input.Perc.*` also matches `Input.Perc`, but `A.*.B.*` does not match `A.X.B`.
    """
    root = (folded[:-2],) if folded.endswith(".*") else None
    return tuple(folded.split("*")), root


def _glob(parts: _Parts, t: str) -> bool:
    """Return whether the whole of `t` matches the literal `parts` joined by `*` wildcards."""
    if len(parts) == 1:
        return t == parts[0]  # OA-MATCH-2: no `*`, equality only
    pre, post = parts[0], parts[-1]
    end = len(t) - len(post)
    # OA-MATCH-6: prefix and suffix must not overlap, so the type is at least as long as both.
    if end < len(pre) or not t.startswith(pre) or not t.endswith(post):
        return False
    # OA-MATCH-3: each `*` takes any run, dots included. Taking the leftmost occurrence of each
    # middle part is optimal for `*`-only globs, so one pass decides (no backtracking).
    pos = len(pre)
    for middle in parts[1:-1]:
        found = t.find(middle, pos, end)
        if found < 0:
            return False
        pos = found + len(middle)
    return True


def _matches_compiled(compiled: _Compiled, t: str) -> bool:
    """Return whether a compiled pattern matches the folded type `t`."""
    parts, root = compiled
    # OA-MATCH-4: `P.*` also matches the type equal to `P`, compared literally (so `A.*.*`
    # matches neither `A` nor `A.X`-through-the-root; only the literal text `A.*` would).
    return _glob(parts, t) or (root is not None and _glob(root, t))


def matches(pattern: str, type_: str) -> bool:
    """Return whether `pattern` matches the message type `type_` under OA-MATCH-1..6.

    ASCII case is ignored (OA-MATCH-1). A pattern without `*` matches only the equal type
    (OA-MATCH-2). `*` matches any run of zero or more characters, dots included (OA-MATCH-3),
    so `*` alone matches every type (OA-MATCH-5). A pattern ending in `.*` also matches the
    type equal to the pattern without that final `.*` (OA-MATCH-4), wherever else its stars
    are: `A.*.B.*` matches `A.X.B`. Otherwise the whole type must be matched (OA-MATCH-6).

    Both arguments are assumed valid (`openair.protocol.types.validate_pattern` / `validate_type`).
    """
    return _matches_compiled(_compile(ascii_fold(pattern)), ascii_fold(type_))


def matcher(pattern: str) -> Callable[[str], bool]:
    """Return a test of types equal to `lambda t: matches(pattern, t)`, compiled once.

    For one pattern against many types (a retrieve's scan of a whiteboard's history): the
    pattern is folded and split once, and `Prefix.*`, the common case, is a prefix test.
    """
    compiled = _compile(ascii_fold(pattern))
    parts, root = compiled
    if root is not None and len(parts) == 2 and not parts[1]:  # `Prefix.*` (OA-MATCH-4)
        prefix, whole = parts[0], root[0]

        def subtree(type_: str) -> bool:
            folded = ascii_fold(type_)
            return folded.startswith(prefix) or folded == whole

        return subtree
    return lambda type_: _matches_compiled(compiled, ascii_fold(type_))


# --- the Psyclone 1.1.7 model -------------------------------------------------------------------


def _psyclone_split(p: str) -> list[str]:
    """Split on each `*` that does not follow a `*`; a `*` right after a `*` is a literal."""
    parts: list[str] = []
    start = 0
    for i, char in enumerate(p):
        if char == "*" and (i == 0 or p[i - 1] != "*"):
            parts.append(p[start:i])
            start = i + 1
    parts.append(p[start:])
    return parts


def _psyclone_glob(p: str, s: str) -> bool:
    """Psyclone's naive glob: prefix, first-occurrence suffix test, middles in order."""
    parts = _psyclone_split(p)
    pre, post = parts[0], parts[-1]
    if not s.startswith(pre):
        return False
    # The suffix passes only if its FIRST occurrence is at the end: `*.A` fails on `X.A.A`.
    if post:
        first = s.find(post)
        if first < 0 or first != len(s) - len(post):
            return False
    # Middles are searched from the end of the prefix, unbounded by the suffix: they may overlap.
    pos = len(pre)
    for middle in parts[1:-1]:
        found = s.find(middle, pos)
        if found < 0:
            return False
        pos = found + len(middle)
    return True


def _psyclone_starred_type(p: str, s: str) -> bool:
    """Model a posted type that contains `*` (seen only in retrieves; a narrower inference)."""
    # Fitted to 39 observations (types `*`, `A*`, `Q*` against 13 retrieve patterns): the text of
    # the type before its first `*` must start the pattern, after one leading `*` is skipped.
    head = s[: s.index("*")]
    return (p[1:] if p.startswith("*") else p).startswith(head)


def psyclone_matches(pattern: str, type_: str) -> bool:
    """Return what Psyclone 1.1.7 is modelled to answer for `pattern` against `type_`.

    The model is an inference, not CMLabs code. It reproduces every observed row of
    `spec/vectors/wildcards` (989 wakeups and retrieve results). Case-insensitive throughout:

    1. a pattern without `*` matches the equal type only;
    2. otherwise the type matches if it is a prefix of the text before the first `*`
       (`Test.Ping.*` matches `Test`);
    3. otherwise, for a pattern starting with `*`, the type matches if it and the rest of the
       pattern agree on their common length (`*Test.Ping.A` matches `Test.Ping.AB`);
    4. otherwise a naive glob: the type starts with the text before the first `*`, the first
       occurrence of the text after the last `*` is at the very end of the type, and the middle
       parts occur in order after the prefix; a `*` right after a `*` is a literal (`**`
       matches nothing without a star).

    A posted type containing `*` acts as a wildcard in Psyclone; for it the model uses a
    separate rule fitted to the 39 such observations, all from retrieves: the text of the type
    before its first `*` must start the pattern, after one leading `*` of the pattern is skipped
    (so a type `*` matches every pattern).
    """
    p, s = ascii_fold(pattern), ascii_fold(type_)
    if "*" in s:
        return _psyclone_starred_type(p, s)
    if "*" not in p:
        return p == s
    head = p[: p.index("*")]
    if len(s) <= len(head) and head.startswith(s):
        return True
    if p.startswith("*"):
        rest = p[1:]
        common = min(len(rest), len(s))
        if rest[:common] == s[:common]:
            return True
    return _psyclone_glob(p, s)


# --- the pattern index --------------------------------------------------------------------------


class _Kind(enum.Enum):
    """How the index files a pattern."""

    EVERYTHING = "*"
    EXACT = "exact"
    SUBTREE = "Prefix.*"
    GLOB = "glob"


def _place(folded: str) -> tuple[_Kind, str | None]:
    """Return how a folded pattern is filed and under which literal (None: not under a node)."""
    if folded == "*":
        return _Kind.EVERYTHING, None
    star = folded.find("*")
    if star < 0:
        return _Kind.EXACT, folded
    if star == len(folded) - 1 and folded.endswith(".*"):
        return _Kind.SUBTREE, folded[:-2]
    # A match starts with the text before the first `*` (also through the OA-MATCH-4 root
    # alternative, which keeps that first `*`), hence with its complete segments and a dot.
    dot = folded.rfind(".", 0, star)
    return _Kind.GLOB, (folded[:dot] if dot >= 0 else None)


# A general glob in the index: its literal prefix and longest other literal part (both necessary
# for a match through either OA-MATCH-4 alternative), the compiled pattern, and its keys.
_GlobEntry = tuple[str, str, _Compiled, set[K]]


def _glob_entry(folded: str) -> _GlobEntry[K]:
    """Compile a general glob (one with a `*` before its end) for the index."""
    compiled = _compile(folded)
    parts = compiled[0]
    # A type matched by either alternative contains every `*`-separated part of the root text
    # (the literal root contains them all; a full match contains them inside the pattern's
    # parts), so the longest such part is a cheap necessary condition.
    root_parts = folded[:-2].split("*") if folded.endswith(".*") else None
    needle = max((root_parts or parts)[1:], key=len)
    return parts[0], needle, compiled, set()


class _Node(Generic[K]):
    """Everything filed under one folded literal (a type, or a dot-prefix of types)."""

    __slots__ = ("exact", "globs", "subtree")

    def __init__(self) -> None:
        self.exact: set[K] = set()  # the pattern is this literal
        self.subtree: set[K] = set()  # the pattern is this literal + ".*"
        # Other globs whose text before the first `*` starts with this literal + ".".
        self.globs: dict[str, _GlobEntry[K]] = {}

    def is_empty(self) -> bool:
        return not (self.exact or self.subtree or self.globs)


class PatternIndex(Generic[K]):
    """A set of (pattern, key) pairs that finds the keys whose patterns match a type.

    `match()` agrees exactly with `matches()` over the pairs held, without scanning them all.
    Patterns are compared after ASCII folding, so `Test.*` and `TEST.*` are the same pattern.
    Where each pattern is filed, and what `match(type_)` pays for it:

    - exact patterns (no `*`): one dict lookup of the folded type;
    - `Prefix.*` (the common subtree form, no other `*`): one dict lookup per dot-prefix of the
      type, plus the type itself for the subtree root (OA-MATCH-4);
    - `*` alone: a set merged into every answer;
    - any other glob: filed under the complete segments before its first `*` (`Test.*.A` under
      `Test`) and tried only for types that start with them; a glob with no complete segment
      before its first `*` (`*.A`, `Te*t.Ping`) is tried for every type.

    Patterns are not validated here; validate them first, as for `matches()`.
    """

    def __init__(self) -> None:
        self._nodes: dict[str, _Node[K]] = {}
        self._everything: set[K] = set()
        self._loose: dict[str, _GlobEntry[K]] = {}
        self._count = 0

    def __len__(self) -> int:
        """Return the number of (pattern, key) pairs held."""
        return self._count

    def __repr__(self) -> str:
        return f"<PatternIndex: {self._count} (pattern, key) pairs>"

    def add(self, pattern: str, key: K) -> None:
        """Add the pair (pattern, key); adding a pair already held changes nothing."""
        keys = self._keys(ascii_fold(pattern), create=True)
        assert keys is not None  # create=True always returns a set
        if key not in keys:
            keys.add(key)
            self._count += 1

    def remove(self, pattern: str, key: K) -> None:
        """Remove the pair (pattern, key); raise KeyError if it is not held."""
        folded = ascii_fold(pattern)
        keys = self._keys(folded, create=False)
        if keys is None or key not in keys:
            raise KeyError((pattern, key))
        keys.remove(key)
        self._count -= 1
        if not keys:
            self._prune(folded)

    def clear(self) -> None:
        """Remove every pair."""
        self._nodes.clear()
        self._everything.clear()
        self._loose.clear()
        self._count = 0

    def match(self, type_: str) -> set[K]:
        """Return a new set of the keys whose patterns match `type_` (no order, no duplicates)."""
        t = ascii_fold(type_)
        found = set(self._everything)
        nodes = self._nodes
        node = nodes.get(t)
        if node is not None:
            found |= node.exact
            found |= node.subtree  # OA-MATCH-4: `t.*` matches `t`
        for pre, needle, compiled, keys in self._loose.values():
            # The cheap necessary test first: most types fail it, so few reach the full glob.
            if t.startswith(pre) and needle in t and _matches_compiled(compiled, t):
                found |= keys
        dot = t.find(".")
        while dot >= 0:
            node = nodes.get(t[:dot])
            if node is not None:
                found |= node.subtree
                for pre, needle, compiled, keys in node.globs.values():
                    if t.startswith(pre) and needle in t and _matches_compiled(compiled, t):
                        found |= keys
            dot = t.find(".", dot + 1)
        return found

    def _keys(self, folded: str, *, create: bool) -> set[K] | None:
        """Return the key set of a folded pattern, creating its place if `create`."""
        kind, literal = _place(folded)
        if kind is _Kind.EVERYTHING:
            return self._everything
        node = None
        if literal is not None:
            node = self._nodes.get(literal)
            if node is None:
                if not create:
                    return None
                node = self._nodes[literal] = _Node()
        if kind is _Kind.EXACT and node is not None:
            return node.exact
        if kind is _Kind.SUBTREE and node is not None:
            return node.subtree
        globs = self._loose if node is None else node.globs
        entry = globs.get(folded)
        if entry is None:
            if not create:
                return None
            entry = globs[folded] = _glob_entry(folded)
        return entry[3]

    def _prune(self, folded: str) -> None:
        """Drop the now empty place of a folded pattern, so removed patterns cost nothing."""
        kind, literal = _place(folded)
        node = None if literal is None else self._nodes[literal]
        if kind is _Kind.GLOB:
            del (self._loose if node is None else node.globs)[folded]
        if literal is not None and node is not None and node.is_empty():
            del self._nodes[literal]
