-- bicycle_spec.lua - the Whipple bicycle of examples/bicycle.lua (8
-- coordinates from 4 rigid bodies, 1 holonomic and 4 rolling constraints)
-- against the benchmark of Meijaard, Papadopoulos, Ruina and Schwab (2007),
-- Proc. R. Soc. A 463, 1955-1982: their linearized equations
--   M q'' + v C1 q' + (g K0 + v^2 K2) q = 0,   q = (lean, steer),
-- with the matrices published for the benchmark (14 digits), the eigenvalues of their
-- Table 2 (every speed, every printed digit), and the weave and capsize
-- speeds.  The nonlinear model is linearized by sys:linearize (exact: jets
-- through the constrained accelerations, nothing differenced) and swept by
-- sys:eigen_sweep.  Its
-- kinematics are checked against the rotation matrices with jets, and a ride
-- of 1 s (#slow: about 16 s today) against the linear motion, the
-- constraints and the energy.
local h = require "tests.helpers"
local nz = h.nz

local env = setmetatable({ nz = nz }, { __index = _G })
local bike = assert(loadfile("examples/bicycle.lua", "t", env))("module")
local sys, p, I = bike.system, bike.params, bike.index

-- The paper's matrices for the benchmark bicycle, 14 digits as published,
-- and its g (Table 1).
local g = 9.81
local Mp = { { 80.81722, 2.31941332208709 }, { 2.31941332208709, 0.29784188199686 } }
local C1p = { { 0, 33.86641391492494 }, { -0.85035641456978, 1.68540397397560 } }
local K0p = { { -80.95, -2.59951685249872 }, { -2.59951685249872, -0.80329488458618 } }
local K2p = { { 0, 76.59734589573222 }, { 0, 2.65431523794604 } }

-- (lean, steer)'' = K q + C q' from the paper: K = -M^-1 (g K0 + v^2 K2), C = -v M^-1 C1.
local function paper(v)
  local det = Mp[1][1] * Mp[2][2] - Mp[1][2] * Mp[2][1]
  local Mi = { { Mp[2][2] / det, -Mp[1][2] / det }, { -Mp[2][1] / det, Mp[1][1] / det } }
  local K, C = { {}, {} }, { {}, {} }
  for i = 1, 2 do for j = 1, 2 do
    K[i][j] = -(Mi[i][1] * (g * K0p[1][j] + v * v * K2p[1][j]) + Mi[i][2] * (g * K0p[2][j] + v * v * K2p[2][j]))
    C[i][j] = -v * (Mi[i][1] * C1p[1][j] + Mi[i][2] * C1p[2][j])
  end end
  return K, C
end

-- Table 2 of the paper: the eigenvalues {re, im} at v = 0, 1, ..., 10 m/s,
-- 14 decimals as published (a complex pair as both members).
local table2 = {
  [0] = { { -3.13164324790656, 0 }, { 3.13164324790656, 0 }, { -5.53094371765393, 0 }, { 5.53094371765393, 0 } },
  { { -3.13423125066578, 0 }, { 3.52696170990070, -0.8077402751993 }, { 3.52696170990070, 0.8077402751993 }, { -7.11008014637442, 0 } },
  { { -3.07158645641514, 0 }, { 2.68234517512745, -1.68066296590675 }, { 2.68234517512745, 1.68066296590675 }, { -8.67387984831735, 0 } },
  { { -2.63366137253667, 0 }, { 1.70675605663975, -2.31582447384325 }, { 1.70675605663975, 2.31582447384325 }, { -10.35101467245920, 0 } },
  { { -1.42944427361326, 0 }, { 0.41325331521125, -3.07910818603206 }, { 0.41325331521125, 3.07910818603206 }, { -12.15861426576450, 0 } },
  { { -0.32286642900409, 0 }, { -0.77534188219585, -4.46486771378823 }, { -0.77534188219585, 4.46486771378823 }, { -14.07838969279820, 0 } },
  { { -0.00406690076970, 0 }, { -1.52644486584142, -5.87673060598709 }, { -1.52644486584142, 5.87673060598709 }, { -16.08537123098030, 0 } },
  { { 0.10268170574766, 0 }, { -2.13875644258362, -7.19525913329805 }, { -2.13875644258362, 7.19525913329805 }, { -18.15788466125262, 0 } },
  { { 0.14327879765713, 0 }, { -2.69348683581097, -8.46037971396931 }, { -2.69348683581097, 8.46037971396931 }, { -20.27940894394569, 0 } },
  { { 0.15790184030917, 0 }, { -3.21675402252485, -9.69377351531791 }, { -3.21675402252485, 9.69377351531791 }, { -22.43788559040858, 0 } },
  { { 0.16105338653172, 0 }, { -3.72016840437287, -10.90681139476287 }, { -3.72016840437287, 10.90681139476287 }, { -24.62459635017404, 0 } },
}

local function max_abs(m) local s = 0; for i = 1, 2 do for j = 1, 2 do s = math.max(s, math.abs(m[i][j])) end end; return s end
local function max_diff(a, b) local s = 0; for i = 1, 2 do for j = 1, 2 do s = math.max(s, math.abs(a[i][j] - b[i][j])) end end; return s end
local function vdiff(a, b) local s = 0; for i = 1, #a do s = math.max(s, math.abs(a[i] - b[i])) end; return s end

-- Jets q + qd t of order 1: evaluating a function of q on them gives its
-- value and its time derivative along qd (coefficient 1).
local function moving(q, qd)
  local out = {}
  for i = 1, #q do out[i] = nz.jet{ q[i], qd[i], order = 1 } end
  return out
end
local function c0(x) return type(x) == "number" and x or x:coef(0) end
local function c1(x) return type(x) == "number" and 0 or x:coef(1) end

describe("the bicycle's geometry and kinematics", function()
  it("Table 1's reference configuration: the bodies where the paper puts them, the front wheel on the ground", function()
    local q0 = { 0, 0, 0, 0, 0, 0, 0, 0 }
    local want = { { 0, 0, -p.rR }, { p.xB, 0, p.zB }, { p.xH, 0, p.zH }, { p.w, 0, -p.rF } }
    for b = 1, 4 do
      assert(vdiff(bike.bodies[b].pos(0, q0), want[b]) <= 1e-15, bike.bodies[b].name)
      local R = bike.bodies[b].rot(0, q0)
      for i = 1, 3 do for j = 1, 3 do assert(math.abs(R[i][j] - (i == j and 1 or 0)) <= 1e-15) end end
    end
    assert(math.abs(bike.front_contact_height(0, q0)) <= 1e-15)
  end)

  it("the rolling constraints: the wheels' contact points move as the bodies' rotation matrices say (jets)", function()
    for _ = 1, 5 do
      local q, qd = bike.state(0.3 * math.random() - 0.15, 0.6 * math.random() - 0.3,
        math.random() - 0.5, math.random() - 0.5, -(2 + 4 * math.random()) / p.rR)
      -- Arbitrary rates (not on the constraints): the identities hold for any.
      local u = {}
      for i = 1, 8 do u[i] = 4 * math.random() - 2 end
      q[I.yaw], q[I.rear], q[I.front] = 2 * math.pi * math.random(), 6 * math.random(), 6 * math.random()
      local qj = moving(q, u)
      -- Material point of a wheel at its contact: fixed in the wheel's body
      -- axes, b = R^T (contact - centre); its velocity d/dt (centre + R b).
      for w, body in ipairs{ bike.bodies[1], bike.bodies[4] } do
        local centre, R = body.pos(0, qj), body.rot(0, qj)
        local Rv = {}
        for i = 1, 3 do Rv[i] = { c0(R[i][1]), c0(R[i][2]), c0(R[i][3]) } end
        local axle = { Rv[1][2], Rv[2][2], Rv[3][2] }
        local r = w == 1 and p.rR or p.rF
        local n = math.sqrt(1 - axle[3] ^ 2)
        local d = { -axle[3] * axle[1] * r / n, -axle[3] * axle[2] * r / n, (1 - axle[3] ^ 2) * r / n }
        local contact = { c0(centre[1]) + d[1], c0(centre[2]) + d[2], c0(centre[3]) + d[3] }
        if w == 1 then assert(math.abs(contact[1] - q[I.x]) + math.abs(contact[2] - q[I.y]) + math.abs(contact[3]) <= 1e-14) end
        local b = {}
        for j = 1, 3 do b[j] = Rv[1][j] * d[1] + Rv[2][j] * d[2] + Rv[3][j] * d[3] end
        local vel = {}
        for i = 1, 3 do vel[i] = c1(centre[i]) + c1(R[i][1]) * b[1] + c1(R[i][2]) * b[2] + c1(R[i][3]) * b[3] end
        local got
        if w == 1 then
          got = { bike.rear_rolling(1)(0, q, u), bike.rear_rolling(2)(0, q, u), 0 }
        else
          got = bike.front_contact_velocity(q, u)
        end
        assert(vdiff(got, vel) <= 1e-13 * 10, ("wheel %d: constraint %s, from the rotation matrices %s"):format(w,
          table.concat(got, ", "), table.concat(vel, ", ")))
        -- Its vertical component is the rate of the holonomic constraint
        -- (the contact is the wheel's lowest point).
        if w == 2 then
          local rate = c1(bike.front_contact_height(0, qj))
          assert(math.abs(vel[3] - rate) <= 1e-13 * 10)
        end
      end
    end
  end)
end)

describe("the bicycle against the benchmark's linearized equations", function()
  it("the mass matrix M: twice T on the constraints at rest, exactly (no differences)", function()
    -- T = E(q, qd) - E(q, 0) at upright rest, the rates of lean and steer
    -- given and the dependent rates from the constraints.
    local function T(a, b)
      local q, qd = bike.state(0, 0, a, b, 0)
      return sys:energy(0, q, qd) - sys:energy(0, q, { 0, 0, 0, 0, 0, 0, 0, 0 })
    end
    local t10, t01, t11 = T(1, 0), T(0, 1), T(1, 1)
    local M = { { 2 * t10, t11 - t10 - t01 }, { t11 - t10 - t01, 2 * t01 } }
    -- The paper gives 14 digits (1e-14 of M11); measured 1.6e-15 of M11.
    assert(max_diff(M, Mp) <= 1e-13 * max_abs(Mp), ("M = {{%.14g, %.14g}, {%.14g, %.14g}}"):format(M[1][1], M[1][2], M[2][1], M[2][2]))
  end)

  it("sys:linearize at upright straight running: what it keeps, solves and drops", function()
    local lin = bike.linearize(5)
    assert.are.same({ "lean", "steer", "lean'", "steer'" }, lin.state)
    local function named(list) local out = {}; for n, i in ipairs(list) do out[n] = sys.coords[i] end; return out end
    assert.are.same({ "pitch" }, named(lin.dependent))
    assert.are.same({ "x", "y", "yaw", "pitch", "front" }, named(lin.dependent_speeds))
    assert.are.same({ "rear" }, named(lin.hold))
    -- the dependent rates solved at the point: the bicycle rolls straight at
    -- v = 5 (x' = v), the front wheel at -v/rF
    assert.near(5, lin.qd[I.x], 1e-13)
    assert.near(-5 / p.rF, lin.qd[I.front], 1e-12)
    assert(lin.residual <= 1e-12, "upright straight running is a steady motion")
    local text = tostring(lin)
    assert.truthy(text:find("dependent speeds (from the velocity constraints): x', y', yaw', pitch', front'", 1, true), text)
  end)

  it("M, C1, K0, K2 of M q'' + v C1 q' + (g K0 + v^2 K2) q = 0 are the published ones (14 digits)", function()
    local M, C1, K0, K2 = bike.matrices()
    -- The paper prints 14 decimals; these come from exact jets through the
    -- constrained accelerations and the reduced mass matrix, so rounding
    -- only: measured 3.5e-16 (M), 4.7e-16 (C1), 3.2e-15 (K0), 1.1e-15 (K2)
    -- of each matrix's largest entry.  Bound 1e-14 of it.
    for _, pair in ipairs{ { "M", M, Mp }, { "C1", C1, C1p }, { "K0", K0, K0p }, { "K2", K2, K2p } } do
      local name, got, want = table.unpack(pair)
      assert(max_diff(got, want) <= 1e-14 * max_abs(want), ("%s off by %.3g: {{%.15g, %.15g}, {%.15g, %.15g}}"):format(
        name, max_diff(got, want), got[1][1], got[1][2], got[2][1], got[2][2]))
    end
  end)

  it("the eigenvalues of Table 2 at every speed from 0 to 10 m/s, to all printed digits", function()
    for v = 0, 10 do
      local got = bike.linearize(v):eigenvalues()
      local want = table2[v]
      assert.are.equal(4, #got)
      -- match each published eigenvalue with the nearest of ours (the
      -- paper's order is by mode: capsize, weave pair, castor)
      local used = {}
      for _, w in ipairs(want) do
        local best, bi = math.huge, nil
        for i, z in ipairs(got) do
          local d = math.abs(z[1] - w[1]) + math.abs(z[2] - w[2])
          if not used[i] and d < best then best, bi = d, i end
        end
        used[bi] = true
        -- 14 decimals printed (half a unit: 5e-15) and the rounding of a
        -- 4x4 nonsymmetric eigenproblem whose entries grow as |lambda|^2:
        -- measured 5.5e-13 at worst (the castor root, -18.16 at 7 m/s:
        -- 2.9e-14 of it), 6e-14 elsewhere.  Bound 1e-13 (1 + |lambda|).
        local size = math.sqrt(w[1] ^ 2 + w[2] ^ 2)
        assert(best <= 1e-13 * (1 + size), ("v = %d: Table 2 has %.14f%+.14fi, nearest %.14f%+.14fi (off by %.3g)"):format(
          v, w[1], w[2], got[bi][1], got[bi][2], best))
      end
    end
  end)

  it("the bifurcation speed 0.68428307889246 of Table 2: the two real roots meet at 3.78290405129320", function()
    local ev = bike.linearize(0.68428307889246):eigenvalues()
    -- A double root splits as the square root of the distance from the
    -- bifurcation: the speed's 14 printed digits (5e-15) leave a split of
    -- ~sqrt(5e-15 * c): measured 1.4e-7 here.  Bound 2e-6.
    local near = 0
    for _, z in ipairs(ev) do
      if math.abs(z[1] - 3.78290405129320) + math.abs(z[2]) <= 2e-6 then near = near + 1 end
    end
    assert.are.equal(2, near)
  end)

  it("sys:eigen_sweep: stable between the weave speed 4.29238253634111 and the capsize speed 6.02426201538837 m/s", function()
    local values = {}
    for i = 0, 20 do values[#values + 1] = i / 2 end
    local sw = bike.sweep(values, 1e-13)
    assert.are.equal(2, #sw.crossings)
    local weave, capsize = sw.crossings[1], sw.crossings[2]
    assert.are.same({ "unstable", "stable", "oscillatory" }, { weave.from, weave.to, weave.kind })
    assert.are.same({ "stable", "unstable", "real" }, { capsize.from, capsize.to, capsize.kind })
    -- Brent's method to 1e-13 on the largest real part, which crosses 0
    -- with slopes ~1.5 (weave) and ~0.2 (capsize) per m/s: its rounding
    -- (~5e-15) moves the root by ~3e-15 and ~2.5e-14; measured 1.3e-14 and
    -- 4.6e-14 off the published 14 digits.  Bound 2e-13.
    assert(math.abs(weave.value - 4.29238253634111) <= 2e-13, ("weave speed %.15f"):format(weave.value))
    assert(math.abs(capsize.value - 6.02426201538837) <= 2e-13, ("capsize speed %.15f"):format(capsize.value))
    -- at the weave speed the weave pair is on the imaginary axis: +-3.43503384866144i
    -- (Table 2); measured 2.7e-15 off
    assert(math.abs(weave.frequency - 3.43503384866144) <= 1e-12, ("weave frequency %.15f"):format(weave.frequency))
    for i, row in ipairs(sw.rows) do
      local stable = row.value > 4.29238253634111 and row.value < 6.02426201538837
      assert.are.equal(stable and "stable" or "unstable", row.status, "v = " .. row.value)
      assert.are.equal(values[i], row.value)
    end
    -- the CSV: a header and one row per speed
    local csv = sw:csv()
    local lines = {}
    for line in csv:gmatch("[^\n]+") do lines[#lines + 1] = line end
    assert.are.equal("v,re1,im1,re2,im2,re3,im3,re4,im4,status", lines[1])
    assert.are.equal(#values + 1, #lines)
  end)
end)

describe("a ride at 5 m/s #slow", function()
  it("1 s after a push: the constraints hold, the energy is conserved, lean and steer follow the linear equations", function()
    local v, push = 5, 0.025
    local q0, qd0 = bike.state(0, 0, push, 0, -v / p.rR)
    local tr = sys:simulate{ q0 = q0, qd0 = qd0, t1 = 1, dt = 0.05, rtol = 1e-8, atol = 1e-10, monitors = { energy = true },
      dense = false }   -- a step end at each point, as the bounds below were measured
    assert(tr.status == "done", tostring(tr.status))
    -- The constraints, evaluated here along the motion (not the trajectory's
    -- own report): the front wheel's height and both contact velocities.
    local worst_h, worst_v = 0, 0
    for i = 1, #tr.t do
      local q, qd = tr.q[i], tr.qd[i]
      worst_h = math.max(worst_h, math.abs(bike.front_contact_height(0, q)))
      local vf = bike.front_contact_velocity(q, qd)
      worst_v = math.max(worst_v, math.abs(vf[1]), math.abs(vf[2]),
        math.abs(bike.rear_rolling(1)(0, q, qd)), math.abs(bike.rear_rolling(2)(0, q, qd)))
    end
    -- The engine closes the constraints at the acceleration level, so they
    -- drift only by the integrator's error in their directions: measured
    -- 7e-16 m and 5e-15 m/s (rk8pd's error is far below rtol 1e-8 here);
    -- bounds 1e-12 m and 1e-11 m/s.
    assert(worst_h <= 1e-12, ("front wheel off the ground by %.3g m"):format(worst_h))
    assert(worst_v <= 1e-11, ("a contact point slips at %.3g m/s"):format(worst_v))
    -- No dissipation in the Whipple model (ideal, scleronomic constraints):
    -- T + V is conserved to the integrator's error, measured 1e-15 of
    -- E ~ 2000 J; bound 1e-11.
    local lo, hi = math.huge, -math.huge
    for _, e in ipairs(tr.energy) do lo, hi = math.min(lo, e), math.max(hi, e) end
    assert(hi - lo <= 1e-11 * math.abs(tr.energy[1]), ("energy drift %.3g J"):format(hi - lo))
    -- The paper's linear equations from the same start (lean' = push),
    -- integrated here by RK4 with a fine step.  The nonlinear motion differs
    -- by the cubic terms (the mirror symmetry removes the quadratic ones):
    -- relative size ~ amplitude^2, measured 1.5e-4 here and 6.1e-4 at twice
    -- the push (4x: quadratic, as it must be); bound 5e-4.
    local K, C = paper(v)
    local function f(x) return { x[3], x[4], K[1][1] * x[1] + K[1][2] * x[2] + C[1][1] * x[3] + C[1][2] * x[4],
      K[2][1] * x[1] + K[2][2] * x[2] + C[2][1] * x[3] + C[2][2] * x[4] } end
    local x, dt, t = { 0, 0, push, 0 }, 1e-4, 0
    local worst, size = 0, 0
    for i = 1, #tr.t do
      while t < tr.t[i] - 1e-12 do
        local k1 = f(x)
        local function at(k, s) return { x[1] + s * k[1], x[2] + s * k[2], x[3] + s * k[3], x[4] + s * k[4] } end
        local k2 = f(at(k1, dt / 2)); local k3 = f(at(k2, dt / 2)); local k4 = f(at(k3, dt))
        for j = 1, 4 do x[j] = x[j] + dt / 6 * (k1[j] + 2 * k2[j] + 2 * k3[j] + k4[j]) end
        t = t + dt
      end
      worst = math.max(worst, math.abs(tr.q[i][I.lean] - x[1]), math.abs(tr.q[i][I.steer] - x[2]))
      size = math.max(size, math.abs(x[1]), math.abs(x[2]))
    end
    assert(worst <= 5e-4 * size, ("lean and steer differ from the linear motion by %.3g (of %.3g)"):format(worst, size))
  end)
end)
