// The live type graph: posting modules → types → whiteboards → woken modules, drawn as SVG in
// four columns; each edge is labelled with its rate (messages per second over the window).
"use strict";

(() => {
  const COLUMNS = [["sender", "Posting modules"], ["type", "Types"],
    ["whiteboard", "Whiteboards"], ["receiver", "Woken modules"]];
  const ROW = 32, BOX = 22, TOP = 36, CHAR = 7;
  const svgEl = document.getElementById("graph");

  function layout(nodes) {
    const columns = COLUMNS.map(([kind]) => nodes.filter((n) => n.kind === kind)
      .sort((a, b) => a.label.localeCompare(b.label)));
    const widths = columns.map((col, c) => Math.max(90, COLUMNS[c][1].length * (CHAR + 1),
      ...col.map((n) => n.label.length * CHAR + 16)));
    const total = Math.max(svgEl.clientWidth || 960, widths.reduce((a, b) => a + b, 0) + 3 * 120);
    const gap = (total - widths.reduce((a, b) => a + b, 0)) / 3;
    const place = new Map();
    let x = 0;
    columns.forEach((col, c) => {
      col.forEach((n, i) => place.set(n.id, { x, y: TOP + i * ROW, w: widths[c], node: n }));
      x += widths[c] + gap;
    });
    const rows = Math.max(1, ...columns.map((col) => col.length));
    return { place, width: total, height: TOP + rows * ROW + 10, columns, widths, gap };
  }

  function render(g) {
    const { svg, clear } = OA;
    const { place, width, height, widths, gap } = layout(g.nodes);
    clear(svgEl);
    svgEl.setAttribute("viewBox", `0 0 ${width} ${height}`);
    svgEl.setAttribute("height", String(height));
    let x = 0;
    COLUMNS.forEach(([, title], c) => {
      svgEl.append(svg("text", { x, y: 16, "font-weight": "600", text: title }));
      x += widths[c] + gap;
    });
    const outs = new Map(), ins = new Map();
    for (const e of g.edges) {
      outs.set(e.from, (outs.get(e.from) || 0) + 1);
      ins.set(e.to, (ins.get(e.to) || 0) + 1);
    }
    for (const e of g.edges) {
      const a = place.get(e.from), b = place.get(e.to);
      if (!a || !b) continue;
      const x1 = a.x + a.w, y1 = a.y + BOX / 2, x2 = b.x, y2 = b.y + BOX / 2, mid = (x1 + x2) / 2;
      const width = 1 + 2.5 * Math.log10(1 + e.rate);
      svgEl.append(svg("path", {
        class: "edge", d: `M${x1},${y1} C${mid},${y1} ${mid},${y2} ${x2},${y2}`,
        "stroke-width": width.toFixed(2), "data-from": e.from, "data-to": e.to,
      }, svg("title", { text: `${e.from} → ${e.to}: ${e.count} in ${g.window_s} s` })));
      // Label the end where fewer edges meet, so that fanned-out labels do not pile up.
      const nearTarget = (ins.get(e.to) || 0) <= (outs.get(e.from) || 0);
      svgEl.append(svg("text", { class: "edge-label", x: nearTarget ? x2 - 6 : x1 + 6,
        y: (nearTarget ? y2 : y1) - 4, "text-anchor": nearTarget ? "end" : "start",
        text: `${OA.rate(e.rate)}/s` }));
    }
    for (const { x: nx, y, w, node } of place.values()) {
      const target = node.kind === "whiteboard" ? `/whiteboard?wb=${encodeURIComponent(node.label)}`
        : node.kind === "type" ? null : `/module?name=${encodeURIComponent(node.label)}`;
      svgEl.append(svg("g", { class: `node ${node.kind}`, "data-id": node.id,
        onclick: () => { if (target) location.href = target; } },
        svg("rect", { x: nx, y, width: w, height: BOX, rx: 4 }),
        svg("text", { x: nx + 8, y: y + 15, text: node.label })));
    }
    document.getElementById("graph-note").textContent =
      `${g.events} posts in the last ${g.window_s} s; edges show messages per second.`;
    document.body.dataset.loaded = "yes";
  }

  OA.header("/graph");
  OA.getJSON("/api/graph").then(render).catch((e) => OA.setLive(false, e.message));
  OA.events({ topics: "graph" }, { graph: render });
})();
