-- constraint_checks_spec.lua - constrained accelerations are never silently
-- wrong: constraints whose nonlinearity or order shows only away from the
-- sample states, the check after every solve (constrained.c), scale-aware
-- classification, and what a failing constraint function says.  Every
-- expected value is derived by hand below from (6.2) and docs/theory.md §10.
local h = require "tests.helpers"
local nz = h.nz
local mech = require("nz.core").mech

local function vec(v) local p = {}; for i = 1, #v do p[i] = ("%.15g"):format(v[i]) end; return "{" .. table.concat(p, ", ") .. "}" end

-- Hamel's particle of docs/theory.md §10 with a constraint phi(t, q, qd, qdd).
local m, Q = 1.5, { 0.7, -0.4, 2.0 }
local function particle(name, phi)
  return nz.system{ name = name, coords = { "q1", "q2", "q3" },
    T = function(t, q, qd) return 0.5 * m * (qd[1] ^ 2 + qd[2] ^ 2 + qd[3] ^ 2) end,
    Q = function() return { Q[1], Q[2], Q[3] } end,
    constraints = { phi } }
end
local function switch(q1) return math.exp(30 * (q1 - 3)) end

-- §10 with the multiplier of Phi = s (q3'' - q1'' q2''), s > 0 a factor:
-- dPhi/dq'' = s (-q2'', -q1'', 1), so (6.2) reads
--   m q1'' - Q1 = -s lambda q2'',  m q2'' - Q2 = -s lambda q1'',  m q3'' - Q3 = s lambda,
-- and eliminating s lambda = m q3'' - Q3 with q3'' = q1'' q2'' gives
--   m q1'' (1 + q2''^2) = Q1 + Q3 q2'',  m q2'' (1 + q1''^2) = Q2 + Q3 q1''.
-- Returns the worst violation, relative to the size of the terms.
local function hamel_violation(qdd, lambda, s)
  local a, b, c = qdd[1], qdd[2], qdd[3]
  local worst = 0
  local function rel(lhs, rhs) worst = math.max(worst, math.abs(lhs - rhs) / (math.abs(lhs) + math.abs(rhs) + 1)) end
  rel(c, a * b)
  rel(m * a * (1 + b * b), Q[1] + Q[3] * b)
  rel(m * b * (1 + a * a), Q[2] + Q[3] * a)
  rel(m * c - Q[3], s * lambda[1])
  return worst
end

-- A state where the switch is on (q1 = 3) and high-entropy velocities.
local t0, q3, qd3 = 0.5, { 3, 0.31, -0.2 }, { 0.4, -0.7, 0.25 }

describe("a constraint nonlinear only away from the sample states", function()
  local function hamel_switch()
    return particle("hamel switch", function(t, q, qd, qdd)
      return qdd[3] - nz.exp(30 * (q[1] - 3)) * qdd[1] * qdd[2]
    end)
  end
  it("accel at q1 = 3 satisfies Hamel's equations (docs/theory.md §10)", function()
    local sys = hamel_switch()
    local qdd, lambda = sys:accel(t0, q3, qd3)
    -- Newton stops at 1e-12 of the forces, then one exact step: rounding.
    local v = hamel_violation(qdd, lambda, switch(q3[1]))
    assert(v <= 1e-12, ("violation %.3g at qdd = %s"):format(v, vec(qdd)))
  end)
  it("the user's state adds samples near it, and the rule says the linearity differs", function()
    local sys = hamel_switch()
    local n, why = sys:rule()
    assert.are.equal(2, n, why)          -- near sys.sample the switch is below exp(-60)
    sys:accel(t0, q3, qd3)
    n, why = sys:rule()
    assert.are.equal(3, n, why)
    assert.truthy(why:find("its linearity in the accelerations differs across the sample states", 1, true), why)
  end)
  it("the check after the solve repairs a linear classification (the C path alone)", function()
    local sys = hamel_switch()
    -- Force the classification the sample states near sys.sample give:
    -- second order, linear.  Without the check: q3'' = Q3/m, Phi = 0.12.
    local qdd, lambda, report = mech.accel_constrained(sys.engine, t0, q3, qd3, { 2 }, { true })
    assert.are.equal(1, report.reclassified)
    local v = hamel_violation(qdd, lambda, 1)
    assert(v <= 1e-12, ("violation %.3g at qdd = %s"):format(v, vec(qdd)))
    local raw = mech.accel_constrained(sys.engine, t0, q3, qd3, { 2 }, { true }, { check = false })
    assert(math.abs(raw[3] - raw[1] * raw[2]) > 0.1, "check = false trusts the linear solve")
  end)
  it("the exact Jacobian of the motion uses the classification the check found", function()
    local sys = hamel_switch()
    -- The integrator told the linear classification; at q1 = 3 the check
    -- switches to Newton, and the Jacobian must include the Hessian term.
    local ode = mech.ode_new(sys.engine, { method = "bsimp", orders = { 2 }, linear = { true } })
    local y = { q3[1], q3[2], q3[3], qd3[1], qd3[2], qd3[3] }
    local J = mech.ode_jacobian(ode, sys.engine, t0, y)
    for j = 1, 6 do
      local yp, ym = { table.unpack(y) }, { table.unpack(y) }
      yp[j], ym[j] = y[j] + 1e-6, y[j] - 1e-6
      local ap, am = mech.ode_accel(ode, sys.engine, t0, yp), mech.ode_accel(ode, sys.engine, t0, ym)
      for i = 1, 3 do
        local fd = (ap[i] - am[i]) / 2e-6
        -- Central differences with h = 1e-6: error ~ h^2 |q''''| + eps/h,
        -- about 1e-9 here (the switch's third derivative is 30^3 e).
        assert(math.abs(J[3 + i][j] - fd) <= 1e-6 * (1 + math.abs(fd)),
          ("d qdd_%d / d y_%d = %.12g exact, %.12g by differences"):format(i, j, J[3 + i][j], fd))
      end
    end
  end)
  it("simulate across the switch keeps Phi at rounding and the motion on Hamel's equations", function()
    local sys = hamel_switch()
    -- Near sys.sample (q1 within 1 of 0.2) the switch is below exp(-60):
    -- classified linear, n = 2; the run reaches q1 = 3.2 at t = 1.2.
    assert.are.equal(2, (sys:rule()))
    local tr = sys:simulate{ q0 = { 0, 0.31, -0.2 }, qd0 = { 2.385, -0.7, 0.25 }, t1 = 1.2, dt = 0.002 }
    assert(tr.q[#tr.q][1] > 3.15, "the run crosses the switch")
    -- The check's promise (constrained.h, NZ_ACCEL_CHECK_TOL) is normwise:
    -- the residuals of (6.2) and of Phi, scaled by the equilibration D, are
    -- at most tol x (||D K D|| ||D^-1 x|| + ||D b||) of the system solved.
    -- Written out for this particle where the linear solve is accepted
    -- (A = dPhi/dq'' at q'' = 0 is (0, 0, 1); K = [m I, -A^T; A, 0]; b =
    -- (Q, 0)): D = (1, 1, 1)/sqrt(m) for q'' and sqrt(m) for lambda (A's
    -- largest scaled entry is 1/sqrt(m)), so ||D K D|| = 2 (row 3: 1 + 1),
    -- ||D^-1 x|| = max(sqrt(m) |q_i''|, |lambda|/sqrt(m)), ||D b|| =
    -- max |Q_i|/sqrt(m).  Where Newton takes over the residuals are rounding.
    -- The rows, from docs/theory.md §10 with the factor e (see
    -- hamel_violation): (6.2) m q1'' - Q1 = -e lambda q2'', m q2'' - Q2 =
    -- -e lambda q1'', m q3'' - Q3 = lambda, and Phi = q3'' - e q1'' q2''.
    local worst = 0
    for n = 1, #tr.t do
      local a, lambda, e = tr.qdd[n], tr.lambda[n][1], switch(tr.q[n][1])
      local sm = math.sqrt(m)
      local xnorm = math.abs(lambda) / sm
      for i = 1, 3 do xnorm = math.max(xnorm, sm * math.abs(a[i])) end
      local size = 2 * xnorm + math.max(math.abs(Q[1]), math.abs(Q[2]), math.abs(Q[3])) / sm
      local rows = { (m * a[1] - Q[1] + e * lambda * a[2]) / sm, (m * a[2] - Q[2] + e * lambda * a[1]) / sm,
        (m * a[3] - Q[3] - lambda) / sm, sm * (a[3] - e * a[1] * a[2]) }
      for _, r in ipairs(rows) do worst = math.max(worst, math.abs(r) / size) end
    end
    assert(worst <= mech.accel_check_tol, ("(6.2) and Phi reach a backward error of %.3g along the run"):format(worst))
    -- The accelerations stored are those of the motion: central differences
    -- of qd agree up to their error dt^2/6 |q''''|, which is largest where
    -- the switch turns on (q2'' goes from -0.23 to 0.54 within 0.03 s, so
    -- q'''' ~ 1e4; measured 0.0089 at q1 = 2.99).
    local fd = 0
    for n = 2, #tr.t - 1 do
      for i = 1, 3 do
        local d = (tr.qd[n + 1][i] - tr.qd[n - 1][i]) / (tr.t[n + 1] - tr.t[n - 1])
        fd = math.max(fd, math.abs(d - tr.qdd[n][i]))
      end
    end
    assert(fd <= 0.012, ("finite differences of qd differ from qdd by %.3g"):format(fd))
  end)
end)

describe("a constraint whose order rises away from the sample states", function()
  local function order_switch()
    return particle("order switch", function(t, q, qd, qdd)
      return qd[3] - qd[1] + nz.exp(30 * (q[1] - 3)) * qdd[2]
    end)
  end
  -- At q1 = 3, Phi = q3' - q1' + e q2'' is of second order in q2'' and is
  -- imposed at its own level: q2'' = (q1' - q3') / e.  dPhi/dq'' = (0, e, 0),
  -- so (6.2): m q1'' = Q1, m q3'' = Q3, m q2'' - Q2 = e lambda.
  local function expected(q, qd)
    local e = switch(q[1])
    local b = (qd[1] - qd[3]) / e
    return { Q[1] / m, b, Q[3] / m }, (m * b - Q[2]) / e
  end
  local function check(qdd, lambda)
    local want, lw = expected(q3, qd3)
    for i = 1, 3 do assert(math.abs(qdd[i] - want[i]) <= 1e-13, ("qdd = %s, hand %s"):format(vec(qdd), vec(want))) end
    assert(math.abs(lambda[1] - lw) <= 1e-13, ("lambda %.17g, hand %.17g"):format(lambda[1], lw))
  end
  it("accel at q1 = 3 satisfies the constraint itself and (6.2)", function()
    local qdd, lambda = order_switch():accel(t0, q3, qd3)
    check(qdd, lambda)
  end)
  it("the check finds the order from a first-order classification (the C path alone)", function()
    local sys = order_switch()
    local qdd, lambda, report = mech.accel_constrained(sys.engine, t0, q3, qd3, { 1 }, { true })
    assert.are.equal(1, report.reclassified)
    check(qdd, lambda)
  end)
end)

describe("a constraint switched on in time (a ramp, zero near sys.sample's time)", function()
  local function ramp(t) return t > 1 and (t - 1) ^ 3 or 0 end
  local function ramped()
    return particle("ramped hamel", function(t, q, qd, qdd)
      return ramp(t) * (qdd[3] - qdd[1] * qdd[2])
    end)
  end
  it("is classified from sample times spread widely, and the rule says its order varies", function()
    local n, why = ramped():rule()
    assert.are.equal(3, n)
    assert.truthy(why:find("its order differs across the", 1, true), why)
  end)
  it("accel at t = 2 satisfies §10 with the multiplier scaled by the ramp", function()
    local sys = ramped()
    local qdd, lambda = sys:accel(2, q3, qd3)
    local v = hamel_violation(qdd, lambda, ramp(2))
    assert(v <= 1e-12, ("violation %.3g at qdd = %s"):format(v, vec(qdd)))
    qdd, lambda = mech.accel_constrained(sys.engine, 2, q3, qd3, { 2 }, { true })
    v = hamel_violation(qdd, lambda, ramp(2))
    assert(v <= 1e-12, ("forced linear: violation %.3g at qdd = %s"):format(v, vec(qdd)))
  end)
  it("simulate once the ramp is on keeps q3'' = q1'' q2''; before, the constraint is singular", function()
    local sys = ramped()
    local tr = sys:simulate{ t0 = 1.5, q0 = { 0.2, 0.31, -0.2 }, qd0 = { 0.4, -0.7, 0.25 }, t1 = 3, dt = 0.02 }
    local worst = 0
    for n = 1, #tr.t do
      local a = tr.qdd[n]
      worst = math.max(worst, math.abs(a[3] - a[1] * a[2]) / (1 + math.abs(a[3])))
    end
    assert(worst <= 1e-11, ("q3'' - q1'' q2'' reaches %.3g"):format(worst))
    -- Before t = 1 the constraint is identically zero: its gradient vanishes,
    -- and the run stops at once with that reason instead of drifting.
    h.checkerror("system 'ramped hamel': constraint 1 has a zero gradient dPhi/dq^(m) here", sys.simulate, sys,
      { t0 = 0, q0 = { 0.2, 0.31, -0.2 }, qd0 = { 0.4, -0.7, 0.25 }, t1 = 3 })
  end)
end)

describe("scale-aware classification", function()
  local function plane(name, phi)
    return nz.system{ name = name, coords = { "x", "y" },
      T = function(t, q, qd) return 0.5 * (qd[1] ^ 2 + qd[2] ^ 2) end, constraints = { phi } }
  end
  it("a circle of radius 1e6 sampled near the origin depends on q (holonomic)", function()
    local R = 1e6
    local sys = plane("big circle", function(t, q) return q[1] ^ 2 + q[2] ^ 2 - R ^ 2 end)
    local c = sys:constraints{ quiet = true }[1]
    assert.are.equal(0, c.order)
    -- Uniform motion on the circle: x'' = -v^2 x / R^2, y'' = -v^2 y / R^2.
    local v, x, y = 2.385, R * math.cos(0.3), R * math.sin(0.3)
    local qdd = sys:accel(0, { x, y }, { -v * math.sin(0.3), v * math.cos(0.3) })
    local want = { -v * v * x / R ^ 2, -v * v * y / R ^ 2 }
    -- Phi'' cancels terms of size |q| |q''| = 6e6 down to 5.7e-6: rounding
    -- of 6e6 eps = 1.3e-9 relative to the answer.
    for i = 1, 2 do assert(math.abs(qdd[i] - want[i]) <= 2e-14, vec(qdd)) end
  end)
  it("1e6 (q1 - q2) + 1e-6 q1' is of first order, not holonomic", function()
    local sys = plane("stiff", function(t, q, qd) return 1e6 * (q[1] - q[2]) + 1e-6 * qd[1] end)
    local c = sys:constraints{ quiet = true }[1]
    assert.are.equal(1, c.order)
    local n, why = sys:rule()
    assert.are.equal(1, n)
    assert.truthy(why:find("constraint 1 is of first order and linear in the velocities", 1, true), why)
  end)
end)

describe("a constraint no reclassification can impose is an error", function()
  -- q3'' - q1'' + e q1''': second order away from q1 = 3, third order there.
  local function jerk_switch()
    return particle("jerk switch", function(t, q, qd, qdd, qddd)
      return qdd[3] - qdd[1] + nz.exp(30 * (q[1] - 3)) * qddd[1]
    end)
  end
  it("accel names the constraint, its order here, and the state", function()
    local sys = jerk_switch()
    -- Its q''' term is e |q1'''| ~ 1 x 1.4 (slot weight) x max(|q''|, 1),
    -- its q'' terms |A| max(|q''|, 1) with A = (-1, 0, 1): 2 max(|q''|, 1).
    local line = debug.getinfo(1, "l").currentline + 1
    local ok, msg = pcall(mech.accel_constrained, sys.engine, t0, q3, qd3, { 2 }, { true })
    assert.is_false(ok)
    -- raised in C, it still starts with the caller's file:line (nz_lua_raise_located)
    assert.truthy(msg:find(("^[^:]*constraint_checks_spec.lua:%d: system 'jerk switch'"):format(line)), msg)
    msg = msg:gsub("^[^:]*:%d+: ", "", 1)
    local above, at = msg:match("^system 'jerk switch': constraint 1, classified of order 2, depends on q%^%(3%) here "
      .. "%(its terms above order 2 are (%S+) against (%S+) at that order%), and accelerations cannot impose a "
      .. "constraint of order 3 at t = 0.5, q = {3, 0.31")
    assert.truthy(above, msg)
    local ratio = tonumber(above) / tonumber(at)
    assert(ratio >= 0.6 / 2 and ratio <= 1.4 / 2, msg)
    assert.truthy(msg:find("give a state where it has that order as sample = {...} in nz.system", 1, true), msg)
  end)
  it("simulate stops with that error where the order rises, never goes on", function()
    local sys = jerk_switch()
    local ok, msg = pcall(sys.simulate, sys, { q0 = { 0, 0.31, -0.2 }, qd0 = { 2.385, -0.7, 0.25 }, t1 = 2, dt = 0.01 })
    assert.is_false(ok)
    assert.truthy(tostring(msg):find("constraint 1, classified of order 2, depends on q^(3) here", 1, true), msg)
  end)
end)

describe("a constraint function that fails says what it did", function()
  local function plane(name, phi)
    return nz.system{ name = name, coords = { "x", "y" },
      T = function(t, q, qd) return 0.5 * (qd[1] ^ 2 + qd[2] ^ 2) end, constraints = { phi } }
  end
  local here = debug.getinfo(1, "S").short_src
  it("returns nil: the user's file:line, what it returned, no hint about sample", function()
    -- (it fails at every state: said when the system is made, tests/errors_spec.lua)
    local line = debug.getinfo(1, "l").currentline + 1
    local ok, msg = pcall(plane, "nil constraint", function(t, q, qd) return nil end)
    assert.is_false(ok)
    assert.truthy(msg:find(("%s:%d: nz.system 'nil constraint': constraint 1 fails at every state"):format(here, line), 1, true), msg)
    assert.truthy(msg:find(("%s:%d: constraint 1 returned nil"):format(here, line), 1, true), msg)
    assert.is_nil(msg:find("sample", 1, true), msg)
  end)
  it("raises: the user's file:line and the error, no hint about sample", function()
    local line = debug.getinfo(1, "l").currentline + 1
    local sys = plane("raising constraint", function(t, q, qd) error("wheel radius not set") end)
    local ok, msg = pcall(sys.rule, sys)
    assert.is_false(ok)
    assert.truthy(msg:find(("%s:%d: system 'raising constraint': constraint 1 raised an error at t = "):format(here, line), 1, true), msg)
    assert.truthy(msg:find(": wheel radius not set", 1, true), msg)
    assert.is_nil(msg:find("sample", 1, true), msg)
  end)
  it("a domain error at every sample state suggests a typical state", function()
    local sys = plane("domain", function(t, q, qd) return nz.sqrt(q[1] - 50) - q[2] end)
    h.checkerror("system 'domain': constraint 1 cannot be evaluated at 20 of 20 sample states ('sqrt' of a negative value",
      sys.rule, sys)
    h.checkerror("give a typical state where it is defined as sample = {t = ..., q = {...}, qd = {...}} in nz.system",
      sys.rule, sys)
    local ok = pcall(function()
      return plane("domain ok", function(t, q, qd) return nz.sqrt(q[1] - 50) - q[2] end):simulate{ q0 = { 0, 0 }, t1 = 1 }
    end)
    assert.is_false(ok)
    local typical = nz.system{ name = "typical", coords = { "x", "y" }, sample = { q = { 60, 3 } },
      T = function(t, q, qd) return 0.5 * (qd[1] ^ 2 + qd[2] ^ 2) end,
      constraints = { function(t, q, qd) return nz.sqrt(q[1] - 50) - q[2] end } }
    assert.are.equal(0, typical:constraints{ quiet = true }[1].order)
  end)
end)

-- A pendulum of length R in Cartesian coordinates, Phi = x^2 + y^2 - R^2:
-- with R = 1e6 the constraint's terms are of size R^2 = 1e12 beside forces
-- of size m g, and the solve must leave only rounding in every row.  Closed
-- form: x = R sin th, y = -R cos th, th'' = -(g/R) sin th, so
--   x'' = R (cos th th'' - sin th th'^2),  y'' = R (sin th th'' + cos th th'^2),
-- and (6.2) m q'' = Q + 2 lambda q with the tension m (g cos th + R th'^2)
-- pointing to the pivot gives lambda = -m (g cos th + R th'^2) / (2 R).
describe("a pendulum of length 1e6 and 1e-6 with gravity", function()
  local g, mass = 9.81, 1.7
  local function pendulum(R)
    return nz.system{ name = "pendulum R", coords = { "x", "y" },
      T = function(t, q, qd) return 0.5 * mass * (qd[1] ^ 2 + qd[2] ^ 2) end,
      V = function(t, q) return mass * g * q[2] end,
      constraints = { function(t, q) return q[1] ^ 2 + q[2] ^ 2 - R ^ 2 end } }
  end
  local function cartesian(R, th, w)
    return { R * math.sin(th), -R * math.cos(th) }, { R * w * math.cos(th), R * w * math.sin(th) }
  end
  -- th'' = -(g/R) sin th by classical RK4 on (th, w): a second path sharing
  -- no code with the engine.
  local function theta_at(R, th, w, t1, steps)
    local hs = t1 / steps
    local function f(a, b) return b, -(g / R) * math.sin(a) end
    for _ = 1, steps do
      local k1a, k1b = f(th, w)
      local k2a, k2b = f(th + hs / 2 * k1a, w + hs / 2 * k1b)
      local k3a, k3b = f(th + hs / 2 * k2a, w + hs / 2 * k2b)
      local k4a, k4b = f(th + hs * k3a, w + hs * k3b)
      th, w = th + hs / 6 * (k1a + 2 * k2a + 2 * k3a + k4a), w + hs / 6 * (k1b + 2 * k2b + 2 * k3b + k4b)
    end
    return th, w
  end
  for _, R in ipairs({ 1e6, 1e-6 }) do
    local th, w = 0.7, 0.385 * math.sqrt(g / R)
    it(("accel at R = %g matches the closed form"):format(R), function()
      for _, thw in ipairs({ { th, w }, { -2.385, 0 }, { 0.3, -1.3 * math.sqrt(g / R) } }) do
        local a, b = thw[1], thw[2]
        local q, qd = cartesian(R, a, b)
        local qdd, lambda = pendulum(R):accel(0, q, qd)
        local acc = -(g / R) * math.sin(a)
        local want = { R * (math.cos(a) * acc - math.sin(a) * b ^ 2), R * (math.sin(a) * acc + math.cos(a) * b ^ 2) }
        local lam = -mass * (g * math.cos(a) + R * b ^ 2) / (2 * R)
        -- rounding: measured 6e-16 g and 7e-16 relative for R = 1e-6 .. 1e8
        -- (before the solve was scaled, 1e-10 g at R = 1e6 and the check
        -- refused it); 1e-13 leaves room for other libms
        for i = 1, 2 do assert(math.abs(qdd[i] - want[i]) <= 1e-13 * g, vec(qdd) .. " want " .. vec(want)) end
        assert(math.abs(lambda[1] - lam) <= 1e-13 * math.abs(lam), lambda[1] .. " want " .. lam)
      end
    end)
    it(("simulate at R = %g follows th'' = -(g/R) sin th"):format(R), function()
      local t1 = 0.5 * math.sqrt(R / g)        -- a twelfth of a period
      local q0, qd0 = cartesian(R, th, w)
      local tr = pendulum(R):simulate{ q0 = q0, qd0 = qd0, t1 = t1, dt = t1 / 4, dense = false }
      local the, we = theta_at(R, th, w, t1, 2000)
      local q, qd = cartesian(R, the, we)
      -- rk8pd at rtol 1e-10 over a twelfth of a period (dense = false: a
      -- step end at each of the 4 output points, as measured), RK4 with 2000
      -- steps (error ~ (h w)^4 ~ 1e-15): measured 3e-14 R in position and
      -- 6e-14 R w in velocity at both scales; 1e-12 leaves room.
      for i = 1, 2 do
        assert(math.abs(tr.q[#tr.q][i] - q[i]) <= 1e-12 * R, vec(tr.q[#tr.q]) .. " want " .. vec(q))
        assert(math.abs(tr.qd[#tr.qd][i] - qd[i]) <= 1e-12 * R * math.abs(w), vec(tr.qd[#tr.qd]) .. " want " .. vec(qd))
      end
    end)
  end
end)

-- The start-state check is relative to the size of the constraint's terms:
-- a circle of radius 3e5 has terms of size R^2 = 9e10, and the rounding of
-- a state on it (x = R sin th to eps R) leaves |Phi| of about eps R^2 = 1e-5,
-- above any absolute tolerance but 1e-16 of the terms.
describe("the start-state check, relative to the constraint's terms", function()
  local g, mass, R = 9.81, 1.7, 3e5
  local sys = nz.system{ name = "big circle", coords = { "x", "y" },
    T = function(t, q, qd) return 0.5 * mass * (qd[1] ^ 2 + qd[2] ^ 2) end,
    V = function(t, q) return mass * g * q[2] end,
    constraints = { function(t, q) return q[1] ^ 2 + q[2] ^ 2 - R ^ 2 end } }
  local th, w = 0.7, 0.385 * math.sqrt(g / R)
  local q0 = { R * math.sin(th), -R * math.cos(th) }
  local qd0 = { R * w * math.cos(th), R * w * math.sin(th) }
  it("a start on a circle of radius 3e5 is accepted", function()
    sys:check_state(0, q0, qd0)
    local tr = sys:simulate{ q0 = q0, qd0 = qd0, t1 = 1, dt = 0.5 }
    assert.are.equal("done", tr.status)
  end)
  it("a start off the circle by 1e-6 of R is refused at the user's line", function()
    -- Phi = 2 x dx = 2 R^2 sin^2(th) 1e-6 = 7.5e4, a relative 4e-7 of the
    -- terms 2 R^2 (well above rounding, 1e-16)
    local bad = { q0[1] * (1 + 1e-6), q0[2] }
    local line = debug.getinfo(1, "l").currentline + 1
    local ok, msg = pcall(sys.simulate, sys, { q0 = bad, t1 = 1 })   -- at rest
    assert.is_false(ok)
    local want = ("constraint_checks_spec.lua:%d: system 'big circle': the state at t = 0 violates constraint 1 at position level by "):format(line)
    assert.truthy(tostring(msg):find(want, 1, true), msg)
    local phi = bad[1] ^ 2 + bad[2] ^ 2 - R ^ 2
    assert.truthy(tostring(msg):find(("by %.3g"):format(phi), 1, true), msg)
    assert.truthy(tostring(msg):find("sys:project", 1, true), msg)
  end)
  it("a velocity off the tangent is refused", function()
    -- Phi' = 2 (x x' + y y') = 2 R^2 w 1e-6 sin(th)cos(th) relative ~1e-6
    local ok, msg = pcall(sys.simulate, sys, { q0 = q0, qd0 = { qd0[1] * (1 + 1e-6), qd0[2] }, t1 = 1 })
    assert.is_false(ok)
    assert.truthy(tostring(msg):find("violates constraint 1 at velocity level", 1, true), msg)
  end)
end)

-- Hamel's constraint times a factor that is zero before t = 11: at the
-- sample states (t within 10 of sys.sample's t) every partial derivative
-- vanishes; classified at t = 12 it is Hamel's (§10).
describe("a constraint switched on after the sample states", function()
  local function late(sample)
    return nz.system{ name = "late", coords = { "q1", "q2", "q3" }, sample = sample,
      T = function(t, q, qd) return 0.5 * m * (qd[1] ^ 2 + qd[2] ^ 2 + qd[3] ^ 2) end,
      Q = function() return { Q[1], Q[2], Q[3] } end,
      constraints = { function(t, q, qd, qdd) return (t > 11 and t - 11 or 0) * (qdd[3] - qdd[1] * qdd[2]) end } }
  end
  it("says its derivatives vanish at the sample states and suggests sample = {t = ...}", function()
    local sys = late()
    local line = debug.getinfo(1, "l").currentline + 1
    local ok, msg = pcall(sys.constraints, sys, { quiet = true })
    assert.is_false(ok)
    msg = tostring(msg)
    local lo, hi = msg:match("at the %d+ sample states %(t from (%S+) to (%S+)%)")
    assert.truthy(lo, msg)
    assert(tonumber(hi) < 11, msg)                -- the factor is zero at all of them
    assert.truthy(msg:find(("^[^:]*constraint_checks_spec.lua:%d: system 'late': constraint 1 depends on no coordinate"):format(line)), msg)
    assert.truthy(msg:find("switched on elsewhere", 1, true), msg)
    assert.truthy(msg:find("sample = {t = ..., q = {...}}", 1, true), msg)
    -- simulate from t = 0 reports it too, at its own line
    line = debug.getinfo(1, "l").currentline + 1
    ok, msg = pcall(sys.simulate, late(), { q0 = { 0, 0.31, -0.2 }, t1 = 1 })
    assert.truthy(tostring(msg):find(("constraint_checks_spec.lua:%d: system 'late'"):format(line), 1, true), msg)
  end)
  it("with sample = {t = 12} it is Hamel's, and accel satisfies §10 there", function()
    local sys = late{ t = 12 }
    local c = sys:constraints{ quiet = true }[1]
    assert.are.equal(2, c.order)
    assert.is_false(c.linear)
    local qdd, lambda = sys:accel(12.5, q3, qd3)
    -- Phi = (t - 11) (q3'' - q1'' q2''): the factor s = 1.5
    local v = hamel_violation(qdd, lambda, 1.5)
    assert(v <= 1e-12, ("violation %.3g at qdd = %s"):format(v, vec(qdd)))
  end)
end)

-- A servo constraint of order 4, x'''' + 2 y'''' = cos t, with (6.2)
-- m x'' = F1 + lambda, m y'' = F2 + 2 lambda: differentiated once,
-- m x''' = lambda', m y''' = 2 lambda', so a start needs y''' = 2 x'''.
describe("a level-4 start with a q3d0 that breaks (6.2) differentiated once", function()
  it("is refused at the user's line", function()
    local mass, F1, F2, l0 = 1.7, 0.3, -0.45, 0.385
    local sys = nz.system{ name = "servo4", coords = { "x", "y" },
      T = function(t, q, qd) return 0.5 * mass * (qd[1] ^ 2 + qd[2] ^ 2) end,
      Q = function() return { F1, F2 } end,
      constraints = { function(t, q, qd, qdd, qddd, q4d, params) return q4d[1] + 2 * q4d[2] - nz.cos(t) end } }
    local start = { q0 = { -0.3, 0.8 }, qd0 = { 0.05, 0.4 }, qdd0 = { (F1 + l0) / mass, (F2 + 2 * l0) / mass }, t1 = 0.5 }
    start.q3d0 = { 0.3, 0.6 }                     -- y''' = 2 x''': consistent, runs
    assert.are.equal("done", sys:simulate(start).status)
    start.q3d0 = { 0.3, -0.1 }
    local line = debug.getinfo(1, "l").currentline + 1
    local ok, msg = pcall(sys.simulate, sys, start)
    assert.is_false(ok)
    assert.truthy(tostring(msg):find(("constraint_checks_spec.lua:%d: system 'servo4': the start state at t = 0 is inconsistent: "
      .. "(6.2) differentiated 1 time"):format(line), 1, true), msg)
  end)
end)
