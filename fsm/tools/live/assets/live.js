/* tral-fsm live: the stream (the trace's lines, and the run's status) from the server's WebSocket into the report's
   front end, and the controls that steer the run. Every string from the run goes through textContent. */
(function () {
  "use strict";
  var $ = function (id) { return document.getElementById(id); };
  var R = window.tralReport, model = new window.TraceModel(JSON.parse($("base").textContent));
  var token = new URLSearchParams(location.search).get("token") || "";
  var decoder = new TextDecoder("utf-8");
  var ws = null, status = null, nextId = 1, pending = {}, dirty = false, drawing = false, lastDraw = 0, cost = 0;
  var live = true, followEnd = null, statusShown = true, breaksShown = "";
  // reconnecting: the server's word that the run is over (null: none yet), attempts since the last good socket
  var bye = null, attempts = 0, opened = false, inputsShown = "";

  // -- drawing: the model rebuilt from the lines so far, at most about 30 times a second ---------------------------
  function schedule() {
    if (drawing) return;
    drawing = true;
    // while the run runs, at most about 30 redraws a second (fewer when a redraw is slow); paused (a step, a
    // breakpoint), at once: the page answers a click
    // (as fast as possible: at most 2 a second, the server sends 5: a page that redraws more takes the run's processor)
    var running = !status || status.state === "running", fastest = !!status && status.speed === null;
    var wait = running ? Math.max(0, Math.max(fastest ? 500 : 33, (fastest ? 10 : 3) * cost) - (performance.now() - lastDraw)) : 0;
    setTimeout(function () { requestAnimationFrame(draw); }, wait);
  }
  function draw() {
    drawing = false;
    // the latest status only (a fast run sends many); none after a reset until the rewound run's comes
    if (!statusShown) { statusShown = true; if (status) showStatus(); }
    if (!dirty) return;
    dirty = false;
    var t0 = performance.now(), dt = R.dt || 0.0125;
    var atEnd = followEnd === null || Math.abs(R.cursor() - followEnd) < dt / 2;  // the cursor follows the run
    var data = model.build();
    R.load(data, atEnd);
    if (atEnd) followEnd = R.end();
    showInputs();
    showLog(data);
    lastDraw = performance.now();
    cost = lastDraw - t0;
    document.body.dataset.drawn = String((document.body.dataset.drawn | 0) + 1);
    document.body.dataset.tick = String(R.current().tick);
  }

  // -- the sticky bars: what the page scrolls into view (a focused field, a found text) lands below them ------------
  function padScroll() {
    var bars = $("toolbar").offsetHeight + $("live-bar").offsetHeight;
    $("live-bar").style.top = $("toolbar").offsetHeight + "px";  // right below the toolbar, however tall it wraps
    document.documentElement.style.scrollPaddingTop = (bars + 6) + "px";
    document.documentElement.dataset.bars = String(bars);
  }
  padScroll();
  window.addEventListener("resize", padScroll);

  // -- the stream ---------------------------------------------------------------------------------------------------
  function connect() {
    // the stream is next to the page: /ws for a run, /run/ID/ws for a run of a sweep's page
    var url = (location.protocol === "https:" ? "wss://" : "ws://") + location.host +
      location.pathname.replace(/\/+$/, "") + "/ws" +
      (token ? "?token=" + encodeURIComponent(token) : "");
    var sock = new WebSocket(url);
    ws = sock;
    sock.binaryType = "arraybuffer";
    sock.onopen = function () { $("conn").textContent = "connected"; $("conn").className = "conn up"; };
    sock.onclose = function () {
      if (sock !== ws) return;  // an older socket's end (a reconnect has replaced it)
      if (!statusShown && status) showStatus();  // the last status, before the controls go off
      statusShown = true;
      setControls(false);
      pending = {};
      if (bye !== null) {  // the server said the run is over: for good
        $("conn").textContent = "disconnected"; $("conn").className = "conn down";
        notice("The server has ended (" + bye + "); what was received stays on this page.");
        return;
      }
      // no word from the server: the connection dropped (a network blip, a sleeping laptop). Again, with backoff
      var wait = Math.min(10000, 500 * Math.pow(2, attempts++));
      $("conn").textContent = "reconnecting…"; $("conn").className = "conn down";
      notice("The connection to the run was lost; reconnecting in " + (wait / 1000).toFixed(1) + " s (attempt " + attempts + ").");
      setTimeout(connect, wait);
    };
    sock.onmessage = function (ev) {
      if (sock !== ws) return;
      if (typeof ev.data !== "string") {
        model.addText(decoder.decode(ev.data));
        dirty = true;
        // a paused run's new lines (a step's) usually come right before its status: one redraw, on the status;
        // lines that come after it (a rewind's last ones can) are drawn shortly after, or they would wait for the
        // next status, which a paused run does not send
        if (!status || status.state === "running") schedule();
        else setTimeout(function () { if (dirty) schedule(); }, 50);
        return;
      }
      var m = JSON.parse(ev.data);
      if (m.kind === "hello") {
        live = m.live;
        if (opened) {  // a reconnect: the server sends the trace from its start again, and the status
          model.reset(); status = null; statusShown = true; followEnd = null; breaksShown = inputsShown = ""; dirty = true;
          notice("Reconnected: the page was rebuilt from the run's trace.");
        }
        opened = true; attempts = 0;
        setControls(live);
        watchRows = []; hits = [];
        asking = null; plotAsking = false; forgetExact();  // requests of a dropped socket get no answer
        if (live) send("watched", {}, function (r) { if (r.ok) { watchRows = []; addWatched(r.rows); } });
        if (!live) {  // a finished run's trace: no controls to show greyed out, only what the page is
          $("live-bar").classList.add("static");
          $("run-state").textContent = "a finished run's trace: nothing to steer (the report's controls replay it)";
        }
      }
      else if (m.kind === "bye") bye = m.why || "the run has ended";
      else if (m.kind === "watched") addWatched(m.rows);
      else if (m.kind === "hit") { hits.push(m); logDirty = true; schedule(); }
      else if (m.kind === "reset") { forgetExact(); model.reset(); status = null; statusShown = true; followEnd = null; dirty = true; }
      else if (m.kind === "status") {  // redrawn when the run moved on or changed state, not for a breakpoint's count
        if (!status || m.tick !== status.tick || m.state !== status.state) dirty = true;
        status = m;
        // the run is at this tick even if no line of it was written (nothing happened). The latest status says
        // so, not the highest: a status of the run before a rewind can still arrive after the reset
        model.runTick = m.tick;
        // a running run's statuses are shown with the next redraw (a fast run sends many); any other at once
        if (m.state === "running") statusShown = false; else { statusShown = true; showStatus(); }
        schedule();
      }
      else if (m.kind === "reload") {
        showReload(m);
        // the server now serves the page with the new statechart: this page is rebuilt from it (the run, its
        // breakpoints, watches and trace are the server's; the page reads them again)
        if (m.ok) setTimeout(function () { sessionStorage.setItem("tral-reloaded", $("reload").textContent); location.reload(); }, 300);
      }
      else if (m.kind === "reply" && m.command === "reload") { if (!m.ok) showReload({ ok: false, file: "", errors: [m.error] }); }
      else if (m.kind === "reply") { var done = pending[m.id]; delete pending[m.id]; if (done) done(m); else if (!m.ok) notice(m.error); }
      else if (m.kind === "rewound") {
        forgetExact();
        var said = [];
        if (m.dropped) said.push(m.dropped + " later input" + (m.dropped === 1 ? "" : "s") + " dropped");
        if (m.reloads_dropped) said.push(m.reloads_dropped + " later hot reload" + (m.reloads_dropped === 1 ? "" : "s") +
          " undone: the run goes on with the machine it had at that tick (save the file again to reload it)");
        notice("Rewound to tick " + m.tick + (said.length ? "; " + said.join("; ") : "") + ".");
        noticeTick = m.tick;  // said until the run is told to move on from there
      }
    };
  }
  function send(cmd, args, done) {
    if (!ws || ws.readyState !== 1) return;
    if (noticeTick !== null && /^(step|step_transition|resume)$/.test(cmd)) notice("");
    var id = nextId++;
    if (done) pending[id] = done;
    var msg = {};
    for (var k in args || {}) msg[k] = args[k];
    msg.cmd = cmd; msg.id = id;  // the request's own number: no argument may take its place
    ws.send(JSON.stringify(msg));
  }
  function showReload(m) {  // a hot reload: the edited file's located errors, or what the swap kept
    var box = $("reload");
    box.hidden = false;
    box.className = m.ok ? "ok" : "error";
    box.dataset.ok = m.ok ? "1" : "0";
    box.dataset.tick = m.ok ? m.tick : "";
    box.textContent = m.ok
      ? "Reloaded " + m.file + " before tick " + m.tick + ": " + m.text + ". The statechart is being redrawn."
      : "The edited " + (m.file || "machine") + " was not loaded; the run goes on with the machine it has:\n" + m.errors.join("\n");
  }
  var noticeTick = null;  // the tick a notice is about (a rewind's): it goes when the run is stepped or resumed
  function notice(text) { var n = $("notice"); n.hidden = !text; n.textContent = text || ""; noticeTick = null; }

  // -- status ---------------------------------------------------------------------------------------------------------
  function showStatus() {
    var st = status, el = $("run-state");
    el.className = st.state;
    var text = st.state;
    if (st.state === "ended") text += ": " + (st.ended === "finished" ? "finished, outcome " + st.outcome : st.ended) + (st.error ? " (" + st.error + ")" : "");
    el.textContent = text;
    var tick = $("run-tick");
    tick.textContent = "tick " + st.tick + " (" + R.timeText(st.time) + " s)" + (st.active.length ? "  " + st.active.join(", ") : "");
    tick.dataset.tick = st.tick; tick.dataset.state = st.state;
    var hit = $("hit");
    hit.hidden = !st.hit;
    if (st.hit) hit.textContent = (st.hit.breakpoint !== null ? "Breakpoint " + st.hit.breakpoint + " (" + st.hit.text + "): " : st.hit.text + ": ") +
      st.hit.why + " at tick " + st.hit.tick + " (" + R.timeText(st.hit.time) + " s)";
    var sp = $("run-speed"), want = st.speed === null ? "max" : String(st.speed);
    if (document.activeElement !== sp) {
      if (!Array.prototype.some.call(sp.options, function (o) { return o.value === want; })) {
        var o = document.createElement("option"); o.value = want; o.textContent = want + "\u00d7"; sp.appendChild(o);
      }
      sp.value = want;
    }
    $("run-pause").disabled = st.state !== "running";
    $("run-resume").disabled = st.state !== "paused";
    ["run-step", "run-step-n", "run-step-tr"].forEach(function (id) { $(id).disabled = st.state === "ended"; });
    $("run-rewind").disabled = !st.can_rewind;
    showBreakpoints(st.breakpoints);
    showInputs();
    showWatches();
    askWhy();
  }
  function showBreakpoints(list) {
    var key = JSON.stringify(list);
    if (key === breaksShown) return;  // the table is rebuilt only when a breakpoint changed
    breaksShown = key;
    var body = $("breaks").tBodies[0];
    body.textContent = "";
    list.forEach(function (bp) {
      var row = body.insertRow();
      row.dataset.id = bp.id;
      if (!bp.enabled) row.className = "off";
      row.insertCell().textContent = bp.id;
      row.insertCell().textContent = bp.text + (bp.error ? " — " + bp.error : "");
      var hits = row.insertCell(); hits.className = "hits"; hits.textContent = bp.hits + " hit" + (bp.hits === 1 ? "" : "s");
      var b = document.createElement("button"); b.type = "button"; b.textContent = "remove";
      b.addEventListener("click", function () { send("unbreak", { breakpoint: bp.id }, reply); });
      row.insertCell().appendChild(b);
    });
  }
  function showInputs() {  // the trace's inputs and reloads, then those the server has not applied yet (pending)
    var body = $("inputs").tBodies[0], rows = model.inputs.map(function (line) {
      return [line.tick, line.text || line.input.kind];
    });
    if (status) rows = rows.concat(status.inputs.filter(function (r) { return r[0] > status.tick; }));
    rows = rows.slice(-50);
    var key = JSON.stringify(rows) + (status ? status.tick : "");
    if (key === inputsShown) return;
    inputsShown = key;
    body.textContent = "";
    rows.forEach(function (r) {
      var row = body.insertRow();
      row.insertCell().textContent = r[0];
      row.insertCell().textContent = r[1];
      if (status && r[0] > status.tick) { row.className = "pending"; row.title = "applied before tick " + r[0]; }
    });
  }
  function setControls(on) {
    Array.prototype.forEach.call(document.querySelectorAll("#live-bar button, #live-bar select, #live-bar input, #break-form *, #inject-form *, #watch-form *"),
      function (el) { el.disabled = !on; });
  }

  // -- controls ---------------------------------------------------------------------------------------------------
  $("run-pause").addEventListener("click", function () { send("pause"); });
  $("run-resume").addEventListener("click", function () { send("resume"); });
  $("run-step").addEventListener("click", function () { send("step", { n: 1 }); });
  $("run-step-n").addEventListener("click", function () { send("step", { n: parseInt($("step-n").value, 10) }, reply); });
  $("run-step-tr").addEventListener("click", function () { send("step_transition"); });
  $("run-speed").addEventListener("change", function () { var v = this.value; send("speed", { x: v === "max" ? null : parseFloat(v) }, reply); });
  $("run-stop").addEventListener("click", function () { send("stop"); });
  $("run-rewind").addEventListener("click", function () { send("rewind", { tick: R.current().tick }, reply); });
  function reply(m) { if (!m.ok) notice(m.error); }
  // the keys the buttons' titles name (not while typing in a form; the report's own keys move the cursor)
  var KEYS = { p: "run-pause", r: "run-resume", s: "run-step", t: "run-step-tr" };
  document.addEventListener("keydown", function (ev) {
    var t = ev.target && ev.target.tagName;
    if (t === "INPUT" || t === "SELECT" || t === "TEXTAREA" || ev.ctrlKey || ev.metaKey || ev.altKey) return;
    var button = KEYS[ev.key] && $(KEYS[ev.key]);
    if (button && !button.disabled) { button.click(); ev.preventDefault(); }
  });

  var BREAK_HINTS = {
    enter: ["state path or glob, e.g. lap1/*", null], leave: ["state path or glob", null],
    transition: ["from (glob)", "to (glob)"], monitor: ["owner (glob)", "monitor (glob)"],
    exception: ["owner (glob)", null], timeout: ["owner (glob)", null],
    expr: ["expression, e.g. car_front < 0.5 or n > 3", null]
  };
  function breakHints() {
    var h = BREAK_HINTS[$("break-kind").value];
    $("break-a").placeholder = h[0]; $("break-a").size = $("break-kind").value === "expr" ? 36 : 22;
    $("break-b").hidden = !h[1]; if (h[1]) $("break-b").placeholder = h[1];
  }
  $("break-kind").addEventListener("change", breakHints);
  breakHints();
  $("break-form").addEventListener("submit", function (ev) {
    ev.preventDefault();
    var kind = $("break-kind").value, a = $("break-a").value.trim(), b = $("break-b").value.trim(), spec = { kind: kind };
    if (kind === "enter" || kind === "leave") spec.state = a || "*";
    else if (kind === "transition") { spec.from = a || "*"; spec.to = b || "*"; }
    else if (kind === "monitor") { spec.owner = a || "*"; spec.monitor = b || "*"; }
    else if (kind === "exception" || kind === "timeout") spec.owner = a || "*";
    else spec.expr = $("break-a").value;
    send("break", { spec: spec }, function (m) {
      var box = $("break-error");
      box.hidden = m.ok;
      if (m.ok) { $("break-a").value = ""; $("break-b").value = ""; return; }
      box.textContent = m.column ? spec.expr + "\n" + " ".repeat(m.column - 1) + "^ " + m.error + " (column " + m.column + ")" : m.error;
      box.dataset.column = m.column || "";
    });
  });

  var INJECT_HINTS = {
    set: ["variable", "value"], signal: ["signal", "1 or 0"], force: ["left/right/front/distance/speed", "value", "ticks"],
    monitor: ["owner state", "monitor label"], finish: ["state path", "outcome (succeeded)"], pause: ["state path ('' = machine)"],
    resume: ["state path ('' = machine)"]
  };
  function injectHints() {
    var h = INJECT_HINTS[$("inject-kind").value];
    ["inject-a", "inject-b", "inject-c"].forEach(function (id, i) { $(id).hidden = !h[i]; if (h[i]) $(id).placeholder = h[i]; });
  }
  $("inject-kind").addEventListener("change", injectHints);
  injectHints();
  function value(text) {
    var t = text.trim();
    if (t === "true") return true;
    if (t === "false") return false;
    if (t !== "" && isFinite(Number(t))) return Number(t);
    if (/^[\[{]/.test(t)) { try { return JSON.parse(t); } catch (e) { /* not JSON: sent as the text it is */ } }
    return text;
  }
  function number(text) {  // "" or not a number: null, which the server refuses by name ("1e9" stays 1e9, not 1)
    var t = text.trim(), n = Number(t);
    return t === "" || !isFinite(n) ? null : n;
  }
  $("inject-form").addEventListener("submit", function (ev) {
    ev.preventDefault();
    var kind = $("inject-kind").value, a = $("inject-a").value.trim(), b = $("inject-b").value, c = $("inject-c").value, input;
    if (kind === "set") { input = { kind: "set", values: {} }; input.values[a] = value(b); }
    else if (kind === "signal") input = { kind: "signal", name: a, value: !/^(0|false|low|off)$/i.test(b.trim()) };
    else if (kind === "force") input = { kind: "force", sensor: a, value: number(b), ticks: number(c) };
    else if (kind === "monitor") input = { kind: "monitor", owner: a, monitor: b.trim() };
    else if (kind === "finish") input = { kind: "finish", path: a, outcome: b.trim() || "succeeded" };
    else input = { kind: "pause", path: a, paused: kind === "pause" };
    $("inject-error").hidden = true;  // until this one's answer
    send("input", { input: input }, function (m) {
      var box = $("inject-error"), field = { name: "inject-a", sensor: "inject-a", value: "inject-b", ticks: "inject-c" }[m.field];
      box.hidden = m.ok;
      box.textContent = m.ok ? "" : m.error;
      box.dataset.field = m.ok ? "" : (m.field || "");
      ["inject-a", "inject-b", "inject-c"].forEach(function (id) { $(id).classList.toggle("wrong", !m.ok && id === field); });
      if (!m.ok && field) $(field).focus();  // the refusal points at the field it is about
    });
  });

  // -- why: asked only while the panel is open and the run paused (it costs a re-simulation to the tick) ---------
  var whyAsked = null;
  function askWhy() {
    if ($("why-box").open && !live) { $("why-info").textContent = "A finished run's trace: fsmctl explain TRACE --tick N says why a tick did what it did."; return; }
    if (!$("why-box").open || !status) return;
    if (status.state === "running") {  // what is shown was asked at a pause: said to be old, dimmed, asked anew
      if ($("why-box").dataset.tick && !$("why").classList.contains("stale")) {
        $("why").classList.add("stale");
        $("why-info").className = "";
        $("why-info").textContent = "The run has gone on: below is tick " + $("why-box").dataset.tick +
          ". Why is asked again when the run pauses.";
      }
      whyAsked = null;
      return;
    }
    if (status.tick < 1) { $("why-info").textContent = "No tick has run yet: step once, and Why says what it did."; return; }
    var key = status.tick + "|" + status.inputs.length + "|" + status.state;
    if (key === whyAsked) return;
    whyAsked = key;
    $("why-info").textContent = "re-simulating to tick " + status.tick + "…";
    send("why", { tick: status.tick }, showWhy);
  }
  function showWhy(m) {
    var body = $("why").tBodies[0], info = $("why-info");
    body.textContent = "";
    $("why").classList.remove("stale");
    if (!m.ok) { info.textContent = m.error; info.className = "error"; return; }
    var w = m.why;
    info.className = "";
    info.textContent = "Tick " + w.tick + " (" + R.timeText(w.time) + " s) from " + (w.active.join(", ") || "nothing") +
      ": fired " + ((w.fired.concat(w.monitors)).join("; ") || "nothing") + (w.paused.length ? "; paused: " + w.paused.join(", ") : "");
    $("why-box").dataset.tick = w.tick;
    w.states.forEach(function (st) {
      var head = body.insertRow(); head.className = "state";
      var c = head.insertCell(); c.colSpan = 5; c.textContent = st.state + (st.transitions.length ? "" : ": no transition leaves it");
      st.transitions.forEach(function (t, i) {
        var row = body.insertRow();
        row.className = t.verdict === "fired" ? "fired" : (t.checked ? "checked" : "skipped");
        row.dataset.verdict = t.verdict;
        row.insertCell().textContent = i + 1;
        row.insertCell().textContent = t.from + " \u2192 " + t.to + (t.preempt ? " (preemptive)" : "");
        var params = Object.keys(t.params).map(function (k) { return k + "=" + JSON.stringify(t.params[k]); }).join(" ");
        row.insertCell().textContent = t.type + (params ? " " + params : "") + (t.guard ? " [" + t.guard + "]" + (t.guard_value === null ? "" : " = " + t.guard_value) : "");
        row.insertCell().textContent = Object.keys(t.values).map(function (k) {
          var v = t.values[k]; return k + " = " + (typeof v === "number" ? +v.toPrecision(4) : JSON.stringify(v));
        }).join(", ");
        row.insertCell().textContent = t.verdict;
      });
    });
  }
  $("why-box").addEventListener("toggle", function () { whyAsked = null; askWhy(); });

  // -- watch expressions. While the run runs, the server sends each watch's value at the ticks of its statuses (at
  // most a chunk of ticks apart): the cell shows the last one, labelled with its tick. Wherever the cursor stands
  // still on a tick the run is not running at (paused, stepped, a click on a plot, a log line or a trace row, a
  // rewind), the page asks the server for the exact values at that tick, which it re-simulates. A watch's plot
  // asks for its values at every tick of the run so far (re-simulated on request, reduced on the server to the
  // least and greatest value per pixel column when there are more ticks than columns). Nothing is asked while the
  // run runs and the cursor follows it.
  var watchRows = [], watchShown = "", watchPlot = null, plotted = {};
  var exact = {}, exactKey = "", asking = null, wanted = null;  // exact values by tick, for the watches of exactKey
  // the plot's values, and the range a drag across it chose (null: the run so far)
  var plotData = null, plotAsking = false, plotWanted = false, plotRange = null, dragged = false;
  function addWatched(rows) {
    rows.forEach(function (r) {  // a rewind drops the later ones: the rows come in tick order again
      while (watchRows.length && watchRows[watchRows.length - 1][0] >= r[0]) watchRows.pop();
      watchRows.push(r);
    });
    if (watchRows.length > 100000) watchRows = watchRows.slice(-100000);
    showWatches();
  }
  function watchRowAt(tick) {  // the row of the last tick at or before ``tick`` (rows come for the ticks shown)
    var lo = 0, hi = watchRows.length - 1, at = -1;
    while (lo <= hi) { var mid = (lo + hi) >> 1; if (watchRows[mid][0] <= tick) { at = mid; lo = mid + 1; } else hi = mid - 1; }
    return at < 0 ? undefined : watchRows[at];
  }
  function forgetExact() { exact = {}; plotData = null; plotRange = null; }  // a rewind forks the run, a reload changes it
  function shown(v) { return v === undefined ? "–" : (typeof v === "number" ? String(+v.toPrecision(6)) : JSON.stringify(v)); }
  function following() {  // the cursor rides along with a running run: no exact value asked for
    return !!status && status.state === "running" && Math.abs(R.cursor() - R.end()) < 2 * (R.dt || 0.0125);
  }
  function askExact(tick) {
    if (!ws || ws.readyState !== 1) return;
    if (asking !== null) { wanted = tick; return; }
    asking = tick; wanted = null;
    var key = exactKey;
    send("watch_values", { from: tick, to: tick }, function (m) {
      asking = null;
      if (key === exactKey) {
        if (!m.ok) exact[tick] = { error: m.error };
        else if (!m.computed) exact[tick] = { error: m.stopped || "not computed" };
        else exact[tick] = { row: m.series.map(function (s) { return s[0]; }), source: m.source };
      }
      if (wanted !== null && wanted !== tick && exact[wanted] === undefined) askExact(wanted);
      showWatches();
    });
  }
  function showWatches() {
    var list = status ? status.watches || [] : [], body = $("watches").tBodies[0], tick = R.current().tick;
    var key = JSON.stringify(list);
    if (key !== watchShown) {
      watchShown = key;
      body.textContent = "";
      list.forEach(function (w) {
        var row = body.insertRow(); row.dataset.id = w.id;
        row.insertCell().textContent = w.text;
        var v = row.insertCell(); v.className = "value";
        var pc = row.insertCell(), box = document.createElement("input"); box.type = "checkbox"; box.title = "plot its value at every tick";
        box.checked = !!plotted[w.id];
        box.addEventListener("change", function () { plotted[w.id] = this.checked; drawWatchPlot(true); });
        var label = document.createElement("label"); label.appendChild(box); label.appendChild(document.createTextNode(" plot")); pc.appendChild(label);
        var b = document.createElement("button"); b.type = "button"; b.textContent = "remove";
        b.addEventListener("click", function () { delete plotted[w.id]; send("unwatch", { watch: w.id }, reply); });
        row.insertCell().appendChild(b);
      });
      var ids = JSON.stringify(list.map(function (w) { return w.id; }));
      if (ids !== exactKey) { exactKey = ids; forgetExact(); }
      drawWatchPlot(true);
    }
    var at = watchRowAt(tick), got = exact[tick], info = $("watch-at");
    if (at !== undefined && at[0] === tick && got === undefined) got = { row: at[1], source: "the run" };  // sent at this very tick
    if (!list.length) info.textContent = "";
    else if (got !== undefined && got.row) info.textContent = "Values after tick " + tick + " (exact).";
    else if (got !== undefined) info.textContent = "Tick " + tick + ": " + got.error;
    else if (following()) info.textContent = at === undefined ? "" : "Values after tick " + at[0] + ", the last sent while the run runs (pause for the exact value at any tick).";
    else { info.textContent = "Tick " + tick + ": computing the exact values…"; askExact(tick); }
    info.dataset.tick = tick;
    info.dataset.exact = got !== undefined && got.row ? "1" : "0";
    Array.prototype.forEach.call(body.rows, function (row, k) {
      var cell = row.cells[1], v = got !== undefined && got.row ? got.row[k] : (at === undefined ? undefined : at[1][k]);
      cell.textContent = got !== undefined && !got.row ? "?" : shown(v);
      cell.dataset.tick = got !== undefined && got.row ? tick : (at === undefined ? "" : at[0]);
      cell.dataset.exact = got !== undefined && got.row ? "1" : "0";
      cell.dataset.value = v === undefined ? "" : JSON.stringify(v);
      cell.title = got !== undefined && got.row ? "the exact value after tick " + tick : (got !== undefined ? got.error :
        (at !== undefined ? "the value after tick " + at[0] + ", the last tick at or before " + tick + " the page was sent" : ""));
    });
    drawWatchPlot(false);
  }
  function askPlot() {  // every tick of the run so far (the server keeps the last 50,000 and reduces per pixel column)
    if (!ws || ws.readyState !== 1) return;
    if (plotAsking) { plotWanted = true; return; }
    var box = $("watch-plot"), now = status ? status.tick : 0, key = exactKey;
    var from = plotRange ? Math.min(plotRange.from, now) : 0, to = plotRange ? Math.min(plotRange.to, now) : now;
    plotAsking = true; plotWanted = false;
    box.dataset.state = "computing";
    send("watch_values", { from: from, to: to, width: Math.max(100, Math.min(4000, Math.round(box.clientWidth || 400))) }, function (m) {
      plotAsking = false;
      if (key === exactKey) plotData = m.ok ? m : { error: m.error, to: to };
      drawWatchPlot(true);
      if (plotWanted) askPlot();
    });
  }
  function drawWatchPlot(rebuild) {
    var list = status ? status.watches || [] : [], box = $("watch-plot"), note = $("watch-plot-note");
    var chosen = list.map(function (w, k) { return [w, k]; }).filter(function (p) { return plotted[p[0].id]; });
    if (!chosen.length || typeof uPlot === "undefined") { box.textContent = ""; note.textContent = ""; watchPlot = null; box.dataset.points = "0"; return; }
    // asked again when the run stands at another tick than the values were computed to (never while it runs)
    if (!plotAsking && status && status.state !== "running" && !plotRange && (!plotData || plotData.to !== status.tick)) { askPlot(); }
    if (!plotData || plotData.error || !plotData.series) {
      box.textContent = ""; watchPlot = null; box.dataset.points = "0";
      note.textContent = plotData && plotData.error ? "Plot: " + plotData.error : (plotAsking ? "Plot: computing the values at every tick…" : "Plot: shown when the run pauses.");
      return;
    }
    if (!rebuild && watchPlot) return;
    var d = plotData, dt = R.dt || 0.0125, xs = d.ticks.map(function (t) { return t * dt; });
    var data = [xs].concat(chosen.map(function (p) {
      var k = d.watches.indexOf(p[0].id);
      return k < 0 ? xs.map(function () { return null; }) : d.series[k].map(function (v) { return typeof v === "boolean" ? (v ? 1 : 0) : (typeof v === "number" ? v : null); });
    }));
    note.textContent = "Plot: " + (d.reduced ? "each pixel column's least and greatest value of " : "the value at each of ") + d.computed +
      " ticks (" + d.from + " to " + d.to + "), computed when asked" + (d.stopped ? "; " + d.stopped : "") + (d.clipped ? "; " + d.clipped : "") +
      (plotRange ? "; double-click for the whole run" : "; drag across it for every tick of a range") +
      (status && status.state === "running" && !plotRange ? "; updated when the run pauses" : "") + ".";
    box.dataset.points = String(xs.length); box.dataset.reduced = d.reduced ? "1" : "0";
    box.dataset.from = d.from; box.dataset.to = d.to; box.dataset.state = "drawn";
    box.textContent = "";
    var palette = ["#1f77b4", "#d62728", "#2ca02c", "#9467bd", "#ff7f0e"];
    watchPlot = new uPlot({ title: "Watch expressions", width: Math.max(240, box.clientWidth - 4), height: 160,
      series: [{}].concat(chosen.map(function (p, i) { return { label: p[0].text, stroke: palette[i % palette.length], width: 1.2 }; })),
      scales: { x: { time: false } }, legend: { live: false },
      // values in the expressions' own units (true/false drawn as 1/0), tick labels as close as the other plots'
      axes: [{ label: "time (s)" }, { label: "value", size: 56, space: 18 }],
      // a drag chooses a range, whose every tick the server computes; a click puts the run's cursor there
      cursor: { drag: { x: true, y: false, setScale: false } },
      hooks: { setSelect: [function (u) {
        if (u.select.width < 4) return;
        var a = u.posToVal(u.select.left, "x"), b = u.posToVal(u.select.left + u.select.width, "x");
        u.setSelect({ left: 0, width: 0, top: 0, height: 0 }, false);
        dragged = true;  // the click that ends the drag is no click
        plotRange = { from: Math.max(0, Math.round(a / dt)), to: Math.max(0, Math.round(b / dt)) };
        askPlot();
      }] } }, data, box);
    watchPlot.over.addEventListener("click", function (ev) {
      if (dragged) { dragged = false; return; }
      followEnd = null; R.setTime(watchPlot.posToVal(ev.offsetX, "x")); showWatches(); });
    watchPlot.over.addEventListener("dblclick", function () { if (plotRange) { plotRange = null; askPlot(); } });
  }
  $("watch-form").addEventListener("submit", function (ev) {
    ev.preventDefault();
    var text = $("watch-expr").value;
    send("watch", { expr: text }, function (m) {
      var box = $("watch-error");
      box.hidden = m.ok;
      if (m.ok) { $("watch-expr").value = ""; plotted[m.watch] = true; return; }
      box.textContent = m.column ? text + "\n" + " ".repeat(m.column - 1) + "^ " + m.error + " (column " + m.column + ")" : m.error;
    });
  });

  // -- the log: what happened, filterable; a click puts the cursor at its tick ------------------------------------
  var hits = [], logDirty = true, logData = null, logShown = "";
  function showLog(data) {
    if (data) logData = data;
    var d = logData;
    if (!d) return;
    var dt = d.meta.dt || 0.0125, S = d.states.map(function (s) { return s.path !== undefined ? s.path : s; }), lines = [];
    d.transitions.forEach(function (tr) {
      lines.push([tr[1], "transition", (tr[2] >= 0 ? S[tr[2]] : "start") + " \u2192 " + S[tr[3]] + " (" + d.types[tr[4]] + ")"]);
    });
    d.monitors.forEach(function (m) {
      lines.push([Math.round(m[0] / dt), "monitor", "monitor of " + m[1] + " fired (" + m[2] + (m[4] ? ", exception " + m[4] : "") + ")"]);
    });
    d.inputs.forEach(function (i) { lines.push([i[0], /^reload/.test(i[2]) ? "reload" : "input", i[2]]); });
    hits.forEach(function (h) { lines.push([h.tick, "breakpoint", (h.breakpoint !== null ? "breakpoint " + h.breakpoint + " (" + h.text + "): " : h.text + ": ") + h.why]); });
    d.meta.warnings.forEach(function (w) { lines.push([0, "warning", w]); });
    lines.sort(function (a, b) { return a[0] - b[0]; });
    var on = {};
    Array.prototype.forEach.call(document.querySelectorAll("#log-filter input[type=checkbox]"), function (c) { on[c.value] = c.checked; });
    var text = $("log-text").value.toLowerCase();
    lines = lines.filter(function (l) { return on[l[1]] && (!text || l[2].toLowerCase().indexOf(text) >= 0); }).slice(-300);
    var key = JSON.stringify(lines);
    if (key === logShown) return;
    logShown = key;
    var box = $("log"), body = box.tBodies[0];  // the table scrolls (#log-box table)
    var atEnd = box.scrollTop + box.clientHeight >= box.scrollHeight - 4;  // the newest lines stay in view
    body.textContent = "";
    lines.forEach(function (l) {
      var row = body.insertRow(); row.className = "log-" + l[1]; row.dataset.tick = l[0]; row.dataset.kind = l[1];
      row.insertCell().textContent = l[0];
      row.insertCell().textContent = l[1];
      row.insertCell().textContent = l[2];
      row.addEventListener("click", function () { followEnd = null; R.setTime(l[0] * dt); showWatches(); });
    });
    if (atEnd) box.scrollTop = box.scrollHeight;  // unless the user scrolled up to read
  }
  var cursorSeen = null;  // the watch values follow the cursor, wherever it was moved from
  setInterval(function () { var c = R.cursor(); if (c !== cursorSeen && status && (status.watches || []).length) { cursorSeen = c; showWatches(); } }, 200);
  Array.prototype.forEach.call(document.querySelectorAll("#log-filter input"), function (c) {
    c.addEventListener("input", function () { showLog(null); });
  });

  // for tests and the console
  window.tralLive = { model: model, status: function () { return status; }, send: send,
                      watchRows: function () { return watchRows; }, watchPlot: function () { return plotData; },
                      drawn: function () { return document.body.dataset.drawn | 0; } };
  var reloaded = sessionStorage.getItem("tral-reloaded");  // the page was rebuilt after a hot reload: say so
  if (reloaded) { sessionStorage.removeItem("tral-reloaded"); showReload({ ok: true, file: "", tick: "", text: "" }); $("reload").textContent = reloaded.replace("The statechart is being redrawn.", "The statechart was redrawn."); }
  connect();
})();
