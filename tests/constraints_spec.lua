-- constraints_spec.lua - constraints of any order, Dolapchiev's rule and the
-- motion they allow (docs/theory.md §6-§10), against equations derived by hand in
-- tests/constraint_systems.lua and closed forms.
local h = require "tests.helpers"
local nz = h.nz
local cs = require "tests.constraint_systems"
local mech = require("nz.core").mech

local function max_abs(v) local m = 0; for i = 1, #v do m = math.max(m, math.abs(v[i])) end; return m end
local function max_diff(a, b) local m = 0; for i = 1, #a do m = math.max(m, math.abs(a[i] - b[i])) end; return m end
local function vec(v) local p = {}; for i = 1, #v do p[i] = ("%.15g"):format(v[i]) end; return "{" .. table.concat(p, ", ") .. "}" end
local STATES = 6

describe("classification and Dolapchiev's rule", function()
  local expected = {
    { cs.sleigh, order = 1, linear = true, n = 1,
      says = "n = 1, Nielsen's equations (Jourdain's principle), since constraint 1 is of first order and linear in the velocities." },
    { cs.rolling_disk, order = 1, linear = true, n = 1, says = "constraint 2 is of first order and linear in the velocities: Nielsen's equations, n = 1." },
    { cs.constant_speed, order = 1, linear = false, n = 2,
      says = "n = 2, Tsenov's equations (Gauss's principle), since constraint 1 is of first order and nonlinear in the velocities." },
    { cs.appell, order = 1, linear = false, n = 2, says = "since constraint 1 is of first order and nonlinear in the velocities." },
    { cs.program, order = 2, linear = true, n = 2, says = "since constraint 1 is of second order and linear in the accelerations." },
    { cs.cartesian_pendulum, order = 0, linear = false, n = 1, says = "since constraint 1 is holonomic" },  -- x^2 + y^2 is nonlinear in q
    { cs.hamel, order = 2, linear = false, n = 3, says = "n = 3, equations with the jerk q''' (generalized Gauss principle of "
      .. "order 3), since constraint 1 is of second order and nonlinear in the accelerations." },
  }
  for _, e in ipairs(expected) do
    local case = e[1]()
    it(case.name .. ": order, linearity and the rule", function()
      local classes = case.sys:constraints{ quiet = true }
      for _, c in ipairs(classes) do
        assert.are.equal(e.order, c.order)
        assert.are.equal(e.linear, c.linear)
        assert.are.equal(e.order == 0, c.holonomic)
        assert.is_true(c.consistent)
      end
      local n, why = case.sys:rule()
      assert.are.equal(e.n, n)
      assert.truthy(why:find(e.says, 1, true), why)
      assert.truthy(why:find(("Dolapchiev's rule: n = %d"):format(n), 1, true), why)
      -- sentences start with a capital; one constraint's equations are named once
      for sentence in why:gmatch("%.  (.)") do assert.truthy(sentence:find("%u"), why) end
      if case.sys.nc == 1 then
        local _, names = why:gsub("equations", "")
        assert.are.equal(1, names, why)
      end
      -- the table and its evidence fit 80 columns, as help does
      for line in tostring(case.sys:constraints()):gmatch("[^\n]+") do
        assert(utf8.len(line) <= 80, ("a line of %d columns:\n%s"):format(utf8.len(line), line))
      end
    end)
  end
  it("homogeneity in the velocities (Euler's theorem) with its degree", function()
    local c = cs.sleigh().sys:constraints{ quiet = true }[1]
    assert.is_true(c.homogeneous); assert.are.equal(1, c.degree)
    c = cs.appell().sys:constraints{ quiet = true }[1]
    assert.is_true(c.homogeneous); assert.are.equal(2, c.degree)
    assert.is_false(cs.constant_speed().sys:constraints{ quiet = true }[1].homogeneous)
    assert.is_true(cs.cartesian_pendulum().sys:constraints{ quiet = true }[1].homogeneous)
    local moving = nz.system{ coords = { "x" }, T = function(t, q, qd) return 0.5 * qd[1] ^ 2 end,
      constraints = { function(t, q) return q[1] - nz.sin(t) end } }
    assert.is_false(moving:constraints{ quiet = true }[1].homogeneous)
  end)
  it("the printed classification shows the evidence", function()
    local sys = cs.constant_speed().sys
    local text = require("nz.model.constraints").report(sys)
    assert.truthy(text:find("nonholonomic", 1, true) and text:find("nonlinear", 1, true), text)
    assert.truthy(text:find("the largest |dPhi/dq^(j)|, j = 0..3", 1, true) and text:find("\n  1: 0, ", 1, true), text)
  end)
  it("constraints of order three: classification, rule and residual work; accel says q'' is part of the state", function()
    local sys = nz.system{ name = "jerk", coords = { "x", "y" }, T = function(t, q, qd) return 0.5 * (qd[1] ^ 2 + qd[2] ^ 2) end,
      constraints = { function(t, q, qd, qdd, qddd) return qddd[1] - qddd[2] * qddd[2] end } }
    local c = sys:constraints{ quiet = true }[1]
    assert.are.equal(3, c.order); assert.is_false(c.linear)
    assert.are.equal(4, (sys:rule()))
    -- (6.2) by hand: E(T) = q'', A = dPhi/dq''' = (1, -2 y'''), so with
    -- lambda = 1.5 and q''' = (0.8, 0.35) the residual is q'' - 1.5 A.
    local r = sys:residual(4, 0, { 0, 0 }, { 1, 2 }, { 0.5, 0.25 }, { 1.5 }, { higher = { { 0.8, 0.35 } } })
    assert(max_diff(r, { 0.5 - 1.5 * 1, 0.25 - 1.5 * (-2 * 0.35) }) <= 1e-14, vec(r))
    h.checkerror("system 'jerk': constraint 1 is of order 3: under it q'' is part of the state, not a function of (t, q, qd)",
      sys.accel, sys, 0, { 0, 0 }, { 1, 2 })
  end)
  it("the extremal form raises n when the forces depend on the velocities (§8)", function()
    local sys = nz.system{ coords = { "x", "y", "th" },
      T = function(t, q, qd) return 0.5 * (qd[1] ^ 2 + qd[2] ^ 2 + qd[3] ^ 2) end,
      Q = function(t, q, qd) return { -0.3 * qd[1], -0.3 * qd[2], 0 } end,
      constraints = { function(t, q, qd) return -qd[1] * nz.sin(q[3]) + qd[2] * nz.cos(q[3]) end } }
    assert.are.equal(1, (sys:rule()))
    local n, why = sys:rule{ extremal = true }
    assert.are.equal(2, n)
    assert.truthy(why:find("the forces depend on the velocities", 1, true), why)
  end)
  it("a constraint that depends on nothing, or differently at different states, is reported", function()
    local none = nz.system{ name = "idle", coords = { "x" }, T = function(t, q, qd) return 0.5 * qd[1] ^ 2 end,
      constraints = { function(t, q, qd) return 0 * qd[1] end } }
    h.checkerror("system 'idle': constraint 1 depends on no coordinate or derivative", none.constraints, none, { quiet = true })
    h.checkerror("else leave it out: it is zero there and constrains nothing", none.constraints, none, { quiet = true })
    -- one that is not zero can never hold: inconsistent, not harmless, with its value and where
    for _, c in ipairs{ 1, -2.5 } do
      local impossible = nz.system{ name = "impossible", coords = { "x" }, T = function(t, q, qd) return 0.5 * qd[1] ^ 2 end,
        constraints = { function(t, q) return c + 0 * q[1] end } }
      local ok, err = pcall(impossible.accel, impossible, 0, { 0 }, { 0 })
      assert.is_false(ok)
      assert.truthy(err:find("system 'impossible': constraint 1 is inconsistent: it depends on no coordinate", 1, true), err)
      assert.are.equal(c, tonumber(err:match("%(Phi = (%S+) at t = ")), err)
      assert.truthy(err:find("so Phi = 0 can never hold", 1, true), err)
      assert.falsy(err:find("constrains nothing", 1, true), err)
    end
    local odd = nz.system{ name = "odd", coords = { "x" }, T = function(t, q, qd) return 0.5 * qd[1] ^ 2 end,
      constraints = { function(t, q, qd) if q[1] > 0.2 then return qd[1] end return q[1] - q[1] + 1 end } }
    local c = odd:constraints{ quiet = true }[1]
    assert.is_false(c.consistent)
    assert.truthy(require("nz.model.constraints").report(odd):find("ORDER DIFFERS ACROSS STATES", 1, true))
  end)
end)

describe("accelerations with constraints against hand derivations", function()
  for _, case in ipairs(cs.linear_at_acceleration_level()) do
    it(case.name, function()
      for _ = 1, STATES do
        local t, q, qd = case.draw()
        local qdd = case.sys:accel(t, q, qd)
        local want = case.accel(t, q, qd)
        -- One SVD solve of a well-conditioned saddle-point system of O(1)
        -- entries: rounding only.
        assert(max_diff(qdd, want) <= 1e-11 * (1 + max_abs(want)),
          ("%s at q = %s, qd = %s: engine %s, hand %s"):format(case.name, vec(q), vec(qd), vec(qdd), vec(want)))
      end
    end)
    it(case.name .. ": Tsenov's elimination gives the same accelerations", function()
      local t, q, qd = case.draw()
      local a = case.sys:accel(t, q, qd)
      for _, n in ipairs{ case.n, case.n + 1 } do
        local red = case.sys:reduced(t, q, qd, n)
        assert(max_diff(red, a) <= 1e-10 * (1 + max_abs(a)), ("n = %d: reduced %s, multipliers %s"):format(n, vec(red), vec(a)))
      end
    end)
    it(case.name .. ": every form's residual vanishes at (qdd, lambda), for the rule's n and others", function()
      local t, q, qd = case.draw()
      local qdd, lambda = case.sys:accel(t, q, qd)
      for _, form in ipairs(nz.forms) do
        if form ~= "wassmuth" then
          for n = 1, 5 do
            local r = case.sys:residual(n, t, q, qd, qdd, lambda, form)
            assert(max_abs(r) <= 1e-11 * n * 10, ("form %s, n = %d: residual %s"):format(form, n, vec(r)))
          end
        end
      end
    end)
  end
end)

describe("Hamel's example (docs/theory.md §10)", function()
  local case = cs.hamel()
  it("the accelerations satisfy the closed-form equations at many states", function()
    local m, Q = case.m, case.Q
    for _ = 1, 10 do
      local t, q, qd = case.draw()
      local a, _, report = case.sys:accel(t, q, qd)
      -- m q1'' (1 + q2''^2) = Q1 + Q3 q2'';  m q2'' (1 + q1''^2) = Q2 + Q3 q1'';  q3'' = q1'' q2''
      local e1 = m * a[1] * (1 + a[2] ^ 2) - (Q[1] + Q[3] * a[2])
      local e2 = m * a[2] * (1 + a[1] ^ 2) - (Q[2] + Q[3] * a[1])
      local e3 = a[3] - a[1] * a[2]
      assert(math.max(math.abs(e1), math.abs(e2), math.abs(e3)) <= 1e-12,
        ("closed-form equations off by %g, %g, %g at %s"):format(e1, e2, e3, vec(a)))
      assert.are.equal("unconstrained", report.start)
    end
  end)
  it("the root reached is the one the solver reaches from the unconstrained accelerations", function()
    -- The reduced closed form has one real root for these forces: scan it
    -- independently (bisection on the second equation) and compare.
    local m, Q = case.m, case.Q
    local function f(a2) local a1 = (Q[1] + Q[3] * a2) / (m * (1 + a2 * a2)); return m * a2 * (1 + a1 * a1) - (Q[2] + Q[3] * a1), a1 end
    local lo, hi = -8, 8
    for i = -800, 799 do
      local x0, x1 = i / 100, (i + 1) / 100
      if (f(x0) > 0) ~= (f(x1) > 0) then lo, hi = x0, x1 end
    end
    for _ = 1, 60 do local mid = 0.5 * (lo + hi); if (f(mid) > 0) == (f(lo) > 0) then lo = mid else hi = mid end end
    local _, a1 = f(lo)
    local a = case.sys:accel(0, { 0, 0, 0 }, { 0, 0, 0 })
    assert(math.abs(a[1] - a1) <= 1e-9 and math.abs(a[2] - lo) <= 1e-9, ("engine %s, bisection a1 = %.15g, a2 = %.15g"):format(vec(a), a1, lo))
  end)
  it("a guess leads to the same root and says it started there", function()
    local a, l = case.sys:accel(0, { 0, 0, 0 }, { 0, 0, 0 })
    local b, lb, report = case.sys:accel(0, { 0, 0, 0 }, { 0, 0, 0 }, { qdd = { 0.8, 0.6, 0.4 }, lambda = { -1 } })
    assert.are.equal("guess", report.start)
    assert(max_diff(a, b) <= 1e-12 and math.abs(l[1] - lb[1]) <= 1e-12)
  end)
  it("the residuals of order 3 (the rule's n) and others vanish there", function()
    local t, q, qd = case.draw()
    local a, l = case.sys:accel(t, q, qd)
    for n = 1, 6 do
      local r = case.sys:residual(n, t, q, qd, a, l)
      assert(max_abs(r) <= 1e-12 * n * 10, ("n = %d: %s"):format(n, vec(r)))
    end
  end)
end)

describe("singular systems and failures are reported, never NaN", function()
  local function free2(constraints_)
    return nz.system{ name = "free", coords = { "x", "y" }, T = function(t, q, qd) return 0.5 * (qd[1] ^ 2 + qd[2] ^ 2) end,
      constraints = constraints_ }
  end
  it("dependent constraints are named", function()
    local s = free2{ function(t, q, qd) return qd[1] + qd[2] end, function(t, q, qd) return 2 * qd[1] + 2 * qd[2] end }
    h.checkerror("system 'free': dependent constraints: constraints 1 and 2 (the rank of their gradients A is 1 < 2): [M A^T; A 0] is singular or badly conditioned",
      s.accel, s, 0, { 0, 0 }, { 1, -1 })
    h.checkerror("at t = 0, q = {0, 0}, qd = {1, -1}: remove a redundant constraint", s.accel, s, 0, { 0, 0 }, { 1, -1 })
  end)
  it("more constraints than coordinates: the dependent ones are named, and only those", function()
    -- x, y, x + y on two coordinates: the three together (the thin SVD of A
    -- once found no dependence direction and named none: "dependent constraints:  (")
    local s = free2{ function(t, q) return q[1] end, function(t, q) return q[2] end, function(t, q) return q[1] + q[2] end }
    h.checkerror("system 'free': dependent constraints: constraints 1, 2 and 3 (the rank of their gradients A is 2 < 3)",
      s.accel, s, 0, { 0, 0 }, { 0, 0 })
    -- x, 2 x, y: constraints 1 and 2, not 3
    s = free2{ function(t, q) return q[1] end, function(t, q) return 2 * q[1] end, function(t, q) return q[2] end }
    h.checkerror("system 'free': dependent constraints: constraints 1 and 2 (the rank of their gradients A is 2 < 3)",
      s.accel, s, 0, { 0, 0 }, { 0, 0 })
  end)
  it("the exact Jacobian of the motion reports dependent constraints as the right-hand side does", function()
    -- It once reported any failed solve as a singular mass matrix, with
    -- eigenvalues from 0 to 0.
    local s = free2{ function(t, q, qd) return qd[1] + qd[2] end, function(t, q, qd) return 2 * qd[1] + 2 * qd[2] end }
    local orders, linear = require("nz.model.constraints").orders(s)
    local ode = mech.ode_new(s.engine, { method = "bsimp", orders = orders, linear = linear })
    local ok, err = pcall(mech.ode_jacobian, ode, s.engine, 0, { 0, 0, 1, -1 })
    assert.is_false(ok)
    assert.truthy(err:find("system 'free': dependent constraints: constraints 1 and 2", 1, true), err)
    assert.falsy(err:find("mass matrix", 1, true), err)
  end)
  it("a constraint at a singular configuration is named", function()
    local s = free2{ function(t, q) return q[1] ^ 2 + q[2] ^ 2 - 1 end }
    h.checkerror("system 'free': constraint 1 has a zero gradient dPhi/dq^(m) here", s.accel, s, 0, { 0, 0 }, { 0, 0 })
  end)
  it("Newton's failure when the constraint has no real solution", function()
    -- qdd1^2 + 1 >= 1: at the start (the free qdd = 0) its gradient 2 qdd1 vanishes, the Jacobian is
    -- singular and the hybrid step is not finite: said so, with the constraint's value there (1), never
    -- "did not converge in 0 iterations"
    local s = free2{ function(t, q, qd, qdd) return qdd[1] ^ 2 + 1 end }
    local ok, err = pcall(s.accel, s, 0, { 0, 0 }, { 1, -1 })
    assert.is_false(ok)
    assert.truthy(err:find("system 'free': Newton's method on (6.2) and the constraints stopped at its start: its "
      .. "first step was not finite: the Jacobian in (qdd, lambda) is singular there", 1, true), err)
    assert.truthy(err:find("(residual 1; constraint 1 is 1 there, not 0) at t = 0, q = {0, 0}, qd = {1, -1}", 1, true), err)
    assert.falsy(err:find("in 0 iterations", 1, true), err)
    assert.truthy(err:find("started from the unconstrained accelerations: the constraints may have no real solution at "
      .. "this state (check them there); if they have one, give Newton another start", 1, true), err)
    -- qdd1^2 + qdd1 + 1 has no real root either, and a nonzero gradient at the start: the steps stop
    -- reducing the residual near its minimum (3/4 at qdd1 = -1/2), the value the message gives
    s = free2{ function(t, q, qd, qdd) return qdd[1] ^ 2 + qdd[1] + 1 end }
    ok, err = pcall(s.accel, s, 0, { 0, 0 }, { 1, -1 })
    assert.is_false(ok)
    assert.truthy(err:find("no longer reduced the residual", 1, true), err)
    local value = tonumber(err:match("constraint 1 is (%S+) there, not 0"))
    assert(value and value >= 0.75 and value <= 0.76, err)
  end)
end)

describe("consistent states", function()
  it("project() returns a state on the holonomic constraint, at position and velocity level", function()
    local case = cs.cartesian_pendulum()
    local q, qd = case.sys:project(0, { 0.9, -1.1 }, { 0.5, 0.7 })
    assert(math.abs(q[1] ^ 2 + q[2] ^ 2 - 1.3 ^ 2) <= 1e-12)
    assert(math.abs(q[1] * qd[1] + q[2] * qd[2]) <= 1e-12)
    -- least change: the projected point lies on the ray through the start
    assert(math.abs(q[1] / q[2] - 0.9 / -1.1) <= 1e-9)
  end)
  it("project() satisfies first-order constraints, linear or not, at velocity level", function()
    for _, case in ipairs{ cs.sleigh(), cs.rolling_disk(), cs.constant_speed(), cs.appell() } do
      local t, q = case.draw()
      local qd = {}
      for i = 1, #q do qd[i] = 0.3 * i - 0.5 end
      local _, pqd = case.sys:project(t, q, qd)
      case.sys:check_state(t, q, pqd, 1e-11)
    end
  end)
  it("a state that violates a constraint gets a clear error that suggests project()", function()
    local case = cs.cartesian_pendulum()
    h.checkerror("system 'cartesian pendulum': the state at t = 0 violates constraint 1 at position level by 0.31 (",
      case.sys.check_state, case.sys, 0, { 1, 1 }, { 0, 0 })
    h.checkerror("; tolerance 1e-08 of it): start from a consistent state, e.g. q, qd = sys:project(t, q, qd)",
      case.sys.check_state, case.sys, 0, { 1, 1 }, { 0, 0 })
  end)
end)

-- A fixed-step RK4 on (q, qd) with the system's accelerations, carrying
-- extra quantities y' = f(t, q, qd) along (the integration issue adds the
-- real integrators; this test must not depend on them).
local function rk4(sys, t, q, qd, dt, steps, extra)
  local k = #q
  local function deriv(tt, x)
    local qq, vv = {}, {}
    for i = 1, k do qq[i], vv[i] = x[i], x[k + i] end
    local a = sys:accel(tt, qq, vv)
    local d = {}
    for i = 1, k do d[i], d[k + i] = vv[i], a[i] end
    d[2 * k + 1] = extra and extra(tt, qq, vv) or 0
    return d
  end
  local x = {}
  for i = 1, k do x[i], x[k + i] = q[i], qd[i] end
  x[2 * k + 1] = 0
  for _ = 1, steps do
    local k1 = deriv(t, x)
    local x2, x3, x4 = {}, {}, {}
    for i = 1, #x do x2[i] = x[i] + 0.5 * dt * k1[i] end
    local k2 = deriv(t + 0.5 * dt, x2)
    for i = 1, #x do x3[i] = x[i] + 0.5 * dt * k2[i] end
    local k3 = deriv(t + 0.5 * dt, x3)
    for i = 1, #x do x4[i] = x[i] + dt * k3[i] end
    local k4 = deriv(t + dt, x4)
    for i = 1, #x do x[i] = x[i] + dt / 6 * (k1[i] + 2 * k2[i] + 2 * k3[i] + k4[i]) end
    t = t + dt
  end
  local qq, vv = {}, {}
  for i = 1, k do qq[i], vv[i] = x[i], x[k + i] end
  return t, qq, vv, x[2 * k + 1]
end

describe("energy and the work of moving constraints (§9)", function()
  local g, R, m, W = 9.81, 0.5, 0.3, 4.0
  -- The bead on a hoop driven at the constant rate W, twice: as one
  -- coordinate with a rheonomic T, and as (th, ph) with the holonomic
  -- moving constraint ph - W t = 0 (then lambda is the motor's torque).
  local rheonomic = nz.system{ name = "hoop", coords = { "th" },
    T = function(t, q, qd) return 0.5 * m * R * R * (qd[1] ^ 2 + W * W * nz.sin(q[1]) ^ 2) end,
    V = function(t, q) return -m * g * R * nz.cos(q[1]) end }
  local driven = nz.system{ name = "driven hoop", coords = { "th", "ph" },
    T = function(t, q, qd) return 0.5 * m * R * R * (qd[1] ^ 2 + nz.sin(q[1]) ^ 2 * qd[2] ^ 2) end,
    V = function(t, q) return -m * g * R * nz.cos(q[1]) end,
    constraints = { function(t, q) return q[2] - W * t end } }

  it("R_0 of the rheonomic form is 2 dT0/dt = 2 m R^2 W^2 sin cos th' (closed form)", function()
    for _ = 1, STATES do
      local th, thd = math.random() * 6 - 3, math.random() * 4 - 2
      local R0 = rheonomic:reaction_power(0, { th }, { thd })
      local want = 2 * m * R * R * W * W * math.sin(th) * math.cos(th) * thd
      assert(math.abs(R0 - want) <= 1e-12 * (1 + math.abs(want)), ("R_0 = %.15g, want %.15g"):format(R0, want))
    end
  end)
  it("the motor's torque lambda and R_0 = lambda ph' against the hand derivation", function()
    -- The ph equation of (6.2) with ph' = W, ph'' = 0 (Phi = ph - W t, A = (0, 1)):
    -- d/dt(m R^2 sin^2 th ph') = 2 m R^2 sin th cos th th' W = lambda, and
    -- th'' = W^2 sin th cos th - (g/R) sin th from the th equation.
    for _ = 1, STATES do
      local t, th, thd = math.random() * 3, math.random() * 6 - 3, math.random() * 4 - 2
      local q, qd = { th, W * t }, { thd, W }
      local a, lambda = driven:accel(t, q, qd)
      local torque = 2 * m * R * R * math.sin(th) * math.cos(th) * thd * W
      assert(math.abs(lambda[1] - torque) <= 1e-12 * (1 + math.abs(torque)), ("lambda = %.15g, hand %.15g"):format(lambda[1], torque))
      local thdd = W * W * math.sin(th) * math.cos(th) - g / R * math.sin(th)
      assert(math.abs(a[1] - thdd) <= 1e-12 * (1 + math.abs(thdd)) and math.abs(a[2]) <= 1e-12,
        ("q'' = %s, hand {%.15g, 0}"):format(vec(a), thdd))
      -- R_0 is the motor's power, the same closed form as the rheonomic hoop's.
      local R0 = driven:reaction_power(t, q, qd)
      assert(math.abs(R0 - torque * W) <= 1e-12 * (1 + math.abs(torque * W)), ("R_0 = %.15g, hand %.15g"):format(R0, torque * W))
    end
  end)
  it("T2 - T0 + V is conserved while T + V is not; T + V - integral R_0 dt is conserved", function()
    local q0, qd0 = { 0.7 }, { 0.3 }
    local E0, H0, cond = rheonomic:energy(0, q0, qd0)
    assert.is_true(cond.holds)
    local function power(t, q, qd) return rheonomic:reaction_power(t, q, qd) end
    local t, q, qd, work = rk4(rheonomic, 0, q0, qd0, 1e-3, 2000, power)
    local E, H = rheonomic:energy(t, q, qd)
    -- RK4 with h = 1e-3 over 2 s: global error ~ C h^4 t ~ 1e-11 for these
    -- O(1) frequencies; 1e-8 bounds it with margin, while T + V moves by O(0.1).
    assert(math.abs(H - H0) <= 1e-8, ("H drifted by %g"):format(H - H0))
    assert(math.abs(E - E0) >= 1e-3, ("T + V changed by only %g"):format(E - E0))
    assert(math.abs((E - work) - E0) <= 1e-8, ("T + V - integral R_0 drifted by %g"):format(E - work - E0))
  end)
  it("with the moving constraint: the energy condition fails, and T + V - integral R_0 dt is conserved", function()
    local q0, qd0 = { 0.7, 0 }, { 0.3, W }
    local E0, _, cond = driven:energy(0, q0, qd0)
    assert.is_false(cond.holds)
    assert.truthy(table.concat(cond.reasons, "; "):find("constraint 1 is not homogeneous in the velocities", 1, true))
    local function power(t, q, qd) return driven:reaction_power(t, q, qd) end
    local t, q, qd, work = rk4(driven, 0, q0, qd0, 1e-3, 2000, power)
    local E = driven:energy(t, q, qd)
    assert(math.abs((E - work) - E0) <= 1e-8, ("T + V - integral R_0 drifted by %g"):format(E - work - E0))
    assert(math.abs(E - E0) >= 1e-3)
  end)
  it("explicit time dependence of L is reported", function()
    local sys = nz.system{ coords = { "x" }, T = function(t, q, qd) return 0.5 * (1 + 0.1 * t) * qd[1] ^ 2 end }
    local _, _, cond = sys:energy(2, { 0 }, { 1 })
    assert.is_false(cond.holds)
    assert(math.abs(cond.explicit_t - 0.05) <= 1e-15)
  end)
end)
