// The report page: inline styles and drawing code (canvas), no library, no network.
#include "page.hpp"

namespace amctl::report {
namespace {

constexpr std::string_view kHead = R"PAGE(<!DOCTYPE html>
<html lang="en">
<head>
<meta charset="utf-8">
<meta http-equiv="Content-Security-Policy" content="default-src 'none'; script-src 'unsafe-inline'; style-src 'unsafe-inline'; img-src data:">
<meta name="viewport" content="width=device-width, initial-scale=1">
<title>amctl report</title>
<style>
:root { --fg:#1d2330; --muted:#5d6675; --line:#d9dde4; --card:#f5f7fa; --accent:#1f77b4; }
* { box-sizing: border-box; }
body { margin:0; font: 14px/1.45 system-ui, -apple-system, "Segoe UI", Roboto, sans-serif; color:var(--fg); background:#fff; }
main { max-width: 1180px; margin: 0 auto; padding: 12px 14px 40px; }
h1 { font-size: 20px; margin: 6px 0 2px; word-break: break-all; }
h2 { font-size: 16px; margin: 22px 0 8px; border-bottom: 1px solid var(--line); padding-bottom: 4px; }
.sub { color: var(--muted); margin: 0 0 8px; }
.cards { display:grid; grid-template-columns: repeat(auto-fit, minmax(150px, 1fr)); gap: 8px; }
.card { background: var(--card); border-radius: 6px; padding: 8px 10px; }
.card .k { color: var(--muted); font-size: 12px; }
.card .v { font-size: 18px; font-weight: 600; }
.card .n { color: var(--muted); font-size: 12px; }
.note { background:#fff6db; border:1px solid #f0d58c; border-radius:6px; padding:8px 10px; margin:8px 0; }
.note.big { font-size: 18px; }
table { border-collapse: collapse; width: 100%; font-size: 13px; }
th, td { text-align:left; padding: 3px 6px; border-bottom: 1px solid var(--line); }
.plot { position: relative; width: 100%; }
canvas { display:block; width:100%; touch-action: none; }
.bar { display:flex; gap: 6px; flex-wrap: wrap; align-items:center; margin: 6px 0; }
button, select { font: inherit; padding: 4px 10px; border:1px solid var(--line); background:#fff; border-radius:5px; }
input[type=range] { flex: 1 1 200px; min-width: 140px; }
.frow { display:grid; grid-template-columns: minmax(90px, 180px) 1fr minmax(110px, auto); gap: 8px; align-items:center; margin: 3px 0; font-size: 13px; }
.frow .b { height: 14px; border-radius: 3px; }
.legend { display:flex; flex-wrap:wrap; gap: 4px 12px; font-size: 12px; color: var(--muted); }
.legend i { display:inline-block; width: 12px; height: 12px; border-radius: 2px; vertical-align: -2px; margin-right: 4px; }
.two { display:grid; grid-template-columns: 1fr 1fr; gap: 16px; }
@media (max-width: 760px) { .two { grid-template-columns: 1fr; } .card .v { font-size: 16px; } main { padding: 8px; } }
.grad { height: 10px; border-radius: 3px; flex: 0 1 220px; }
.mono { font-family: ui-monospace, Menlo, Consolas, monospace; }
</style>
</head>
<body>
<main>
<h1 id="title">amctl report</h1>
<p class="sub" id="subtitle"></p>
<div id="notes"></div>
<section id="summary"><h2>Summary</h2><div class="cards" id="cards"></div><div id="unknown"></div></section>
<section id="speed-section"><h2>Speed over print time</h2>
<div class="bar"><button id="zin" title="zoom in">+</button><button id="zout" title="zoom out">&minus;</button><button id="left" title="earlier">&larr;</button><button id="right" title="later">&rarr;</button><button id="zreset">whole print</button><span class="sub" id="zinfo"></span></div>
<div class="plot"><canvas id="speed" height="300"></canvas></div>
<div class="legend" id="flegend"></div>
<p class="sub mono" id="sread">&nbsp;</p>
</section>
<section id="time-section"><h2>Time per layer and per feature</h2>
<div class="two"><div><div class="plot"><canvas id="layers" height="220"></canvas></div><p class="sub" id="layerinfo"></p></div><div id="features"></div></div>
</section>
<section id="toolpath-section"><h2>Toolpath</h2>
<div class="bar"><button id="lprev">&larr;</button><input type="range" id="lslider" min="0" max="0" value="0"><button id="lnext">&rarr;</button>
<select id="cmode"><option value="speed">colour: speed</option></select></div>
<p class="sub" id="linfo"></p>
<div class="bar"><span class="sub" id="gmin"></span><div class="grad" id="grad"></div><span class="sub" id="gmax"></span><span class="legend"><span><i style="background:#b8bec8"></i>travel</span></span></div>
<div class="plot"><canvas id="toolpath" height="520"></canvas></div>
</section>
<section id="quality-section" hidden><h2>Contour error (belt model)</h2><div class="cards" id="qcards"></div><div id="qtable"></div></section>
<section id="accel-section" hidden><h2>Resonances (accelerometer record)</h2><div class="cards" id="acards"></div>
<div class="plot"><canvas id="accel" height="320"></canvas></div><div class="legend" id="alegend"></div><div id="atable"></div></section>
<section id="thermal-section" hidden><h2 id="thtitle">Heater loop</h2><div class="cards" id="thcards"></div>
<div class="plot"><canvas id="thermal" height="300"></canvas></div><div class="legend" id="thlegend"></div><div id="thtable"></div></section>
<p class="sub" id="footer"></p>
</main>
<script type="application/json" id="data">)PAGE";

constexpr std::string_view kTail = R"PAGE(</script>
<script>
"use strict";
(function () {
const D = JSON.parse(document.getElementById("data").textContent);
const E = D.estimate, FN = D.feature_names || [];
const $ = (id) => document.getElementById(id);
const PALETTE = ["#ff7f0e","#2ca02c","#d62728","#9467bd","#8c564b","#e377c2","#17becf","#bcbd22","#7f7f7f","#393b79","#637939","#8c6d31","#843c39","#7b4173","#6baed6"];
const fcolor = (f) => f < 0 ? "#cfd3da" : PALETTE[f % PALETTE.length];
const fname = (f) => f < 0 ? "travel" : (FN[f] !== undefined ? FN[f] : "feature " + f);
function el(tag, attrs, text) { const e = document.createElement(tag); if (attrs) for (const k in attrs) e.setAttribute(k, attrs[k]); if (text !== undefined) e.textContent = text; return e; }
function fmtTime(s) {
  if (s === null || s === undefined || !isFinite(s)) return "\u2013";
  const neg = s < 0; s = Math.abs(s);
  let out;
  if (s < 60) out = s.toFixed(s < 10 ? 2 : 1) + " s";
  else { const h = Math.floor(s / 3600), m = Math.floor((s % 3600) / 60), sec = Math.round(s % 60);
    out = h > 0 ? h + "h " + String(m).padStart(2, "0") + "m " + String(sec).padStart(2, "0") + "s" : m + "m " + String(sec).padStart(2, "0") + "s"; }
  return (neg ? "-" : "") + out;
}
function fmtClock(s, span) {
  const h = Math.floor(s / 3600), m = Math.floor((s % 3600) / 60), sec = s % 60;
  const ss = span < 20 ? sec.toFixed(span < 2 ? 2 : 1).padStart(span < 2 ? 5 : 4, "0") : String(Math.round(sec)).padStart(2, "0");
  return (h > 0 ? h + ":" + String(m).padStart(2, "0") : String(m)) + ":" + ss;
}
function card(parent, k, v, n) { const c = el("div", {class: "card"}); c.append(el("div", {class: "k"}, k), el("div", {class: "v"}, v)); if (n) c.append(el("div", {class: "n"}, n)); parent.append(c); }
function note(text, big) { $("notes").append(el("div", {class: big ? "note big" : "note"}, text)); }
// Canvas sized to its box in device pixels; returns the 2D context in CSS pixels.
function prep(cv, hCss) {
  const dpr = window.devicePixelRatio || 1, w = cv.clientWidth, h = hCss || cv.height / (cv._dpr || 1);
  cv._dpr = dpr; cv.width = Math.max(1, Math.round(w * dpr)); cv.height = Math.round(h * dpr);
  cv.style.height = h + "px";
  const g = cv.getContext("2d"); g.setTransform(dpr, 0, 0, dpr, 0, 0); g.clearRect(0, 0, w, h);
  return {g, w, h};
}
function niceStep(span, n) { const raw = span / n, p = Math.pow(10, Math.floor(Math.log10(raw))), r = raw / p; return (r < 1.5 ? 1 : r < 3.5 ? 2 : r < 7.5 ? 5 : 10) * p; }
function niceTimeStep(span, n) {
  const steps = [0.01,0.02,0.05,0.1,0.2,0.5,1,2,5,10,15,30,60,120,300,600,900,1800,3600,7200,14400,28800];
  const raw = span / n; for (const s of steps) if (s >= raw) return s; return steps[steps.length - 1];
}
// Colour scale (viridis-like), u in [0, 1].
const STOPS = [[68,1,84],[59,82,139],[33,145,140],[94,201,98],[253,231,37]];
function ramp(u) {
  u = Math.min(1, Math.max(0, isFinite(u) ? u : 0)) * (STOPS.length - 1);
  const i = Math.min(STOPS.length - 2, Math.floor(u)), f = u - i, a = STOPS[i], b = STOPS[i + 1];
  return "rgb(" + Math.round(a[0] + (b[0] - a[0]) * f) + "," + Math.round(a[1] + (b[1] - a[1]) * f) + "," + Math.round(a[2] + (b[2] - a[2]) * f) + ")";
}
const gradCss = "linear-gradient(to right," + [0, 0.25, 0.5, 0.75, 1].map(ramp).join(",") + ")";

// ---------------------------------------------------------------- summary
const base = String(D.file).split(/[\\/]/).pop();
document.title = "amctl report: " + base;
$("title").textContent = base;
$("subtitle").textContent = "machine " + E.machine.name + " (" + E.machine.firmware + ", " + E.machine.kinematics + ") \u00b7 " + E.lines + " lines \u00b7 written by amctl report";
if (D.no_moves) note("This file has no moves: there is no print to show. The summary below lists what was read.", true);
if (D.toolpath.capped) note("The toolpath was thinned to stay small: " + D.toolpath.points + " points kept (at most " + D.toolpath.max_points_per_layer + " per layer, " + D.toolpath.max_points + " in all); layers whose tolerance grew or that were cut short say so below the slider.");
(E.warnings || []).forEach((w) => note("Planner: " + w));
const cards = $("cards");
card(cards, "Print time (amctl)", fmtTime(E.total_time_s), "motion " + fmtTime(E.motion_time_s) + ", dwells " + fmtTime(E.dwell_time_s));
if (E.slicer_estimate_s !== null && E.slicer_estimate_s !== undefined) {
  const d = (E.slicer_estimate_s / E.total_time_s - 1) * 100;
  card(cards, "Slicer's estimate" + (E.slicer ? " (" + E.slicer + ")" : ""), fmtTime(E.slicer_estimate_s), isFinite(d) ? (d >= 0 ? "+" : "") + d.toFixed(1) + " % against amctl" : "");
} else card(cards, "Slicer's estimate", "none", "the file carries no estimate");
card(cards, "Filament", (E.filament_mm / 1000).toFixed(2) + " m", (E.filament_volume_mm3 / 1000).toFixed(2) + " cm\u00b3");
card(cards, "Extruding", fmtTime(E.extrude_time_s), (E.extrude_path_mm / 1000).toFixed(1) + " m of path");
card(cards, "Travel", fmtTime(E.travel_time_s), (E.travel_mm / 1000).toFixed(1) + " m");
card(cards, "Moves", String(E.moves), "top speed " + E.max_speed_mm_s.toFixed(0) + " mm/s");
card(cards, "Layers", String(E.layers.length), E.layers.length ? "mean " + fmtTime(E.total_time_s / E.layers.length) : "");
const waits = (E.heater_waits || []).length, untimed = (E.untimed_commands || []).length;
card(cards, "Not in the time", waits + " heater waits", untimed + " untimed commands (homing, ...)");
const unk = E.unknown_commands || [];
if (unk.length) {
  const t = el("table"); const hr = el("tr"); ["Unknown command", "count", "first line", "why skipped"].forEach((h) => hr.append(el("th", null, h))); t.append(hr);
  unk.forEach((u) => { const r = el("tr"); r.append(el("td", {class: "mono"}, u.name), el("td", null, String(u.count)), el("td", null, String(u.first_line)), el("td", null, u.explanation || "")); t.append(r); });
  $("unknown").append(el("h2", null, "Unknown commands"), t);
} else $("unknown").append(el("p", {class: "sub"}, "No unknown commands."));

// ---------------------------------------------------------------- speed over time
// Two levels of detail: the whole print in a few thousand buckets, and (for long prints) a
// finer level used once the view is short enough that the coarse buckets are wider than a
// pixel. Each bucket: the min-max band of the speed and its mean (distance / width).
const S = D.speed, NB = S.max_speed.length, BW = S.bucket_s, TEND = Math.max(S.end_time_s, NB * BW * 1e-9);
const SF = D.speed_fine || null;
let vTop = 10; for (let k = 0; k < NB; k++) vTop = Math.max(vTop, S.max_speed[k] / 10);
function levelFor(span, pw) { return SF && span / BW < pw ? SF : S; }
vTop = Math.ceil(vTop / niceStep(vTop, 5)) * niceStep(vTop, 5);
const view = {t0: 0, t1: Math.max(TEND, 1e-3)};
// An address ending in #t=A-B opens the speed plot on print times A..B [s] (a view to share).
const hashView = /^#t=([0-9.]+)-([0-9.]+)$/.exec(window.location.hash);
if (hashView && Number(hashView[2]) > Number(hashView[1])) { view.t0 = Number(hashView[1]); view.t1 = Number(hashView[2]); }
const minSpan = Math.max((SF ? SF.bucket_s : BW) * 16, 1e-3);
function clampView() {
  let span = Math.min(Math.max(view.t1 - view.t0, minSpan), Math.max(TEND, minSpan));
  let t0 = Math.max(0, Math.min(view.t0, Math.max(TEND, minSpan) - span));
  view.t0 = t0; view.t1 = t0 + span;
}
const PAD = {l: 46, r: 10, t: 8, b: 44};
function drawSpeed() {
  const cv = $("speed"), {g, w, h} = prep(cv);
  const pw = w - PAD.l - PAD.r, ph = h - PAD.t - PAD.b;
  const xOf = (t) => PAD.l + (t - view.t0) / (view.t1 - view.t0) * pw, yOf = (v) => PAD.t + ph - v / vTop * ph;
  g.font = "11px system-ui, sans-serif";
  // layer bands
  const L = E.layers;
  for (let i = 0; i < L.length; i++) {
    const a = L[i].start_s, b = a + L[i].time_s; if (b < view.t0 || a > view.t1) continue;
    const xa = Math.max(PAD.l, xOf(a)), xb = Math.min(PAD.l + pw, xOf(b));
    g.fillStyle = i % 2 ? "#eef1f5" : "#f8f9fb"; g.fillRect(xa, PAD.t, xb - xa, ph);
    if (xb - xa > 34) { g.fillStyle = "#9aa2ae"; g.fillText("L" + L[i].layer, xa + 3, PAD.t + 11); }
  }
  // grid
  g.strokeStyle = "#e1e4ea"; g.fillStyle = "#5d6675"; g.lineWidth = 1; g.textAlign = "right";
  const vs = niceStep(vTop, 5);
  for (let v = 0; v <= vTop + 1e-9; v += vs) { const y = Math.round(yOf(v)) + 0.5; g.beginPath(); g.moveTo(PAD.l, y); g.lineTo(PAD.l + pw, y); g.stroke(); g.fillText(v.toFixed(0), PAD.l - 4, y + 4); }
  g.save(); g.translate(11, PAD.t + ph / 2); g.rotate(-Math.PI / 2); g.textAlign = "center"; g.fillText("speed [mm/s]", 0, 0); g.restore();
  // The min-max band (light) and the mean speed (a dark line) of the buckets under each pixel
  // column: at whole-print zoom a column holds seconds of print, whose band spans standing
  // still to top speed, while the mean shows how fast the print actually went.
  const Lv = levelFor(view.t1 - view.t0, pw), nb = Lv.max_speed.length, bw = Lv.bucket_s;
  if (nb > 0) {
    g.beginPath(); let started = false;
    for (let px = 0; px < pw; px++) {
      const ta = view.t0 + px / pw * (view.t1 - view.t0), tb = view.t0 + (px + 1) / pw * (view.t1 - view.t0);
      let ka = Math.floor(ta / bw), kb = Math.ceil(tb / bw) - 1; if (kb < ka) kb = ka;
      if (ka >= nb || ta >= TEND) break;
      kb = Math.min(kb, nb - 1);
      let lo = Infinity, hi = -Infinity, best = -1, bestHi = -1, sum = 0;
      for (let k = ka; k <= kb; k++) { lo = Math.min(lo, Lv.min_speed[k]); hi = Math.max(hi, Lv.max_speed[k]); sum += Lv.mean_speed[k]; if (Lv.max_speed[k] > bestHi) { bestHi = Lv.max_speed[k]; best = Lv.feature[k]; } }
      const ya = yOf(hi / 10), yb = yOf(lo / 10), ym = yOf(sum / (kb - ka + 1) / 10);
      g.fillStyle = "#a9c8e4"; g.fillRect(PAD.l + px, ya - 1, 1, Math.max(2, yb - ya + 1));
      if (!started) { g.moveTo(PAD.l + px + 0.5, ym); started = true; } else g.lineTo(PAD.l + px + 0.5, ym);
      g.fillStyle = fcolor(Lv.feature[ka] >= 0 ? Lv.feature[ka] : best); g.fillRect(PAD.l + px, PAD.t + ph + 2, 1, 9);
    }
    g.strokeStyle = "#0b4f8a"; g.lineWidth = 1.5; g.stroke(); g.lineWidth = 1;
  }
  g.strokeStyle = "#8a93a0"; g.strokeRect(PAD.l + 0.5, PAD.t + 0.5, pw, ph);
  // time axis
  g.textAlign = "center"; g.fillStyle = "#5d6675";
  const span = view.t1 - view.t0, ts = niceTimeStep(span, Math.max(2, pw / 110));
  for (let t = Math.ceil(view.t0 / ts) * ts; t <= view.t1 + 1e-9; t += ts) { const x = xOf(t); g.fillRect(x, PAD.t + ph + 12, 1, 4); g.fillText(fmtClock(t, ts), x, PAD.t + ph + 27); }
  g.fillText("print time (h:mm:ss); band: min-max speed, line: mean speed; strip: the feature printed", PAD.l + pw / 2, h - 3);
  $("zinfo").textContent = fmtClock(view.t0, span) + " \u2013 " + fmtClock(view.t1, span) + " (" + fmtTime(span) + " shown; buckets of " + fmtTime(bw) + (Lv === SF ? ", the finer level" : "") + ")";
}
// What is under the pointer: the bucket's time, speeds, feature and layer.
function readout(clientX) {
  const r = spc.getBoundingClientRect(), Lv = levelFor(view.t1 - view.t0, r.width - PAD.l - PAD.r);
  const t = timeAtX(clientX), k = Math.floor(t / Lv.bucket_s);
  if (!(k >= 0 && k < Lv.max_speed.length) || t > TEND) { $("sread").textContent = "\u00a0"; return; }
  const li = E.layers.findIndex((l) => t >= l.start_s && t < l.start_s + l.time_s);
  $("sread").textContent = "at " + fmtClock(t, 1) + ": " + (Lv.min_speed[k] / 10).toFixed(1) + "\u2013" + (Lv.max_speed[k] / 10).toFixed(1) + " mm/s, mean " + (Lv.mean_speed[k] / 10).toFixed(1) + " mm/s, " +
    (Lv.feature[k] >= 0 ? fname(Lv.feature[k]) : "standing still") + (li >= 0 ? ", layer " + E.layers[li].layer : "");
}
clampView();
function zoomAt(t, f) { const a = view.t0, b = view.t1; view.t0 = t - (t - a) * f; view.t1 = t + (b - t) * f; clampView(); drawSpeed(); }
const spc = $("speed");
function timeAtX(clientX) { const r = spc.getBoundingClientRect(), pw = r.width - PAD.l - PAD.r; return view.t0 + (clientX - r.left - PAD.l) / pw * (view.t1 - view.t0); }
spc.addEventListener("wheel", (e) => { e.preventDefault(); zoomAt(timeAtX(e.clientX), e.deltaY < 0 ? 1 / 1.3 : 1.3); }, {passive: false});
$("zin").onclick = () => zoomAt((view.t0 + view.t1) / 2, 0.5);
$("zout").onclick = () => zoomAt((view.t0 + view.t1) / 2, 2);
$("zreset").onclick = () => { view.t0 = 0; view.t1 = Math.max(TEND, 1e-3); clampView(); drawSpeed(); };
$("left").onclick = () => { const s = view.t1 - view.t0; view.t0 -= s / 3; view.t1 -= s / 3; clampView(); drawSpeed(); };
$("right").onclick = () => { const s = view.t1 - view.t0; view.t0 += s / 3; view.t1 += s / 3; clampView(); drawSpeed(); };
// drag to pan, two fingers to zoom (pointer events: mouse, pen and touch)
const ptrs = new Map(); let pinch0 = null;
spc.addEventListener("pointerdown", (e) => { spc.setPointerCapture(e.pointerId); ptrs.set(e.pointerId, {x: e.clientX, t0: view.t0, t1: view.t1, tx: timeAtX(e.clientX)}); pinch0 = null; });
spc.addEventListener("pointermove", (e) => {
  readout(e.clientX);
  const p = ptrs.get(e.pointerId); if (!p) return;
  p.cx = e.clientX;
  const r = spc.getBoundingClientRect(), pw = r.width - PAD.l - PAD.r;
  if (ptrs.size === 1) { const dt = (e.clientX - p.x) / pw * (p.t1 - p.t0); view.t0 = p.t0 - dt; view.t1 = p.t1 - dt; clampView(); drawSpeed(); }
  else if (ptrs.size === 2) {
    const [a, b] = [...ptrs.values()]; const xa = a.cx !== undefined ? a.cx : a.x, xb = b.cx !== undefined ? b.cx : b.x;
    if (!pinch0) pinch0 = {d: Math.abs(xa - xb) || 1, t0: view.t0, t1: view.t1, mid: timeAtX((xa + xb) / 2)};
    const f = pinch0.d / (Math.abs(xa - xb) || 1);
    view.t0 = pinch0.mid - (pinch0.mid - pinch0.t0) * f; view.t1 = pinch0.mid + (pinch0.t1 - pinch0.mid) * f; clampView(); drawSpeed();
  }
});
const up = (e) => { ptrs.delete(e.pointerId); pinch0 = null; for (const p of ptrs.values()) { p.x = p.cx !== undefined ? p.cx : p.x; p.t0 = view.t0; p.t1 = view.t1; } };
spc.addEventListener("pointerup", up); spc.addEventListener("pointercancel", up);
const seen = new Set(S.feature.filter((f) => f >= 0));
const fl = $("flegend"); [...seen].sort((a, b) => a - b).forEach((f) => { const s = el("span"); const i = el("i"); i.style.background = fcolor(f); s.append(i, document.createTextNode(fname(f))); fl.append(s); });

// ---------------------------------------------------------------- time per layer / feature
let selLayer = 0;
function drawLayers() {
  const {g, w, h} = prep($("layers")); const L = E.layers; const P = {l: 46, r: 8, t: 8, b: 30};
  const pw = w - P.l - P.r, ph = h - P.t - P.b; g.font = "11px system-ui, sans-serif";
  let top = 1; L.forEach((l) => { top = Math.max(top, l.time_s); });
  const st = niceStep(top, 4); top = Math.ceil(top / st) * st;
  g.strokeStyle = "#e1e4ea"; g.fillStyle = "#5d6675"; g.textAlign = "right";
  for (let v = 0; v <= top + 1e-9; v += st) { const y = Math.round(P.t + ph - v / top * ph) + 0.5; g.beginPath(); g.moveTo(P.l, y); g.lineTo(P.l + pw, y); g.stroke(); g.fillText(fmtTime(v), P.l - 4, y + 4); }
  const bw = pw / Math.max(1, L.length);
  L.forEach((l, i) => { const bh = l.time_s / top * ph; g.fillStyle = i === selLayer ? "#d62728" : "#5a8dc0"; g.fillRect(P.l + i * bw, P.t + ph - bh, Math.max(1, bw - (bw > 3 ? 1 : 0)), bh); });
  g.fillStyle = "#5d6675"; g.textAlign = "center";
  const ls = Math.max(1, niceStep(L.length, Math.max(2, pw / 60)));
  for (let i = 0; i < L.length; i += ls) g.fillText(String(L[i].layer), P.l + (i + 0.5) * bw, P.t + ph + 14);
  g.fillText("layer (click a bar to show its toolpath)", P.l + pw / 2, h - 2);
  if (!L.length) { g.font = "14px system-ui, sans-serif"; g.fillText("no layers: the file marks no layer changes and prints nothing", P.l + pw / 2, P.t + ph / 2); }
  if (L.length) { let s = 0; L.forEach((l, i) => { if (l.time_s > L[s].time_s) s = i; }); $("layerinfo").textContent = "slowest layer " + L[s].layer + ": " + fmtTime(L[s].time_s) + "; selected layer " + L[selLayer].layer + ": " + fmtTime(L[selLayer].time_s); }
}
$("layers").addEventListener("click", (e) => { const r = $("layers").getBoundingClientRect(); const i = Math.floor((e.clientX - r.left - 46) / ((r.width - 54) / Math.max(1, E.layers.length))); if (i >= 0 && i < E.layers.length) selectLayerNumber(E.layers[i].layer); });
(function features() {
  const box = $("features"); const F = (E.features || []).filter((f) => f.time_s > 0).sort((a, b) => b.time_s - a.time_s);
  const tot = E.motion_time_s || 1; const top = F.length ? F[0].time_s : 1;
  F.forEach((f) => { const r = el("div", {class: "frow"}); const b = el("div", {class: "b"}); b.style.width = Math.max(0.5, f.time_s / top * 100) + "%"; b.style.background = fcolor(FN.indexOf(f.name));
    r.append(el("span", null, f.name), el("div", null), el("span", {class: "sub"}, fmtTime(f.time_s) + "  " + (f.time_s / tot * 100).toFixed(1) + " %")); r.children[1].append(b); box.append(r); });
  if (!F.length) box.append(el("p", {class: "sub"}, "No feature took any time."));
})();

// ---------------------------------------------------------------- toolpath
const TP = D.toolpath, Q = D.quality;
const layersTP = TP.layers.map((l) => { const n = l.dx.length, x = new Float64Array(n), y = new Float64Array(n); let px = 0, py = 0;
  for (let i = 0; i < n; i++) { px += l.dx[i]; py += l.dy[i]; x[i] = px / 100; y[i] = py / 100; } return {meta: l, x, y}; });
// One frame for every layer: the extrusions of the layers above the first (a purge line or
// a wide brim on the first layer would shrink the part), with a margin; the first layer may clip.
let bb = [Infinity, Infinity, -Infinity, -Infinity], vMaxTP = 1, eMaxTP = 0;
const upper = layersTP.some((L) => L.meta.layer >= 1);
layersTP.forEach((L) => { const k = L.meta.kind, inFrame = !upper || L.meta.layer >= 1; for (let i = 1; i < k.length; i++) if (k[i] >= 0) {
  if (inFrame) for (const j of [i - 1, i]) { bb[0] = Math.min(bb[0], L.x[j]); bb[1] = Math.min(bb[1], L.y[j]); bb[2] = Math.max(bb[2], L.x[j]); bb[3] = Math.max(bb[3], L.y[j]); }
  vMaxTP = Math.max(vMaxTP, L.meta.speed[i]); if (L.meta.error_um) eMaxTP = Math.max(eMaxTP, L.meta.error_um[i]); } });
const extrudes = isFinite(bb[0]);
if (!extrudes) layersTP.forEach((L) => { for (let i = 0; i < L.x.length; i++) { bb[0] = Math.min(bb[0], L.x[i]); bb[1] = Math.min(bb[1], L.y[i]); bb[2] = Math.max(bb[2], L.x[i]); bb[3] = Math.max(bb[3], L.y[i]); } });
if (isFinite(bb[0])) { const mx = 0.08 * Math.max(bb[2] - bb[0], bb[3] - bb[1], 1); bb = [bb[0] - mx, bb[1] - mx, bb[2] + mx, bb[3] + mx]; }
if (Q) { const o = el("option", {value: "error"}, "colour: contour error"); $("cmode").append(o); $("cmode").value = "error"; }
const qLayer = new Map(); if (Q) (Q.layers || []).forEach((l) => qLayer.set(l.layer, l));
const slider = $("lslider"); slider.max = String(Math.max(0, layersTP.length - 1));
let cur = Math.floor(layersTP.length / 2); slider.value = String(cur);
if (layersTP[cur] && layersTP[cur].meta.layer < 0 && layersTP.length > 1) { cur = 1; slider.value = "1"; }
function selectLayerNumber(n) { const i = layersTP.findIndex((L) => L.meta.layer === n); if (i >= 0) { cur = i; slider.value = String(i); drawToolpath(); } }
function drawToolpath() {
  const cv = $("toolpath"); const {g, w, h} = prep(cv, Math.round(Math.min(560, Math.max(260, cv.clientWidth * 0.8))));
  if (!layersTP.length) { g.fillStyle = "#5d6675"; g.font = "16px system-ui, sans-serif"; g.textAlign = "center"; g.fillText("no XY moves: no toolpath to draw", w / 2, h / 2); $("linfo").textContent = ""; return; }
  const L = layersTP[cur], m = L.meta, byErr = $("cmode").value === "error" && m.error_um;
  const sx = bb[2] - bb[0] || 1, sy = bb[3] - bb[1] || 1, pad = 14;
  const s = Math.min((w - 2 * pad) / sx, (h - 2 * pad) / sy), ox = (w - s * sx) / 2, oy = (h - s * sy) / 2;
  const X = (x) => ox + (x - bb[0]) * s, Y = (y) => h - oy - (y - bb[1]) * s;
  g.fillStyle = "#fbfcfd"; g.fillRect(X(bb[0]) - 4, Y(bb[3]) - 4, s * sx + 8, s * sy + 8);
  g.strokeStyle = "#e1e4ea"; g.strokeRect(X(bb[0]) - 4.5, Y(bb[3]) - 4.5, s * sx + 9, s * sy + 9);
  g.save(); g.beginPath(); g.rect(X(bb[0]) - 4, Y(bb[3]) - 4, s * sx + 8, s * sy + 8); g.clip();
  g.lineCap = "round"; g.lineJoin = "round";
  // travel first, thin and grey (darker and wider when the file has nothing else)
  g.strokeStyle = extrudes ? "#b8bec8" : "#6b7480"; g.lineWidth = extrudes ? 0.6 : 1.4; g.beginPath();
  for (let i = 1; i < m.kind.length; i++) if (m.kind[i] === -1) { g.moveTo(X(L.x[i - 1]), Y(L.y[i - 1])); g.lineTo(X(L.x[i]), Y(L.y[i])); }
  g.stroke();
  g.lineWidth = Math.max(1.2, Math.min(3, 0.45 * s));
  const top = byErr ? Math.max(1, eMaxTP) : vMaxTP;
  for (let i = 1; i < m.kind.length; i++) {
    if (m.kind[i] < 0) continue;
    const val = byErr ? m.error_um[i] : m.speed[i];
    g.strokeStyle = byErr && val < 0 ? "#c8ccd4" : ramp(val / top);
    g.beginPath(); g.moveTo(X(L.x[i - 1]), Y(L.y[i - 1])); g.lineTo(X(L.x[i]), Y(L.y[i])); g.stroke();
  }
  g.restore();
  $("grad").style.background = gradCss;
  $("gmin").textContent = !extrudes ? "" : byErr ? "0 \u00b5m" : "0 mm/s";
  $("gmax").textContent = !extrudes ? "no extrusion: travel only" : byErr ? (top / 1000).toFixed(3) + " mm contour error" : top.toFixed(0) + " mm/s";
  $("grad").style.visibility = extrudes ? "visible" : "hidden";
  const lt = E.layers.find((l) => l.layer === m.layer);
  // Layer numbers as the summary counts them: the moves before the first layer (start G-code,
  // purge line) are shown apart, not as one more layer.
  const numbered = layersTP.filter((x) => x.meta.layer >= 0).length;
  let info = (m.layer < 0 ? (numbered ? "before the first layer (start G-code, purge line)" : "every move (the file marks no layers)")
                          : "layer " + m.layer + " (" + (layersTP.filter((x) => x.meta.layer >= 0 && x.meta.layer <= m.layer).length) + " of " + numbered + ")") +
             ", z " + m.z_mm.toFixed(2) + " mm, " + m.moves + " XY moves drawn as " + m.kind.length + " points";
  if (!extrudes) info += "; no extrusion in the file: travel moves only";
  if (lt) info += ", " + fmtTime(lt.time_s);
  if (m.tolerance_mm > TP.tolerance_mm) info += "; thinned to " + m.tolerance_mm.toFixed(2) + " mm to stay under the cap";
  if (m.truncated) info += "; cut short at the point cap";
  const q = qLayer.get(m.layer); if (q) info += "; contour error max " + (q.max_contour_error_mm * 1000).toFixed(1) + " \u00b5m, RMS " + (q.rms_contour_error_mm * 1000).toFixed(1) + " \u00b5m";
  $("linfo").textContent = info;
  const li = E.layers.findIndex((l) => l.layer === m.layer); if (li >= 0 && li !== selLayer) { selLayer = li; drawLayers(); }
}
slider.addEventListener("input", () => { cur = Number(slider.value); drawToolpath(); });
$("lprev").onclick = () => { if (cur > 0) { cur--; slider.value = String(cur); drawToolpath(); } };
$("lnext").onclick = () => { if (cur < layersTP.length - 1) { cur++; slider.value = String(cur); drawToolpath(); } };
$("cmode").addEventListener("change", drawToolpath);

// ---------------------------------------------------------------- quality
if (Q) {
  $("quality-section").hidden = false; const qc = $("qcards");
  card(qc, "Model", Q.natural_frequency_hz + " Hz, \u03b6 " + Q.damping_ratio, "belt on X and Y, " + Q.sample_rate_hz + " samples/s");
  if (Q.shaper) {
    const sh = (a, s) => s ? a + " " + s.type + " " + s.freq_hz + " Hz \u03b6 " + s.damping_ratio + " (" + s.firmware + (s.marlin_sample_rate_hz ? ", " + s.marlin_sample_rate_hz + " Hz grid" : "") + ")" : a + " none";
    const src = [Q.shaper.x, Q.shaper.y].filter((s) => s).map((s) => s.source).filter((v, i, a) => a.indexOf(v) === i).join(", ");
    card(qc, "Input shaper", sh("X", Q.shaper.x) + "; " + sh("Y", Q.shaper.y), "from " + src + "; contour error of the shaped motion against the planned path" + (Q.shaper.warnings.length ? "; " + Q.shaper.warnings.join("; ") : ""));
  }
  card(qc, "Contour error max", (Q.max_contour_error_mm * 1000).toFixed(1) + " \u00b5m", "RMS " + (Q.rms_contour_error_mm * 1000).toFixed(1) + " \u00b5m");
  card(qc, "While printing", (Q.max_contour_error_printing_mm * 1000).toFixed(1) + " \u00b5m", "RMS " + (Q.rms_contour_error_printing_mm * 1000).toFixed(1) + " \u00b5m");
  card(qc, "Corner overshoot max", (Q.max_corner_overshoot_mm * 1000).toFixed(1) + " \u00b5m", Q.corners + " corners");
  const t = el("table"); const hr = el("tr"); ["feature", "max error [\u00b5m]", "RMS [\u00b5m]"].forEach((x) => hr.append(el("th", null, x))); t.append(hr);
  (Q.features || []).forEach((f) => { const r = el("tr"); r.append(el("td", null, String(f.feature)), el("td", null, (f.max_contour_error_mm * 1000).toFixed(1)), el("td", null, (f.rms_contour_error_mm * 1000).toFixed(1))); t.append(r); });
  $("qtable").append(t);
}
$("footer").textContent = "Speed: " + NB + " buckets of " + fmtTime(BW) + (SF ? " and, zoomed in, " + SF.max_speed.length + " of " + fmtTime(SF.bucket_s) : "") + " (min, max and mean per bucket); toolpath: " + TP.points + " points from " + TP.moves + " XY moves, decimated at " + TP.tolerance_mm + " mm. Computed in " + E.compute_time_s.toFixed(3) + " s.";

// The accelerometer section (D.accel, from resonance::calibrate_file): the normalised PSD of
// each axis and their sum (left scale), every shaper Klipper fitted as the fraction of
// vibration it leaves (right scale, 0-100 %), and psd_xyz after the recommended shaper.
const A = D.accel;
if (A) {
  $("accel-section").hidden = false;
  const rec = A.klipper.recommended;
  card($("acards"), "Klipper recommends", rec.name + " @ " + rec.freq_hz.toFixed(1) + " Hz", "calibrate_shaper.py's rule");
  if (A.psd) card($("acards"), "PSD peak", A.psd.peak_xyz_hz.toFixed(1) + " Hz", "x+y+z; axis " + A.axis + ": " + A.psd.peak_axis_hz.toFixed(1) + " Hz");
  if (A.sample_rate_hz) card($("acards"), "Record", A.sample_rate_hz.toFixed(0) + " samples/s", A.source);
  if (A.model) card($("acards"), "Modal fit (sweep)", A.model.natural_frequency_hz.toFixed(2) + " Hz", "\u03b6 " + A.model.damping_ratio.toFixed(3));
  const t = el("table"); const hr = el("tr");
  ["shaper", "frequency [Hz]", "vibrations left", "smoothing [mm]", "max accel [mm/s\u00b2]"].forEach((x) => hr.append(el("th", null, x))); t.append(hr);
  A.klipper.shapers.forEach((s) => { const r = el("tr"); r.append(el("td", null, s.name + (s.name === rec.name ? " (recommended)" : "")), el("td", null, s.freq_hz.toFixed(1)), el("td", null, (s.vibrations * 100).toFixed(1) + " %"), el("td", null, s.smoothing.toFixed(3)), el("td", null, s.max_accel_mm_s2.toFixed(0))); t.append(r); });
  $("atable").append(t);
  const lg = $("alegend");
  const item = (c, name, dash) => { const s = el("span"); const i = el("i"); i.style.background = c; if (dash) i.style.opacity = "0.6"; s.append(i, document.createTextNode(name)); lg.append(s); };
  [["#1f77b4", "PSD x"], ["#2ca02c", "PSD y"], ["#d62728", "PSD z"], ["#7f7f7f", "PSD x+y+z"], ["#000000", "x+y+z after " + rec.name]].forEach(([c, n]) => item(c, n));
  A.plot.curves.forEach((c, i) => item(PALETTE[(i + 3) % PALETTE.length], c.name + " @ " + c.freq_hz.toFixed(1) + " Hz (vibration left, right scale)", true));
}
function drawAccel() {
  if (!A) return;
  const P = A.plot, f = P.freq_hz;
  const {g, w, h} = prep($("accel"), 320);
  if (!f.length) return;
  const L = 64, R = 48, T = 10, B = 32, pw = w - L - R, ph = h - T - B, fmax = f[f.length - 1];
  let pmax = 0;
  for (const k of ["psd_x", "psd_y", "psd_z", "psd_xyz"]) for (const v of P[k]) if (v > pmax) pmax = v;
  if (!(pmax > 0)) pmax = 1;
  const X = (x) => L + x / fmax * pw, Y = (v) => T + ph - v / pmax * ph, Y2 = (v) => T + ph - Math.min(1, v) * ph;
  g.font = "11px system-ui, sans-serif"; g.lineWidth = 1;
  const fs = niceStep(fmax, Math.max(4, Math.floor(pw / 70)));
  for (let x = 0; x <= fmax + 1e-9; x += fs) { g.strokeStyle = "#e6e9ee"; g.beginPath(); g.moveTo(X(x), T); g.lineTo(X(x), T + ph); g.stroke(); g.fillStyle = "#5d6675"; g.textAlign = "center"; g.fillText(String(Math.round(x)), X(x), T + ph + 14); }
  const ps = niceStep(pmax, 5);
  for (let v = 0; v <= pmax * 1.0001; v += ps) { g.strokeStyle = "#e6e9ee"; g.beginPath(); g.moveTo(L, Y(v)); g.lineTo(L + pw, Y(v)); g.stroke(); g.fillStyle = "#5d6675"; g.textAlign = "right"; g.fillText(v.toExponential(1), L - 4, Y(v) + 4); }
  g.textAlign = "left"; for (let v = 0; v <= 1.0001; v += 0.25) g.fillText((v * 100).toFixed(0) + " %", L + pw + 4, Y2(v) + 4);
  g.textAlign = "center"; g.fillText("frequency [Hz]", L + pw / 2, h - 4);
  g.save(); g.translate(12, T + ph / 2); g.rotate(-Math.PI / 2); g.fillText("normalised PSD", 0, 0); g.restore();
  const line = (ys, Yf, color, width, dash) => {
    g.strokeStyle = color; g.lineWidth = width; g.setLineDash(dash || []); g.beginPath();
    for (let i = 0; i < f.length; i++) { const px = X(f[i]), py = Yf(ys[i]); if (i) g.lineTo(px, py); else g.moveTo(px, py); }
    g.stroke(); g.setLineDash([]);
  };
  P.curves.forEach((c, i) => line(c.remaining, Y2, PALETTE[(i + 3) % PALETTE.length], 1.2, [3, 3]));
  [["psd_x", "#1f77b4", 1.2], ["psd_y", "#2ca02c", 1.2], ["psd_z", "#d62728", 1.2], ["psd_xyz", "#7f7f7f", 2]].forEach(([k, c, wd]) => line(P[k], Y, c, wd));
  if (P.after_recommended.length) line(P.after_recommended, Y, "#000000", 1.6, [6, 3]);
  g.strokeStyle = "#9aa1ab"; g.lineWidth = 1; g.strokeRect(L, T, pw, ph);
}

// The heater section (D.thermal, thermal::run_heater_study): temperature of every controller
// against the set point (left scale) and its heater effort (duty, right scale, dashed).
const TH = D.thermal;
if (TH) {
  $("thermal-section").hidden = false;
  $("thtitle").textContent = "Heater loop (" + TH.heater + ", set point " + TH.target_c + " \u00b0C; fan at " + TH.fan_on_at_s + " s, flow from " + TH.flow_start_s + " s)";
  if (TH.target_from) $("thtable").append(el("p", {class: "sub"}, "Set point: " + TH.target_from + "."));
  const t = el("table"); const hr = el("tr");
  ["controller", "heat-up [s]", "overshoot [K]", "fan step max dev. [K]", "flow ripple [K]", "energy [kJ]"].forEach((x) => hr.append(el("th", null, x))); t.append(hr);
  (TH.runs || []).forEach((r) => { const tr = el("tr"); tr.append(el("td", null, r.controller), el("td", null, Number(r.heat_up_time_s).toFixed(1)), el("td", null, Number(r.overshoot_k).toFixed(2)), el("td", null, Number(r.fan_max_dev_k).toFixed(2)), el("td", null, Number(r.flow_ripple_k).toFixed(2)), el("td", null, (Number(r.energy_j) / 1000).toFixed(1))); t.append(tr); });
  $("thtable").append(t);
  TH.traces.forEach((r, i) => { const s = el("span"); const b = el("i"); b.style.background = PALETTE[i % PALETTE.length]; s.append(b, document.createTextNode(r.controller + " (temperature; effort dashed)")); $("thlegend").append(s); });
  const s = el("span"); const b = el("i"); b.style.background = "#000"; s.append(b, document.createTextNode("set point")); $("thlegend").append(s);
}
function drawThermal() {
  if (!TH || !TH.traces.length) return;
  const {g, w, h} = prep($("thermal"), 300);
  const L = 56, R = 48, T = 10, B = 32, pw = w - L - R, ph = h - T - B;
  let tmax = 0, cmin = 1e9, cmax = -1e9;
  for (const r of TH.traces) { tmax = Math.max(tmax, r.t_s[r.t_s.length - 1]); for (const c of r.measured_c) { cmin = Math.min(cmin, c); cmax = Math.max(cmax, c); } }
  cmax = Math.max(cmax, TH.target_c) + 2; cmin = Math.min(cmin, TH.target_c) - 2;
  const X = (t) => L + t / tmax * pw, Y = (c) => T + ph - (c - cmin) / (cmax - cmin) * ph, Y2 = (d) => T + ph - d * ph;
  g.font = "11px system-ui, sans-serif";
  const ts = niceStep(tmax, Math.max(4, Math.floor(pw / 70)));
  for (let x = 0; x <= tmax + 1e-9; x += ts) { g.strokeStyle = "#e6e9ee"; g.beginPath(); g.moveTo(X(x), T); g.lineTo(X(x), T + ph); g.stroke(); g.fillStyle = "#5d6675"; g.textAlign = "center"; g.fillText(String(Math.round(x)), X(x), T + ph + 14); }
  const cs = niceStep(cmax - cmin, 6);
  for (let c = Math.ceil(cmin / cs) * cs; c <= cmax; c += cs) { g.strokeStyle = "#e6e9ee"; g.beginPath(); g.moveTo(L, Y(c)); g.lineTo(L + pw, Y(c)); g.stroke(); g.fillStyle = "#5d6675"; g.textAlign = "right"; g.fillText(c.toFixed(0) + " \u00b0C", L - 4, Y(c) + 4); }
  g.textAlign = "left"; for (let d = 0; d <= 1.0001; d += 0.25) g.fillText((d * 100).toFixed(0) + " %", L + pw + 4, Y2(d) + 4);
  g.textAlign = "center"; g.fillText("time [s]", L + pw / 2, h - 4);
  g.strokeStyle = "#000"; g.lineWidth = 1; g.setLineDash([2, 2]); g.beginPath(); g.moveTo(L, Y(TH.target_c)); g.lineTo(L + pw, Y(TH.target_c)); g.stroke(); g.setLineDash([]);
  TH.traces.forEach((r, i) => {
    const c = PALETTE[i % PALETTE.length];
    g.strokeStyle = c; g.lineWidth = 1.5; g.beginPath(); r.t_s.forEach((t, k) => { const px = X(t), py = Y(r.measured_c[k]); if (k) g.lineTo(px, py); else g.moveTo(px, py); }); g.stroke();
    g.globalAlpha = 0.5; g.lineWidth = 1; g.setLineDash([4, 3]); g.beginPath(); r.t_s.forEach((t, k) => { const px = X(t), py = Y2(r.duty[k]); if (k) g.lineTo(px, py); else g.moveTo(px, py); }); g.stroke(); g.setLineDash([]); g.globalAlpha = 1;
  });
  g.strokeStyle = "#9aa1ab"; g.lineWidth = 1; g.strokeRect(L, T, pw, ph);
}

function drawAll() { drawSpeed(); drawLayers(); drawToolpath(); drawAccel(); drawThermal(); }
drawAll();
let rz = null; window.addEventListener("resize", () => { clearTimeout(rz); rz = setTimeout(drawAll, 100); });
document.body.setAttribute("data-drawn", "yes");
})();
</script>
</body>
</html>
)PAGE";

}  // namespace

std::string_view page_head() { return kHead; }
std::string_view page_tail() { return kTail; }

}  // namespace amctl::report
