/* spinemesh preview player: the original and the upgraded skeleton side by side, one time line.
 *
 * Data comes from scripts beside the page (file:// pages may load <script src>, not fetch):
 * SM.model(id, model) once per skeleton, SM.frames(key, frames) per animation and skin, loaded
 * when chosen. Each frame lists the attachments drawn (table index, alpha, blend, tint: the light
 * colour's 24 bits plus the dark colour's times 2^24 where a slot has one, or -1 - k for the k-th
 * of the side's "tints", colours that overshoot 0..1 listed as numbers, clipping)
 * and their vertices, 16-bit over the animation's bounds. Drawing: textured triangles on a 2D
 * canvas, each an affine map of its image clipped to the triangle (one clip and one draw when a
 * whole attachment is one affine map of its image, as a region or an unbent mesh is: no seams).
 * An attachment a clipping attachment clips is drawn inside that polygon (a canvas clip path:
 * the area the runtimes keep when they cut its triangles by the polygon).
 *
 * Page options in its #hash: play=A (start animation A playing); skin=S (the skin S offered);
 * wire=1, bones=1 (the toggles on). Test hooks: test=S (play S
 * seconds of page time, then write times and canvas checksums to <pre id="sm-test">);
 * at=A,T[,x,y,w,h,ppu] (animation A paused at T seconds, drawn in that world frame at ppu pixels
 * per unit; both canvases then written as PNG data to <pre id="sm-test">, with the window's size
 * and where on the page the upgraded canvas's figure starts and ends). A frame whose canvas would
 * pass MAX_VIEW_SIDE pixels a side or MAX_VIEW_AREA in all is left out (the page fits the pose).
 */
(function () {
  "use strict";
  var SM = window.SM = window.SM || {};
  var frames = {}, waiting = {};
  var BLEND = ["source-over", "lighter", "multiply", "screen"];

  /* The frames kept: those of the HELD animations shown last (the latest last). An animation's
   * frames take up to 4 MB of script; a page shown each of 200 animations in turn held them all,
   * and one shown again after HELD others is read again from its file. */
  var HELD = 12, held = [];

  function hold(key) {
    var at = held.indexOf(key);
    if (at >= 0) held.splice(at, 1);
    held.push(key);
    while (held.length > HELD) delete frames[held.shift()];
  }

  SM.frames = function (key, data) {
    frames[key] = data;
    hold(key);
    (waiting[key] || []).forEach(function (f) { f(data); });
    delete waiting[key];
  };

  function load(key, src, done, fail) {
    if (frames[key]) { hold(key); done(frames[key]); return; }
    if (waiting[key]) { waiting[key].push(done); return; }
    waiting[key] = [done];
    var s = document.createElement("script");
    s.src = src;
    s.onload = function () { s.remove(); }; /* run: the page needs it no more */
    s.onerror = function () { s.remove(); delete waiting[key]; fail(src); };
    document.head.appendChild(s);
  }

  function u16(b64) {
    var bin = atob(b64), n = bin.length >> 1, out = new Uint16Array(n);
    for (var i = 0; i < n; i++) out[i] = bin.charCodeAt(2 * i) | (bin.charCodeAt(2 * i + 1) << 8);
    return out;
  }

  function el(tag, attrs, parent, text) {
    var e = document.createElement(tag);
    for (var k in attrs) e.setAttribute(k, attrs[k]);
    if (text !== undefined) e.textContent = text;
    if (parent) parent.appendChild(e);
    return e;
  }

  /* The page's #hash options. An address is typed, cut short or pasted by hand: an option the
   * page cannot read (a broken %-escape, which decodeURIComponent throws on) is left out, and the
   * page opens as it would without it. */
  function hashParams() {
    var out = Object.create(null);
    location.hash.replace(/^#/, "").split("&").forEach(function (kv) {
      var i = kv.indexOf("=");
      if (i <= 0) return;
      try { out[kv.slice(0, i)] = decodeURIComponent(kv.slice(i + 1)); } catch (e) { /* URIError: left out */ }
    });
    return out;
  }

  /* The largest still frame an address may ask for (at=): the harness renders at most 8192 pixels
   * a side; a link asking 16,000 x 16,000 made the page take 30 s and 5 GB for its two canvases. */
  var MAX_VIEW_SIDE = 8192, MAX_VIEW_AREA = 4096 * 4096;

  /* An option's choice among count (an animation, a skin): the first (0) unless it names one. */
  function choice(text, count) {
    var i = Number(text);
    return Math.floor(i) === i && i >= 0 && i < count ? i : 0;
  }

  /* An animation list this long gets a box to find one by a part of its name (a native list finds
   * only by the first letters typed). */
  var FIND_FROM = 12;

  /* A name as a list shows it: at most LABEL_CHARS characters (whole code points), its end cut to
   * an ellipsis, the whole name in the option's title; a name of thousands of characters made the
   * list, and the page with it, tens of thousands of pixels wide. */
  var LABEL_CHARS = 60;
  function label(name) {
    var chars = Array.from(String(name));
    return chars.length > LABEL_CHARS ? chars.slice(0, LABEL_CHARS - 1).join("") + "…" : chars.join("");
  }

  /* Only the options of list whose item's name holds text (any case) shown, their count said in
   * found; the option chosen, when hidden so, gives way to the first shown (chosen: the list
   * shows, and the canvases draw, the same animation). */
  function filter(list, items, text, found) {
    var q = text.toLowerCase(), first = -1, shown = 0;
    items.forEach(function (item, i) {
      var hit = item.name.toLowerCase().indexOf(q) >= 0;
      list.options[i].hidden = !hit;
      if (hit) { shown++; if (first < 0) first = i; }
    });
    found.textContent = q ? shown + " of " + items.length : "";
    if (first >= 0 && list.options[list.selectedIndex].hidden) {
      list.value = first;
      list.onchange();
    }
  }

  /* One side's frames, decoded: per frame the start of its draw list and of its vertices. */
  function decodeSide(side, table) {
    var xy = u16(side.xy), d = side.draws, starts = [], p = 0, v = 0;
    while (p < d.length) {
      starts.push([p, v]);
      var n = d[p++];
      for (var i = 0; i < n; i++) { v += table[d[p]].uv.length + (d[p + 4] > 0 ? 2 * d[p + 4] : 0); p += 5; }
    }
    return { draws: d, xy: xy, starts: starts, tints: side.tints || [] };
  }

  /* The pixels of images tinted in one page (tinted()), and the SVG filters of two-colour tints. */
  var MAX_TINT_PIXELS = 64 * 1024 * 1024, SVGNS = "http://www.w3.org/2000/svg", filters = null, filterCount = 0;

  /* A tint's light and dark colours, three numbers each, and what multiplies the texels' alpha:
   * 0..1 from their 24 bits (alpha 1, the draw's alpha doing the rest), or as a side's "tints"
   * list them where one overshoots 0..1 (an array: the light colour's r, g, b, the dark colour's,
   * the alpha). A light colour alone has a dark colour of 0. */
  function tintColours(light, dark) {
    if (typeof light !== "number") return [light.slice(0, 3), light.slice(3, 6), light[6]];
    var l = [], dk = [];
    for (var k = 0; k < 3; k++) {
      var shift = 16 - 8 * k;
      l.push((light >> shift & 255) / 255);
      dk.push((dark >> shift & 255) / 255);
    }
    return [l, dk, 1];
  }

  /* The image drawn on x as the runtimes' two-colour tint draws it (spine-webgl's two-colour
   * shader, straight alpha): each texel's colour c becomes dark + c * (light - dark), its alpha
   * kept. An SVG colour matrix as the canvas's filter: it works on straight colour, and, unlike
   * reading the pixels back, on a page opened from disk, whose images a browser will not let a
   * script read. Its coefficients may be any number and only its output is clamped to 0..1, as
   * the shader's: a colour that overshoots 0..1 (4.0 to 4.2 leave a Bezier's overshoot) is passed
   * as it is. A light colour alone is dark 0. False where the browser has no canvas filters. */
  function twoColour(x, im, light, dark) {
    if (typeof x.filter !== "string") return false;
    if (!filters) {
      var svg = document.createElementNS(SVGNS, "svg");
      svg.setAttribute("width", "0"); svg.setAttribute("height", "0");
      svg.setAttribute("style", "position:absolute;width:0;height:0");
      svg.setAttribute("aria-hidden", "true");
      filters = document.createElementNS(SVGNS, "defs");
      svg.appendChild(filters);
      document.body.appendChild(svg);
    }
    var rows = [], c = tintColours(light, dark);
    for (var k = 0; k < 3; k++) {
      var row = [0, 0, 0, 0, c[1][k]];
      row[k] = c[0][k] - c[1][k];
      rows.push(row.join(" "));
    }
    rows.push("0 0 0 " + c[2] + " 0");
    var f = document.createElementNS(SVGNS, "filter"), m = document.createElementNS(SVGNS, "feColorMatrix");
    var id = "sm-two-colour-" + (++filterCount);
    f.setAttribute("id", id);
    f.setAttribute("color-interpolation-filters", "sRGB"); /* the colours as stored, as the shader reads them */
    m.setAttribute("type", "matrix");
    m.setAttribute("values", rows.join(" "));
    f.appendChild(m);
    filters.appendChild(f);
    x.filter = "url(#" + id + ")";
    if (x.filter === "none") return false;
    x.drawImage(im, 0, 0);
    x.filter = "none";
    return true;
  }

  function affine(s, d) { /* s, d: [x0,y0,x1,y1,x2,y2]; returns [a,b,c,e,f,...] as canvas setTransform args */
    var u1 = s[2] - s[0], v1 = s[3] - s[1], u2 = s[4] - s[0], v2 = s[5] - s[1];
    var det = u1 * v2 - u2 * v1;
    if (Math.abs(det) < 1e-9) return null;
    var x1 = d[2] - d[0], y1 = d[3] - d[1], x2 = d[4] - d[0], y2 = d[5] - d[1];
    var a = (x1 * v2 - x2 * v1) / det, c = (x2 * u1 - x1 * u2) / det;
    var b = (y1 * v2 - y2 * v1) / det, dd = (y2 * u1 - y1 * u2) / det;
    return [a, b, c, dd, d[0] - a * s[0] - c * s[1], d[1] - b * s[0] - dd * s[1]];
  }

  SM.model = function (id, model) {
    var root = document.getElementById("player-" + id);
    if (!root) return;
    var P = { id: id, model: model, anim: 0, skin: 0, t: 0, playing: false, speed: 1, data: null,
              images: [], wire: false, bones: false, view: null, last: null };
    var bar = el("div", { "class": "controls" }, root);
    var find = model.anims.length >= FIND_FROM ?
      el("input", { type: "search", placeholder: "find an animation", "aria-label": "find an animation", size: 18 }, bar) : null;
    var animSel = el("select", { "aria-label": "animation" }, bar);
    model.anims.forEach(function (a, i) { el("option", { value: i, title: a.name }, animSel, label(a.name) + " (" + a.dur.toFixed(2) + " s)"); });
    var found = el("span", { "class": "found", "aria-live": "polite" }, bar);
    var skinSel = el("select", { "aria-label": "skin" }, bar);
    model.skins.forEach(function (s, i) { el("option", { value: i, title: s }, skinSel, "skin: " + label(s)); });
    var play = el("button", { type: "button" }, bar, "▶ play");
    var scrub = el("input", { type: "range", min: 0, max: 1000, value: 0, "aria-label": "time" }, bar);
    var clock = el("span", { "class": "clock" }, bar, "0.00 s");
    var speedSel = el("select", { "aria-label": "speed" }, bar);
    [0.1, 0.25, 0.5, 1, 2].forEach(function (s) {
      var o = el("option", { value: s }, speedSel, s + "×");
      if (s === 1) o.selected = true;
    });
    var wl = el("label", {}, bar); var wire = el("input", { type: "checkbox" }, wl); wl.appendChild(document.createTextNode(" wireframe"));
    var bl = el("label", {}, bar); var bones = el("input", { type: "checkbox" }, bl); bl.appendChild(document.createTextNode(" vertices by bone"));
    var stage = el("div", { "class": "stage" }, root);
    var sides = ["before", "after"].map(function (name) {
      var fig = el("figure", {}, stage);
      var c = el("canvas", { width: 460, height: 460, "class": "checker" }, fig);
      el("figcaption", {}, fig, name === "before" ? "original" : "upgraded");
      return { name: name, canvas: c, ctx: c.getContext("2d") };
    });
    var status = el("div", { "class": "status" }, root);
    P.images = model.images.map(function () { return null; });

    function image(i) {
      if (i === null || i === undefined) return null;
      if (!P.images[i]) {
        var im = new Image();
        im.onload = function () { draw(); };
        im.src = model.images[i];
        P.images[i] = im;
      }
      return P.images[i].complete && P.images[i].naturalWidth ? P.images[i] : null;
    }

    /* The image as a tint draws it, its alpha kept: multiplied by the light colour (24-bit RGB), or
     * with a dark colour (two-colour tint; 0: none), as the runtimes' two-colour shader draws it
     * (twoColour). Kept for reuse: a few hundred at most, MAX_TINT_PIXELS pixels in all (a dark
     * colour keyed over time makes one per frame). */
    var tints = {}, tintCount = 0, tintPixels = 0;
    function tinted(i, rgb, dark) {
      var im = image(i);
      if (!im || (rgb === 0xffffff && !dark)) return im;
      var key = i + ":" + rgb + ":" + dark;
      if (!tints[key]) {
        var area = im.naturalWidth * im.naturalHeight;
        if (++tintCount > 300 || tintPixels + area > MAX_TINT_PIXELS) {
          tints = {}; tintCount = 1; tintPixels = 0;
          while (filters && filters.firstChild) filters.removeChild(filters.firstChild);
        }
        tintPixels += area;
        var c = document.createElement("canvas"), x = c.getContext("2d");
        c.width = im.naturalWidth; c.height = im.naturalHeight;
        /* The shader's formula through a colour matrix, exact on half-transparent texels too (a
         * dark colour 0 is the light colour alone); compositing is the fallback where a browser has
         * no canvas filters (multiply then the image's alpha: edges a little towards the colour). */
        if (twoColour(x, im, rgb, dark || 0)) return (tints[key] = c);
        x.drawImage(im, 0, 0);
        x.globalCompositeOperation = "multiply";
        var l = tintColours(rgb, 0)[0];
        x.fillStyle = "rgb(" + l.map(function (v) { return Math.round(255 * Math.min(Math.max(v, 0), 1)); }).join(",") + ")";
        x.fillRect(0, 0, c.width, c.height);
        x.globalCompositeOperation = "destination-in";
        x.drawImage(im, 0, 0);
        tints[key] = c;
      }
      return tints[key];
    }

    function choose() {
      /* a.src: the animation's script per skin, by the skin's place in model.skins (null where
       * it was not sampled in that skin) */
      var a = model.anims[P.anim], own = a.src[P.skin];
      var src = own || a.src[0];
      var key = id + "/" + P.anim + "/" + (own ? P.skin : 0);
      status.textContent = "loading " + a.name + " …";
      P.wanted = key;
      load(key, src, function (data) {
        /* chosen again while this loaded (a keyboard's arrows choose at every press): the frames
         * drawn are those of the last choice, never of a script that came in after it */
        if (P.wanted !== key) return;
        if (!data.decoded) {
          data.decoded = {
            before: decodeSide(data.before, model.sides.before),
            after: decodeSide(data.after, model.sides.after)
          };
          data.before.xy = data.after.xy = null; /* decoded: their text (base64, a third more) is not needed */
        }
        P.data = data;
        status.textContent = (own ? "" : "Drawn in the skin " + model.skins[0] + ": to keep the preview " +
                              "small, this animation was sampled in that skin only (the setup pose shows every skin). ") +
                             (data.note || "");
        resize();
        draw();
        run();
      }, function (s) { if (P.wanted === key) status.textContent = "could not load " + s; });
    }

    /* The pixels the skeleton's larger side takes on each canvas: the two side by side fill the
     * window's width, and one is at most 80% of its height and ends above the window's bottom
     * edge, caption included, where the page opens (240 to 900: readable on a laptop, not a
     * wall on a large screen). */
    function fit() {
      var w = (window.innerWidth || 800) - 80, h = (window.innerHeight || 600) * 0.8;
      var below = (window.innerHeight || 600) - (stage.getBoundingClientRect().top + window.scrollY) - 44; /* its margin, caption */
      return Math.round(Math.max(240, Math.min(900, w / 2 - 36, h, below)));
    }

    /* Measured when the canvases are sized, not at every frame drawn (reading the page's layout
     * while the clock's text changes would lay the page out again each frame). */
    var fitted = 240;

    function resize() {
      var b = P.data.box, v = P.view;
      fitted = fit();
      sides.forEach(function (s) {
        var w, h;
        if (v) { w = Math.max(1, Math.round(v[2] * v[4])); h = Math.max(1, Math.round(v[3] * v[4])); }
        else {
          var k = Math.min(fitted / (b[2] - b[0]), fitted / (b[3] - b[1]));
          w = Math.max(40, Math.round((b[2] - b[0]) * k) + 20); h = Math.max(40, Math.round((b[3] - b[1]) * k) + 20);
        }
        s.canvas.width = w; s.canvas.height = h;
      });
    }

    /* world = box0 + q / 65535 * span; canvas = (world - frame origin) * scale, y flipped */
    function mapping() {
      var b = P.data.box, sx = (b[2] - b[0]) / 65535, sy = (b[3] - b[1]) / 65535, k, ox, oy;
      if (P.view) { var v = P.view; k = v[4]; ox = -v[0] * k; oy = (v[1] + v[3]) * k; }
      else { k = Math.min(fitted / (b[2] - b[0]), fitted / (b[3] - b[1])); ox = 10 - b[0] * k; oy = 10 + b[3] * k; }
      return function (qx, qy) { return [ox + (b[0] + qx * sx) * k, oy - (b[1] + qy * sy) * k]; };
    }

    function frameIndex() {
      var n = P.data.n; /* frame i is the pose at i / fps seconds */
      return Math.min(n - 1, Math.max(0, Math.floor(P.t * P.data.fps + 1e-6))) || 0;
    }

    function drawSide(s, side, table, f, map) {
      var ctx = s.ctx, d = side.draws, p = side.starts[f][0], v = side.starts[f][1], xy = side.xy;
      ctx.setTransform(1, 0, 0, 1, 0, 0);
      ctx.clearRect(0, 0, s.canvas.width, s.canvas.height);
      var n = d[p++], lines = [], dots = [], clip = null;
      for (var i = 0; i < n; i++) {
        var row = table[d[p]], alpha = d[p + 1] / 255, blend = d[p + 2], tint = d[p + 3] % 16777216,
            dark = Math.floor(d[p + 3] / 16777216), cl = d[p + 4];
        if (d[p + 3] < 0) { tint = side.tints[-1 - d[p + 3]]; dark = 0; } /* overshooting 0..1: as listed */
        p += 5;
        if (cl === 0) clip = null;
        else if (cl > 0) { /* a new clipping polygon: its vertices come first */
          clip = new Array(2 * cl);
          for (var j = 0; j < cl; j++) {
            var cp = map(xy[v + 2 * j], xy[v + 2 * j + 1]);
            clip[2 * j] = cp[0]; clip[2 * j + 1] = cp[1];
          }
          v += 2 * cl;
        }
        var nv = row.uv.length / 2, pts = new Array(2 * nv);
        for (var j = 0; j < nv; j++) {
          var c = map(xy[v + 2 * j], xy[v + 2 * j + 1]);
          pts[2 * j] = c[0]; pts[2 * j + 1] = c[1];
        }
        v += 2 * nv;
        var im = tinted(row.img, tint, dark);
        ctx.globalAlpha = alpha;
        ctx.globalCompositeOperation = BLEND[blend] || "source-over";
        if (im && clip) {
          ctx.save();
          ctx.setTransform(1, 0, 0, 1, 0, 0);
          ctx.beginPath();
          ctx.moveTo(clip[0], clip[1]);
          for (j = 2; j < clip.length; j += 2) ctx.lineTo(clip[j], clip[j + 1]);
          ctx.closePath();
          ctx.clip();
          drawTextured(ctx, im, row, pts);
          ctx.restore();
        } else if (im) drawTextured(ctx, im, row, pts);
        if (s.name === "after" && P.wire) lines.push([row, pts]);
        if (s.name === "after" && P.bones) dots.push([row, pts]);
      }
      ctx.globalAlpha = 1;
      ctx.globalCompositeOperation = "source-over";
      ctx.setTransform(1, 0, 0, 1, 0, 0);
      lines.forEach(function (lp) {
        var row = lp[0], q = lp[1], t = row.t;
        ctx.strokeStyle = row.mesh ? "rgba(224,88,43,.85)" : "rgba(200,0,0,.8)";
        ctx.lineWidth = 1;
        ctx.beginPath();
        for (var k = 0; k < t.length; k += 3) {
          ctx.moveTo(q[2 * t[k]], q[2 * t[k] + 1]); ctx.lineTo(q[2 * t[k + 1]], q[2 * t[k + 1] + 1]);
          ctx.lineTo(q[2 * t[k + 2]], q[2 * t[k + 2] + 1]); ctx.closePath();
        }
        ctx.stroke();
      });
      dots.forEach(function (dp) {
        var row = dp[0], q = dp[1];
        for (var k = 0; k < q.length / 2; k++) {
          ctx.fillStyle = "#" + row.c.substr(6 * k, 6);
          ctx.beginPath(); ctx.arc(q[2 * k], q[2 * k + 1], 3, 0, 6.2832); ctx.fill();
          ctx.strokeStyle = "#000"; ctx.lineWidth = 0.7; ctx.stroke();
        }
      });
    }

    function drawTextured(ctx, im, row, pts) {
      var W = im.naturalWidth || im.width, H = im.naturalHeight || im.height, uv = row.uv, t = row.t;
      var src = new Array(uv.length);
      for (var i = 0; i < uv.length; i += 2) { src[i] = uv[i] * W; src[i + 1] = uv[i + 1] * H; }
      /* one affine map for the whole attachment? */
      var m = null;
      for (var k = 0; k < t.length && !m; k += 3) {
        m = affine([src[2 * t[k]], src[2 * t[k] + 1], src[2 * t[k + 1]], src[2 * t[k + 1] + 1], src[2 * t[k + 2]], src[2 * t[k + 2] + 1]],
                   [pts[2 * t[k]], pts[2 * t[k] + 1], pts[2 * t[k + 1]], pts[2 * t[k + 1] + 1], pts[2 * t[k + 2]], pts[2 * t[k + 2] + 1]]);
      }
      if (!m) return;
      var rigid = true;
      for (i = 0; i < pts.length && rigid; i += 2) {
        var x = m[0] * src[i] + m[2] * src[i + 1] + m[4], y = m[1] * src[i] + m[3] * src[i + 1] + m[5];
        rigid = Math.abs(x - pts[i]) < 0.25 && Math.abs(y - pts[i + 1]) < 0.25;
      }
      if (rigid) {
        ctx.save();
        ctx.setTransform(1, 0, 0, 1, 0, 0);
        ctx.beginPath();
        for (k = 0; k < t.length; k += 3) tri(ctx, pts, t[k], t[k + 1], t[k + 2], 0);
        ctx.clip();
        ctx.setTransform(m[0], m[1], m[2], m[3], m[4], m[5]);
        ctx.drawImage(im, 0, 0);
        ctx.restore();
        return;
      }
      for (k = 0; k < t.length; k += 3) {
        var a = t[k], b = t[k + 1], c = t[k + 2];
        var mm = affine([src[2 * a], src[2 * a + 1], src[2 * b], src[2 * b + 1], src[2 * c], src[2 * c + 1]],
                        [pts[2 * a], pts[2 * a + 1], pts[2 * b], pts[2 * b + 1], pts[2 * c], pts[2 * c + 1]]);
        if (!mm) continue;
        ctx.save();
        ctx.setTransform(1, 0, 0, 1, 0, 0);
        ctx.beginPath();
        tri(ctx, pts, a, b, c, 0.5); /* grown a little so that neighbours leave no seam */
        ctx.clip();
        ctx.setTransform(mm[0], mm[1], mm[2], mm[3], mm[4], mm[5]);
        ctx.drawImage(im, 0, 0);
        ctx.restore();
      }
    }

    /* The triangle a, b, c of the points q, each edge moved out by grow pixels (its corners cut
     * square: a bevel, so that a sliver's sharp corner does not spike out). Neighbours then
     * overlap where both are drawn, so the canvas's anti-aliased clip edges, each leaving a
     * half-covered pixel, leave no light seam between them. */
    function tri(ctx, q, a, b, c, grow) {
      var p = [q[2 * a], q[2 * a + 1], q[2 * b], q[2 * b + 1], q[2 * c], q[2 * c + 1]];
      var turn = (p[2] - p[0]) * (p[5] - p[1]) - (p[4] - p[0]) * (p[3] - p[1]);
      if (!(grow > 0) || turn === 0) {
        ctx.moveTo(p[0], p[1]); ctx.lineTo(p[2], p[3]); ctx.lineTo(p[4], p[5]); ctx.closePath();
        return;
      }
      var side = turn > 0 ? 1 : -1, out = []; /* the outward normal of edge i -> i+1, grow long */
      for (var e = 0; e < 3; e++) {
        var dx = p[(2 * e + 2) % 6] - p[2 * e], dy = p[(2 * e + 3) % 6] - p[2 * e + 1], l = Math.hypot(dx, dy) || 1;
        out.push([side * dy / l * grow, -side * dx / l * grow]);
      }
      for (var v = 0; v < 3; v++) { /* corner v: moved out along the edge before it, then the one after */
        var x = p[2 * v], y = p[2 * v + 1], before = out[(v + 2) % 3], after = out[v];
        if (v === 0) ctx.moveTo(x + before[0], y + before[1]); else ctx.lineTo(x + before[0], y + before[1]);
        ctx.lineTo(x + after[0], y + after[1]);
      }
      ctx.closePath();
    }

    /* The frame and the frames drawn last: a tick draws again only when the picture changes (a
     * page left playing a still pose, or a slow animation between its frames, redraws nothing). */
    var drawn = { frame: -1, data: null };

    function draw() {
      if (!P.data) return;
      var f = frameIndex(), map = mapping();
      drawSide(sides[0], P.data.decoded.before, model.sides.before, f, map);
      drawSide(sides[1], P.data.decoded.after, model.sides.after, f, map);
      drawn.frame = f; drawn.data = P.data;
      showTime(performance.now());
    }

    /* The clock and the time line: at every frame drawn and, between frames far apart, every
     * CLOCK_MS (an hour sampled every 12 s shows its time moving, not 12 s frozen). */
    var CLOCK_MS = 250, timeShown = -Infinity;

    function showTime(now) {
      clock.textContent = P.t.toFixed(2) + " / " + P.data.dur.toFixed(2) + " s";
      scrub.value = P.data.dur > 0 ? Math.round(P.t / P.data.dur * 1000) : 0;
      timeShown = now;
    }

    /* The one tick asked for, [0, animation frame] or [1, timer], or null: one loop at most,
     * and none while nothing can move (paused, waiting for its frames, or a still: the setup
     * pose, an animation of 0 s). Between frames far apart (an animation sampled sparsely, a slow
     * speed) it sleeps on a timer until the next one is due, not waking at every screen frame. */
    var pending = null;

    /* The time played from the last tick to now, at the speed in effect (a clock a frame behind
     * another plays nothing backwards). */
    function advance(now) {
      if (P.last !== null) {
        P.t += Math.max(0, now - P.last) / 1000 * P.speed;
        P.t = P.data.dur > 0 ? P.t % P.data.dur : 0;
      }
      P.last = now;
    }

    function tick(now) {
      pending = null;
      if (!P.playing || !P.data || P.data.n < 2) { P.last = null; return; }
      var moved = P.last !== null;
      advance(now);
      if (moved && (frameIndex() !== drawn.frame || P.data !== drawn.data)) draw();
      else if (moved && now - timeShown >= CLOCK_MS) showTime(now);
      var due = Math.min((Math.min((frameIndex() + 1) / P.data.fps, P.data.dur) - P.t) / P.speed * 1000, CLOCK_MS);
      pending = due > 100 ? [1, setTimeout(function () { pending = [0, requestAnimationFrame(tick)]; }, due - 50)]
                          : [0, requestAnimationFrame(tick)];
    }

    function stop() {
      if (pending) (pending[0] ? clearTimeout : cancelAnimationFrame)(pending[1]);
      pending = null;
    }

    /* (Re)starts the loop: at once, whatever it slept for (a new animation, a new speed). */
    function run() {
      stop();
      if (P.playing) pending = [0, requestAnimationFrame(tick)];
    }

    function setPlaying(on) {
      P.playing = on;
      P.last = null; /* the time paused is not played */
      play.textContent = on ? "❚❚ pause" : "▶ play";
      run();
    }

    play.onclick = function () { setPlaying(!P.playing); };
    /* The loop may sleep seconds between frames far apart: a time set, a speed or an animation
     * chosen, while it sleeps restarts it from that moment (the time slept before a scrub or a
     * choice was added to the time set, and the time slept before a new speed was played at the
     * new speed). */
    scrub.oninput = function () {
      if (P.data) { P.t = scrub.value / 1000 * P.data.dur; P.last = null; draw(); run(); }
    };
    speedSel.onchange = function () {
      if (P.playing && P.data && P.data.n > 1) advance(performance.now());
      P.speed = parseFloat(speedSel.value);
      run();
    };
    animSel.onchange = function () { P.anim = +animSel.value; P.t = 0; P.last = null; choose(); };
    if (find) {
      find.oninput = function () { filter(animSel, model.anims, find.value, found); };
      find.onkeydown = function (e) { if (e.key === "Enter") animSel.focus(); }; /* then the arrows go through the matches */
    }
    skinSel.onchange = function () { P.skin = +skinSel.value; choose(); };
    wire.onchange = function () { P.wire = wire.checked; draw(); };
    bones.onchange = function () { P.bones = bones.checked; draw(); };
    window.addEventListener("resize", function () { if (P.data && !P.view) { resize(); draw(); } });
    P.draw = draw; P.setPlaying = setPlaying; P.choose = choose;
    SM.players = SM.players || {};
    SM.players[id] = P;

    var h = hashParams();
    if (h.skin !== undefined) { P.skin = choice(h.skin, model.skins.length); skinSel.value = P.skin; }
    if (h.wire) { wire.checked = P.wire = true; }
    if (h.bones) { bones.checked = P.bones = true; }
    if (h.play !== undefined) { P.anim = choice(h.play, model.anims.length); animSel.value = P.anim; }
    if (h.at !== undefined) {
      var at = h.at.split(",").map(Number);
      P.anim = choice(at[0], model.anims.length); animSel.value = P.anim;
      P.t = isFinite(at[1]) && at[1] >= 0 ? at[1] : 0;
      var view = at.slice(2, 7);
      var side = [view[2] * view[4], view[3] * view[4]];
      if (view.length === 5 && view.every(isFinite) && view[2] > 0 && view[3] > 0 && view[4] > 0 &&
          Math.max(side[0], side[1]) <= MAX_VIEW_SIDE && side[0] * side[1] <= MAX_VIEW_AREA) P.view = view;
    }
    choose();
    if (h.play !== undefined || h.test !== undefined) setPlaying(true);
    if (h.test !== undefined || h.at !== undefined) selftest(P, sides, +(h.test || 0), h.at !== undefined);
  };

  function frameOf(P) { return Math.min(P.data.n - 1, Math.floor(P.t * P.data.fps + 1e-6)); }

  function checksum(canvas) {
    var px = canvas.getContext("2d").getImageData(0, 0, canvas.width, canvas.height).data, s = 0;
    for (var i = 0; i < px.length; i++) s = (s * 31 + px[i]) % 1000000007; /* every byte: a small move shows */
    return s;
  }

  function selftest(P, sides, seconds, still) {
    var out = document.getElementById("sm-test") || el("pre", { id: "sm-test" }, document.body);
    var samples = [], started = performance.now();
    function sample() {
      if (!P.data) { setTimeout(sample, 50); return; }
      if (still) {
        P.draw();
        var pending = P.model.images.filter(function (_, i) { return P.images[i] && !(P.images[i].complete); });
        if (pending.length) { setTimeout(sample, 50); return; }
        P.draw();
        var box = sides[1].canvas.parentNode.getBoundingClientRect();
        out.textContent = JSON.stringify({ t: P.t, frame: frameOf(P),
          before: sides[0].canvas.toDataURL("image/png"), after: sides[1].canvas.toDataURL("image/png"),
          window: [window.innerWidth, window.innerHeight], figure: [box.top + window.scrollY, box.bottom + window.scrollY] });
        return;
      }
      samples.push({ t: P.t, before: checksum(sides[0].canvas), after: checksum(sides[1].canvas) });
      if (performance.now() - started < seconds * 1000) setTimeout(sample, 100);
      else out.textContent = JSON.stringify({ anim: P.model.anims[P.anim].name, samples: samples });
    }
    sample();
  }
})();
