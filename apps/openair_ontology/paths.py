"""File names and relative links of the generated docs (HTML and Markdown alike).

Every page lives at a fixed depth (`index` at the root, one folder per kind of page below it),
so a link is the target's path from the root with the page's `root` prefix ("" or "../") in
front, and the site works from `file://` wherever it is copied.
"""

from __future__ import annotations

from dataclasses import dataclass

__all__ = ["Paths", "file_name"]

_KEPT = frozenset("ABCDEFGHIJKLMNOPQRSTUVWXYZabcdefghijklmnopqrstuvwxyz0123456789-_.")


def file_name(name: str) -> str:
    """Return a file name for `name` that is safe on every file system and in a URL.

    Letters, digits, `-`, `_` and `.` are kept; every other character becomes `~XX` per UTF-8
    byte (so `Psyclone.Context:A` is `Psyclone.Context~3AA`). A leading dot is escaped too,
    which keeps names like `..` harmless. Types differing only in ASCII case are one type
    (OA-MATCH-1), so case-insensitive file systems see no collision.
    """
    out: list[str] = []
    for i, char in enumerate(name):
        if char in _KEPT and not (i == 0 and char == "."):
            out.append(char)
        else:
            out.extend(f"~{byte:02X}" for byte in char.encode("utf-8", "surrogatepass"))
    return "".join(out) or "~"


@dataclass(frozen=True, slots=True, kw_only=True)
class Paths:
    """Where each page is, from the site's root; `ext` is `.html` or `.md`."""

    ext: str = ".html"

    @property
    def index(self) -> str:
        return f"index{self.ext}"

    def type(self, name: str) -> str:
        return f"types/{file_name(name)}{self.ext}"

    def module(self, name: str) -> str:
        return f"modules/{file_name(name)}{self.ext}"

    def whiteboard(self, name: str) -> str:
        return f"{self.index}#{self.anchor(name)}"

    @staticmethod
    def anchor(name: str) -> str:
        """Return the id of a whiteboard's section on the index page."""
        return "wb-" + file_name(name).replace("~", "-")
