-- bicycle_spec.lua - the Whipple bicycle of examples/bicycle.lua (8
-- coordinates from 4 rigid bodies, 1 holonomic and 4 rolling constraints)
-- against the benchmark of Meijaard, Papadopoulos, Ruina and Schwab (2007),
-- Proc. R. Soc. A 463, 1955-1982: their linearized equations
--   M q'' + v C1 q' + (g K0 + v^2 K2) q = 0,   q = (lean, steer),
-- with the matrices published for the benchmark (14 digits), the eigenvalues of their
-- Table 2, and the weave and capsize speeds.  The nonlinear model is
-- linearized numerically by central differences of sys:accel.  Its
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
local C1 = { { 0, 33.86641391492494 }, { -0.85035641456978, 1.68540397397560 } }
local K0 = { { -80.95, -2.59951685249872 }, { -2.59951685249872, -0.80329488458618 } }
local K2 = { { 0, 76.59734589573222 }, { 0, 2.65431523794604 } }

-- (lean, steer)'' = K q + C q' from the paper: K = -M^-1 (g K0 + v^2 K2), C = -v M^-1 C1.
local function paper(v)
  local det = Mp[1][1] * Mp[2][2] - Mp[1][2] * Mp[2][1]
  local Mi = { { Mp[2][2] / det, -Mp[1][2] / det }, { -Mp[2][1] / det, Mp[1][1] / det } }
  local K, C = { {}, {} }, { {}, {} }
  for i = 1, 2 do for j = 1, 2 do
    K[i][j] = -(Mi[i][1] * (g * K0[1][j] + v * v * K2[1][j]) + Mi[i][2] * (g * K0[2][j] + v * v * K2[2][j]))
    C[i][j] = -v * (Mi[i][1] * C1[1][j] + Mi[i][2] * C1[2][j])
  end end
  return K, C
end

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

  it("K and C of the numerical linearization match -M^-1 (g K0 + v^2 K2) and -v M^-1 C1 at 0, 3, 5 and 8 m/s", function()
    for _, v in ipairs{ 0, 3, 5, 8 } do
      local K, C = bike.linearize(v)
      local Kp, Cp = paper(v)
      -- Central differences with h = 1e-5: truncation ~ h^2 f'''/6, measured
      -- 3e-10 of the largest entry at 5 m/s; the bound leaves a factor 30.
      local scale = math.max(max_abs(Kp), max_abs(Cp))
      assert(max_diff(K, Kp) <= 1e-8 * scale, ("v = %g: K off by %.3g"):format(v, max_diff(K, Kp)))
      assert(max_diff(C, Cp) <= 1e-8 * scale, ("v = %g: C off by %.3g"):format(v, max_diff(C, Cp)))
    end
  end)

  it("the eigenvalues of Table 2 at 0, 4, 5 and 10 m/s", function()
    -- Table 2 of the paper, as published (sorted as bike.eigenvalues sorts).
    local table2 = {
      [0] = { { -5.53094371765393, 0 }, { -3.13164324790656, 0 }, { 3.13164324790656, 0 }, { 5.53094371765393, 0 } },
      [4] = { { -12.15861426576447, 0 }, { -1.42944427361326, 0 }, { 0.41325331521125, -3.07910818603206 }, { 0.41325331521125, 3.07910818603206 } },
      [5] = { { -14.07838969279822, 0 }, { -0.77534188219585, -4.46486771378823 }, { -0.77534188219585, 4.46486771378823 }, { -0.32286642900409, 0 } },
      [10] = { { -24.62459635017404, 0 }, { -3.72016840437287, -10.90681139476287 }, { -3.72016840437287, 10.90681139476287 }, { 0.16105338653172, 0 } },
    }
    for _, v in ipairs{ 0, 4, 5, 10 } do
      local got, ref = bike.eigenvalues(bike.linearize(v)), bike.eigenvalues(paper(v))
      for i = 1, 4 do
        local want = table2[v][i]
        local size = math.abs(want[1]) + math.abs(want[2])
        -- The paper's own matrices give its eigenvalues to its 14 digits
        -- (a check of the quartic's roots here).
        local e_ref = math.abs(ref[i][1] - want[1]) + math.abs(ref[i][2] - want[2])
        assert(e_ref <= 1e-12 * size, ("v = %g, eigenvalue %d from the paper's matrices off by %.3g"):format(v, i, e_ref))
        -- The nonlinear model: measured 1.8e-9 relative at worst (the small
        -- capsize root at 5 m/s); the bound 1e-7 leaves a factor 50.
        local e = math.abs(got[i][1] - want[1]) + math.abs(got[i][2] - want[2])
        assert(e <= 1e-7 * size, ("v = %g, eigenvalue %d: %.15g%+.15gi, Table 2 %.15g%+.15gi (off by %.3g)"):format(
          v, i, got[i][1], got[i][2], want[1], want[2], e))
      end
    end
  end)

  it("self-stable between the weave speed 4.29238253634111 and the capsize speed 6.02426201538837 m/s", function()
    -- The speed where the real part of the weave pair (weave) or the largest
    -- real root (capsize) crosses 0, by the secant method.
    local function weave(v)
      for _, z in ipairs(bike.eigenvalues(bike.linearize(v))) do if z[2] > 0 then return z[1] end end
      error("no weave pair at v = " .. v)
    end
    local function capsize(v)
      local best = -math.huge
      for _, z in ipairs(bike.eigenvalues(bike.linearize(v))) do if z[2] == 0 then best = math.max(best, z[1]) end end
      return best
    end
    local function crossing(f, a, b)
      local fa, fb = f(a), f(b)
      assert(fa * fb < 0, "no sign change")
      for _ = 1, 12 do
        local c = b - fb * (b - a) / (fb - fa)
        a, fa, b, fb = b, fb, c, f(c)
        if math.abs(b - a) < 1e-11 then break end
      end
      return b
    end
    local vw, vc = crossing(weave, 4.2, 4.4), crossing(capsize, 5.9, 6.1)
    -- The eigenvalues are good to ~1e-9 and cross 0 with slopes ~1.5 (weave)
    -- and ~0.2 (capsize) per m/s: measured 4e-10 and 2e-9 m/s off.
    assert(math.abs(vw - 4.29238253634111) <= 1e-7, ("weave speed %.14f"):format(vw))
    assert(math.abs(vc - 6.02426201538837) <= 1e-7, ("capsize speed %.14f"):format(vc))
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
