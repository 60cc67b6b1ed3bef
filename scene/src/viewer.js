// The trajectory player of constraint-verify's viewer (verify/src/viewer.rs).
// Plain 2D canvas: shapes are tessellated once in their body frame; each draw moves
// them to the interpolated pose, projects them with a perspective camera, shades
// every face (Lambert, one directional light plus ambient) and paints them back to
// front (painter's algorithm). Planes are drawn first as a checkered floor, with the
// bodies' shadows cast straight down on the horizontal ones.
// A script error is shown in place of the title (and seen by the browser test).
window.addEventListener("error", function (e) {
  var el = document.getElementById("title");
  if (el) el.textContent = "viewer error: " + e.message;
});
(function () {
  "use strict";
  var D = JSON.parse(document.getElementById("scene-data").textContent);
  var canvas = document.getElementById("view");
  var ctx = canvas.getContext("2d");
  var slider = document.getElementById("slider");
  var playBtn = document.getElementById("play");
  var clock = document.getElementById("clock");
  var T = D.times, N = T.length;
  var SKY = "#e9eef3";
  var FOV = 40 * Math.PI / 180;
  var LIGHT = norm([0.35, -0.45, 1.0]);

  // ---- vectors and quaternions ([w, x, y, z]) ----
  function add(a, b) { return [a[0] + b[0], a[1] + b[1], a[2] + b[2]]; }
  function sub(a, b) { return [a[0] - b[0], a[1] - b[1], a[2] - b[2]]; }
  function scale(a, s) { return [a[0] * s, a[1] * s, a[2] * s]; }
  function dot(a, b) { return a[0] * b[0] + a[1] * b[1] + a[2] * b[2]; }
  function cross(a, b) {
    return [a[1] * b[2] - a[2] * b[1], a[2] * b[0] - a[0] * b[2], a[0] * b[1] - a[1] * b[0]];
  }
  function norm(a) { var l = Math.sqrt(dot(a, a)) || 1; return scale(a, 1 / l); }
  function qnorm(q) {
    var l = Math.sqrt(q[0] * q[0] + q[1] * q[1] + q[2] * q[2] + q[3] * q[3]) || 1;
    return [q[0] / l, q[1] / l, q[2] / l, q[3] / l];
  }
  // v' = v + 2w (u × v) + 2 u × (u × v), u = (x, y, z).
  function qrot(q, v) {
    var u = [q[1], q[2], q[3]];
    var t = scale(cross(u, v), 2);
    return add(add(v, scale(t, q[0])), cross(u, t));
  }

  // ---- tessellation in the shape frame: faces as vertex lists, outward by the
  // right-hand rule ----
  // A surface of revolution about z from rings [radius, z] (bottom to top).
  function lathe(rings, seg, sx, sy) {
    var faces = [];
    for (var i = 0; i + 1 < rings.length; i++) {
      for (var j = 0; j < seg; j++) {
        var a0 = 2 * Math.PI * j / seg, a1 = 2 * Math.PI * (j + 1) / seg;
        var p = function (r, a) { return [sx * r[0] * Math.cos(a), sy * r[0] * Math.sin(a), r[1]]; };
        var lo = rings[i], hi = rings[i + 1], f = [];
        f.push(p(lo, a0));
        if (lo[0] > 0) f.push(p(lo, a1));
        f.push(p(hi, a1));
        if (hi[0] > 0) f.push(p(hi, a0));
        if (f.length >= 3) faces.push(f);
      }
    }
    return faces;
  }
  function sphereRings(r, zlo, zhi, n) {
    var rings = [];
    for (var i = 0; i <= n; i++) {
      var lat = -Math.PI / 2 + Math.PI * i / n;
      var z = r * Math.sin(lat) + (i * 2 < n ? zlo : i * 2 > n ? zhi : 0);
      if (i * 2 === n && zhi !== zlo) {
        rings.push([r, zlo]);
        rings.push([r, zhi]);
      } else {
        rings.push([i === 0 || i === n ? 0 : r * Math.cos(lat), z]);
      }
    }
    return rings;
  }
  // Levels of detail: latitude rings and segments of round shapes, segments of a
  // cylinder; a shape takes a coarser level the smaller it looks on screen.
  var LODS = [[10, 16, 20], [6, 10, 12], [4, 6, 8]];
  function tessellate(shape, size, lod) {
    var L = LODS[lod];
    if (shape === "sphere") return lathe(sphereRings(size[0], 0, 0, L[0]), L[1], 1, 1);
    if (shape === "capsule")
      return lathe(sphereRings(size[0], -size[1], size[1], L[0]), L[1], 1, 1);
    if (shape === "cylinder") {
      var r = size[0], h = size[1];
      return lathe([[0, -h], [r, -h], [r, h], [0, h]], L[2], 1, 1);
    }
    if (shape === "ellipsoid") {
      var faces = lathe(sphereRings(1, 0, 0, L[0]), L[1], size[0], size[1]);
      return faces.map(function (f) { return f.map(function (v) { return [v[0], v[1], v[2] * size[2]]; }); });
    }
    if (shape === "box") {
      var x = size[0], y = size[1], z = size[2], out = [];
      var c = function (i, j, k) { return [i * x, j * y, k * z]; };
      out.push([c(1, -1, -1), c(1, 1, -1), c(1, 1, 1), c(1, -1, 1)]);
      out.push([c(-1, -1, -1), c(-1, -1, 1), c(-1, 1, 1), c(-1, 1, -1)]);
      out.push([c(-1, 1, -1), c(-1, 1, 1), c(1, 1, 1), c(1, 1, -1)]);
      out.push([c(-1, -1, -1), c(1, -1, -1), c(1, -1, 1), c(-1, -1, 1)]);
      out.push([c(-1, -1, 1), c(1, -1, 1), c(1, 1, 1), c(-1, 1, 1)]);
      out.push([c(-1, -1, -1), c(-1, 1, -1), c(1, 1, -1), c(1, -1, -1)]);
      return out;
    }
    return [];
  }
  // Faces of a part in the frame that holds it (body or world).
  function placed(part, lod) {
    var q = qnorm(part.quat);
    return tessellate(part.shape, part.size, lod).map(function (f) {
      return f.map(function (v) { return add(part.pos, qrot(q, v)); });
    });
  }
  function bound(part) {
    var s = part.size;
    if (part.shape === "capsule") return s[0] + s[1];
    if (part.shape === "cylinder") return Math.sqrt(s[0] * s[0] + s[1] * s[1]);
    if (part.shape === "box" || part.shape === "ellipsoid") return Math.sqrt(dot(s, s));
    return s[0];
  }

  var bodies = D.bodies.map(function (b) {
    return b.parts.map(function (p) {
      return { lods: [0, 1, 2].map(function (l) { return placed(p, l); }), pos: p.pos, r: bound(p), rgba: p.rgba };
    });
  });
  var solids = [];
  var planes = [];
  D.statics.forEach(function (p) {
    if (p.shape === "plane") planes.push(p);
    else placed(p, 0).forEach(function (f) { solids.push({ v: f, rgba: p.rgba }); });
  });

  // ---- scene bounds over every frame: the default camera frames them ----
  var lo = [Infinity, Infinity, Infinity], hi = [-Infinity, -Infinity, -Infinity];
  function grow(p, r) {
    for (var d = 0; d < 3; d++) {
      lo[d] = Math.min(lo[d], p[d] - r);
      hi[d] = Math.max(hi[d], p[d] + r);
    }
  }
  for (var k = 0; k < N; k++) {
    var row = D.poses[k];
    D.bodies.forEach(function (b, i) {
      var x = row.slice(7 * i, 7 * i + 3), q = qnorm(row.slice(7 * i + 3, 7 * i + 7));
      b.parts.forEach(function (p) { grow(add(x, qrot(q, p.pos)), bound(p)); });
    });
    (D.verts[k] || []).forEach(function (vs) {
      for (var j = 0; j + 2 < vs.length; j += 3) grow([vs[j], vs[j + 1], vs[j + 2]], 0);
    });
  }
  D.statics.forEach(function (p) { if (p.shape !== "plane") grow(p.pos, bound(p)); });
  if (!(lo[0] <= hi[0])) {
    planes.forEach(function (p) { grow(p.pos, 0.5); });
    if (!(lo[0] <= hi[0])) { lo = [-1, -1, -1]; hi = [1, 1, 1]; }
  }
  var CENTER = scale(add(lo, hi), 0.5);
  var RADIUS = Math.max(0.25, 0.5 * Math.sqrt(dot(sub(hi, lo), sub(hi, lo))));
  // Without a plane, a reference grid (lines only) under the lowest point reached.
  if (planes.length === 0)
    planes.push({ shape: "plane", size: [0, 0, 0], pos: [CENTER[0], CENTER[1], lo[2]],
      quat: [1, 0, 0, 0], rgba: [0.5, 0.5, 0.5, 1], lines: true });

  // ---- camera: orbit about a target, z up ----
  var cam = {};
  function resetCamera() {
    cam.az = -70 * Math.PI / 180;
    cam.el = 20 * Math.PI / 180;
    cam.dist = 0.95 * RADIUS / Math.tan(FOV / 2);
    cam.target = CENTER.slice();
  }
  resetCamera();
  var view = {};
  function setupView(w, h) {
    var ce = Math.cos(cam.el);
    var dir = [ce * Math.cos(cam.az), ce * Math.sin(cam.az), Math.sin(cam.el)];
    view.eye = add(cam.target, scale(dir, cam.dist));
    view.f = scale(dir, -1);
    view.r = norm(cross(view.f, [0, 0, 1]));
    view.u = cross(view.r, view.f);
    view.F = 0.5 * h / Math.tan(FOV / 2);
    view.cx = w / 2;
    view.cy = h / 2;
    view.near = 1e-3 * cam.dist;
  }
  // Screen position and depth of a world point.
  function project(p) {
    var d = sub(p, view.eye), z = dot(d, view.f);
    return [view.cx + view.F * dot(d, view.r) / z, view.cy - view.F * dot(d, view.u) / z, z];
  }

  // ---- the state at time t: poses interpolated between samples ----
  function frameAt(t) {
    var a = 0, b = N - 1;
    if (t <= T[0]) return [0, 0, 0];
    if (t >= T[N - 1]) return [N - 1, N - 1, 0];
    while (b - a > 1) { var m = (a + b) >> 1; if (T[m] <= t) a = m; else b = m; }
    return [a, b, (t - T[a]) / (T[b] - T[a])];
  }
  function poseAt(fr, i) {
    var A = D.poses[fr[0]], B = D.poses[fr[1]], s = fr[2], o = 7 * i;
    var x = [0, 1, 2].map(function (d) { return A[o + d] + s * (B[o + d] - A[o + d]); });
    var qa = A.slice(o + 3, o + 7), qb = B.slice(o + 3, o + 7);
    var sign = qa[0] * qb[0] + qa[1] * qb[1] + qa[2] * qb[2] + qa[3] * qb[3] < 0 ? -1 : 1;
    var q = qnorm([0, 1, 2, 3].map(function (d) { return qa[d] + s * (sign * qb[d] - qa[d]); }));
    return [x, q];
  }

  function rgb(c, k) {
    var f = function (x) { return Math.max(0, Math.min(255, Math.round(255 * x * k))); };
    return "rgb(" + f(c[0]) + "," + f(c[1]) + "," + f(c[2]) + ")";
  }
  function path(g, pts) {
    g.beginPath();
    g.moveTo(pts[0][0], pts[0][1]);
    for (var i = 1; i < pts.length; i++) g.lineTo(pts[i][0], pts[i][1]);
    g.closePath();
  }

  // Checker squares of a plane, centred near the target, in world coordinates.
  function planeTiles(p) {
    var q = qnorm(p.quat), ex = qrot(q, [1, 0, 0]), ey = qrot(q, [0, 1, 0]);
    var ext = Math.max(3 * RADIUS, 1);
    var hx = p.size[0] > 0 ? Math.min(p.size[0], ext) : ext;
    var hy = p.size[1] > 0 ? Math.min(p.size[1], ext) : ext;
    var rel = sub(cam.target, p.pos), cx = dot(rel, ex), cy = dot(rel, ey);
    if (p.size[0] > 0) cx = Math.max(-p.size[0] + hx, Math.min(p.size[0] - hx, cx));
    if (p.size[1] > 0) cy = Math.max(-p.size[1] + hy, Math.min(p.size[1] - hy, cy));
    var g = p.size[2] > 0 ? p.size[2] : 0;
    if (!(g > 0) || Math.max(hx, hy) / g > 20) {
      var raw = Math.max(hx, hy) / 8, e = Math.pow(10, Math.floor(Math.log10(raw)));
      g = raw / e < 2 ? e : raw / e < 5 ? 2 * e : 5 * e;
    }
    var tiles = [];
    var i0 = Math.floor((cx - hx) / g), i1 = Math.ceil((cx + hx) / g);
    var j0 = Math.floor((cy - hy) / g), j1 = Math.ceil((cy + hy) / g);
    for (var i = i0; i < i1; i++) {
      for (var j = j0; j < j1; j++) {
        var x0 = Math.max(i * g, cx - hx), x1 = Math.min((i + 1) * g, cx + hx);
        var y0 = Math.max(j * g, cy - hy), y1 = Math.min((j + 1) * g, cy + hy);
        var at = function (u, v) { return add(p.pos, add(scale(ex, u), scale(ey, v))); };
        tiles.push({ v: [at(x0, y0), at(x1, y0), at(x1, y1), at(x0, y1)], odd: (i + j) & 1 });
      }
    }
    return { tiles: tiles, normal: qrot(q, [0, 0, 1]), pos: p.pos, rgba: p.rgba, lines: !!p.lines };
  }

  var shadowCanvas = document.createElement("canvas");
  var sctx = shadowCanvas.getContext("2d");

  function draw(t) {
    var dpr = window.devicePixelRatio || 1;
    var w = canvas.clientWidth, h = canvas.clientHeight;
    // Not laid out yet (a frame still being placed): nothing to draw; the resize
    // listener or the next animation frame draws it.
    if (!(w >= 1 && h >= 1)) return;
    if (canvas.width !== Math.round(w * dpr) || canvas.height !== Math.round(h * dpr)) {
      canvas.width = Math.round(w * dpr);
      canvas.height = Math.round(h * dpr);
    }
    ctx.setTransform(dpr, 0, 0, dpr, 0, 0);
    ctx.fillStyle = SKY;
    ctx.fillRect(0, 0, w, h);
    setupView(w, h);
    if (N === 0) {
      ctx.fillStyle = "#333";
      ctx.fillText("no samples to show", 20, 40);
      return;
    }
    var fr = frameAt(t);
    // World faces of every body and mesh at t.
    var faces = solids.map(function (f) { return { v: f.v, rgba: f.rgba, two: false }; });
    bodies.forEach(function (parts, i) {
      var pq = poseAt(fr, i), x = pq[0], q = pq[1];
      parts.forEach(function (p) {
        var depth = dot(sub(add(x, qrot(q, p.pos)), view.eye), view.f);
        var px = view.F * p.r / Math.max(depth, view.near);
        p.lods[px > 14 ? 0 : px > 5 ? 1 : 2].forEach(function (f) {
          faces.push({ v: f.map(function (v) { return add(x, qrot(q, v)); }), rgba: p.rgba, two: false });
        });
      });
    });
    D.meshes.forEach(function (m, mi) {
      var A = D.verts[fr[0]][mi], B = D.verts[fr[1]][mi], s = fr[2];
      var P = function (k) {
        return [0, 1, 2].map(function (d) { return A[3 * k + d] + s * (B[3 * k + d] - A[3 * k + d]); });
      };
      for (var j = 0; j + 2 < m.tris.length; j += 3)
        faces.push({ v: [P(m.tris[j]), P(m.tris[j + 1]), P(m.tris[j + 2])], rgba: m.rgba, two: true });
    });
    faces.forEach(function (f) {
      var v = f.v, n = cross(sub(v[1], v[0]), sub(v[2], v[0]));
      if (v.length > 3) n = add(n, cross(sub(v[2], v[0]), sub(v[3], v[0])));
      f.n = norm(n);
    });
    // Planes: checker squares, far to near, then the shadows of the faces on them.
    planes.forEach(function (p) {
      var pl = planeTiles(p);
      if (dot(sub(view.eye, pl.pos), pl.normal) < 0) return;
      var sq = [];
      pl.tiles.forEach(function (tile) {
        var s = tile.v.map(project);
        if (s.some(function (v) { return v[2] < view.near; })) return;
        sq.push({ s: s, z: (s[0][2] + s[2][2]) / 2, odd: tile.odd });
      });
      sq.sort(function (a, b) { return b.z - a.z; });
      sq.forEach(function (tile) {
        path(ctx, tile.s);
        if (pl.lines) {
          ctx.strokeStyle = "#c3cbd4";
          ctx.lineWidth = 1;
          ctx.stroke();
          return;
        }
        ctx.fillStyle = rgb(pl.rgba.map(function (c) { return 0.45 * c + 0.55; }), tile.odd ? 0.95 : 1.0);
        ctx.fill();
        ctx.strokeStyle = ctx.fillStyle;
        ctx.lineWidth = 0.6;
        ctx.stroke();
      });
      if (Math.abs(pl.normal[2]) < 0.9) return;
      if (shadowCanvas.width !== canvas.width || shadowCanvas.height !== canvas.height) {
        shadowCanvas.width = canvas.width;
        shadowCanvas.height = canvas.height;
      }
      sctx.setTransform(1, 0, 0, 1, 0, 0);
      sctx.clearRect(0, 0, shadowCanvas.width, shadowCanvas.height);
      sctx.setTransform(dpr, 0, 0, dpr, 0, 0);
      sctx.fillStyle = "#000";
      sctx.strokeStyle = "#000";
      sctx.lineWidth = 0.8;
      sctx.lineJoin = "round";
      var z0 = pl.pos[2];
      // A closed shape's upward faces cover its whole shadow.
      faces.forEach(function (f) {
        if (!f.two && !(f.n[2] > 0)) return;
        if (f.v.every(function (v) { return v[2] < z0; })) return;
        var s = f.v.map(function (v) { return project([v[0], v[1], z0]); });
        if (s.some(function (v) { return v[2] < view.near; })) return;
        path(sctx, s);
        sctx.fill();
        sctx.stroke();
      });
      ctx.save();
      ctx.setTransform(1, 0, 0, 1, 0, 0);
      ctx.globalAlpha = 0.18;
      ctx.drawImage(shadowCanvas, 0, 0);
      ctx.restore();
    });
    // Solid faces: cull the ones facing away, shade, paint far to near.
    var drawn = [];
    faces.forEach(function (f) {
      var v = f.v, n = f.n, c = [0, 0, 0];
      v.forEach(function (p) { c = add(c, p); });
      c = scale(c, 1 / v.length);
      if (dot(n, sub(view.eye, c)) < 0) {
        if (!f.two) return;
        n = scale(n, -1);
      }
      var s = v.map(project);
      if (s.some(function (p) { return p[2] < view.near; })) return;
      var z = 0;
      s.forEach(function (p) { z += p[2]; });
      var lit = 0.38 + 0.5 * Math.max(0, dot(n, LIGHT)) + 0.17 * Math.max(0, dot(n, scale(view.f, -1)));
      drawn.push({ s: s, z: z / s.length, fill: rgb(f.rgba, lit), a: f.rgba[3] });
    });
    drawn.sort(function (a, b) { return b.z - a.z; });
    ctx.lineJoin = "round";
    drawn.forEach(function (f) {
      ctx.globalAlpha = Math.max(0, Math.min(1, f.a));
      path(ctx, f.s);
      ctx.fillStyle = f.fill;
      ctx.fill();
      ctx.strokeStyle = f.fill;
      ctx.lineWidth = 0.7;
      ctx.stroke();
    });
    ctx.globalAlpha = 1;
  }

  // ---- playback and controls ----
  var t0 = N ? T[0] : 0, t1 = N ? T[N - 1] : 0;
  var state = { t: t0, playing: true, wall: 0, from: t0 };
  function show() {
    draw(state.t);
    slider.value = t1 > t0 ? Math.round(1000 * (state.t - t0) / (t1 - t0)) : 0;
    clock.textContent = "t = " + state.t.toFixed(3) + " s / " + t1.toFixed(3) + " s";
    playBtn.textContent = state.playing ? "Pause" : "Play";
  }
  function tick(now) {
    if (!state.playing) return;
    var t = state.from + (now - state.wall) / 1000;
    if (t > t1) { state.from = t0; state.wall = now; t = t0; }
    state.t = t;
    show();
    window.requestAnimationFrame(tick);
  }
  function play(on) {
    state.playing = on;
    if (on) {
      if (state.t >= t1) state.t = t0;
      state.from = state.t;
      state.wall = performance.now();
      window.requestAnimationFrame(tick);
    }
    show();
  }
  function fromHash() {
    var h = {};
    location.hash.replace(/^#/, "").split("&").forEach(function (kv) {
      var p = kv.split("=");
      if (p.length === 2) h[p[0]] = decodeURIComponent(p[1]);
    });
    var num = function (k) { var v = parseFloat(h[k]); return isFinite(v) ? v : null; };
    if (num("t") !== null) state.t = Math.max(t0, Math.min(t1, num("t")));
    if (num("az") !== null) cam.az = num("az") * Math.PI / 180;
    if (num("el") !== null) cam.el = Math.max(-1.55, Math.min(1.55, num("el") * Math.PI / 180));
    if (num("zoom") !== null && num("zoom") > 0) cam.dist /= num("zoom");
    var paused = h.paused === "1" || h.paused === "true";
    play(!paused);
  }
  playBtn.addEventListener("click", function () { play(!state.playing); });
  slider.addEventListener("input", function () {
    state.playing = false;
    state.t = t0 + (t1 - t0) * slider.value / 1000;
    show();
  });
  var drag = null;
  canvas.addEventListener("pointerdown", function (e) {
    drag = [e.clientX, e.clientY];
    canvas.setPointerCapture(e.pointerId);
  });
  canvas.addEventListener("pointermove", function (e) {
    if (!drag) return;
    cam.az -= 0.008 * (e.clientX - drag[0]);
    cam.el = Math.max(-1.55, Math.min(1.55, cam.el + 0.008 * (e.clientY - drag[1])));
    drag = [e.clientX, e.clientY];
    if (!state.playing) show();
  });
  canvas.addEventListener("pointerup", function () { drag = null; });
  canvas.addEventListener("wheel", function (e) {
    e.preventDefault();
    cam.dist *= Math.exp(0.001 * e.deltaY);
    if (!state.playing) show();
  }, { passive: false });
  canvas.addEventListener("dblclick", function () { resetCamera(); if (!state.playing) show(); });
  window.addEventListener("keydown", function (e) {
    if (e.key === " ") { e.preventDefault(); play(!state.playing); }
  });
  window.addEventListener("resize", function () { if (!state.playing) show(); });
  window.addEventListener("hashchange", fromHash);
  fromHash();
})();
