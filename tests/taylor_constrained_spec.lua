-- taylor_constrained_spec.lua - Taylor's method under constraints of order
-- 0, 1 and 2 (src/mech/mech_graph.c, nz_recording_constrained_series): the
-- series of a constrained motion against a closed form, runs against
-- closed forms and against rk8pd at a tight tolerance, the constraints'
-- drift over long runs, the multipliers, and what it refuses.  Every bound
-- says why it is what it is.
local h = require "tests.helpers"
local nz = h.nz
local mech = require("nz.core").mech
local constraints = require "nz.model.constraints"
local cs = require "tests.constraint_systems"

local function classification(sys, q0, qd0)
  local orders, linear = constraints.orders(sys, { t = 0, q = q0, qd = qd0 })
  return { orders = orders, linear = linear }
end

-- The largest difference of two runs' q on the same grid.
local function qdiff(a, b)
  local worst = 0
  for i = 1, #a.t do
    for j = 1, #a.q[i] do worst = math.max(worst, math.abs(a.q[i][j] - b.q[i][j])) end
  end
  return worst
end

describe("the series of a constrained motion", function()
  it("a particle on a circle at constant speed: the Taylor coefficients of R cos wt, R sin wt to order 20", function()
    local R, w = 1.3, 0.7
    local sys = nz.system{ name = "circle", coords = { "x", "y" },
      T = function(t, q, qd) return 0.5 * (qd[1] ^ 2 + qd[2] ^ 2) end,
      constraints = { function(t, q) return q[1] ^ 2 + q[2] ^ 2 - R ^ 2 end } }
    local q0, qd0 = { R, 0 }, { 0, R * w }
    local a = mech.motion_series(sys.engine, 0, q0, qd0, 20, classification(sys, q0, qd0))
    local fact = 1
    for n = 0, 20 do
      if n > 0 then fact = fact * n end
      local cx = ({ 1, 0, -1, 0 })[n % 4 + 1] * R * w ^ n / fact
      local cy = ({ 0, 1, 0, -1 })[n % 4 + 1] * R * w ^ n / fact
      -- Coefficient n comes from coefficient n + 2 of x^2 + y^2 - R^2 = 0,
      -- a sum of products of the lower ones much larger than its value (the
      -- binomial sums of cos^2 + sin^2 = 1 cancel): the rounding relative to
      -- R w^n / n! grows by ~2.75 per order, measured 1.3e-15 at n = 5 and
      -- 5.0e-9 at n = 20 (2e-30 absolute).  Bound 1e-15 3^n, a margin of
      -- 100 to 700 along the way.
      local s = R * w ^ n / fact
      assert(math.abs(a[n + 1][1] - cx) <= 1e-15 * 3 ^ n * s, ("x, order %d: %.3g"):format(n, a[n + 1][1] - cx))
      assert(math.abs(a[n + 1][2] - cy) <= 1e-15 * 3 ^ n * s, ("y, order %d: %.3g"):format(n, a[n + 1][2] - cy))
    end
  end)
end)

describe("taylor under constraints", function()
  it("a pendulum in Cartesian coordinates (x^2 + y^2 = L^2) over 100 s against its Jacobi elliptic closed form", function()
    local g, L, th0 = 9.81, 1.0, 1.0
    local sys = nz.system{ name = "cartesian pendulum", coords = { "x", "y" },
      T = function(t, q, qd) return 0.5 * (qd[1] ^ 2 + qd[2] ^ 2) end,
      V = function(t, q) return g * q[2] end,
      constraints = { function(t, q) return q[1] ^ 2 + q[2] ^ 2 - L ^ 2 end } }
    local k, w = math.sin(th0 / 2), math.sqrt(g / L)
    local K = nz.special.ellint_K(k)
    local function theta(t) return 2 * math.asin(k * nz.special.elljac(K - w * t, k * k)) end
    local tr = sys:simulate{ q0 = { L * math.sin(th0), -L * math.cos(th0) }, qd0 = { 0, 0 }, t1 = 100, dt = 0.5,
      method = "taylor", rtol = 1e-12, atol = 1e-12 }
    local worst, drift = 0, 0
    for i = 1, #tr.t do
      worst = math.max(worst, math.abs(math.atan(tr.q[i][1], -tr.q[i][2]) - theta(tr.t[i])))
      drift = math.max(drift, tr.violation[i])
    end
    -- Measured: angle 8.6e-11 over ~45 periods (1478 steps of order 15);
    -- the constraint drifts by 4.7e-12 (each step keeps x^2 + y^2 to its
    -- truncation error, nothing projects: rk8pd at the same tolerance drifts
    -- 2.3e-9).  Bounds 1e-9 and 1e-10: margins of 12 and 20.
    assert(worst <= 1e-9, ("angle error %.3g"):format(worst))
    assert(drift <= 1e-10, ("constraint drift %.3g"):format(drift))
    -- the multiplier: lambda = (m g cos th + m L th'^2) / (2 L) ... compared
    -- at the last point with the energy: th'^2 = 2 g (cos th - cos th0) / L
    local n = #tr.t
    local th = math.atan(tr.q[n][1], -tr.q[n][2])
    local thd2 = 2 * g * (math.cos(th) - math.cos(th0)) / L
    -- M q'' = -grad V + A^T lambda, A = 2 (x, y): the rod's pull is -2 lambda L
    local pull = -(g * math.cos(th) + L * thd2)
    assert.near(pull, 2 * tr.lambda[n][1] * L, 1e-8)
  end)

  local function against_rk8pd(case, q0, qd0, t1, residual)
    local sys = case.sys
    local opts = { q0 = q0, qd0 = qd0, t1 = t1, dt = t1 / 20, rtol = 1e-12, atol = 1e-12, method = "taylor" }
    local ta = sys:simulate(opts)
    opts.method, opts.rtol, opts.atol = "rk8pd", 1e-13, 1e-13
    local rb = sys:simulate(opts)
    local worst = 0
    for i = 1, #ta.t do worst = math.max(worst, math.abs(residual(ta.q[i], ta.qd[i], ta.qdd[i]))) end
    return qdiff(ta, rb), worst, ta
  end

  it("the Chaplygin sleigh (a velocity constraint) against rk8pd at 1e-13, and its constraint along the run", function()
    local d, r = against_rk8pd(cs.sleigh(), { 0, 0, 0 }, { 1, 0, 0.5 }, 20,
      function(q, qd) return -qd[1] * math.sin(q[3]) + qd[2] * math.cos(q[3]) end)
    -- measured 2.4e-13 from rk8pd (itself ~1e-13 off); constraint 1e-15
    assert(d <= 1e-11, ("difference %.3g"):format(d))
    assert(r <= 1e-12, ("constraint %.3g"):format(r))
  end)

  it("the vertical rolling disk (two velocity constraints) against its closed form", function()
    local R = 0.3
    local case = cs.rolling_disk()
    local q0, qd0 = { 0, 0, 0, 0 }, { R * 2, 0, 0.7, 2 }
    local tr = case.sys:simulate{ q0 = q0, qd0 = qd0, t1 = 20, dt = 1, method = "taylor", rtol = 1e-12, atol = 1e-12 }
    -- th = 0.7 t, ph = 2 t, x' = R ph' cos th: x = (2 R / 0.7) sin 0.7 t, y = (2 R / 0.7)(1 - cos 0.7 t)
    local worst = 0
    for i = 1, #tr.t do
      local t = tr.t[i]
      local ex = { 2 * R / 0.7 * math.sin(0.7 * t), 2 * R / 0.7 * (1 - math.cos(0.7 * t)), 0.7 * t, 2 * t }
      for j = 1, 4 do worst = math.max(worst, math.abs(tr.q[i][j] - ex[j])) end
    end
    -- measured 3.0e-14 (18 steps of order 15 over 20 s); bound 1e-12
    assert(worst <= 1e-12, ("max error %.3g"):format(worst))
  end)

  it("Appell's constraint (nonlinear in the velocities) against rk8pd at 1e-13", function()
    local c = 0.6
    local d, r = against_rk8pd(cs.appell(), { 0.2, -0.3, 0.5 }, { 1, 0.5, c * math.sqrt(1.25) }, 5,
      function(q, qd) return qd[3] ^ 2 - c * c * (qd[1] ^ 2 + qd[2] ^ 2) end)
    -- measured 1.4e-12 from rk8pd (itself ~1e-13 off), and the constraint
    -- 7.8e-13 at the output points (held by the series to its truncation,
    -- as its velocity-level value is not projected); bounds 1e-10, 1e-11
    assert(d <= 1e-10, ("difference %.3g"):format(d))
    assert(r <= 1e-11, ("constraint %.3g"):format(r))
  end)

  it("Hamel's constraint on the accelerations (nonlinear in q'') with a spring: Newton at order 0, the root's Jacobian after", function()
    local m = 1.5
    local sys = nz.system{ name = "hamel with a spring", coords = { "q1", "q2", "q3" },
      T = function(t, q, qd) return 0.5 * m * (qd[1] ^ 2 + qd[2] ^ 2 + qd[3] ^ 2) end,
      V = function(t, q) return 0.5 * (q[1] ^ 2 + 2 * q[2] ^ 2 + 3 * q[3] ^ 2) end,
      constraints = { function(t, q, qd, qdd) return qdd[3] - qdd[1] * qdd[2] end } }
    local d, r = against_rk8pd({ sys = sys }, { 0.3, -0.2, 0.1 }, { 0.1, 0.2, -0.1 }, 5,
      function(q, qd, qdd) return qdd[3] - qdd[1] * qdd[2] end)
    -- measured 1.5e-14 from rk8pd (24 steps against its 62); the
    -- constraint q3'' = q1'' q2'' at the output points is the point
    -- solver's, 2.8e-17.  Bounds 1e-12 and 1e-14.
    assert(d <= 1e-12, ("difference %.3g"):format(d))
    assert(r <= 1e-14, ("constraint %.3g"):format(r))
  end)
end)

describe("what taylor refuses under constraints", function()
  it("projection and Baumgarte's terms, and constraints of order 3", function()
    local case = cs.cartesian_pendulum()
    h.checkerror("takes no 'project' or 'baumgarte'", case.sys.simulate, case.sys,
      { q0 = { 1, 0 }, t1 = 1, method = "taylor", project = true })
    local jerk = nz.system{ name = "jerk", coords = { "x", "y" },
      T = function(t, q, qd) return 0.5 * (qd[1] ^ 2 + qd[2] ^ 2) end,
      constraints = { function(t, q, qd, qdd, q3) return q3[1] + q3[2] end } }
    h.checkerror("method 'taylor' takes constraints of order 0, 1 and 2", jerk.simulate, jerk,
      { q0 = { 0, 0 }, t1 = 1, method = "taylor" })
    -- a constraint with a Lua branch on the state is not in the graph the
    -- series are built on: refused with the reason (it was a "series failed
    -- ... the motion may be singular" at t = 0)
    local branch = nz.system{ name = "branch", coords = { "x", "y" },
      T = function(t, q, qd) return 0.5 * (qd[1] ^ 2 + qd[2] ^ 2) end,
      constraints = { function(t, q) if q[1] > 0 then return q[1] - q[2] else return q[1] + q[2] end end } }
    h.checkerror("method 'taylor' cannot run this system: the Taylor method needs the constraints recorded, "
      .. "and constraint 1 runs in Lua", branch.simulate, branch, { q0 = { 1, 1 }, t1 = 1, method = "taylor" })
  end)

  it("a singular constrained solve is said as the GSL steppers say it, with the constraints involved (it crashed)", function()
    -- the reading of the constraints in a dependence had no storage under
    -- taylor: every singular [M A^T; A 0] ended in a segmentation fault
    local T2 = function(t, q, qd) return 0.5 * (qd[1] ^ 2 + qd[2] ^ 2) end
    local redundant = nz.system{ name = "redundant", coords = { "x", "y" }, T = T2,
      constraints = { function(t, q) return q[1] ^ 2 + q[2] ^ 2 - 1 end, function(t, q) return 2 * (q[1] ^ 2 + q[2] ^ 2 - 1) end } }
    h.checkerror("system 'redundant': dependent constraints: constraints 1 and 2 (the rank of their gradients A is 1 < 2)",
      redundant.simulate, redundant, { q0 = { 1, 0 }, t1 = 1, method = "taylor" })
    -- qd1 + qd2 = 0 and qd1 + t qd2 = 0 become dependent at t = 1 (by hand)
    local later = nz.system{ name = "later", coords = { "x", "y" }, T = T2,
      constraints = { function(t, q, qd) return qd[1] + qd[2] end, function(t, q, qd) return qd[1] + t * qd[2] end } }
    local ok, e = pcall(later.simulate, later, { q0 = { 0, 0 }, t1 = 2, method = "taylor" })
    assert.is_false(ok)
    assert.truthy(tostring(e):find("dependent constraints: constraints 1 and 2", 1, true), e)
    assert(math.abs(tonumber(tostring(e):match("at t = ([%d.e+-]+)")) - 1) <= 1e-12, e)
    local cone = nz.system{ name = "cone", coords = { "x", "y" }, T = T2,
      constraints = { function(t, q) return q[1] ^ 2 - q[2] ^ 2 end } }
    h.checkerror("constraint 1 has a zero gradient dPhi/dq^(m) here", cone.simulate, cone,
      { q0 = { 0, 0 }, t1 = 1, method = "taylor" })
    local massless = nz.system{ name = "massless z", coords = { "x", "y", "z" }, T = T2,
      constraints = { function(t, q) return q[1] - q[2] end } }
    h.checkerror("the mass matrix is singular on the directions the constraints allow", massless.simulate, massless,
      { q0 = { 0, 0, 0 }, t1 = 1, method = "taylor" })
  end)
end)
