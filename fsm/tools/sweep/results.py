"""A sweep's results: ``sweep.jsonl`` (one record per run, appended as runs finish), ``sweep.csv`` (one row per run,
sorted by run id) and ``sweep.html`` (a self-contained page: sortable table, success rate per parameter value, a
heat map over two parameters, the trajectories of each world in small multiples, dwell times per state, links to
each run's files). Every string from a machine or a record is escaped."""

from __future__ import annotations

import csv
import html
import io
import json
import math
from collections import defaultdict
from pathlib import Path
from typing import Any

COLUMNS = ["id", "ok", "outcome", "world", "seed", "run_seed", "sim_time", "distance_m", "collisions",
           "wall_error_rms_m", "transitions", "seconds", "error", "flags"]
#: A run stands out when one of its figures (a lap's time, the time in a state) lies more than this many median
#: absolute deviations (MAD) from the median of the same figure over the runs in the same world.
OUTLIER_MADS = 3.0
#: Figures are compared when at least this many runs have them.
OUTLIER_MIN_RUNS = 5
#: The MAD used is at least this fraction of the median and this many seconds: runs that agree to the tick (a fixed
#: manoeuvre) would otherwise make a difference of one tick an outlier; states end on 20 Hz sensor samples, and two
#: samples (0.1 s) are no glitch.
MAD_FLOOR_FRACTION = 0.005
MAD_FLOOR_SECONDS = 0.1


def figures(record: dict[str, Any]) -> dict[str, float]:
    """The figures of a run that the sweep compares across runs: ``lap N time`` of each complete lap (the summary's
    ``laps``) and ``time in PATH`` of each state (the record's dwell times), seconds."""
    out: dict[str, float] = {}
    for lap in (record.get("summary") or {}).get("laps") or []:
        if isinstance(lap, dict) and lap.get("complete") and isinstance(lap.get("time_s"), (int, float)) \
                and not isinstance(lap.get("time_s"), bool):
            out[f"lap {lap.get('lap')} time"] = float(lap["time_s"])
    for path, sec in (record.get("dwell") or {}).items():
        out[f"time in {path}"] = float(sec)
    return out


def _median(values: list[float]) -> float:
    v = sorted(values)
    n = len(v)
    return v[n // 2] if n % 2 else (v[n // 2 - 1] + v[n // 2]) / 2


def outliers(records: list[dict[str, Any]]) -> dict[str, list[dict[str, Any]]]:
    """The flags of each run (by run id) whose figures lie more than :data:`OUTLIER_MADS` MADs from the others' in
    the same world: figure, value, median, MAD (with its floor) and the signed number of MADs, largest first."""
    groups: dict[tuple[str, str], list[tuple[str, float]]] = defaultdict(list)
    for r in records:
        if not r.get("ok"):
            continue
        for name, value in figures(r).items():
            if math.isfinite(value):
                groups[(str(r.get("world")), name)].append((r["id"], value))
    flags: dict[str, list[dict[str, Any]]] = defaultdict(list)
    for (_world, name), runs in groups.items():
        if len(runs) < OUTLIER_MIN_RUNS:
            continue
        values = [v for _id, v in runs]
        med = _median(values)
        mad = max(_median([abs(v - med) for v in values]), MAD_FLOOR_FRACTION * abs(med), MAD_FLOOR_SECONDS)
        for run_id, v in runs:
            k = (v - med) / mad
            if abs(k) > OUTLIER_MADS:
                flags[run_id].append({"figure": name, "value": round(v, 4), "median": round(med, 4),
                                      "mad": round(mad, 4), "mads": round(k, 1)})
    for fl in flags.values():
        fl.sort(key=lambda f: -abs(f["mads"]))
    return dict(flags)


def flag_text(flag: dict[str, Any]) -> str:
    """One flag in words: ``time in lap1/right_slow 12.3 s (median 2.3 s, +40.1 MAD)``."""
    return f"{flag['figure']} {flag['value']:g} s (median {flag['median']:g} s, {flag['mads']:+g} MAD)"


def with_flags(records: list[dict[str, Any]]) -> list[dict[str, Any]]:
    """The records, each with its ``flags`` (:func:`outliers`; an empty list for a run that does not stand out)."""
    flags = outliers(records)
    return [{**r, "flags": flags.get(r["id"], [])} for r in records]


def success(record: dict[str, Any]) -> bool:
    """A run succeeds when it ran, its machine finished with outcome 'succeeded', and the car never collided."""
    s = record.get("summary") or {}
    return bool(record.get("ok")) and s.get("outcome") == "succeeded" and not s.get("collisions")


def read_jsonl(path: Path) -> list[dict[str, Any]]:
    """The records of an earlier (maybe interrupted) sweep: whole lines only."""
    out: list[dict[str, Any]] = []
    if not path.is_file():
        return out
    for line in path.read_text(encoding="utf-8", errors="replace").splitlines():
        try:
            rec = json.loads(line)
        except ValueError:
            continue  # a line cut off by a kill
        if isinstance(rec, dict) and "key" in rec and "id" in rec:
            out.append(rec)
    return out


def csv_text(records: list[dict[str, Any]], param_names: list[str]) -> str:
    buf = io.StringIO()
    w = csv.writer(buf, lineterminator="\n")
    w.writerow(COLUMNS[:5] + param_names + COLUMNS[5:])
    for r in sorted(records, key=lambda r: r["id"]):
        s = r.get("summary") or {}
        row = [r["id"], r.get("ok"), s.get("outcome"), Path(r["world"]).name if r.get("world") else "", r["seed"]]
        row += [r["params"].get(p) for p in param_names]
        row += [r["run_seed"], s.get("sim_time"), s.get("distance_m"), s.get("collisions"), s.get("wall_error_rms_m"),
                s.get("transitions"), r.get("seconds"), r.get("error", ""),
                "; ".join(flag_text(f) for f in r.get("flags") or [])]
        w.writerow(["" if v is None else v for v in row])
    return buf.getvalue()


def _e(value: Any) -> str:
    return html.escape("" if value is None else str(value), quote=True)


def _rate_color(rate: float) -> str:
    """Red (0 %) to green (100 %)."""
    r = int(220 - 170 * rate)
    g = int(60 + 140 * rate)
    return f"rgb({r},{g},70)"


def html_page(title: str, records: list[dict[str, Any]], param_names: list[str], worlds: dict[str, Any],
              runs_dir: str = "runs") -> str:
    records = sorted(records, key=lambda r: r["id"])
    n = len(records)
    ok = sum(success(r) for r in records)
    odd = sum(bool(r.get("flags")) for r in records)
    parts = [f"<h1>{_e(title)}</h1>",
             f"<p class=lead>{n} runs, {ok} succeeded ({(ok / n if n else 0):.0%}), {odd} stand out (below); a run "
             "succeeds when the machine finishes with outcome <code>succeeded</code> and the car never collides. "
             "Click a column to sort.</p>"]
    parts.append(_standouts(records))
    parts.append(_rates(records, param_names))
    if len(param_names) >= 2:
        parts.append(_heatmap(records, param_names[0], param_names[1]))
    parts.append(_trajectories(records, worlds))
    parts.append(_dwell(records))
    parts.append(_table(records, param_names, runs_dir))
    body = "\n".join(parts)
    return f"""<!DOCTYPE html>
<html lang="en"><head><meta charset="utf-8"><title>{_e(title)}</title>
<meta name="viewport" content="width=device-width, initial-scale=1">
<style>
body{{font:14px/1.45 system-ui,sans-serif;margin:24px;color:#222;max-width:1400px}}
h1{{font-size:22px;margin:0 0 6px}} h2{{font-size:16px;margin:26px 0 8px}}
table{{border-collapse:collapse;font-size:13px}}
th,td{{padding:3px 8px;border-bottom:1px solid #e4e4e4;text-align:right}}
th{{cursor:pointer;background:#f3f4f7;position:sticky;top:0}} td.l,th.l{{text-align:left}}
tr.fail td{{background:#fff1f0}} .bar{{display:inline-block;height:10px;background:#4a7;vertical-align:middle}}
.multiples{{display:flex;flex-wrap:wrap;gap:14px}} .multiples figure{{margin:0}} figcaption{{font-size:12px;color:#555}}
.heat td{{width:70px;height:34px;text-align:center;color:#fff;font-weight:600}} code{{background:#f3f3f3;padding:0 3px}}
.lead{{color:#444}}
</style></head><body>
{body}
<script>
document.querySelectorAll("table.sortable th").forEach(function(th, col) {{
  th.addEventListener("click", function() {{
    var table = th.closest("table"), body = table.tBodies[0], rows = Array.from(body.rows);
    var asc = th.dataset.dir !== "asc"; th.dataset.dir = asc ? "asc" : "desc";
    rows.sort(function(a, b) {{
      var x = a.cells[col].dataset.v || a.cells[col].textContent;
      var y = b.cells[col].dataset.v || b.cells[col].textContent;
      var nx = parseFloat(x), ny = parseFloat(y);
      var c = (!isNaN(nx) && !isNaN(ny)) ? nx - ny : x.localeCompare(y);
      return asc ? c : -c;
    }});
    rows.forEach(function(r) {{ body.appendChild(r); }});
  }});
}});
</script>
</body></html>
"""


def _standouts(records: list[dict[str, Any]]) -> str:
    flagged = [r for r in records if r.get("flags")]
    if not flagged:
        return (f"<h2>Runs that stand out</h2><p>None: no run's lap time or time in a state lies more than "
                f"{OUTLIER_MADS:g} median absolute deviations from the other runs' in its world.</p>")
    out = [f"<h2>Runs that stand out ({len(flagged)})</h2><p class=lead>A lap's time or the time in a state more than "
           f"{OUTLIER_MADS:g} median absolute deviations (MAD) from the other runs' in the same world, even when the "
           "run succeeded; the command reproduces the run alone.</p><table><tr><th class=l>run</th><th class=l>figure"
           "</th><th>value (s)</th><th>median (s)</th><th>MADs</th><th class=l>reproduce</th></tr>"]
    for r in flagged:
        for k, f in enumerate(r["flags"]):
            cmd = f"<td class=l rowspan={len(r['flags'])}><code>{_e(r.get('command'))}</code></td>" if k == 0 else ""
            run = f"<td class=l rowspan={len(r['flags'])}>{_e(r['id'])}</td>" if k == 0 else ""
            out.append(f"<tr>{run}<td class=l>{_e(f['figure'])}</td><td>{_e(f['value'])}</td><td>{_e(f['median'])}"
                       f"</td><td>{f['mads']:+.1f}</td>{cmd}</tr>")
    out.append("</table>")
    return "".join(out)


def _rates(records: list[dict[str, Any]], params: list[str]) -> str:
    if not params:
        return ""
    out = ["<h2>Success rate per parameter value</h2><table><tr><th class=l>parameter</th><th class=l>value</th>"
           "<th>runs</th><th>succeeded</th><th class=l></th></tr>"]
    for p in params:
        groups: dict[str, list[bool]] = defaultdict(list)
        for r in records:
            groups[json.dumps(r["params"].get(p))].append(success(r))
        for value, flags in sorted(groups.items()):
            rate = sum(flags) / len(flags)
            out.append(f"<tr><td class=l>{_e(p)}</td><td class=l>{_e(value)}</td><td>{len(flags)}</td>"
                       f"<td>{rate:.0%}</td>"
                       f"<td class=l><span class=bar style='width:{int(rate * 160)}px'></span></td></tr>")
    out.append("</table>")
    return "".join(out)


def _heatmap(records: list[dict[str, Any]], px: str, py: str) -> str:
    xs = sorted({json.dumps(r["params"].get(px)) for r in records})
    ys = sorted({json.dumps(r["params"].get(py)) for r in records})
    cells: dict[tuple[str, str], list[bool]] = defaultdict(list)
    for r in records:
        cells[(json.dumps(r["params"].get(px)), json.dumps(r["params"].get(py)))].append(success(r))
    out = [f"<h2>Success rate over {_e(px)} (columns) and {_e(py)} (rows)</h2><table class=heat><tr><th></th>"]
    out += [f"<th>{_e(x)}</th>" for x in xs]
    out.append("</tr>")
    for y in ys:
        out.append(f"<tr><th>{_e(y)}</th>")
        for x in xs:
            flags = cells.get((x, y), [])
            if flags:
                rate = sum(flags) / len(flags)
                out.append(f"<td style='background:{_rate_color(rate)}' title='{len(flags)} runs'>{rate:.0%}</td>")
            else:
                out.append("<td style='background:#ccc'>-</td>")
        out.append("</tr>")
    out.append("</table>")
    return "".join(out)


def _map_xy(p: Any, x0: float, y1: float, scale: float) -> str:
    """A point in metres as SVG coordinates on a map whose top-left corner is (x0, y1), ``scale`` pixels a metre."""
    return f"{(p[0] - x0) * scale:.1f},{(y1 - p[1]) * scale:.1f}"


def _trajectories(records: list[dict[str, Any]], worlds: dict[str, Any]) -> str:
    """One small map per run with a track, grouped by world, the world's walls under each."""
    by_world: dict[str, list[dict[str, Any]]] = defaultdict(list)
    for r in records:
        if r.get("track"):
            by_world[str(r.get("world"))].append(r)
    if not by_world:
        return ""
    maps = [_world_maps(world, recs, worlds.get(world) or []) for world, recs in sorted(by_world.items())]
    return "<h2>Trajectories (ground truth), one small map per run</h2>" + "".join(maps)


def _world_maps(world: str, recs: list[dict[str, Any]], walls: list[Any]) -> str:
    """The maps of the runs in one world, each framed to the walls and every run's track (none: nothing)."""
    pts = [(x, y) for w in walls for x, y in w] + [(p[0], p[1]) for r in recs for p in r["track"]]
    if not pts:
        return ""
    xs, ys = [p[0] for p in pts], [p[1] for p in pts]
    x0, x1, y0, y1 = min(xs) - 0.3, max(xs) + 0.3, min(ys) - 0.3, max(ys) + 0.3
    w = 220
    h = max(60, int(w * (y1 - y0) / max(x1 - x0, 1e-6)))
    sx = w / (x1 - x0)
    wall_svg = "".join(f"<polyline points='{' '.join(_map_xy(p, x0, y1, sx) for p in line)}' fill='none' "
                       "stroke='#333' stroke-width='1.5'/>" for line in walls)
    out = [f"<h3>{_e(Path(world).name)}</h3><div class=multiples>"]
    for r in recs:
        colour = "#2a8f4a" if success(r) else "#c83a2e"
        path = " ".join(_map_xy(p, x0, y1, sx) for p in r["track"])
        label = ", ".join(f"{k}={v}" for k, v in r["params"].items())
        out.append(f"<figure><svg width='{w}' height='{h}' viewBox='0 0 {w} {h}' role='img'>{wall_svg}"
                   f"<polyline points='{path}' fill='none' stroke='{colour}' stroke-width='1.2'/></svg>"
                   f"<figcaption>{_e(r['id'])} seed {_e(r['seed'])} {_e(label)}</figcaption></figure>")
    out.append("</div>")
    return "".join(out)


def _dwell(records: list[dict[str, Any]]) -> str:
    per: dict[str, list[float]] = defaultdict(list)
    for r in records:
        for path, sec in (r.get("dwell") or {}).items():
            per[path].append(sec)
    if not per:
        return ""
    out = ["<h2>Dwell time per state across runs (s)</h2><table class=sortable><thead><tr><th class=l>state</th>"
           "<th>runs</th><th>min</th><th>mean</th><th>max</th></tr></thead><tbody>"]
    for path, vals in sorted(per.items()):
        mean = sum(vals) / len(vals)
        out.append(f"<tr><td class=l>{_e(path)}</td><td>{len(vals)}</td><td>{min(vals):.2f}</td><td>{mean:.2f}</td>"
                   f"<td>{max(vals):.2f}</td></tr>")
    out.append("</tbody></table>")
    return "".join(out)


def _table(records: list[dict[str, Any]], params: list[str], runs_dir: str) -> str:
    head = ["id", "ok", "outcome", "world", "seed"] + params + ["sim time", "distance", "collisions", "wall RMS",
                                                               "seconds", "files", "error"]
    out = ["<h2>Runs</h2><table class=sortable><thead><tr>"]
    out += [f"<th class=l>{_e(h)}</th>" if h in ("id", "outcome", "world", "files", "error") else f"<th>{_e(h)}</th>"
            for h in head]
    out.append("</tr></thead><tbody>")
    for r in records:
        s = r.get("summary") or {}
        files = [f"<a href='{_e(runs_dir)}/{_e(r['id'])}/{_e(f)}'>{_e(f)}</a>" for f in r.get("files", [])]
        cls = "" if success(r) else " class=fail"
        cells = [f"<td class=l>{_e(r['id'])}</td>", f"<td>{_e(r.get('ok'))}</td>",
                 f"<td class=l>{_e(s.get('outcome'))}</td>",
                 f"<td class=l>{_e(Path(r['world']).name if r.get('world') else '')}</td>", f"<td>{_e(r['seed'])}</td>"]
        cells += [f"<td>{_e(r['params'].get(p))}</td>" for p in params]
        rms = s.get("wall_error_rms_m")
        cells += [f"<td>{_e(s.get('sim_time'))}</td>", f"<td>{_e(s.get('distance_m'))}</td>",
                  f"<td>{_e(s.get('collisions'))}</td>",
                  f"<td>{'' if rms is None or (isinstance(rms, float) and math.isnan(rms)) else f'{rms * 100:.1f} cm'}"
                  "</td>",
                  f"<td>{_e(r.get('seconds'))}</td>", f"<td class=l>{' '.join(files)}</td>",
                  f"<td class=l title='{_e(r.get('traceback', ''))}'>{_e(r.get('error', ''))}</td>"]
        out.append(f"<tr{cls}>{''.join(cells)}</tr>")
    out.append("</tbody></table>")
    return "".join(out)
