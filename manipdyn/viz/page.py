"""The self-contained playback page: meshcat's 3-D view with a time bar (play/pause, time slider, speed,
loop) and, beside it, plots of q, q̇, τ (and the closure gap) against time with a cursor that follows
playback and seeks on click.

Everything runs from the file: meshcat's viewer script inlined, the scene as msgpack commands in a JSON
data element, the plot data as JSON inside the player script (escaped by json_for_script: no "<", ">", "&"
and no raw non-ASCII survive). Names reach the page only through ``textContent`` (never as markup). The
page's Content-Security-Policy runs only its own scripts (by nonce) and fetches nothing.
"""
from __future__ import annotations

STYLE = """
html,body{margin:0;height:100%;font:13px/1.35 system-ui,-apple-system,"Segoe UI",sans-serif;color:#1d2330;
  background:#f4f5f7}
#manipdyn-app{display:grid;grid-template-columns:minmax(0,1fr) 34%;grid-template-rows:minmax(0,1fr) auto;
  height:100vh}
#manipdyn-view{grid-area:1/1;position:relative;overflow:hidden}
#meshcat-pane{width:100%;height:100%;overflow:hidden}
#manipdyn-bar{grid-area:2/1;display:flex;align-items:center;gap:10px;padding:6px 10px;background:#fff;
  border-top:1px solid #d5d8de}
#manipdyn-bar button{min-width:64px;padding:3px 8px}
#manipdyn-time{flex:1;min-width:80px}
#manipdyn-clock{font-variant-numeric:tabular-nums;min-width:150px}
#manipdyn-side{grid-area:1/2/3/3;overflow-y:auto;background:#fff;border-left:1px solid #d5d8de;padding:6px 8px}
#manipdyn-joints{display:flex;flex-wrap:wrap;gap:2px 10px;margin:2px 0 6px}
#manipdyn-joints label{white-space:nowrap;cursor:pointer}
.manipdyn-swatch{display:inline-block;width:10px;height:10px;border-radius:2px;margin-right:3px}
.manipdyn-plot{margin:4px 0 8px}
.manipdyn-plot h3{font-size:12px;font-weight:600;margin:2px 0}
.manipdyn-plot svg{width:100%;height:auto;display:block;cursor:crosshair;background:#fbfbfc;
  border:1px solid #e3e5e9}
.manipdyn-note{color:#8a4b00;font-size:12px}
"""

PLAYER = r"""
(function () {
  var D = MANIPDYN_DATA, anim = viewer.animator, P = D.plots;
  var COLORS = ["#1f77b4", "#d62728", "#2ca02c", "#ff7f0e", "#9467bd", "#8c564b", "#e377c2", "#17becf",
                "#7f7f7f", "#bcbd22"];
  var SVG = "http://www.w3.org/2000/svg", W = 420, H = 130, L = 46, R = 8, T = 8, B = 18;
  var st = {t: 0, playing: true, speed: D.speed, loop: true, last: null};
  function el(tag, attrs, text, ns) {
    var e = ns ? document.createElementNS(SVG, tag) : document.createElement(tag);
    for (var k in attrs || {}) e.setAttribute(k, attrs[k]);
    if (text !== undefined) e.textContent = text;
    return e;
  }
  function fmt(x) { return Math.abs(x) >= 1e4 || (Math.abs(x) < 1e-3 && x !== 0) ? x.toExponential(2) : +x.toPrecision(4) + ""; }

  // camera: refit the distance to this pane's width / height (the scene was framed for ASPECT_LIVE)
  function fit() {
    var pane = document.getElementById("meshcat-pane"), v = D.view, b = v.back;
    var aspect = Math.max(pane.clientWidth, 1) / Math.max(pane.clientHeight, 1);
    var f = [-b[0], -b[1], -b[2]], r = [f[1], -f[0], 0], n = Math.hypot(r[0], r[1]);
    r = [r[0] / n, r[1] / n, 0];
    var u = [r[1] * f[2] - r[2] * f[1], r[2] * f[0] - r[0] * f[2], r[0] * f[1] - r[1] * f[0]];
    var tv = Math.tan(v.fov * Math.PI / 360), th = tv * aspect, d = 1e-3;
    v.points.forEach(function (p) {
      var x = Math.abs(p[0] * r[0] + p[1] * r[1]) + v.pad;
      var y = Math.abs(p[0] * u[0] + p[1] * u[1] + p[2] * u[2]) + v.pad;
      d = Math.max(d, Math.max(x / th, y / tv) + p[0] * b[0] + p[1] * b[1] + p[2] * b[2]);
    });
    d *= v.margin;
    viewer.set_property(["Cameras", "default", "rotated", "<object>"], "position", [d * b[0], d * b[2], -d * b[1]]);
    viewer.set_dirty();
  }

  // the time bar
  var bar = document.getElementById("manipdyn-bar");
  var play = el("button", {id: "manipdyn-play", type: "button"}, "Pause");
  var slider = el("input", {id: "manipdyn-time", type: "range", min: "0", max: String(D.duration), step: "any",
                            value: "0", "aria-label": "time"});
  var clock = el("span", {id: "manipdyn-clock"});
  var speed = el("select", {id: "manipdyn-speed", "aria-label": "speed"});
  [0.25, 0.5, 1, 2, 4].forEach(function (s) {
    var o = el("option", {value: String(s)}, s + "×");
    if (s === D.speed) o.selected = true;
    speed.appendChild(o);
  });
  var loopBox = el("input", {id: "manipdyn-loop", type: "checkbox"});
  loopBox.checked = true;
  var loopLabel = el("label", {}, " loop");
  loopLabel.insertBefore(loopBox, loopLabel.firstChild);
  [play, slider, clock, el("span", {}, "speed"), speed, loopLabel].forEach(function (e) { bar.appendChild(e); });

  // the plots
  var side = document.getElementById("manipdyn-side"), plots = [], shown = {};
  var names = [];
  P.groups.forEach(function (g) { g.names.forEach(function (n) { if (names.indexOf(n) < 0 && g.key !== "gap") names.push(n); }); });
  var preferred = P.groups.filter(function (g) { return g.key === "tau"; }).map(function (g) { return g.names; })[0] || names;
  names.forEach(function (n, k) { shown[n] = preferred.indexOf(n) >= 0 && k < 12; });
  var picker = el("div", {id: "manipdyn-joints"});
  names.forEach(function (n, k) {
    var box = el("input", {type: "checkbox", "data-joint": n});
    box.checked = shown[n];
    box.addEventListener("change", function () { shown[n] = box.checked; draw(); });
    var lab = el("label", {});
    lab.appendChild(box);
    lab.appendChild(el("span", {"class": "manipdyn-swatch", style: "background:" + COLORS[k % COLORS.length]}));
    lab.appendChild(document.createTextNode(n));
    picker.appendChild(lab);
  });
  side.appendChild(el("div", {}, "joints shown:"));
  side.appendChild(picker);
  var t0 = P.t[0], tEnd = D.t0 + D.duration, tAxis = tEnd;
  P.marks.forEach(function (m) { if (m.t > tAxis && m.t <= tEnd + 0.25 * (tEnd - D.t0)) tAxis = m.t; });
  if (tAxis <= D.t0) tAxis = D.t0 + 1;
  function X(t) { return L + (t - D.t0) / (tAxis - D.t0) * (W - L - R); }
  P.groups.forEach(function (g) {
    var box = el("div", {"class": "manipdyn-plot", id: "manipdyn-plot-" + g.key});
    box.appendChild(el("h3", {}, g.title));
    var svg = el("svg", {viewBox: "0 0 " + W + " " + H, preserveAspectRatio: "none"}, undefined, true);
    var lines = el("g", {}, undefined, true), axes = el("g", {}, undefined, true);
    var cursor = el("line", {"class": "manipdyn-cursor", x1: L, x2: L, y1: T, y2: H - B, stroke: "#111",
                             "stroke-width": "1.2"}, undefined, true);
    svg.appendChild(axes); svg.appendChild(lines); svg.appendChild(cursor);
    svg.addEventListener("click", function (ev) {
      var rect = svg.getBoundingClientRect(), x = (ev.clientX - rect.left) / rect.width * W;
      var t = D.t0 + (x - L) / (W - L - R) * (tAxis - D.t0);
      pause(); seek(t - D.t0);
    });
    box.appendChild(svg);
    side.appendChild(box);
    plots.push({g: g, svg: svg, lines: lines, axes: axes, cursor: cursor});
  });
  (P.notes || []).forEach(function (n) { side.appendChild(el("div", {"class": "manipdyn-note"}, n)); });
  function draw() {
    plots.forEach(function (p) {
      var g = p.g, lo = Infinity, hi = -Infinity, idx = [];
      g.names.forEach(function (n, k) {
        var on = g.key === "gap" || shown[n];
        if (!on) return;
        idx.push(k);
        g.series[k].forEach(function (v) { if (v !== null) { lo = Math.min(lo, v); hi = Math.max(hi, v); } });
      });
      if (!(hi >= lo)) { lo = -1; hi = 1; }
      if (g.key === "gap") { lo = 0; hi = Math.max(hi, D.closure_tol); }   // closed: a flat line at 0
      if (hi - lo < 1e-12 * Math.max(1, Math.abs(hi))) { lo -= 0.5; hi += 0.5; }
      var pad = 0.06 * (hi - lo); lo -= pad; hi += pad;
      function Y(v) { return T + (hi - v) / (hi - lo) * (H - T - B); }
      while (p.lines.firstChild) p.lines.removeChild(p.lines.firstChild);
      while (p.axes.firstChild) p.axes.removeChild(p.axes.firstChild);
      p.axes.appendChild(el("rect", {x: L, y: T, width: W - L - R, height: H - T - B, fill: "none", stroke: "#c9ccd2"}, undefined, true));
      [hi - pad, lo + pad].forEach(function (v) {
        p.axes.appendChild(el("text", {x: L - 3, y: Y(v) + 4, "text-anchor": "end", "font-size": "10", fill: "#444"}, fmt(v), true));
      });
      if (lo < 0 && hi > 0) p.axes.appendChild(el("line", {x1: L, x2: W - R, y1: Y(0), y2: Y(0), stroke: "#d5d8de"}, undefined, true));
      [D.t0, tAxis].forEach(function (t, k) {
        p.axes.appendChild(el("text", {x: X(t), y: H - 5, "text-anchor": k ? "end" : "start", "font-size": "10", fill: "#444"}, fmt(t) + " s", true));
      });
      if (tAxis > tEnd) p.axes.appendChild(el("rect", {x: X(tEnd), y: T, width: X(tAxis) - X(tEnd), height: H - T - B, fill: "#eceef1"}, undefined, true));
      P.marks.forEach(function (m) {
        if (m.t < D.t0 || m.t > tAxis) return;
        p.axes.appendChild(el("line", {"class": "manipdyn-mark", x1: X(m.t), x2: X(m.t), y1: T, y2: H - B, stroke: "#c00",
                                       "stroke-dasharray": "4 3"}, undefined, true));
        p.axes.appendChild(el("text", {x: X(m.t) - 3, y: T + 10, "text-anchor": "end", "font-size": "10", fill: "#c00"}, m.label, true));
      });
      idx.forEach(function (k) {
        var pts = [];
        g.series[k].forEach(function (v, i) { if (v !== null) pts.push(X(P.t[i]).toFixed(1) + "," + Y(v).toFixed(1)); });
        var color = g.key === "gap" ? COLORS[k % COLORS.length] : COLORS[names.indexOf(g.names[k]) % COLORS.length];
        p.lines.appendChild(el("polyline", {points: pts.join(" "), fill: "none", stroke: color, "stroke-width": "1.4",
                                            "data-series": g.names[k]}, undefined, true));
      });
    });
  }

  // time
  function show() {
    slider.value = String(st.t);
    clock.textContent = "t = " + (D.t0 + st.t).toFixed(3) + " / " + tEnd.toFixed(3) + " s";
    var x = X(D.t0 + st.t).toFixed(2);
    plots.forEach(function (p) { p.cursor.setAttribute("x1", x); p.cursor.setAttribute("x2", x); });
  }
  function seek(t) {
    st.t = Math.max(0, Math.min(D.duration, t));
    anim.seek(st.t);
    show();
  }
  function pause() { st.playing = false; st.last = null; play.textContent = "Play"; }
  function resume() {
    if (st.t >= D.duration) st.t = 0;
    st.playing = true; st.last = null; play.textContent = "Pause";
  }
  function tick(now) {
    if (st.playing) {
      if (st.last !== null) {
        var t = st.t + (now - st.last) / 1000 * st.speed;
        if (t > D.duration) {
          if (st.loop && D.duration > 0) t = t % D.duration; else { t = D.duration; pause(); }
        }
        seek(t);
      }
      st.last = now;
    }
    requestAnimationFrame(tick);
  }
  play.addEventListener("click", function () { if (st.playing) pause(); else resume(); });
  slider.addEventListener("input", function () { pause(); seek(parseFloat(slider.value)); });
  speed.addEventListener("change", function () { st.speed = parseFloat(speed.value); });
  loopBox.addEventListener("change", function () { st.loop = loopBox.checked; });

  anim.pause();                                     // the page keeps the time; meshcat's clock stays stopped
  var m = /t=([0-9.eE+-]+)/.exec(window.location.hash);
  draw();
  fit();
  window.addEventListener("resize", fit);
  if (m) { pause(); seek(parseFloat(m[1]) - D.t0); } else { seek(0); }
  window.manipdyn = {seek: seek, pause: pause, play: resume, state: st, fit: fit, redraw: draw};
  requestAnimationFrame(tick);
})();
"""


def document(title_html, csp, nonce, commands_json, data_json, viewer_js, boot_js):
    """The page: escaped title, CSP, the command data element, the viewer script and the player script."""
    return ("<!DOCTYPE html>\n<html><head><meta charset=utf-8>"
            f'<meta http-equiv="Content-Security-Policy" content="{csp}">'
            f"<title>{title_html}</title><style>{STYLE}</style></head>"
            '<body><div id="manipdyn-app"><div id="manipdyn-view"><div id="meshcat-pane"></div></div>'
            '<div id="manipdyn-bar"></div><div id="manipdyn-side"></div></div>'
            f'<script type="application/json" id="manipdyn-commands">{commands_json}</script>'
            f'<script nonce="{nonce}">{viewer_js}</script>'
            f'<script nonce="{nonce}">var MANIPDYN_DATA = {data_json};\n{boot_js}{PLAYER}</script></body></html>\n')
