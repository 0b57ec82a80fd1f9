-- longrun_spec.lua - nz.longrun: what accuracy costs over time.  The growth
-- exponent's fit against series written here, the errors of the rows
-- against the runs themselves (their first integrals computed in the
-- test), and what the methods' construction predicts on the oscillator:
-- rk4's energy drifts (exponent 1), a variational integrator's stays
-- bounded (0); the options' errors; the diagram's series and a file.
local h = require "tests.helpers"
local nz = h.nz
local longrun = require "nz.analysis.longrun"

local w = 1.5
local oscillator = nz.system{ name = "lr oscillator", coords = { "x" },
  T = function(t, q, qd) return qd[1] ^ 2 / 2 end, V = function(t, q) return w * w * q[1] ^ 2 / 2 end }

describe("nz.longrun", function()
  it("the growth exponent: the slope of the windows' RMS on log-log axes", function()
    local x, half, one, flat = {}, {}, {}, {}
    for i = 1, 10000 do
      x[i] = i / 10
      half[i], one[i], flat[i] = 3e-16 * math.sqrt(x[i]), 2e-12 * x[i], 1e-4 * (1.5 + math.sin(x[i]))
    end
    -- the RMS of c t^a over [u, 10^(1/2) u) is a fixed multiple of
    -- (u 10^(1/4))^a in the continuum: the fit gives a, up to the sampling
    -- of the first window (22 samples here; measured 0.5008)
    local a = longrun.growth(x, half, 1)
    assert(math.abs(a - 0.5) < 0.01, tostring(a))
    a = longrun.growth(x, one, 1)
    assert(math.abs(a - 1) < 0.01, tostring(a))
    -- a bounded oscillation: its RMS over windows of many periods is flat
    a = longrun.growth(x, flat, 10)
    assert(math.abs(a) < 0.02, tostring(a))
    -- windows: a factor sqrt(10) each, from `from` to the last sample
    local _, wins = longrun.growth(x, one, 10)
    assert.are.equal(10, wins[1].from)
    assert(math.abs(wins[2].from - 10 * math.sqrt(10)) < 1e-9)
    assert.are.equal(1000, wins[#wins].to)
  end)

  it("rk4's energy drifts, a variational integrator's stays bounded; the rows are the runs' own", function()
    local P = 2 * math.pi / w
    local rows = nz.longrun(oscillator, { q0 = { 1 }, qd0 = { 0 }, t1 = 2000 * P, period = P, samples = 20000,
      methods = { { method = "rk4", step = P / 20 }, { method = "variational", step = P / 20, name = "verlet" } },
      integrals = { momentum_squared = function(t, q, qd) return qd[1] ^ 2 end }, quiet = true })
    assert.are.equal(4, #rows)
    local by = {}
    for _, r in ipairs(rows) do by[r.method .. " " .. r.integral] = r end
    local rk4, verlet = by["rk4 step 0.209 energy"], by["verlet energy"]
    assert(rk4 and verlet, "rows: " .. table.concat((function() local t = {} for k in pairs(by) do t[#t + 1] = k end return t end)(), ", "))
    -- rk4 at 20 steps a period loses energy by a fixed fraction each step
    -- (|R(i w h)|^2 = 1 - (w h)^6 / 72 + ...): a drift, measured t^0.98;
    -- the trapezoidal rule's energy oscillates within O(h^2): t^-0.0002
    assert(math.abs(rk4.exponent - 1) < 0.05, ("rk4: t^%.3f"):format(rk4.exponent))
    assert(math.abs(verlet.exponent) < 0.05, ("verlet: t^%.3f"):format(verlet.exponent))
    -- over the windows: rk4's error grows 70x from the first to the last
    -- (a factor 100 in time; measured 1.8e-4 to 1.26e-2), Verlet's stays
    -- (1.51e-2 in both)
    local rw, vw = rk4.windows, verlet.windows
    assert(rw[#rw].rms > 50 * rw[1].rms, ("rk4: %.3g then %.3g"):format(rw[1].rms, rw[#rw].rms))
    assert(vw[#vw].rms < 1.5 * vw[1].rms, ("verlet: %.3g then %.3g"):format(vw[1].rms, vw[#vw].rms))
    -- the final error is the run's own: the same run, its energy computed here
    local tr = oscillator:simulate{ q0 = { 1 }, qd0 = { 0 }, t1 = 2000 * P, dt = 2000 * P / 20000, method = "rk4",
      step = P / 20 }
    local n, E0 = #tr.t, w * w / 2
    local final = math.abs(tr.qd[n][1] ^ 2 / 2 + w * w * tr.q[n][1] ^ 2 / 2 - E0) / E0
    assert(math.abs(rk4.final - final) <= 1e-12 * final, ("%.17g against %.17g"):format(rk4.final, final))
    assert.are.equal(tr.stats.steps, rk4.steps)
    assert(rk4.seconds > 0 and math.abs(rk4.per_unit * 2000 - rk4.seconds) < 1e-12)
    -- the user's integral: x'^2 is no integral, its "error" is of order 1
    assert(by["verlet momentum_squared"].final > 0.01)
    local text = longrun.table(rows)
    assert.truthy(text:find("per period", 1, true), text)
    assert.truthy(text:find("Brouwer's law", 1, true), text)
    assert.truthy(tostring(rows):find("Long run of 'lr oscillator'", 1, true))
  end)

  it("draws a line per method and integral, log-log, to the terminal or a file", function()
    local P = 2 * math.pi / w
    local rows = nz.longrun(oscillator, { q0 = { 1 }, qd0 = { 0 }, t1 = 100 * P, period = P, samples = 2000,
      methods = { "variational", "rk8pd" }, tol = 1e-6, quiet = true })
    local drawn = h.plotted(longrun.diagram, rows, { quiet = true })
    assert.are.equal(2, #drawn.series)
    assert(drawn.logx and drawn.logy)
    assert.are.equal("t - t0 (periods)", drawn.xlabel)
    for _, s in ipairs(drawn.series) do
      assert(#s.x > 10 and #s.x <= 200, #s.x)
      for i = 2, #s.x do assert(s.x[i] > s.x[i - 1]) end
    end
    assert.truthy(drawn.series[1].name:find("^variational, energy %(slope %-?%d"), drawn.series[1].name)
    if not os.execute("command -v gnuplot >/dev/null 2>&1") then return end   -- (the diagram needs gnuplot)
    -- in the terminal the key goes under the axes (at the right, its long
    -- names left the plot a fifth of the width): the x label, then the key
    local text = longrun.diagram(rows, { quiet = true })
    local xlabel, key = text:find("t - t0 (periods)", 1, true), text:find("variational, energy (slope", 1, true)
    assert(xlabel and key and xlabel < key, text)
    local svg = os.tmpname() .. ".svg"
    nz.longrun(oscillator, { q0 = { 1 }, qd0 = { 0 }, t1 = 10 * P, samples = 100, methods = { "rk8pd" }, quiet = true,
      plot = svg })
    local file = h.slurp(svg)
    os.remove(svg)
    assert.truthy(file and file:find("<svg", 1, true), "an SVG file")
  end)

  it("in a notebook: the table as HTML from its rows, the diagram inline", function()
    local display, frontend = require "nz.draw.display", require "nz.base.frontend"
    -- a front-end that renders text and HTML and keeps what it is given
    local fe = { name = "test", accepts = { ["text/plain"] = true, ["text/html"] = true }, shown = {} }
    function fe.publish(data, kind) fe.shown[#fe.shown + 1] = { data = data, kind = kind } end
    function fe.print(s) display.show(display.of(s)) end
    function fe.progress() return true end
    local gnuplot = os.execute("command -v gnuplot >/dev/null 2>&1")
    frontend.use(fe)
    display.keep_tables(true)
    local P = 2 * math.pi / w
    local ok, rows = pcall(nz.longrun, oscillator, { q0 = { 1 }, qd0 = { 0 }, t1 = 400 * P, period = P, samples = 400,
      methods = { "rk8pd" }, plot = gnuplot or nil })
    frontend.use(nil)
    display.keep_tables(false)
    assert(ok, rows)
    local html = fe.shown[1] and fe.shown[1].data["text/html"]
    assert(html and html:find("Long run of &#39;lr oscillator&#39;", 1, true) or html:find("Long run of 'lr oscillator'",
      1, true), tostring(html))
    -- the row's own numbers in their cells: its exponent and its final error
    assert.truthy(html:find(('<td style="text-align:right">t^%.2f</td>'):format(rows[1].exponent), 1, true), html)
    assert.truthy(html:find(('<td style="text-align:right">%.2e</td>'):format(rows[1].final), 1, true), html)
    if not gnuplot then return end   -- (the diagram needs gnuplot)
    local img = fe.shown[2] and fe.shown[2].data["text/html"]
    local svg = img and h.img_data(img, "image/svg+xml")
    assert(svg and svg:find("<svg", 1, true) and svg:find("long run: lr oscillator", 1, true), tostring(img):sub(1, 200))
  end)

  it("bad options: one error naming it, from the caller's line", function()
    local base = { q0 = { 1 }, qd0 = { 0 }, t1 = 1, quiet = true }
    local function with(changes)
      local o = {}
      for k, v in pairs(base) do o[k] = v end
      for k, v in pairs(changes) do o[k] = v end
      return o
    end
    h.option_errors(nz.longrun, oscillator, base, {
      { { methods = { "rk9" } }, "option 'methods': methods[1] = 'rk9' is not a method (did you mean 'rk2'?)" },
      { { methods = { 5 } }, "option 'methods': methods[1] must be a method's name or a table {method = ..." },
      { { methods = { "rk4", "rk4" } }, "option 'methods': 'rk4' is listed twice (methods[1] and methods[2])" },
      { { integrals = { L = 5 } }, "option 'integrals': each entry must be name = function(t, q, qd)" },
      { { integrals = { energy = false } }, "option 'integrals': nothing to watch" },
      { { samples = 3 }, "option 'samples': an integer >= 10 expected" },
      { { tol = -1 }, "option 'tol': a positive number expected" },
      { { simulate = { step = 0.1 } }, "option 'simulate': 'step' is set by the study for each run" },
      { { perod = 1 }, "unknown option 'perod' (did you mean 'period'?)" },
      -- an integral that is not a finite number where the run has been
      { { methods = { "rk8pd" }, integrals = { L = function() return 0 / 0 end } }, "option 'integrals': 'L' gave NaN at "
        .. "t = 0.0, q = {1}, qd = {0} (method rk8pd): a finite number expected" },
      { { methods = { "rk8pd" }, integrals = { L = function(t) return t < 0.5 and 1 or "one" end } }, "option "
        .. "'integrals': 'L' gave the string \"one\" at t = 0.5, q = {" },
    })
    local ok, msg = pcall(nz.longrun, base)
    assert.is_false(ok)
    assert.truthy(msg:find("bad argument #1 to 'longrun' (a system from nz.system{...} expected", 1, true), msg)
    -- a method that fails says so in its rows, the others run
    local rows = nz.longrun(oscillator, with{ methods = { "rk8pd", { method = "variational" } } })
    assert.are.equal("failed", rows[2].status)
    assert.truthy(rows[2].message:find("method 'variational' takes a fixed step", 1, true), rows[2].message)
  end)
end)
