// The post form: builds the JSON of POST /api/post; the server posts it through its router.
"use strict";

(() => {
  const { el } = OA;
  const field = (id) => document.getElementById(id);

  async function send(event) {
    event.preventDefault();
    const result = field("post-result");
    const body = {
      from: field("p-from").value, to: field("p-to").value, type: field("p-type").value,
      cc: field("p-cc").value, priority: field("p-priority").value === "" ? null : Number(field("p-priority").value),
      content: field("p-content").value, xml: field("p-xml").checked,
    };
    result.className = "note";
    try {
      const r = await OA.getJSON("/api/post", {
        method: "POST", headers: { "Content-Type": "application/json", Accept: "application/json" },
        body: JSON.stringify(body),
      });
      OA.clear(result).append(`${r.reply.type}: stored on `, OA.boardLink(r.whiteboard), ` as wbid ${r.wbid}`);
      result.className = "ok";
    } catch (e) {
      const reply = e.body && e.body.reply;
      result.textContent = reply ? `${reply.type}: ${reply.content}` : e.message;
      result.className = "error";
    }
    result.dataset.done = String(Date.now());
  }

  async function init() {
    OA.header("/post");
    const overview = await OA.getJSON("/api/overview");
    OA.setLive(true, overview.server.post_enabled ? "posting allowed" : "read-only");
    for (const b of overview.whiteboards) field("p-to").append(el("option", { value: b.name, text: b.name }));
    field("p-to").value = overview.whiteboards.some((b) => b.name === "WB1") ? "WB1" : overview.whiteboards[0].name;
    if (!overview.server.post_enabled) {
      field("post-disabled").hidden = false;
      for (const input of field("post-form").elements) input.disabled = true;
    }
    field("post-form").addEventListener("submit", send);
    document.body.dataset.loaded = "yes";
  }

  init().catch((e) => OA.setLive(false, e.message));
})();
