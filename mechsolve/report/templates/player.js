// The report's animation: the frames' coordinates (JSON above) drawn on a canvas.
// No library and no network: plain DOM and canvas calls that every browser has.
(function () {
  "use strict";
  var holder = document.getElementById("player");
  var source = document.getElementById("player-data");
  if (!holder || !source) { return; }
  var data = JSON.parse(source.textContent);
  var canvas = document.getElementById("player-canvas");
  var ctx = canvas.getContext("2d");
  var slider = document.getElementById("player-slider");
  var button = document.getElementById("player-play");
  var label = document.getElementById("player-label");
  var forcesBox = document.getElementById("player-forces");
  var n = data.labels.length;
  var b = data.bounds;  // xmin, xmax, ymin, ymax [m]
  var W = canvas.width, H = canvas.height, pad = 24;
  var k = Math.min((W - 2 * pad) / (b[1] - b[0]), (H - 2 * pad) / (b[3] - b[2]));
  var ox = (W - k * (b[1] - b[0])) / 2, oy = (H - k * (b[3] - b[2])) / 2;
  var font = getComputedStyle(document.body).fontFamily;
  var colors = ["#1f77b4", "#ff7f0e", "#2ca02c", "#d62728", "#9467bd", "#8c564b",
                "#e377c2", "#7f7f7f", "#bcbd22", "#17becf"];
  function X(x) { return ox + k * (x - b[0]); }
  function Y(y) { return H - oy - k * (y - b[2]); }
  function ok(v) { return v !== null && v !== undefined && isFinite(v); }

  function path(xs, ys, first, last) {
    var started = false;
    ctx.beginPath();
    for (var i = first; i <= last; i++) {
      if (!ok(xs[i]) || !ok(ys[i])) { started = false; continue; }
      if (started) { ctx.lineTo(X(xs[i]), Y(ys[i])); } else { ctx.moveTo(X(xs[i]), Y(ys[i])); started = true; }
    }
  }

  function arrow(x0, y0, x1, y1) {
    var dx = x1 - x0, dy = y1 - y0, len = Math.sqrt(dx * dx + dy * dy);
    if (len < 1) { return; }
    var ux = dx / len, uy = dy / len, h = Math.min(10, len / 2);
    ctx.beginPath();
    ctx.moveTo(x0, y0); ctx.lineTo(x1, y1);
    ctx.moveTo(x1, y1); ctx.lineTo(x1 - h * ux + 0.5 * h * uy, y1 - h * uy - 0.5 * h * ux);
    ctx.moveTo(x1, y1); ctx.lineTo(x1 - h * ux - 0.5 * h * uy, y1 - h * uy + 0.5 * h * ux);
    ctx.stroke();
  }

  function draw(f) {
    ctx.clearRect(0, 0, W, H);
    ctx.lineJoin = "round"; ctx.lineCap = "round";
    // fixed guides
    ctx.setLineDash([6, 4]); ctx.strokeStyle = "#666"; ctx.lineWidth = 1;
    data.guides.forEach(function (g) {
      ctx.beginPath(); ctx.moveTo(X(g[0]), Y(g[1])); ctx.lineTo(X(g[2]), Y(g[3])); ctx.stroke();
    });
    ctx.setLineDash([]);
    // paths: the whole path faint, the part travelled so far strong; with few frames
    // from a finer sweep (traces: its samples, trace_upto: how many each frame passed)
    data.paths.forEach(function (p, j) {
      var xy = data.points[p], tr = data.traces ? data.traces[p] : null;
      ctx.strokeStyle = colors[j % colors.length];
      ctx.globalAlpha = 0.25; ctx.lineWidth = 1;
      if (tr) { path(tr[0], tr[1], 0, tr[0].length - 1); } else { path(xy[0], xy[1], 0, n - 1); }
      ctx.stroke();
      ctx.globalAlpha = 1; ctx.lineWidth = 2;
      if (tr) {
        var k = data.trace_upto[f];
        path(tr[0].slice(0, k).concat([xy[0][f]]), tr[1].slice(0, k).concat([xy[1][f]]), 0, k);
      } else { path(xy[0], xy[1], 0, f); }
      ctx.stroke();
    });
    // links
    data.outlines.forEach(function (o) {
      var m = o.corners, xs = o.x.slice(f * m, f * m + m), ys = o.y.slice(f * m, f * m + m);
      if (!xs.every(ok) || !ys.every(ok)) { return; }
      ctx.beginPath();
      for (var i = 0; i < m; i++) { if (i) { ctx.lineTo(X(xs[i]), Y(ys[i])); } else { ctx.moveTo(X(xs[i]), Y(ys[i])); } }
      if (o.closed) {
        ctx.closePath(); ctx.fillStyle = o.color; ctx.globalAlpha = 0.25; ctx.fill(); ctx.globalAlpha = 1;
      }
      ctx.strokeStyle = o.color; ctx.lineWidth = 3; ctx.stroke();
      var cx = 0, cy = 0;
      for (i = 0; i < m; i++) { cx += xs[i] / m; cy += ys[i] / m; }
      ctx.fillStyle = o.color; ctx.font = "12px " + font; ctx.textAlign = "center";
      ctx.fillText(o.name, X(cx), Y(cy) - 6);
    });
    // fixed pivots, joints, names
    ctx.textAlign = "left";
    data.ground.forEach(function (p) {
      var x = X(data.points[p][0][f]), y = Y(data.points[p][1][f]);
      ctx.fillStyle = "#555"; ctx.beginPath();
      ctx.moveTo(x, y); ctx.lineTo(x - 9, y + 14); ctx.lineTo(x + 9, y + 14); ctx.closePath(); ctx.fill();
    });
    data.ground.concat(data.joints, data.paths).forEach(function (p) {
      var xv = data.points[p][0][f], yv = data.points[p][1][f];
      if (!ok(xv) || !ok(yv)) { return; }
      var x = X(xv), y = Y(yv);
      ctx.beginPath(); ctx.arc(x, y, 4, 0, 2 * Math.PI);
      ctx.fillStyle = "#fff"; ctx.fill(); ctx.strokeStyle = "#000"; ctx.lineWidth = 1.2; ctx.stroke();
      ctx.fillStyle = "#000"; ctx.font = "13px " + font; ctx.fillText(p, x + 6, y - 6);
    });
    // force arrows, each labelled beyond its head: the joint forces (when asked for)
    // in red, the file's point loads in blue (where they act); one scale, shown by a bar
    function forces(set, color, text) {
      ctx.strokeStyle = color; ctx.fillStyle = color; ctx.lineWidth = 2;
      ctx.font = "11px " + font; ctx.textAlign = "center";
      Object.keys(set).forEach(function (j) {
        var F = set[j], xy = data.points[F.at];
        var x = xy[0][f], y = xy[1][f], fx = F.fx[f], fy = F.fy[f];
        if (!(ok(x) && ok(y) && ok(fx) && ok(fy)) || (fx === 0 && fy === 0)) { return; }
        var x0 = X(x), y0 = Y(y), x1 = X(x + fx), y1 = Y(y + fy);
        arrow(x0, y0, x1, y1);
        var len = Math.sqrt((x1 - x0) * (x1 - x0) + (y1 - y0) * (y1 - y0));
        if (len >= 1) { ctx.fillText(text(j, F), x1 + 12 * (x1 - x0) / len, y1 + 12 * (y1 - y0) / len + 4); }
      });
    }
    var showForces = data.forces && forcesBox && forcesBox.checked;
    if (showForces) { forces(data.forces, "#d62728", function (j) { return "R " + j; }); }
    if (data.loads) { forces(data.loads, "#1b3f8b", function (j, F) { return F.text; }); }
    if (data.bar && data.bar.length > 0 && (showForces || data.loads)) {
      var bx = pad, by = H - pad, bl = k * data.bar.length;
      ctx.strokeStyle = "#000"; ctx.lineWidth = 2; ctx.beginPath();
      ctx.moveTo(bx, by); ctx.lineTo(bx + bl, by);
      ctx.moveTo(bx, by - 5); ctx.lineTo(bx, by + 5); ctx.moveTo(bx + bl, by - 5); ctx.lineTo(bx + bl, by + 5);
      ctx.stroke();
      ctx.fillStyle = "#000"; ctx.font = "12px " + font; ctx.textAlign = "left";
      ctx.fillText(data.bar.text, bx, by - 9);
    }
    label.textContent = data.labels[f];
    holder.setAttribute("data-frame", String(f));
  }

  var frame = 0, timer = null, fps = 30;
  function show(f) { frame = ((f % n) + n) % n; slider.value = String(frame); draw(frame); }
  function stop() { if (timer !== null) { clearInterval(timer); timer = null; } button.textContent = "Play"; }
  function play() {
    if (timer !== null) { return; }
    button.textContent = "Pause";
    timer = setInterval(function () { show(frame + 1); }, 1000 / fps);
  }
  button.addEventListener("click", function () { if (timer === null) { play(); } else { stop(); } });
  slider.addEventListener("input", function () { stop(); show(parseInt(slider.value, 10)); });
  if (forcesBox) { forcesBox.addEventListener("change", function () { draw(frame); }); }
  show(0);
})();
