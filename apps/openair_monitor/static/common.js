// Shared helpers of the monitor pages: DOM building, JSON fetches, formatting, live events.
// Everything that shows server data goes through textContent (never innerHTML).
"use strict";

const OA = (() => {
  function el(tag, attrs, ...children) {
    const node = document.createElement(tag);
    for (const [key, value] of Object.entries(attrs || {})) {
      if (value === null || value === undefined || value === false) continue;
      if (key === "text") node.textContent = String(value);
      else if (key === "class") node.className = value;
      else if (key === "data") Object.assign(node.dataset, value);
      else if (key.startsWith("on")) node.addEventListener(key.slice(2), value);
      else node.setAttribute(key, value === true ? "" : String(value));
    }
    for (const child of children.flat()) {
      if (child === null || child === undefined) continue;
      node.append(child instanceof Node ? child : document.createTextNode(String(child)));
    }
    return node;
  }

  function svg(tag, attrs, ...children) {
    const node = document.createElementNS("http://www.w3.org/2000/svg", tag);
    for (const [key, value] of Object.entries(attrs || {})) {
      if (key === "text") node.textContent = String(value);
      else if (key.startsWith("on")) node.addEventListener(key.slice(2), value);
      else node.setAttribute(key, String(value));
    }
    for (const child of children.flat()) if (child) node.append(child);
    return node;
  }

  function clear(node) {
    while (node.firstChild) node.removeChild(node.firstChild);
    return node;
  }

  async function getJSON(url, options) {
    const response = await fetch(url, Object.assign({ headers: { Accept: "application/json" } },
      options || {}));
    let body = {};
    try { body = await response.json(); } catch (e) { body = {}; }
    if (!response.ok) {
      const error = new Error(body.error || response.statusText);
      error.status = response.status;
      error.body = body;
      throw error;
    }
    return body;
  }

  const pad = (n, w) => String(n).padStart(w || 2, "0");

  function time(ms) {
    if (ms === null || ms === undefined) return "–";
    const d = new Date(ms);
    return `${pad(d.getHours())}:${pad(d.getMinutes())}:${pad(d.getSeconds())}.${pad(d.getMilliseconds(), 3)}`;
  }

  function dateTime(ms) {
    if (ms === null || ms === undefined) return "–";
    const d = new Date(ms);
    return `${d.getFullYear()}-${pad(d.getMonth() + 1)}-${pad(d.getDate())} ${time(ms)}`;
  }

  function rate(r) {
    if (r === null || r === undefined) return "–";
    return r < 10 ? r.toFixed(1) : String(Math.round(r));
  }

  function duration(s) {
    if (s === null || s === undefined) return "–";
    s = Math.floor(s);
    const d = Math.floor(s / 86400), h = Math.floor(s / 3600) % 24, m = Math.floor(s / 60) % 60;
    const parts = [];
    if (d) parts.push(`${d}d`);
    if (d || h) parts.push(`${h}h`);
    parts.push(`${m}m`, `${s % 60}s`);
    return parts.join(" ");
  }

  function ms(value) {
    if (value === null || value === undefined) return "–";
    return `${Number(value).toFixed(3).replace(/\.?0+$/, "")} ms`;
  }

  function param(name) {
    return new URLSearchParams(location.search).get(name) || "";
  }

  function bar(fraction) {
    const f = Math.max(0, Math.min(1, fraction || 0));
    const outer = el("span", { class: "bar" + (f > 0.95 ? " bad" : f > 0.8 ? " warn" : "") });
    const inner = el("span");
    inner.style.width = `${(f * 100).toFixed(1)}%`;
    outer.append(inner);
    return outer;
  }

  const PAGES = [["/", "Overview"], ["/whiteboard", "Whiteboards"], ["/graph", "Type graph"],
    ["/post", "Post"]];

  function header(active) {
    const nav = el("nav", {}, PAGES.map(([href, label]) =>
      el("a", { href, class: href === active ? "active" : null, text: label })));
    const live = el("span", { id: "live", class: "off", text: "connecting" });
    document.body.prepend(el("header", {}, el("h1", { text: "OpenAIR monitor" }), nav, live));
  }

  function setLive(on, text) {
    const live = document.getElementById("live");
    if (!live) return;
    live.className = on ? "on" : "off";
    live.textContent = text;
  }

  // Open /api/events with `params`; handlers maps event names to functions of the parsed data.
  function events(params, handlers) {
    const source = new EventSource(`/api/events?${new URLSearchParams(params)}`);
    source.addEventListener("open", () => setLive(true, "live"));
    source.addEventListener("error", () => setLive(false, "reconnecting"));
    for (const [name, handler] of Object.entries(handlers)) {
      source.addEventListener(name, (event) => handler(JSON.parse(event.data)));
    }
    return source;
  }

  function moduleLink(name) {
    return el("a", { href: `/module?name=${encodeURIComponent(name)}`, text: name });
  }

  function boardLink(name) {
    return el("a", { href: `/whiteboard?wb=${encodeURIComponent(name)}`, text: name });
  }

  return { el, svg, clear, getJSON, time, dateTime, rate, duration, ms, param, bar, header,
    setLive, events, moduleLink, boardLink };
})();
