// somite replay page: decodes the episodes inlined by somite.viz.replay and draws them on
// canvases as somite.viz.frame draws a video frame. No network, no libraries.
"use strict";
(function () {
  var DATA = JSON.parse(document.getElementById("somite-data").textContent);
  var S = DATA.style;
  var HZ = S.hz;
  var VIEW_W = 720, VIEW_H = 405, BRAIN_PAD = 16, BRAIN_TITLE = 18;

  function bytes(b64) {
    var bin = atob(b64), out = new Uint8Array(bin.length);
    for (var i = 0; i < bin.length; i++) out[i] = bin.charCodeAt(i);
    return out.buffer;
  }

  // -- decoding ---------------------------------------------------------------------------------
  function decode(r) {
    r.com = new Float64Array(bytes(r.com));
    r.camera = new Float64Array(bytes(r.camera));
    r.pos = new Int16Array(bytes(r.pos));
    r.act = new Int8Array(bytes(r.act));
    r.readings = new Uint8Array(bytes(r.readings));
    r.contact = new Uint8Array(bytes(r.contact));
    r.groundX = new Float64Array(bytes(r.groundX));
    r.groundY = new Float32Array(bytes(r.groundY));
    if (r.brain) r.brain.activity = new Int8Array(bytes(r.brain.activity));
    return r;
  }
  var runs = DATA.runs.map(decode);
  var lastStep = Math.max.apply(null, runs.map(function (r) { return r.steps - 1; }));

  // Corner p of run r at step k [m].
  function point(r, k, p) {
    var i = (k * r.points + p) * 2;
    return [r.com[2 * k] + r.pos[i] * r.posScale, r.com[2 * k + 1] + r.pos[i + 1] * r.posScale];
  }
  function quads(r, k) {
    return r.corners.map(function (c) { return c.map(function (p) { return point(r, k, p); }); });
  }
  function velocityAt(r, k) {
    var start = Math.max(0, k - S.velocityWindow);
    if (k === start) return 0;
    return (r.com[2 * k] - r.com[2 * start]) * HZ / (k - start);
  }
  function areaRatio(q) {
    var twice = 0;
    for (var i = 0; i < 4; i++) {
      var a = q[i], b = q[(i + 1) % 4];
      twice += a[0] * b[1] - b[0] * a[1];
    }
    return 0.5 * twice / (S.voxelSide * S.voxelSide);
  }
  function areaColour(ratio, delta) {
    // AREA_RAMP spans ratios 0.75 .. 1.25 in 101 steps; frame.area_colour scales by delta.
    var t = Math.max(-1, Math.min(1, (ratio - 1) / Math.max(delta, 1e-9)));
    return S.ramp[Math.round((t + 1) * 50)];
  }

  // -- the camera (camera.follow_view) ----------------------------------------------------------
  function view(r, k, w, h) {
    var span = 2.4 * S.voxelSide * Math.max(r.width, r.height * w / h, 4);
    var scale = w / span;
    var cx = r.camera[2 * k], cy = r.camera[2 * k + 1];
    return {x0: cx - 0.5 * w / scale, y0: cy - 0.38 * h / scale, scale: scale, w: w, h: h};
  }
  function px(v, xy) { return [(xy[0] - v.x0) * v.scale, v.h - (xy[1] - v.y0) * v.scale]; }

  // -- drawing one frame ------------------------------------------------------------------------
  function paintWorld(ctx, v, r) {
    ctx.fillStyle = S.sky;
    ctx.fillRect(0, 0, v.w, v.h);
    var x1 = v.x0 + v.w / v.scale, first = Math.floor(v.x0 / S.gridStep) * S.gridStep, x;
    ctx.strokeStyle = S.grid;
    ctx.lineWidth = 1;
    for (x = first; x <= x1 + S.gridStep; x += S.gridStep) {
      var c = (x - v.x0) * v.scale;
      ctx.beginPath(); ctx.moveTo(c, 0); ctx.lineTo(c, v.h); ctx.stroke();
    }
    var xs = r.groundX, ys = r.groundY, lo = 0, hi = xs.length - 1;
    while (lo < hi && xs[lo + 1] < v.x0) lo++;
    while (hi > lo && xs[hi - 1] > x1) hi--;
    ctx.beginPath();
    var top = [];
    for (var i = lo; i <= hi; i++) top.push(px(v, [xs[i], ys[i]]));
    var bottom = v.h + 10;
    top.forEach(function (p, j) { if (j === 0) ctx.moveTo(p[0], p[1]); else ctx.lineTo(p[0], p[1]);
      bottom = Math.max(bottom, p[1] + 10); });
    ctx.lineTo(top[top.length - 1][0], bottom); ctx.lineTo(top[0][0], bottom); ctx.closePath();
    ctx.fillStyle = S.ground; ctx.fill();
    ctx.beginPath();
    top.forEach(function (p, j) { if (j === 0) ctx.moveTo(p[0], p[1]); else ctx.lineTo(p[0], p[1]); });
    ctx.strokeStyle = S.groundEdge; ctx.lineWidth = 2; ctx.stroke();
    ctx.fillStyle = "#f5f0e6"; ctx.font = "11px sans-serif";
    for (x = first; x <= x1 + S.gridStep; x += S.gridStep) {
      if (Math.round(x / S.gridStep) % 2 === 0)
        ctx.fillText(x.toFixed(0) + " m", (x - v.x0) * v.scale + 3, v.h - 6);
    }
  }

  function paintRobot(ctx, v, r, k, opts) {
    var q = quads(r, k);
    ctx.lineWidth = 1.5; ctx.strokeStyle = S.outline; ctx.lineJoin = "round";
    q.forEach(function (quad) {
      ctx.beginPath();
      quad.forEach(function (xy, j) { var p = px(v, xy); if (j === 0) ctx.moveTo(p[0], p[1]);
        else ctx.lineTo(p[0], p[1]); });
      ctx.closePath();
      ctx.fillStyle = areaColour(areaRatio(quad), r.areaDelta);
      ctx.fill(); ctx.stroke();
    });
    if (!opts.overlays) return;
    paintRays(ctx, v, r, k, q);
    if (opts.sensors) paintSensors(ctx, v, r, k, q);
    if (opts.act) paintActuation(ctx, v, r, k, q);
  }

  function centre(quad) {
    return [(quad[0][0] + quad[1][0] + quad[2][0] + quad[3][0]) / 4,
            (quad[0][1] + quad[1][1] + quad[2][1] + quad[3][1]) / 4];
  }
  function reading(r, k, i) { return r.readings[k * r.readingCount + i] / 255; }

  function paintRays(ctx, v, r, k, q) {
    ctx.strokeStyle = S.ray; ctx.lineWidth = 1;
    r.sensors.forEach(function (sensors, vox) {
      var turn = 0;
      if (r.lidar.frame === "voxel") {
        var qd = q[vox];
        turn = Math.atan2(qd[1][1] - qd[0][1] + qd[2][1] - qd[3][1],
                          qd[1][0] - qd[0][0] + qd[2][0] - qd[3][0]);
      }
      sensors.forEach(function (s) {
        if (s[0] !== "lidar") return;
        var c = centre(q[vox]), a = px(v, c);
        s[1].forEach(function (idx, j) {
          var reach = reading(r, k, idx) * r.lidar.range, ang = r.lidar.angles[j] + turn;
          var b = px(v, [c[0] + reach * Math.cos(ang), c[1] + reach * Math.sin(ang)]);
          ctx.beginPath(); ctx.moveTo(a[0], a[1]); ctx.lineTo(b[0], b[1]); ctx.stroke();
        });
      });
    });
  }

  function paintSensors(ctx, v, r, k, q) {
    // Figure 1: a half disc at the voxel centre, a sector per sensor, one per reading.
    var radius = S.sectorRadius * S.voxelSide * v.scale;
    ctx.lineWidth = 1; ctx.strokeStyle = S.outline;
    r.sensors.forEach(function (sensors, vox) {
      if (!sensors.length) return;
      var c = px(v, centre(q[vox]));
      ctx.beginPath(); ctx.moveTo(c[0], c[1]); ctx.arc(c[0], c[1], radius, Math.PI, 2 * Math.PI);
      ctx.closePath(); ctx.stroke();
      var span = Math.PI / sensors.length;
      sensors.forEach(function (s, i) {
        var sub = span / s[1].length;
        s[1].forEach(function (idx, j) {
          var value = reading(r, k, idx);
          if (value * radius < 0.5) return;
          var start = Math.PI + i * span + j * sub;
          ctx.beginPath(); ctx.moveTo(c[0], c[1]);
          ctx.arc(c[0], c[1], value * radius, start, start + sub); ctx.closePath();
          ctx.fillStyle = S.sensorColours[s[0]]; ctx.fill(); ctx.stroke();
        });
      });
    });
  }

  function paintActuation(ctx, v, r, k, q) {
    // A bar across the voxel's top: to the right and blue when it contracts (+1), to the left
    // and magenta when it expands (-1).
    var half = 0.4 * S.voxelSide * v.scale;
    q.forEach(function (quad, vox) {
      var a = r.act[k * r.voxels + vox] / 127, c = px(v, centre(quad));
      var y = c[1] + 0.25 * S.voxelSide * v.scale;
      ctx.fillStyle = "#ffffff"; ctx.fillRect(c[0] - half, y - 3, 2 * half, 6);
      ctx.fillStyle = a >= 0 ? "#1f4fbf" : "#d81b60";
      ctx.fillRect(Math.min(c[0], c[0] + a * half), y - 3, Math.abs(a * half), 6);
    });
  }

  function paintText(ctx, v, r, k, label) {
    var text = "t = " + (k / HZ).toFixed(2) + " s   v_x = " +
      (velocityAt(r, k) >= 0 ? "+" : "") + velocityAt(r, k).toFixed(2) + " m/s";
    ctx.font = "15px sans-serif";
    var w = ctx.measureText(text).width;
    ctx.fillStyle = "#ffffff"; ctx.fillRect(4, 4, w + 12, 24);
    ctx.fillStyle = S.text; ctx.fillText(text, 10, 21);
    ctx.font = "12px sans-serif";
    var name = label || r.terrain;
    ctx.fillText(name, v.w - ctx.measureText(name).width - 8, 18);
  }

  // -- the controller panel ---------------------------------------------------------------------
  function activityColour(a) {
    // -1 magenta, 0 white, +1 blue: the edge colours of the brain drawings.
    var t = Math.min(1, Math.abs(a)), end = a >= 0 ? [31, 79, 191] : [216, 27, 96];
    var c = end.map(function (e) { return Math.round(255 + (e - 255) * t); });
    return "rgb(" + c.join(",") + ")";
  }
  // Pixels per voxel of the controller panel: 60, less for a body wider than 7 or taller than 6.
  function brainUnit(r) { return Math.min(60, 420 / r.width, 360 / r.height); }
  function paintBrain(ctx, r, k, w, h) {
    var b = r.brain;
    ctx.fillStyle = "#ffffff"; ctx.fillRect(0, 0, w, h);
    var pad = BRAIN_PAD, unit = brainUnit(r);
    var ox = (w - unit * r.width) / 2, oy = pad + BRAIN_TITLE;
    function at(xy) { return [ox + xy[0] * unit, oy + (r.height - xy[1]) * unit]; }
    ctx.lineWidth = 1; ctx.strokeStyle = "#555555"; ctx.fillStyle = "#f4f1e8";
    b.quads.forEach(function (quad) {
      ctx.beginPath();
      quad.forEach(function (xy, j) { var p = at(xy); if (j === 0) ctx.moveTo(p[0], p[1]);
        else ctx.lineTo(p[0], p[1]); });
      ctx.closePath(); ctx.fill(); ctx.stroke();
    });
    var n = b.nodes.length, act = b.activity;
    b.edges.forEach(function (e) {
      var a = at(b.nodes[e[0]].slice(1)), c = at(b.nodes[e[1]].slice(1));
      var flow = Math.abs(act[k * n + e[0]] / 127);
      ctx.globalAlpha = 0.25 + 0.75 * flow;
      ctx.strokeStyle = e[3]; ctx.lineWidth = 0.7 + 2.3 * Math.min(Math.abs(e[2]), 3) / 3;
      ctx.beginPath(); ctx.moveTo(a[0], a[1]); ctx.lineTo(c[0], c[1]); ctx.stroke();
    });
    ctx.globalAlpha = 1;
    var radius = Math.max(3, 0.07 * unit);
    b.nodes.forEach(function (node, i) {
      var p = at(node.slice(1)), a = act[k * n + i] / 127;
      ctx.fillStyle = activityColour(a); ctx.strokeStyle = "#202020"; ctx.lineWidth = 1;
      ctx.beginPath();
      if (node[0] === "sensor") ctx.arc(p[0], p[1], radius, 0, 2 * Math.PI);
      else if (node[0] === "hidden") ctx.rect(p[0] - radius, p[1] - radius, 2 * radius, 2 * radius);
      else {
        var d = 1.5 * radius;
        ctx.moveTo(p[0], p[1] - d); ctx.lineTo(p[0] + d, p[1]); ctx.lineTo(p[0], p[1] + d);
        ctx.lineTo(p[0] - d, p[1]); ctx.closePath();
      }
      ctx.fill(); ctx.stroke();
    });
    ctx.fillStyle = S.text; ctx.font = "12px sans-serif";
    ctx.fillText("controller: node activity (blue +1, white 0, magenta -1)", 6, 14);
  }

  // -- the page ---------------------------------------------------------------------------------
  var state = {step: 0, time: 0, playing: false, speed: 1, follow: true, fixed: null};
  // The address's fragment: #t=SECONDS&speed=S&ghosts&act&play, and #probe and #keys=...
  // for the tests.
  var hash = {};
  location.hash.replace(/^#/, "").split("&").forEach(function (part) {
    var kv = part.split("="); if (kv[0]) hash[kv[0]] = kv.length > 1 ? kv[1] : "1";
  });
  var probing = Boolean(hash.probe);
  var $ = function (id) { return document.getElementById(id); };
  var box = $("runs"), views = [];
  runs.forEach(function (r, i) {
    var div = document.createElement("div");
    div.className = "run";
    var canvas = document.createElement("canvas");
    canvas.width = VIEW_W; canvas.height = VIEW_H; canvas.id = "view" + i;
    div.appendChild(canvas);
    var brain = null;
    if (r.brain) {
      brain = document.createElement("canvas");
      brain.width = Math.max(340, Math.ceil(brainUnit(r) * r.width + 2 * BRAIN_PAD));
      brain.height = Math.ceil(brainUnit(r) * r.height + 2 * BRAIN_PAD + BRAIN_TITLE);
      brain.id = "brain" + i;
      div.appendChild(brain);
    }
    var meta = document.createElement("div");
    meta.style.flexBasis = "100%";
    var title = document.createElement("div");
    title.className = "meta";
    title.textContent = (r.name ? r.name + ": " : "") + r.shape.replace(/\n/g, "/") + " on " +
      r.terrain + ", v_x = " + (r.velocity === null ? "n/a" : r.velocity.toFixed(3)) + " m/s" +
      (r.complete ? "" : " (the simulation went non-finite; the recording stops early)");
    var gait = document.createElement("div");
    gait.className = "meta";
    gait.textContent = r.gait ? "gait: " + r.gait : "";
    var readout = document.createElement("div");
    readout.className = "readout"; readout.id = "readout" + i;
    meta.appendChild(title); meta.appendChild(gait); meta.appendChild(readout);
    div.appendChild(meta);
    box.appendChild(div);
    views.push({div: div, canvas: canvas, brain: brain, readout: readout});
  });
  if (runs.length < 2) $("ghostLabel").style.display = "none";
  var scrub = $("scrub");
  scrub.max = String(lastStep);

  function stepOf(r) { return Math.min(state.step, r.steps - 1); }
  function draw() {
    var ghosts = $("ghosts").checked && runs.length > 1;
    var opts = {sensors: $("sensors").checked, act: $("act").checked, overlays: true};
    runs.forEach(function (r, i) {
      var vw = views[i], k = stepOf(r);
      // As a ghost a run keeps its controller panel and readout; its own view is hidden.
      vw.canvas.style.display = ghosts && i > 0 ? "none" : "";
      var ctx = vw.canvas.getContext("2d");
      var v = view(r, k, VIEW_W, VIEW_H);
      if (!state.follow) {
        if (!state.fixed) state.fixed = [v.x0, v.y0];
        v.x0 = state.fixed[0]; v.y0 = state.fixed[1];
      }
      if (!ghosts || i === 0) {
        paintWorld(ctx, v, r);
        if (ghosts) {
          runs.forEach(function (g, j) {
            if (j === 0) return;
            ctx.globalAlpha = 0.45;
            paintRobot(ctx, v, g, stepOf(g), {overlays: false});
            ctx.globalAlpha = 1;
          });
        }
        paintRobot(ctx, v, r, k, opts);
        paintText(ctx, v, r, k, ghosts ? r.terrain + " (others as ghosts)" : "");
      }
      if (vw.brain) paintBrain(vw.brain.getContext("2d"), r, k, vw.brain.width, vw.brain.height);
      var x = r.com[2 * k], vel = velocityAt(r, k);
      vw.readout.textContent = "t = " + (k / HZ).toFixed(3) + " s   x = " + x.toFixed(3) +
        " m   v_x = " + vel.toFixed(3) + " m/s   step " + k + "/" + (r.steps - 1);
      vw.readout.setAttribute("data-step", String(k));
      vw.readout.setAttribute("data-x", String(x));
    });
    scrub.value = String(state.step);
    $("play").textContent = state.playing ? "pause" : "play";
    if (probing) document.body.setAttribute("data-probe", JSON.stringify(probe()));
  }

  function seekStep(k) {
    state.step = Math.max(0, Math.min(lastStep, Math.round(k)));
    state.time = state.step / HZ;
    draw();
  }
  function seek(t) { seekStep(t * HZ); state.time = Math.max(0, Math.min(lastStep / HZ, t)); }
  function setSpeed(s) {
    if (!isFinite(s)) return;
    state.speed = Math.max(0.05, Math.min(4, s));
    $("speed").value = String(Math.round(state.speed * 100) / 100);
  }
  var previous = null;
  function tick(now) {
    if (!state.playing) { previous = null; return; }
    if (previous !== null) {
      state.time += (now - previous) / 1000 * state.speed;
      if (state.time * HZ >= lastStep) { state.time = lastStep / HZ; state.playing = false; }
      state.step = Math.floor(state.time * HZ + 1e-9);
      draw();
    }
    previous = now;
    if (state.playing) requestAnimationFrame(tick);
  }
  function toggle() {
    if (!state.playing && state.step >= lastStep) seekStep(0);
    state.playing = !state.playing;
    previous = null;
    draw();
    if (state.playing) requestAnimationFrame(tick);
  }

  // Blurred after a click, so that the space bar reaches the page's keys, not the button.
  $("play").addEventListener("click", function () { toggle(); $("play").blur(); });
  scrub.addEventListener("input", function () { state.playing = false; seekStep(+scrub.value); });
  $("speed").addEventListener("change", function () { setSpeed(+$("speed").value); });
  $("follow").addEventListener("change", function () {
    state.follow = $("follow").checked; state.fixed = null; draw(); });
  ["sensors", "act", "ghosts"].forEach(function (id) { $(id).addEventListener("change", draw); });
  document.addEventListener("keydown", function (e) {
    // A focused control keeps its own keys (the scrubber's arrows move it one step too).
    if (e.target && /^(INPUT|BUTTON|SELECT)$/.test(e.target.tagName)) return;
    var jump = e.shiftKey ? Math.round(HZ) : 1;
    if (e.key === " ") { toggle(); }
    else if (e.key === "ArrowRight") { state.playing = false; seekStep(state.step + jump); }
    else if (e.key === "ArrowLeft") { state.playing = false; seekStep(state.step - jump); }
    else if (e.key === "Home") { seekStep(0); }
    else if (e.key === "End") { seekStep(lastStep); }
    else if (e.key === "[") { setSpeed(state.speed / 2); }
    else if (e.key === "]") { setSpeed(state.speed * 2); }
    else return;
    e.preventDefault();
  });

  // The test hook: the state shown, and the recorded corners of every run at that step.
  function probe() {
    return runs.map(function (r) {
      var k = stepOf(r), pts = [];
      if (state.playing) return {step: k, t: k / HZ, time: state.time, playing: true};
      for (var p = 0; p < r.points; p++) pts.push(point(r, k, p));
      return {step: k, t: k / HZ, x: r.com[2 * k], v: velocityAt(r, k), speed: state.speed,
              points: pts};
    });
  }
  window.somiteReplay = {seek: seek, seekStep: seekStep, probe: probe, setSpeed: setSpeed,
                         runs: runs, state: state};

  setSpeed(DATA.speed);
  if (hash.speed) setSpeed(parseFloat(hash.speed));
  if (hash.ghosts) $("ghosts").checked = true;
  if (hash.act) $("act").checked = true;
  if (hash.t) seek(parseFloat(hash.t)); else draw();
  // #keys=ArrowRight,shift+ArrowLeft,...: key presses replayed through the page's handler.
  if (hash.keys) decodeURIComponent(hash.keys).split(",").forEach(function (key) {
    var shift = key.indexOf("shift+") === 0;
    document.dispatchEvent(new KeyboardEvent("keydown", {key: shift ? key.slice(6) : key,
                                                         shiftKey: shift, bubbles: true}));
  });
  if (hash.keys) draw();
  if (hash.play) toggle();
  document.documentElement.setAttribute("data-ready", "1");
})();
