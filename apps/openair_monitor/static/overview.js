// The overview page: server facts, whiteboards, modules and streams, live from /api/events.
"use strict";

(() => {
  const { el, clear } = OA;

  function fact(list, label, value) {
    list.append(el("dt", { text: label }), el("dd", {}, value));
  }

  function renderServer(s, monitor) {
    const list = clear(document.getElementById("server"));
    fact(list, "Server", `${s.name || "(unnamed)"} — ${s.implementation}`);
    fact(list, "Address", `${s.host}:${s.port}` + (s.http_port ? ` (HTTP also on ${s.http_port})` : ""));
    fact(list, "Started", OA.dateTime(s.started_ms));
    fact(list, "Uptime", el("span", { id: "uptime", text: OA.duration(s.uptime_s) }));
    fact(list, "Connections", `${s.connections} open, ${s.bound} modules bound, ${s.triggers} triggers`);
    fact(list, "Deliveries", `${s.delivered} delivered; dropped: ` +
      Object.entries(s.dropped || {}).map(([k, v]) => `${k} ${v}`).join(", "));
    fact(list, "Extensions", (s.extensions || []).join(", ") || "none");
    fact(list, "Posting", s.post_enabled ? "allowed from this monitor" : "read-only");
    fact(list, "Monitor", `${monitor.events} posts seen, ${monitor.streams} live views`);
  }

  function renderBoards(boards) {
    const body = clear(document.querySelector("#whiteboards tbody"));
    for (const b of boards) {
      const fill = b.maxcount ? b.count / b.maxcount : 0;
      body.append(el("tr", { data: { name: b.name } },
        el("td", {}, OA.boardLink(b.name)),
        el("td", { class: "num", text: b.received }),
        el("td", { class: "num", text: b.dispatched }),
        el("td", {}, OA.bar(fill), `${b.count} / ${b.maxcount}`),
        el("td", { class: "num", text: b.evicted }),
        el("td", { class: "num", text: OA.rate(b.rate) })));
    }
  }

  function registration(m) {
    const r = m.registration;
    if (!r.triggers && !r.retrieves) return el("span", { class: "muted", text: "none" });
    const shown = r.patterns.join(", ") + (r.triggers > r.patterns.length ? ", …" : "");
    return el("span", { title: shown },
      `${r.triggers} trigger${r.triggers === 1 ? "" : "s"}`,
      r.retrieves ? `, ${r.retrieves} retrieve${r.retrieves === 1 ? "" : "s"}` : "",
      el("br"), el("code", { text: shown }));
  }

  function renderModules(modules) {
    const body = clear(document.querySelector("#modules tbody"));
    document.getElementById("no-modules").hidden = modules.length > 0;
    for (const m of modules) {
      body.append(el("tr", { data: { name: m.name }, class: m.bound ? "bound" : "unbound" },
        el("td", {}, OA.moduleLink(m.name)),
        el("td", {}, m.bound ? OA.dateTime(m.since_ms) : el("span", { class: "muted", text: "not bound" })),
        el("td", { class: "num", text: `${m.posted} (${OA.rate(m.posted_rate)}/s)` }),
        el("td", { class: "num", text: `${m.delivered} (${OA.rate(m.delivered_rate)}/s)` }),
        el("td", { class: "num", text: m.depth }),
        el("td", { class: "num " + (m.dropped || m.failed ? "bad" : ""), text: m.dropped + m.failed }),
        el("td", {}, el("code", { text: m.last_type || "–" })),
        el("td", {}, registration(m))));
    }
  }

  function fill(value) {
    return value === null || value === undefined ? "–" : [OA.bar(value), `${(value * 100).toFixed(0)}%`];
  }

  function renderStreams(streams) {
    const table = document.getElementById("streams");
    table.hidden = streams.length === 0;
    document.getElementById("no-streams").hidden = streams.length > 0;
    const body = clear(table.querySelector("tbody"));
    for (const s of streams) {
      body.append(el("tr", { data: { name: s.name } },
        el("td", { text: s.name }), el("td", { text: s.whiteboard || "–" }),
        el("td", { text: s.type || "–" }), el("td", { class: "num", text: s.count || "–" }),
        el("td", { class: "num", text: OA.rate(s.rate) }),
        el("td", {}, fill(s.fill_soft)), el("td", {}, fill(s.fill_hard))));
    }
  }

  function render(data) {
    renderServer(data.server, data.monitor);
    renderBoards(data.whiteboards);
    renderModules(data.modules);
    renderStreams(data.streams);
    document.body.dataset.loaded = "yes";
  }

  OA.header("/");
  OA.getJSON("/api/overview").then(render).catch((e) => OA.setLive(false, e.message));
  OA.events({ topics: "overview" }, { overview: render });
})();
