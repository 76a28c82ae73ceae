// vpid-bench report: sortable tables and optimizer toggles of the inline SVG figures.
// Plain script, no library, nothing loaded from elsewhere (the pages open from file://).
"use strict";
(function () {
  function key(td) {
    var raw = td.getAttribute("data-sort");
    if (raw !== null) { return raw === "" ? NaN : parseFloat(raw); }
    return td.textContent.trim().toLowerCase();
  }
  function compare(a, b, dir) {
    var an = typeof a === "number", bn = typeof b === "number";
    if (an && bn) {
      if (isNaN(a) || isNaN(b)) { return isNaN(a) - isNaN(b); } // missing values last
      return dir * (a - b);
    }
    return dir * String(a).localeCompare(String(b), undefined, { numeric: true });
  }
  document.querySelectorAll("table.sortable").forEach(function (table) {
    var heads = table.querySelectorAll("thead th");
    heads.forEach(function (th, col) {
      th.querySelector("button").addEventListener("click", function () {
        var dir = th.getAttribute("aria-sort") === "ascending" ? -1 : 1;
        heads.forEach(function (h) { h.setAttribute("aria-sort", "none"); });
        th.setAttribute("aria-sort", dir === 1 ? "ascending" : "descending");
        var body = table.tBodies[0];
        var rows = Array.prototype.slice.call(body.rows);
        rows.sort(function (r1, r2) { return compare(key(r1.cells[col]), key(r2.cells[col]), dir); });
        rows.forEach(function (r) { body.appendChild(r); });
      });
    });
  });
  document.querySelectorAll("figure.interactive").forEach(function (fig) {
    function show(i, on) {
      var g = fig.querySelector('g.series[data-series="' + i + '"]');
      var b = fig.querySelector('button.toggle[data-series="' + i + '"]');
      if (g) { g.style.display = on ? "" : "none"; }
      if (b) { b.setAttribute("aria-pressed", on ? "true" : "false"); }
    }
    fig.querySelectorAll("button.toggle").forEach(function (b) {
      b.addEventListener("click", function () {
        show(b.getAttribute("data-series"), b.getAttribute("aria-pressed") !== "true");
      });
    });
    fig.querySelectorAll("button.all").forEach(function (b) {
      b.addEventListener("click", function () {
        fig.querySelectorAll("button.toggle").forEach(function (t) {
          show(t.getAttribute("data-series"), b.getAttribute("data-show") === "1");
        });
      });
    });
  });
})();
