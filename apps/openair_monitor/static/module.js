// The module view: session, registration (triggers and retrieves), latency histogram and the
// recent wakeups, refreshed whenever the live overview ticks.
"use strict";

(() => {
  const { el, clear } = OA;
  const name = OA.param("name");

  function fact(list, label, value) {
    list.append(el("dt", { text: label }), el("dd", {}, value));
  }

  function renderSession(m) {
    const list = clear(document.getElementById("session"));
    if (!m) { fact(list, "State", "not bound (configured registration only)"); return; }
    fact(list, "State", m.bound ? "bound" : "not bound");
    fact(list, "Connected since", OA.dateTime(m.since_ms));
    const port = m.port === -1 ? "no listening port (BIND_NOLISTEN)" : `port ${m.port}`;
    fact(list, "Address", m.bound ? `${m.address || "?"}, ${port}` + (m.callback ? ", callback connection" : "") : "–");
    fact(list, "Extensions", m.extensions.join(", ") || "none (legacy)");
    fact(list, "Posted (out)", `${m.posted} (${OA.rate(m.posted_rate)}/s)`);
    fact(list, "Delivered (in)", `${m.delivered} (${OA.rate(m.delivered_rate)}/s), ${m.queued} queued in all`);
    fact(list, "Queue depth", String(m.depth));
    fact(list, "Dropped / failed", `${m.dropped} / ${m.failed}`);
    fact(list, "Last type posted", el("code", { text: m.last_type || "–" }));
  }

  function table(headers, rows, id) {
    return el("table", { id }, el("thead", {}, el("tr", {}, headers.map((h) => el("th", { text: h })))),
      el("tbody", {}, rows));
  }

  function renderRegistration(reg) {
    const box = clear(document.getElementById("registration"));
    if (!reg) { box.append(el("p", { class: "note", text: "No registration." })); return; }
    box.append(el("p", { class: "note", text: `Form ${reg.form}; self-triggering ${reg.allow_self_triggering ? "allowed" : "not allowed"}.` }));
    for (const phase of reg.phases) {
      box.append(el("h3", { text: `Phase ${phase.name} (context ${phase.context})${phase.active ? " — in force" : ""}` }));
      box.append(table(["Trigger pattern", "Whiteboard", "After"], phase.triggers.map((t) =>
        el("tr", { data: { pattern: t.pattern } }, el("td", {}, el("code", { text: t.pattern })),
          el("td", { text: t.whiteboard || "any" }), el("td", { text: `${t.after_ms} ms` }))), "triggers"));
      if (phase.retrieves.length) {
        box.append(table(["Retrieve from", "Pattern", "From", "Content", "Latest"], phase.retrieves.map((r) =>
          el("tr", {}, el("td", { text: r.whiteboard || "(default)" }), el("td", {}, el("code", { text: r.pattern || "*" })),
            el("td", { text: r.from || "" }), el("td", { text: r.content || "" }), el("td", { text: r.latest }))), "retrieves"));
      }
    }
  }

  function renderLatency(hist, measured) {
    const box = clear(document.getElementById("latency"));
    if (!measured) {
      box.append(el("p", { class: "note", text: "This server's dispatcher reports no per-delivery times, so latency is not measured." }));
      return;
    }
    if (!hist || !hist.count) {
      box.append(el("p", { class: "note", text: "No acknowledged wakeup yet." }));
      return;
    }
    const w = 640, h = 150, pad = 18, n = hist.buckets.length, bw = (w - 2 * pad) / n;
    const top = Math.max(...hist.buckets.map((b) => b.count));
    const chart = OA.svg("svg", { class: "hist", id: "histogram", viewBox: `0 0 ${w} ${h + 30}`, width: w, height: h + 30 });
    hist.buckets.forEach((b, i) => {
      const bh = top ? (b.count / top) * (h - pad) : 0;
      const x = pad + i * bw;
      chart.append(OA.svg("rect", { x: x + 2, y: h - bh, width: bw - 4, height: bh },
        OA.svg("title", { text: `${b.label}: ${b.count}` })));
      if (b.count) chart.append(OA.svg("text", { x: x + bw / 2, y: h - bh - 3, "text-anchor": "middle", text: b.count }));
      chart.append(OA.svg("text", { x: x + bw / 2, y: h + 14, "text-anchor": "middle", text: b.label.replace(" ms", "") }));
    });
    chart.append(OA.svg("text", { x: w - pad, y: h + 28, "text-anchor": "end", text: "ms" }));
    box.append(chart, el("p", { class: "note", text: `${hist.count} wakeups; mean ${OA.ms(hist.mean_ms)}, max ${OA.ms(hist.max_ms)}.` }));
  }

  function renderWakeups(list) {
    const body = clear(document.querySelector("#wakeups tbody"));
    document.getElementById("no-wakeups").hidden = list.length > 0;
    for (const m of list) {
      const link = el("a", { href: `/whiteboard?wb=${encodeURIComponent(m.whiteboard)}`, text: m.whiteboard });
      body.append(el("tr", {}, el("td", { text: OA.time(m.received_ms) }), el("td", {}, link),
        el("td", { class: "num", text: m.wbid }), el("td", {}, el("code", { text: m.type })),
        el("td", { text: m.from }), el("td", { class: "preview", text: m.preview })));
    }
  }

  async function refresh() {
    try {
      const d = await OA.getJSON(`/api/modules/${encodeURIComponent(name)}`);
      document.getElementById("module-error").hidden = true;
      renderSession(d.module);
      renderRegistration(d.registration);
      renderLatency(d.latency, d.latency_measured);
      renderWakeups(d.recent_wakeups);
      document.body.dataset.loaded = "yes";
    } catch (e) {
      const error = document.getElementById("module-error");
      error.textContent = e.message;
      error.hidden = false;
    }
  }

  OA.header("");
  document.getElementById("module-title").textContent = `Module ${name}`;
  refresh();
  OA.events({ topics: "overview" }, { overview: refresh });
})();
