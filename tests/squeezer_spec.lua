-- squeezer_spec.lua - Andrews' squeezing mechanism of examples/squeezer.lua
-- (7 bodies, 7 angles, 6 loop-closure constraints, SI units) against the
-- Test Set for IVP Solvers (Mazzia and Magherini, problem "andrews"; Hairer
-- and Wanner, "Solving ODEs II", section VII.7): the mass matrix and forces
-- it publishes, its consistent start, its reference solution at t = 0.03,
-- under every stepper; and the same mechanism in units that move masses,
-- lengths, times and forces by many orders of magnitude, whose angles must
-- not change (dimensional analysis).  The check after every constrained solve
-- (src/mech/constrained.c) refused msbdf, msadams, rk2imp and rk1imp at t =
-- 4e-6 ("equation (6.2) for coordinate 6 is violated by 2.33e-16 ..."): a
-- loop at rest has rows of size 1e-6 beside multipliers of 1e2 in another,
-- and a backward-stable solve leaves rounding of the whole system in them.
local h = require "tests.helpers"
local nz = h.nz

local env = setmetatable({ nz = nz }, { __index = _G })
local model = assert(loadfile("examples/squeezer.lua", "t", env))("module")
local sys, start, ref, p = model.system, model.start, model.reference, model.params

-- The Test Set's M and f of M q'' = f(q, q') - G^T lambda (andrews.f,
-- andfunc; Hairer and Wanner VII.7), written out here: nzlua derives its
-- own from T, V and Q, so M must agree and its bias h must be -f.
local function testset_mf(q, qd)
  local sin, cos, sqrt = math.sin, math.cos, math.sqrt
  local coth, siph, siom = cos(q[2]), sin(q[4]), sin(q[6])
  local ee, zz = p.e - p.ea, p.zf - p.fa
  local M = {}
  for i = 1, 7 do M[i] = { 0, 0, 0, 0, 0, 0, 0 } end
  M[1][1] = p.m1 * p.ra ^ 2 + p.m2 * (p.rr ^ 2 - 2 * p.da * p.rr * coth + p.da ^ 2) + p.i1 + p.i2
  M[2][1] = p.m2 * (p.da ^ 2 - p.da * p.rr * coth) + p.i2
  M[2][2] = p.m2 * p.da ^ 2 + p.i2
  M[3][3] = p.m3 * (p.sa ^ 2 + p.sb ^ 2) + p.i3
  M[4][4] = p.m4 * ee ^ 2 + p.i4
  M[5][4] = p.m4 * (ee ^ 2 + p.zt * ee * siph) + p.i4
  M[5][5] = p.m4 * (p.zt ^ 2 + 2 * p.zt * ee * siph + ee ^ 2) + p.m5 * (p.ta ^ 2 + p.tb ^ 2) + p.i4 + p.i5
  M[6][6] = p.m6 * zz ^ 2 + p.i6
  M[7][6] = p.m6 * (zz ^ 2 - p.u * zz * siom) + p.i6
  M[7][7] = p.m6 * (zz ^ 2 - 2 * p.u * zz * siom + p.u ^ 2) + p.m7 * (p.ua ^ 2 + p.ub ^ 2) + p.i6 + p.i7
  M[1][2], M[4][5], M[6][7] = M[2][1], M[5][4], M[7][6]
  local xd = p.sd * cos(q[3]) + p.sc * sin(q[3]) + p.xb
  local yd = p.sd * sin(q[3]) - p.sc * cos(q[3]) + p.yb
  local lang = sqrt((xd - p.xc) ^ 2 + (yd - p.yc) ^ 2)
  local force = -p.c0 * (lang - p.l0) / lang
  local fx, fy = force * (xd - p.xc), force * (yd - p.yc)
  local f = {
    p.mom - p.m2 * p.da * p.rr * qd[2] * (qd[2] + 2 * qd[1]) * sin(q[2]),
    p.m2 * p.da * p.rr * qd[1] ^ 2 * sin(q[2]),
    fx * (p.sc * cos(q[3]) - p.sd * sin(q[3])) + fy * (p.sd * cos(q[3]) + p.sc * sin(q[3])),
    p.m4 * p.zt * ee * qd[5] ^ 2 * cos(q[4]),
    -p.m4 * p.zt * ee * qd[4] * (qd[4] + 2 * qd[5]) * cos(q[4]),
    -p.m6 * p.u * zz * qd[7] ^ 2 * cos(q[6]),
    p.m6 * p.u * zz * qd[6] * (qd[6] + 2 * qd[7]) * cos(q[6]),
  }
  return M, f
end

describe("Andrews' squeezer: the model is the Test Set's", function()
  it("M and the forces agree with the published M and f at high-entropy states", function()
    for _, s in ipairs{ { 0.385, -1.2, 0.7, 0.31, -2.385, 1.1, 0.2 }, { 15.8, -15.76, 0.04, -0.53, 0.52, 0.53, 1.05 } } do
      local q, qd = {}, {}
      for i = 1, 7 do q[i], qd[i] = s[i], 1e3 * math.sin(2.385 * i + s[i]) end
      local M, f = testset_mf(q, qd)
      local Mn, hn = sys:mass(0, q, qd), sys:bias(0, q, qd)
      for i = 1, 7 do
        for j = 1, 7 do
          -- rounding: M's entries are 4e-7 .. 3e-5 kg m^2
          assert(math.abs(Mn[i][j] - M[i][j]) <= 1e-15 * 3e-5, ("M[%d][%d] = %.17g, Test Set %.17g"):format(i, j, Mn[i][j], M[i][j]))
        end
        -- f's terms: m2 da rr qd^2 ~ 3e-1 at qd ~ 1e3, the spring's ~ 1e2 x 1e-2
        assert(math.abs(hn[i] + f[i]) <= 1e-13 * (1 + math.abs(f[i])), ("h[%d] = %.17g, -f = %.17g"):format(i, hn[i], -f[i]))
      end
    end
  end)
  it("the accelerations and multipliers at the start are the Test Set's consistent ones", function()
    local qdd, lambda = sys:accel(0, start.q, start.qd)
    -- the Test Set gives them to 30 digits; the solve's rounding, in the
    -- scaled system (multipliers of 1e2, accelerations of 1e4): measured
    -- 2e-12 relative for the crank, 2e-10 absolute for the loops at rest
    for i = 1, 7 do
      assert(math.abs(qdd[i] - start.qdd[i]) <= 1e-9 + 1e-11 * math.abs(start.qdd[i]),
        ("q''_%d = %.17g, Test Set %.17g"):format(i, qdd[i], start.qdd[i]))
    end
    -- (6.2) here reads M q'' + h = A^T lambda: the Test Set's lambda with the other sign
    for r = 1, 6 do
      assert(math.abs(-lambda[r] - start.lambda[r]) <= 1e-12 + 1e-11 * math.abs(start.lambda[r]),
        ("lambda_%d = %.17g, Test Set %.17g"):format(r, -lambda[r], start.lambda[r]))
    end
  end)
  it("at the reference state the solve gives the reference's q'' and lambda to its accuracy", function()
    local qdd, lambda = sys:accel(ref.t, ref.q, ref.qd)
    -- an index-3 solver's q'' and lambda are its least accurate output:
    -- measured 1.1e-6 (q'') and 1.3e-6 (lambda) relative against it
    for i = 1, 7 do
      assert(math.abs(qdd[i] - ref.qdd[i]) <= 5e-6 * math.abs(ref.qdd[i]), ("q''_%d = %.10g, reference %.10g"):format(i, qdd[i], ref.qdd[i]))
    end
    for r = 1, 6 do
      assert(math.abs(-lambda[r] - ref.lambda[r]) <= 5e-6 * math.abs(ref.lambda[r]),
        ("lambda_%d = %.10g, reference %.10g"):format(r, -lambda[r], ref.lambda[r]))
    end
  end)
end)

describe("Andrews' squeezer: the check after the solve", function()
  it("measures a backward error at rounding along the motion, and the bound on the solve's error", function()
    -- The rows of the loop at rest (Omega, epsilon) have terms of size
    -- 1e-6 beside multipliers of 1e2: each row's residual against its own
    -- terms reached 1e-10, rounding of the whole system that the old check
    -- refused; the normwise backward error (constrained.h) is a few eps.
    local tr = sys:simulate{ q0 = start.q, qd0 = start.qd, t1 = ref.t, dt = 1e-4 }
    local eta, bound = 0, 0
    for i = 1, #tr.t do
      local _, _, report = sys:accel(tr.t[i], tr.q[i], tr.qd[i])
      eta, bound = math.max(eta, report.backward_error), math.max(bound, report.error_bound)
    end
    -- measured 1.8e-16 and 1.2e-13 (rcond 2e-3 after equilibration)
    assert(eta <= 1e-15, ("backward error %.3g"):format(eta))
    assert(bound <= 1e-12, ("error bound %.3g"):format(bound))
  end)
end)

-- Each stepper at a tolerance (or fixed step) it reaches in under a second
-- or two, and the largest errors of the angles (rad) and of the angular
-- velocities (rad/s; the crank turns at 1.1e3 rad/s) at t = 0.03, bounds
-- about 3x what was measured.  The reference itself is good to about 1.5e-9
-- rad and 6e-7 rad/s (rk8pd at 1e-12 and taylor at 1e-14 agree with each
-- other to 2e-13 and with it to 1.43e-9), the floor of the tightest.
local CASES = {
  { "rk8pd", 1e-10, 3e-9, 1.5e-6 },        -- measured 1.4e-9, 5.2e-7
  { "taylor", 1e-12, 3e-9, 1.5e-6 },       -- 1.4e-9, 5.4e-7
  { "rkf45", 1e-8, 5e-8, 5e-6 },           -- 1.5e-8, 1.4e-6
  { "rkck", 1e-8, 1.2e-7, 1.5e-5 },        -- 4.0e-8, 5.3e-6
  { "bsimp", 1e-10, 3e-9, 1.5e-6 },        -- 9.5e-10, 3.5e-7
  { "rk4imp", 1e-6, 4e-5, 1.6e-2 },        -- 1.3e-5, 5.4e-3
  { "msadams", 1e-10, 6e-8, 2e-5 },        -- 1.8e-8, 6.9e-6
  { "msbdf", 1e-8, 3e-5, 1.2e-2 },         -- 9.9e-6, 3.8e-3
  { "rk4", 2e-5, 3e-8, 1e-5, fixed = true },    -- 8.3e-9, 3.0e-6
  { "rk2", 2e-6, 6e-8, 2e-5, fixed = true },    -- 1.9e-8, 5.4e-6
}
-- The first-order and second-order implicit steppers need thousands of
-- steps of a Newton iteration each: rk2imp at 1e-5 (1.7e-3 rad, 0.65 rad/s,
-- 2 s) and rk1imp at 1e-4 (6.9e-2 rad, 18 rad/s, 12 s).
local SLOW = { { "rk2imp", 1e-5, 5e-3, 2 }, { "rk1imp", 1e-4, 0.2, 60 } }

-- The run of one case on the mechanism in units (L, M, T), from the Test
-- Set's start to t1 (0.03 T by default): its angles and its angular
-- velocities times T, comparable with the reference.
local function run(case, L, M, T, t1)
  local s = (L or M or T) and model.build(model.scaled(L, M, T), "squeezer scaled") or sys
  T = T or 1
  local opts = { q0 = start.q, qd0 = start.qd, t1 = t1 or ref.t * T, dt = t1 or ref.t * T, method = case[1] }
  if case.fixed then opts.step = case[2] * T else opts.rtol, opts.atol = case[2], case[2] end
  local tr = s:simulate(opts)
  local n, w = #tr.t, {}
  for i = 1, 7 do w[i] = tr.qd[n][i] * T end
  return tr.q[n], w, tr
end

local function errors(q, w, want)
  local eq, ew = 0, 0
  for i = 1, 7 do
    eq = math.max(eq, math.abs(q[i] - want.q[i]))
    ew = math.max(ew, math.abs(w[i] - want.qd[i]))
  end
  return eq, ew
end

local function check(case, eq, ew, what)
  assert(eq <= case[3] and ew <= case[4], ("%s %s: the angles are off by %.3g rad (bound %.3g), the angular velocities "
    .. "by %.3g rad/s (bound %.3g)"):format(case[1], what, eq, case[3], ew, case[4]))
end

describe("Andrews' squeezer under every stepper", function()
  for _, case in ipairs(CASES) do
    it(("%s reproduces the Test Set's reference at t = 0.03"):format(case[1]), function()
      local q, w = run(case)
      local eq, ew = errors(q, w, ref)
      check(case, eq, ew, "at t = 0.03")
    end)
  end
  for _, case in ipairs(SLOW) do
    it(("%s reproduces the Test Set's reference at t = 0.03 #slow"):format(case[1]), function()
      local q, w = run(case)
      local eq, ew = errors(q, w, ref)
      check(case, eq, ew, "at t = 0.03")
    end)
  end
end)

-- The same mechanism in other units (examples/squeezer.lua, scaled):
-- lengths times L, masses times M; the inertias (M L^2), the spring's
-- stiffness (M) and the torque (M L^2) follow, and the angles are the
-- reference's at the same times.  Time keeps its unit, so that the state
-- (angles and angular velocities) is the same numbers and every stepper's
-- error control sees what it saw in SI units (measured: the same errors
-- as in SI to two digits).  Masses from 3.7e-9 kg to 7e7 kg, lengths from
-- 9e-8 m to 78 m, moments of inertia from 4e-9 to 2 kg m^2, the torque
-- from 3.3e-4 to 3.3e3 N m, the spring from 4.5e-3 to 4.5e12 N/m.
local UNITS = { { 1e3, 1e-6 }, { 1e-4, 1e6 }, { 1e-2, 1e9 } }
describe("Andrews' squeezer in units far from SI, under every stepper", function()
  for _, u in ipairs(UNITS) do
    local L, M, T = u[1], u[2], 1
    it(("lengths x %g, masses x %g: every stepper's angles are the reference's"):format(L, M), function()
      for _, case in ipairs(CASES) do
        local q, w = run(case, L, M, T)
        local eq, ew = errors(q, w, ref)
        check(case, eq, ew, ("in units (%g, %g, %g)"):format(L, M, T))
      end
    end)
    it(("lengths x %g, masses x %g: rk2imp and rk1imp over the first 3 ms"):format(L, M), function()
      -- against the mechanism in SI units under Taylor's method at 1e-14
      local q0, w0 = run({ "taylor", 1e-14 }, nil, nil, nil, 0.003)
      for _, case in ipairs(SLOW) do
        local q, w = run(case, L, M, T, 0.003 * T)
        local eq, ew = errors(q, w, { q = q0, qd = w0 })
        -- measured: rk2imp 4.1e-6 rad, 2.2e-3 rad/s; rk1imp 3.7e-4 rad, 0.15 rad/s
        local bound = case[1] == "rk2imp" and { 1.2e-5, 6.5e-3 } or { 1.1e-3, 0.45 }
        assert(eq <= bound[1] and ew <= bound[2], ("%s in units (%g, %g, %g): off by %.3g rad, %.3g rad/s at 3 ms")
          :format(case[1], L, M, T, eq, ew))
      end
    end)
  end
end)
