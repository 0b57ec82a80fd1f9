-- workprecision_spec.lua - nz.workprecision: what accuracy costs in time.
-- The errors are checked against a closed form written here (the harmonic
-- oscillator), the table's rows against the runs themselves, and the
-- flags (a grid that sets the steps, methods that do not apply) against
-- what each run did.  The timing procedure (warm-up, repetitions, one
-- evaluator) against the system's own graph_info and the study's budget,
-- the flags, the noise and the x axis against rows written by hand, and
-- the whole procedure by its reproducibility: the same study twice.
local h = require "tests.helpers"
local nz = h.nz

local w = 1.5
local oscillator = nz.system{ name = "wp oscillator", coords = { "x" },
  T = function(t, q, qd) return qd[1] ^ 2 / 2 end, V = function(t, q) return w * w * q[1] ^ 2 / 2 end }
local function exact(t) return { math.cos(w * t) } end

describe("nz.workprecision", function()
  it("one row per method and tolerance, errors against the closed form, tighter is more accurate", function()
    local rows = nz.workprecision(oscillator, { budget = 0.01, q0 = { 1 }, qd0 = { 0 }, t1 = 10, dt = 1, methods = { "rk8pd", "taylor" },
      tols = { 1e-5, 1e-10 }, reference = exact, quiet = true })
    assert.are.equal(4, #rows)
    local by = {}
    for _, r in ipairs(rows) do
      assert.are.equal("done", r.status)
      by[r.method .. r.tol] = r
      -- the error is the run's own, against cos(w t) on the grid (rtol = tol, atol = tol / 100):
      -- measured at most 30 tol over these 15 periods
      local tr = oscillator:simulate{ q0 = { 1 }, qd0 = { 0 }, t1 = 10, dt = 1, method = r.method, rtol = r.tol,
        atol = r.tol * 1e-2 }
      local worst = 0
      for i = 1, #tr.t do worst = math.max(worst, math.abs(tr.q[i][1] - exact(tr.t[i])[1])) end
      assert.are.equal(worst, r.error)
      assert(r.error <= 1e2 * r.tol, ("%s at %g: error %.3g"):format(r.method, r.tol, r.error))
      assert(r.time > 0 and r.nfev > 0 and r.steps > 0)
    end
    assert(by["rk8pd1e-10"].error < by["rk8pd1e-05"].error)
    assert(by["rk8pd1e-10"].nfev > by["rk8pd1e-05"].nfev)
  end)

  it("flags the rows whose steps the output grid set, and says so under the table", function()
    -- dt = 0.01 over 10 s: 1000 outputs, more than rk8pd needs at 1e-5
    -- (about 60 steps with dt = 10); rk8pd reads its points off its dense
    -- output and taylor off the series; msbdf (no dense output unless
    -- asked) and rk8pd with dense = false stop at every output time
    local rows = nz.workprecision(oscillator, { budget = 0.01, q0 = { 1 }, qd0 = { 0 }, t1 = 10, dt = 0.01,
      methods = { "rk8pd", "taylor", "msbdf" }, tols = { 1e-5 }, reference = exact, quiet = true })
    local text = require("nz.analysis.workprecision").table(rows)
    assert.is_false(rows[1].grid)
    assert(rows[1].steps < 100, rows[1].steps)
    assert.is_false(rows[2].grid)
    assert(rows[2].steps < 100, rows[2].steps)
    assert.is_true(rows[3].grid)
    assert.truthy(text:find("%(grid%)"), text)
    assert.truthy(text:find("the output grid, not the tolerance, set these steps", 1, true), text)
    local off = nz.workprecision(oscillator, { budget = 0.01, q0 = { 1 }, qd0 = { 0 }, t1 = 10, dt = 0.01, simulate = { dense = false },
      methods = { "rk8pd" }, tols = { 1e-5 }, reference = exact, quiet = true })
    assert.is_true(off[1].grid)
    assert(off[1].steps >= 1000, off[1].steps)
    local coarse = nz.workprecision(oscillator, { budget = 0.01, q0 = { 1 }, qd0 = { 0 }, t1 = 10, dt = 10,
      methods = { "rk8pd" }, tols = { 1e-5 }, reference = exact, quiet = true })
    assert.is_false(coarse[1].grid)
    assert.is_nil(require("nz.analysis.workprecision").table(coarse):find("(grid)", 1, true))
  end)

  it("a method that does not apply gets one row that says why", function()
    local osc = nz.system{ name = "oscillator in Lua", coords = { "x" }, compile = false,
      T = function(t, q, qd) return qd[1] ^ 2 / 2 end, V = function(t, q) return q[1] ^ 2 / 2 end }
    local rows = nz.workprecision(osc, { budget = 0.01, q0 = { 1 }, t1 = 1, dt = 0.5,
      methods = { "rk8pd", "taylor" }, tols = { 1e-6, 1e-8 }, quiet = true })
    local text = require("nz.analysis.workprecision").table(rows)
    local skipped = 0
    for _, r in ipairs(rows) do
      if r.method == "taylor" then
        assert.are.equal("skipped", r.status)
        assert.are.equal("skipped: not recorded", r.message)
        skipped = skipped + 1
      else
        assert.are.equal("done", r.status)
      end
    end
    assert.are.equal(2, skipped)
    assert.truthy(text:find("skipped: not recorded", 1, true), text)
  end)

  it("the variational integrators run at step = tol^(1/order), and are skipped, with the reason, where they do not "
    .. "apply", function()
    local rows = nz.workprecision(oscillator, { budget = 0.01, q0 = { 1 }, qd0 = { 0 }, t1 = 10, dt = 1,
      methods = { "variational", "variational4" }, tols = { 1e-4, 1e-8 }, reference = exact, quiet = true })
    assert.are.equal(4, #rows)
    for _, r in ipairs(rows) do
      local p = r.method == "variational" and 2 or 4
      -- steps of tol^(1/p) (no longer than dt = 1), equal and landing on each output time: ceil(1 / h) a unit of time
      local hstep = math.min(1, r.tol ^ (1 / p))
      assert.are.equal(10 * math.ceil(1 / hstep - 1e-9), r.steps)
      -- the error, C h^p with C about 1 (w = 1.5 over 10 s): measured 0.2 to 0.3 tol at order 2, 1e-3 to 0.2 at 4
      assert(r.error <= 10 * r.tol, ("%s at %g: error %.3g"):format(r.method, r.tol, r.error))
    end
    local sleigh = require("tests.constraint_systems").sleigh()
    local rs = nz.workprecision(sleigh.sys, { budget = 0.01, q0 = { 0, 0, 0 }, qd0 = { 1, 0, 0.5 }, t1 = 1,
      methods = { "rk8pd", "variational" }, tols = { 1e-6 }, quiet = true })
    local text = require("nz.analysis.workprecision").table(rs)
    assert.are.equal("skipped", rs[2].status)
    assert.truthy(rs[2].message:find("skipped: takes holonomic constraints (on q and t), and constraint 1 is on q' "
      .. "(nonholonomic", 1, true), rs[2].message)
    assert.truthy(text:find("skipped: takes holonomic constraints", 1, true), text)
    local measured = require("nz.analysis.workprecision").table(rows)
    assert.truthy(measured:find("variational (of order p: variational, variational4, 6, 8): fixed steps, step = "
      .. "tol^(1/p)", 1, true), measured)
  end)

  it("taylor's rows for a system with a velocity constraint (the sleigh), against rk8pd's reference", function()
    local cs = require "tests.constraint_systems"
    local s = cs.sleigh()
    local rows = nz.workprecision(s.sys, { budget = 0.01, q0 = { 0, 0, 0 }, qd0 = { 1, 0, 0.5 }, t1 = 5, dt = 0.5,
      methods = { "taylor" }, tols = { 1e-6, 1e-9 }, quiet = true })
    for _, r in ipairs(rows) do
      assert.are.equal("done", r.status)
      -- the global error against rk8pd at 1e-13: within 10 tol (measured
      -- far below: taylor's steps keep well inside their tolerance)
      assert(r.error <= 10 * r.tol, ("tol %g: error %.3g"):format(r.tol, r.error))
    end
  end)
end)

-- A system whose machine code is not in the cache: a constant of its own
-- (numbers read from upvalues are baked into the graph, so its plans hash
-- to new objects), made with `native` as given.
local fresh_count = 0
local function fresh_kepler(native)
  fresh_count = fresh_count + 1
  local mu = 1 + ((require("nz.core").mech.now() * 1e6) % 1e6 + fresh_count / 7) * 1e-13
  return nz.system{ name = "fresh Kepler " .. fresh_count, coords = { "r", "phi" }, native = native,
    T = function(t, q, qd) return 0.5 * (qd[1] ^ 2 + q[1] ^ 2 * qd[2] ^ 2) end,
    V = function(t, q) return -mu / q[1] end }
end
-- e = 0.6, a = 1: ten orbits from the periapsis, 80 output points
local kepler_start = { q0 = { 0.4, 0 }, qd0 = { 0, math.sqrt(1.6 / 0.4) / 0.4 }, t1 = 20 * math.pi, dt = math.pi / 4 }
local function study_opts(extra)
  local o = {}
  for k, v in pairs(kepler_start) do o[k] = v end
  for k, v in pairs(extra) do o[k] = v end
  o.quiet = true
  return o
end

describe("nz.workprecision's timing", function()
  it("a warm-up run per method is not timed (the compile is reported apart); each point runs at least 3 times "
    .. "and until its budget is spent; the table gives the minimum, median and maximum", function()
    local sys = fresh_kepler()
    local before = sys:graph_info()
    assert.are.equal(0, before.native_plans)
    local rows = nz.workprecision(sys, study_opts{ methods = { "rk8pd", "rk4" }, tols = { 1e-6, 1e-9 }, budget = 0.05 })
    local study, info = rows.study, sys:graph_info()
    local native = os.getenv("NZLUA_NATIVE") ~= "0"
    -- the plan rk8pd and rk4 use was compiled in the untimed part, which
    -- says so with graph_info's own figures
    assert.are.equal(info.native_plans - before.native_plans, study.compiled)
    assert.are.equal(info.native_seconds - before.native_seconds, study.compile_seconds)
    local text = require("nz.analysis.workprecision").table(rows)
    if native then
      assert(info.native_plans >= 1 and study.compile_seconds > 0, info.native_plans)
      assert.truthy(text:find(("of which %.3g s compiling %d plan"):format(study.compile_seconds, study.compiled), 1, true),
        text)
    end
    assert.are.equal(4, #rows)
    for _, r in ipairs(rows) do
      local what = ("%s at %g: %d runs, %.3g / %.3g / %.3g s"):format(r.method, r.tol, r.runs or 0, r.time or 0,
        r.time_median or 0, r.time_max or 0)
      assert(r.runs and r.runs >= 3, what)
      assert(r.time <= r.time_median and r.time_median <= r.time_max and r.wall > 0, what)
      -- no timed run paid the compiler (on main the first point's run did)
      assert(not native or r.time_max < study.compile_seconds, what)
      -- the point stopped once it had spent its budget: each run's wall
      -- time is at least its processor time, so before the last run the
      -- runs had less than 0.05 s of it
      assert(r.runs == 3 or (r.runs - 1) * r.time < 0.05, what)
      -- each row in the table: min, median, max, runs
      assert.truthy(text:find(("%%s%s%%s+%s%%s+%s%%s+%d%%s"):format(("%.3g"):format(r.time):gsub("%.", "%%."),
        ("%.3g"):format(r.time_median):gsub("%.", "%%."), ("%.3g"):format(r.time_max):gsub("%.", "%%."), r.runs)), text)
    end
    -- a larger budget, more runs of the same point (the cheapest: far below
    -- the budget even on a slow machine)
    local small = nz.workprecision(sys, study_opts{ methods = { "rk8pd" }, tols = { 1e-6 }, budget = 0.01 })
    local large = nz.workprecision(sys, study_opts{ methods = { "rk8pd" }, tols = { 1e-6 }, budget = 0.1 })
    assert(large[1].runs > small[1].runs, ("%d runs with 0.1 s, %d with 0.01 s"):format(large[1].runs, small[1].runs))
  end)

  it("the budget is the runs' own time, however large the session's heap (collections are neither timed nor counted)",
    function()
    -- a million live tables: a full collection here costs more than a run
    -- of the cheap point, so a budget that counted one before every run (the
    -- first version) was spent on collections and both studies ran 3 times
    local sys = fresh_kepler()
    local live = {}
    for i = 1, 1000000 do live[i] = { i } end
    local t0 = os.clock()
    collectgarbage()
    local one_collection = os.clock() - t0
    local small = nz.workprecision(sys, study_opts{ methods = { "rk8pd" }, tols = { 1e-6 }, budget = 0.01 })
    local large = nz.workprecision(sys, study_opts{ methods = { "rk8pd" }, tols = { 1e-6 }, budget = 0.1 })
    live = nil
    collectgarbage()
    assert(large[1].runs > small[1].runs, ("%d runs with 0.1 s, %d with 0.01 s (a full collection took %.3g s)"):format(
      large[1].runs, small[1].runs, one_collection))
    -- the budget was spent on runs: all but the last run fit in it
    assert(large[1].runs == 3 or (large[1].runs - 1) * large[1].time < 0.1, large[1].runs)
  end)

  it("one evaluator for the whole study, named in its title; the system's own setting restored", function()
    local native_off = os.getenv("NZLUA_NATIVE") == "0"
    -- the machine-code setting as the study sets it (the compiled object's
    -- set_native: true, false, or nil for "once it has earned it")
    local methods = getmetatable(fresh_kepler().engine.recording).__index
    local set_native, calls = methods.set_native, {}
    methods.set_native = function(c, v) calls[#calls + 1] = tostring(v); return set_native(c, v) end
    local function study(sys)
      calls = {}
      local ok, rows = pcall(nz.workprecision, sys, study_opts{ methods = { "rk8pd", "taylor" }, tols = { 1e-6 },
        budget = 0.01 })
      return ok, rows
    end
    local sys, on, interp = fresh_kepler(), fresh_kepler(true), fresh_kepler(false)
    local ok, rows = study(sys)
    local auto_calls = calls
    local ok_on = study(on)
    local on_calls = calls
    local ok_off, rows_off = study(interp)
    local off_calls = calls
    methods.set_native = set_native
    assert(ok and ok_on and ok_off, tostring(rows))
    local info = sys:graph_info()
    if native_off then
      assert.truthy(tostring(rows):find("\nevaluator: interpreted graphs", 1, true), tostring(rows))
      assert.are.equal(0, info.native_plans)
      assert.are.same({}, auto_calls)
    else
      -- rk8pd's plan and taylor's series both machine code, before the
      -- timing: compiled at their first use, and the default restored
      assert.truthy(tostring(rows):find("\nevaluator: machine code (2 plans, of them 1 series)", 1, true), tostring(rows))
      assert.are.equal(2, info.native_plans)
      assert.are.equal(1, info.native_series)
      -- (nil: once it has earned it; under NZLUA_NATIVE=1 the system's
      -- own setting is at first use)
      assert.are.same({ "true", os.getenv("NZLUA_NATIVE") == "1" and "true" or "nil" }, auto_calls)
    end
    assert.are.same({ "true", "true" }, on_calls)
    -- a system made with native = false runs interpreted throughout
    assert.are.same({}, off_calls)
    assert.truthy(tostring(rows_off):find("\nevaluator: interpreted graphs (machine code off: native = false, or NZLUA_NATIVE=0)",
      1, true), tostring(rows_off))
    assert.are.equal(0, interp:graph_info().native_plans)
    -- and a system that is not recorded runs its Lua functions
    local lua = nz.system{ name = "Kepler in Lua", coords = { "r", "phi" }, compile = false,
      T = function(t, q, qd) return 0.5 * (qd[1] ^ 2 + q[1] ^ 2 * qd[2] ^ 2) end, V = function(t, q) return -1 / q[1] end }
    rows = nz.workprecision(lua, study_opts{ methods = { "rk8pd" }, tols = { 1e-6 }, budget = 0.01, t1 = 2 })
    assert.truthy(tostring(rows):find("\nevaluator: Lua functions", 1, true), tostring(rows))
  end)

  it("the same study twice in one process: the same ranking of the methods, each time within the other's spread #slow",
    function()
    -- A fresh system: the first study pays its compile in the warm-up, not
    -- in a timed run.  rk8pd, rkf45 and rk4 on Kepler: at 1e-9 about 1, 2
    -- and 4.5 ms (far apart), at 1e-6 rk8pd and rkf45 within 10 % of each
    -- other, which the study must call within the noise or rank the same
    -- way twice.  Each point runs 10 to 100 times; its processor time
    -- (other programs add none) has a minimum that moved by at most 2.2 %
    -- between studies at load average 4 on 2 cores.  Under heavier load
    -- the machine's speed itself moves, every point of a study by the same
    -- factor (30 % measured between two studies a second apart): the times
    -- are compared up to that one factor, the median of the ratios.
    -- A timing on a shared machine can still be thrown off by a burst of
    -- load that hits one study only: the pair of studies is tried up to
    -- three times and must agree once (a study whose ranking or spread is
    -- wrong fails all three).  (Not under the sanitizers: their timings say
    -- nothing of the methods.)
    local wp = require "nz.analysis.workprecision"
    local sys = fresh_kepler()
    local o = study_opts{ methods = { "rk4", "rkf45", "rk8pd" }, tols = { 1e-6, 1e-9 }, budget = 0.05 }
    local function attempt()
      local a = nz.workprecision(sys, o)
      local b = nz.workprecision(sys, o)
      assert.are.equal(6, #a)
      assert.are.equal(6, #b)
      local ratios = {}
      for i = 1, #a do ratios[i] = b[i].time / a[i].time end
      table.sort(ratios)
      local speed = (ratios[3] + ratios[4]) / 2
      local compared = 0
      for i, r in ipairs(a) do
        local s = b[i]
        assert.are.equal(r.method .. r.tol, s.method .. s.tol)
        -- the ranges of the runs overlap (a study that reports no spread
        -- has a range of one time)
        assert(r.time * speed <= (s.time_max or s.time) and s.time <= (r.time_max or r.time) * speed,
          ("%s at %g: the first study %.3g .. %.3g s, the second %.3g .. %.3g s (machine %.2fx)"):format(r.method, r.tol,
            r.time, r.time_max or r.time, s.time, s.time_max or s.time, speed))
        for j = i + 1, #a do
          local r2, s2 = a[j], b[j]
          -- two methods at one tolerance that either study tells apart are
          -- in the same order in both
          if r2.tol == r.tol and not (wp.within_noise(r, r2) and wp.within_noise(s, s2)) then
            compared = compared + 1
            assert((r.time < r2.time) == (s.time < s2.time), ("%s and %s at %g: %.3g and %.3g s, then %.3g and %.3g s")
              :format(r.method, r2.method, r.tol, r.time, r2.time, s.time, s2.time))
          end
        end
      end
      -- rk8pd before rk4 at 1e-9 in both (4x apart: never within the noise)
      assert(a[6].time < a[2].time and b[6].time < b[2].time)
      assert(compared >= 1)
    end
    local ok, err
    for _ = 1, 3 do
      ok, err = pcall(attempt)
      if ok then break end
    end
    assert(ok, err)
  end)
end)

describe("nz.workprecision's flags, noise and axes", function()
  local wp = require "nz.analysis.workprecision"
  -- rows as a study returns them, written by hand
  local function row(method, tol, err, time, median, nfev, steps)
    return { method = method, tol = tol, error = err, time = time, time_median = median or time, time_max = median or time,
      runs = 5, nfev = nfev or 1000, steps = steps or 100, status = "done" }
  end

  it("flags a row whose error grows as the tolerance tightens: in the table, the summary and apart in the diagram", function()
    -- bsimp on Kepler as the issue measured it (9.2e-5 at 1e-4, 8.6e-3 at
    -- 1e-6), taylor's 2.1e-6 at 1e-6 and 2.7e-6 at 1e-8
    local rows = { row("bsimp", 1e-4, 9.2e-5, 0.28), row("bsimp", 1e-6, 8.6e-3, 0.38), row("bsimp", 1e-8, 3.6e-7, 0.56),
      row("taylor", 1e-6, 2.1e-6, 0.01), row("taylor", 1e-8, 2.7e-6, 0.012), row("taylor", 1e-10, 1e-9, 0.015),
      row("rk8pd", 1e-6, 1e-4, 0.02), row("rk8pd", 1e-8, 1e-6, 0.03) }
    wp.flag(rows)
    local flagged = {}
    for _, r in ipairs(rows) do if r.flag then flagged[#flagged + 1] = r.method .. " " .. r.tol end end
    -- bsimp's 1e-8 row (3.6e-7) is below its loosest one: not flagged
    assert.are.same({ "bsimp 1e-06", "taylor 1e-08" }, flagged)
    local text = wp.table(rows)
    assert.truthy(text:find("8.60e-03 !", 1, true), text)
    assert.truthy(text:find("2.70e-06 !", 1, true), text)
    assert.falsy(text:find("9.20e-05 !", 1, true), text)
    assert.truthy(text:find("!: the error grew as the tolerance tightened (bsimp at 1e-06, taylor at 1e-08)", 1, true), text)
    -- the recommendation leaves them out: taylor at 1e-8 (0.012 s, error
    -- 2.7e-6) would otherwise be the cheapest below 1e-5
    local advice = wp.recommend(rows)
    assert.falsy(advice:find("taylor at tol 1e-08", 1, true), advice)
    -- the diagram: the method's line without them, and a series of its own
    -- with the method in each label
    local drawn = h.plotted(wp.diagram, rows, { quiet = true })
    local by = {}
    for _, s in ipairs(drawn.series) do by[s.name] = s end
    assert.are.same({ 0.28, 0.56 }, by.bsimp.x)
    assert.are.same({ 0.01, 0.015 }, by.taylor.x)
    local odd = by["error grew as tol tightened"]
    assert.are.same({ 0.38, 0.012 }, odd.x)
    assert.are.same({ 8.6e-3, 2.7e-6 }, odd.y)
    assert.are.same({ "bsimp 1e-06", "taylor 1e-08" }, odd.labels)
    assert.truthy(odd.style:find("^points"), odd.style)
  end)

  it("the x axis can be the time, the right-hand-side evaluations or the steps", function()
    local rows = { row("rk4", 1e-6, 1e-3, 0.002, nil, 9249, 812), row("rk4", 1e-9, 1e-5, 0.006, nil, 30413, 2736),
      row("taylor", 1e-6, 1e-6, 0.001, nil, 511, 511), row("taylor", 1e-9, 1e-9, 0.0015, nil, 480, 480) }
    local function draw(x)
      local drawn = h.plotted(wp.diagram, rows, { quiet = true, x = x })
      local by = {}
      for _, s in ipairs(drawn.series) do by[s.name] = s end
      return by, drawn
    end
    local by, d = draw("time")
    assert.are.same({ 0.002, 0.006 }, by.rk4.x)
    assert.truthy(d.xlabel:find("processor time (s)", 1, true), d.xlabel)
    by, d = draw("steps")
    assert.are.same({ 812, 2736 }, by.rk4.x)
    assert.are.same({ 511, 480 }, by.taylor.x)
    assert.are.equal("steps", d.xlabel)
    -- taylor's evaluations are series (of order ~10), not right-hand
    -- sides: left out of that axis, and the title says so
    by, d = draw("nfev")
    assert.are.same({ 9249, 30413 }, by.rk4.x)
    assert.is_nil(by.taylor)
    assert.are.equal("right-hand-side evaluations", d.xlabel)
    assert.truthy(d.title:find("taylor left out: its evaluations are series", 1, true), d.title)
    -- the study takes x and draws with it
    local svg = os.tmpname() .. ".svg"
    nz.workprecision(oscillator, { budget = 0.01, q0 = { 1 }, qd0 = { 0 }, t1 = 10, methods = { "rk8pd" }, tols = { 1e-6, 1e-8 },
      reference = exact, budget = 0.01, quiet = true, x = "nfev", plot = svg })
    local file = assert(h.slurp(svg))
    os.remove(svg)
    assert.truthy(file:find("right-hand-side evaluations", 1, true))
  end)

  it("the recommendation says when two methods are within the noise of each other", function()
    -- at error <= 1e-4: rk8pd 1.00 ms (its median 1.10), taylor 1.15 ms
    -- (within NOISE_FLOOR = 20 %), rkf45 1.30 ms (above 1.2 and above
    -- rk8pd's median: told apart), rk4 2.0 ms
    assert.are.equal(0.2, wp.NOISE_FLOOR)
    local rows = { row("rk8pd", 1e-6, 5e-5, 1.00e-3, 1.10e-3), row("taylor", 1e-6, 6e-5, 1.15e-3, 1.2e-3),
      row("rkf45", 1e-7, 7e-5, 1.30e-3, 1.4e-3), row("rk4", 1e-8, 8e-5, 2.0e-3, 2.1e-3) }
    assert.are.equal("cheapest for each accuracy: error <= 1e-4: rk8pd at tol 1e-06 (0.001 s), within the noise of "
      .. "taylor at tol 1e-06 (0.00115 s)", wp.recommend(rows))
    -- runs that spread more: rk8pd's median 1.35 ms, above rkf45's fastest
    -- run, which is then within the noise too
    rows[1].time_median = 1.35e-3
    assert.are.equal("cheapest for each accuracy: error <= 1e-4: rk8pd at tol 1e-06 (0.001 s), within the noise of "
      .. "taylor at tol 1e-06 (0.00115 s) and rkf45 at tol 1e-07 (0.0013 s)", wp.recommend(rows))
    assert.truthy(wp.within_noise(rows[3], rows[1]))
    assert.falsy(wp.within_noise(rows[1], rows[4]))
  end)
end)

describe("nz.workprecision's options", function()
  local base = { q0 = { 1 }, qd0 = { 0 }, t1 = 1, methods = { "rk8pd" }, tols = { 1e-6 }, reference = exact, quiet = true,
    budget = 0.01 }
  it("an unknown method, a tolerance <= 0, a bad option: one error naming it, from the caller's line", function()
    h.option_errors(nz.workprecision, oscillator, base, {
      { { methods = { "rk8pd", "rk9" } }, "option 'methods': methods[2] = 'rk9' is not a method (did you mean 'rk2'?) "
        .. "(the methods: rk2 rk4 rkf45 rkck rk8pd rk1imp rk2imp rk4imp bsimp msadams msbdf taylor variational "
        .. "variational4 variational6 variational8)" },
      { { methods = { "rk8pd", "rk8pd" } }, "option 'methods': 'rk8pd' is listed twice (methods[1] and methods[2])" },
      { { methods = {} }, "option 'methods': a non-empty list expected" },
      { { tols = { 1e-6, 0 } }, "option 'tols': tols[2] = 0: a tolerance from 1e-15 to 1 (each run takes rtol = tol, "
        .. "atol = tol / 100) expected" },
      { { tols = { -1e-6 } }, "option 'tols': tols[1] = -1e-06: a tolerance from 1e-15 to 1" },
      { { tols = { 1e-6, 1e-6 } }, "option 'tols': 1e-06 is listed twice (tols[1] and tols[2])" },
      { { budget = 0 }, "option 'budget': seconds per point, a positive number expected, got 0" },
      { { x = "work" }, "option 'x': \"time\", \"nfev\" or \"steps\" expected, got the string \"work\"" },
      { { plot = "diagram.pdf" }, "option 'plot': true, or a file name ending in .svg or .png expected" },
      { { reference = 5 }, "option 'reference': a function(t) returning q expected, got 5" },
      { { budgte = 1 }, "unknown option 'budgte' (did you mean 'budget'?)" },
      { { simulate = { rtol = 1e-3 } }, "option 'simulate': 'rtol' is set by the study for each run" },
      -- simulate's own checks, once instead of a failed row per method
      { { q0 = { 1, 2 } }, "simulate 'wp oscillator': 'q0' must be a table of 1 numbers" },
      { { simulate = { dens = false } }, "unknown option 'dens' (did you mean 'dense'?)" },
    })
    -- the first argument
    local line = debug.getinfo(1, "l").currentline + 1
    local ok, msg = pcall(nz.workprecision, base)
    assert.is_false(ok)
    assert.truthy(msg:find(("^[^:]*workprecision_spec.lua:%d: bad argument #1 to 'workprecision' %%(a system from "
      .. "nz.system{...} expected"):format(line)), msg)
  end)
end)
