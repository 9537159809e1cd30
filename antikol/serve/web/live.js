/* The antikol live view (antikol.serve): the fleet moving on the map with its threats.
 *
 * antikolLive(map, layerControl, options) opens the server-sent events at options.events
 * (with the page's access token, if its address has one) and draws every snapshot: a
 * marker per vehicle coloured by its level, a line from each vehicle to every vehicle it
 * is warned about, and a panel with the clock, the connection and the current warnings.
 * window.antikolLiveView keeps what was drawn (tests read it). No library besides Leaflet;
 * no request but to the server the page came from.
 */
(function () {
  "use strict";

  var LEVEL_COLOURS = {none: "#4f6d8a", advisory: "#e9a100", warning: "#d62728", emergency: "#7b0000"};
  var RANK = {none: 0, advisory: 1, warning: 2, emergency: 3};
  var HISTORY = 5000;

  function esc(s) {
    return String(s === null || s === undefined ? "" : s)
      .replace(/&/g, "&amp;").replace(/</g, "&lt;").replace(/>/g, "&gt;").replace(/"/g, "&quot;");
  }

  function fmtTime(t) {
    if (t === null || t === undefined) { return "-"; }
    if (t > 1e8) { return new Date(t * 1000).toISOString().substr(11, 8) + " UTC"; }
    return t.toFixed(1) + " s";
  }

  function fmt(v, unit) { return v === null || v === undefined ? "-" : v.toFixed(1) + " " + unit; }

  function antikolLive(map, control, options) {
    var view = {map: map, markers: {}, history: [], latest: null, status: "connecting", ended: false};
    var vehicles = L.featureGroup().addTo(map);
    var lines = L.featureGroup().addTo(map);
    control.addOverlay(vehicles, "vehicles");
    control.addOverlay(lines, "threats (lines to the other vehicle)");
    var fitted = false;

    var panel = L.control({position: "topleft"});
    var box;
    panel.onAdd = function () {
      box = L.DomUtil.create("div", "ak-live");
      box.innerHTML = "<div class=\"ak-live-title\">" + esc(options.title) + "</div>" +
        "<div class=\"ak-live-status\" id=\"ak-status\">connecting\u2026</div>" +
        "<div class=\"ak-live-clock\" id=\"ak-clock\"></div>" +
        "<div class=\"ak-live-legend\">" + ["none", "advisory", "warning", "emergency"].map(function (lv) {
          return "<span><i style=\"background:" + LEVEL_COLOURS[lv] + "\"></i>" +
            (lv === "none" ? "no threat" : lv) + "</span>";
        }).join("") + "</div>" +
        "<table class=\"ak-live-warnings\" id=\"ak-warnings\"></table>" +
        "<a href=\"#\" class=\"ak-live-zoom\">zoom to the fleet</a>";
      box.querySelector(".ak-live-zoom").addEventListener("click", function (e) {
        e.preventDefault();
        if (vehicles.getLayers().length) { map.fitBounds(vehicles.getBounds().pad(0.3), {maxZoom: 17}); }
      });
      L.DomEvent.disableClickPropagation(box);
      L.DomEvent.disableScrollPropagation(box);
      return box;
    };
    panel.addTo(map);

    function setStatus(text, cls) {
      view.status = text;
      var el = document.getElementById("ak-status");
      if (el) { el.textContent = text; el.className = "ak-live-status " + (cls || ""); }
    }

    function render(snap) {
      var seen = {};
      snap.vehicles.forEach(function (v) {
        seen[v.id] = true;
        var m = view.markers[v.id];
        var style = {fillColor: LEVEL_COLOURS[v.level] || "#333", color: v.lamp ? "#000" : "#fff",
          weight: v.lamp ? 2.5 : 1.5, radius: v.lamp ? 9 : 7, fillOpacity: 0.95};
        if (!m) {
          m = L.circleMarker([v.lat, v.lon], style).addTo(vehicles);
          m.bindTooltip(esc(v.id), {permanent: true, direction: "right", offset: [8, 0], className: "ak-live-label"});
          view.markers[v.id] = m;
        } else {
          m.setLatLng([v.lat, v.lon]);
          m.setStyle(style);
        }
        m.bindPopup("<b>" + esc(v.id) + "</b>: " + esc(v.level) + (v.lamp ? " (lamp on)" : "") +
          "<br>speed " + fmt(v.speed, "m/s") + ", heading " + fmt(v.heading, "\u00b0") +
          "<br>position: " + esc(v.status) + ", method " + esc(v.method) +
          (v.threats.length ? "<br>threats: " + v.threats.map(function (th) {
            return esc(th.other) + " " + esc(th.kind) + " " + esc(th.level) + " at " + fmt(th.d, "m");
          }).join("; ") : ""));
      });
      Object.keys(view.markers).forEach(function (id) {
        if (!seen[id]) { vehicles.removeLayer(view.markers[id]); delete view.markers[id]; }
      });
      lines.clearLayers();
      var where = {};
      snap.vehicles.forEach(function (v) { where[v.id] = [v.lat, v.lon]; });
      snap.vehicles.forEach(function (v) {
        v.threats.forEach(function (th) {
          if (RANK[th.level] >= 1 && where[th.other]) {
            L.polyline([where[v.id], where[th.other]], {
              color: LEVEL_COLOURS[th.level], weight: RANK[th.level] >= 2 ? 4 : 2,
              dashArray: RANK[th.level] >= 2 ? null : "5 5", opacity: 0.9
            }).addTo(lines);
          }
        });
      });
      var clock = document.getElementById("ak-clock");
      if (clock) {
        clock.textContent = "cycle " + snap.cycle + ", " + fmtTime(snap.t) + " \u2014 " +
          snap.vehicles.length + " vehicle(s)" + (snap.source ? " \u2014 " + snap.source : "");
      }
      var table = document.getElementById("ak-warnings");
      if (table) {
        table.innerHTML = snap.warnings.length ?
          "<tr><th>level</th><th>vehicle</th><th>about</th><th>kind</th><th>gap</th><th>closing</th><th>ttc</th></tr>" +
          snap.warnings.map(function (w) {
            return "<tr class=\"ak-warning\" data-own=\"" + esc(w.own) + "\" data-other=\"" + esc(w.other) +
              "\" data-level=\"" + esc(w.level) + "\"><td><i style=\"background:" + LEVEL_COLOURS[w.level] +
              "\"></i>" + esc(w.level) + (w.held ? " (held)" : "") + "</td><td>" + esc(w.own) + "</td><td>" +
              esc(w.other) + "</td><td>" + esc(w.kind) + "</td><td>" + fmt(w.d, "m") + "</td><td>" +
              fmt(w.v, "m/s") + "</td><td>" + fmt(w.ttc, "s") + "</td></tr>";
          }).join("") : "<tr><td class=\"ak-quiet\">no warning</td></tr>";
      }
      if (options.fit && !fitted && snap.vehicles.length) {
        map.fitBounds(L.latLngBounds(snap.vehicles.map(function (v) { return [v.lat, v.lon]; })).pad(0.5),
          {maxZoom: 17, animate: false});
        fitted = true;
      }
      // what was drawn, read back from the map and the page
      var drawn = {};
      Object.keys(view.markers).forEach(function (id) {
        var ll = view.markers[id].getLatLng();
        drawn[id] = [ll.lat, ll.lng];
      });
      var rows = [];
      document.querySelectorAll("#ak-warnings tr.ak-warning").forEach(function (r) {
        rows.push(r.getAttribute("data-own") + ">" + r.getAttribute("data-other") + ":" + r.getAttribute("data-level"));
      });
      view.latest = snap;
      view.history.push({cycle: snap.cycle, t: snap.t, end: !!snap.end, markers: drawn, warnings: rows});
      if (view.history.length > HISTORY) { view.history.shift(); }
    }

    var token = new URLSearchParams(window.location.search).get("token");
    var url = options.events + (token ? "?token=" + encodeURIComponent(token) : "");
    var source = new EventSource(url);
    source.addEventListener("open", function () { setStatus("connected", "ak-ok"); });
    source.addEventListener("error", function () {
      if (!view.ended) { setStatus("connection lost: retrying\u2026", "ak-bad"); }
    });
    source.addEventListener("snapshot", function (e) { render(JSON.parse(e.data)); });
    source.addEventListener("end", function (e) {
      render(JSON.parse(e.data));
      view.ended = true;
      setStatus("the replay has ended", "ak-ended");
      source.close();
    });
    view.source = source;
    window.antikolLiveView = view;
    return view;
  }

  window.antikolLive = antikolLive;
}());
