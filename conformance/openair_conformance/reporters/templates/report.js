(function () {
  "use strict";
  function byId(id) { return document.getElementById(id); }
  var text = byId("f-text"), verdict = byId("f-verdict"), section = byId("f-section"),
      diff = byId("f-diff"), count = byId("f-count");
  var rows = Array.prototype.slice.call(document.querySelectorAll("table.filterable tbody tr"));
  function apply() {
    var q = text ? text.value.trim().toLowerCase() : "", shown = 0;
    rows.forEach(function (row) {
      var d = row.dataset, ok = true;
      if (verdict && verdict.value && d.verdict !== verdict.value) { ok = false; }
      if (section && section.value && d.section !== section.value) { ok = false; }
      if (diff && diff.checked && !row.classList.contains("differs")) { ok = false; }
      if (q && (d.search || "").indexOf(q) < 0) { ok = false; }
      row.hidden = !ok;
      if (ok) { shown += 1; }
    });
    if (count) { count.textContent = shown + " of " + rows.length + " cases shown"; }
  }
  [text, verdict, section, diff].forEach(function (el) {
    if (el) { el.addEventListener("input", apply); el.addEventListener("change", apply); }
  });
  Array.prototype.forEach.call(document.querySelectorAll("[data-filter]"), function (a) {
    a.addEventListener("click", function () {
      if (section) { section.value = a.dataset.filterSection || ""; }
      if (verdict) { verdict.value = a.dataset.filterVerdict || ""; }
      if (text) { text.value = ""; }
      apply();
    });
  });
  Array.prototype.forEach.call(document.querySelectorAll("button[data-open]"), function (b) {
    b.addEventListener("click", function () {
      var open = b.dataset.open === "1", scope = b.closest("article") || document;
      Array.prototype.forEach.call(scope.querySelectorAll("ol.trace details"), function (d) {
        d.open = open;
      });
    });
  });
  apply();
}());
