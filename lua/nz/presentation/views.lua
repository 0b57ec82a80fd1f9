-- nz/presentation/views.lua - two more ways to look at a trajectory:
--   tr:section{...}  a Poincare section: the states where an event of the
--                    run crossed zero (located by simulate, not read off the
--                    output grid), two quantities against each other;
--   tr:animate{...}  the mechanism drawn frame by frame: in the terminal,
--                    or to an animated GIF or SVG frames (gnuplot); with
--                    view = "3d" the bodies in space (nz/presentation/view3d.lua).
local plot = require "nz.draw.plot"

local M = {}

local function fail(fname, fmt, ...)
  error(("%strajectory:%s: " .. fmt):format(require("nz.base.where").user_where(), fname, ...), 0)
end

local function check_options(fname, opts, known)
  require("nz.base.options").check(opts, known, function(...) fail(fname, ...) end)
end

-- A value as the user wrote it, for messages.
local shown = require("nz.base.text").literal   -- an option as written: key = "value"

-- The value of a named quantity at an event's state: a coordinate, or its
-- velocity "name'".
local function value_at(tr, ev, name)
  local base, primes = name:match("^(.-)('*)$")
  for j, c in ipairs(tr.coords) do
    if c == base then
      if #primes == 0 then return ev.q[j] end
      if #primes == 1 then return ev.qd[j] end
    end
  end
  if name == "t" then return ev.t end
  fail("section", "no quantity '%s' at the crossings (coordinates %s, with ' for velocities, and t)", name,
    table.concat(tr.coords, ", "))
end

-- tr:section{ when = "x=0", plot = {"y", "y'"} [, file =, title =, quiet =] }:
-- the crossings of event `when` (its name in simulate's events; default the
-- only one), the two quantities at each; returns {x = {...}, y = {...}, t = {...}}
-- and draws them (draw = false: only returns them; file = ... to an SVG or PNG).
local SECTION = require("nz.base.options").declare("tr:section", { when = true, plot = true, file = true, title = true,
  draw = true, width = true, height = true })
function M.section(tr, opts)
  opts = opts or {}
  check_options("section", opts, SECTION)
  -- (the sizes and the file are plot.lines's to check)
  if opts.when ~= nil and type(opts.when) ~= "string" then fail("section", "when = %s: an event's name (a string) expected", shown(opts.when)) end
  if opts.draw ~= nil and type(opts.draw) ~= "boolean" then fail("section", "draw = %s: true or false expected", shown(opts.draw)) end
  if opts.title ~= nil and type(opts.title) ~= "string" then fail("section", "title = %s: a string expected", shown(opts.title)) end
  local evs = tr.events or {}
  local names, seen = {}, {}
  for _, e in ipairs(evs) do
    if not seen[e.name or ""] then seen[e.name or ""] = true; names[#names + 1] = tostring(e.name) end
  end
  table.sort(names)
  if #evs == 0 then
    fail("section", "the run recorded no event crossing: simulate with events = {{name = 'x=0', f = function(t, q, qd) "
      .. "return q[1] end, direction = 1}} (the section's surface), long enough to cross it")
  end
  local when = opts.when
  if when == nil then
    if #names > 1 then fail("section", "the run has several events (%s): say which with when = \"name\"", table.concat(names, ", ")) end
    when = evs[1].name
  end
  if not seen[when] then fail("section", "no event named '%s' crossed (events: %s)", tostring(when), table.concat(names, ", ")) end
  local pair = opts.plot or { tr.coords[1], tr.coords[1] .. "'" }
  if type(pair) ~= "table" or #pair ~= 2 or type(pair[1]) ~= "string" or type(pair[2]) ~= "string" then
    fail("section", "plot: two quantities' names {\"y\", \"y'\"} expected")
  end
  local out = { x = {}, y = {}, t = {}, names = pair }
  for _, e in ipairs(evs) do
    if e.name == when then
      out.x[#out.x + 1], out.y[#out.y + 1], out.t[#out.t + 1] = value_at(tr, e, pair[1]), value_at(tr, e, pair[2]), e.t
    end
  end
  if opts.draw ~= false then
    plot.lines{ series = { { name = ("%s at %s"):format(pair[2], tostring(when)), x = out.x, y = out.y, style = "points pt 7 ps 0.3" } },
      file = opts.file, title = opts.title or ("Poincare section of %s: %s crossings"):format(tr.system.name, tostring(when)),
      xlabel = pair[1], ylabel = pair[2], width = opts.width, height = opts.height, legend = false }
    -- drawn in the terminal: the session prints nothing more (not the lists)
    if not opts.file then return require("nz.base.frontend").shown(out) end
  end
  return out
end

-- The two axes of the bodies' positions that plane = "xy", "xz", "yz" draws.
local PLANES = { xy = { 1, 2 }, xz = { 1, 3 }, yz = { 2, 3 } }

-- The shapes of the frame at (t, q): points {x, y}, segments {x1, y1,
-- x2, y2} and fixed supports (pivots {x, y}, drawn with a mark of their
-- own) in the plane of the first two coordinates of `plane` (default x,
-- y).  From `draw(t, q)` when given; else from the system's bodies: a
-- point per body and a link from the origin to the first and between
-- successive bodies (a chain, as pendulums are), hung from a pivot at the
-- origin; else refused.
local function shapes_of(tr, opts)
  if opts.draw then return opts.draw end
  local bodies = tr.system.bodies
  if not bodies then
    fail("animate", "the system has no bodies to draw: give draw = function(t, q) return {points = {{x, y}, ...}, "
      .. "segments = {{x1, y1, x2, y2}, ...}} end")
  end
  local axes = PLANES[opts.plane or "xy"]
  return function(t, q)
    local points, segments = {}, {}
    local px, py = 0, 0
    for _, b in ipairs(bodies) do
      local r = b.pos(t, q, tr.system.params)
      local x, y = r[axes[1]], r[axes[2]]
      points[#points + 1] = { x, y, body = b.name }
      if opts.links ~= false then segments[#segments + 1] = { px, py, x, y } end
      px, py = x, y
    end
    return { points = points, segments = segments, pivots = opts.links ~= false and { { 0, 0 } } or nil }
  end
end

local function whole(v, lo, hi) return type(v) == "number" and v == math.floor(v) and v >= lo and v <= hi end
local finite = require("nz.base.args").finite

-- A point or segment as given, for messages.
local function listed(v)
  if type(v) ~= "table" then return tostring(v) end
  local o = {}
  for i = 1, math.max(#v, 2) do o[i] = tostring(v[i]) end
  return "{" .. table.concat(o, ", ") .. "}"
end

-- tr:animate's options, each checked before anything is computed or drawn
-- (gnuplot's own messages about them name its script, not the option).
local function check_animate(tr, opts)
  local function bad(key, want, ...) fail("animate", "%s = %s: " .. want, key, shown(opts[key]), ...) end
  local file = opts.file
  if file ~= nil then
    if type(file) ~= "string" then bad("file", "a file name ending in .gif or .svg expected") end
    local kind = file:match("%.(%w+)$")
    if kind ~= "gif" and kind ~= "svg" then
      fail("animate", "file '%s' must end in .gif (one animated GIF) or .svg (one file per frame); "
        .. "leave file out to draw in the terminal", file)
    end
  end
  if opts.frames ~= nil and not whole(opts.frames, 1, math.huge) then
    bad("frames", "a whole number of frames, 1 or more, expected (at most one per output point: this trajectory has %d)", #tr.t)
  end
  if opts.fps ~= nil and not (finite(opts.fps) and opts.fps > 0 and opts.fps <= 100) then
    bad("fps", "frames per second, a number above 0 and at most 100, expected")
  end
  if opts.draw ~= nil and type(opts.draw) ~= "function" then
    bad("draw", "a function(t, q) returning {points = {{x, y}, ...}, segments = {{x1, y1, x2, y2}, ...}} expected")
  end
  if opts.plane ~= nil and not PLANES[opts.plane] then
    bad("plane", "\"xy\", \"xz\" or \"yz\" expected (the two coordinates of the bodies' positions drawn)")
  end
  if opts.links ~= nil and type(opts.links) ~= "boolean" then
    bad("links", "true (lines from the origin through the bodies in turn, the default) or false expected")
  end
  if opts.view ~= nil and opts.view ~= "2d" and opts.view ~= "3d" then
    bad("view", "\"2d\" (the bodies in a plane, the default) or \"3d\" (in space) expected")
  end
  if opts.view == "3d" then
    for _, key in ipairs{ "draw", "plane", "range" } do
      if opts[key] ~= nil then
        fail("animate", "view = \"3d\" draws the bodies in space, and %s = ... is for a drawing in a plane: give one or the "
          .. "other", key)
      end
    end
    if not tr.system.bodies then
      fail("animate", "view = \"3d\" draws a system's bodies, and this one has none: make it with bodies = {...} "
        .. "(nz.system or nz.scene)")
    end
  end
  if opts.draw and (opts.plane ~= nil or opts.links ~= nil) then
    fail("animate", "%s draws the bodies, and draw = function(t, q) ... replaces them: give one or the other",
      opts.plane ~= nil and "plane" or "links")
  end
  local r = opts.range
  if r ~= nil and not (type(r) == "table" and #r == 4 and finite(r[1]) and finite(r[2]) and finite(r[3])
      and finite(r[4]) and r[1] < r[2] and r[3] < r[4]) then
    fail("animate", "range = %s: {xmin, xmax, ymin, ymax} expected, four numbers with xmin < xmax and ymin < ymax",
      listed(r))
  end
  local min = file and 50 or 20   -- pixels of a file, characters of the terminal
  for _, key in ipairs{ "width", "height" } do
    if opts[key] ~= nil and not whole(opts[key], min, 10000) then
      bad(key, "a whole number from %d to 10000 expected (%s)", min, file and "pixels" or "characters of the terminal")
    end
  end
  if opts.title ~= nil and type(opts.title) ~= "string" then bad("title", "a string expected") end
end

-- The shapes one frame drew, checked: numbers gnuplot cannot place (nil,
-- NaN, infinite) would make it fail with a message about its script.
local function check_shapes(s, t)
  local shape = "{points = {{x, y}, ...}, segments = {{x1, y1, x2, y2}, ...}}"
  if type(s) ~= "table" or (s.points ~= nil and type(s.points) ~= "table")
      or (s.segments ~= nil and type(s.segments) ~= "table") or (s.pivots ~= nil and type(s.pivots) ~= "table") then
    fail("animate", "draw(t, q) at t = %.6g returned %s: a table %s expected", t, listed(s), shape)
  end
  for k, p in ipairs(s.points or {}) do
    if type(p) ~= "table" or not (finite(p[1]) and finite(p[2])) then
      if type(p) == "table" and p.body then
        fail("animate", "body '%s' at t = %.6g is at %s in the plane drawn: two finite numbers expected "
          .. "(plane = \"xz\" or \"yz\" needs positions of three coordinates)", tostring(p.body), t, listed(p))
      end
      fail("animate", "draw(t, q) at t = %.6g: point %d is %s: {x, y}, two finite numbers, expected", t, k, listed(p))
    end
  end
  for k, p in ipairs(s.pivots or {}) do
    if type(p) ~= "table" or not (finite(p[1]) and finite(p[2])) then
      fail("animate", "draw(t, q) at t = %.6g: pivot %d is %s: {x, y}, two finite numbers, expected", t, k, listed(p))
    end
  end
  for k, g in ipairs(s.segments or {}) do
    if type(g) ~= "table" or not (finite(g[1]) and finite(g[2]) and finite(g[3]) and finite(g[4])) then
      fail("animate", "draw(t, q) at t = %.6g: segment %d is %s: {x1, y1, x2, y2}, four finite numbers, expected",
        t, k, listed(g))
    end
  end
end

-- tr:animate{ [file = "motion.gif" | "frame.svg", frames = 60, fps = 20,
--   draw = function(t, q) ... end, plane = "xy", links = true, range =
--   {xmin, xmax, ymin, ymax}, view = "2d" | "3d"] }: `frames` evenly spaced
-- output points drawn with gnuplot; with a .gif file one animated GIF, with
-- .svg one file per frame (name-001.svg, ...), else in the terminal, one
-- frame after another.  Returns the number of frames (and the file names).
local ANIMATE = require("nz.base.options").declare("tr:animate", { file = true, frames = true, fps = true, draw = true,
  plane = true, links = true, range = true, width = true, height = true, title = true, view = true })
-- In a notebook: the animated GIF shown inline (sized as a file's unless
-- width and height are given, then in the terminal's characters, as a
-- plot's), with a line of text beside it.
local animate
function M.inline_animation(tr, opts, nframes)
  local gif = plot.drawn("gif", function(o) return animate(tr, o) end, opts, opts.width, opts.height)
  local display = require "nz.draw.display"
  display.show(display.bundle{
    ["image/gif"] = gif,
    -- the same GIF as an image in HTML, for renderers without image/gif (nbconvert's HTML)
    ["text/html"] = function() return display.img("image/gif", gif, "animation of " .. tr.system.name) end,
    ["text/plain"] = ("animation of '%s': %d frames"):format(tr.system.name, nframes),
  })
  return require("nz.base.frontend").shown(nframes, {})   -- shown: nothing more at the prompt
end

-- The output points drawn: `frames` of them (default 60, at most all),
-- evenly spaced.
local function frame_points(tr, opts)
  local nframes = math.min(opts.frames or 60, #tr.t)
  local idx = {}
  for f = 1, nframes do idx[f] = nframes == 1 and 1 or math.floor(1 + (f - 1) * (#tr.t - 1) / (nframes - 1) + 0.5) end
  return idx
end

-- The frames of draw(t, q) at the chosen output points, drawn by gnuplot
-- (to opts.file, else in the terminal, or in a notebook its inline GIF).
local draw_frames

function M.animate(tr, opts)
  opts = opts or {}
  check_options("animate", opts, ANIMATE)
  check_animate(tr, opts)
  if #tr.t == 0 then fail("animate", "the trajectory is empty") end
  if opts.view == "3d" then return require("nz.presentation.view3d").animate(tr, opts, frame_points(tr, opts), draw_frames) end
  local draw = shapes_of(tr, opts)
  if tr.contacts then draw = require("nz.motion.contact_run").drawing(tr, draw, PLANES[opts.plane or "xy"]) end
  return draw_frames(tr, opts, draw)
end

function draw_frames(tr, opts, draw)
  local idx = frame_points(tr, opts)
  local nframes = #idx
  local frames = {}
  local xmin, xmax, ymin, ymax = math.huge, -math.huge, math.huge, -math.huge
  for f, i in ipairs(idx) do
    local s = draw(tr.t[i], tr.q[i])
    check_shapes(s, tr.t[i])
    frames[f] = { t = tr.t[i], shapes = s }
    for _, list in ipairs{ s.points or {}, s.pivots or {} } do
      for _, p in ipairs(list) do
        xmin, xmax, ymin, ymax = math.min(xmin, p[1]), math.max(xmax, p[1]), math.min(ymin, p[2]), math.max(ymax, p[2])
      end
    end
    for _, g in ipairs(s.segments or {}) do
      xmin, xmax = math.min(xmin, g[1], g[3]), math.max(xmax, g[1], g[3])
      ymin, ymax = math.min(ymin, g[2], g[4]), math.max(ymax, g[2], g[4])
    end
  end
  if opts.range then xmin, xmax, ymin, ymax = table.unpack(opts.range, 1, 4) end
  if xmin > xmax then
    fail("animate", "nothing to draw: draw(t, q) returned no points and no segments in any frame "
      .. "(or give the view: range = {xmin, xmax, ymin, ymax})")
  end
  local file = opts.file
  if not file and require("nz.base.frontend").accepts("image/gif") then return M.inline_animation(tr, opts, nframes) end
  local kind = file and file:match("%.(%w+)$")
  local w, h = opts.width or (file and 480 or 60), opts.height or (file and 480 or 24)
  -- a margin around the drawing: 5 %, and in the terminal two lines'
  -- worth, so that a point at the edge (the pivot) is not drawn on the frame
  local span = math.max(xmax - xmin, ymax - ymin, 1e-9)
  local pad = math.max(0.05, file and 0 or 2 / h) * span
  xmin, xmax, ymin, ymax = xmin - pad, xmax + pad, ymin - pad, ymax + pad
  local data = os.tmpname()
  local d = assert(io.open(data, "w"))
  for _, fr in ipairs(frames) do      -- per frame: block 3f of segments, 3f+1 of points, 3f+2 of pivots
    for _, g in ipairs(fr.shapes.segments or {}) do d:write(("%.9g %.9g\n%.9g %.9g\n\n"):format(g[1], g[2], g[3], g[4])) end
    d:write("0 0\n\n\n")   -- (a dummy line keeps the block present)
    for _, p in ipairs(fr.shapes.points or {}) do d:write(("%.9g %.9g\n"):format(p[1], p[2])) end
    d:write("\n\n")
    for _, p in ipairs(fr.shapes.pivots or {}) do d:write(("%.9g %.9g\n"):format(p[1], p[2])) end
    d:write("NaN NaN\n\n\n")   -- (undefined: keeps the block present, draws nothing)
  end
  d:close()
  local script = {}
  local outputs = {}
  if kind == "gif" then
    script[#script + 1] = ("set terminal gif animate delay %d size %d,%d"):format(math.floor(100 / (opts.fps or 20) + 0.5), w, h)
    script[#script + 1] = ("set output %q"):format(file)
    outputs[1] = file
  elseif not file then
    script[#script + 1] = ("set terminal dumb size %d,%d"):format(w, h)
  end
  script[#script + 1] = ("set xrange [%.9g:%.9g]\nset yrange [%.9g:%.9g]\nset size ratio -1\nunset key"):format(xmin, xmax, ymin, ymax)
  for f, fr in ipairs(frames) do
    if kind == "svg" then
      local name = file:gsub("%.svg$", ("-%03d.svg"):format(f))
      script[#script + 1] = ("set terminal svg size %d,%d\nset output %q"):format(w, h, name)
      outputs[#outputs + 1] = name
    end
    script[#script + 1] = ("set title %q"):format(("%s  t = %.3f"):format(opts.title or tr.system.name, fr.t))
    -- a pivot: a filled square in a file, # in the terminal
    local pivots = fr.shapes.pivots and #fr.shapes.pivots > 0
      and (", %q index %d with points %s"):format(data, 3 * (f - 1) + 2, file and "pt 5 ps 2 lc rgb 'black'" or "pt '#'")
      or ""
    script[#script + 1] = ("plot %q index %d with lines lw 2, %q index %d with points pt 7 ps 1.5%s"):format(
      data, 3 * (f - 1), data, 3 * (f - 1) + 1, pivots)
  end
  local ok, out = plot.gnuplot(script)
  os.remove(data)
  if not ok then fail("animate", "gnuplot failed: %s", out) end
  if not file then
    -- the terminal: frames one after another, the screen cleared between
    -- them when it is one (a redirected output keeps them all)
    local tty = require("nz.core").mech.isatty(1)
    local pieces = {}
    for frame in out:gmatch("\f?([^\f]+)") do pieces[#pieces + 1] = frame end
    for _, frame in ipairs(pieces) do
      if tty then io.write("\27[H\27[2J") end
      io.write(frame)
      io.flush()
      if tty then os.execute(("sleep %g"):format(1 / (opts.fps or 20))) end
    end
    return require("nz.base.frontend").shown(nframes, outputs)   -- the frames were the output: nothing more at the prompt
  end
  return nframes, outputs
end
animate = M.animate

-- The trajectory's methods of this module: a Poincare section from the
-- run's event crossings, and the mechanism animated.
local Trajectory = require("nz.motion.trajectory").Trajectory
function Trajectory:section(opts) return M.section(self, opts) end
function Trajectory:animate(opts) return M.animate(self, opts) end
require("nz.base.where").methods(Trajectory, "tr", "trajectory")

return M
