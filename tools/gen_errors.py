#!/usr/bin/env python3
"""Generate the error classes (Python, C++, Java) from the spec's single error table.

Usage: gen_errors.py [--check] [--cpp OUT]. With --check, exit 1 if a generated file is stale.
With --cpp OUT, only the C++ header (bindings/cpp/include/openair/errc.hpp) is written or checked,
at OUT; without it every target is, the C++ header included once bindings/cpp exists.
Model: asyncpg's tools/generate_exceptions.py (style rule 4).
"""

from __future__ import annotations

import argparse
import sys
import textwrap
from collections.abc import Callable
from dataclasses import dataclass
from pathlib import Path

from lxml import etree

ROOT = Path(__file__).resolve().parent.parent
TABLE = ROOT / "spec" / "errors.xml"
HEADER = "generated from spec/errors.xml by tools/gen_errors.py — do not edit"


@dataclass(frozen=True, slots=True, kw_only=True)
class Row:
    """One error condition of the table."""

    code: int
    name: str
    blame: str
    reply: str
    closes: bool
    requirements: tuple[str, ...]
    text: str

    @property
    def camel(self) -> str:
        return "".join(part.capitalize() for part in self.name.split("_"))


def load_rows(path: Path = TABLE) -> list[Row]:
    """Read the error table."""
    parser = etree.XMLParser(resolve_entities=False, no_network=True, load_dtd=False)
    root = etree.parse(str(path), parser).getroot()
    rows = [
        Row(
            code=int(el.get("code", "")),
            name=el.get("name", ""),
            blame=el.get("blame", ""),
            reply=el.get("reply", "-"),
            closes=el.get("closes") == "yes",
            requirements=tuple((el.get("requirement") or "").split()),
            text=" ".join((el.text or "").split()),
        )
        for el in root.iter("error")
    ]
    codes = [r.code for r in rows]
    names = [r.name for r in rows]
    if len(set(codes)) != len(codes) or len(set(names)) != len(names):
        raise SystemExit("spec/errors.xml: duplicate code or name")
    return rows


def _docstring(text: str) -> list[str]:
    """Render a class docstring wrapped to the project's line length."""
    lines = textwrap.wrap(text, width=92)
    if len(lines) == 1 and len(lines[0]) <= 90:
        return [f'    """{lines[0]}"""']
    return ['    """' + lines[0], *[f"    {line}" for line in lines[1:]], '    """']


_BASE = {"remote": "RemoteProtocolError", "peer": "PeerError", "local": "LocalProtocolError"}


_EXPORTS = [
    "ERRORS",
    "Blame",
    "ErrorCode",
    "LocalProtocolError",
    "OpenAIRError",
    "PeerError",
    "RemoteProtocolError",
    "error_for",
]


def _isort_key(name: str) -> tuple[int, str]:
    """Order names as ruff's RUF022 expects: CONSTANTS, then Classes, then functions."""
    return (0 if name.isupper() else 1 if name[0].isupper() else 2, name)


def python_source(rows: list[Row]) -> str:
    """Render reference/openair/protocol/errors.py."""
    out = [
        '"""OpenAIR error conditions.',
        "",
        f"{HEADER[0].upper()}{HEADER[1:]}.",
        '"""',
        "",
        "from __future__ import annotations",
        "",
        "import enum",
        "",
        "from openair.protocol._errors_base import (",
        "    Blame,",
        "    LocalProtocolError,",
        "    OpenAIRError,",
        "    PeerError,",
        "    RemoteProtocolError,",
        ")",
        "",
        "",
        "class ErrorCode(enum.IntEnum):",
        '    """Stable numeric codes of the error table."""',
        "",
    ]
    out += [f"    {r.name} = {r.code}" for r in rows]
    for r in rows:
        reply = "None" if r.reply == "-" else f'"{r.reply}"'
        reqs = ", ".join(f'"{q}"' for q in r.requirements)
        reqs += "," if len(r.requirements) == 1 else ""
        out += [
            "",
            "",
            f"class {r.camel}Error({_BASE[r.blame]}):",
            *_docstring(r.text),
            "",
            f"    code = ErrorCode.{r.name}",
            f'    name = "{r.name}"',
            f"    blame = Blame.{r.blame.upper()}",
            f"    reply = {reply}",
            f"    closes = {r.closes}",
            f"    requirements = ({reqs})",
        ]
    out += [
        "",
        "",
        "ERRORS: dict[str, type[OpenAIRError]] = {",
        *[f'    "{r.name}": {r.camel}Error,' for r in rows],
        "}",
        "",
        "",
        "def error_for(name: str) -> type[OpenAIRError]:",
        '    """Return the error class for a condition name (KeyError if unknown)."""',
        "    return ERRORS[name]",
        "",
        "",
        "__all__ = [",
        *[
            f'    "{n}",'
            for n in sorted(_EXPORTS + [f"{r.camel}Error" for r in rows], key=_isort_key)
        ],
        "]",
        "",
    ]
    return "\n".join(out)


def _cpp_string(text: str) -> str:
    """Render `text` as a C++ string literal (the table's text is ASCII)."""
    return '"' + text.replace("\\", "\\\\").replace('"', '\\"') + '"'


def _cpp_switch(
    rows: list[Row], signature: str, value: Callable[[Row], str], last: str
) -> list[str]:
    """Render a constexpr function that switches over every condition."""
    return [
        f"constexpr {signature} noexcept {{",
        "    switch (e) {",
        *[f"        case errc::{r.name.lower()}: return {value(r)};" for r in rows],
        "    }",
        f"    return {last};",
        "}",
        "",
    ]


def cpp_source(rows: list[Row]) -> str:
    """Render bindings/cpp/include/openair/errc.hpp."""
    lines = [
        f"// {HEADER}",
        "#pragma once",
        "",
        "#include <optional>",
        "#include <string_view>",
        "",
        "namespace openair {",
        "",
        "/// The stable codes of the OpenAIR error table (spec section 13, spec/errors.xml).",
        "enum class errc : int {",
        *[
            line
            for r in rows
            for line in (f"    /// {r.text}", f"    {r.name.lower()} = {r.code},")
        ],
        "};",
        "",
        "/// Who is at fault for a condition (OA-GEN-3).",
        "enum class blame { remote, peer, local };",
        "",
        "/// The condition name that travels on the wire (RECEIVE_ERROR content `NAME: detail`).",
        *_cpp_switch(
            rows, "std::string_view errc_name(errc e)", lambda r: f'"{r.name}"', '"UNKNOWN"'
        ),
        "/// Who is at fault for the condition.",
        *_cpp_switch(
            rows, "blame errc_blame(errc e)", lambda r: f"blame::{r.blame}", "blame::remote"
        ),
        "/// Whether the condition blames the local caller (API misuse and local conditions).",
        "constexpr bool errc_is_local(errc e) noexcept { return errc_blame(e) == blame::local; }",
        "",
        "/// Whether the connection that carried the condition is closed afterwards.",
        *_cpp_switch(rows, "bool errc_closes(errc e)", lambda r: str(r.closes).lower(), "false"),
        '/// The reply a server sends for the condition ("" when none is sent).',
        *_cpp_switch(
            rows,
            "std::string_view errc_reply(errc e)",
            lambda r: '""' if r.reply == "-" else f'"{r.reply}"',
            '""',
        ),
        "/// The table's one-line description of the condition.",
        *_cpp_switch(
            rows, "std::string_view errc_text(errc e)", lambda r: _cpp_string(r.text), '""'
        ),
        "/// Look a condition up by its wire name; nullopt when the table has no such name.",
        "constexpr std::optional<errc> errc_from_name(std::string_view name) noexcept {",
        *[f'    if (name == "{r.name}") return errc::{r.name.lower()};' for r in rows],
        "    return std::nullopt;",
        "}",
        "",
        "}  // namespace openair",
        "",
    ]
    return "\n".join(lines)


def java_source(rows: list[Row]) -> str:
    """Render bindings/java/src/main/java/org/openair/ErrorCode.java."""
    body = ",\n".join(
        f'    {r.name}({r.code}, Blame.{r.blame.upper()}, {str(r.closes).lower()}, "{r.text}")'
        for r in rows
    )
    return "\n".join(
        [
            f"// {HEADER}",
            "package org.openair;",
            "",
            "/** Error conditions of the OpenAIR error table (spec/errors.xml). */",
            "public enum ErrorCode {",
            body + ";",
            "",
            "    /** Who is at fault for a condition. */",
            "    public enum Blame { REMOTE, PEER, LOCAL }",
            "",
            "    private final int code;",
            "    private final Blame blame;",
            "    private final boolean closes;",
            "    private final String description;",
            "",
            "    ErrorCode(int code, Blame blame, boolean closes, String description) {",
            "        this.code = code;",
            "        this.blame = blame;",
            "        this.closes = closes;",
            "        this.description = description;",
            "    }",
            "",
            "    /** @return the stable numeric code */",
            "    public int code() { return code; }",
            "",
            "    /** @return who is at fault */",
            "    public Blame blame() { return blame; }",
            "",
            "    /** @return whether the connection is closed after this condition */",
            "    public boolean closes() { return closes; }",
            "",
            "    /** @return the table's one-line description */",
            "    public String description() { return description; }",
            "",
            "    /**",
            "     * Look a condition up by its wire name.",
            "     * @param name the condition name, e.g. XML_MALFORMED",
            "     * @return the condition, or null if the name is unknown",
            "     */",
            "    public static ErrorCode byName(String name) {",
            "        for (ErrorCode c : values()) {",
            "            if (c.name().equals(name)) {",
            "                return c;",
            "            }",
            "        }",
            "        return null;",
            "    }",
            "}",
            "",
        ]
    )


TARGETS = {
    ROOT / "reference" / "openair" / "protocol" / "errors.py": python_source,
}
OPTIONAL_TARGETS = {
    # Written only when the binding's folder exists (the bindings arrive in later work).
    ROOT / "bindings" / "cpp" / "include" / "openair" / "errc.hpp": cpp_source,
    ROOT / "bindings" / "java" / "src" / "main" / "java" / "org" / "openair" / "ErrorCode.java": (
        java_source
    ),
}


def main(argv: list[str] | None = None) -> int:
    """Write (or with --check, verify) every generated file."""
    ap = argparse.ArgumentParser(description=__doc__)
    ap.add_argument("--check", action="store_true", help="fail if a generated file is stale")
    ap.add_argument(
        "--cpp",
        metavar="OUT",
        type=Path,
        help="write (or with --check, verify) only the C++ header, at OUT",
    )
    args = ap.parse_args(argv)
    rows = load_rows()
    targets: dict[Path, Callable[[list[Row]], str]] = dict(TARGETS)
    for optional_path, optional_render in OPTIONAL_TARGETS.items():
        binding_root = optional_path.parents[len(optional_path.relative_to(ROOT).parts) - 3]
        if binding_root.exists():
            targets[optional_path] = optional_render
    if args.cpp is not None:
        targets = {args.cpp.resolve(): cpp_source}
    stale = []
    for path, render in targets.items():
        text = render(rows)
        if args.check:
            if not path.exists() or path.read_text(encoding="utf-8") != text:
                stale.append(path.relative_to(ROOT) if path.is_relative_to(ROOT) else path)
        else:
            path.parent.mkdir(parents=True, exist_ok=True)
            path.write_text(text, encoding="utf-8")
    if stale:
        print("stale generated files (run `make generate`):", *stale, sep="\n  ", file=sys.stderr)
        return 1
    return 0


if __name__ == "__main__":
    sys.exit(main())
