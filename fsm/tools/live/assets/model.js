/* tral-fsm live: the report's model (what fsm/tools/report/model.py computes) built in the browser from trace lines
   as they arrive, so a live run and a finished trace are shown by the same report.js from the same stream. */
(function () {
  "use strict";
  var PLOTS = [["Ultrasonic sensors", "m", [["car.left", "left"], ["car.front", "front"], ["car.right", "right"]]],
               ["Speed", "m/s", [["car.speed", "speed"], ["car.speed_command", "command"]]],
               ["Steering", "-1 to 1", [["car.steering", "steering"]]]];
  var DIGITS = 1000;

  function TraceModel(base) { this.base = base || {}; this.reset(); }

  TraceModel.prototype.reset = function () {
    this.header = null; this.events = []; this.keyframes = []; this.frames = []; this.inputs = []; this.end = null;
    this.columns = { t: [] }; this.names = []; this.rows = 0; this.lastTick = 0; this.lastTime = 0;
    this.runTick = 0;  // where the run's last status says it is (lines stop at the last tick something happened)
  };

  // -- lines ------------------------------------------------------------------------------------------------------
  TraceModel.prototype.add = function (line) {
    var kind = line.type;
    if (kind === "header") this.header = line;
    else if (kind === "event") this.events.push(line);
    else if (kind === "keyframe") this.keyframes.push(line);
    else if (kind === "frame") this.frames.push(line);
    else if (kind === "input") this.inputs.push(line);
    else if (kind === "reload") this.inputs.push({ tick: line.tick, time: line.time, input: { kind: "reload" },  // listed with the inputs
                                                   text: "reload of " + line.file + ": " + line.text });
    else if (kind === "end") this.end = line;
    else if (kind === "sample") this.addSample(line);
    else if (kind === "samples") this.addBlock(line);
    if (typeof line.tick === "number" && line.tick >= this.lastTick) {
      this.lastTick = line.tick;
      if (typeof line.time === "number") this.lastTime = Math.max(this.lastTime, line.time);
    }
  };
  TraceModel.prototype.addText = function (text) {  // JSON lines (a chunk of the stream, or a whole trace file)
    var lines = text.split("\n");
    for (var i = 0; i < lines.length; i++) if (lines[i]) this.add(JSON.parse(lines[i]));
  };

  function flatten(prefix, value, out) {
    if (typeof value === "boolean") out[prefix] = value ? 1 : 0;
    else if (typeof value === "number") out[prefix] = isFinite(value) ? value : null;
    else if (Array.isArray(value)) { if (value.length <= 8) value.forEach(function (v, i) { flatten(prefix + "[" + i + "]", v, out); }); }
    else if (value && typeof value === "object") Object.keys(value).forEach(function (k) { flatten(prefix + "." + k, value[k], out); });
  }
  TraceModel.prototype.addRow = function (time, flat) {
    var cols = this.columns, n = this.rows;
    cols.t.push(Math.round(time * 10000) / 10000);
    for (var name in flat) {
      if (!cols[name]) { cols[name] = new Array(n).fill(null); this.names.push(name); }
      var v = flat[name];
      if (v !== null) v = Math.round(v * DIGITS) / DIGITS;
      cols[name].push(v);
    }
    this.rows = n + 1;
    for (var k = 0; k < this.names.length; k++) if (cols[this.names[k]].length < this.rows) cols[this.names[k]].push(null);
    var last = time / ((this.header && this.header.dt) || 0.0125);
    this.lastTime = Math.max(this.lastTime, time);
    this.lastTick = Math.max(this.lastTick, Math.round(last));
  };
  TraceModel.prototype.addSample = function (line) {
    var flat = {};
    Object.keys(line).forEach(function (k) { if (k !== "type" && k !== "tick" && k !== "time") flatten(k, line[k], flat); });
    this.addRow(line.time, flat);
  };
  TraceModel.prototype.addBlock = function (b) {
    var fields = b.fields, rows = b.rows, dt = (this.header && this.header.dt) || 0;
    if (!rows) rows = unpack(b);
    for (var i = 0; i < rows.length; i++) {
      var tick = b.tick + i * b.every, flat = {};
      for (var j = 0; j < fields.length; j++) {
        var v = rows[i][j];
        flat[fields[j]] = typeof v === "number" && isFinite(v) ? v : null;
      }
      this.addRow(dt ? Math.round(tick * dt * 1e9) / 1e9 : b.time, flat);
    }
  };
  function unpack(b) {  // float32 little-endian, row after row, in base64 (fsm/trace/recorder.py PACKED_SAMPLES)
    var bin = atob(b.data), bytes = new Uint8Array(bin.length);
    for (var i = 0; i < bin.length; i++) bytes[i] = bin.charCodeAt(i);
    var view = new DataView(bytes.buffer), width = b.fields.length, scale = Math.pow(10, b.digits === undefined ? 6 : b.digits);
    var rows = [];
    for (var r = 0; r < b.count; r++) {
      var row = [];
      for (var c = 0; c < width; c++) {
        var v = view.getFloat32((r * width + c) * 4, true);
        row.push(isFinite(v) ? Math.round(v * scale) / scale : null);
      }
      rows.push(row);
    }
    return rows;
  }

  // -- the model -------------------------------------------------------------------------------------------------
  function activeOf(e) { return Array.isArray(e.active) ? e.active : (e.active ? String(e.active).split(", ") : []); }

  TraceModel.prototype.build = function () {
    var h = this.header || {}, base = this.base, dt = h.dt || 0.0125;
    var ticks = Math.max(this.lastTick, this.runTick);
    var tEnd = Math.max(this.lastTime, Math.round(ticks * dt * 1e9) / 1e9, this.end ? this.end.time : 0);
    var states = [], index = {};
    function add(p) { if (typeof p === "string" && !(p in index)) { index[p] = states.length; states.push(p); } }
    (h.regions || []).forEach(function (r) { (r.states || []).forEach(add); });
    this.events.forEach(function (e) {
      (e.transitions || []).forEach(function (tr) { add(tr.from); add(tr.to); });
      activeOf(e).forEach(add);
    });
    this.keyframes.forEach(function (k) { k.active.forEach(add); });
    var regions = this.regions(h, states, index);
    var types = [], transitions = [];
    this.events.forEach(function (e) {
      (e.transitions || []).forEach(function (tr) {
        var kind = String(tr.type);
        if (types.indexOf(kind) < 0) types.push(kind);
        transitions.push([tr.time !== undefined ? tr.time : e.time, e.tick, tr.from ? index[tr.from] : -1, index[tr.to], types.indexOf(kind)]);
      });
    });
    var monitors = [], pauses = [];
    this.events.forEach(function (e) {
      (e.monitors || []).forEach(function (m) { monitors.push([e.time, m.owner, m.behavior, m.kind, m.exception]); });
      ["paused", "resumed"].forEach(function (kind) { (e[kind] || []).forEach(function (p) { pauses.push([e.time, p, kind === "paused"]); }); });
    });
    var end = this.end || {}, warnings = (base.warnings || []).slice();
    var samples = this.rows ? this.columns : null, plots = [];
    if (samples) PLOTS.forEach(function (p) {
      var got = p[2].filter(function (s) { return samples[s[0]]; }).map(function (s) { return { field: s[0], label: s[1] }; });
      if (got.length) plots.push({ title: p[0], unit: p[1], series: got });
    });
    return {
      meta: { name: h.name || base.name || "run", source: h.source || base.trace || "", trace: base.trace || "", version: h.version,
              tral_fsm: h.tral_fsm, dt: dt, t_end: tEnd, ticks: ticks, outcome: end.outcome === undefined ? null : end.outcome,
              finished: end.finished, interrupted: !!end.interrupted, error: end.error && end.error.message || null,
              cut_off: false, live: !this.end, seed: h.seed === undefined ? null : h.seed, world_file: h.world_file || null,
              overrides: h.overrides || [], warnings: warnings },
      states: states,
      regions: regions.map(function (r) { return { path: r.path, label: r.label }; }),
      lanes: this.lanes(regions, states, index, tEnd),
      types: types, transitions: transitions, monitors: monitors, pauses: pauses,
      keyframes: this.keyframes.map(function (k) { return [k.tick, k.active.filter(function (a) { return a in index; }).map(function (a) { return index[a]; }), k.vars]; }),
      events: this.events.map(function (e) { return [e.tick, activeOf(e).filter(function (a) { return a in index; }).map(function (a) { return index[a]; }), e.vars || {}, e.unset || []]; }),
      samples: samples, plots: plots,
      frames: this.frames.map(function (f) {
        return { t: f.time, jpeg: f.jpeg, w: f.width, h: f.height, gates: f.gates || [],
                 det: (f.detections || []).map(function (d) { return { id: d.id, c: d.corners, d: d.distance }; }) };
      }),
      map: base.map || null,
      inputs: this.inputs.map(function (i) { return [i.tick, i.time, i.text || i.input.kind]; })
    };
  };

  TraceModel.prototype.regions = function (h, states, index) {  // model.py _regions
    var name = h.name || "machine", regions;
    if (h.regions && h.regions.length) {
      regions = h.regions.map(function (r) { return { path: String(r.path || ""), states: (r.states || []).filter(function (s) { return s in index; }).map(function (s) { return index[s]; }) }; });
    } else {
      var byParent = {}, order = [];
      states.forEach(function (p, i) { var parent = p.lastIndexOf("/") >= 0 ? p.slice(0, p.lastIndexOf("/")) : ""; if (!byParent[parent]) { byParent[parent] = []; order.push(parent); } byParent[parent].push(i); });
      regions = order.map(function (p) { return { path: p, states: byParent[p] }; });
    }
    function key(r) { return r.path.split("/").filter(function (x) { return x; }); }
    regions.sort(function (a, b) {
      var ka = key(a), kb = key(b);
      for (var i = 0; i < Math.min(ka.length, kb.length); i++) if (ka[i] !== kb[i]) return ka[i] < kb[i] ? -1 : 1;
      return ka.length - kb.length;
    });
    var paths = regions.map(function (r) { return r.path; });
    regions.forEach(function (r) {
      r.label = r.path || name + " (top level)";
      if (paths.filter(function (p) { return p === r.path; }).length > 1) {
        var steps = r.states.map(function (i) { return states[i].split("/").pop(); });
        r.label += ": " + steps.slice(0, 3).join(", ") + (steps.length > 3 ? ", …" : "");
      }
    });
    return regions;
  };

  function laneLabel(regions) {  // model.py lane_label
    if (regions.length === 1) return regions[0];
    var parents = {}, names = [];
    regions.forEach(function (r) {
      var at = r.lastIndexOf("/"), name = at >= 0 ? r.slice(at + 1) : r;
      parents[at >= 0 ? r.slice(0, at) : ""] = true;
      if (names.indexOf(name) < 0) names.push(name);
    });
    var shown = names.slice(0, 3).join(", ") + (names.length > 3 ? " +" + (names.length - 3) : "");
    var keys = Object.keys(parents);
    return keys.length === 1 && keys[0] ? keys[0] + "/{" + shown + "}" : "in " + shown;
  }
  TraceModel.prototype.lanes = function (regions, states, index, tEnd) {  // model.py _lanes
    var regionOf = {};
    regions.forEach(function (r, ri) { r.states.forEach(function (s) { if (!(s in regionOf)) regionOf[s] = ri; }); });
    var current = {}, segments = {}, t = 0;
    function close(ri, time) { var c = current[ri]; delete current[ri]; (segments[ri] = segments[ri] || []).push([c[1], time, c[0]]); }
    this.events.forEach(function (e) {
      t = e.time;
      var now = {};
      activeOf(e).forEach(function (leaf) {
        var parts = leaf.split("/");
        for (var n = 1; n <= parts.length; n++) {
          var i = index[parts.slice(0, n).join("/")];
          if (i !== undefined && i in regionOf) now[regionOf[i]] = i;
        }
      });
      Object.keys(current).forEach(function (ri) { if (now[ri] !== current[ri][0]) close(ri, t); });
      Object.keys(now).forEach(function (ri) { if (!(ri in current)) current[ri] = [now[ri], t]; });
    });
    Object.keys(current).forEach(function (ri) { close(ri, tEnd); });
    var stateSet = {};
    states.forEach(function (s) { stateSet[s] = true; });
    function overlap(a, b) {
      var both = a.concat(b).map(function (s) { return [s[0], s[1]]; }).sort(function (x, y) { return x[0] - y[0] || x[1] - y[1]; });
      for (var i = 1; i < both.length; i++) if (both[i][0] < both[i - 1][1]) return true;
      return false;
    }
    var lanes = [];
    regions.forEach(function (r, ri) {
      if (!segments[ri]) return;
      var steps = r.path.split("/").filter(function (x) { return x; }), prefixes = [];
      for (var n = 1; n <= steps.length; n++) prefixes.push(steps.slice(0, n).join("/"));
      var branch = prefixes.filter(function (p) { return !stateSet[p]; }), depth = steps.length - branch.length;
      var key = depth + "|" + branch.join("|"), found = null;
      for (var k = 0; k < lanes.length; k++) if (lanes[k].key === key && !overlap(lanes[k].seg, segments[ri])) { found = lanes[k]; break; }
      if (found) { found.seg = found.seg.concat(segments[ri]).sort(function (x, y) { return x[0] - y[0] || x[1] - y[1] || x[2] - y[2]; }); found.regions.push(r.label); }
      else lanes.push({ key: key, depth: depth, branch: branch, seg: segments[ri], regions: [r.label] });
    });
    lanes.sort(function (a, b) { return a.depth - b.depth || (a.branch.join("/") < b.branch.join("/") ? -1 : a.branch.join("/") > b.branch.join("/") ? 1 : 0) || a.seg[0][0] - b.seg[0][0]; });
    return lanes.map(function (lane) {
      var label = laneLabel(lane.regions);
      var flat = [];
      lane.seg.forEach(function (s) { flat.push(s[0], s[1], s[2]); });
      return { label: label, depth: lane.depth, regions: lane.regions, seg: flat };
    });
  };

  window.TraceModel = TraceModel;
})();
