-- nz/draw/three.lua - a 3-D scene for a notebook: the HTML of an interactive
-- three.js view of bodies moving (tr:animate{ view = "3d" },
-- nz/presentation/view3d.lua computes what it shows).
--
-- The page holds the motion as data and a small player written here: the
-- bodies as spheres and ellipsoids, their axes, the links, the contacts'
-- points, each body's path, a grid across the up direction; play/pause, a
-- time slider, a drag to turn the view about the up direction and a wheel to
-- zoom.  three.js itself is Debian's libjs-three, never fetched from the
-- network: the notebook server serves it from the kernel spec's folder
-- (`--install-kernel` links it there, as kernelspecs/nzlua/three.min.js),
-- and an exported page opened where libjs-three is installed takes it from
-- /usr/share/javascript.  Where neither answers, or the browser has no
-- WebGL, the page keeps the fallback it starts with (an <img>: the same
-- motion as an animated GIF from a fixed direction) and says why in the
-- root's data-nz-view attribute ("webgl" once the scene is drawn).
local display = require "nz.draw.display"

local M = {}

-- Where three.js is looked for, in order (see above).
M.SERVED = "kernelspecs/nzlua/three.min.js"
M.DEBIAN = "/usr/share/javascript/three/build/three.min.js"

-- The player: `root` is the element with the scene's id, D the data
-- (nz/presentation/view3d.lua's model: width, height, fps, up, center,
-- radius, grid, bodies, contacts, frames).  Only ES5, no module syntax:
-- it runs as the notebook runs a script in an output.
local PLAYER = [=[
(function () {
  var root = document.getElementById(ID);
  if (!root || root.getAttribute("data-nz-view") !== "loading") return;
  var D = DATA;
  var view = root.querySelector(".nzlua-3d-view"), bar = root.querySelector(".nzlua-3d-bar");
  var button = bar.querySelector("button"), slider = bar.querySelector("input"), label = bar.querySelector("span");
  function fallback(why) { root.setAttribute("data-nz-view", "fallback: " + why); bar.style.display = "none"; }
  function places() {
    var list = [], base = document.body && document.body.getAttribute("data-base-url");
    var config = document.getElementById("jupyter-config-data");
    if (base === null && config) { try { base = JSON.parse(config.textContent).baseUrl; } catch (e) { base = null; } }
    if (base) list.push(base.replace(/\/?$/, "/") + SERVED);
    list.push("file://" + DEBIAN);
    return list;
  }
  function load(list, done) {
    if (window.THREE) return done(window.THREE);
    if (!list.length) return fallback("three.js not found (Debian's libjs-three)");
    var url = list.shift();
    if (window.require && window.define && window.define.amd) {
      window.require([url], function (T) { done(T || window.THREE); }, function () { load(list, done); });
      return;
    }
    var s = document.createElement("script");
    s.src = url;
    s.onload = function () { if (window.THREE) done(window.THREE); else load(list, done); };
    s.onerror = function () { load(list, done); };
    document.head.appendChild(s);
  }
  function matrix(T, R) {
    return new T.Matrix4().set(R[0], R[1], R[2], 0, R[3], R[4], R[5], 0, R[6], R[7], R[8], 0, 0, 0, 0, 1);
  }
  function line(T, points, colour) {
    var g = new T.BufferGeometry();
    g.setAttribute("position", new T.BufferAttribute(new Float32Array(points.length * 3), 3));
    var l = new T.Line(g, new T.LineBasicMaterial({ color: colour }));
    l.frustumCulled = false;
    set_line(l, points);
    return l;
  }
  function set_line(l, points) {
    var a = l.geometry.attributes.position;
    for (var k = 0; k < points.length; k++) a.setXYZ(k, points[k][0], points[k][1], points[k][2]);
    a.needsUpdate = true;
  }
  function start(T) {
    var renderer;
    try { renderer = new T.WebGLRenderer({ antialias: true, preserveDrawingBuffer: true }); }
    catch (e) { return fallback("no WebGL in this browser"); }
    renderer.setPixelRatio(window.devicePixelRatio || 1);
    renderer.setSize(D.width, D.height);
    renderer.setClearColor(0xffffff, 1);
    var scene = new T.Scene(), up = new T.Vector3().fromArray(D.up), target = new T.Vector3().fromArray(D.center);
    var camera = new T.PerspectiveCamera(35, D.width / D.height, D.radius / 100, D.radius * 100);
    camera.up.copy(up);
    camera.position.copy(target).add(new T.Vector3().fromArray(D.eye).multiplyScalar(D.radius * 3.2));
    camera.lookAt(target);
    scene.add(new T.AmbientLight(0xffffff, 0.45));
    var light = new T.DirectionalLight(0xffffff, 0.75);
    scene.add(light);
    var grid = new T.GridHelper(D.grid.size, D.grid.divisions, 0x888888, 0xdddddd);
    grid.quaternion.setFromUnitVectors(new T.Vector3(0, 1, 0), up);
    grid.position.fromArray(D.grid.center);
    scene.add(grid);
    var sphere = new T.SphereGeometry(1, 32, 20), groups = [], dots = [], links = null;
    D.bodies.forEach(function (b, k) {
      var g = new T.Group(), mesh = new T.Mesh(sphere, new T.MeshPhongMaterial({ color: b.colour, shininess: 30 }));
      mesh.scale.fromArray(b.semi);
      if (b.principal) mesh.quaternion.setFromRotationMatrix(matrix(T, b.principal));
      g.add(mesh);
      if (b.axes) {
        ["#d62728", "#2ca02c", "#1f77b4"].forEach(function (c, a) {
          var tip = [0, 0, 0]; tip[a] = b.axes;
          g.add(line(T, [[0, 0, 0], tip], c));
        });
      }
      scene.add(g);
      groups.push(g);
      scene.add(line(T, D.frames.map(function (f) { return f.p[k]; }), b.colour));
    });
    if (D.links) {
      links = line(T, [[0, 0, 0]].concat(D.frames[0].p), 0x333333);
      scene.add(links);
      var pivot = new T.Mesh(sphere, new T.MeshPhongMaterial({ color: 0x000000 }));
      pivot.scale.setScalar(D.dot);
      scene.add(pivot);
    }
    D.contacts.forEach(function () {
      var dot = new T.Mesh(sphere, new T.MeshPhongMaterial({ color: 0x222222 }));
      dot.scale.setScalar(D.dot);
      scene.add(dot);
      dots.push(dot);
    });
    var i = 0, playing = D.frames.length > 1, last = null, due = 0;
    function show(n) {
      var f = D.frames[n];
      groups.forEach(function (g, k) {
        g.position.fromArray(f.p[k]);
        if (f.R[k]) g.quaternion.setFromRotationMatrix(matrix(T, f.R[k]));
      });
      if (links) set_line(links, [[0, 0, 0]].concat(f.p));
      dots.forEach(function (dot, j) { dot.visible = !!f.c[j]; if (f.c[j]) dot.position.fromArray(f.c[j]); });
      slider.value = n;
      label.textContent = "t = " + f.t.toFixed(3);
    }
    // a drag turns the view about the target (about `up`, and up and down),
    // the wheel moves closer or away
    var drag = null;
    renderer.domElement.addEventListener("pointerdown", function (e) { drag = [e.clientX, e.clientY]; });
    window.addEventListener("pointerup", function () { drag = null; });
    window.addEventListener("pointermove", function (e) {
      if (!drag) return;
      var offset = camera.position.clone().sub(target), right = new T.Vector3().crossVectors(offset, up).normalize();
      offset.applyAxisAngle(up, -(e.clientX - drag[0]) * 0.01);
      var turned = offset.clone().applyAxisAngle(right, (e.clientY - drag[1]) * 0.01);
      if (Math.abs(turned.clone().normalize().dot(up)) < 0.98) offset = turned;
      camera.position.copy(target).add(offset);
      camera.lookAt(target);
      drag = [e.clientX, e.clientY];
    });
    renderer.domElement.addEventListener("wheel", function (e) {
      e.preventDefault();
      camera.position.sub(target).multiplyScalar(Math.exp(e.deltaY * 0.001)).add(target);
    }, { passive: false });
    button.onclick = function () { playing = !playing; button.textContent = playing ? "pause" : "play"; };
    slider.max = D.frames.length - 1;
    slider.oninput = function () { playing = false; button.textContent = "play"; i = +slider.value; show(i); };
    button.textContent = playing ? "pause" : "play";
    view.querySelector("img").style.display = "none";
    view.appendChild(renderer.domElement);
    show(0);
    function tick(now) {
      if (!document.body.contains(root)) return;      // the output was cleared
      if (playing) {
        due += last === null ? 0 : (now - last) / 1000 * D.fps;
        last = now;
        if (due >= 1) { i = (i + Math.floor(due)) % D.frames.length; due -= Math.floor(due); show(i); }
      } else {
        last = null;
      }
      light.position.copy(camera.position);
      renderer.render(scene, camera);
      root.setAttribute("data-nz-view", "webgl");
      requestAnimationFrame(tick);
    }
    requestAnimationFrame(tick);
  }
  try { load(places(), start); } catch (e) { fallback(String(e)); }
})();
]=]

-- A string as a JavaScript string literal (JSON's escapes).
local function js_string(s)
  return '"' .. s:gsub('[%c"\\<>&]', function(c) return ("\\u%04x"):format(c:byte()) end) .. '"'
end
M.js_string = js_string

-- The scene's HTML: `model` as JSON (model_json, made by the caller), the
-- fallback picture (a GIF's bytes) shown until the scene draws, a title.
local serial = 0
function M.html(model_json, width, height, gif, title)
  serial = serial + 1
  local id = ("nzlua-3d-%d-%d"):format(os.time(), serial)
  local player = PLAYER:gsub("%f[%w]ID%f[^%w]", js_string(id), 1):gsub("%f[%w]SERVED%f[^%w]", js_string(M.SERVED), 1)
    :gsub("%f[%w]DEBIAN%f[^%w]", js_string(M.DEBIAN), 1)
  player = player:gsub("%f[%w]DATA%f[^%w]", function() return model_json end, 1)
  return table.concat({
    ('<div class="nzlua-3d" id="%s" data-nz-view="loading" style="width:%dpx">'):format(id, width),
    ('<div class="nzlua-3d-view" style="width:%dpx;height:%dpx">%s</div>'):format(width, height,
      gif and display.img("image/gif", gif, title) or ""),
    '<div class="nzlua-3d-bar" style="font:13px sans-serif;margin-top:4px">'
      .. '<button type="button" style="width:4.5em">play</button> '
      .. ('<input type="range" min="0" max="0" value="0" step="1" style="width:%dpx;vertical-align:middle"/> ')
        :format(math.max(100, width - 180))
      .. '<span></span></div>',
    "<script>" .. player .. "</script>",
    "</div>" }, "\n")
end

return M
