-- simulate_dense_spec.lua - dense output of the GSL steppers (src/ode/ode_run.c):
-- the output points inside a step come off its Hermite interpolant, so the
-- output grid no longer sets the steps; the interpolant's error control
-- keeps every point at the run's own accuracy; events are located on it;
-- dense = false keeps the grid.  Checked against closed forms.
local h = require "tests.helpers"
local nz = h.nz

local g, l = 9.81, 1.0
local pendulum = nz.system{ name = "pendulum", coords = { "th" },
  T = function(t, q, qd) return 0.5 * l * l * qd[1] ^ 2 end,
  V = function(t, q) return -g * l * nz.cos(q[1]) end }
local oscillator = nz.system{ name = "oscillator", coords = { "x" },
  T = function(t, q, qd) return 0.5 * qd[1] ^ 2 end,
  V = function(t, q) return 0.5 * q[1] ^ 2 end }

-- The pendulum released from rest at th0: sin(th/2) = k sn(K(k) - w t | k^2),
-- k = sin(th0/2), w = sqrt(g/l); its first zero at the quarter period K / w.
local function exact_pendulum(th0)
  local k, w = math.sin(th0 / 2), math.sqrt(g / l)
  local K = nz.special.ellint_K(k)
  return function(t) return 2 * math.asin(k * nz.special.elljac(K - w * t, k * k)) end, K / w
end

local function max_error(tr, exact)
  local worst = 0
  for i = 1, #tr.t do worst = math.max(worst, math.abs(tr.q[i][1] - exact(tr.t[i]))) end
  return worst
end

describe("dense output", function()
  it("the output grid no longer sets the steps: rk8pd on a pendulum, dt = 0.01 against dt = 1", function()
    local fine = pendulum:simulate{ q0 = { 1 }, t1 = 200, dt = 0.01, method = "rk8pd" }
    local coarse = pendulum:simulate{ q0 = { 1 }, t1 = 200, dt = 1, method = "rk8pd" }
    assert.are.equal(20001, #fine.t)
    -- Measured: 3,673 steps at dt = 0.01 (111 points made step ends by the
    -- error control), 3,419 at dt = 1; with dense = false, 20,002 at
    -- dt = 0.01 and 3,511 at dt = 1.
    assert(fine.stats.steps <= 1.1 * coarse.stats.steps, ("%d steps against %d"):format(fine.stats.steps, coarse.stats.steps))
    assert(fine.stats.interpolated > 0.9 * 20000, fine.stats.interpolated)
    assert.is_nil(fine.stats.grid_why)
  end)

  -- The interpolated points against the closed form, compared with what the
  -- same tolerance gives at the step ends of a run whose steps the grid does
  -- not set (dt = 1 with dense = false: every point a step end).  Measured
  -- on this pendulum (max over t = 0..200): rtol 1e-10: 1.94e-9 dense,
  -- 1.89e-9 at step ends; 1e-12: 1.4e-11 and 1.2e-11.  Local control lets
  -- the global error grow with time; the interpolant must add nothing to it
  -- that matters: the bound is twice the step ends' error (the two sets of
  -- times differ, hence not 1x).
  for _, tol in ipairs{ 1e-8, 1e-10, 1e-12 } do
    it(("interpolated points are as accurate as step ends (rk8pd, rtol %g, amplitude 2.5)"):format(tol), function()
      local exact = exact_pendulum(2.5)
      local opts = { q0 = { 2.5 }, t1 = 50, rtol = tol, atol = tol * 1e-2 }
      opts.dt = 0.01
      local dense = pendulum:simulate(opts)
      opts.dt, opts.dense = 1, false
      local ends = pendulum:simulate(opts)
      local ed, ee = max_error(dense, exact), max_error(ends, exact)
      assert(ed <= 2 * math.max(ee, tol), ("dense %.3g, step ends %.3g"):format(ed, ee))
    end)
  end

  it("the harmonic oscillator: q and qd at every point within the tolerance's global error", function()
    local tr = oscillator:simulate{ q0 = { 1 }, t1 = 20, dt = 0.003 }
    local worst = 0
    for i = 1, #tr.t do
      worst = math.max(worst, math.abs(tr.q[i][1] - math.cos(tr.t[i])), math.abs(tr.qd[i][1] + math.sin(tr.t[i])))
    end
    -- rtol 1e-10 over ~3 periods: a global error of a few 1e-10 (measured
    -- the same with dense = false at dt = 1)
    assert(worst <= 2e-9, ("max error %.3g"):format(worst))
    assert(tr.stats.steps < 0.2 * (#tr.t - 1), tr.stats.steps)
  end)

  for _, method in ipairs{ "rkf45", "rk4imp", "bsimp" } do
    it(method .. ": dense output meets its tolerance, with fewer steps than the grid", function()
      local exact = exact_pendulum(1.0)
      local opts = { q0 = { 1 }, t1 = 10, dt = 0.01, method = method, rtol = 1e-9, atol = 1e-11 }
      local dense = pendulum:simulate(opts)
      opts.dense = false
      local grid = pendulum:simulate(opts)
      -- the grid run's steps are capped at 0.01: more accurate than the
      -- method's own; the dense run's error is the method's own at rtol
      -- 1e-9 (a few 1e-9 over 10 s, measured), bound 1e-7
      assert(max_error(dense, exact) <= 1e-7, ("%.3g"):format(max_error(dense, exact)))
      assert(dense.stats.steps < grid.stats.steps, ("%d against %d"):format(dense.stats.steps, grid.stats.steps))
    end)
  end

  it("events are located on the interpolant: the pendulum's zero at the quarter period K(k)/w", function()
    for _, th0 in ipairs{ 1.0, 2.5 } do
      local _, quarter = exact_pendulum(th0)
      local tr = pendulum:simulate{ q0 = { th0 }, t1 = 10, dt = 0.01,
        events = { { name = "zero", f = function(t, q) return q[1] end, direction = -1, stop = true } } }
      assert.are.equal("stopped", tr.status)
      -- event_tol 1e-12 on t; the state's error at rtol 1e-10 over a
      -- quarter period moves the zero by ~1e-10 / |qd| (|qd| ~ 3 .. 6)
      assert(math.abs(tr.events[1].t - quarter) <= 1e-9, ("%.17g against %.17g"):format(tr.events[1].t, quarter))
      assert(math.abs(tr.events[1].q[1]) <= 1e-9)
      -- the points past the event are gone; the last is the event's
      for i = 2, #tr.t do assert(tr.t[i] > tr.t[i - 1]) end
      assert.are.equal(tr.events[1].t, tr.t[#tr.t])
    end
  end)

  it("dense = false keeps the grid: one step per output point, as before", function()
    local tr = pendulum:simulate{ q0 = { 1 }, t1 = 10, dt = 0.01, dense = false }
    assert(tr.stats.steps >= 1000 and tr.stats.steps <= 1010, tr.stats.steps)
    assert.are.equal("dense = false", tr.stats.grid_why)
    -- and gives what a loop written in the test gives, to the bit
    local ref = h.reference_run(pendulum, { q0 = { 1 }, t1 = 10, dt = 0.01 })
    assert.are.equal(#ref.t, #tr.t)
    for i = 1, #tr.t do assert.are.equal(ref.q[i][1], tr.q[i][1]) end
    assert.are.equal(ref.stats.steps, tr.stats.steps)
  end)

  it("msbdf keeps the grid unless asked (a point made a step end would restart it), and says so", function()
    local tr = pendulum:simulate{ q0 = { 1 }, t1 = 2, dt = 0.01, method = "msbdf" }
    assert.are.equal(0, tr.stats.interpolated)
    tr = pendulum:simulate{ q0 = { 1 }, t1 = 2, dt = 0.01, method = "msbdf", dense = true }
    assert(tr.stats.interpolated > 0)
    -- where the grid sets its steps (loose tolerance, fine grid), grid_why says why
    tr = pendulum:simulate{ q0 = { 1 }, t1 = 2, dt = 0.001, method = "msbdf", rtol = 1e-6, atol = 1e-8 }
    assert.truthy(tr.stats.grid_why and tr.stats.grid_why:find("msbdf keeps the grid unless dense = true", 1, true),
      tr.stats.grid_why)
  end)

  it("'dense' must be a boolean", function()
    h.checkerror("'dense' must be true or false, got 1", pendulum.simulate, pendulum, { q0 = { 1 }, t1 = 1, dense = 1 })
  end)
end)
