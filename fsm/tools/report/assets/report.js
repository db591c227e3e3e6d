/* tral-fsm run report: replays a trace (embedded as JSON) at a cursor time. Plain DOM and canvas, uPlot for the
   plots. Every string from the trace goes through textContent, never innerHTML. */
(function () {
  "use strict";
  // D: the model (embedded; a live page loads new ones with tralReport.load), and what is derived from it
  var D = JSON.parse(document.getElementById("data").textContent);
  var M, S, dt, T, keyTicks, eventTicks, Sm, hasTrack, frames, frameTimes, stops;
  function derive() {
    M = D.meta; S = D.states; dt = M.dt || 0.0125; T = Math.max(M.t_end, dt);
    keyTicks = D.keyframes.map(function (k) { return k[0]; });
    eventTicks = D.events.map(function (e) { return e[0]; });
    Sm = D.samples; hasTrack = !!(Sm && Sm["car.x"] && Sm["car.y"]);
    frames = D.frames.filter(function (f) { return f.jpeg || f.det.length; });
    frameTimes = frames.map(function (f) { return f.t; });
    stops = D.transitions.filter(function (tr) { return tr[2] >= 0; }).map(function (tr) { return tr[0]; });
  }
  derive();
  var $ = function (id) { return document.getElementById(id); };
  var cursor = 0, playing = false, lastFrame = 0, selected = -1, lastLeaf = null;

  // -- colours: one per state, stable ------------------------------------------------------------------
  function colour(i) {
    var h = (i * 137.508) % 360;
    return "hsl(" + h.toFixed(0) + ",55%," + (i % 2 ? "62%" : "72%") + ")";
  }

  // -- replay: the configuration and variables after tick k (nearest keyframe, then the events) -------------
  function upper(arr, x) { var lo = 0, hi = arr.length; while (lo < hi) { var m = (lo + hi) >> 1; if (arr[m] <= x) lo = m + 1; else hi = m; } return lo; }
  function stateAt(tick) {
    var k = upper(keyTicks, tick) - 1, active = [], vars = {}, since = -1;
    if (k >= 0) { active = D.keyframes[k][1]; vars = Object.assign({}, D.keyframes[k][2]); since = keyTicks[k]; }
    var changed = {};
    for (var i = upper(eventTicks, since), n = upper(eventTicks, tick); i < n; i++) {
      var e = D.events[i];
      active = e[1];
      for (var name in e[2]) { vars[name] = e[2][name]; if (e[0] === tick) changed[name] = true; }
      for (var j = 0; j < e[3].length; j++) delete vars[e[3][j]];
    }
    return { active: active, vars: vars, changed: changed };
  }
  function tickAt(t) { return Math.floor(t / dt + 1e-6); }

  // -- header -------------------------------------------------------------------------------------------------
  function showHeader() {
    $("title").textContent = M.name;
    $("trace-name").textContent = M.trace;
    if (!window.tralLive) document.title = M.name + " — tral-fsm report";
    var meta = $("meta");
    meta.textContent = "";
    function add(text, cls) {
      if (meta.childNodes.length) meta.appendChild(document.createTextNode("  ·  "));
      var s = document.createElement("span"); s.textContent = text; if (cls) s.className = cls; meta.appendChild(s);
    }
    add(M.source);
    if (M.outcome !== null && M.outcome !== undefined) add("outcome " + M.outcome, M.outcome === "succeeded" ? "good" : "bad");
    else if (M.live) add("live run", "good");
    else add(M.cut_off ? "cut off (no end line)" : "not finished", "bad");
    if (M.interrupted) add("interrupted", "bad");
    if (M.error) add("error: " + M.error, "bad");
    add(T.toFixed(2) + " s, " + M.ticks + " ticks, " + D.transitions.filter(function (tr) { return tr[2] >= 0; }).length + " transitions");
    if (M.seed !== null && M.seed !== undefined) add("seed " + M.seed);
    if (M.world_file) add("world " + M.world_file);
    if (M.overrides.length) add("--set " + M.overrides.join(" "));
    var ul = $("warnings");
    ul.textContent = "";
    M.warnings.forEach(function (w) { var li = document.createElement("li"); li.textContent = w; ul.appendChild(li); });
  }
  showHeader();

  // -- statechart -------------------------------------------------------------------------------------------
  var svg = document.querySelector("#chart svg");
  var groups = {};  // path -> [g]
  if (svg) {
    Array.prototype.forEach.call(svg.querySelectorAll("g[data-path]"), function (g) {
      var p = g.getAttribute("data-path");
      (groups[p] = groups[p] || []).push(g);
      g.addEventListener("click", function (ev) {
        var i = S.indexOf(p);
        if (g.classList.contains("composite") && ev.target.tagName === "text") { fold(p); ev.stopPropagation(); return; }
        if (i >= 0) { showVisits(i); ev.stopPropagation(); }
      });
    });
  } else {
    $("chart").textContent = "No drawing: the trace carries no machine document that can be drawn.";
  }
  // The drawing is seen through its viewBox: the wheel zooms about the pointer, a drag pans, "fit" shows what fits;
  // following the active state moves the view to it (at a readable scale when the whole drawing is not).
  var full = null, vb = null, box = $("chart");
  function applyView() {  // a panel not laid out yet (no width or height) gives no view: the last one stays
    if (svg && vb && vb.w > 0 && vb.h > 0) svg.setAttribute("viewBox", vb.x + " " + vb.y + " " + vb.w + " " + vb.h);
  }
  function boxAspect() { return (box.clientHeight || 400) / (box.clientWidth || 600); }
  // "fit": the largest of the whole drawing, the composites around the active state (outermost first), the active
  // state with the states its arrows join and their labels, or the state alone, that shows its smallest text at
  // READABLE px or more; shown whole, MARGIN px clear of the panel's sides, centred (then moved towards the
  // drawing where the panel would show nothing beside it). The panel grows taller (up to what the window holds
  // below the sticky bars) when that makes a larger part readable. data-fit names the part, data-fit-kind what.
  var READABLE = 9, MARGIN = 16, MAX_FIT = 1, minFont = null;
  function smallestFont() {
    if (minFont === null) {
      minFont = Infinity;
      Array.prototype.forEach.call(svg.querySelectorAll("text"), function (t) {
        var f = parseFloat(getComputedStyle(t).fontSize);
        if (f > 0 && f < minFont) minFont = f;
      });
      if (!isFinite(minFont)) minFont = 10;
    }
    return minFont;
  }
  function union(r, s) {  // drawing-space boxes {x, y, w, h}; r may be null
    if (!s || !(s.width || s.height || s.w || s.h)) return r;
    var b = s.w !== undefined ? s : { x: s.x, y: s.y, w: s.width, h: s.height };
    if (!r) return { x: b.x, y: b.y, w: b.w, h: b.h };
    var x0 = Math.min(r.x, b.x), y0 = Math.min(r.y, b.y);
    return { x: x0, y: y0, w: Math.max(r.x + r.w, b.x + b.w) - x0, h: Math.max(r.y + r.h, b.y + b.h) - y0 };
  }
  function shownBox(els) {  // the union of the boxes of the elements not folded away
    var r = null;
    Array.prototype.forEach.call(els, function (el) { if (!el.closest(".hidden")) r = union(r, el.getBBox()); });
    return r;
  }
  function attrIs(name, value) { return "[" + name + "=\"" + value.replace(/["\\]/g, "\\$&") + "\"]"; }
  function fitParts() {  // [path, kind, drawing-space box], largest first
    var out = [["all", "all", full]];
    var leaf = current && current.active.length ? current.active[0] : (S.length ? S[0] : "");
    if (!leaf) return out;
    var parts = leaf.split("/");
    for (var n = 1; n < parts.length; n++) {
      var p = parts.slice(0, n).join("/"), gs = groups[p];
      if (!gs || !gs.length || gs[0].classList.contains("hidden") || !gs[0].classList.contains("composite")) continue;
      var r = shownBox(gs.map(function (g) { return g.querySelector("rect") || g; }));
      r = union(r, shownBox(svg.querySelectorAll("g.label" + attrIs("data-in", p) + ", g.label[data-in^=\"" +
        (p + "/").replace(/["\\]/g, "\\$&") + "\"]")));
      if (r) out.push([p, "composite", r]);
    }
    var own = groups[leaf] && !groups[leaf][0].classList.contains("hidden") ? shownBox([groups[leaf][0]]) : null;
    if (!own) return out;
    var ends = attrIs("data-from", leaf) + "," + attrIs("data-to", leaf);
    var around = union(own, shownBox(Array.prototype.filter.call(svg.querySelectorAll("polyline.edge, g.label"),
      function (el) { return el.matches(ends); })));
    Array.prototype.forEach.call(svg.querySelectorAll("polyline.edge"), function (e) {
      if (!e.matches(ends)) return;
      var other = e.getAttribute("data-from") === leaf ? e.getAttribute("data-to") : e.getAttribute("data-from");
      var g = groups[other] && groups[other][0];
      if (g && !g.classList.contains("composite")) around = union(around, shownBox([g]));
    });
    if (around.w > own.w || around.h > own.h) out.push([leaf, "around", around]);
    out.push([leaf, "state", own]);
    return out;
  }
  function panelHeights() {  // the panel's own height (66vh in the style), and the most it may grow to: what the
    // window holds below the sticky bars (all of the panel is seen once it is scrolled up to them)
    box.style.height = "";  // the style's height for this window (it changes with the window)
    var base = box.clientHeight || 400, bars = 0;
    ["toolbar", "live-bar"].forEach(function (id) { var el = $(id); if (el) bars += el.offsetHeight; });
    return [base, Math.max(base, Math.floor(window.innerHeight - bars - 12))];
  }
  function fitAll() {
    var W = box.clientWidth || 600, f = smallestFont(), hs = panelHeights(), parts = fitParts();
    var pick = null, height = hs[0];
    for (var i = 0; i < parts.length && !pick; i++) {
      var r = parts[i][2], kw = (W - 2 * MARGIN) / r.w;
      if (Math.min(kw, (hs[0] - 2 * MARGIN) / r.h) * f >= READABLE - 1e-6) pick = parts[i];
      else if (Math.min(kw, (hs[1] - 2 * MARGIN) / r.h) * f >= READABLE - 1e-6) {
        pick = parts[i];
        height = Math.ceil(Math.min(kw, (hs[1] - 2 * MARGIN) / r.h, MAX_FIT) * r.h + 2 * MARGIN);
      }
    }
    pick = pick || parts[parts.length - 1];  // nothing is readable whole: the smallest part, whole
    box.style.height = height + "px";
    frame(pick[2]);
    box.dataset.fit = pick[0];
    box.dataset.fitKind = pick[1];
  }
  function frame(t) {  // the drawing-space box ``t`` shown whole in the panel, MARGIN px clear of its sides
    var W = box.clientWidth || 600, H = box.clientHeight || 400;
    var k = Math.min((W - 2 * MARGIN) / t.w, (H - 2 * MARGIN) / t.h, MAX_FIT);
    if (!(k > 0)) return;  // a panel narrower or lower than its margins (while the page lays itself out)
    var w = W / k, h = H / k, m = MARGIN / k;
    vb = { x: placed(t.x, t.w, w, m, full.x, full.w), y: placed(t.y, t.h, h, m, full.y, full.h), w: w, h: h };
    applyView();
  }
  // where a view of length ``len`` starts on one axis: the part (at ``at``, of length ``size``) centred, then moved
  // towards the drawing (``d0``, ``dlen``) so that no side shows nothing while the other cuts the drawing off,
  // the part always ``m`` clear of both sides
  function placed(at, size, len, m, d0, dlen) {
    var v = at + size / 2 - len / 2;
    if (len >= dlen) v = Math.min(Math.max(d0 + dlen / 2 - len / 2, at + size + m - len), at - m);
    else v = Math.min(Math.max(Math.min(Math.max(v, d0), d0 + dlen - len), at + size + m - len), at - m);
    return v;
  }
  function scale() { return (box.clientWidth || 600) / vb.w; }  // screen px per drawing unit
  function centreOn(r, zoomTo) {  // r: a drawing-space box
    var w = vb.w, h = vb.h;
    if (zoomTo) { var k = scale() / zoomTo; w *= k; h *= k; }
    vb = { x: r.x + r.width / 2 - w / 2, y: r.y + r.height / 2 - h / 2, w: w, h: h };
    applyView();
  }
  // the view outlives a reload of the page (a hot reload's, or the user's): fitted, or where the user left it
  var VIEW_KEY = "tral-chart-view:" + location.pathname;
  if (svg) {
    var v = svg.viewBox.baseVal;
    full = { x: v.x, y: v.y, w: v.width || svg.width.baseVal.value, h: v.height || svg.height.baseVal.value };
    svg.removeAttribute("width"); svg.removeAttribute("height");
    svg.setAttribute("preserveAspectRatio", "xMidYMid meet");
    box.classList.add("zoomable");
    var kept = null;
    try { kept = JSON.parse(sessionStorage.getItem(VIEW_KEY) || "null"); } catch (e) { kept = null; }
    if (kept && !kept.fit && kept.vb && kept.height > 0) {
      $("fit").checked = false;
      box.style.height = kept.height + "px";
      vb = kept.vb; vb.h = vb.w * boxAspect();
      applyView();
    } else { $("fit").checked = true; fitAll(); }
    window.addEventListener("pagehide", function () {
      var view = JSON.stringify({ fit: $("fit").checked, vb: vb, height: box.clientHeight });
      try { sessionStorage.setItem(VIEW_KEY, view); } catch (e) { /* no storage: the next page fits */ }
    });
    box.addEventListener("wheel", function (ev) {
      ev.preventDefault();
      var r = box.getBoundingClientRect(), fx = (ev.clientX - r.left) / r.width, fy = (ev.clientY - r.top) / r.height;
      var k = Math.pow(1.0015, ev.deltaY), w = Math.min(Math.max(vb.w * k, 40), full.w * 4), h = w * boxAspect();
      vb = { x: vb.x + (vb.w - w) * fx, y: vb.y + (vb.h - h) * fy, w: w, h: h };
      $("fit").checked = false;
      applyView();
    }, { passive: false });
    var pan = null;
    box.addEventListener("mousedown", function (ev) { if (ev.button === 0) pan = { x: ev.clientX, y: ev.clientY, vb: vb, moved: false }; });
    window.addEventListener("mousemove", function (ev) {
      if (!pan) return;
      var dx = ev.clientX - pan.x, dy = ev.clientY - pan.y;
      if (!pan.moved && Math.abs(dx) + Math.abs(dy) < 4) return;
      pan.moved = true; box.classList.add("panning");
      var k = pan.vb.w / (box.clientWidth || 600);
      vb = { x: pan.vb.x - dx * k, y: pan.vb.y - dy * k, w: pan.vb.w, h: pan.vb.h };
      $("fit").checked = false;
      applyView();
    });
    window.addEventListener("mouseup", function () { if (pan && pan.moved) box.dataset.dragged = "1"; pan = null; box.classList.remove("panning"); });
    box.addEventListener("click", function (ev) {  // the click that ends a drag is no click on a state
      if (box.dataset.dragged) { delete box.dataset.dragged; ev.stopPropagation(); }
    }, true);
  }
  // "whole": the whole drawing in the panel as it is, however small its text; "fit" is unticked (it would follow)
  $("fit-whole").addEventListener("click", function () {
    if (!svg) return;
    $("fit").checked = false;
    frame(full);
    box.dataset.fit = "all";
    box.dataset.fitKind = "whole";
  });
  $("fit").addEventListener("change", function () { if (!svg) return; if (this.checked) fitAll(); lastLeaf = null; setTime(cursor); });
  window.addEventListener("resize", function () { if (svg && $("fit").checked) fitAll(); else if (svg) { vb.h = vb.w * boxAspect(); applyView(); } });
  // search by name: states whose path holds the text are marked; Enter shows the next one
  var found = [], foundAt = -1;
  $("chart-search").addEventListener("input", function () {
    var q = this.value.trim().toLowerCase();
    found = [];
    foundAt = -1;
    Object.keys(groups).forEach(function (p) {
      var hit = q !== "" && p.toLowerCase().indexOf(q) >= 0;
      groups[p].forEach(function (g) { g.classList.toggle("found", hit); });
      if (hit) found.push(p);
    });
    $("chart-found").textContent = q ? found.length + " found" : "";
  });
  $("chart-search").addEventListener("keydown", function (ev) {
    if (ev.key !== "Enter" || !found.length || !svg) return;
    ev.preventDefault();
    foundAt = (foundAt + 1) % found.length;
    var p = found[foundAt], g = groups[p][0];
    Object.keys(folded).forEach(function (f) { if (folded[f] && p.indexOf(f + "/") === 0) fold(f); });  // unfold to it
    $("fit").checked = false;
    $("follow").checked = false;  // looking elsewhere than the active state
    centreOn(g.getBBox(), Math.max(scale(), 1));
    $("chart-found").textContent = (foundAt + 1) + " of " + found.length + ": " + p;
  });
  var folded = {};
  function fold(path, on) {
    folded[path] = on === undefined ? !folded[path] : on;
    (groups[path] || []).forEach(function (g) { g.classList.toggle("folded", !!folded[path]); });
    refold();
  }
  function refold() {
    var prefixes = Object.keys(folded).filter(function (p) { return folded[p]; });
    function inside(p) { return prefixes.some(function (f) { return p === f || p.indexOf(f + "/") === 0; }); }
    Array.prototype.forEach.call(svg.querySelectorAll("[data-path],[data-in]"), function (el) {
      var p = el.getAttribute("data-path"), within = el.getAttribute("data-in");
      var hide = p !== null ? prefixes.some(function (f) { return p.indexOf(f + "/") === 0; }) : (within !== "" && inside(within));
      el.classList.toggle("hidden", hide);
    });
    squeeze();
  }
  // A folded composite is drawn as its title band, and what is below it moves up: the heights inside it where
  // nothing else is drawn beside it (its ancestors aside) are taken out of the drawing, every y mapped from the
  // drawn ones (so unfolding gives the drawing back as it was).
  var FOLDED_H = 34, drawn = null, drawnH = 0;
  var Y_ATTRS = { rect: ["y", "height"], text: ["y"], line: ["y1", "y2"], circle: ["cy"], polyline: ["points"], polygon: ["points"] };
  function squeeze() {
    if (!drawn) {
      drawn = [];
      drawnH = full.h;
      Array.prototype.forEach.call(svg.querySelectorAll("rect,text,line,circle,polyline,polygon"), function (el) {
        if (el.closest("defs")) return;
        var a = {};
        Y_ATTRS[el.tagName].forEach(function (n) { a[n] = el.getAttribute(n); });
        drawn.push([el, a]);
      });
    }
    var at = new Map(drawn);
    function box(p) {
      var r = groups[p][0].querySelector("rect"), a = r && at.get(r);
      return a ? { y: parseFloat(a.y), h: parseFloat(a.height) } : null;
    }
    var shut = Object.keys(folded).filter(function (f) {
      return folded[f] && groups[f] && !groups[f][0].classList.contains("hidden") &&
        groups[f].some(function (g) { return g.classList.contains("composite"); });
    });
    var cuts = [];
    shut.forEach(function (f) {
      var b = box(f);
      if (!b || b.h <= FOLDED_H) return;
      var free = [[b.y + FOLDED_H, b.y + b.h]];
      Object.keys(groups).forEach(function (p) {
        if (p === f || f.indexOf(p + "/") === 0 || p.indexOf(f + "/") === 0) return;
        if (groups[p][0].classList.contains("hidden")) return;
        var o = box(p);
        if (!o) return;
        var lo = o.y, hi = o.y + o.h, next = [];
        free.forEach(function (c) {  // c minus [lo, hi]
          if (hi <= c[0] || lo >= c[1]) { next.push(c); return; }
          if (lo > c[0]) next.push([c[0], lo]);
          if (hi < c[1]) next.push([hi, c[1]]);
        });
        free = next;
      });
      cuts = cuts.concat(free);
    });
    cuts.sort(function (a, b) { return a[0] - b[0]; });
    var merged = [];
    cuts.forEach(function (c) {
      var last = merged[merged.length - 1];
      if (last && c[0] <= last[1]) last[1] = Math.max(last[1], c[1]); else merged.push([c[0], c[1]]);
    });
    function map(y) {
      var out = y;
      for (var i = 0; i < merged.length; i++) out -= Math.min(Math.max(y - merged[i][0], 0), merged[i][1] - merged[i][0]);
      return out;
    }
    drawn.forEach(function (d) {
      var el = d[0], a = d[1];
      Object.keys(a).forEach(function (n) {
        var v = a[n];
        if (v === null) return;
        if (n === "points") {
          el.setAttribute(n, merged.length ? v.trim().split(/\s+/).map(function (pt) {
            var xy = pt.split(","); return xy[0] + "," + map(parseFloat(xy[1]));
          }).join(" ") : v);
        } else if (n === "height") {
          var y = parseFloat(a.y);
          el.setAttribute(n, merged.length ? String(map(y + parseFloat(v)) - map(y)) : v);
        } else {
          el.setAttribute(n, merged.length ? String(map(parseFloat(v))) : v);
        }
      });
    });
    full.h = map(full.y + drawnH) - full.y;
    svg.dataset.height = String(full.h);
    if ($("fit").checked) fitAll();
  }
  // "fold the rest": every composite not on an active path folded, again whenever the active states change
  var composites = Object.keys(groups).filter(function (p) { return groups[p].some(function (g) { return g.classList.contains("composite"); }); });
  var foldedFor = null;
  function foldRest(active) {
    var key = $("fold-rest").checked ? active.join(",") : "";
    if (key === foldedFor) return;
    foldedFor = key;
    var on = {};
    active.forEach(function (i) { var parts = S[i].split("/"); for (var n = 1; n <= parts.length; n++) on[parts.slice(0, n).join("/")] = true; });
    composites.forEach(function (p) {
      folded[p] = !!key && !on[p];
      groups[p].forEach(function (g) { g.classList.toggle("folded", folded[p]); });
    });
    refold();
  }
  $("fold-rest").addEventListener("change", function () { lastLeaf = null; setTime(cursor); });
  var shown = [];
  function highlight(active) {
    if (svg) foldRest(active);
    shown.forEach(function (g) { g.classList.remove("active"); });
    shown = [];
    var leaf = null;
    active.forEach(function (i) {
      var parts = S[i].split("/");
      for (var n = 1; n <= parts.length; n++) {
        var gs = groups[parts.slice(0, n).join("/")];
        if (gs) gs.forEach(function (g) { g.classList.add("active"); shown.push(g); if (n === parts.length && !leaf) leaf = g; });
      }
    });
    // "fit" follows the active state out of the part it shows (a composite's states stay in their composite's view)
    var part = box.dataset.fit, at = current.active[0];
    if (svg && $("fit").checked && part && part !== "all" && leaf && leaf !== lastLeaf && at !== part &&
        !(box.dataset.fitKind === "composite" && at && at.indexOf(part + "/") === 0)) fitAll();
    if ($("follow").checked && leaf && leaf !== lastLeaf && !leaf.classList.contains("hidden") && svg && !$("fit").checked) {
      var r = leaf.getBBox();  // moved to it when it is not wholly in view
      if (r.x < vb.x || r.x + r.width > vb.x + vb.w || r.y < vb.y || r.y + r.height > vb.y + vb.h) centreOn(r, null);
    }
    lastLeaf = leaf;
  }

  // -- visits of a state ---------------------------------------------------------------------------------
  function transitionAt(time, pred) {
    for (var i = 0; i < D.transitions.length; i++) {
      var tr = D.transitions[i];
      if (Math.abs(tr[0] - time) < dt / 2 && pred(tr)) return tr;
    }
    return null;
  }
  function describe(tr) {
    if (!tr) return "";
    return D.types[tr[4]] + (tr[2] >= 0 ? " from " + S[tr[2]] : "") + " to " + S[tr[3]];
  }
  function showVisits(i) {
    selected = i;
    Object.keys(groups).forEach(function (p) { groups[p].forEach(function (g) { g.classList.toggle("selected", p === S[i]); }); });
    $("visits-of").textContent = "of " + S[i];
    var body = $("visits").tBodies[0];
    body.textContent = "";
    var prefix = S[i] + "/";
    D.lanes.forEach(function (lane) {
      var seg = lane.seg;
      for (var k = 0; k < seg.length; k += 3) {
        if (seg[k + 2] !== i) continue;
        var t0 = seg[k], t1 = seg[k + 1];
        var by = transitionAt(t0, function (tr) { return tr[3] === i; });
        var out = t1 < T - dt / 2 ? transitionAt(t1, function (tr) { return tr[2] >= 0 && (tr[2] === i || (S[i] + "/").indexOf(S[tr[2]] + "/") === 0 || S[tr[2]].indexOf(prefix) === 0); }) : null;
        var row = body.insertRow();
        [t0.toFixed(3) + " s", t1 < T - dt / 2 ? t1.toFixed(3) + " s" : "(active at the end)", (t1 - t0).toFixed(3) + " s",
         by ? describe(by) : "", out ? describe(out) : ""].forEach(function (text) { row.insertCell().textContent = text; });
        row.dataset.t0 = t0; row.dataset.t1 = t1;
        row.addEventListener("click", function () { setTime(parseFloat(this.dataset.t0)); });
      }
    });
    if (!body.rows.length) { var row = body.insertRow(); var c = row.insertCell(); c.colSpan = 5; c.textContent = "never active"; }
    markVisit();
  }
  function markVisit() {
    Array.prototype.forEach.call($("visits").tBodies[0].rows, function (row) {
      var a = parseFloat(row.dataset.t0), b = parseFloat(row.dataset.t1);
      row.classList.toggle("current", cursor >= a && cursor < b);
    });
  }

  // -- variables ----------------------------------------------------------------------------------------------
  // a value as JSON with its numbers to 6 significant digits (the full value is the cell's title): 0.30000000000000004
  // and 16-digit floats would overflow the panel
  function shownValue(v) {
    return JSON.stringify(v, function (k, x) { return typeof x === "number" && isFinite(x) && !Number.isInteger(x) ? Number(x.toPrecision(6)) : x; });
  }
  function showVars(vars, changed) {
    var body = $("vars").tBodies[0];
    body.textContent = "";
    var names = Object.keys(vars).sort();
    names.forEach(function (name) {
      var row = body.insertRow();
      row.dataset.name = name;
      row.insertCell().textContent = name;
      var cell = row.insertCell();
      cell.textContent = shownValue(vars[name]);
      cell.title = cell.dataset.value = JSON.stringify(vars[name]);
      if (changed[name]) row.classList.add("changed");
    });
    if (!names.length) { var row = body.insertRow(); row.insertCell().textContent = "(no variables)"; }
  }

  // -- timeline lanes ---------------------------------------------------------------------------------------
  var LANE_H = 18, LABEL_W = 220, lanes = $("lanes"), lanesBg = document.createElement("canvas");
  // the time window the lanes and plots show (the wheel over the lanes zooms it, a double click shows the whole run)
  var win = null;
  function w0() { return win ? win[0] : 0; }
  function w1() { return win ? Math.min(win[1], T) : T; }
  function laneX(t, w) { return LABEL_W + (w - LABEL_W - 8) * ((t - w0()) / (w1() - w0() || 1)); }
  function laneT(x, w) { return Math.min(T, Math.max(0, w0() + (x - LABEL_W) / (w - LABEL_W - 8) * (w1() - w0()))); }
  function setWindow(a, b) {
    var span = Math.max(b - a, Math.min(T, 20 * dt));
    if (span >= T) win = null;
    else { a = Math.min(Math.max(0, a), T - span); win = [a, a + span]; }
    lanes.dataset.window = win ? win[0].toFixed(3) + " " + win[1].toFixed(3) : "";
    drawLanesBg(); plotWindow(); drawLanes(); drawPlots();
  }
  lanes.addEventListener("wheel", function (ev) {
    ev.preventDefault();
    var r = lanes.getBoundingClientRect(), at = laneT(ev.clientX - r.left, r.width), k = Math.pow(1.0015, ev.deltaY);
    setWindow(at - (at - w0()) * k, at + (w1() - at) * k);
  }, { passive: false });
  lanes.addEventListener("dblclick", function () { setWindow(0, T); });
  // a canvas is given its size only when it changes: setting it (even to the same value) clears the canvas and
  // allocates a new one, which the browser then uploads whole (a redraw after each step of a live run)
  function resize(canvases, w, h) {
    canvases.forEach(function (c) { if (c.width !== w) c.width = w; if (c.height !== h) c.height = h; });
  }
  function drawLanesBg() {
    var ratio = window.devicePixelRatio || 1, w = lanes.clientWidth || 800;
    var h = D.lanes.length * LANE_H + 22;
    lanes.style.height = h + "px";
    resize([lanes, lanesBg], Math.round(w * ratio), Math.round(h * ratio));
    var c = lanesBg.getContext("2d");
    c.setTransform(ratio, 0, 0, ratio, 0, 0);
    c.fillStyle = "#fff"; c.fillRect(0, 0, w, h);
    c.font = "11px Helvetica, Arial, sans-serif"; c.textBaseline = "middle";
    var base = D.lanes.length * LANE_H, span = w1() - w0();
    var step = Math.pow(10, Math.floor(Math.log10(span / 5 || 1)));
    if (span / step > 12) step *= 5; else if (span / step > 6) step *= 2;
    var first = Math.ceil(w0() / step - 1e-9) * step;
    D.lanes.forEach(function (lane, row) {
      c.fillStyle = "#345";
      c.fillText(lane.label.length > 36 ? lane.label.slice(0, 35) + "…" : lane.label, 4 + 6 * Math.min(lane.depth, 4), row * LANE_H + LANE_H / 2);
    });
    c.save(); c.beginPath(); c.rect(LABEL_W, 0, w - LABEL_W, h); c.clip();  // the window's part of the run only
    c.fillStyle = "#e4e4e4";
    for (var g = first; g <= w1() + 1e-9; g += step) c.fillRect(laneX(g, w), 0, 1, base + 4);
    D.lanes.forEach(function (lane, row) {
      var y = row * LANE_H;
      var seg = lane.seg;
      for (var k = 0; k < seg.length; k += 3) {
        var x0 = laneX(seg[k], w), x1 = Math.max(laneX(seg[k + 1], w), x0 + 1);
        c.fillStyle = colour(seg[k + 2]);
        c.fillRect(x0, y + 2, x1 - x0, LANE_H - 4);
        var xs = Math.max(x0, LABEL_W), xe = Math.min(x1, w);  // the part in the window
        if (xe - xs > 40) {
          c.fillStyle = "#222";
          var name = S[seg[k + 2]].split("/").pop();
          c.save(); c.beginPath(); c.rect(xs, y, xe - xs - 2, LANE_H); c.clip();
          c.fillText(name, xs + 3, y + LANE_H / 2); c.restore();
        }
      }
    });
    c.strokeStyle = "rgba(0,0,0,0.55)"; c.lineWidth = 1;
    D.transitions.forEach(function (tr) {
      if (tr[2] < 0) return;
      var x = Math.round(laneX(tr[0], w)) + 0.5;
      c.beginPath(); c.moveTo(x, base); c.lineTo(x, base + 6); c.stroke();
    });
    c.fillStyle = "#c00";
    D.monitors.forEach(function (m) { var x = laneX(m[0], w); c.fillRect(x - 2, base + 6, 4, 4); });
    c.fillStyle = "#555"; c.textBaseline = "top";
    for (var t = first; t <= w1() + 1e-9; t += step) c.fillText(+t.toFixed(3) + " s", laneX(t, w) + 2, base + 10);
    c.restore();
    if (win) { c.fillStyle = "#a60"; c.fillText("zoomed: double-click for the whole run", 4, base + 10); }
  }
  function drawLanes() {
    var ratio = window.devicePixelRatio || 1, w = lanes.clientWidth || 800;
    var c = lanes.getContext("2d");
    c.setTransform(1, 0, 0, 1, 0, 0);
    c.drawImage(lanesBg, 0, 0);
    c.setTransform(ratio, 0, 0, ratio, 0, 0);
    var x = laneX(cursor, w);
    if (x >= LABEL_W - 1 && x <= w) { c.fillStyle = "#c00"; c.fillRect(x - 1, 0, 2, lanes.height / ratio); }
  }
  var dragging = false;
  function fromMouse(ev) { var r = lanes.getBoundingClientRect(); setTime(laneT(ev.clientX - r.left, r.width)); }
  lanes.addEventListener("mousedown", function (ev) { dragging = true; fromMouse(ev); ev.preventDefault(); });
  window.addEventListener("mousemove", function (ev) { if (dragging) fromMouse(ev); });
  window.addEventListener("mouseup", function () { dragging = false; });

  // -- map -------------------------------------------------------------------------------------------------
  var map = $("map"), mapBg = document.createElement("canvas"), view = null, SCALE_STRIP = 20;
  function drawMapBg() {
    trackDrawn = 0;
    map.dataset.redrawn = String((map.dataset.redrawn | 0) + 1);  // whole redraws (tests: a step adds to the track)
    $("map-box").style.display = !D.map && !hasTrack ? "none" : "";
    if (!D.map && !hasTrack) return;
    var ratio = window.devicePixelRatio || 1, w = map.clientWidth || 400;
    var x0, y0, x1, y1;
    if (D.map) { x0 = D.map.bounds[0]; y0 = D.map.bounds[1]; x1 = D.map.bounds[2]; y1 = D.map.bounds[3]; }
    else { x0 = y0 = Infinity; x1 = y1 = -Infinity; }
    if (hasTrack) Sm["car.x"].forEach(function (x, i) { var y = Sm["car.y"][i]; if (x === null) return; x0 = Math.min(x0, x); x1 = Math.max(x1, x); y0 = Math.min(y0, y); y1 = Math.max(y1, y); });
    var pad = 0.3; x0 -= pad; y0 -= pad; x1 += pad; y1 += pad;
    var s = w / (x1 - x0), h = Math.min(Math.max((y1 - y0) * s, 120), 700);
    s = Math.min(s, h / (y1 - y0));
    view = { s: s, x0: x0, y1: y1 };
    var world = h;  // the world's part; below it a strip for the scale bar, clear of the walls at the map's edge
    if (D.map) h += SCALE_STRIP;
    map.style.height = h + "px";
    resize([map, mapBg], Math.round(w * ratio), Math.round(h * ratio));
    var c = mapBg.getContext("2d");
    c.setTransform(ratio, 0, 0, ratio, 0, 0);
    c.fillStyle = "#fff"; c.fillRect(0, 0, w, h);
    function X(x) { return (x - x0) * s; } function Y(y) { return (y1 - y) * s; }
    function label(text, x, y) {  // kept inside the map: a marker or gate at its edge has its name drawn inwards
      var tw = c.measureText(text).width;
      c.fillText(text, Math.max(2, Math.min(x, w - tw - 2)), Math.max(10, Math.min(y, h - 3)));
    }
    view.X = X; view.Y = Y; view.box = [x0, y0, x1, y1];
    if (D.map) {
      c.strokeStyle = "#333"; c.lineWidth = 2;
      D.map.walls.forEach(function (wl) { c.beginPath(); c.moveTo(X(wl[0]), Y(wl[1])); c.lineTo(X(wl[2]), Y(wl[3])); c.stroke(); });
      c.fillStyle = "#999";
      D.map.obstacles.forEach(function (o) {
        c.beginPath();
        if (o.poly) { o.poly.forEach(function (p, i) { if (i) c.lineTo(X(p[0]), Y(p[1])); else c.moveTo(X(p[0]), Y(p[1])); }); c.closePath(); }
        else c.arc(X(o.circle[0]), Y(o.circle[1]), o.circle[2] * s, 0, 2 * Math.PI);
        c.fill();
      });
      c.strokeStyle = "#0a7"; c.lineWidth = 3; c.font = "10px Helvetica, Arial, sans-serif"; c.fillStyle = "#0a7";
      D.map.gates.forEach(function (g) {
        c.beginPath(); c.moveTo(X(g.a[0]), Y(g.a[1])); c.lineTo(X(g.b[0]), Y(g.b[1])); c.stroke();
        label(g.name, X((g.a[0] + g.b[0]) / 2) + 4, Y((g.a[1] + g.b[1]) / 2) - 4);
      });
      c.fillStyle = "#07a";
      D.map.markers.forEach(function (m) { c.fillRect(X(m.p[0]) - 3, Y(m.p[1]) - 3, 6, 6); label("#" + m.id, X(m.p[0]) + 4, Y(m.p[1]) - 4); });
    }
    if (D.map) {  // a scale bar in metres (1, 2, 5, 10 ...: about a fifth of the map's width), below the world, left
      var metres = [0.5, 1, 2, 5, 10, 20, 50, 100].filter(function (m) { return m * s <= w / 4; }).pop() || 0.5;
      var bx = 8, by = world + SCALE_STRIP - 6;
      c.strokeStyle = "#222"; c.lineWidth = 2; c.beginPath();
      c.moveTo(bx, by - 4); c.lineTo(bx, by); c.lineTo(bx + metres * s, by); c.lineTo(bx + metres * s, by - 4); c.stroke();
      c.fillStyle = "#222"; c.font = "10px Helvetica, Arial, sans-serif";
      c.fillText(metres + " m", bx + 4, by - 4);
      map.dataset.scale = String(metres);
    }
    if (hasTrack) drawTrack(c);
  }
  // the trajectory, coloured by the active leaf at each sample: one path per run of a colour; from the samples
  // drawn before on (a live run's new samples are added to the map, not the whole track drawn again)
  var trackDrawn = 0;
  function drawTrack(c) {
    var X = view.X, Y = view.Y;
    c.lineWidth = 2.5; c.lineJoin = "round";
    var xs = Sm["car.x"], ys = Sm["car.y"], ts = Sm.t, open = false, inkNow = null;
    for (var i = trackDrawn; i < ts.length; i++) {
      if (xs[i] === null) { if (open) c.stroke(); open = false; continue; }
      var st = stateAt(tickAt(ts[i])).active, ink = st.length ? colour(st[0]) : "#888";
      if (open && ink !== inkNow) { c.stroke(); open = false; }  // the next path starts where this one ended
      if (!open && i > 0 && xs[i - 1] !== null) { c.beginPath(); c.moveTo(X(xs[i - 1]), Y(ys[i - 1])); open = true; }
      if (open) c.lineTo(X(xs[i]), Y(ys[i]));
      inkNow = ink; c.strokeStyle = ink;
    }
    if (open) c.stroke();
    trackDrawn = ts.length;
    map.dataset.track = String(trackDrawn);
  }
  function trackLeaves() {  // a new sample outside the map's scale: the map is drawn anew, at a new scale
    var b = view.box, xs = Sm["car.x"], ys = Sm["car.y"];
    for (var i = trackDrawn; i < xs.length; i++) {
      if (xs[i] !== null && (xs[i] < b[0] || xs[i] > b[2] || ys[i] < b[1] || ys[i] > b[3])) return true;
    }
    return false;
  }
  function sampleIndex(t) { return Sm ? Math.max(0, upper(Sm.t, t + 1e-9) - 1) : -1; }
  function drawMap() {
    if (!view) return;
    var ratio = window.devicePixelRatio || 1, c = map.getContext("2d");
    c.setTransform(1, 0, 0, 1, 0, 0); c.drawImage(mapBg, 0, 0);
    if (!hasTrack) return;
    c.setTransform(ratio, 0, 0, ratio, 0, 0);
    var i = sampleIndex(cursor), x = Sm["car.x"][i], y = Sm["car.y"][i], h = Sm["car.heading"] ? Sm["car.heading"][i] : 0;
    if (x === null || x === undefined) return;
    var L = D.map ? D.map.car.length : 0.4, W = D.map ? D.map.car.width : 0.2;
    c.save(); c.translate(view.X(x), view.Y(y)); c.rotate(-h);
    c.fillStyle = "rgba(200,30,30,0.85)"; c.fillRect(-L / 2 * view.s, -W / 2 * view.s, L * view.s, W * view.s);
    c.fillStyle = "#fff"; c.fillRect(L / 4 * view.s, -W / 4 * view.s, L / 4 * view.s, W / 2 * view.s);
    c.restore();
  }

  // -- camera ---------------------------------------------------------------------------------------------
  var shownFrame = -2;
  function drawCamera() {
    $("camera-box").style.display = frames.length ? "" : "none";
    if (!frames.length) return;
    var k = upper(frameTimes, cursor + 1e-9) - 1;
    var ageKey = k + "|" + Math.floor(cursor * 4);  // the age said to a quarter of a second
    if (ageKey === shownFrame) return;
    shownFrame = ageKey;
    var img = $("frame"), cv = $("dets"), c = cv.getContext("2d");
    cv.width = 320; cv.height = 240; c.clearRect(0, 0, 320, 240);
    if (k < 0) { img.removeAttribute("src"); $("camera-info").textContent = "no frame yet"; return; }
    var f = frames[k];
    if (f.jpeg) img.src = "data:image/jpeg;base64," + f.jpeg; else img.removeAttribute("src");
    var sx = 320 / (f.w || 160), sy = 240 / (f.h || 120);
    c.strokeStyle = "#0f0"; c.lineWidth = 2; c.fillStyle = "#0f0"; c.font = "bold 12px Helvetica, Arial, sans-serif";
    f.det.forEach(function (d) {
      if (!d.c || d.c.length !== 4) return;
      c.beginPath(); d.c.forEach(function (p, i) { if (i) c.lineTo(p[0] * sx, p[1] * sy); else c.moveTo(p[0] * sx, p[1] * sy); }); c.closePath(); c.stroke();
      c.fillText("#" + d.id, d.c[0][0] * sx, d.c[0][1] * sy - 3);
    });
    // a frame older than its period (and a bit) says how old it is at the cursor: the camera has not seen since
    var next = k + 1 < frames.length ? frames[k + 1].t : null, period = k > 0 ? f.t - frames[k - 1].t : (next !== null ? next - f.t : 1);
    var age = cursor - f.t, stale = age > 1.5 * Math.max(period, dt) ? " (" + age.toFixed(2) + " s old)" : "";
    $("camera-info").dataset.age = stale ? age.toFixed(2) : "";
    $("camera-info").textContent = "frame at " + f.t.toFixed(2) + " s" + stale + ": " + (f.det.length ? f.det.map(function (d) { return "#" + d.id + " at " + d.d.toFixed(2) + " m"; }).join(", ") : "no marker") + (f.gates.length ? "; gates " + f.gates.map(function (g) { return g.join("/"); }).join(", ") : "");
  }

  // -- plots -------------------------------------------------------------------------------------------------
  var plots = [];
  function makePlots() {
    var box = $("plots");
    box.textContent = "";
    plots = [];
    if (!Sm || typeof uPlot === "undefined") return;
    var palette = ["#1f77b4", "#d62728", "#2ca02c", "#9467bd"];
    var per = Math.min(3, D.plots.length || 1);
    var width = Math.max(280, Math.floor((box.clientWidth - 28 - 12 * (per - 1)) / per) - 2);
    D.plots.forEach(function (p) {
      var div = document.createElement("div"); div.className = "plot"; box.appendChild(div);
      var series = [{}].concat(p.series.map(function (s, i) { return { label: s.label, stroke: palette[i % palette.length], width: 1.2 }; }));
      var data = [Sm.t].concat(p.series.map(function (s) { return Sm[s.field]; }));
      // axes from the run's data: x from 0 to the run's end, y from the data (a flat line gets a margin, so it
      // has tick labels), a command of -1 to 1 on -1 to 1
      var yRange = p.unit === "-1 to 1" ? function () { return [-1.05, 1.05]; } : function (u, lo, hi) {
        if (lo === null || hi === null) return [0, 1];
        var pad = hi - lo < 1e-9 ? Math.max(Math.abs(hi) * 0.1, 0.5) : (hi - lo) * 0.05;
        return [lo - pad, hi + pad];
      };
      var u = new uPlot({ title: p.title + " (" + p.unit + ")", width: width, height: 180, series: series,
        scales: { x: { time: false, range: function () { return [w0(), Math.max(w1(), dt)]; } }, y: { range: yRange } },
        axes: [{ label: "time (s)" }, { label: p.unit, size: 56, space: 18 }], cursor: { drag: { x: false, y: false } },
        legend: { live: false } }, data, div);
      var line = document.createElement("div"); line.className = "cursor"; div.appendChild(line);
      u.over.addEventListener("click", function (ev) { setTime(u.posToVal(ev.offsetX, "x")); });
      plots.push({ u: u, line: line, div: div });
    });
    if (win) plotWindow();
  }
  function plotWindow() {  // the plots show the lanes' window
    plots.forEach(function (p) { p.u.setScale("x", { min: w0(), max: w1() }); });
  }
  function updatePlots() {  // new data in the plots there are (a live page), else new plots
    if (!Sm || plots.length !== D.plots.length) { makePlots(); return; }
    D.plots.forEach(function (p, i) { plots[i].u.setData([Sm.t].concat(p.series.map(function (s) { return Sm[s.field]; }))); });
    if (win) plotWindow();
  }
  function drawPlots() {
    plots.forEach(function (p) {
      var o = p.u.over, x = p.u.valToPos(cursor, "x");
      // only inside the plot's own area (its x scale can end before the cursor: the last sample is older)
      p.line.style.display = !isFinite(x) || x < 0 || x > o.clientWidth || cursor < w0() || cursor > w1() ? "none" : "";
      // where the plot area is inside the plot's box (offsetTop would be relative to uPlot's own wrapper, which
      // put the line over the title and short of the x axis)
      var box = p.div.getBoundingClientRect(), area = o.getBoundingClientRect();
      p.line.style.left = (area.left - box.left - p.div.clientLeft + x) + "px";
      p.line.style.top = (area.top - box.top - p.div.clientTop) + "px"; p.line.style.height = area.height + "px";
    });
  }

  // -- the cursor --------------------------------------------------------------------------------------------
  var current = null;
  function setTime(t) {
    cursor = Math.min(T, Math.max(0, t));
    var tick = Math.min(tickAt(cursor), M.ticks !== undefined ? M.ticks : Infinity), st = stateAt(tick);  // no tick past the run
    current = { time: cursor, tick: tick, active: st.active.map(function (i) { return S[i]; }), vars: st.vars };
    var el = $("time"); el.textContent = timeText(tick * dt) + " s · tick " + tick; el.dataset.t = cursor; el.dataset.tick = tick;
    $("active").textContent = current.active.join(", ");
    highlight(st.active);
    showVars(st.vars, st.changed);
    markVisit();
    drawLanes(); drawMap(); drawCamera(); drawPlots();
  }
  function jump(dir) {
    var t = null;
    if (dir > 0) { for (var i = 0; i < stops.length; i++) if (stops[i] > cursor + dt / 2) { t = stops[i]; break; } }
    else { for (var j = stops.length - 1; j >= 0; j--) if (stops[j] < cursor - dt / 2) { t = stops[j]; break; } }
    if (t !== null) setTime(t);
  }
  function play(on) {
    playing = on === undefined ? !playing : on;
    $("play").innerHTML = playing ? "&#10074;&#10074;" : "&#9654;";
    if (playing) { if (cursor >= T) setTime(0); lastFrame = performance.now(); requestAnimationFrame(step); }
  }
  function step(now) {
    if (!playing) return;
    var speed = parseFloat($("speed").value);
    setTime(cursor + (now - lastFrame) / 1000 * speed);
    lastFrame = now;
    if (cursor >= T) play(false); else requestAnimationFrame(step);
  }
  $("play").addEventListener("click", function () { play(); });
  $("prev").addEventListener("click", function () { jump(-1); });
  $("next").addEventListener("click", function () { jump(1); });
  document.addEventListener("keydown", function (ev) {
    if (ev.target && (ev.target.tagName === "INPUT" || ev.target.tagName === "SELECT")) return;
    if (ev.key === " ") { play(); ev.preventDefault(); }
    else if (ev.key === "ArrowLeft") { jump(-1); ev.preventDefault(); }
    else if (ev.key === "ArrowRight") { jump(1); ev.preventDefault(); }
    else if (ev.key === "Home") { setTime(0); ev.preventDefault(); }  // the cursor, not the page's scroll
    else if (ev.key === "End") { setTime(T); ev.preventDefault(); }
  });
  function layout() { drawLanesBg(); drawMapBg(); makePlots(); setTime(cursor); }
  var resizeTimer = null;
  window.addEventListener("resize", function () { clearTimeout(resizeTimer); resizeTimer = setTimeout(layout, 150); });
  layout();
  // a new model (a live page's, as the trace grows): redrawn, the cursor kept or put at the end (``follow``)
  var lastMapKey = null, lastSamples = null;
  function load(data, follow) {
    D = data; derive(); showHeader(); shownFrame = -2;
    // the map's background (walls, the whole track) again only when the states along the track changed; with a
    // world map (the scale is the map's) new samples of the same run are only added to the track (a keyframe
    // changes no state, and an event comes before the samples of its tick: it colours only the samples after)
    var mapKey = D.events.length + "|" + map.clientWidth, samples = Sm ? Sm.t.length : 0;
    drawLanesBg();
    if (mapKey !== lastMapKey || Sm !== lastSamples ||
        (samples !== trackDrawn && (!D.map || !view || (hasTrack && trackLeaves())))) {
      lastMapKey = mapKey; lastSamples = Sm; drawMapBg();
    } else if (hasTrack && samples !== trackDrawn) {
      var ratio = window.devicePixelRatio || 1, c = mapBg.getContext("2d");
      c.setTransform(ratio, 0, 0, ratio, 0, 0);
      drawTrack(c);
    }
    updatePlots();
    if (selected >= 0 && selected < S.length) showVisits(selected);
    setTime(follow ? T : cursor);
  }
  // a time in seconds with as many decimals as the tick needs (3 to 6: 0.0125 s ticks give 14.7625), rounded as
  // a decimal, so that a tick's time reads the same wherever it is shown (the toolbar, the status, Why, explain)
  function timeText(t) {
    var places = Math.min(6, Math.max(3, (String(+dt.toFixed(9)).split(".")[1] || "").length));
    return (Math.round(t * 1e6) / 1e6).toFixed(places);
  }
  // for tests and the console: the state at the cursor, and moving it
  window.tralReport = { setTime: setTime, current: function () { return current; }, stateAt: stateAt, duration: T, dt: dt,
    timeText: timeText, load: load, end: function () { return T; }, cursor: function () { return cursor; } };
})();
