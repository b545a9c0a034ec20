// index.html's behaviour (inlined by report/report_page.py). Image comparison viewers: one per
// material; the images of one lighting are stacked and one is shown at a time, so switching
// (keys, hover, click) alternates them in place: the way FLIP's authors compare images.
// Sortable tables. No network, no libraries.
"use strict";
(function () {
  const viewers = Array.from(document.querySelectorAll(".viewer"));
  let active = viewers[0] || null;

  function setActive(v) {
    if (active && active !== v) active.classList.remove("active");
    active = v;
    if (v) v.classList.add("active");
  }

  function initViewer(v) {
    const state = { lighting: 0, image: 0, last_fit: 1 };
    const groups = Array.from(v.querySelectorAll(".lighting-group"));
    const buttons = Array.from(v.querySelectorAll(".lightings button"));
    const slider = v.querySelector("input.exposure");
    const evLabel = v.querySelector(".ev");
    const slope = Array.from(v.querySelectorAll("feFuncR, feFuncG, feFuncB"));
    const stacks = Array.from(v.querySelectorAll(".stack"));

    function show() {
      groups.forEach((g, gi) => {
        g.classList.toggle("hidden", gi !== state.lighting);
        const imgs = Array.from(g.querySelectorAll(".stack img"));
        const thumbs = Array.from(g.querySelectorAll(".thumb"));
        const errors = Array.from(g.querySelectorAll(".error figure"));
        imgs.forEach((im, i) => im.classList.toggle("hidden", i !== state.image));
        thumbs.forEach((t, i) => t.classList.toggle("on", i === state.image));
        const fit = state.image > 0 ? state.image : state.last_fit;
        errors.forEach((e, i) => e.classList.toggle("hidden", i + 1 !== fit));
        const label = g.querySelector(".shown-label");
        if (label && thumbs[state.image]) label.textContent = thumbs[state.image].dataset.label;
      });
      buttons.forEach((b, i) => b.classList.toggle("on", i === state.lighting));
      v.dataset.shown = state.lighting + ":" + state.image;
    }
    function count() {
      return groups[state.lighting].querySelectorAll(".stack img").length;
    }
    function select(i) {
      const n = count();
      state.image = ((i % n) + n) % n;
      if (state.image > 0) state.last_fit = state.image;
      show();
    }
    function exposure(ev) {
      // The SVG filter works in linear RGB (color-interpolation-filters): slope 2^EV scales the
      // preview's linear radiance, as an exposure change does. Clipped pixels stay clipped.
      slider.value = ev;
      evLabel.textContent = (ev > 0 ? "+" : "") + Number(ev).toFixed(1) + " EV";
      slope.forEach((f) => f.setAttribute("slope", String(Math.pow(2, ev))));
      stacks.forEach((s) => { s.style.filter = Number(ev) === 0 ? "none" : "url(#" + v.dataset.filter + ")"; });
    }
    v.viewer = {
      key(e) {
        const k = e.key;
        if (k === " " || k === "f") {  // Flip: reference <-> the last fit shown.
          select(state.image === 0 ? state.last_fit : 0);
        } else if (k === "ArrowRight" || k === "n") {
          select(state.image + 1);
        } else if (k === "ArrowLeft" || k === "p") {
          select(state.image - 1);
        } else if (k === "r" || k === "0") {
          select(0);
        } else if (k >= "1" && k <= "9") {
          if (Number(k) < count()) select(Number(k));
        } else if (k === "]" || k === "ArrowDown") {
          state.lighting = (state.lighting + 1) % groups.length;
          select(Math.min(state.image, count() - 1));
        } else if (k === "[" || k === "ArrowUp") {
          state.lighting = (state.lighting - 1 + groups.length) % groups.length;
          select(Math.min(state.image, count() - 1));
        } else if (k === "+" || k === "=") {
          exposure(Math.min(Number(slider.max), Number(slider.value) + 0.5));
        } else if (k === "-") {
          exposure(Math.max(Number(slider.min), Number(slider.value) - 0.5));
        } else {
          return false;
        }
        return true;
      },
    };
    buttons.forEach((b, i) => b.addEventListener("click", () => {
      state.lighting = i;
      select(Math.min(state.image, count() - 1));
    }));
    groups.forEach((g) => g.querySelectorAll(".thumb").forEach((t, i) => {
      t.addEventListener("mouseenter", () => select(i));
      t.addEventListener("click", () => select(i));
    }));
    slider.addEventListener("input", () => exposure(Number(slider.value)));
    v.addEventListener("focus", () => setActive(v));
    v.addEventListener("mouseenter", () => setActive(v));
    v.addEventListener("click", () => { setActive(v); v.focus({ preventScroll: true }); });
    exposure(0);
    show();
  }

  viewers.forEach(initViewer);
  document.addEventListener("keydown", (e) => {
    if (e.ctrlKey || e.metaKey || e.altKey) return;
    if (e.target && (e.target.tagName === "INPUT" && e.target.type !== "range")) return;
    const v = (document.activeElement && document.activeElement.closest &&
               document.activeElement.closest(".viewer")) || active;
    if (v && v.viewer.key(e)) e.preventDefault();
  });

  // Detail tables carry their rows as JSON; they are built when their <details> first opens.
  function fill(table) {
    const src = table.dataset.rows && document.getElementById(table.dataset.rows);
    if (!src || table.tBodies[0].rows.length) return;
    const body = table.tBodies[0];
    JSON.parse(src.textContent).forEach((cells) => {
      const tr = body.insertRow();
      cells.forEach((c) => {
        const td = tr.insertCell();
        td.textContent = c;
        if (c === "yes") td.className = "yes";
        else if (c === "no" || c === "NO") td.className = "no";
      });
    });
  }
  document.querySelectorAll("details").forEach((d) => {
    const tables = () => d.querySelectorAll("table[data-rows]").forEach(fill);
    if (d.open) tables();
    d.addEventListener("toggle", () => { if (d.open) tables(); });
  });

  // Sortable tables: click a header; numbers sort as numbers, empty cells last.
  document.querySelectorAll("table.sortable").forEach((table) => {
    const heads = Array.from(table.querySelectorAll("thead th"));
    heads.forEach((th, col) => th.addEventListener("click", () => {
      fill(table);
      const asc = th.getAttribute("aria-sort") !== "ascending";
      heads.forEach((h) => h.removeAttribute("aria-sort"));
      th.setAttribute("aria-sort", asc ? "ascending" : "descending");
      const body = table.tBodies[0];
      const rows = Array.from(body.rows);
      const keyOf = (r) => {
        const t = r.cells[col] ? r.cells[col].textContent.trim() : "";
        const x = parseFloat(t);
        return t === "" ? null : (isNaN(x) || !/^[-+0-9.]/.test(t) ? t : x);
      };
      rows.sort((a, b) => {
        const x = keyOf(a), y = keyOf(b);
        if (x === null || y === null) return (x === null) - (y === null);
        const c = typeof x === typeof y ? (x < y ? -1 : x > y ? 1 : 0)
                                        : (typeof x === "number" ? -1 : 1);
        return asc ? c : -c;
      });
      rows.forEach((r) => body.appendChild(r));
    }));
  });
})();
