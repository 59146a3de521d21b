"""The system diagram: modules, whiteboards, streams and the types between them (SVG).

Drawn in the manner of Figure 1 of Thórisson et al., "Scheduling Blackboards for Interactive
Robots": modules around the whiteboards they post to and are woken by, each arrow labelled with
the message types (module to whiteboard) or the trigger patterns (whiteboard to module) it
carries. Retrieves are dotted, streams are drawn beside the whiteboard that declares them.
Posts known only from a history are dashed, and so are modules the psySpec does not declare.
The caller may hide types (the docs hide members of parameterised families such as
`Psyclone.Module.Connect.{module}`, which every module posts and which would hide the rest).

The graph is built with the Python `graphviz` library and laid out by Graphviz `dot` (Debian's
`graphviz` package). Without `dot` there is no diagram: `render_svg` says why.
"""

from __future__ import annotations

from collections.abc import Callable
from dataclasses import dataclass, field

import graphviz  # type: ignore[import-untyped]  # the library ships no type information

from openair_ontology.usage import Source, Usage

__all__ = ["DiagramResult", "build_graph", "render_svg"]

_MAX_LABEL_LINES = 5
_ANY = "(any whiteboard)"
_FONT = "Helvetica"
_STYLES = {
    "post": {"color": "#2f5f9e"},
    "trigger": {"color": "#c0601a"},
    "retrieve": {"color": "#c0601a", "style": "dotted"},
}

Link = Callable[[str, str], str]  # (kind, name) -> relative URL ("" for none)


@dataclass(frozen=True, slots=True, kw_only=True)
class DiagramResult:
    """The SVG text, or None with the reason it could not be drawn."""

    svg: str | None
    problem: str = ""


@dataclass(slots=True)
class _Edge:
    items: list[str] = field(default_factory=list)
    declared: bool = False  # at least one item comes from the psySpec


def _label(items: list[str]) -> str:
    """Join items one per line, shortened to a few lines."""
    unique = list(dict.fromkeys(items))
    shown = unique[:_MAX_LABEL_LINES]
    if len(unique) > len(shown):
        shown.append(f"(+{len(unique) - len(shown)} more)")
    return "\n".join(shown)


def _url(url: str) -> dict[str, str]:
    """Return the URL attribute, or nothing (Graphviz would keep an empty link)."""
    return {"URL": url} if url else {}


class _Builder:
    """Collects nodes and labelled edges, then writes them into a graphviz Digraph."""

    def __init__(self, usage: Usage, link: Link, hide: Callable[[str], bool]) -> None:
        self.usage = usage
        self.link = link
        self.hide = hide
        self.graph = graphviz.Digraph("system", format="svg")
        self.edges: dict[tuple[str, str, str], _Edge] = {}
        self.modules: dict[str, bool] = {}  # name -> declared in the psySpec
        self.boards: dict[str, str] = {}  # name -> description
        self.ids: dict[tuple[str, str], str] = {}

    def node_id(self, kind: str, name: str) -> str:
        """Return a plain node id: names may hold ':', which Graphviz reads as a port."""
        return self.ids.setdefault((kind, name), f"n{len(self.ids)}")

    def build(self) -> graphviz.Digraph:
        g = self.graph
        g.attr(rankdir="TB", bgcolor="transparent", nodesep="0.3", ranksep="0.9")
        g.attr("node", fontname=_FONT, fontsize="11")
        g.attr("edge", fontname=_FONT, fontsize="9")
        self.modules = {m.name: True for m in self.usage.modules}
        self.boards = {w.name: w.description for w in self.usage.whiteboards}
        self._subscriptions()
        self._postings()
        self._whiteboard_nodes()
        self._streams()
        self._module_nodes()
        self._edge_lines()
        return g

    def _edge(self, module: str, board: str, kind: str, item: str, declared: bool) -> None:
        self.boards.setdefault(board, "")
        m, wb = self.node_id("m", module), self.node_id("wb", board)
        key = (m, wb, kind) if kind == "post" else (wb, m, kind)
        edge = self.edges.setdefault(key, _Edge())
        edge.items.append(item)
        edge.declared = edge.declared or declared

    def _subscriptions(self) -> None:
        for sub in self.usage.subscriptions:
            self._edge(sub.module, sub.whiteboard or _ANY, sub.kind, sub.pattern, True)

    def _postings(self) -> None:
        for post in self.usage.postings:
            if not post.module or post.source is Source.ONTOLOGY or self.hide(post.type):
                continue
            self.modules.setdefault(post.module, False)
            declared = post.source is Source.PSYSPEC
            self._edge(post.module, post.whiteboard or _ANY, "post", post.type, declared)

    def _whiteboard_nodes(self) -> None:
        for name, description in self.boards.items():
            dashed = name == _ANY
            self.graph.node(
                self.node_id("wb", name),
                label=name if dashed else f"{name}\nwhiteboard",
                shape="box",
                style="rounded,dashed" if dashed else "rounded,filled,bold",
                fillcolor="#fff4d6",
                color="#b07d10",
                fontsize="13",
                tooltip=description or name,
                **_url("" if dashed else self.link("wb", name)),
            )

    def _streams(self) -> None:
        for stream in self.usage.streams:
            sid = self.node_id("s", f"{stream.whiteboard}/{stream.name}")
            label = f"{stream.name}\n{stream.type}" if stream.type else stream.name
            self.graph.node(
                sid,
                label=label,
                shape="cds",
                style="filled",
                fillcolor="#e6f4e6",
                color="#3c8d3c",
                tooltip=f"stream {stream.name} on {stream.whiteboard}",
                **_url(self.link("type", stream.type) if stream.type else ""),
            )
            wb = self.node_id("wb", stream.whiteboard)
            self.graph.edge(wb, sid, style="dotted", arrowhead="none")
            for writer in stream.writers:
                self.modules.setdefault(writer, False)
                self.graph.edge(self.node_id("m", writer), sid, color="#3c8d3c", label="writes")
            for reader in stream.readers:
                self.modules.setdefault(reader, False)
                self.graph.edge(sid, self.node_id("m", reader), color="#3c8d3c", label="reads")

    def _module_nodes(self) -> None:
        for name, declared in self.modules.items():
            info = self.usage.module(name)
            self.graph.node(
                self.node_id("m", name),
                label=name,
                shape="ellipse",
                style="filled" if declared else "filled,dashed",
                fillcolor="#e4eefb" if declared else "#f2f2f2",
                color="#2f5f9e" if declared else "#777777",
                tooltip=(info.description if info else "") or name,
                **_url(self.link("module", name)),
            )

    def _edge_lines(self) -> None:
        for (source, target, kind), edge in self.edges.items():
            style = dict(_STYLES[kind])
            if not edge.declared:
                style["style"] = "dashed"
            self.graph.edge(
                source,
                target,
                label=_label(edge.items),
                tooltip=f"{kind}: " + ", ".join(dict.fromkeys(edge.items)),
                **style,
            )


def _never(type_: str) -> bool:
    return False


def build_graph(
    usage: Usage, link: Link, hide: Callable[[str], bool] = _never
) -> graphviz.Digraph | None:
    """Return the system graph, or None when the usage names no module."""
    if not (usage.modules or usage.postings or usage.subscriptions):
        return None
    return _Builder(usage, link, hide).build()


def render_svg(usage: Usage, link: Link, hide: Callable[[str], bool] = _never) -> DiagramResult:
    """Lay out the system graph with `dot` and return the SVG text (without XML prolog)."""
    graph = build_graph(usage, link, hide)
    if graph is None:
        return DiagramResult(svg=None, problem="no psySpec or history was given")
    try:
        svg = graph.pipe(format="svg", encoding="utf-8")
    except graphviz.ExecutableNotFound:
        return DiagramResult(svg=None, problem="Graphviz `dot` is not installed")
    except graphviz.CalledProcessError as exc:
        return DiagramResult(svg=None, problem=f"Graphviz failed: {exc}")
    start = svg.find("<svg")
    return DiagramResult(svg=svg[start:] if start >= 0 else svg)
