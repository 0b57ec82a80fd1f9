-- simulate_taylor_spec.lua - sys:simulate{method = "taylor"} on free recorded
-- systems: closed forms, agreement with rk8pd on the same output
-- grid, Ctrl-C keeping the partial trajectory, failures and refusals.
-- Every bound says why it is what it is.
local h = require "tests.helpers"
local nz = h.nz
local function mech_order(tol) return require("nz.core").mech.taylor_order(tol) end

local function oscillator()
  return nz.system{ name = "oscillator", coords = { "x" },
    T = function(t, q, qd) return qd[1] ^ 2 / 2 end, V = function(t, q) return 2.25 * q[1] ^ 2 / 2 end }
end

describe("simulate with method = 'taylor'", function()
  it("oscillator against x0 cos wt + v0/w sin wt: q, qd, qdd and the energy monitor", function()
    local w, x0, v0 = 1.5, 0.7, -1.3
    local tr = oscillator():simulate{ q0 = { x0 }, qd0 = { v0 }, t1 = 100, dt = 0.1, method = "taylor",
      rtol = 1e-14, atol = 1e-14, monitors = { energy = true } }
    assert.equal("done", tr.status)
    assert.equal(1001, #tr.t)
    assert.equal(100, tr.t[#tr.t])
    local worst, dE = 0, 0
    local E0 = v0 ^ 2 / 2 + w * w * x0 ^ 2 / 2
    for i = 1, #tr.t do
      local t = tr.t[i]
      local x, v = x0 * math.cos(w * t) + v0 / w * math.sin(w * t), -x0 * w * math.sin(w * t) + v0 * math.cos(w * t)
      worst = math.max(worst, math.abs(tr.q[i][1] - x), math.abs(tr.qd[i][1] - v), math.abs(tr.qdd[i][1] + w * w * x))
      dE = math.max(dE, math.abs(tr.energy[i] - E0))
    end
    -- 24 periods at tol 1e-14 in ~110 steps: the phase error grows by
    -- ~1e-15 per step (taylor_spec's oscillator: 1.1e-14 after 100
    -- periods).  Measured 3.7e-14 (energy 3.3e-15); bound 1e-12 (the cos/sin
    -- of the reference at w t ~ 150 carry ~1e-14 each; 25x the measure).
    assert(worst <= 1e-12, ("error %.3g"):format(worst))
    assert(dE <= 1e-13, ("energy error %.3g"):format(dE))
    assert.equal(0, tr.stats.rejected)
    assert.equal(tr.stats.steps, tr.stats.nfev)        -- one series per step
    assert.equal(18, tr.stats.order)  -- ceil(-ln(1e-14)/2 + 1) = 18
  end)

  it("Kepler, e = 0.6, 10 orbits: energy and angular momentum, and the position against Kepler's equation", function()
    local kep = nz.system{ name = "kepler", coords = { "x", "y" },
      T = function(t, q, qd) return (qd[1] ^ 2 + qd[2] ^ 2) / 2 end,
      V = function(t, q) return -1 / nz.sqrt(q[1] ^ 2 + q[2] ^ 2) end }
    local e, P = 0.6, 2 * math.pi
    local function at(t)
      local M = math.fmod(t, 2 * math.pi)
      local E = M + e * math.sin(M)
      for _ = 1, 60 do E = E - (E - e * math.sin(E) - M) / (1 - e * math.cos(E)) end
      return math.cos(E) - e, math.sqrt(1 - e * e) * math.sin(E)
    end
    local tr = kep:simulate{ q0 = { 1 - e, 0 }, qd0 = { 0, math.sqrt((1 + e) / (1 - e)) }, t1 = 10 * P, dt = P / 32,
      method = "taylor", rtol = 1e-15, atol = 1e-15 }
    local L0 = (1 - e) * math.sqrt((1 + e) / (1 - e))
    local worst, dE, dL = 0, 0, 0
    for i = 1, #tr.t do
      local q, v = tr.q[i], tr.qd[i]
      local x, y = at(tr.t[i])
      worst = math.max(worst, math.abs(q[1] - x), math.abs(q[2] - y))
      dE = math.max(dE, math.abs((v[1] ^ 2 + v[2] ^ 2) / 2 - 1 / math.sqrt(q[1] ^ 2 + q[2] ^ 2) + 0.5))
      dL = math.max(dL, math.abs(q[1] * v[2] - q[2] * v[1] - L0))
    end
    -- As taylor_spec's Kepler run (3.6e-13 after 20 orbits; bound 1e-10),
    -- here over 10 orbits.  Energy -1/2 and angular
    -- momentum 1.2: 1e-13 relative, as Henon-Heiles (measured 3.6e-13
    -- position, 1.8e-15 energy, 1.0e-15 angular momentum).
    assert(worst <= 1e-10, ("position error %.3g"):format(worst))
    assert(dE <= 0.5e-13, ("energy error %.3g"):format(dE))
    assert(dL <= 1.2e-13, ("angular momentum error %.3g"):format(dL))
  end)

  it("Henon-Heiles: the same output grid as rk8pd, and agreement at tight tolerance", function()
    local hh = nz.system{ name = "henon-heiles", coords = { "x", "y" },
      T = function(t, q, qd) return (qd[1] ^ 2 + qd[2] ^ 2) / 2 end,
      V = function(t, q) return (q[1] ^ 2 + q[2] ^ 2) / 2 + q[1] ^ 2 * q[2] - q[2] ^ 3 / 3 end }
    local o = { q0 = { 0, -0.1 }, qd0 = { 0.5, 0 }, t1 = 20, dt = 0.37, rtol = 1e-13, atol = 1e-13 }
    local a = hh:simulate(o)
    o.method = "taylor"
    local b = hh:simulate(o)
    assert.equal(#a.t, #b.t)
    local worst = 0
    for i = 1, #a.t do
      assert.equal(a.t[i], b.t[i])                         -- the grid to the bit, t1 last
      for j = 1, 2 do
        worst = math.max(worst, math.abs(a.q[i][j] - b.q[i][j]), math.abs(a.qd[i][j] - b.qd[i][j]),
          math.abs(a.qdd[i][j] - b.qdd[i][j]))
      end
    end
    -- Both at 1e-13 over 20 time units of a regular orbit (energy 0.13, |q|
    -- < 0.6): each holds ~1e-13 per unit of time; measured agreement
    -- 3.9e-13.  Bound 1e-11: 100 steps' worth of the tolerance.
    assert(worst <= 1e-11, ("taylor vs rk8pd %.3g"):format(worst))
  end)

  it("the output grid does not change the steps: the C loop reads its points off each step's polynomial", function()
    local osc = oscillator()
    local fine = osc:simulate{ q0 = { 1 }, t1 = 50, dt = 0.05, method = "taylor", rtol = 1e-13, atol = 1e-13 }
    local coarse = osc:simulate{ q0 = { 1 }, t1 = 50, dt = 50, method = "taylor", rtol = 1e-13, atol = 1e-13 }
    assert.equal(1001, #fine.t)
    assert.equal(2, #coarse.t)
    assert.equal(coarse.stats.steps, fine.stats.steps)
    -- the same steps, so the same end state to the bit
    assert.equal(coarse.q[2][1], fine.q[#fine.q][1])
    assert.equal(coarse.qd[2][1], fine.qd[#fine.qd][1])
    assert.equal(0, fine.stats.forced)                  -- the polynomial needs no step end
    assert.equal(999, fine.stats.interpolated)          -- every point but t0 and t1 (a step end)
  end)

  it("events on the series: the pendulum's zero crossings at odd multiples of the quarter period K(k)/w", function()
    local w, th0 = 1.3, 2.5                 -- amplitude 2.5 rad: far from the small-angle period
    local pend = nz.system{ name = "pendulum", coords = { "th" },
      T = function(t, q, qd) return qd[1] ^ 2 / 2 end, V = function(t, q) return -w * w * nz.cos(q[1]) end }
    -- K(k) = pi / (2 AGM(1, sqrt(1 - k^2))), k = sin(th0 / 2): converged to
    -- rounding after 6 iterations (40 here)
    local function agm(a, b) for _ = 1, 40 do a, b = (a + b) / 2, math.sqrt(a * b) end return a end
    local kk = math.sin(th0 / 2)
    local K = math.pi / (2 * agm(1, math.sqrt(1 - kk * kk)))
    local tr = pend:simulate{ q0 = { th0 }, t1 = 40, dt = 0.1, method = "taylor", rtol = 1e-14, atol = 1e-14,
      events = { { f = function(t, q) return q[1] end, name = "zero" } } }
    assert.equal("done", tr.status)
    assert.equal(401, #tr.t)                              -- the grid whole: events add no point
    assert.equal(math.floor(40 * w / (2 * K) + 0.5), #tr.events)
    local worst = 0
    for n, e in ipairs(tr.events) do
      assert.equal("zero", e.name)
      worst = math.max(worst, math.abs(e.t - (2 * n - 1) * K / w), math.abs(e.q[1]))
    end
    -- Located to event_tol = 1e-12 (relative to max(1, t)) on the step's
    -- polynomial, which holds q to ~1e-14: measured 2.1e-14 over 10
    -- crossings up to t = 37 (rk8pd at 1e-13, locating by integrating
    -- again: 1.4e-11).  Bound 1e-11: event_tol at t ~ 10.
    assert(worst <= 1e-11, ("event times %.3g"):format(worst))
    -- direction = 1 and stop: the first rising crossing, at 3 K / w; the run
    -- ends there with the event's point last
    local st = pend:simulate{ q0 = { th0 }, t1 = 40, dt = 0.1, method = "taylor", rtol = 1e-14, atol = 1e-14,
      events = { { f = function(t, q) return q[1] end, name = "up", direction = 1, stop = true } } }
    assert.equal("stopped", st.status)
    assert.equal(1, #st.events)
    local te = st.t[#st.t]
    assert(math.abs(te - 3 * K / w) <= 1e-11, ("stop at %.17g, want %.17g"):format(te, 3 * K / w))
    assert(st.t[#st.t - 1] < te and te - st.t[#st.t - 1] <= 0.1 + 1e-12)   -- the grid up to it, then it
    assert(math.abs(st.q[#st.q][1]) <= 1e-13 and st.qd[#st.qd][1] > 0)
    assert.truthy(st.message:find("event 'up' at t = 5.955670884", 1, true), st.message)
  end)

  it("a long run says so once, goes on, and advises a looser rtol (taylor's order)", function()
    -- The oscillator takes ~1.6 steps per unit of time at 1e-14 (3,218 to
    -- t = 2000): 2e4 units project to ~3.2e4 steps, over the threshold
    -- lowered here to 2e4 (the clock's criterion off, as in
    -- simulate_options_spec).  The C loop looks at 16, 32, ... steps, as
    -- for the GSL steppers: at 2048 steps (t ~ 1300) the projection says
    -- ~3.2e4; the run stops at an event after that.
    local simulate = require "nz.motion.simulate"
    local said, saved_warn, saved_limits = {}, simulate.warn, simulate.LONG_RUN
    simulate.warn = function(msg) said[#said + 1] = msg end
    simulate.LONG_RUN = { steps = 2e4, seconds = math.huge, check_steps = 2000 }
    local ok, tr = pcall(oscillator().simulate, oscillator(), { q0 = { 0.7 }, qd0 = { -1.3 }, t1 = 2e4, dt = 1,
      method = "taylor", rtol = 1e-14, atol = 1e-14, events = { { f = function(t) return t - 8000 end, stop = true } } })
    simulate.warn, simulate.LONG_RUN = saved_warn, saved_limits
    assert(ok, tostring(tr))
    assert.are.equal("stopped", tr.status)          -- it went on, to the event
    assert.are.equal(1, #said)
    assert.are.equal(said[1], tr.warnings[1])
    local msg = said[1]
    assert.truthy(msg:find("simulate 'oscillator': warning: at its pace so far this run will take about", 1, true), msg)
    local mech = require("nz.core").mech
    local p, lp = mech.taylor_order(1e-14), mech.taylor_order(1e-11)
    assert.truthy(msg:find(("a looser rtol (taylor's order comes from it: rtol = 1e-11 takes order %d instead of %d"):format(lp, p),
      1, true), msg)
  end)
  it("Ctrl-C stops a long run and returns the part computed", function()
    local code, out = h.interrupt_script([[
local s = nz.system{ coords = {"x"}, T = function(t, q, v) return 0.5 * v[1]^2 end, V = function(t, q) return 0.5 * q[1]^2 end }
local tr = s:simulate{ q0 = {1}, t1 = 1e9, dt = 1000, rtol = 1e-12, method = "taylor" }
print("status " .. tr.status .. " points " .. #tr.t .. " last " .. tr.t[#tr.t])
]], 2)
    assert.are.equal(130, code)
    local n, last = out:match("status interrupted points (%d+) last (%S+)")
    assert(n and tonumber(n) > 1, out)
    assert.equal(1000 * (tonumber(n) - 1), tonumber(last))  -- the grid kept whole up to its last point
  end)

  it("a failure says where, keeps the points computed in nz.last: the radial fall into 1/r", function()
    local fall = nz.system{ name = "fall", coords = { "x" }, T = function(t, q, v) return 0.5 * v[1] ^ 2 end,
      V = function(t, q) return -1 / q[1] end }
    local ok, e = pcall(fall.simulate, fall, { q0 = { 1 }, t1 = 2, dt = 0.01, method = "taylor" })
    assert.is_false(ok)
    assert.truthy(e:find("^[^:]*simulate_taylor_spec%.lua:%d+: simulate 'fall': method 'taylor' stopped at t = "), e)
    assert.truthy(e:find("last output point at t = 1.11, q = {", 1, true), e)
    -- x'' = -1/x^2 from rest at x = 1 reaches 0 at t = pi / (2 sqrt 2)
    -- (the energy 1/2 v^2 - 1/x = -1 gives the cycloid's collapse time).
    -- The steps shrink like the distance to the singularity; the run stops
    -- when t + h rounds onto t: measured 1.2e-12 past the closed form (its
    -- rounding; the last steps are ~1e-16).  Bound 1e-9.
    local tstop = tonumber(e:match("stopped at t = ([^,]+), q = {"))
    assert(math.abs(tstop - math.pi / (2 * math.sqrt(2))) <= 1e-9, e)
    assert.equal("failed", nz.last.status)
    assert.equal(112, #nz.last.t)                        -- t = 0, 0.01, .., 1.11: every grid point before it
    assert.equal(1.11, nz.last.t[112])
  end)

  it("an event function that fails on a step's polynomial stops the run with where", function()
    local osc = oscillator()
    local ok, e = pcall(osc.simulate, osc, { q0 = { 1 }, t1 = 10, dt = 0.5, method = "taylor",
      events = { function(t, q) return nz.sqrt(q[1]) - 0.5 end } })
    assert.is_false(ok)
    -- x = cos(1.5 t) turns negative at t = pi / 3: the step holding it fails
    assert.truthy(e:find("simulate_taylor_spec%.lua:%d+: simulate 'oscillator': method 'taylor' stopped in the step from t = "), e)
    assert.truthy(e:find("event 1's recorded function failed", 1, true), e)
    assert.equal("failed", nz.last.status)
    assert(nz.last.t[#nz.last.t] < math.pi / 3)
  end)

  it("refuses what it does not do, from the user's line", function()
    local osc = oscillator()
    local function err(o)
      o.q0, o.t1, o.method = { 1 }, 1, "taylor"
      local ok, e = pcall(osc.simulate, osc, o)
      assert.is_false(ok)
      assert.truthy(e:find("^[^:]*simulate_taylor_spec%.lua:%d+: simulate 'oscillator': "), e)
      return e
    end
    assert.truthy(err{ step = 0.1 }:find("'step' does not apply to method 'taylor'", 1, true))
    assert.truthy(err{ h0 = 0.1 }:find("'h0' does not apply", 1, true))
    assert.truthy(err{ events = { function(t, q) if q[1] > 0 then return 1 end return -1 end } }
      :find("needs event functions it can record", 1, true))
    assert.truthy(err{ monitors = { work = true } }:find("'work' monitor", 1, true))
    assert.truthy(err{ rtol = 1e-16 }:find("'rtol' must be between", 1, true))
    local lua_sys = nz.system{ name = "oscillator", coords = { "x" }, compile = false,
      T = function(t, q, qd) return qd[1] ^ 2 / 2 end, V = function(t, q) return q[1] ^ 2 / 2 end }
    local ok, e = pcall(lua_sys.simulate, lua_sys, { q0 = { 1 }, t1 = 1, method = "taylor" })
    assert.is_false(ok)
    assert.truthy(e:find("needs a recorded system", 1, true), e)
    local vwell = nz.system{ name = "vwell", coords = { "x" },
      T = function(t, q, qd) return qd[1] ^ 2 / 2 end, V = function(t, q) return nz.abs(q[1]) end }
    ok, e = pcall(vwell.simulate, vwell, { q0 = { 1 }, t1 = 1, method = "taylor" })
    assert.is_false(ok)
    assert.truthy(e:find("simulate_taylor_spec%.lua:%d+: simulate 'vwell': method 'taylor' cannot run this system: .*branches"), e)
    -- (constraints: tests/taylor_constrained_spec.lua)
  end)
end)

-- One stepping loop for every method (src/ode/stepper.h, ode_run.c): the
-- same events problem through taylor and rk8pd, both in the C loop, with
-- the interface's statistics.  Taylor's crossings are located on the step's
-- polynomial in C; rk8pd's in Lua on its Hermite interpolant.
describe("taylor and rk8pd through the same loop", function()
  local w, th0 = 1.3, 2.5
  local pend = nz.system{ name = "pendulum", coords = { "th" },
    T = function(t, q, qd) return qd[1] ^ 2 / 2 end, V = function(t, q) return -w * w * nz.cos(q[1]) end }
  -- the quarter period K(k) / w, K(k) = pi / (2 AGM(1, sqrt(1 - k^2))), k = sin(th0 / 2)
  local function agm(a, b) for _ = 1, 40 do a, b = (a + b) / 2, math.sqrt(a * b) end return a end
  local kk = math.sin(th0 / 2)
  local K = math.pi / (2 * agm(1, math.sqrt(1 - kk * kk)))
  -- Taylor: measured 4.3e-14 (its polynomial holds q to ~1e-14, Illinois
  -- stops within event_tol); rk8pd: 5.3e-11 (event_tol = 1e-12 relative to
  -- max(1, t): 3.7e-11 at the last crossing, and the interpolant's error).
  -- Bounds: 1e-11 (as the test above) and 2e-10.
  for method, bound in pairs{ taylor = 1e-11, rk8pd = 2e-10 } do
    it(method .. ": the zero crossings at odd multiples of the quarter period, and the statistics", function()
      local tr = pend:simulate{ q0 = { th0 }, t1 = 40, dt = 0.1, method = method, rtol = 1e-13, atol = 1e-13,
        events = { { f = function(t, q) return q[1] end, name = "zero" } } }
      assert.equal("done", tr.status)
      assert.equal(401, #tr.t)
      assert.equal(math.floor(40 * w / (2 * K) + 0.5), #tr.events)
      local worst = 0
      for n, e in ipairs(tr.events) do
        worst = math.max(worst, math.abs(e.t - (2 * n - 1) * K / w), math.abs(e.q[1]))
      end
      assert(worst <= bound, ("%s: event times %.3g"):format(method, worst))
      local s = tr.stats
      assert(s.steps > 0 and s.nfev > 0 and s.rejected >= 0)
      assert.equal(method == "taylor" and mech_order(1e-13) or 8, s.order)
      if method == "taylor" then
        assert.equal(0, s.rejected)
        assert.equal(s.steps, s.nfev)                  -- one series per step
        assert.equal(0, s.forced)
      else
        assert(s.nfev >= 12 * s.steps, "rk8pd: 13 stages a step")
      end
      assert.equal(399, s.interpolated + s.forced)     -- every point but t0 and t1 off the dense output or forced
      assert.is_nil(s.grid_why)                        -- the grid set no step
    end)
  end
end)

-- The free problems of the work-precision benchmark (bench/problems.lua)
-- meet their tolerance with taylor: the closed forms of Kepler (10 orbits)
-- and of the pendulum at 2.5 rad (5 periods), the double pendulum (5 s)
-- against rk8pd at 1e-13.  The error is the worst over the output grid,
-- relative to max(1, |q|); measured at tol 1e-6 .. 1e-13: Kepler 13-48 tol
-- (the global error of ~380 steps), the pendulum 0.14-2.0 tol, the double
-- pendulum 0.2-1.2 tol.  Bound: 1e3 tol, as the integrator battery's for
-- adaptive runs.  (The sleigh, the rolling disk and Hamel's particle have
-- constraints, which taylor refuses; see the refusals above.)
describe("taylor on the benchmark's free problems", function()
  package.path = "./?.lua;" .. package.path
  local problems = require "bench.problems"
  for _, name in ipairs{ "kepler", "pendulum", "double_pendulum" } do
    it(name .. " meets its tolerance at 1e-6, 1e-9 and 1e-12", function()
      local p = problems[name]()
      local reftr
      if not p.reference then
        local o = { method = "rk8pd", rtol = 1e-13, atol = 1e-13 }
        for key, v in pairs(p.start) do o[key] = v end
        reftr = p.sys:simulate(o)
      end
      for _, tol in ipairs{ 1e-6, 1e-9, 1e-12 } do
        local o = { method = "taylor", rtol = tol, atol = tol }
        for key, v in pairs(p.start) do o[key] = v end
        local tr = p.sys:simulate(o)
        assert.are.equal("done", tr.status)
        local worst = 0
        for i = 1, #tr.t do
          local want = p.reference and p.reference(tr.t[i]) or reftr.q[i]
          for j = 1, #want do worst = math.max(worst, math.abs(tr.q[i][j] - want[j]) / math.max(1, math.abs(want[j]))) end
        end
        assert(worst <= 1e3 * tol, ("%s at tol %g: error %.3g"):format(name, tol, worst))
      end
    end)
  end
end)
