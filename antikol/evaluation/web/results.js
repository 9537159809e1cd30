/* Result maps of antikol replays and comparisons (antikol.evaluation.html_results).
 *
 * antikolResults(map, layerControl, data) draws, on a Leaflet map of the network:
 * each vehicle's path coloured by its warning level (the lamp is on at "warning" and
 * "emergency"), one layer per analyser; every warning, false alarm and missed warning as a
 * clickable marker whose popup gives the pair, kind, level, distance, closing speed and
 * time and draws the pair's distance and warnings against time (the view of Figs. 10-11 of
 * the 2008 paper); a panel with the scores, a legend and the list of events.
 * No library besides Leaflet; no network access.
 */
(function () {
  "use strict";

  var LEVEL_COLOURS = {none: "#6b7b8c", advisory: "#e9a100", warning: "#d62728", emergency: "#7b0000"};
  var CATEGORIES = {
    warning: {label: "warning", colour: "#2166ac"},
    false_alarm: {label: "false alarm", colour: "#f58231"},
    missed: {label: "missed warning", colour: "#111111"}
  };
  var SVG = "http://www.w3.org/2000/svg";

  function esc(s) {
    return String(s === null || s === undefined ? "" : s)
      .replace(/&/g, "&amp;").replace(/</g, "&lt;").replace(/>/g, "&gt;").replace(/"/g, "&quot;");
  }

  function fmtTime(t) {
    if (t === null || t === undefined) { return "-"; }
    if (t > 1e8) {  // Unix time: show UTC clock time
      return new Date(t * 1000).toISOString().replace("T", " ").replace(/\.\d+Z$/, " UTC");
    }
    return t.toFixed(t % 1 ? 1 : 0) + " s";
  }

  function fmt(v, unit, digits) {
    if (v === null || v === undefined) { return "-"; }
    return v.toFixed(digits === undefined ? 1 : digits) + (unit ? " " + unit : "");
  }

  function el(name, attrs, parent) {
    var node = document.createElementNS(SVG, name);
    Object.keys(attrs || {}).forEach(function (k) { node.setAttribute(k, attrs[k]); });
    if (parent) { parent.appendChild(node); }
    return node;
  }

  function ticks(lo, hi, n) {
    var span = hi - lo;
    if (!(span > 0)) { return [lo]; }
    var step = Math.pow(10, Math.floor(Math.log10(span / n)));
    [1, 2, 5, 10].some(function (m) { if (span / (step * m) <= n) { step *= m; return true; } return false; });
    var out = [];
    for (var v = Math.ceil(lo / step) * step; v <= hi + 1e-9; v += step) { out.push(v); }
    return out;
  }

  /* The pair chart: distance against time, the warnings of each analyser as bars below,
   * the ground truth (if any) as a band behind, the events as vertical lines. */
  function drawChart(box, chart, event, levels) {
    var t = chart.t, n = t.length;
    var W = 440, left = 46, right = 10, top = 10, plotH = 120, barH = 12, barGap = 16;
    var bars = chart.bars || [];
    var H = top + plotH + 30 + bars.length * (barH + barGap) + 14 * (chart.lines.length + (chart.band ? 1 : 0));
    var svg = el("svg", {width: W, height: H, viewBox: "0 0 " + W + " " + H, "class": "ak-chart-svg"});
    if (!n) { box.textContent = "no samples"; return svg; }
    var t0 = t[0], t1 = t[n - 1] > t0 ? t[n - 1] : t0 + 1;
    var dmax = 10;
    chart.lines.forEach(function (line) {
      line.values.forEach(function (v) { if (v !== null && v > dmax) { dmax = v; } });
    });
    dmax *= 1.08;
    var x = function (v) { return left + (v - t0) / (t1 - t0) * (W - left - right); };
    var y = function (v) { return top + plotH - v / dmax * plotH; };
    var half = n > 1 ? (x(t[1]) - x(t[0])) / 2 : 2;
    var cell = function (i, yy, h, fill) {  // one sample's cell, clipped to the plot
      var a = Math.max(left, x(t[i]) - half), b = Math.min(W - right, x(t[i]) + half + 0.5);
      if (b > a) { el("rect", {x: a, y: yy, width: b - a, height: h, fill: fill}, svg); }
    };
    if (chart.band) {
      chart.band.values.forEach(function (s, i) {
        var fill = s === 2 ? "#f6c4c4" : (s === 1 ? "#fbefc4" : null);
        if (fill) { cell(i, top, plotH, fill); }
      });
    }
    el("rect", {x: left, y: top, width: W - left - right, height: plotH, fill: "none", stroke: "#888"}, svg);
    ticks(0, dmax, 4).forEach(function (v) {
      el("line", {x1: left, x2: W - right, y1: y(v), y2: y(v), stroke: "#ddd"}, svg);
      var lab = el("text", {x: left - 4, y: y(v) + 3, "text-anchor": "end", "class": "ak-tick"}, svg);
      lab.textContent = Math.round(v);
    });
    var rel = t0 > 1e8;  // Unix times: label seconds relative to the event
    var origin = rel ? event.t0 : 0;
    ticks(t0 - origin, t1 - origin, 6).forEach(function (v) {
      var xv = x(v + origin);
      el("line", {x1: xv, x2: xv, y1: top + plotH, y2: top + plotH + 4, stroke: "#666"}, svg);
      var lab = el("text", {x: xv, y: top + plotH + 15, "text-anchor": "middle", "class": "ak-tick"}, svg);
      lab.textContent = Math.round(v);
    });
    var xl = el("text", {x: W - right, y: top + plotH + 27, "text-anchor": "end", "class": "ak-tick"}, svg);
    xl.textContent = rel ? "time from the event (s)" : "time (s)";
    var yl = el("text", {x: 4, y: top + 8, "class": "ak-tick"}, svg);
    yl.textContent = "m";
    (chart.marks || []).forEach(function (m) {
      el("line", {x1: x(m), x2: x(m), y1: top, y2: top + plotH, stroke: m === event.t0 ? "#000" : "#999",
        "stroke-dasharray": "4 3", "stroke-width": m === event.t0 ? 1.5 : 1}, svg);
    });
    var lineColours = ["#1f4e9c", "#e6550d", "#31a354"];
    chart.lines.forEach(function (line, j) {
      var colour = lineColours[j % lineColours.length];
      if (line.style === "dots") {
        line.values.forEach(function (v, i) {
          if (v !== null) { el("circle", {cx: x(t[i]), cy: y(v), r: 2.2, fill: colour}, svg); }
        });
      } else {
        var pts = [];
        var flush = function () {
          if (pts.length) { el("polyline", {points: pts.join(" "), fill: "none", stroke: colour, "stroke-width": 1.8}, svg); }
          pts = [];
        };
        line.values.forEach(function (v, i) {
          if (v === null) { flush(); } else { pts.push(x(t[i]).toFixed(1) + "," + y(v).toFixed(1)); }
        });
        flush();
      }
    });
    var yb = top + plotH + 34;
    bars.forEach(function (bar) {
      var lab = el("text", {x: left, y: yb + 9, "class": "ak-bar-label"}, svg);
      lab.textContent = bar.label;
      yb += 12;
      el("rect", {x: left, y: yb, width: W - left - right, height: barH, fill: "#eef0f2"}, svg);
      bar.values.forEach(function (lv, i) {
        if (lv > 0) { cell(i, yb, barH, LEVEL_COLOURS[levels[lv]] || "#d62728"); }
      });
      yb += barH + barGap - 12;
    });
    chart.lines.forEach(function (line, j) {
      var colour = lineColours[j % lineColours.length];
      el("rect", {x: left, y: yb + 2, width: 14, height: 3, fill: colour}, svg);
      var lab = el("text", {x: left + 18, y: yb + 7, "class": "ak-bar-label"}, svg);
      lab.textContent = line.label;
      yb += 14;
    });
    if (chart.band) {
      el("rect", {x: left, y: yb, width: 7, height: 8, fill: "#f6c4c4"}, svg);
      el("rect", {x: left + 7, y: yb, width: 7, height: 8, fill: "#fbefc4"}, svg);
      var bl = el("text", {x: left + 18, y: yb + 7, "class": "ak-bar-label"}, svg);
      bl.textContent = chart.band.label;
      yb += 14;
    }
    box.appendChild(svg);
    return svg;
  }

  function popupHtml(ev, methodLabel) {
    var cat = CATEGORIES[ev.cat] || {label: ev.cat};
    var rows = [
      ["analyser", methodLabel],
      ["event", cat.label + (ev.by && ev.by !== ev.method ? " (by " + ev.by + ")" : "")],
      ["pair", ev.own + " \u2192 " + ev.other],
      ["kind", ev.kind || "-"],
      ["level", ev.level],
      ["time", fmtTime(ev.t0) + (ev.t1 !== null && ev.t1 !== ev.t0 ? " \u2013 " + fmtTime(ev.t1) : "")],
      ["distance", fmt(ev.d, "m") + (ev.dmin !== null && ev.dmin !== undefined ? " (min " + fmt(ev.dmin, "m") + ")" : "")],
      ["closing speed", fmt(ev.v, "m/s")],
      ["time to collision", fmt(ev.ttc, "s")]
    ];
    if (ev.zone) { rows.push(["zone", ev.zone]); }
    if (ev.p !== null && ev.p !== undefined) { rows.push(["probability", fmt(ev.p, "", 3)]); }
    if (ev.note) { rows.push(["note", ev.note]); }
    return "<div class=\"ak-pop\" data-event=\"" + ev.id + "\"><div class=\"ak-pop-title\">" +
      esc(cat.label) + ": " + esc(ev.own) + " about " + esc(ev.other) + "</div><table>" +
      rows.map(function (r) { return "<tr><th>" + esc(r[0]) + "</th><td>" + esc(r[1]) + "</td></tr>"; }).join("") +
      "</table><div class=\"ak-chart\"></div></div>";
  }

  function antikolResults(map, control, data) {
    var view = {map: map, markers: {}, layers: {}, data: data};
    var methodLabel = {};
    data.methods.forEach(function (m) { methodLabel[m.key] = m.label; });

    data.methods.forEach(function (m, mi) {
      var group = L.featureGroup();
      (data.paths[m.key] || []).forEach(function (p) {
        p.runs.forEach(function (run) {
          var level = data.levels[run[0]];
          var lamp = run[0] >= 2;
          L.polyline(run[1], {color: LEVEL_COLOURS[level], weight: lamp ? 5 : 3, opacity: lamp ? 0.95 : 0.75})
            .bindTooltip(p.v + (lamp ? " (lamp on)" : ""), {sticky: true})
            .addTo(group);
        });
      });
      if (mi === 0) { group.addTo(map); }
      control.addOverlay(group, m.label + ": paths, red where the lamp is on");
      view.layers["paths:" + m.key] = group;
    });

    var groups = {};
    data.events.forEach(function (ev) {
      var key = ev.method + ":" + ev.cat;
      if (!groups[key]) { groups[key] = L.featureGroup(); }
      var cat = CATEGORIES[ev.cat] || {colour: "#555"};
      var ring = ev.method === "sector" && data.methods.length > 1;
      var marker = L.circleMarker([ev.lat, ev.lon], {
        radius: ring ? 8 : 7, color: ring ? cat.colour : "#fff", weight: ring ? 3 : 1.5,
        fillColor: ring ? "#fff" : cat.colour, fillOpacity: ring ? 0.6 : 0.95
      });
      // built when opened, so the chart is drawn before Leaflet lays the popup out
      marker.bindPopup(function () {
        var div = document.createElement("div");
        div.innerHTML = popupHtml(ev, methodLabel[ev.method] || ev.method);
        if (ev.chart !== undefined) {
          drawChart(div.querySelector(".ak-chart"), data.charts[ev.chart], ev, data.levels);
        }
        return div;
      }, {maxWidth: 470, minWidth: 440});
      marker.bindTooltip((CATEGORIES[ev.cat] || {label: ev.cat}).label + ": " + ev.own + " \u2192 " + ev.other);
      marker.addTo(groups[key]);
      view.markers[ev.id] = {marker: marker, group: groups[key]};
    });
    data.methods.forEach(function (m) {
      Object.keys(CATEGORIES).forEach(function (c) {
        var g = groups[m.key + ":" + c];
        if (!g) { return; }
        g.addTo(map);
        control.addOverlay(g, m.label + ": " + CATEGORIES[c].label + "s (" + g.getLayers().length + ")");
        view.layers["events:" + m.key + ":" + c] = g;
      });
    });

    view.open = function (id) {
      var entry = view.markers[id];
      if (!entry) { return; }
      if (!map.hasLayer(entry.group)) { entry.group.addTo(map); }
      map.setView(entry.marker.getLatLng(), Math.max(map.getZoom(), 16), {animate: false});
      entry.marker.openPopup();
    };

    var panel = L.control({position: "topleft"});
    panel.onAdd = function () {
      var div = L.DomUtil.create("div", "ak-panel");
      var html = "<div class=\"ak-title\">" + esc(data.title) + "</div>";
      data.methods.forEach(function (m) {
        if (m.summary) { html += "<div class=\"ak-score\"><b>" + esc(m.label) + ":</b> " + esc(m.summary) + "</div>"; }
      });
      html += "<div class=\"ak-legend\">";
      ["none", "advisory", "warning", "emergency"].forEach(function (lv) {
        if (data.kind === "comparison" && (lv === "advisory" || lv === "emergency")) { return; }
        var label = lv === "none" ? "lamp off" : (lv === "advisory" ? "advisory (lamp off)" : "lamp on (" + lv + ")");
        html += "<span><i class=\"ak-line\" style=\"background:" + LEVEL_COLOURS[lv] + "\"></i>" + esc(label) + "</span>";
      });
      html += "</div><div class=\"ak-legend\">";
      Object.keys(CATEGORIES).forEach(function (c) {
        html += "<span><i class=\"ak-dot\" style=\"background:" + CATEGORIES[c].colour + "\"></i>" + CATEGORIES[c].label + "</span>";
      });
      if (data.methods.length > 1) {
        html += "<span><i class=\"ak-dot ak-ring\"></i>ring: " + esc(methodLabel.sector || "sector rule") + "</span>";
      }
      html += "</div>";
      var events = data.events.slice().sort(function (a, b) { return a.t0 - b.t0; });
      html += "<details" + (events.length <= 12 ? " open" : "") + "><summary>" + events.length +
        " event(s): click one to see it</summary><table class=\"ak-events\"><tr><th>time</th>" +
        (data.methods.length > 1 ? "<th>analyser</th>" : "") + "<th>event</th><th>pair</th><th>kind</th></tr>";
      events.forEach(function (ev) {
        html += "<tr data-event=\"" + ev.id + "\"><td>" + esc(fmtTime(ev.t0)) + "</td>" +
          (data.methods.length > 1 ? "<td>" + esc(ev.method) + "</td>" : "") +
          "<td><i class=\"ak-dot\" style=\"background:" + (CATEGORIES[ev.cat] || {}).colour + "\"></i>" +
          esc((CATEGORIES[ev.cat] || {label: ev.cat}).label) + "</td><td>" + esc(ev.own + " \u2192 " + ev.other) +
          "</td><td>" + esc(ev.kind || "-") + "</td></tr>";
      });
      html += "</table></details>";
      div.innerHTML = html;
      div.querySelector(".ak-title").addEventListener("click", function () {
        div.classList.toggle("ak-min");
      });
      map.on("popupopen", function () { div.classList.add("ak-min"); });
      map.on("popupclose", function () { div.classList.remove("ak-min"); });
      L.DomEvent.disableClickPropagation(div);
      L.DomEvent.disableScrollPropagation(div);
      div.querySelectorAll("tr[data-event]").forEach(function (row) {
        row.addEventListener("click", function () { view.open(Number(row.getAttribute("data-event"))); });
      });
      return div;
    };
    panel.addTo(map);
    if (data.bounds) { map.fitBounds(data.bounds, {padding: [20, 20], animate: false}); }
    window.antikolResultsView = view;
    return view;
  }

  window.antikolResults = antikolResults;
  window.antikolDrawChart = drawChart;
}());
