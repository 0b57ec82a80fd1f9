-- views_spec.lua - what a user sees of a trajectory and a study, checked as
-- files and text: tr:plot's labels in the SVG, tr:section's points against
-- a closed form (the harmonic oscillator's section is one point), the
-- animation's GIF frames counted, SVG frames written, the work-precision
-- table's recommendation and its diagram's labels, and an interrupted study
-- that keeps its rows.
local h = require "tests.helpers"
local nz = h.nz

local function osc()
  return nz.system{ name = "oscillator", coords = { "x" },
    T = function(t, q, qd) return 0.5 * qd[1] ^ 2 end, V = function(t, q) return 0.5 * q[1] ^ 2 end }
end

local function slurp(path) return assert(h.slurp(path), path) end

-- The frames of a GIF file: one Graphic Control Extension (0x21 0xF9 0x04) each.
local function gif_frames(path)
  local data = slurp(path)
  assert.are.equal("GIF8", data:sub(1, 4))
  local frames = 0
  for _ in data:gmatch("\33\249\4") do frames = frames + 1 end
  return frames
end

-- A terminal plot taken apart: its lines, the frame (first and last line,
-- first and last column), the x tick labels (the line under the frame), the
-- y tick labels (each ending one blank left of the frame), and count(c):
-- how often the character c is drawn inside the frame.
local function dissect(text)
  local rows = {}
  for line in (text .. "\n"):gmatch("([^\n]*)\n") do rows[#rows + 1] = line end
  local p = { rows = rows, xlabels = {}, ylabels = {} }
  for r, line in ipairs(rows) do
    local s, e = line:find("%+%-+%+")
    if s and e - s > 8 then
      if not p.top then p.top, p.left, p.right = r, s, e end
      p.bottom = r
    end
  end
  assert(p.top and p.bottom > p.top, "no frame in:\n" .. text)
  for tok in rows[p.bottom + 1]:gmatch("%S+") do p.xlabels[#p.xlabels + 1] = tok end
  for r = p.top, p.bottom do
    local tok = rows[r]:sub(1, p.left - 1):match("(%S+) $")
    if tok then p.ylabels[#p.ylabels + 1] = tok end
  end
  function p.inside(r) return rows[r]:sub(p.left + 1, p.right - 1) end
  function p.count(c)
    local n = 0
    for r = p.top + 1, p.bottom - 1 do
      for _ in p.inside(r):gmatch(c:gsub("%p", "%%%0")) do n = n + 1 end
    end
    return n
  end
  return p
end

-- Tick labels that can be told apart: each reads as one number (labels
-- run together do not), no two alike, in order.
local function assert_ticks(labels, increasing, text)
  assert(#labels >= 2, "fewer than two tick labels:\n" .. text)
  for i, l in ipairs(labels) do
    assert(tonumber(l), ("tick label %q is not one number (labels run together?):\n%s"):format(l, text))
    if i > 1 then
      local a, b = tonumber(labels[i - 1]), tonumber(l)
      assert(increasing and a < b or not increasing and a > b, ("tick labels %q, %q repeat or are out of order:\n%s")
        :format(labels[i - 1], l, text))
    end
  end
end

describe("tr:plot", function()
  it("writes the title, axis labels and legend to the SVG, and refuses unknown options", function()
    local tr = osc():simulate{ q0 = { 1 }, t1 = 3, monitors = { energy = true } }
    local svg = os.tmpname() .. ".svg"
    assert.are.equal(svg, tr:plot{ y = { "x" }, file = svg, title = "my title", xlabel = "time (s)", ylabel = "position (m)" })
    local text = slurp(svg)
    for _, s in ipairs{ "my title", "time (s)", "position (m)" } do assert.truthy(text:find(s, 1, true), s) end
    os.remove(svg)
    -- E drawn as its drift from its first value, named so
    local plain = tr:plot{ y = { "E" }, quiet = true, size = { 70, 16 } }
    assert.truthy(plain:find("E - E(0)", 1, true), plain)
    h.checkerror("trajectory:plot: unknown option 'colour'", tr.plot, tr, { colour = "red" })
    h.checkerror("trajectory:plot: y = 3: a quantity's name or a list of names expected", tr.plot, tr, { y = 3 })
    h.checkerror("trajectory:plot: size = 70: {width, height} expected", tr.plot, tr, { size = 70 })
    -- a quantity it does not have: from the caller's line, not the library's
    local ok, msg = pcall(tr.plot, tr, { y = { "z" } })
    assert(not ok and msg:match("^[^:]*views_spec%.lua:%d+: trajectory: no quantity 'z'"), msg)
  end)
  it("a short terminal plot keeps its y tick labels apart: at most five, each on a line of its own", function()
    local tr = osc():simulate{ q0 = { 1.2345 }, t1 = 10 }
    local text = tr:plot{ y = { "x" }, quiet = true, size = { 60, 12 } }
    local ticks = 0
    for line in text:gmatch("[^\n]+") do
      if line:match("^%s*%-?[%d%.]+e?[%-%d]*%s+[%+|]") then ticks = ticks + 1 end
    end
    assert(ticks >= 2 and ticks <= 5, text)
  end)
end)

describe("terminal plots (one path for every caller: nz.plot.lines)", function()
  local plot = require "nz.draw.plot"
  it("choose the ticks from the plot's width: labels apart, each telling its tick from the next", function()
    -- the reviewer's ranges (henon_chaos's energies, a phase plot, planet_path's x)
    -- and some that need many digits or an exponent, at several widths
    local ranges = { { 1 / 12, 1 / 6.5 }, { -2.5, 2.5 }, { -1.6, 0.4 }, { 1000.1, 1000.25 }, { 0, 3e-9 },
      { -3e6, 5e6 }, { 1e-4, 0.3, log = true }, { 0.007, 0.023, log = true } }
    for _, r in ipairs(ranges) do
      for _, width in ipairs{ 40, 60, 72, 80, 120 } do
        local x = { r[1], (r[1] + r[2]) / 2, r[2] }
        local text = plot.lines{ series = { { name = "a curve", x = x, y = { 1, 3, 2 } } }, logx = r.log, quiet = true,
          width = width, height = 14, xlabel = "x", ylabel = "y" }
        local p = dissect(text)
        assert_ticks(p.xlabels, true, text)
        assert_ticks(p.ylabels, false, text)
      end
    end
  end)
  it("draw a point on the edge of the data's range inside the frame, not on it", function()
    for _, size in ipairs{ { 40, 10 }, { 60, 15 }, { 100, 30 } } do
      -- the four corners of the data and its middle, each an A (point type 1)
      local text = plot.lines{ series = { { x = { 0, 1, 0, 1, 0.5 }, y = { 0, 0, 2, 2, 1 }, style = "points pt 1" } },
        legend = false, quiet = true, width = size[1], height = size[2] }
      assert.are.equal(5, dissect(text).count("A"), text)
    end
    -- the reviewer's eigenvalue sweep: Im(lambda) = 2 (its largest value, point type 6: F) at c = 0
    local osc = nz.system{ name = "osc", coords = { "x" }, params = { m = 2, k = 8, c = 0.4 },
      T = function(t, q, qd, p) return 0.5 * p.m * qd[1] ^ 2 end, V = function(t, q, p) return 0.5 * p.k * q[1] ^ 2 end,
      Q = function(t, q, qd, p) return { -p.c * qd[1] } end }
    local values = {}
    for i = 0, 10 do values[#values + 1] = -1 + 0.2 * i end
    local sw = osc:eigen_sweep{ parameter = "c", values = values, at = function(c) osc.params.c = c; return { q = { 0 }, qd = { 0 } } end }
    local text = sw:plot{ width = 70, height = 15, quiet = true }
    assert.are.equal(#values, dissect(text).count("F"), text)
  end)
  it("write the y axis' label apart from its tick labels", function()
    local tr = osc():simulate{ q0 = { 1.2 }, t1 = 10 }
    for _, size in ipairs{ { 70, 15 }, { 50, 12 }, { 100, 30 } } do
      local text = tr:plot{ y = { "x", "x'" }, quiet = true, size = size }   -- its y label: "x, x'"
      local p = dissect(text)
      local found = false
      for r = p.top, p.bottom do
        local margin = p.rows[r]:sub(1, p.left - 1)
        if margin:find("x, x'", 1, true) then
          found = true
          assert(margin:match("^x, x'%s+%S* $"), ("the y label runs into a tick label: %q\n%s"):format(margin, text))
        end
      end
      assert(found, "no y label:\n" .. text)
      assert_ticks(p.ylabels, false, text)
    end
  end)
  it("refuse a bad file or size, and values with nothing to draw, from the caller's line", function()
    local s = { { x = { 1, 2 }, y = { 1, 2 } } }
    local function from_here(msg) return msg:match("^[^:]*views_spec%.lua:%d+: plot: ") end
    for _, case in ipairs{ { { series = s, file = "out.pdf" }, "file 'out.pdf' must end in .svg or .png" },
        { { series = s, width = 0 }, "width = 0: a whole number from 30 to 10000 expected" },
        { { series = s, height = "big" }, "height = \"big\": a whole number" },
        { { series = { { x = { 0 / 0, 1 / 0 }, y = { 1, 2 } } } }, "nothing to draw: every value is NaN or infinite" } } do
      local ok, msg = pcall(plot.lines, case[1])
      assert.is_false(ok)
      assert(from_here(msg) and msg:find(case[2], 1, true), msg)
    end
  end)
end)

describe("tr:csv", function()
  it("writes each number in the shortest form that reads back exactly", function()
    local tr = osc():simulate{ q0 = { 1 }, t1 = math.pi, dt = math.pi / 2 }
    local file = os.tmpname()
    tr:csv(file)
    local text = slurp(file)
    os.remove(file)
    assert.truthy(text:find("\n3.141592653589793,", 1, true), text)
    assert.falsy(text:find("3.1415926535897931", 1, true), text)
    -- and every number reads back as the trajectory's
    local row = 0
    for line in text:gmatch("[^\n]+") do
      if row > 0 then
        local t, x = line:match("^([^,]+),([^,]+)")
        assert.are.equal(tr.t[row], tonumber(t))
        assert.are.equal(tr.q[row][1], tonumber(x))
      end
      row = row + 1
    end
  end)
end)

describe("tr:csv without a file", function()
  it("returns the CSV text, the same as the file's, and the session shows it", function()
    local tr = osc():simulate{ q0 = { 1 }, t1 = 1, dt = 0.5 }
    local file = os.tmpname()
    assert.are.equal(file, tr:csv(file))
    assert.are.equal(slurp(file), tr:csv())
    os.remove(file)
    h.checkerror("bad argument #1 to 'csv' (a file name, or nothing for the CSV text, expected, got number)", tr.csv, tr, 5)
    -- a directory is named as such, with what to write instead, at the caller's line
    local ok, msg = pcall(function()
      local f = tr:csv("/tmp/")
      return f
    end)
    assert(not ok and msg:find("views_spec.lua:%d+: tr:csv: cannot write '/tmp/': it is a directory: give the name of "
      .. "a file to write, as tr:csv%(\"/tmp/run.csv\"%)"), msg)
    local rc, out = h.run(h.nzlua .. " -i", "o = nz.system{ coords = {'x'}, T = function(t, q, qd) return qd[1]^2 / 2 end,"
      .. " V = function(t, q) return q[1]^2 / 2 end }\notr = o:simulate{ q0 = {1}, t1 = 1, dt = 0.5 }\notr:csv()\n")
    assert.are.equal(0, rc)
    assert.truthy(out:find("t,x,x',x''\n0,1,0,-1\n0.5,", 1, true), out)
  end)
end)

-- What a view prints at the prompt, it prints once: a function that prints
-- its result returns it for scripts, and the session does not print it again.
describe("views typed at the prompt", function()
  local setup_lines = "o = nz.system{ coords = {'x'}, T = function(t, q, qd) return qd[1]^2 / 2 end,"
    .. " V = function(t, q) return q[1]^2 / 2 end }\n"
    .. "otr = o:simulate{ q0 = {0.7}, t1 = 20, events = { { name = 'x=0', f = function(t, q) return q[1] end, direction = 1 } } }\n"
  it("tr:section drawn in the terminal and tr:animate in the terminal print nothing after the drawing", function()
    local rc, out = h.run(h.nzlua .. " -i", setup_lines .. "otr:section{ width = 60, height = 15 }\nprint('mark S')\n"
      .. "otr:animate{ frames = 2, draw = function(t, q) return { points = { { q[1], 0 } } } end }\nprint('mark A')\n")
    assert.are.equal(0, rc)
    local section = out:match("Poincare section of(.-)mark S")
    assert(section, out)
    assert.falsy(section:find("{names =", 1, true), section)    -- no dump of the section's lists
    local frames = out:match("mark S(.-)mark A")
    assert.falsy(frames:find("\n2\t{}", 1, true), frames)       -- no "2 {}" after the frames
  end)
  it("tr:residuals and nz.workprecision: the table once, and their results print as that table", function()
    local rc, out = h.run(h.nzlua .. " -i", setup_lines .. "r = otr:residuals(2)\nr\notr:residuals(2)\nprint('mark R')\n"
      .. "nz.workprecision(o, { budget = 0.01, q0 = {1}, t1 = 1, methods = {'rk8pd'}, tols = {1e-6} })\nprint('mark W')\n")
    assert.are.equal(0, rc)
    local _, n = out:gsub("Defect of the motion of 'unnamed'", "")
    assert.are.equal(3, n, out)     -- printed by the call, r typed, the bare call: once each
    assert.falsy(out:find("{{coordinate", 1, true), out)
    local wp = out:match("mark R(.-)mark W")
    local _, m = wp:gsub("cheapest for each accuracy", "")
    assert.are.equal(1, m, wp)
    assert.falsy(wp:find("{{error", 1, true), wp)
    -- in a script, print(rows) is the same table
    local rows = nz.workprecision(osc(), { budget = 0.01, q0 = { 1 }, t1 = 1, methods = { "rk8pd" }, tols = { 1e-6 }, quiet = true })
    assert.truthy(tostring(rows):find(require("nz.analysis.workprecision").table(rows), 1, true))
    assert.are.equal(1, #rows)
  end)
end)

describe("tr:section", function()
  it("the oscillator's section x = 0, x' > 0 is one point: x' = amplitude, crossings every 2 pi", function()
    local tr = osc():simulate{ q0 = { 0.7 }, qd0 = { 0 }, t1 = 40, dt = 40, rtol = 1e-12, atol = 1e-12,
      events = { { name = "x=0", f = function(t, q, qd) return q[1] end, direction = 1 } } }
    local s = tr:section{ when = "x=0", plot = { "x", "x'" }, draw = false }
    -- x = 0.7 cos t crosses 0 rising at t = 3 pi / 2 + 2 pi n, with x' = 0.7
    assert.are.equal(6, #s.x)
    for n = 1, #s.x do
      assert.near(1.5 * math.pi + 2 * math.pi * (n - 1), s.t[n], 1e-9)
      assert.near(0.7, s.y[n], 1e-10)
      assert.near(0, s.x[n], 1e-10)
    end
    local two = osc():simulate{ q0 = { 0.7 }, t1 = 10,
      events = { { name = "a", f = function(t, q) return q[1] end }, { name = "b", f = function(t, q) return q[1] - 0.5 end } } }
    h.checkerror("the run has several events (a, b): say which with when", two.section, two, { draw = false })
    local none = osc():simulate{ q0 = { 0.7 }, t1 = 1 }
    h.checkerror("the run recorded no event crossing", none.section, none, { draw = false })
    h.checkerror("trajectory:section: plot: two quantities' names {\"y\", \"y'\"} expected", tr.section, tr, { plot = { "x", 2 } })
    h.checkerror('trajectory:section: draw = "no": true or false expected', tr.section, tr, { draw = "no" })
  end)
end)

describe("tr:animate", function()
  local function pendulum()
    return nz.scene{ name = "pendulum", coords = { "th" },
      bodies = { { name = "bob", mass = 1, pos = function(t, q) return { nz.sin(q[1]), -nz.cos(q[1]), 0 } end } },
      effects = { nz.effects.gravity{ g = { 0, -9.81, 0 } } } }
  end
  it("an animated GIF with one frame per requested output point", function()
    local tr = pendulum():simulate{ q0 = { 1 }, t1 = 2, dt = 0.05 }
    local gif = os.tmpname() .. ".gif"
    local n = tr:animate{ file = gif, frames = 12 }
    assert.are.equal(12, n)
    assert.are.equal(12, gif_frames(gif))
    os.remove(gif)
  end)
  it("SVG frames, and a user's drawing function", function()
    local tr = osc():simulate{ q0 = { 1 }, t1 = 1, dt = 0.1 }
    local base = os.tmpname()
    local n, files = tr:animate{ file = base .. ".svg", frames = 3,
      draw = function(t, q) return { points = { { q[1], 0 } }, segments = { { 0, 0, q[1], 0 } } } end }
    assert.are.equal(3, n)
    assert.are.equal(3, #files)
    for _, f in ipairs(files) do
      assert.truthy(slurp(f):find("<svg", 1, true))
      os.remove(f)
    end
    h.checkerror("the system has no bodies to draw", tr.animate, tr, { frames = 2 })
    h.checkerror("must end in .gif (one animated GIF) or .svg", tr.animate, tr, { file = "x.png", draw = function() return {} end })
  end)
  it("marks the fixed pivot the bodies hang from: # in the terminal, a filled square in a file, still in every frame", function()
    local tr = pendulum():simulate{ q0 = { 1 }, t1 = 1, dt = 0.05 }
    -- the terminal: the frames as written (captured), each taken apart
    local written, write = {}, io.write
    io.write = function(...) for i = 1, select("#", ...) do written[#written + 1] = tostring(select(i, ...)) end end
    local ok, err = pcall(tr.animate, tr, { frames = 3 })
    io.write = write
    assert(ok, err)
    local text, at, bobs = table.concat(written), nil, {}
    local n = 0
    for frame in text:gmatch("pendulum  t = [^\n]*\n(.-)\n%s*\n") do
      local p = dissect(frame)
      assert.are.equal(1, p.count("#"), frame)                  -- the pivot, once
      for r = p.top + 1, p.bottom - 1 do
        local c = p.inside(r):find("#", 1, true)
        if c then
          -- in the same place in every frame, not on the frame's edge
          assert(not at or (at[1] == r and at[2] == c), frame)
          assert(r > p.top + 1 and c > 2 and c < #p.inside(r) - 1, frame)
          at = { r, c }
        end
        local b = p.inside(r):find("G", 1, true)                -- the bob (point type 7)
        if b then bobs[#bobs + 1] = r * 1000 + b end
      end
      n = n + 1
    end
    assert.are.equal(3, n, text)
    assert(bobs[1] ~= bobs[2] or bobs[2] ~= bobs[3], "the bob swings:\n" .. text)
    -- SVG frames: one filled square (gnuplot's point 4 of its list) each, at the same place
    local base = os.tmpname()
    local _, files = tr:animate{ file = base .. ".svg", frames = 3 }
    local where
    for _, f in ipairs(files) do
      local svg = slurp(f)
      local _, count = svg:gsub("#gpPt4' transform", "")
      assert.are.equal(1, count, f)
      local pos = svg:match("#gpPt4' transform='translate%(([^)]*)%)")
      assert(not where or where == pos, pos)
      where = pos
      os.remove(f)
    end
    os.remove(base)
    -- draw = function returns pivots of its own; links = false draws none
    local osc_tr = osc():simulate{ q0 = { 1 }, t1 = 1, dt = 0.1 }
    written = {}
    io.write = function(...) for i = 1, select("#", ...) do written[#written + 1] = tostring(select(i, ...)) end end
    ok, err = pcall(osc_tr.animate, osc_tr, { frames = 1, draw = function(t, q)
      return { points = { { q[1], 0 } }, segments = { { -1.5, 0, q[1], 0 } }, pivots = { { -1.5, 0 } } } end })
    io.write = write
    assert(ok, err)
    assert.are.equal(1, dissect(table.concat(written)).count("#"), table.concat(written))
    h.checkerror("draw(t, q) at t = 0: pivot 1 is {nil, nil}: {x, y}, two finite numbers, expected", osc_tr.animate, osc_tr,
      { frames = 1, draw = function() return { points = { { 0, 0 } }, pivots = { {} } } end })
  end)
  it("refuses each bad option before drawing: the caller's line, the option, what it accepts", function()
    local tr = pendulum():simulate{ q0 = { 1 }, t1 = 1, dt = 0.1 }
    local gif = os.tmpname() .. ".gif"
    for _, case in ipairs{
      { { frames = 0 }, "frames = 0: a whole number of frames, 1 or more, expected" },
      { { frames = 2.5 }, "frames = 2.5: a whole number of frames" },
      { { plane = "xq" }, 'plane = "xq": "xy", "xz" or "yz" expected' },
      { { fps = 0 }, "fps = 0: frames per second, a number above 0 and at most 100, expected" },
      { { links = "yes" }, 'links = "yes": true (lines from the origin through the bodies' },
      { { range = { 0, 1 } }, "range = {0, 1}: {xmin, xmax, ymin, ymax} expected" },
      { { range = { 1, 0, 0, 1 } }, "range = {1, 0, 0, 1}: {xmin, xmax, ymin, ymax} expected, four numbers with xmin < xmax" },
      { { width = 3 }, "width = 3: a whole number from 50 to 10000 expected (pixels)" },
      { { title = 3 }, "title = 3: a string expected" },
      { { draw = "circle" }, 'draw = "circle": a function(t, q) returning {points = ' },
      { { draw = function() return 1 end }, "draw(t, q) at t = 0 returned 1: a table {points = " },
      { { draw = function() return { points = { { 0 / 0, 1 } } } end }, "draw(t, q) at t = 0: point 1 is {" },
      { { draw = function() return { segments = { { 0, 0, 1 } } } end },
        "draw(t, q) at t = 0: segment 1 is {0, 0, 1}: {x1, y1, x2, y2}, four finite numbers, expected" },
      { { draw = function() return {} end }, "nothing to draw: draw(t, q) returned no points and no segments" },
      { { draw = function() return {} end, plane = "xy" }, "plane draws the bodies, and draw = function(t, q) ... replaces them" },
    } do
      case[1].file = gif
      local ok, msg = pcall(tr.animate, tr, case[1])
      assert.is_false(ok)
      assert(msg:match("^[^:]*views_spec%.lua:%d+: trajectory:animate: ") and msg:find(case[2], 1, true),
        ("expected %q from the caller's line, got %q"):format(case[2], msg))
      assert.is_nil(io.open(gif), "nothing written")
    end
    -- and in the terminal, where sizes are characters
    h.checkerror("height = 5: a whole number from 20 to 10000 expected (characters of the terminal)", tr.animate, tr, { height = 5 })
  end)
end)

describe("tr:animate{ view = \"3d\" }", function()
  local view3d = require "nz.presentation.view3d"
  local display = require "nz.draw.display"
  local frontend = require "nz.base.frontend"
  local R = nz.rotations
  -- the heavy top of examples/heavy_top.lua, about its fixed point
  local m, lc = 1.5, 0.4
  local function rot(t, q) return R.euler_zxz(q[1], q[2], q[3]) end
  local function top()
    return nz.scene{ name = "top", coords = { "psi", "theta", "phi" },
      bodies = { { name = "top", mass = m, inertia = { 0.06, 0.06, 0.2 }, rot = rot,
        pos = function(t, q) local M = rot(t, q); return { lc * M[1][3], lc * M[2][3], lc * M[3][3] } end } },
      effects = { nz.effects.gravity{ g = { 0, 0, -9.81 } } } }
  end
  local function run(sys) return sys:simulate{ q0 = { 0, 0.5, 0 }, qd0 = { 0, 0, 40 }, t1 = 0.5, dt = 0.01 } end

  it("draws a rigid body as its ellipsoid of inertia, turned with it, and puts up against gravity", function()
    -- inertia {a, b, c} turned by Q in the body: the principal moments found
    -- again, semi-axes^2 = 5 (I_j + I_k - I_i) / (2 m) (a uniform ellipsoid's
    -- moments are m (b^2 + c^2)/5, ...)
    local a, b, c, mass = 0.3, 0.5, 0.7, 2.0
    local Q = R.mul(R.z(0.4), R.x(1.1))
    local D = { { a, 0, 0 }, { 0, b, 0 }, { 0, 0, c } }
    local QT = { { Q[1][1], Q[2][1], Q[3][1] }, { Q[1][2], Q[2][2], Q[3][2] }, { Q[1][3], Q[2][3], Q[3][3] } }
    local I = R.mul(R.mul(Q, D), QT)
    local sys = nz.system{ name = "block", coords = { "x" }, bodies = { gravity = { 0, -9.81, 0 },
      { name = "block", mass = mass, inertia = I, rot = function(t, q) return R.z(q[1]) end,
        pos = function(t, q) return { q[1], 0, 0 } end } } }
    local tr = sys:simulate{ q0 = { 0 }, qd0 = { 1 }, t1 = 1, dt = 0.5 }
    local model = view3d.model(tr, { 1, 2, 3 }, {})
    local shape = model.shapes[1]
    for i, moment in ipairs{ a, b, c } do
      local others = a + b + c - moment
      local want = math.sqrt(5 * (others - moment) / (2 * mass))
      -- the principal axis of this moment: column i of Q, found among E's
      local found = false
      for j = 1, 3 do
        local along = math.abs(Q[1][i] * shape.E[1][j] + Q[2][i] * shape.E[2][j] + Q[3][i] * shape.E[3][j])
        if along > 1 - 1e-9 then
          found = true
          assert(math.abs(shape.semi[j] - want) <= 1e-9, ("semi-axis %d: %.12g, by hand %.12g"):format(i, shape.semi[j], want))
        end
      end
      assert(found, "no principal axis along Q's column " .. i)
    end
    assert.are.same({ 0, 1, 0 }, model.up)
    -- seen from 28 degrees above the floor
    local e = model.eye
    assert(math.abs(e[1] * 0 + e[2] * 1 + e[3] * 0 - math.sin(math.rad(28))) <= 1e-12)
    -- each frame: where pos and rot put the body
    for f, i in ipairs{ 1, 2, 3 } do
      assert(math.abs(model.frames[f].p[1][1] - tr.q[i][1]) <= 1e-15)
      assert(math.abs(model.frames[f].R[1][1][2] + math.sin(tr.q[i][1])) <= 1e-15)
    end
    -- a scene's gravity effect: up is z for the top
    assert.are.same({ 0, 0, 1 }, view3d.model(run(top()), { 1 }, {}).up)
  end)

  it("marks a contact's point while it is held: a ball dropped on the floor, from its rest on", function()
    -- dropped from z = 1 with e = 0.5, it is in the air until sqrt(2/g) and
    -- rests from 3 sqrt(2/g) on (t1 (1 + e)/(1 - e)), its point on the floor
    local ball = nz.scene{ name = "ball", coords = { "z" },
      bodies = { { name = "b", mass = 1, pos = function(t, q) return { 0, 0, q[1] } end } },
      effects = { nz.effects.gravity{}, nz.effects.contact{ name = "floor", at = "b", e = 0.5,
        plane = { normal = { 0, 0, 1 } } } } }
    local tr = ball:simulate{ q0 = { 1 }, t1 = 2, dt = 0.01 }
    local idx = {}
    for i = 1, #tr.t, 10 do idx[#idx + 1] = i end
    local model = view3d.model(tr, idx, { links = false })
    local fall, rest = math.sqrt(2 / 9.81), 3 * math.sqrt(2 / 9.81)
    local air, held = 0, 0
    for _, f in ipairs(model.frames) do
      if f.t < fall - 1e-6 then
        assert(f.c[1] == false, ("t = %g: in the air, yet a contact point is drawn"):format(f.t))
        air = air + 1
      elseif f.t > rest + 1e-3 then
        assert(f.c[1] and math.abs(f.c[1][3]) <= 1e-9, ("t = %g: resting, and no point on the floor"):format(f.t))
        held = held + 1
      end
    end
    assert(air > 2 and held > 2, ("frames in the air %d, at rest %d"):format(air, held))
  end)

  it("in the terminal and to a file: the scene from a fixed direction, frame by frame", function()
    local tr = run(top())
    local written, write = {}, io.write
    io.write = function(...) for i = 1, select("#", ...) do written[#written + 1] = tostring(select(i, ...)) end end
    local ok, n = pcall(tr.animate, tr, { view = "3d", frames = 3 })
    io.write = write
    assert(ok, n)
    assert.are.equal(3, n)
    local text = table.concat(written)
    local frames = 0
    for _ in text:gmatch("top  t = ") do frames = frames + 1 end
    assert.are.equal(3, frames)
    assert(text:find("#", 1, true), "no pivot at the origin")
    local gif = os.tmpname() .. ".gif"
    assert.are.equal(5, tr:animate{ view = "3d", frames = 5, file = gif })
    assert.are.equal(5, gif_frames(gif))
    os.remove(gif)
  end)

  it("in a notebook: the three.js scene with the frames' data and the GIF inside", function()
    local tr = run(top())
    local fe = { name = "test", accepts = {}, shown = {} }
    for _, mime in ipairs(display.MIMES) do fe.accepts[mime] = true end
    function fe.publish(data) fe.shown[#fe.shown + 1] = data end
    function fe.progress() return false end
    frontend.use(fe)
    local ok, err = pcall(tr.animate, tr, { view = "3d", frames = 4 })
    frontend.use(nil)
    assert(ok, err)
    local data = fe.shown[1]
    local html = data["text/html"]
    assert(html and html:find('data-nz-view="loading"', 1, true) and html:find("THREE", 1, true), "no scene")
    assert(html:find("kernelspecs/nzlua/three.min.js", 1, true) and html:find("/usr/share/javascript/three/build/three.min.js",
      1, true), "three.js is not looked for where it is served")
    assert(not html:find("https?://"), "the scene reaches for the network")
    local gif = h.img_data(html, "image/gif")
    assert(gif and gif:sub(1, 6) == "GIF89a" and gif == data["image/gif"], "no GIF inside the scene")
    assert(data["text/plain"] == "3-D view of 'top': 4 frames")
    -- the first frame's position, as pos gives it at t = 0 (6 digits)
    local x, y, z = html:match('"frames":%[{"t":0,"p":%[%[([^,]+),([^,]+),([^%]]+)%]')
    local want = { lc * math.sin(0) * math.sin(0.5), -lc * math.cos(0) * math.sin(0.5), lc * math.cos(0.5) }
    assert(x and math.abs(x - want[1]) + math.abs(y - want[2]) + math.abs(z - want[3]) <= 3e-6, tostring(x))
    local _, nframes = html:gsub('{"t":', "")
    assert.are.equal(4, nframes)
  end)

  it("refuses what a 3-D view cannot draw, from the caller's line", function()
    local tr = run(top())
    h.checkerror('view = "4d": "2d" (the bodies in a plane, the default) or "3d" (in space) expected', tr.animate, tr,
      { view = "4d" })
    h.checkerror('view = "3d" draws the bodies in space, and plane = ... is for a drawing in a plane', tr.animate, tr,
      { view = "3d", plane = "xz" })
    local otr = osc():simulate{ q0 = { 1 }, t1 = 1, dt = 0.1 }
    h.checkerror('view = "3d" draws a system\'s bodies, and this one has none', otr.animate, otr, { view = "3d" })
  end)
end)

describe("nz.workprecision's table and diagram", function()
  it("ends with the cheapest method for each accuracy, and labels the diagram's points with their tolerances", function()
    local rows = nz.workprecision(osc(), { budget = 0.01, q0 = { 1 }, t1 = 5, methods = { "rk4", "rk8pd" }, tols = { 1e-4, 1e-8 },
      reference = function(t) return { math.cos(t) } end, quiet = true })
    local text = require("nz.analysis.workprecision").table(rows)
    local line = text:match("cheapest for each accuracy: ([^\n]+)")
    assert(line, text)
    -- each named method reaches the accuracy it is named for, in the least time among those that do
    for e, method, tol in line:gmatch("error <= 1e(%-?%d+): (%w+) at tol ([%de%.%-]+)") do
      local best
      for _, r in ipairs(rows) do
        if r.error <= 10 ^ tonumber(e) and (not best or r.time < best.time) then best = r end
      end
      assert.are.equal(best.method, method)
      assert.are.equal(best.tol, tonumber(tol))
    end
    local svg = os.tmpname() .. ".svg"
    require("nz.analysis.workprecision").diagram(rows, { file = svg })
    local s = slurp(svg)
    assert.truthy(s:find(">1e-08<", 1, true) or s:find("1e-08", 1, true), "a point's tolerance label")
    os.remove(svg)
  end)
  it("in the terminal: each method's points with its mark, the key showing each mark, tolerance labels whole and apart", function()
    local wp = require "nz.analysis.workprecision"
    -- rows as a study returns them: rk8pd at one tolerance, in the top right
    -- corner (where a label beside it would be cut by the frame), the others
    -- at three
    local rows = {}
    local function add(method, tol, err, time)
      rows[#rows + 1] = { method = method, tol = tol, error = err, time = time, nfev = 1, steps = 1, status = "done" }
    end
    add("rk8pd", 1e-8, 1e-5, 0.02)
    add("taylor", 1e-6, 1e-7, 2e-4); add("taylor", 1e-8, 1e-9, 4e-4); add("taylor", 1e-10, 1e-11, 8e-4)
    add("rk4", 1e-6, 3e-6, 1e-3); add("rk4", 1e-8, 1e-7, 3e-3); add("rk4", 1e-10, 1e-9, 1e-2)
    for _, size in ipairs{ { 100, 30 }, { 80, 20 } } do
      local text = wp.diagram(rows, { quiet = true, width = size[1], height = size[2] })
      local p = dissect(text)
      local tols = {}
      for _, r in ipairs(rows) do tols[("%g"):format(r.tol)] = true end
      for i, m in ipairs{ "rk8pd", "taylor", "rk4" } do
        local mark, n = string.char(64 + i), 0     -- point types 1, 2, 3: A, B, C
        for _, r in ipairs(rows) do if r.method == m then n = n + 1 end end
        assert.are.equal(n, p.count(mark), ("%s's %d points as %s in:\n%s"):format(m, n, mark, text))
        assert(text:find("\n[^\n]-" .. m .. " [^\n%w]*" .. mark), ("the key shows %s's mark %s:\n%s"):format(m, mark, text))
      end
      local labels = 0
      for r = p.top + 1, p.bottom - 1 do
        for word in p.inside(r):gmatch("[^%s%.:]*e[%-+][^%s%.:]*") do
          assert(tols[word], ("a tolerance label cut or run into something: %q in:\n%s"):format(word, text))
          labels = labels + 1
        end
      end
      assert(labels >= 3, "tolerance labels drawn where they fit:\n" .. text)
      assert_ticks(p.xlabels, true, text)
      assert_ticks(p.ylabels, false, text)
    end
  end)
  -- A study's rows as the issue's pendulum gave them: bsimp, the slowest,
  -- piled up at the right edge of the diagram, its points a few
  -- characters apart.
  local function piled_rows()
    local rows = {}
    local function add(method, tol, err, time)
      rows[#rows + 1] = { method = method, tol = tol, error = err, time = time, nfev = 1, steps = 1, status = "done" }
    end
    add("rk4", 1e-4, 1e-1, 2e-4); add("rk4", 1e-6, 1e-3, 3e-4); add("rk4", 1e-8, 1e-5, 5e-4); add("rk4", 1e-10, 1e-7, 9e-4)
    add("rk8pd", 1e-4, 1e-3, 2.5e-4); add("rk8pd", 1e-6, 1e-6, 3e-4); add("rk8pd", 1e-8, 1e-8, 3.6e-4)
    add("rk8pd", 1e-10, 1e-10, 4.4e-4)
    add("bsimp", 1e-4, 1e-6, 4.1e-3); add("bsimp", 1e-6, 2.6e-9, 4.4e-3); add("bsimp", 1e-8, 1e-11, 6.4e-3)
    add("bsimp", 1e-10, 2e-12, 6.8e-3)
    return rows
  end
  it("in the terminal: the points at the edges clear of the frame's tick marks, the last ones' labels inside", function()
    local wp = require "nz.analysis.workprecision"
    for _, size in ipairs{ { 100, 30 }, { 80, 24 } } do
      local text = wp.diagram(piled_rows(), { quiet = true, width = size[1], height = size[2] })
      local p = dissect(text)
      local marks = 0
      for r = p.top + 1, p.bottom - 1 do
        local inside = p.inside(r)
        for c in inside:gmatch("()[ABC]") do
          -- the tick marks take two columns inside each side and the line inside the top and bottom
          assert(c > 2 and c < #inside - 1 and r > p.top + 1 and r < p.bottom - 1,
            ("a point drawn over the frame's tick marks (line %d, column %d):\n%s"):format(r, c, text))
          marks = marks + 1
        end
      end
      assert.are.equal(12, marks, text)
      -- the rightmost point (bsimp at 1e-10, the bottom right) keeps its label, whole
      local last = text:match("C[ .]1e%-10") or text:match("1e%-10[ .]C")
      assert(last, "the last point's label is missing:\n" .. text)
    end
  end)
  it("in an SVG each method has a colour of its own that stands out on white (contrast at least 4.5)", function()
    local wp = require "nz.analysis.workprecision"
    local rows = {}
    for i, m in ipairs{ "rk4", "rkf45", "rkck", "rk8pd", "rk4imp", "bsimp", "msadams", "msbdf", "taylor" } do
      for j, tol in ipairs{ 1e-4, 1e-6, 1e-8 } do
        rows[#rows + 1] = { method = m, tol = tol, error = tol * i, time = 1e-4 * i * j, nfev = 1, steps = 1, status = "done" }
      end
    end
    local svg = os.tmpname() .. ".svg"
    wp.diagram(rows, { file = svg })
    local text = slurp(svg)
    os.remove(svg)
    -- WCAG 2: relative luminance of sRGB, contrast (L1 + 0.05) / (L2 + 0.05)
    local function luminance(r, g, b)
      local function lin(c) c = c / 255; return c <= 0.03928 and c / 12.92 or ((c + 0.055) / 1.055) ^ 2.4 end
      return 0.2126 * lin(r) + 0.7152 * lin(g) + 0.0722 * lin(b)
    end
    local seen, n = {}, 0
    for method, r, g, b in text:gmatch("<title>(%w+)</title>.-rgb%(%s*(%d+),%s*(%d+),%s*(%d+)%)") do
      local contrast = 1.05 / (luminance(tonumber(r), tonumber(g), tonumber(b)) + 0.05)
      assert(contrast >= 4.5, ("%s is drawn in rgb(%s, %s, %s): contrast %.2f on white"):format(method, r, g, b, contrast))
      local key = r .. "," .. g .. "," .. b
      assert(not seen[key], ("%s and %s share a colour"):format(seen[key], method))
      seen[key] = method
      n = n + 1
    end
    assert.are.equal(9, n, text:sub(1, 2000))
  end)
  it("Ctrl-C keeps the rows measured and marks the interrupted one, once", function()
    local script = [[
local osc = nz.system{ name = "osc", coords = { "x" }, T = function(t, q, qd) return 0.5 * qd[1] ^ 2 end,
  V = function(t, q) return 0.5 * q[1] ^ 2 end }
local ok, rows = pcall(nz.workprecision, osc, { q0 = { 1 }, t1 = 2e6, dt = 2e6, methods = { "rk8pd", "rk4" },
  tols = { 1e-2, 1e-12 }, reference = function(t) return { math.cos(t) } end })
]]
    local code, out = h.interrupt_script(script, 2)
    assert.are.equal(130, code)
    local n = 0
    for _ in out:gmatch("stopped by Ctrl%-C") do n = n + 1 end
    assert.are.equal(1, n, out)
    assert.truthy(out:find("interrupted", 1, true), out)
    -- no row of zeros for the methods it did not run
    assert.falsy(out:find("0.00e+00", 1, true), out)
    assert.falsy(out:find("\nrk4 ", 1, true), out)
  end)
end)
