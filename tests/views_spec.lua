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
      .. "nz.workprecision(o, { q0 = {1}, t1 = 1, methods = {'rk8pd'}, tols = {1e-6} })\nprint('mark W')\n")
    assert.are.equal(0, rc)
    local _, n = out:gsub("Residuals of the equations of order 2", "")
    assert.are.equal(3, n, out)     -- printed by the call, r typed, the bare call: once each
    assert.falsy(out:find("{{coordinate", 1, true), out)
    local wp = out:match("mark R(.-)mark W")
    local _, m = wp:gsub("cheapest for each accuracy", "")
    assert.are.equal(1, m, wp)
    assert.falsy(wp:find("{{error", 1, true), wp)
    -- in a script, print(rows) is the same table
    local rows = nz.workprecision(osc(), { q0 = { 1 }, t1 = 1, methods = { "rk8pd" }, tols = { 1e-6 }, quiet = true })
    assert.truthy(tostring(rows):find(require("nz.workprecision").table(rows), 1, true))
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
    local data = slurp(gif)
    assert.are.equal("GIF8", data:sub(1, 4))
    -- one Graphic Control Extension (0x21 0xF9 0x04) per frame
    local frames = 0
    for _ in data:gmatch("\33\249\4") do frames = frames + 1 end
    assert.are.equal(12, frames)
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
    h.checkerror("must end in .gif or .svg", tr.animate, tr, { file = "x.png", draw = function() return {} end })
  end)
end)

describe("nz.workprecision's table and diagram", function()
  it("ends with the cheapest method for each accuracy, and labels the diagram's points with their tolerances", function()
    local rows = nz.workprecision(osc(), { q0 = { 1 }, t1 = 5, methods = { "rk4", "rk8pd" }, tols = { 1e-4, 1e-8 },
      reference = function(t) return { math.cos(t) } end, quiet = true })
    local text = require("nz.workprecision").table(rows)
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
    require("nz.workprecision").diagram(rows, { file = svg })
    local s = slurp(svg)
    assert.truthy(s:find(">1e-08<", 1, true) or s:find("1e-08", 1, true), "a point's tolerance label")
    os.remove(svg)
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
