-- higher_order_spec.lua - constraints of order 3 and more (docs/theory.md §6, §8):
-- the derivative slots a constraint declares, classification and
-- Dolapchiev's rule, the residuals of every form, and the motion integrated
-- at level p >= 3 (state q, qd, qdd, ..., lambda, ...; src/mech/constrained_series.c)
-- against closed forms derived by hand below, with the start state checked
-- and completed by sys:project.
local h = require "tests.helpers"
local nz = h.nz
local mech = require("nz.core").mech

local function nz_mech_partials(sys, t, q, qd, qdd, qddd, higher)
  return mech.constraint_partials(sys.engine, 1, t, q, qd, qdd, qddd, higher)
end

local function max_diff(a, b)
  local m = 0
  for i = 1, #a do m = math.max(m, math.abs(a[i] - b[i])) end
  return m
end

-- A particle of mass m in the plane, constant forces (F1, F2), and the
-- servo constraint x^(p) + 2 y^(p) = u(t) on its p-th derivatives (A = (1, 2)).
-- (6.2): m x'' = F1 + lambda, m y'' = F2 + 2 lambda; differentiating p - 2
-- times and inserting into the constraint: 5 lambda^(p-2) / m = u(t).
local m, F1, F2 = 1.7, 0.3, -0.45
local function servo(p)
  local constraint
  if p == 3 then
    constraint = function(t, q, qd, qdd, qddd) return qddd[1] + 2 * qddd[2] - nz.sin(t) end
  else        -- order 4: q4d is a fifth level, so params must follow it (here unused)
    constraint = function(t, q, qd, qdd, qddd, q4d, params) return q4d[1] + 2 * q4d[2] - params.a * nz.cos(t) end
  end
  return nz.system{ name = "servo" .. p, coords = { "x", "y" }, params = { a = 1 },
    T = function(t, q, qd) return 0.5 * m * (qd[1] ^ 2 + qd[2] ^ 2) end,
    Q = function() return { F1, F2 } end,
    constraints = { constraint } }
end

describe("derivative slots", function()
  it("a constraint declaring q4d before params gets q^(4) and params in their places", function()
    local seen
    local sys = nz.system{ name = "slots", coords = { "x" }, params = { c = 2.385 },
      T = function(t, q, qd) return 0.5 * qd[1] ^ 2 end,
      constraints = { function(t, q, qd, qdd, qddd, q4d, p) seen = p; return q4d[1] - p.c * q[1] end } }
    local value, partials = nz_mech_partials(sys, 0.3, { 0.5 }, { 0 }, { 0 }, { 0 }, { { 0.75 } })
    assert.are.equal(sys.params, seen)
    assert(math.abs(value - (0.75 - 2.385 * 0.5)) < 1e-15, value)
    assert.are.equal(5, #partials)                            -- q .. q^(4)
    assert(math.abs(partials[5][1] - 1) < 1e-15 and math.abs(partials[1][1] + 2.385) < 1e-15)
  end)
  it("function(t, q, qd, qdd, qddd, params) keeps params as its sixth argument", function()
    local seen
    local sys = nz.system{ name = "six", coords = { "x" }, params = { c = 1 },
      T = function(t, q, qd) return 0.5 * qd[1] ^ 2 end,
      constraints = { function(t, q, qd, qdd, qddd, params) seen = params; return qd[1] end } }
    sys:constraints{ quiet = true }
    assert.are.equal(sys.params, seen)
  end)
  it("the rolling_ball effect hands params (not qdd) to the body's functions", function()
    -- A ball of radius p.R pushed at its centre accelerates at 5 F / (7 m) (rolling without slipping).
    local m, R, F = 1.3, 0.3, 0.7
    local I = 0.4 * m * R * R
    local ball = nz.scene{ name = "ball", coords = { "x", "y", "psi", "theta", "phi" }, params = { R = R },
      bodies = { { name = "ball", mass = m, inertia = { I, I, I },
        rot = function(t, q) return nz.rotations.euler_zxz(q[3], q[4], q[5]) end,
        pos = function(t, q, p) return { q[1], q[2], p.R } end } },
      effects = { nz.effects.rolling_ball{ body = "ball", radius = R },
        nz.effects.force{ at = "ball", F = function() return { F, 0, 0 } end } } }
    local qdd = ball:accel(0, { 0, 0, 0.1, 1.2, 0.3 }, { 0, 0, 0, 0, 0 })
    assert(math.abs(qdd[1] - 5 * F / (7 * m)) <= 1e-13, ("%.17g"):format(qdd[1]))
  end)
  it("a sixth parameter named like a derivative is refused, with the fix", function()
    h.checkerror("nz.system 'trap': constraint 1 declares 6 parameters and its last, 'q4d', receives params", nz.system,
      { name = "trap", coords = { "x" }, T = function(t, q, qd) return qd[1] ^ 2 end,
        constraints = { function(t, q, qd, qdd, qddd, q4d) return q4d[1] end } })
  end)
end)

describe("classification and Dolapchiev's rule for orders 3 and 4", function()
  local function one(f)
    return nz.system{ coords = { "x", "y" }, T = function(t, q, qd) return 0.5 * (qd[1] ^ 2 + qd[2] ^ 2) end,
      constraints = { f } }
  end
  it("n = m for a linear constraint and m + 1 for a nonlinear one (§8)", function()
    local cases = {
      { function(t, q, qd, qdd, qddd) return qddd[1] + q[2] * qddd[2] end, 3, true, 3 },
      { function(t, q, qd, qdd, qddd) return qddd[1] - qddd[2] ^ 2 end, 3, false, 4 },
      { function(t, q, qd, qdd, qddd, q4d, p) return q4d[1] - qdd[2] * q4d[2] end, 4, true, 4 },
      { function(t, q, qd, qdd, qddd, q4d, p) return q4d[1] * q4d[2] - 1 end, 4, false, 5 },
    }
    for i, c in ipairs(cases) do
      local sys = one(c[1])
      local cl = sys:constraints{ quiet = true }[1]
      assert.are.equal(c[2], cl.order, "case " .. i)
      assert.are.equal(c[3], cl.linear, "case " .. i)
      assert.are.equal(c[4], (sys:rule()), "case " .. i)
    end
  end)
  it("every form's residual with multipliers equals m q'' - Q - A^T lambda at an order-3 constraint (q''' nonzero)", function()
    -- Phi = x''' - x y'''^2: A = dPhi/dq''' = (1, -2 x y'''), which depends on q'''.
    local sys = nz.system{ name = "jerk", coords = { "x", "y" },
      T = function(t, q, qd) return 0.5 * m * (qd[1] ^ 2 + qd[2] ^ 2) end,
      Q = function() return { F1, F2 } end,
      constraints = { function(t, q, qd, qdd, qddd) return qddd[1] - q[1] * qddd[2] ^ 2 end } }
    local q, qd, qdd, qddd, lambda = { 0.61, -0.2 }, { 0.3, 1.1 }, { 0.25, -0.7 }, { 0.9, 1.35 }, { 0.43 }
    local A = { 1, -2 * q[1] * qddd[2] }
    local want = { m * qdd[1] - F1 - A[1] * lambda[1], m * qdd[2] - F2 - A[2] * lambda[1] }
    for _, form in ipairs{ "generalized", "lagrange", "difference", "euler", "appell", "extremal" } do
      for _, n in ipairs{ 3, 4 } do
        local r = sys:residual(n, 0.4, q, qd, qdd, lambda, { form = form, higher = { qddd } })
        assert(max_diff(r, want) <= 1e-13, ("%s n = %d: {%.17g, %.17g}"):format(form, n, r[1], r[2]))
      end
    end
  end)
end)

describe("sys:project at level 3 keeps a consistent start and chooses no multiplier for the user", function()
  -- x''' = 0 with T = (x'^2 + y'^2)/2: A = dPhi/dq''' = (1, 0), so (6.2)
  -- reads x'' = lambda, y'' = 0 (by hand).  Every x'' is consistent, with
  -- lambda = x''; y'' must be 0.
  local sys = nz.system{ name = "jerk free", coords = { "x", "y" },
    T = function(t, q, qd) return 0.5 * (qd[1] ^ 2 + qd[2] ^ 2) end,
    constraints = { function(t, q, qd, qdd, qddd) return qddd[1] end } }
  it("a consistent qdd is returned unchanged, with the multiplier it needs", function()
    local q, qd, rep = sys:project(0, { 0, 0 }, { 1, 0 }, { qdd = { 0.5, 0 } })
    -- it returned qdd = {0.25, 0} and lambda = {0.25}: the least change of
    -- (qdd, lambda) together from lambda = 0
    assert.are.same({ 0.5, 0 }, rep.qdd)
    assert.are.equal(0.5, rep.lambda[1])
    assert.are.same({ 0, 0 }, q)
    assert.are.same({ 1, 0 }, qd)
  end)
  it("an inconsistent qdd changes least, in qdd alone", function()
    -- y'' = 0.3 is not allowed: the nearest consistent qdd is (0.5, 0)
    local _, _, rep = sys:project(0, { 0, 0 }, { 1, 0 }, { qdd = { 0.5, 0.3 } })
    assert(math.abs(rep.qdd[1] - 0.5) <= 1e-15 and math.abs(rep.qdd[2]) <= 1e-15, ("{%.17g, %.17g}"):format(rep.qdd[1], rep.qdd[2]))
    assert(math.abs(rep.lambda[1] - 0.5) <= 1e-15, rep.lambda[1])
  end)
  it("lambda = {...} is the user's choice: the least change of qdd and lambda together", function()
    -- from (x'', lambda) = (0.5, 0.1): min dx^2 + dl^2 with 0.5 + dx =
    -- 0.1 + dl gives dx = -0.2, dl = 0.2 (lambda was ignored: 0.25, 0.25)
    local _, _, rep = sys:project(0, { 0, 0 }, { 1, 0 }, { qdd = { 0.5, 0 }, lambda = { 0.1 } })
    assert(math.abs(rep.qdd[1] - 0.3) <= 1e-15 and math.abs(rep.lambda[1] - 0.3) <= 1e-15,
      ("qdd = %.17g, lambda = %.17g"):format(rep.qdd[1], rep.lambda[1]))
    -- a consistent pair is kept
    _, _, rep = sys:project(0, { 0, 0 }, { 1, 0 }, { qdd = { 0.7, 0 }, lambdas = { { 0.7 } } })
    assert.are.same({ 0.7, 0 }, rep.qdd)
    assert.are.equal(0.7, rep.lambda[1])
  end)
  it("unknown keys, levels the constraints do not have, and misshapen values are refused", function()
    h.checkerror("bad argument #4 to 'project' (unknown option 'lamda' (did you mean 'lambda'?) (options: lambda, "
      .. "lambdas, maxit, qdd, tol))", sys.project, sys, 0, { 0, 0 }, { 1, 0 }, { qdd = { 0.5, 0 }, lamda = { 1 } })
    h.checkerror("option 'q3d': the constraints are of order 3 at most, so the start has levels q .. qdd",
      sys.project, sys, 0, { 0, 0 }, { 1, 0 }, { q3d = { 0, 0 } })
    h.checkerror("option 'lambda': a table of 1 finite number (one multiplier per constraint) expected",
      sys.project, sys, 0, { 0, 0 }, { 1, 0 }, { lambda = { 1, 2 } })
    h.checkerror("options 'lambda' and 'lambdas': give one of them", sys.project, sys, 0, { 0, 0 }, { 1, 0 },
      { lambda = { 1 }, lambdas = { { 1 } } })
    local free = nz.system{ name = "free", coords = { "x" }, T = function(t, q, qd) return 0.5 * qd[1] ^ 2 end }
    h.checkerror("option 'qdd': no constraint is of order 3 or more, so the start is q and qd alone",
      free.project, free, 0, { 0 }, { 1 }, { qdd = { 1 } })
    h.checkerror("option 'lambda': no constraint is of order 3 or more, so the start has no multipliers",
      free.project, free, 0, { 0 }, { 1 }, { lambda = { 1 } })
  end)
end)

describe("integration at level 3: a servo constraint on the jerk", function()
  -- lambda' = m sin t / 5, so lambda = lambda0 + m (1 - cos t) / 5 and
  -- x = x0 + vx t + (F1 + lambda0) t^2 / (2m) + (t^2/2 - 1 + cos t) / 5,
  -- y = y0 + vy t + (F2 + 2 lambda0) t^2 / (2m) + 2 (t^2/2 - 1 + cos t) / 5.
  local sys = servo(3)
  local q0, qd0 = { 0.1, 0.2 }, { 0.3, -0.1 }
  it("sys:project completes qdd0 and the multiplier: (6.2) holds with them", function()
    local q, qd, rep = sys:project(0, q0, qd0, { qdd = { 0.2, 0.1 } })
    assert(max_diff(q, q0) == 0 and max_diff(qd, qd0) == 0)
    local l0 = rep.lambda[1]
    assert(max_diff(rep.qdd, { (F1 + l0) / m, (F2 + 2 * l0) / m }) <= 1e-14, ("%.17g %.17g"):format(rep.qdd[1], rep.qdd[2]))
  end)
  it("the motion, qdd and lambda follow the closed form to 1e-13 over 0 <= t <= 2.385", function()
    local _, _, rep = sys:project(0, q0, qd0, { qdd = { 0.2, 0.1 } })
    local l0 = rep.lambda[1]
    local tr = sys:simulate{ q0 = q0, qd0 = qd0, qdd0 = rep.qdd, t1 = 2.385, dt = 2.385 / 50, dense = false }   -- a step end at each point, as measured
    assert.are.equal("done", tr.status)
    local worst = 0
    for n, t in ipairs(tr.t) do
      local s = t * t / 2 - 1 + math.cos(t)
      local lam = l0 + m * (1 - math.cos(t)) / 5
      local x = q0[1] + qd0[1] * t + (F1 + l0) * t * t / (2 * m) + s / 5
      local y = q0[2] + qd0[2] * t + (F2 + 2 * l0) * t * t / (2 * m) + 2 * s / 5
      worst = math.max(worst, math.abs(tr.q[n][1] - x), math.abs(tr.q[n][2] - y), math.abs(tr.lambda[n][1] - lam),
        math.abs(tr.qdd[n][1] - (F1 + lam) / m), math.abs(tr.qdd[n][2] - (F2 + 2 * lam) / m))
    end
    -- rk8pd at rtol 1e-10: measured 6.7e-16 (the solution is smooth and the
    -- stepper takes few steps); 1e-13 leaves room for other libm/BLAS.
    assert(worst <= 1e-13, ("worst error %.3g"):format(worst))
  end)
  it("Tsenov's reduced equations at level 3 give q''' = (1, 2) sin t / 5 without the multipliers' rate", function()
    local t = 0.7
    local lam = 0.21
    local qdd = { (F1 + lam) / m, (F2 + 2 * lam) / m }
    local q3 = sys:reduced(t, q0, qd0, nil, { qdd = qdd, lambdas = { { lam } } })
    local s = math.sin(t) / 5
    assert(max_diff(q3, { s, 2 * s }) <= 1e-15, ("{%.17g, %.17g}"):format(q3[1], q3[2]))
  end)
  it("tr:column(\"x'''\") and tr:csv hold the run's q''' = (1, 2) sin t / 5 (closed form), from the equations of level 3", function()
    local _, _, rep = sys:project(0, q0, qd0, { qdd = { 0.2, 0.1 } })
    local tr = sys:simulate{ q0 = q0, qd0 = qd0, qdd0 = rep.qdd, t1 = 2, dt = 0.1 }
    local x3, y3 = tr:column("x'''"), tr:column("y'''")
    local worst = 0
    for n, t in ipairs(tr.t) do
      worst = math.max(worst, math.abs(x3[n] - math.sin(t) / 5), math.abs(y3[n] - 2 * math.sin(t) / 5))
    end
    -- the level-3 equations at the run's own q'' and lambda: rounding off
    -- the closed form (q''' does not depend on lambda here); bound 1e-13
    assert(worst <= 1e-13, ("worst error %.3g"):format(worst))
    assert.truthy(tr:plot{ y = { "x'''" }, width = 40, height = 12, quiet = true }:find("x'''", 1, true))
    -- a name with primes is quoted so that it reads: "x''''", not 'x'''''
    local ok, msg = pcall(tr.column, tr, "x''''")
    assert.is_false(ok)
    assert.truthy(msg:find([[no quantity "x''''": this run holds the derivatives up to x''' only]], 1, true), msg)
    assert.truthy(msg:find("x'', y'', x''', y''', lambda1", 1, true), msg)
    -- and tr:csv writes them, after q'' and before the multipliers, as the same numbers
    local text = tr:csv()
    local header = text:match("^[^\n]*")
    assert.are.equal("t,x,y,x',y',x'',y'',x''',y''',lambda1,violation", header)
    local n = 0
    for line in text:gmatch("\n([^\n]+)") do
      n = n + 1
      local cols = {}
      for v in line:gmatch("[^,]+") do cols[#cols + 1] = tonumber(v) end
      assert(cols[8] == x3[n] and cols[9] == y3[n] and cols[10] == tr.lambda[n][1], line)
    end
    assert.are.equal(#tr.t, n)
  end)
  it("tr.violation records the drift of (6.2): an inconsistent start (check = false) keeps its residual", function()
    -- qdd0 = (1/2, 1/2): the best multiplier minimizes (a - l)^2 + (b - 2 l)^2 with
    -- a = m/2 - F1, b = m/2 - F2, so l = (a + 2 b)/5 and the residual of (6.2) is
    -- (a - l, b - 2 l).  Level 3 enforces its derivative, so it stays constant.
    local a, b = m / 2 - F1, m / 2 - F2
    local l = (a + 2 * b) / 5
    local want = math.max(math.abs(a - l), math.abs(b - 2 * l))
    local tr = sys:simulate{ q0 = q0, qd0 = qd0, qdd0 = { 0.5, 0.5 }, t1 = 2, dt = 0.5, check = false }
    for n = 1, #tr.t do
      assert(math.abs(tr.violation[n] - want) <= 1e-13, ("t = %g: %.17g, want %.17g"):format(tr.t[n], tr.violation[n], want))
    end
    local good = sys:simulate{ q0 = q0, qd0 = qd0, qdd0 = { (F1 + 0.1) / m, (F2 + 0.2) / m }, t1 = 2, dt = 0.5 }
    for n = 1, #good.t do assert(good.violation[n] <= 1e-14, good.violation[n]) end
  end)
  it("a qdd0 that no multiplier makes consistent is refused, naming the equation", function()
    h.checkerror("the equation of motion (6.2) for 'x' (no multipliers satisfy it with this qdd) is violated",
      sys.simulate, sys, { q0 = q0, qd0 = qd0, qdd0 = { 0.5, 0.5 }, t1 = 1 })
  end)
  it("a missing qdd0, and qdd0 for a system that has no use for it are refused", function()
    h.checkerror("constraints of order 3 make qdd part of the state: give 'qdd0' = {...}",
      sys.simulate, sys, { q0 = q0, qd0 = qd0, t1 = 1 })
    local free = nz.system{ name = "free", coords = { "x" }, T = function(t, q, qd) return 0.5 * qd[1] ^ 2 end }
    h.checkerror("'qdd0' is for constraints of order 3 or more", free.simulate, free, { q0 = { 0 }, qdd0 = { 0 }, t1 = 1 })
  end)
  it("a nonlinear constraint of order 3 beside a linear one of order 4 is refused for integration", function()
    local s2 = nz.system{ name = "nl3", coords = { "x", "y" }, T = function(t, q, qd) return 0.5 * (qd[1] ^ 2 + qd[2] ^ 2) end,
      constraints = { function(t, q, qd, qdd, qddd) return qddd[1] - qddd[2] ^ 2 end,
        function(t, q, qd, qdd, qddd, q4d, p) return q4d[1] + q4d[2] end } }
    h.checkerror("constraint 2 (order 4, linear in q^(4)) and constraint 1 (order 3, nonlinear in q^(3)) cannot be integrated together",
      s2.simulate, s2, { q0 = { 0, 0 }, qdd0 = { 0, 0 }, t1 = 1 })
  end)
end)

describe("integration at level 3 with a holonomic constraint beside it, and events", function()
  -- The servo particle in space on the plane z = 0 under gravity: (6.2) for z reads
  -- m z'' = -m g + mu, and z'' = 0 (the plane, twice differentiated) gives mu = m g;
  -- x and y move as in the plane (closed form above).
  local g = 9.81
  local sys = nz.system{ name = "servo in space", coords = { "x", "y", "z" },
    T = function(t, q, qd) return 0.5 * m * (qd[1] ^ 2 + qd[2] ^ 2 + qd[3] ^ 2) end,
    Q = function() return { F1, F2, -m * g } end,
    constraints = { function(t, q, qd, qdd, qddd) return qddd[1] + 2 * qddd[2] - nz.sin(t) end,
      function(t, q) return q[3] end } }
  local q0, qd0 = { 0.1, 0.2, 0 }, { 0.3, -0.1, 0 }
  local function x_exact(t, l0)
    return q0[1] + qd0[1] * t + (F1 + l0) * t * t / (2 * m) + (t * t / 2 - 1 + math.cos(t)) / 5
  end
  it("sys:project completes qdd0 with z'' = 0 and the plane's multiplier m g; the motion follows the closed form", function()
    local _, _, rep = sys:project(0, q0, qd0, { qdd = { 0.2, 0.1, 0.3 } })
    -- one least-squares solve: measured |z''| = 1.9e-15
    assert(math.abs(rep.qdd[3]) <= 1e-14 and math.abs(rep.lambda[2] - m * g) <= 1e-13, ("%.17g %.17g"):format(rep.qdd[3], rep.lambda[2]))
    local tr = sys:simulate{ q0 = q0, qd0 = qd0, qdd0 = rep.qdd, t1 = 2, dt = 0.25 }
    local worst = 0
    for n, t in ipairs(tr.t) do
      worst = math.max(worst, math.abs(tr.q[n][1] - x_exact(t, rep.lambda[1])), math.abs(tr.q[n][3]),
        math.abs(tr.lambda[n][2] - m * g))
    end
    -- rk8pd at rtol 1e-10: measured about 1e-14 (z'' = 0 exactly at level 3, so z stays 0).
    assert(worst <= 1e-12, ("worst error %.3g"):format(worst))
  end)
  it("an event x = 1 stops the run where the closed form crosses 1", function()
    local _, _, rep = sys:project(0, q0, qd0, { qdd = { 0.2, 0.1, 0 } })
    local l0 = rep.lambda[1]
    local tr = sys:simulate{ q0 = q0, qd0 = qd0, qdd0 = rep.qdd, t1 = 5, dt = 0.5,
      events = { { f = function(t, q) return q[1] - 1 end, stop = true, name = "x = 1" } } }
    local a, b = 0, 5                 -- x is increasing here: bisect the closed form
    for _ = 1, 200 do
      local c = 0.5 * (a + b)
      if x_exact(c, l0) < 1 then a = c else b = c end
    end
    assert.are.equal("stopped", tr.status)
    -- located to event_tol 1e-12 on a state accurate to about 1e-14
    assert(math.abs(tr.events[1].t - a) <= 1e-11, ("%.17g vs %.17g"):format(tr.events[1].t, a))
  end)
end)

describe("integration at level 3 beside Hamel's nonlinear second-order constraint", function()
  it("q3'' = q1'' q2'' and (6.2) of order 1 hold along the motion (from tr.qdd and tr.lambda)", function()
    local M = 1.5
    local sys = nz.system{ name = "hamel and jerk", coords = { "q1", "q2", "q3", "q4" },
      T = function(t, q, qd) return 0.5 * M * (qd[1] ^ 2 + qd[2] ^ 2 + qd[3] ^ 2 + qd[4] ^ 2) end,
      Q = function() return { 0.7, -0.4, 2.0, 0.3 } end,
      constraints = { function(t, q, qd, qdd) return qdd[3] - qdd[1] * qdd[2] end,
        function(t, q, qd, qdd, qddd) return qddd[4] + qddd[1] - nz.sin(t) end } }
    assert.are.equal(3, (sys:rule()))
    local q0, qd0 = { 0, 0, 0, 0 }, { 0.4, -0.5, 0.6, 0.1 }
    local _, _, rep = sys:project(0, q0, qd0, { qdd = { 0.5, -0.2, -0.1, 0.2 } })
    local tr = sys:simulate{ q0 = q0, qd0 = qd0, qdd0 = rep.qdd, t1 = 5, dt = 0.5 }
    local wc, wr = 0, 0
    for n = 1, #tr.t do
      local a = tr.qdd[n]
      wc = math.max(wc, math.abs(a[3] - a[1] * a[2]))
      local r = sys:residual(1, tr.t[n], tr.q[n], tr.qd[n], a, tr.lambda[n])
      for i = 1, 4 do wr = math.max(wr, math.abs(r[i])) end
    end
    -- level 3 holds their derivatives; measured drift 3.4e-12 and 4.0e-12 over t = 5 (rk8pd, rtol 1e-10)
    assert(wc <= 1e-11 and wr <= 1e-11, ("constraint %.3g, (6.2) %.3g"):format(wc, wr))
  end)
end)

describe("integration at level 3: a chain of integrators", function()
  -- y on a spring (V = c y^2 / 2, unit mass) drives x''' = y: y = Y cos(w t) + (vy / w) sin(w t),
  -- and three integrations of x''' = Y cos w t + B sin w t give x (below).  The
  -- multiplier is x'' itself: (6.2) for x reads x'' = lambda.
  local c = 2.385
  local w = math.sqrt(c)
  local sys = nz.system{ name = "chain", coords = { "x", "y" },
    T = function(t, q, qd) return 0.5 * (qd[1] ^ 2 + qd[2] ^ 2) end,
    V = function(t, q) return 0.5 * c * q[2] ^ 2 end,
    constraints = { function(t, q, qd, qdd, qddd) return qddd[1] - q[2] end } }
  it("x, y and lambda = x'' follow the closed form to 1e-13", function()
    local q0, qd0, ax = { 0.4, 0.7 }, { -0.2, 0.35 }, 0.15
    local Y, B = q0[2], qd0[2] / w
    local tr = sys:simulate{ q0 = q0, qd0 = qd0, qdd0 = { ax, -c * q0[2] }, t1 = 3, dt = 0.1 }
    local worst = 0
    for n, t in ipairs(tr.t) do
      local x = q0[1] + qd0[1] * t + ax * t * t / 2 + Y / (w * w) * (t - math.sin(w * t) / w)
        + B / w * (t * t / 2 - (1 - math.cos(w * t)) / (w * w))
      local xdd = ax + Y / w * math.sin(w * t) + B / w * (1 - math.cos(w * t))
      local y = Y * math.cos(w * t) + B * math.sin(w * t)
      worst = math.max(worst, math.abs(tr.q[n][1] - x), math.abs(tr.q[n][2] - y), math.abs(tr.lambda[n][1] - xdd))
    end
    -- rk8pd at rtol 1e-10: measured 6.9e-15 (chain) / 4.4e-16 (level 4); 1e-13 leaves room.
    assert(worst <= 1e-13, ("worst error %.3g"):format(worst))
  end)
  it("y'' must be -c y at the start: no multiplier acts on y", function()
    h.checkerror("the equation of motion (6.2) for 'y'", sys.simulate, sys,
      { q0 = { 0.4, 0.7 }, qdd0 = { 0, 0 }, t1 = 1 })
  end)
end)

describe("integration at level 4 (constant gradient)", function()
  -- lambda'' = m cos t / 5: lambda = l0 + l1 t + m (1 - cos t) / 5, and
  -- x = x0 + vx t + (F1 + l0) t^2/(2m) + l1 t^3/(6m) + (t^2/2 - 1 + cos t)/5 (y: 2 lambda, F2).
  local sys = servo(4)
  it("the start needs qdd0 and q3d0; sys:project completes both; the motion follows the closed form", function()
    local q0, qd0 = { -0.3, 0.8 }, { 0.05, 0.4 }
    h.checkerror("give 'q3d0' = {...}", sys.simulate, sys, { q0 = q0, qd0 = qd0, qdd0 = { 0, 0 }, t1 = 1 })
    local _, _, rep = sys:project(0, q0, qd0, { qdd = { 0.1, 0.2 }, q3d = { 0.3, -0.1 } })
    local l0, l1 = rep.lambdas[1][1], rep.lambdas[2][1]
    assert(max_diff(rep.q3d, { l1 / m, 2 * l1 / m }) <= 1e-14)
    local tr = sys:simulate{ q0 = q0, qd0 = qd0, qdd0 = rep.qdd, q3d0 = rep.q3d, t1 = 2, dt = 0.1 }
    local worst, wl = 0, 0
    for n, t in ipairs(tr.t) do
      local s = t * t / 2 - 1 + math.cos(t)
      local x = q0[1] + qd0[1] * t + (F1 + l0) * t * t / (2 * m) + l1 * t ^ 3 / (6 * m) + s / 5
      local y = q0[2] + qd0[2] * t + (F2 + 2 * l0) * t * t / (2 * m) + 2 * l1 * t ^ 3 / (6 * m) + 2 * s / 5
      local lam = l0 + l1 * t + m * (1 - math.cos(t)) / 5
      worst = math.max(worst, math.abs(tr.q[n][1] - x), math.abs(tr.q[n][2] - y),
        math.abs(tr.higher[n][1][1] - (l1 + m * math.sin(t) / 5) / m))
      wl = math.max(wl, math.abs(tr.lambda[n][1] - lam))
    end
    -- rk8pd at rtol 1e-10: measured 3.3e-15 in x, y and q'''; 1e-13 leaves
    -- room.  lambda (a state of level 4, from l0 = 0.29, what (6.2) needs
    -- at the consistent qdd nearest to (0.1, 0.2)) 1.3e-13; 5e-13.
    assert(worst <= 1e-13, ("worst error %.3g"):format(worst))
    assert(wl <= 5e-13, ("worst error of lambda %.3g"):format(wl))
    -- q''' is part of the state: a column, the closed form's 2 (l1 + m sin t / 5) / m for y
    local y3 = tr:column("y'''")
    for n, t in ipairs(tr.t) do assert(math.abs(y3[n] - 2 * (l1 + m * math.sin(t) / 5) / m) <= 1e-13, y3[n]) end
  end)
  it("Tsenov's reduced equations at level 4 give q^(4) = (1, 2) cos t / 5", function()
    local t, l0, l1 = 1.3, 0.4, -0.25
    local q4 = sys:reduced(t, { 0.1, 0.2 }, { 0.3, 0.4 }, nil, { qdd = { (F1 + l0) / m, (F2 + 2 * l0) / m },
      q3d = { l1 / m, 2 * l1 / m }, lambdas = { { l0 }, { l1 } } })
    local c = math.cos(t) / 5
    assert(max_diff(q4, { c, 2 * c }) <= 1e-15, ("{%.17g, %.17g}"):format(q4[1], q4[2]))
  end)
  it("a gradient that depends on q''' does not close at level 4: a clear error", function()
    local s2 = nz.system{ name = "open4", coords = { "x", "y" }, T = function(t, q, qd) return 0.5 * (qd[1] ^ 2 + qd[2] ^ 2) end,
      constraints = { function(t, q, qd, qdd, qddd, q4d, p) return q4d[1] + qddd[1] * q4d[2] end } }
    h.checkerror("constraint 1: its gradient dPhi/dq^(m) depends on q''' or higher", s2.simulate, s2,
      { q0 = { 0, 0 }, qd0 = { 0, 0 }, qdd0 = { 0, 0 }, q3d0 = { 0.5, 0 }, t1 = 1 })
  end)
end)

describe("integration at level 3: a constraint nonlinear in q''' (Hamel's one order up)", function()
  -- A particle of mass M under constant forces Q with Phi = q3''' - q1''' q2''':
  -- A = dPhi/dq''' = (-q2''', -q1''', 1), and (6.2), M q'' - Q = lambda A, gives by hand
  --   M q1'' = Q1 - lambda q2''',  M q2'' = Q2 - lambda q1''',  M q3'' = Q3 + lambda,
  -- so lambda = M q3'' - Q3 comes from the state (q'' is part of it), then
  --   q2''' = (Q1 - M q1'') / lambda,  q1''' = (Q2 - M q2'') / lambda,  q3''' = q1''' q2'''.
  -- Nothing constrains qdd0 beyond lambda != 0 (M q3'' != Q3).
  local M, Q = 1.3, { 0.7, -0.4, 2.0 }
  local function hamel3(extra)
    local cs = { function(t, q, qd, qdd, qddd) return qddd[3] - qddd[1] * qddd[2] end }
    if extra then cs[2] = extra end
    return nz.system{ name = "hamel3", coords = { "q1", "q2", "q3" },
      T = function(t, q, qd) return 0.5 * M * (qd[1] ^ 2 + qd[2] ^ 2 + qd[3] ^ 2) end,
      Q = function() return { Q[1], Q[2], Q[3] } end, constraints = cs }
  end
  local sys = hamel3()
  local function jerk(qdd)
    local lambda = M * qdd[3] - Q[3]
    local j1, j2 = (Q[2] - M * qdd[2]) / lambda, (Q[1] - M * qdd[1]) / lambda
    return { j1, j2, j1 * j2 }, lambda
  end
  -- A plain RK4 on y = (q, q', q''), written here and sharing no code with nzlua.
  local function hand_rk4(y, t1, nsteps)
    local function f(v)
      local j = jerk({ v[7], v[8], v[9] })
      return { v[4], v[5], v[6], v[7], v[8], v[9], j[1], j[2], j[3] }
    end
    local h = t1 / nsteps
    for _ = 1, nsteps do
      local function add(a, b, s) local o = {}; for i = 1, 9 do o[i] = a[i] + s * b[i] end; return o end
      local k1 = f(y); local k2 = f(add(y, k1, h / 2)); local k3 = f(add(y, k2, h / 2)); local k4 = f(add(y, k3, h))
      for i = 1, 9 do y[i] = y[i] + h / 6 * (k1[i] + 2 * k2[i] + 2 * k3[i] + k4[i]) end
    end
    return y
  end
  local q0, qd0, qdd0 = { 0.2, -0.1, 0.3 }, { 0.4, -0.5, 0.6 }, { 0.3, -0.2, 0.5 }

  it("Dolapchiev's rule gives n = 4", function()
    assert.are.equal(4, (sys:rule()))
  end)
  it("the motion, q'' and lambda follow the hand equations integrated by a plain RK4 (rk8pd, and bsimp)", function()
   for _, method in ipairs{ "rk8pd", "bsimp" } do
    local tr = sys:simulate{ q0 = q0, qd0 = qd0, qdd0 = qdd0, t1 = 2, dt = 0.25, method = method }
    assert.are.equal("done", tr.status)
    assert.are.equal("least squares", tr.branch.from)
    local worst = 0
    for n, t in ipairs(tr.t) do
      local y = { q0[1], q0[2], q0[3], qd0[1], qd0[2], qd0[3], qdd0[1], qdd0[2], qdd0[3] }
      if t > 0 then y = hand_rk4(y, t, math.floor(t * 400 + 0.5)) end
      local j, lambda = jerk({ y[7], y[8], y[9] })
      for i = 1, 3 do
        worst = math.max(worst, math.abs(tr.q[n][i] - y[i]), math.abs(tr.qd[n][i] - y[3 + i]),
          math.abs(tr.qdd[n][i] - y[6 + i]), math.abs(tr.top[n][i] - j[i]))
      end
      worst = math.max(worst, math.abs(tr.lambda[n][1] - lambda))
    end
    -- The hand RK4 at h = 1/400 differs from h = 1/1600 by 3.8e-13 at t = 2;
    -- at rtol 1e-10 measured worst differences 2.5e-12 (rk8pd), 3.8e-13 (bsimp).
    assert(worst <= 1e-11, ("%s: worst difference %.3g"):format(method, worst))
   end
  end)
  it("the residuals of every form at n = 4 vanish with the solved q''' and lambda", function()
    local tr = sys:simulate{ q0 = q0, qd0 = qd0, qdd0 = qdd0, t1 = 1, dt = 0.5 }
    local worst = 0
    for n, t in ipairs(tr.t) do
      for _, form in ipairs{ "generalized", "lagrange", "difference", "euler", "appell", "extremal" } do
        local r = sys:residual(4, t, tr.q[n], tr.qd[n], tr.qdd[n], tr.lambda[n], { form = form, higher = { tr.top[n] } })
        for i = 1, 3 do worst = math.max(worst, math.abs(r[i])) end
      end
      local c = tr.top[n]
      worst = math.max(worst, math.abs(c[3] - c[1] * c[2]))
    end
    -- Newton's tolerance 1e-12 relative, then one polishing step: measured 1.8e-15.
    assert(worst <= 1e-13, ("worst residual %.3g"):format(worst))
  end)
  it("where lambda = 0 (M q'' = Q) q''' is not determined: an error naming the state", function()
    -- Every q''' with q3''' = q1''' q2''' is a root there: the Jacobian at the root is singular.
    local rest = { Q[1] / M, Q[2] / M, Q[3] / M }
    h.checkerror("the Jacobian of (6.2) and the constraints in (q^(3), lambda) is singular", sys.simulate, sys,
      { q0 = q0, qd0 = qd0, qdd0 = rest, t1 = 1 })
    h.checkerror("qdd = {0.538462, -0.307692, 1.53846}: the motion is not determined there", sys.simulate, sys,
      { q0 = q0, qd0 = qd0, qdd0 = rest, t1 = 1 })
  end)
  it("where M q3'' = Q3 but M q1'' != Q1 there is no root: Newton's failure, with the state", function()
    -- The third row of (6.2) forces lambda = 0, and then the first reads M q1'' = Q1.
    -- its least-squares step from the start is zero: said so, not "did not converge in 0 iterations"
    h.checkerror("Newton's method on (6.2) and the constraints for (q^(3), lambda) stopped at its start: its first "
      .. "step is zero (residual", sys.simulate, sys, { q0 = q0, qd0 = qd0, qdd0 = { 0.3, -0.2, Q[3] / M }, t1 = 1 })
    h.checkerror("qdd = {0.3, -0.2, 1.53846}: give Newton a start with simulate{..., guess = {lambda = ..., q3d = ...}}",
      sys.simulate, sys, { q0 = q0, qd0 = qd0, qdd0 = { 0.3, -0.2, Q[3] / M }, t1 = 1 })
  end)
  it("Newton starts from a guess when given, and says so; a malformed guess is refused", function()
    local tr = sys:simulate{ q0 = q0, qd0 = qd0, qdd0 = qdd0, t1 = 0.5, dt = 0.5, guess = { lambda = { -1 }, q3d = { 0.1, -0.2, 0 } } }
    local j, lambda = jerk(qdd0)
    assert.are.equal("guess", tr.branch.from)
    assert(max_diff(tr.branch.q3d, j) <= 1e-14 and math.abs(tr.branch.lambda[1] - lambda) <= 1e-14)
    h.checkerror("'guess' must be {lambda = {...}, q3d = {...}}", sys.simulate, sys,
      { q0 = q0, qd0 = qd0, qdd0 = qdd0, t1 = 1, guess = { 1 } })
  end)
  it("a holonomic constraint beside it: qdd0 is checked, and sys:project completes it", function()
    -- q1 = q2 on top: q1'' = q2'' is required at the start (levels 0, 1 by check_state).
    local s2 = hamel3(function(t, q) return q[1] - q[2] end)
    local qa, qda = { 0.2, 0.2, 0.3 }, { 0.4, 0.4, 0.6 }
    h.checkerror("constraint 2 differentiated 2 times is violated by 0.5", s2.simulate, s2,
      { q0 = qa, qd0 = qda, qdd0 = qdd0, t1 = 1 })
    local _, _, rep = s2:project(0, qa, qda, { qdd = qdd0 })
    -- the least change of qdd0 with q1'' = q2'': both move to their mean 0.05
    assert(max_diff(rep.qdd, { 0.05, 0.05, 0.5 }) <= 1e-12, ("{%.17g, %.17g, %.17g}"):format(rep.qdd[1], rep.qdd[2], rep.qdd[3]))
    local tr = s2:simulate{ q0 = qa, qd0 = qda, qdd0 = rep.qdd, t1 = 1, dt = 0.25 }
    for n = 1, #tr.t do
      assert(math.abs(tr.q[n][1] - tr.q[n][2]) <= 1e-12 and tr.violation[n] <= 1e-12, tr.violation[n])
    end
  end)
  it("Tsenov's elimination is refused with the reason", function()
    h.checkerror("Tsenov's elimination does not apply", sys.reduced, sys, 0, q0, qd0)
  end)
  it("an event q3 = 0.8 is located where the hand RK4 puts q3 = 0.8", function()
    local tr = sys:simulate{ q0 = q0, qd0 = qd0, qdd0 = qdd0, t1 = 2, dt = 0.5,
      events = { { f = function(t, q) return q[3] - 0.8 end, stop = true, name = "q3 = 0.8" } } }
    assert.are.equal("stopped", tr.status)
    local te = tr.events[1].t
    local y = hand_rk4({ q0[1], q0[2], q0[3], qd0[1], qd0[2], qd0[3], qdd0[1], qdd0[2], qdd0[3] }, te, 400)
    -- event_tol 1e-12 on a state accurate to about 1e-12: measured 4.6e-14 (te = 0.6555)
    assert(math.abs(y[3] - 0.8) <= 1e-12, ("q3(%.15g) = %.15g by hand"):format(te, y[3]))
  end)
end)

describe("integration at level 3: two roots, and the branch Newton's start picks", function()
  -- |q'''|^2 = c for a particle under a constant force Q: A = 2 q''', and (6.2),
  -- u = M q'' - Q = 2 lambda q''', gives q''' = s sqrt(c) u/|u| with s = sign(lambda):
  -- two roots.  Then u' = M q''' keeps u's direction e, so q''' = s sqrt(c) e is constant,
  -- q = q0 + qd0 t + qdd0 t^2/2 + s sqrt(c) e t^3/6 and lambda = s |u| / (2 sqrt c) with
  -- |u| = |u0| + s M sqrt(c) t (lambda passes through 0 at t = 0.169 for s = -1, smoothly).
  local M, Q, c = 1.3, { 0.7, -0.4 }, 2.385
  local sys = nz.system{ name = "jerk circle", coords = { "x", "y" },
    T = function(t, q, qd) return 0.5 * M * (qd[1] ^ 2 + qd[2] ^ 2) end,
    Q = function() return { Q[1], Q[2] } end,
    constraints = { function(t, q, qd, qdd, qddd) return qddd[1] ^ 2 + qddd[2] ^ 2 - c end } }
  local q0, qd0, qdd0 = { 0.2, -0.1 }, { 0.4, -0.5 }, { 0.3, -0.2 }
  it("without a guess Newton cannot start (q''' = 0 makes A = 0): the error asks for one", function()
    h.checkerror("the Jacobian is singular at the last iterate and no step reduces the residual", sys.simulate, sys,
      { q0 = q0, qd0 = qd0, qdd0 = qdd0, t1 = 1 })
  end)
  it("guess lambda > 0 or < 0 selects the branch s, which the run keeps (closed form)", function()
    local u0 = { M * qdd0[1] - Q[1], M * qdd0[2] - Q[2] }
    local nu = math.sqrt(u0[1] ^ 2 + u0[2] ^ 2)
    local e, w = { u0[1] / nu, u0[2] / nu }, math.sqrt(c)
    for _, s in ipairs{ 1, -1 } do
      local tr = sys:simulate{ q0 = q0, qd0 = qd0, qdd0 = qdd0, t1 = 0.5, dt = 0.1, guess = { lambda = { 2.385 * s } } }
      assert.are.equal("guess", tr.branch.from)
      assert(tr.branch.lambda[1] * s > 0, tr.branch.lambda[1])
      local worst = 0
      for n, t in ipairs(tr.t) do
        for i = 1, 2 do
          local q = q0[i] + qd0[i] * t + qdd0[i] * t * t / 2 + s * w * e[i] * t ^ 3 / 6
          worst = math.max(worst, math.abs(tr.q[n][i] - q), math.abs(tr.top[n][i] - s * w * e[i]))
        end
        worst = math.max(worst, math.abs(tr.lambda[n][1] - s * (nu + s * M * w * t) / (2 * w)))
      end
      -- rk8pd at rtol 1e-10: measured 2.2e-16 (s = 1) and 4.5e-13 (s = -1, through lambda = 0)
      assert(worst <= 5e-12, ("s = %d: worst error %.3g"):format(s, worst))
    end
  end)
end)

describe("implicit steppers at level p >= 3: the Jacobian by central differences", function()
  local constraints = require "nz.model.constraints"
  local function integrator(sys, cfg)
    local orders, linear = constraints.orders(sys)
    sys.engine.orders = orders
    cfg.orders, cfg.linear = orders, linear
    return mech.ode_new(sys.engine, cfg)
  end
  it("the jerk servo's Jacobian is the closed form: a shift, and dfdt = (0, 0, 0, 0, 1, 2, m) cos t / 5", function()
    -- y = (x, y, x', y', x'', y'', lambda): f = (x', y', x'', y'', sin t/5, 2 sin t/5, m sin t/5).
    local sys = servo(3)
    local ode = integrator(sys, { method = "bsimp", level = 3 })
    local t, y = 0.7, { 0.1, 0.2, 0.3, -0.1, 0.25, 0.4, 0.33 }
    local J, dfdt = mech.ode_jacobian(ode, sys.engine, t, y)
    local wy, wt = 0, 0
    for i = 1, 7 do
      for j = 1, 7 do wy = math.max(wy, math.abs(J[i][j] - ((i <= 4 and j == i + 2) and 1 or 0))) end
    end
    local c = math.cos(t) / 5
    local want = { 0, 0, 0, 0, c, 2 * c, m * c }
    for i = 1, 7 do wt = math.max(wt, math.abs(dfdt[i] - want[i])) end
    -- f is affine in y: exact differences (measured 0); dfdt: h_t = 6e-6 (1 + t), rounding
    -- eps |f| / h_t and truncation h_t^2 |f'''| / 6, measured 5.5e-12.
    assert(wy <= 1e-12 and wt <= 5e-11, ("dfdy %.3g, dfdt %.3g"):format(wy, wt))
  end)
  it("a nonlinear level-3 Jacobian agrees with central differences at another step (1e-4)", function()
    local M, Q = 1.3, { 0.7, -0.4, 2.0 }
    local sys = nz.system{ name = "hamel3", coords = { "q1", "q2", "q3" },
      T = function(t, q, qd) return 0.5 * M * (qd[1] ^ 2 + qd[2] ^ 2 + qd[3] ^ 2) end,
      Q = function() return { Q[1], Q[2], Q[3] } end,
      constraints = { function(t, q, qd, qdd, qddd) return qddd[3] - qddd[1] * qddd[2] end } }
    local ode = integrator(sys, { method = "bsimp", level = 3, top = true })
    local t, y = 0.4, { 0.2, -0.1, 0.3, 0.4, -0.5, 0.6, 0.3, -0.2, 0.5 }
    local J, dfdt = mech.ode_jacobian(ode, sys.engine, t, y)
    local worst, hh = 0, 1e-4
    for j = 0, 9 do                    -- j = 0: the time column
      local yp, ym, tp, tm = { table.unpack(y) }, { table.unpack(y) }, t, t
      if j == 0 then tp, tm = t + hh, t - hh else yp[j], ym[j] = y[j] + hh, y[j] - hh end
      local fp, fm = mech.ode_rhs(ode, sys.engine, tp, yp), mech.ode_rhs(ode, sys.engine, tm, ym)
      for i = 1, 9 do
        local d = (fp[i] - fm[i]) / (2 * hh)
        worst = math.max(worst, math.abs((j == 0 and dfdt[i] or J[i][j]) - d))
      end
    end
    -- the columns are of size 1; truncation at h = 1e-4 is h^2 |f'''| / 6: measured 2.0e-9
    assert(worst <= 1e-8, ("worst difference %.3g"):format(worst))
  end)
  it("bsimp and msbdf reproduce the jerk servo's closed form", function()
    local sys = servo(3)
    local q0, qd0 = { 0.1, 0.2 }, { 0.3, -0.1 }
    local _, _, rep = sys:project(0, q0, qd0, { qdd = { 0.2, 0.1 } })
    local l0 = rep.lambda[1]
    -- at rtol 1e-10: measured 1.6e-14 (bsimp, 54 steps) and 4.0e-9 (msbdf, 591 steps,
    -- its variable order stays low on this smooth motion)
    for method, bound in pairs{ bsimp = 1e-12, msbdf = 2e-8 } do
      local tr = sys:simulate{ q0 = q0, qd0 = qd0, qdd0 = rep.qdd, t1 = 2.385, dt = 2.385 / 50, method = method,
        dense = false }   -- a step end at each point, as measured
      assert.are.equal("done", tr.status)
      assert(tr.stats.njev > 0, method)
      local worst = 0
      for n, t in ipairs(tr.t) do
        local s = t * t / 2 - 1 + math.cos(t)
        local lam = l0 + m * (1 - math.cos(t)) / 5
        local x = q0[1] + qd0[1] * t + (F1 + l0) * t * t / (2 * m) + s / 5
        local y = q0[2] + qd0[2] * t + (F2 + 2 * l0) * t * t / (2 * m) + 2 * s / 5
        worst = math.max(worst, math.abs(tr.q[n][1] - x), math.abs(tr.q[n][2] - y), math.abs(tr.lambda[n][1] - lam))
      end
      assert(worst <= bound, ("%s: worst error %.3g"):format(method, worst))
    end
  end)
end)

describe("project = true at level p >= 3", function()
  -- The jerk servo on the circle x^2 + z^2 = 1 under gravity: no closed form, so the
  -- checks are the constraints and (6.2) evaluated by hand from tr.q, tr.qd, tr.qdd, tr.lambda.
  local g = 9.81
  local sys = nz.system{ name = "servo on a circle", coords = { "x", "y", "z" },
    T = function(t, q, qd) return 0.5 * m * (qd[1] ^ 2 + qd[2] ^ 2 + qd[3] ^ 2) end,
    Q = function() return { F1, F2, -m * g } end,
    constraints = { function(t, q, qd, qdd, qddd) return qddd[1] + 2 * qddd[2] - nz.sin(t) end,
      function(t, q) return q[1] ^ 2 + q[3] ^ 2 - 1 end } }
  local function drift(tr)
    local w = 0
    for n = 1, #tr.t do
      local q, qd, a, l = tr.q[n], tr.qd[n], tr.qdd[n], tr.lambda[n]
      w = math.max(w, math.abs(q[1] ^ 2 + q[3] ^ 2 - 1), math.abs(q[1] * qd[1] + q[3] * qd[3]),
        math.abs(q[1] * a[1] + qd[1] ^ 2 + q[3] * a[3] + qd[3] ^ 2))
      -- (6.2): m q'' - Q = lambda1 (1, 2, 0) + lambda2 (2x, 0, 2z)
      w = math.max(w, math.abs(m * a[1] - F1 - l[1] - 2 * q[1] * l[2]), math.abs(m * a[2] - F2 - 2 * l[1]),
        math.abs(m * a[3] + m * g - 2 * q[3] * l[2]))
    end
    return w
  end
  it("holds the circle, its derivatives and (6.2) along 20 s, which drift without it", function()
    local q0, qd0 = { 1, 0.2, 0 }, { 0, -0.1, 0.3 }
    local _, _, rep = sys:project(0, q0, qd0, { qdd = { 0.2, 0.1, 0.3 } })
    local opts = { q0 = q0, qd0 = qd0, qdd0 = rep.qdd, t1 = 20, dt = 1, rtol = 1e-8, atol = 1e-10 }
    local free = drift(sys:simulate(opts))
    opts.project = true
    local held = drift(sys:simulate(opts))
    -- measured 1.1e-6 without projection; with it the state goes back onto
    -- the constraints (to 1e-12) whenever its violation exceeds simulate's
    -- PROJECT_TOL (1e-10): measured 8.6e-11
    local bound = require("nz.motion.simulate").PROJECT_TOL
    assert(free > 1e-8 and held <= bound, ("without %.3g, with %.3g"):format(free, held))
  end)
  it("with a constraint nonlinear in q''' (top level) it holds the circle too", function()
    local h3 = require("tests.constraint_systems").hamel3_on_circle()
    local s3, q0, qd0 = h3.sys, h3.q0, h3.qd0
    local _, _, rep = s3:project(0, q0, qd0, { qdd = { 0.3, -0.2, 0.5 } })
    -- the least change of qdd0 onto q1 q1'' + q2 q2'' = -(q1'^2 + q2'^2) = -0.25: the
    -- residual 0.18 - 0.16 + 0.25 = 0.27 moves (q1'', q2'') by -0.27 (0.6, 0.8)
    assert(max_diff(rep.qdd, { 0.138, -0.416, 0.5 }) <= 1e-12, ("{%.17g, %.17g}"):format(rep.qdd[1], rep.qdd[2]))
    local function worst(tr)
      local w = 0
      for n = 1, #tr.t do
        local q, qd, a = tr.q[n], tr.qd[n], tr.qdd[n]
        w = math.max(w, math.abs(q[1] ^ 2 + q[2] ^ 2 - 1), math.abs(q[1] * qd[1] + q[2] * qd[2]),
          math.abs(q[1] * a[1] + qd[1] ^ 2 + q[2] * a[2] + qd[2] ^ 2))
      end
      return w
    end
    -- At rtol 1e-6 the circle drifts past simulate's PROJECT_TOL (1e-10):
    -- measured 6.2e-10 free, 3.1e-11 with projection (2 projections).
    local opts = { q0 = q0, qd0 = qd0, qdd0 = rep.qdd, t1 = 1, dt = 0.25, rtol = 1e-6, atol = 1e-8 }
    local free = worst(s3:simulate(opts))
    opts.project = true
    local tr = s3:simulate(opts)
    local bound = require("nz.motion.simulate").PROJECT_TOL
    assert(free > bound and worst(tr) <= bound and tr.projections > 0,
      ("without %.3g, with %.3g after %d projections"):format(free, worst(tr), tr.projections))
  end)
end)

describe("level p >= 3: what is refused", function()
  it("baumgarte and the work monitor, with the reason", function()
    local sys = servo(3)
    local o = { q0 = { 0, 0 }, qd0 = { 0, 0 }, qdd0 = { F1 / m, F2 / m }, t1 = 1 }
    o.baumgarte = 2.385
    h.checkerror("'baumgarte' is not available with constraints of order 3", sys.simulate, sys, o)
    o.baumgarte, o.monitors = nil, { work = true }
    h.checkerror("the 'work' monitor is not available with constraints of order 3", sys.simulate, sys, o)
  end)
  it("sys:project says when a level cannot be completed (q1''^2 + 1 = 0 has no real root)", function()
    local sys = nz.system{ name = "no root", coords = { "q1", "q2", "q3" },
      T = function(t, q, qd) return 0.5 * (qd[1] ^ 2 + qd[2] ^ 2 + qd[3] ^ 2) end,
      constraints = { function(t, q, qd, qdd, qddd) return qddd[3] - qddd[1] * qddd[2] end,
        function(t, q, qd, qdd) return qdd[1] ^ 2 + 1 end } }
    h.checkerror("completing qdd of the start state did not converge in 5 steps", sys.project, sys, 0,
      { 0, 0, 0 }, { 0, 0, 0 }, { qdd = { 0.5, 0, 0 }, maxit = 5 })
  end)
end)

describe("integration at level 4: a constraint nonlinear in q^(4)", function()
  -- Phi = q3^(4) - q1^(4) q2^(4) on the particle of the level-3 case: (6.2) by hand gives
  -- lambda = M q3'' - Q3, q2^(4) = (Q1 - M q1'') / lambda, q1^(4) = (Q2 - M q2'') / lambda;
  -- the state is (q, q', q'', q''') and the start needs qdd0 and q3d0 only.
  local M, Q = 1.3, { 0.7, -0.4, 2.0 }
  local sys = nz.system{ name = "hamel4", coords = { "q1", "q2", "q3" },
    T = function(t, q, qd) return 0.5 * M * (qd[1] ^ 2 + qd[2] ^ 2 + qd[3] ^ 2) end,
    Q = function() return { Q[1], Q[2], Q[3] } end,
    constraints = { function(t, q, qd, qdd, qddd, q4d, p) return q4d[3] - q4d[1] * q4d[2] end } }
  local function f(v)                  -- v = (q, q', q'', q'''): a plain RK4's right-hand side
    local lambda = M * v[9] - Q[3]
    local a1, a2 = (Q[2] - M * v[8]) / lambda, (Q[1] - M * v[7]) / lambda
    local out = {}
    for i = 1, 9 do out[i] = v[i + 3] end
    out[10], out[11], out[12] = a1, a2, a1 * a2
    return out
  end
  it("Dolapchiev's n = 5; the motion follows the hand equations integrated by RK4", function()
    assert.are.equal(5, (sys:rule()))
    local y = { 0.2, -0.1, 0.3, 0.4, -0.5, 0.6, 0.3, -0.2, 0.5, 0.1, 0.2, -0.3 }
    local tr = sys:simulate{ q0 = { y[1], y[2], y[3] }, qd0 = { y[4], y[5], y[6] }, qdd0 = { y[7], y[8], y[9] },
      q3d0 = { y[10], y[11], y[12] }, t1 = 1, dt = 0.5 }
    assert(tr.branch.q4d and #tr.branch.q4d == 3)
    local h4, worst, t = 1 / 800, 0, 0
    for n = 1, #tr.t do
      while t < tr.t[n] - 1e-12 do
        local function add(a, b, s) local o = {}; for i = 1, 12 do o[i] = a[i] + s * b[i] end; return o end
        local k1 = f(y); local k2 = f(add(y, k1, h4 / 2)); local k3 = f(add(y, k2, h4 / 2)); local k4 = f(add(y, k3, h4))
        for i = 1, 12 do y[i] = y[i] + h4 / 6 * (k1[i] + 2 * k2[i] + 2 * k3[i] + k4[i]) end
        t = t + h4
      end
      local top = f(y)
      for i = 1, 3 do
        worst = math.max(worst, math.abs(tr.q[n][i] - y[i]), math.abs(tr.qdd[n][i] - y[6 + i]),
          math.abs(tr.higher[n][1][i] - y[9 + i]), math.abs(tr.top[n][i] - top[9 + i]))
      end
      worst = math.max(worst, math.abs(tr.lambda[n][1] - (M * y[9] - Q[3])))
    end
    -- rk8pd at rtol 1e-10 against RK4 at h = 1/800: measured 1.75e-13
    assert(worst <= 1e-11, ("worst difference %.3g"):format(worst))
  end)
end)
