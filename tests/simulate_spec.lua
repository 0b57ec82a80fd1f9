-- simulate_spec.lua - sys:simulate and trajectories: accuracy against closed
-- forms, every GSL stepper, the exact Jacobian against finite differences,
-- the output grid, events, monitors only on request, failures with time
-- and state, CSV and plots.
local h = require "tests.helpers"
local nz = h.nz
local cs = require "tests.constraint_systems"
local ms = require "tests.mech_systems"
local nz_mech = require("nz.core").mech

local g, l = 9.81, 1.0
local pendulum = nz.system{ name = "pendulum", coords = { "th" },
  T = function(t, q, qd) return 0.5 * l * l * qd[1] ^ 2 end,
  V = function(t, q) return -g * l * nz.cos(q[1]) end }

-- The large-amplitude pendulum released from rest at th0 (closed form with
-- Jacobi's elliptic functions, GSL): sin(th/2) = k sn(K(k) - w t | k^2),
-- k = sin(th0/2), w = sqrt(g/l); period 4 K(k) / w.
local function exact_pendulum(th0)
  local k, w = math.sin(th0 / 2), math.sqrt(g / l)
  local K = nz.special.ellint_K(k)
  return function(t)
    local sn = nz.special.elljac(K - w * t, k * k)
    return 2 * math.asin(k * sn)
  end, 4 * K / w
end

describe("simulate against closed forms", function()
  it("a pendulum at large amplitude (2.5 rad) with the defaults stays within 1e-8 of the exact motion", function()
    local exact = exact_pendulum(2.5)
    local tr = pendulum:simulate{ q0 = { 2.5 }, t1 = 10, dt = 0.05 }
    local worst = 0
    for i = 1, #tr.t do worst = math.max(worst, math.abs(tr.q[i][1] - exact(tr.t[i]))) end
    -- rtol 1e-10 per step over ~150 steps of an O(1) motion: the global
    -- error is a few 1e-9; 1e-8 states what the defaults promise.
    assert(worst <= 1e-8, ("max error %.3g"):format(worst))
    assert.are.equal("done", tr.status)
  end)
  it("the output grid is every dt from t0 to t1, whatever the steps", function()
    local tr = pendulum:simulate{ q0 = { 1 }, t0 = 0.5, t1 = 2.5, dt = 0.25 }
    assert.are.equal(9, #tr.t)
    for i = 1, #tr.t do assert(math.abs(tr.t[i] - (0.5 + 0.25 * (i - 1))) <= 1e-12) end
    assert.are.equal(2.5, tr.t[#tr.t])
    assert(tr.stats.steps ~= #tr.t - 1, "the steps should not be the output grid")
  end)
  it("a fixed step: rk4 with h = 1e-3 has the global error of a fourth-order method", function()
    local exact = exact_pendulum(1.0)
    local tr = pendulum:simulate{ q0 = { 1 }, t1 = 2, dt = 0.1, method = "rk4", step = 1e-3 }
    local worst = 0
    for i = 1, #tr.t do worst = math.max(worst, math.abs(tr.q[i][1] - exact(tr.t[i]))) end
    -- C h^4 with C ~ (w^5 amplitude) ~ 1e2: ~1e-10; bound 1e-9.
    assert(worst <= 1e-9, ("max error %.3g"):format(worst))
    assert.are.equal(2000, tr.stats.steps)
  end)
  -- The global error over t = 0..3 against the elliptic closed form, in
  -- units of rtol.  Local control does not bound the global error by rtol:
  -- how far each stepper's errors add up is its own (a first-order method
  -- takes ~3000 steps and its errors all add).  Measured (rtol 1e-8; rk1imp
  -- 1e-5): rk2 0.65, rk4 4.9, rkf45 1.1, rkck 2.8, rk8pd 0.088, rk1imp 532,
  -- rk2imp 133, rk4imp 5.3, bsimp 2.3e-5, msadams 26, msbdf 66.  Each bound
  -- is about twice the measured figure, so a stepper that got worse shows.
  local factor = { rk2 = 1.5, rk4 = 10, rkf45 = 2.5, rkck = 6, rk8pd = 0.2, rk1imp = 1000, rk2imp = 300,
    rk4imp = 12, bsimp = 1e-4, msadams = 60, msbdf = 150 }
  for _, m in ipairs(nz.methods) do
    it(("method %s integrates the pendulum to its tolerance"):format(m.name), function()
      local exact = exact_pendulum(1.0)
      -- First-order rk1imp needs ~3000 steps for 1e-5 (its steps grow like
      -- rtol^-1/2); 1e-8 would take 30 times as many.
      local tol = m.name == "rk1imp" and 1e-5 or 1e-8
      local tr = pendulum:simulate{ q0 = { 1 }, t1 = 3, dt = 0.5, method = m.name, rtol = tol, atol = tol * 1e-2 }
      local worst = 0
      for i = 1, #tr.t do worst = math.max(worst, math.abs(tr.q[i][1] - exact(tr.t[i]))) end
      assert(factor[m.name], "no measured bound for the new method " .. m.name)
      assert(worst <= factor[m.name] * tol, ("%s: max error %.3g, bound %.3g"):format(m.name, worst, factor[m.name] * tol))
      if m.implicit then assert(tr.stats.njev > 0, m.name .. " used no Jacobian") end
    end)
  end
  -- With a fixed step the error at t = 1 must fall as h^p, p the order of
  -- the solution each GSL stepper propagates (rk2 propagates its third-order
  -- solution, rkf45 and rkck their fifth-order one).  A wrong term in the
  -- accelerations would make the error stall instead of falling.
  local orders = { { "rk1imp", 1, 1e-3 }, { "rk2imp", 2, 1e-2 }, { "rk2", 3, 1e-2 }, { "rk4", 4, 5e-2 },
    { "rk4imp", 4, 5e-2 }, { "rkf45", 5, 0.1 }, { "rkck", 5, 0.1 } }
  for _, o in ipairs(orders) do
    it(("method %s converges with order %d at a fixed step"):format(o[1], o[2]), function()
      local exact = exact_pendulum(1.0)(1)
      local err = {}
      for i, hh in ipairs{ o[3], o[3] / 2, o[3] / 4 } do
        local tr = pendulum:simulate{ q0 = { 1 }, t1 = 1, dt = 1, method = o[1], step = hh }
        err[i] = math.abs(tr.q[#tr.t][1] - exact)
      end
      -- Measured log2 of the error ratios: within 0.22 of p for every method
      -- here (rk4: 4.22 and 4.12 at these coarse steps, rkf45: 4.81 and 4.95).
      for i = 1, 2 do
        local p = math.log(err[i] / err[i + 1], 2)
        assert(math.abs(p - o[2]) <= 0.3, ("%s: observed order %.3f between h = %g and %g, expected %d"):format(
          o[1], p, o[3] / 2 ^ (i - 1), o[3] / 2 ^ i, o[2]))
      end
    end)
  end
end)

-- The same closed forms, events and failures with method = "taylor"
-- (Taylor's method on the recorded series; its own spec is
-- simulate_taylor_spec.lua).
describe("simulate against closed forms with method = 'taylor'", function()
  it("the pendulum at 2.5 rad with the default tolerances stays within 1e-8 of the exact motion", function()
    local exact = exact_pendulum(2.5)
    local tr = pendulum:simulate{ q0 = { 2.5 }, t1 = 10, dt = 0.05, method = "taylor" }
    local worst = 0
    for i = 1, #tr.t do worst = math.max(worst, math.abs(tr.q[i][1] - exact(tr.t[i]))) end
    -- measured 1.1e-10 (128 steps of order 13); the bound is the GSL run's
    assert(worst <= 1e-8, ("max error %.3g"):format(worst))
  end)
  it("integrates the pendulum to its tolerance at 1e-6, 1e-8, 1e-10 and 1e-12", function()
    local exact = exact_pendulum(1.0)
    for _, tol in ipairs{ 1e-6, 1e-8, 1e-10, 1e-12 } do
      local tr = pendulum:simulate{ q0 = { 1 }, t1 = 3, dt = 0.5, method = "taylor", rtol = tol, atol = tol * 1e-2 }
      local worst = 0
      for i = 1, #tr.t do worst = math.max(worst, math.abs(tr.q[i][1] - exact(tr.t[i]))) end
      -- in units of rtol, as the GSL steppers above: measured 0.009, 0.0032,
      -- 0.0034, 0.0083 (the step rule's safety keeps taylor well inside);
      -- bound 0.02, about twice the worst
      assert(worst <= 0.02 * tol, ("rtol %g: max error %.3g"):format(tol, worst))
    end
  end)
  it("a direction filter and stop = true end the run at the event, located on the step's polynomial", function()
    local _, P = exact_pendulum(1.0)
    local tr = pendulum:simulate{ q0 = { 1 }, t1 = 10, dt = 0.1, method = "taylor",
      events = { { name = "upward", f = function(t, q, qd) return q[1] end, direction = 1, stop = true } } }
    assert.are.equal("stopped", tr.status)
    -- measured 4.7e-14 from 3P/4
    assert(math.abs(tr.t[#tr.t] - 3 * P / 4) <= 1e-10, ("stopped at %.15g"):format(tr.t[#tr.t]))
    assert.are.equal(1, #tr.events)
  end)
  it("a mass matrix that degenerates, a blow-up in finite time, a singular start: stopped with where, never NaN", function()
    local deg = nz.system{ name = "degenerating", coords = { "x" },
      T = function(t, q, qd) return 0.5 * (1 - t / 2) * qd[1] ^ 2 end }
    h.checkerror("simulate 'degenerating': method 'taylor' stopped at t = 1.99999", deg.simulate, deg,
      { q0 = { 0 }, qd0 = { 1 }, t1 = 3, method = "taylor" })
    local blow = nz.system{ name = "blowup", coords = { "x" }, T = function(t, q, qd) return 0.5 * qd[1] ^ 2 end,
      V = function(t, q) return -q[1] ^ 3 / 3 end }
    -- x = 6 / (t - sqrt(6))^2 ... is infinite at t = sqrt(6) = 2.449489742783178
    h.checkerror("stopped at t = 2.44948974", blow.simulate, blow,
      { q0 = { 1 }, qd0 = { math.sqrt(2 / 3) }, t1 = 5, method = "taylor" })
    local sing = nz.system{ name = "degenerate", coords = { "x", "y" },
      T = function(t, q, qd) return 0.5 * (qd[1] + q[2] * qd[2]) ^ 2 + 0.5 * q[1] ^ 2 * qd[2] ^ 2 end }
    h.checkerror("system 'degenerate': the mass matrix M = d2T/dqd2 is not positive definite at t = 0, q = {0, 1}",
      sing.simulate, sing, { q0 = { 0, 1 }, t1 = 1, method = "taylor" })
  end)
end)

-- Central differences of the accelerations, for the Jacobian check.
local function fd_jacobian(sys, t, y)
  local k = sys.k
  local ode_accel = function(yy)
    local q, qd = {}, {}
    for i = 1, k do q[i], qd[i] = yy[i], yy[k + i] end
    return sys:accel(t, q, qd)
  end
  local J = {}
  local hstep = 1e-6
  for j = 1, 2 * k do
    local yp, ym = { table.unpack(y) }, { table.unpack(y) }
    yp[j], ym[j] = y[j] + hstep, y[j] - hstep
    local ap, am = ode_accel(yp), ode_accel(ym)
    for i = 1, k do J[i] = J[i] or {}; J[i][j] = (ap[i] - am[i]) / (2 * hstep) end
  end
  return J
end

describe("the exact Jacobian of the motion", function()
  local cases = {
    { "double pendulum", ms.double_pendulum(false) },
    { "top from a rigid body", ms.top(true) },
    { "hoop turning at a time-dependent rate", ms.hoop(false) },
    { "Chaplygin sleigh (constraint)", cs.sleigh() },
    { "Cartesian pendulum (holonomic constraint)", cs.cartesian_pendulum() },
    { "Hamel (nonlinear second-order constraint)", cs.hamel() },
  }
  for _, c in ipairs(cases) do
    it(c[1] .. ": d qdd / d(q, qd) agrees with central differences", function()
      local case = c[2]
      local sys = case.sys
      local t, q, qd = case.draw()
      local y = {}
      for i = 1, sys.k do y[i], y[sys.k + i] = q[i], qd[i] end
      local orders, linear = require("nz.model.constraints").orders(sys)
      local ode = nz_mech.ode_new(sys.engine, { method = "bsimp", orders = orders, linear = linear })
      local J = nz_mech.ode_jacobian(ode, sys.engine, t, y)
      local F = fd_jacobian(sys, t, y)
      for i = 1, sys.k do
        for j = 1, 2 * sys.k do
          local exact, fd = J[sys.k + i][j], F[i][j]
          -- Central differences with h = 1e-6: error ~ h^2 + eps/h ~ 1e-10
          -- relative to the accelerations' scale.
          assert(math.abs(exact - fd) <= 1e-6 * (1 + math.abs(fd)),
            ("%s: d qdd_%d / d y_%d = %.12g exact, %.12g by differences"):format(c[1], i, j, exact, fd))
        end
        assert.are.equal(0, J[i][i])                 -- (q)' = qd: dq'/dq = 0
        assert.are.equal(1, J[i][sys.k + i])         -- dq'/dqd = I
      end
    end)
  end
  it("dfdt: the explicit time dependence (hoop at a changing rate)", function()
    local case = ms.hoop(false)
    local sys = case.sys
    local y = { 0.7, 0.3 }
    local ode = nz_mech.ode_new(sys.engine, { method = "bsimp", orders = {}, linear = {} })
    local _, dfdt = nz_mech.ode_jacobian(ode, sys.engine, 1.5, y)
    local a = function(t) return sys:accel(t, { 0.7 }, { 0.3 })[1] end
    local fd = (a(1.5 + 1e-6) - a(1.5 - 1e-6)) / 2e-6
    assert(math.abs(dfdt[2] - fd) <= 1e-6 * (1 + math.abs(fd)), ("dfdt %.12g, differences %.12g"):format(dfdt[2], fd))
  end)
end)

describe("events", function()
  it("the pendulum passes the bottom at a quarter period, located to 1e-10", function()
    local _, P = exact_pendulum(1.0)
    local tr = pendulum:simulate{ q0 = { 1 }, t1 = 3, dt = 0.5,
      events = { { name = "bottom", f = function(t, q, qd) return q[1] end } } }
    assert(#tr.events >= 3)
    for i = 1, 3 do
      assert(math.abs(tr.events[i].t - (2 * i - 1) * P / 4) <= 1e-10,
        ("crossing %d at %.15g, expected %.15g"):format(i, tr.events[i].t, (2 * i - 1) * P / 4))
      assert(math.abs(tr.events[i].q[1]) <= 1e-9)
    end
  end)
  it("a direction filter and stop = true end the run at the event", function()
    local _, P = exact_pendulum(1.0)
    local tr = pendulum:simulate{ q0 = { 1 }, t1 = 10, dt = 0.1,
      events = { { name = "upward", f = function(t, q, qd) return q[1] end, direction = 1, stop = true } } }
    assert.are.equal("stopped", tr.status)
    assert(math.abs(tr.t[#tr.t] - 3 * P / 4) <= 1e-10, ("stopped at %.15g"):format(tr.t[#tr.t]))
    assert.are.equal(1, #tr.events)
  end)
end)

describe("monitors and cost", function()
  it("nothing that was not asked for is recorded", function()
    local tr = pendulum:simulate{ q0 = { 1 }, t1 = 1 }
    assert.is_nil(tr.energy); assert.is_nil(tr.work); assert.is_nil(tr.violation)
    h.checkerror("'E' was not recorded: ask for it with monitors = {energy = true", tr.column, tr, "E")
  end)
  it("energy is recorded on request, and the summary says what the run cost", function()
    local tr = pendulum:simulate{ q0 = { 1 }, t1 = 2, monitors = { energy = true } }
    assert.are.equal(#tr.t, #tr.energy)
    local text = tostring(tr)
    assert.truthy(text:find("cost: %d+ steps %(%d+ rejected%), %d+ right%-hand sides, 0 Jacobians"), text)
    assert.truthy(text:find("energy T + V: drift up to", 1, true), text)
    assert(tr.stats.nfev > 0 and tr.stats.wall > 0)
  end)
  it("the work of a moving constraint: T + V - W is conserved", function()
    local case = cs.driven_hoop()
    local driven, W = case.sys, case.W
    -- the engine's accelerations against the hand derivation first
    for _ = 1, 5 do
      local t, q, qd = case.draw()
      local a, want = driven:accel(t, q, qd), case.accel(t, q, qd)
      assert(math.abs(a[1] - want[1]) <= 1e-12 * math.max(1, math.abs(want[1])) and math.abs(a[2]) <= 1e-12,
        ("th'' = %.17g, hand %.17g; ph'' = %.3g"):format(a[1], want[1], a[2]))
    end
    local tr = driven:simulate{ q0 = { 0.7, 0 }, qd0 = { 0.3, W }, t1 = 3, monitors = { work = true } }
    local drift, change = 0, 0
    for i = 1, #tr.t do
      drift = math.max(drift, math.abs((tr.energy[i] - tr.work[i]) - tr.energy[1]))
      change = math.max(change, math.abs(tr.energy[i] - tr.energy[1]))
    end
    -- W is integrated with the motion at rtol 1e-10: drift ~1e-10 while
    -- T + V itself changes by O(0.1).
    assert(drift <= 1e-8, ("T + V - W drifted by %.3g"):format(drift))
    assert(change >= 1e-2, ("T + V changed by only %.3g"):format(change))
  end)
  it("tr:consistency(n): the forms of order n agree with the run's own q'' and multipliers", function()
    local case = cs.sleigh()
    local t, q, qd = case.draw()
    local tr = case.sys:simulate{ t0 = t, q0 = q, qd0 = qd, t1 = t + 2 }
    for _, n in ipairs{ 1, 2, 12 } do
      local res = tr:consistency(n, { quiet = true })
      for _, r in ipairs(res) do assert(r.max <= 1e-12 * n, ("n = %d: %s max %.3g"):format(n, r.coordinate, r.max)) end
    end
  end)
end)

describe("failures keep what was computed", function()
  it("NaN from a user function mid-run: an error with the time and state; nz.last holds the part done", function()
    local sys = nz.system{ name = "breaks", coords = { "x" }, T = function(t, q, qd) return 0.5 * qd[1] ^ 2 end,
      V = function(t, q) if t > 1 then return 0 / 0 end return 0.5 * q[1] ^ 2 end }
    local ok, err = pcall(sys.simulate, sys, { q0 = { 1 }, t1 = 3, dt = 0.1 })
    assert.is_false(ok)
    assert.truthy(err:find("system 'breaks': V returned a value that is not finite at t = 1", 1, true), err)
    assert.truthy(err:find("is kept in nz.last", 1, true), err)
    assert.are.equal("failed", nz.last.status)
    assert(#nz.last.t >= 10 and nz.last.t[#nz.last.t] <= 1.0 + 1e-12)
  end)
  it("a mass matrix that degenerates during the run stops it at that time, never NaN", function()
    -- M = 1 - t/2 vanishes at t = 2; the velocity M^-1 p blows up first.
    -- Near t = 2 the bias h is 1e16 times M: both evaluators must still
    -- see M itself (the jets take it as a derivative along q'', not as a
    -- difference of residuals, which lost it and called M = 0 "not
    -- positive definite"), so that both stall at t = 1.99999.. with the
    -- singular values of M there.
    for _, compile in ipairs{ false, true } do
      local sys = nz.system{ name = "degenerating", coords = { "x" }, compile = compile,
        T = function(t, q, qd) return 0.5 * (1 - t / 2) * qd[1] ^ 2 end }
      local tt = 1.9999999852989838
      assert.are.equal(1 - tt / 2, sys:mass(tt, { 37.4 }, { 171139522.82566622 })[1][1])
      h.checkerror("'degenerating': the integrator (rk8pd) stopped making progress", sys.simulate, sys,
        { q0 = { 0 }, qd0 = { 1 }, t1 = 3 })
      h.checkerror("at t = 1.99999", sys.simulate, sys, { q0 = { 0 }, qd0 = { 1 }, t1 = 3 })
    end
  end)
  it("a run that starts where M is singular names the mass matrix and the state", function()
    local sys = nz.system{ name = "degenerate", coords = { "x", "y" },
      T = function(t, q, qd) return 0.5 * (qd[1] + q[2] * qd[2]) ^ 2 + 0.5 * q[1] ^ 2 * qd[2] ^ 2 end }
    h.checkerror("system 'degenerate': the mass matrix M = d2T/dqd2 is not positive definite at t = 0, q = {0, 1}",
      sys.simulate, sys, { q0 = { 0, 1 }, t1 = 1 })
  end)
  it("a motion that blows up in finite time is stopped with a clear error, never NaN", function()
    -- x'' = x^2 from x = 1, x' = sqrt(2/3): x = 6 / (t - sqrt(6))^2 ... infinite at t = sqrt(6)
    local sys = nz.system{ name = "blowup", coords = { "x" }, T = function(t, q, qd) return 0.5 * qd[1] ^ 2 end,
      V = function(t, q) return -q[1] ^ 3 / 3 end }
    local ok, err = pcall(sys.simulate, sys, { q0 = { 1 }, qd0 = { math.sqrt(2 / 3) }, t1 = 5 })
    assert.is_false(ok)
    assert.truthy(err:find("system 'blowup':", 1, true) and err:find("at t = 2.4", 1, true), err)
  end)
  it("a start state off the constraints is refused with a hint", function()
    local case = cs.cartesian_pendulum()
    h.checkerror("violates constraint 1 at position level", case.sys.simulate, case.sys, { q0 = { 1, 1 }, t1 = 1 })
    h.checkerror("sys:project(t, q, qd)", case.sys.simulate, case.sys, { q0 = { 1, 1 }, t1 = 1 })
  end)
  it("bad options name the option", function()
    h.checkerror("simulate 'pendulum': unknown option 'tend'", pendulum.simulate, pendulum, { q0 = { 1 }, tend = 3 })
    h.checkerror("'t1' must be a number greater than t0 = 0", pendulum.simulate, pendulum, { q0 = { 1 } })
    h.checkerror("'q0' must be a table of 1 numbers (one per coordinate: th)", pendulum.simulate, pendulum, { q0 = { 1, 2 }, t1 = 1 })
    h.checkerror("unknown method 'rk9'; GSL's steppers are: rk2 rk4", pendulum.simulate, pendulum, { q0 = { 1 }, t1 = 1, method = "rk9" })
    h.checkerror("unknown monitor 'power'", pendulum.simulate, pendulum, { q0 = { 1 }, t1 = 1, monitors = { power = true } })
    h.checkerror("event 1 must be {f = function(t, q, qd)", pendulum.simulate, pendulum, { q0 = { 1 }, t1 = 1, events = { 3 } })
  end)
end)

describe("output", function()
  local tr = pendulum:simulate{ q0 = { 1 }, t1 = 1, dt = 0.5, monitors = { energy = true } }
  it("csv has a header naming the coordinates and one row per point", function()
    local file = os.tmpname()
    tr:csv(file)
    local f = assert(io.open(file))
    assert.are.equal("t,th,th',th'',E,H", f:read("l"))
    local n = 0
    for line in f:lines() do n = n + 1; assert.truthy(line:match("^[%d%.e%-+]+,")) end
    f:close()
    os.remove(file)
    assert.are.equal(3, n)
  end)
  it("plots to the terminal and to SVG and PNG files", function()
    local text = tr:plot{ quiet = true, width = 60, height = 15 }
    assert.truthy(text:find("th", 1, true) and text:find("%*"), text)
    local svg = os.tmpname() .. ".svg"
    tr:plot{ file = svg }
    local content = assert(io.open(svg)):read("a")
    assert.truthy(content:find("<svg", 1, true))
    os.remove(svg)
    local png = os.tmpname() .. ".png"
    tr:plot{ phase = "th", file = png }
    assert.are.equal("\137PNG", assert(io.open(png, "rb")):read(4))
    os.remove(png)
  end)
  it("without gnuplot the error says how to install it", function()
    local code, _, err = h.run("env PATH=/nonexistent " .. (os.getenv("PWD") or ".") .. "/" .. h.nzlua ..
      [[ -e 'local s = nz.system{coords = {"x"}, T = function(t, q, v) return v[1]^2 end}; s:simulate{q0 = {0}, t1 = 1}:plot()']])
    assert.are.equal(1, code)
    assert.truthy(err:find("gnuplot is not installed: install it with 'sudo apt-get install gnuplot-nox'", 1, true), err)
  end)
  it("Ctrl-C stops a long run and returns the part computed", function()
    local code, out = h.interrupt_script([[
local s = nz.system{ coords = {"x"}, T = function(t, q, v) return 0.5 * v[1]^2 end, V = function(t, q) return 0.5 * q[1]^2 end }
local tr = s:simulate{ q0 = {1}, t1 = 1e7, dt = 10, rtol = 1e-12 }
print("status " .. tr.status .. " points " .. #tr.t)
]], 2)
    assert.are.equal(130, code)      -- the script goes on with the part computed, then exits 128 + SIGINT
    local n = tonumber(out:match("status interrupted points (%d+)"))
    assert(n and n > 1, out)
  end)
end)
