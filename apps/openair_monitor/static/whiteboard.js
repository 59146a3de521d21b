// The whiteboard view: the newest stored messages, live, filtered on the server by the trigger
// matcher (type pattern) and globs on sender and content; a click shows the whole message.
"use strict";

(() => {
  const { el, clear } = OA;
  const MAX_ROWS = 200;
  const form = document.getElementById("filters");
  const field = (id) => document.getElementById(id);
  let source = null;
  let selected = null;

  function filters() {
    return {
      wb: field("wb").value,
      pattern: field("f-pattern").value.trim(),
      from: field("f-from").value.trim(),
      content: field("f-content").value,
    };
  }

  function query(f) {
    const q = new URLSearchParams();
    for (const key of ["pattern", "from", "content"]) if (f[key]) q.set(key, f[key]);
    return q;
  }

  function row(m, fresh) {
    const tr = el("tr", {
      class: "clickable" + (fresh ? " fresh" : "") + (m.wbid === selected ? " selected" : ""),
      data: { wbid: m.wbid, type: m.type, id: m.id },
      onclick: () => show(m.wbid),
    },
    el("td", { class: "num", text: m.wbid }),
    el("td", { text: OA.time(m.received_ms) }),
    el("td", {}, el("code", { text: m.type })),
    el("td", { text: m.from }),
    el("td", { text: m.cc || "" }),
    el("td", { class: "preview", title: m.preview, text: m.preview }),
    el("td", { class: "num", text: m.wakeups === null ? "?" : m.wakeups }));
    return tr;
  }

  function setStatus(text) { field("status").textContent = text; }

  function prepend(messages) {
    const body = document.querySelector("#messages tbody");
    const have = new Set(Array.from(body.rows, (r) => r.dataset.wbid));
    for (const m of messages) {
      if (have.has(String(m.wbid))) continue;
      body.prepend(row(m, true));
    }
    while (body.rows.length > MAX_ROWS) body.deleteRow(body.rows.length - 1);
    setStatus(`showing the newest ${body.rows.length} that pass the filter; live`);
  }

  async function load() {
    const f = filters();
    const error = field("filter-error");
    history.replaceState(null, "", `/whiteboard?${new URLSearchParams(
      Object.entries(f).filter(([, v]) => v))}`);
    field("board-title").textContent = `Messages on ${f.wb}`;
    if (source) { source.close(); source = null; }
    if (!f.wb) { refused("choose a whiteboard"); return; }
    let data;
    try {
      data = await OA.getJSON(`/api/whiteboards/${encodeURIComponent(f.wb)}/messages?${query(f)}`);
    } catch (e) {
      refused(e.status === 400 ? `invalid filter: ${e.message}` : e.message);
      return;
    }
    error.hidden = true;
    const body = clear(document.querySelector("#messages tbody"));
    for (const m of data.messages) body.append(row(m, false));
    setStatus(`${data.count} of ${data.maxcount} stored; showing the newest ${data.messages.length}` +
      (data.truncated ? " (search stopped early)" : "") + " that pass the filter");
    document.body.dataset.loaded = "yes";
    if (field("f-live").checked) live(f, data.seq);
  }

  // The filter was refused (or the list could not be read): say so, show no stale rows, and
  // leave the form usable; the next Apply starts again.
  function refused(message) {
    const error = field("filter-error");
    error.textContent = message;
    error.hidden = false;
    clear(document.querySelector("#messages tbody"));
    setStatus("nothing shown: correct the filter and apply it again");
    OA.setLive(false, "not live");
    document.body.dataset.loaded = "error";
  }

  // The page was asked for a whiteboard the server does not have: say so, never show another.
  function missing(name, boards) {
    const select = field("wb");
    select.prepend(el("option", { value: "", text: `(no whiteboard ${name})`, disabled: true }));
    select.value = "";
    field("board-title").textContent = `No whiteboard ${name}`;
    const error = field("filter-error");
    error.textContent = `There is no whiteboard ${JSON.stringify(name)} on this server; ` +
      `it has ${boards.map((b) => b.name).join(", ")}. Choose one above.`;
    error.hidden = false;
    setStatus("");
    OA.setLive(false, "not live");
    document.body.dataset.loaded = "missing";
  }

  function live(f, since) {
    const params = Object.assign({ topics: "messages", wb: f.wb }, Object.fromEntries(query(f)));
    if (since !== undefined) params.since = since;
    source = OA.events(params, {
      messages: prepend,
      gap: (g) => setStatus(`live: ${g.new} messages not shown (too many at once); ` +
        `${g.skipped} skipped and ${g.dropped} dropped since this view opened`),
    });
  }

  function slotRows(slots) {
    const rows = [];
    for (const [name, value] of Object.entries(slots)) {
      let text;
      if (value === null || value === "" || (Array.isArray(value) && !value.length)) text = "";
      else if (typeof value === "object") text = value.text !== undefined ? value.text : JSON.stringify(value);
      else text = String(value);
      const cell = name === "content" ? el("pre", { text }) : el("code", { text });
      rows.push(el("tr", { data: { slot: name } }, el("th", { text: name }), el("td", {}, cell)));
    }
    return rows;
  }

  function wakeupTable(d) {
    if (!d.wakeups_known) {
      return el("p", { class: "note", text: "Older than the monitor's memory: the wakeups it caused are not known." });
    }
    if (!d.wakeups.length) return el("p", { class: "note", id: "no-wakeups", text: "It woke no module." });
    return el("table", { id: "wakeups" },
      el("thead", {}, el("tr", {}, ["Module", "Cause", "Trigger", "After", "Wakeup id"].map(
        (h) => el("th", { text: h })))),
      el("tbody", {}, d.wakeups.map((w) => el("tr", { data: { module: w.module } },
        el("td", {}, OA.moduleLink(w.module)), el("td", { text: w.cause }),
        el("td", {}, el("code", { text: w.lasttrigger === null ? "?" : w.lasttrigger || "–" })),
        el("td", { text: `${w.after_ms} ms` }), el("td", { class: "mono", text: w.id })))));
  }

  function attachmentList(d) {
    const sizes = d.slots.binarysizes;
    if (!sizes.length) return el("p", { class: "note", id: "no-attachments", text: "None." });
    const base = `/api/messages/${encodeURIComponent(d.whiteboard)}/${d.wbid}/attachments/`;
    return el("ul", { id: "attachments" }, sizes.map((size, i) => el("li", {},
      el("a", { href: base + (i + 1), download: "", text: `attachment ${i + 1}` }),
      el("span", { text: ` ${size} bytes` }))));
  }

  async function show(wbid) {
    selected = wbid;
    for (const r of document.querySelectorAll("#messages tbody tr")) {
      r.classList.toggle("selected", r.dataset.wbid === String(wbid));
    }
    const d = await OA.getJSON(`/api/messages/${encodeURIComponent(field("wb").value)}/${wbid}`);
    field("detail-empty").hidden = true;
    const s = d.slots;
    clear(field("detail-body")).append(
      el("dl", { class: "facts", id: "detail-facts" },
        el("dt", { text: "Type" }), el("dd", {}, el("code", { text: s.type })),
        el("dt", { text: "wbid" }), el("dd", { text: d.wbid }),
        el("dt", { text: "postedTime" }), el("dd", { text: s.postedTime ? `${OA.dateTime(s.postedTime.ms)} (${s.postedTime.text})` : "–" }),
        el("dt", { text: "receivedTime" }), el("dd", { text: s.receivedTime ? `${OA.dateTime(s.receivedTime.ms)} (${s.receivedTime.text})` : "–" }),
        el("dt", { text: "Latency" }), el("dd", { id: "detail-latency", text: OA.ms(d.latency_ms) }),
        el("dt", { text: "cc" }), el("dd", { id: "detail-cc", text: d.cc.join(", ") || "–" })),
      el("h3", { text: "Attachments" }), attachmentList(d),
      el("h3", { text: "Wakeups it caused" }), wakeupTable(d),
      el("h3", { text: "Every slot" }), el("table", { id: "slots" }, el("tbody", {}, slotRows(s))));
    document.body.dataset.detail = String(d.wbid);
  }

  async function init() {
    OA.header("/whiteboard");
    const overview = await OA.getJSON("/api/whiteboards");
    const select = field("wb");
    for (const b of overview.whiteboards) select.append(el("option", { value: b.name, text: b.name }));
    const wanted = OA.param("wb");
    const known = overview.whiteboards.some((b) => b.name === wanted);
    select.value = known ? wanted
      : (overview.whiteboards.find((b) => b.name !== "AIRCentral") || overview.whiteboards[0]).name;
    field("f-pattern").value = OA.param("pattern");
    field("f-from").value = OA.param("from");
    field("f-content").value = OA.param("content");
    form.addEventListener("submit", (e) => { e.preventDefault(); load(); });
    select.addEventListener("change", load);
    field("f-live").addEventListener("change", () => {
      if (field("f-live").checked) live(filters());
      else if (source) { source.close(); source = null; OA.setLive(false, "paused"); }
    });
    field("f-clear").addEventListener("click", () => {
      for (const id of ["f-pattern", "f-from", "f-content"]) field(id).value = "";
      load();
    });
    if (wanted && !known) missing(wanted, overview.whiteboards);  // OA-WB-10: names are exact
    else await load();
  }

  init().catch((e) => OA.setLive(false, e.message));
})();
