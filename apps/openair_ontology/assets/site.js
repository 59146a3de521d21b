/* The type tree of the OpenAIR ontology docs: collapsing and search.
 *
 * Plain JavaScript, no build step, no network: the search index is the script
 * assets/search-index.js (window.OPENAIR_INDEX), loaded before this one, so search
 * works from file://, where a page may not fetch other files. Without JavaScript the tree is
 * simply fully expanded.
 *
 * Search: words match type names and descriptions (all words must occur); a query
 * with '*' is an OpenAIR pattern (spec 5.2): '*' is any run of characters, dots
 * included, case is ignored, and 'P.*' also matches 'P' itself (OA-MATCH-4).
 */
(function () {
  "use strict";

  var tree = document.getElementById("tree");
  if (!tree) {
    return;
  }
  var current = document.body.getAttribute("data-current") || "";
  var search = document.getElementById("search");
  var statusLine = document.getElementById("search-status");
  var info = {};
  (window.OPENAIR_INDEX || []).forEach(function (item) {
    info[item.n] = item;
  });
  /* Pages other than the overview ship an empty tree: build it from the index, with the
   * same markup the overview has (parents come before their children in the index). */
  function makeToggle(name) {
    var button = document.createElement("button");
    button.type = "button";
    button.className = "toggle";
    button.setAttribute("aria-expanded", "true");
    button.setAttribute("aria-label", "Collapse " + name);
    button.textContent = "\u25BE";
    return button;
  }

  function buildTree() {
    var root = document.body.getAttribute("data-root") || "";
    var made = {};
    (window.OPENAIR_INDEX || []).forEach(function (item) {
      var dot = item.n.lastIndexOf(".");
      var parent = dot < 0 ? null : made[item.n.slice(0, dot)];
      var li = document.createElement("li");
      li.className = "node kind-" + item.k + (item.x ? " deprecated" : "");
      li.setAttribute("data-type", item.n);
      li.setAttribute("role", "treeitem");
      li.setAttribute("data-depth", String(parent ? Number(parent.getAttribute("data-depth")) + 1 : 0));
      var row = document.createElement("div");
      row.className = "row";
      var spacer = document.createElement("span");
      spacer.className = "toggle-spacer";
      var link = document.createElement("a");
      link.href = root + item.u;
      link.title = item.t;
      link.textContent = item.l;
      row.appendChild(spacer);
      row.appendChild(link);
      if (item.k === "stream") {
        var mini = document.createElement("span");
        mini.className = "mini";
        mini.textContent = "stream";
        row.appendChild(document.createTextNode(" "));
        row.appendChild(mini);
      }
      li.appendChild(row);
      made[item.n] = li;
      if (!parent) {
        tree.appendChild(li);
        return;
      }
      var list = parent.querySelector(":scope > ul");
      if (!list) {
        list = document.createElement("ul");
        list.setAttribute("role", "group");
        parent.appendChild(list);
        var parentRow = parent.querySelector(":scope > .row");
        parentRow.replaceChild(makeToggle(parent.getAttribute("data-type")), parentRow.firstChild);
      }
      list.appendChild(li);
    });
  }

  if (!tree.querySelector("li.node")) {
    buildTree();
  }
  var nodes = Array.prototype.slice.call(tree.querySelectorAll("li.node"));

  function toggleOf(li) {
    return li.querySelector(":scope > .row > .toggle");
  }

  function setExpanded(li, open) {
    var button = toggleOf(li);
    if (!button) {
      return;
    }
    li.classList.toggle("collapsed", !open);
    button.setAttribute("aria-expanded", open ? "true" : "false");
    button.setAttribute("aria-label", (open ? "Collapse " : "Expand ") + li.getAttribute("data-type"));
    button.textContent = open ? "\u25BE" : "\u25B8";
  }

  function onPath(name) {
    return current !== "" && (current === name || current.indexOf(name + ".") === 0);
  }

  /* The resting state: top level open, the path to the current page open, the rest closed. */
  function initialState() {
    nodes.forEach(function (li) {
      var name = li.getAttribute("data-type");
      var depth = Number(li.getAttribute("data-depth"));
      li.classList.remove("hidden", "match");
      setExpanded(li, depth < 1 || onPath(name));
      if (name === current) {
        li.classList.add("current");
        li.querySelector(":scope > .row > a").setAttribute("aria-current", "page");
      }
    });
  }

  function escapeRegExp(text) {
    return text.replace(/[.+?^${}()|[\]\\]/g, "\\$&");
  }

  function patternTest(query) {
    var lower = query.toLowerCase();
    var glob = new RegExp("^" + lower.split("*").map(escapeRegExp).join(".*") + "$");
    var root = lower.slice(-2) === ".*" ? lower.slice(0, -2) : null;
    return function (name, item) {
      if (item && item.k === "group") {
        return false; /* groups are never posted; they show as ancestors of matches */
      }
      /* A family (Psyclone.Module.Lost.{module}) is tried on one member. */
      var type = (item && item.f ? name + item.f + "x" : name).toLowerCase();
      return glob.test(type) || (root !== null && type === root);
    };
  }

  function wordTest(query) {
    var words = query.toLowerCase().split(/\s+/);
    return function (name, item) {
      var text = (name + " " + (item ? item.d + " " + item.s : "")).toLowerCase();
      return words.every(function (word) {
        return text.indexOf(word) >= 0;
      });
    };
  }

  function say(text) {
    if (statusLine) {
      statusLine.textContent = text;
    }
  }

  function filter(raw) {
    var query = raw.trim();
    if (query === "") {
      initialState();
      say("");
      return;
    }
    var test = query.indexOf("*") >= 0 ? patternTest(query) : wordTest(query);
    var count = 0;
    /* Reverse document order decides every child before its parent. */
    for (var i = nodes.length - 1; i >= 0; i--) {
      var li = nodes[i];
      var name = li.getAttribute("data-type");
      var self = test(name, info[name]);
      var below = li.querySelector(":scope > ul > li.node:not(.hidden)") !== null;
      li.classList.toggle("match", self);
      li.classList.toggle("hidden", !self && !below);
      setExpanded(li, below);
      if (self) {
        count += 1;
      }
    }
    say(count === 0 ? "No type matches." : count + (count === 1 ? " type matches." : " types match."));
  }

  tree.addEventListener("click", function (event) {
    var button = event.target.closest(".toggle");
    if (button) {
      var li = button.closest("li.node");
      setExpanded(li, li.classList.contains("collapsed"));
    }
  });

  function setAll(open) {
    nodes.forEach(function (li) {
      setExpanded(li, open);
    });
  }
  var expandAll = document.getElementById("expand-all");
  var collapseAll = document.getElementById("collapse-all");
  if (expandAll) {
    expandAll.addEventListener("click", function () { setAll(true); });
  }
  if (collapseAll) {
    collapseAll.addEventListener("click", function () { setAll(false); });
  }

  if (search) {
    search.addEventListener("input", function () {
      filter(search.value);
    });
    search.addEventListener("keydown", function (event) {
      if (event.key === "Escape") {
        search.value = "";
        filter("");
      } else if (event.key === "Enter") {
        var first = tree.querySelector("li.match > .row > a");
        if (first) {
          window.location.href = first.getAttribute("href");
        }
      }
    });
  }

  initialState();
  if (search && search.value) {
    filter(search.value);
  }
  /* Bring the current type into view inside the sidebar only (the page does not move). */
  var here = tree.querySelector("li.current");
  var sidebar = tree.closest(".sidebar");
  if (here && sidebar && sidebar.scrollHeight > sidebar.clientHeight) {
    sidebar.scrollTop = Math.max(0, here.offsetTop - sidebar.clientHeight / 2);
  }
})();
