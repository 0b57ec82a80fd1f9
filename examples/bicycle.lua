-- bicycle.lua - the Whipple bicycle of Meijaard, Papadopoulos, Ruina and
-- Schwab (2007), "Linearized dynamics equations for the balance and steer of
-- a bicycle: a benchmark and review", Proc. R. Soc. A 463, 1955-1982, with
-- the benchmark's parameters (their Table 1).
--
-- Four rigid bodies (rear wheel R, rear frame B with the rider, front frame
-- H = handlebar and fork, front wheel F) and 8 coordinates: the rear contact
-- point (x, y), yaw, lean, pitch of the rear frame, rear wheel angle
-- (relative to the frame), steer, front wheel angle (relative to the fork).
-- T and V come from the bodies' positions and rotation matrices; the
-- constraints are 1 holonomic (the front wheel touches the ground) and 4
-- nonholonomic (both wheels roll without slipping, 2 each).  The paper's
-- axes: x forward, y to the right, z down; lean and steer positive to the
-- right.
--
-- The example linearizes the nonlinear equations numerically about upright
-- straight running and prints the eigenvalues of lean and steer at a few
-- speeds, beside the paper's, then rides 1 s at 5 m/s.
--
-- Run: build/nzlua examples/bicycle.lua.  Loaded with an argument
-- (loadfile(path)("module")) it returns the model and the tools below
-- without printing anything (tests/bicycle_spec.lua does that).

-- Table 1 of the paper.  The inertia matrices are in the paper's axes, in the
-- reference configuration (upright, steer straight ahead).
local p = {
  w = 1.02, c = 0.08, lambda = math.pi / 10, g = 9.81,
  rR = 0.3, mR = 2, IRxx = 0.0603, IRyy = 0.12,
  xB = 0.3, zB = -0.9, mB = 85, IB = { { 9.2, 0, 2.4 }, { 0, 11, 0 }, { 2.4, 0, 2.8 } },
  xH = 0.9, zH = -0.7, mH = 4, IH = { { 0.05892, 0, -0.00756 }, { 0, 0.06, 0 }, { -0.00756, 0, 0.00708 } },
  rF = 0.35, mF = 3, IFxx = 0.1405, IFyy = 0.28,
}
local rot = nz.rotations
local X, Y, YAW, LEAN, PITCH, REAR, STEER, FRONT = 1, 2, 3, 4, 5, 6, 7, 8

-- 3x3 products that skip the zero entries of constant factors: today every
-- product of a jet with 0 still costs a jet operation.
local function mul(A, B)
  local C = {}
  for i = 1, 3 do
    C[i] = {}
    for j = 1, 3 do
      local s = 0
      for k = 1, 3 do
        local a, b = A[i][k], B[k][j]
        if a ~= 0 and b ~= 0 then s = s + a * b end
      end
      C[i][j] = s
    end
  end
  return C
end
local function apply(A, v)   -- A v, skipping zeros of v
  local r = {}
  for i = 1, 3 do
    local s = 0
    for k = 1, 3 do if v[k] ~= 0 then s = s + A[i][k] * v[k] end end
    r[i] = s
  end
  return r
end
local function add(a, b) return { a[1] + b[1], a[2] + b[2], a[3] + b[3] } end
local function scale(s, a) return { s * a[1], s * a[2], s * a[3] } end
local function cross(a, b) return { a[2] * b[3] - a[3] * b[2], a[3] * b[1] - a[1] * b[3], a[1] * b[2] - a[2] * b[1] } end
local function column(A, j) return { A[1][j], A[2][j], A[3][j] } end

-- The steer axis: tilted back by lambda, through the ground a trail c ahead
-- of the front contact point; rotation by delta about it (pointing down).
local steer_axis = { math.sin(p.lambda), 0, math.cos(p.lambda) }
local tilt, untilt = rot.y(p.lambda), rot.y(-p.lambda)
local S0 = { p.w + p.c, 0, 0 }                          -- a point of the steer axis (reference configuration)
local rear_to_axis = { p.w + p.c, 0, p.rR }             -- S0 from the rear wheel centre (0, 0, -rR)

-- Orientations: the lean frame L = Rz(yaw) Rx(lean) (the rear wheel's plane),
-- the rear frame B = L Ry(pitch), the front frame H = B Ry(l) Rz(delta) Ry(-l).
local function frames(q)
  local L = mul(rot.z(q[YAW]), rot.x(q[LEAN]))
  local B = mul(L, rot.y(q[PITCH]))
  local H = mul(B, mul(mul(tilt, rot.z(q[STEER])), untilt))
  return L, B, H
end
-- The rear wheel centre: rR above the contact point in the wheel's plane.
local function rear_centre(q, L) return { q[X] - p.rR * L[1][3], q[Y] - p.rR * L[2][3], -p.rR * L[3][3] } end
-- A point of the front frame given in the reference configuration.
local function front_point(q, ref)
  local L, B, H = frames(q)
  return add(add(rear_centre(q, L), apply(B, rear_to_axis)), apply(H, { ref[1] - S0[1], ref[2] - S0[2], ref[3] - S0[3] }))
end

local bodies = {
  gravity = { 0, 0, p.g },                              -- z points down
  { name = "rear wheel", mass = p.mR, inertia = { p.IRxx, p.IRyy, p.IRxx },
    pos = function(t, q) return rear_centre(q, (frames(q))) end,
    rot = function(t, q) local _, B = frames(q); return mul(B, rot.y(q[REAR])) end },
  { name = "rear frame", mass = p.mB, inertia = p.IB,
    pos = function(t, q) local L, B = frames(q); return add(rear_centre(q, L), apply(B, { p.xB, 0, p.zB + p.rR })) end,
    rot = function(t, q) local _, B = frames(q); return B end },
  { name = "front frame", mass = p.mH, inertia = p.IH,
    pos = function(t, q) return front_point(q, { p.xH, 0, p.zH }) end,
    rot = function(t, q) local _, _, H = frames(q); return H end },
  { name = "front wheel", mass = p.mF, inertia = { p.IFxx, p.IFyy, p.IFxx },
    pos = function(t, q) return front_point(q, { p.w, 0, -p.rF }) end,
    rot = function(t, q) local _, _, H = frames(q); return mul(H, rot.y(q[FRONT])) end },
}

-- The front wheel touches the ground: its lowest point, rF from the centre
-- along the wheel's plane, is at z = 0.  With a = H e_y the axle,
-- |e_z - a_z a| = sqrt(1 - a_z^2) = sqrt(H31^2 + H33^2).
local function front_contact_height(t, q)
  local _, _, H = frames(q)
  local centre = front_point(q, { p.w, 0, -p.rF })
  return centre[3] + p.rF * nz.sqrt(H[3][1] ^ 2 + H[3][3] ^ 2)
end

-- Angular velocities (in space) of the lean frame, the rear frame and the
-- front frame, from the rotation sequence: each rate about its current axis.
local function omegas(q, qd, L, B)
  local wL = { qd[LEAN] * L[1][1], qd[LEAN] * L[2][1], qd[YAW] }   -- yaw about e_z, lean about Rz e_x (= L e_x)
  local wB = add(wL, scale(qd[PITCH], column(L, 2)))
  local wH = add(wB, scale(qd[STEER], apply(B, steer_axis)))
  return wL, wB, wH
end

-- Rolling without slipping: the velocity of the wheel's material point at
-- the contact is zero (its horizontal components; the vertical one is the
-- derivative of the holonomic constraint).
local function rear_rolling(i)
  -- contact point velocity = (x', y', 0) + rR (pitch' + rear') L e_x, L e_x = (cos yaw, sin yaw, 0)
  return function(t, q, qd)
    local spin = p.rR * (qd[PITCH] + qd[REAR])
    return i == 1 and qd[X] + spin * nz.cos(q[YAW]) or qd[Y] + spin * nz.sin(q[YAW])
  end
end
local function front_contact_velocity(q, qd)
  local L, B, H = frames(q)
  local wL, wB, wH = omegas(q, qd, L, B)
  local axle = column(H, 2)
  local down = { -axle[3] * axle[1], -axle[3] * axle[2], 1 - axle[3] * axle[3] }   -- e_z - a_z a
  local centre_to_contact = scale(p.rF / nz.sqrt(H[3][1] ^ 2 + H[3][3] ^ 2), down)
  local v = { qd[X], qd[Y], 0 }                                                   -- rear contact point
  v = add(v, scale(-p.rR, cross(wL, column(L, 3))))                               -- rear wheel centre
  v = add(v, cross(wB, apply(B, rear_to_axis)))                                   -- point S0 of the steer axis
  v = add(v, cross(wH, apply(H, { -p.c, 0, -p.rF })))                             -- front wheel centre
  local wF = add(wH, scale(qd[FRONT], axle))
  return add(v, cross(wF, centre_to_contact))
end
local function front_rolling(i) return function(t, q, qd) return front_contact_velocity(q, qd)[i] end end

local bicycle = nz.system{
  name = "Whipple bicycle (Meijaard et al. 2007 benchmark)",
  coords = { "x", "y", "yaw", "lean", "pitch", "rear", "steer", "front" },
  bodies = bodies,
  constraints = { front_contact_height, rear_rolling(1), rear_rolling(2), front_rolling(1), front_rolling(2) },
  sample = { t = 0, q = { 0, 0, 0.1, 0.05, 0, 0, 0.1, 0 }, qd = { 5, 0, 0, 0.1, 0, -5 / p.rR, 0.1, -5 / p.rF } },
}

-- ------------------------------------------------------------------ --
-- A consistent state from the independent quantities: lean, steer, their
-- rates and the rear wheel's rate (-v/rR at speed v).  The pitch solves the
-- holonomic constraint (Newton, its derivative from a jet); the other rates
-- solve the five velocity constraints (linear in the rates).

local function solve(A, b)   -- Gaussian elimination with partial pivoting
  local n = #b
  local M = {}
  for i = 1, n do M[i] = { table.unpack(A[i]) }; M[i][n + 1] = b[i] end
  for k = 1, n do
    local piv = k
    for i = k + 1, n do if math.abs(M[i][k]) > math.abs(M[piv][k]) then piv = i end end
    M[k], M[piv] = M[piv], M[k]
    for i = k + 1, n do
      local f = M[i][k] / M[k][k]
      for j = k, n + 1 do M[i][j] = M[i][j] - f * M[k][j] end
    end
  end
  local x = {}
  for i = n, 1, -1 do
    local s = M[i][n + 1]
    for j = i + 1, n do s = s - M[i][j] * x[j] end
    x[i] = s / M[i][i]
  end
  return x
end

local function state(lean, steer, leand, steerd, rear_rate)
  local q = { 0, 0, 0, lean, 0, 0, steer, 0 }
  for _ = 1, 30 do
    local qj = { table.unpack(q) }
    qj[PITCH] = nz.jet(q[PITCH], 1)
    local f = front_contact_height(0, qj)
    local step = f:coef(0) / f:coef(1)
    q[PITCH] = q[PITCH] - step
    if math.abs(step) < 1e-17 then break end
  end
  -- Rows: d/dt of the holonomic constraint (its gradient from jets) and the
  -- four rolling constraints, as linear functions of the rates.
  local rows = { {}, {}, {}, {}, {} }
  local zero = { 0, 0, 0, 0, 0, 0, 0, 0 }
  for j = 1, 8 do
    local qj, e = { table.unpack(q) }, { table.unpack(zero) }
    qj[j], e[j] = nz.jet(q[j], 1), 1
    local f = front_contact_height(0, qj)
    rows[1][j] = type(f) == "number" and 0 or f:coef(1)       -- x, y, yaw, ... do not enter it
    rows[2][j], rows[3][j] = rear_rolling(1)(0, q, e), rear_rolling(2)(0, q, e)
    local v = front_contact_velocity(q, e)
    rows[4][j], rows[5][j] = v[1], v[2]
  end
  local known = { [LEAN] = leand, [STEER] = steerd, [REAR] = rear_rate }
  local unknown = { X, Y, YAW, PITCH, FRONT }
  local A, b = {}, {}
  for r = 1, 5 do
    A[r], b[r] = {}, 0
    for c, j in ipairs(unknown) do A[r][c] = rows[r][j] end
    for j, v in pairs(known) do b[r] = b[r] - rows[r][j] * v end
  end
  local u = solve(A, b)
  local qd = { 0, 0, 0, leand, 0, rear_rate, steerd, 0 }
  for c, j in ipairs(unknown) do qd[j] = u[c] end
  return q, qd
end

-- The linearization about upright straight running at speed v: central
-- differences of the constrained accelerations of lean and steer with
-- respect to (lean, steer, lean', steer'), the rear wheel's rate held at
-- -v/rR (the speed's own perturbation decouples at first order).  Returns
-- K and C of  (lean, steer)'' = K (lean, steer) + C (lean, steer)'.
local function linearize(v, h)
  h = h or 1e-5
  local K, C = { {}, {} }, { {}, {} }
  for j = 1, 4 do
    local acc = {}
    for s, sign in ipairs{ 1, -1 } do
      local x = { 0, 0, 0, 0 }
      x[j] = sign * h
      local q, qd = state(x[1], x[2], x[3], x[4], -v / p.rR)
      local qdd = bicycle:accel(0, q, qd)
      acc[s] = { qdd[LEAN], qdd[STEER] }
    end
    for i = 1, 2 do
      local d = (acc[1][i] - acc[2][i]) / (2 * h)
      if j <= 2 then K[i][j] = d else C[i][j - 2] = d end
    end
  end
  return K, C
end

-- Eigenvalues of [[0, I], [K, C]]: the roots of det(s^2 - s C - K), a
-- quartic, by Durand-Kerner's iteration in complex arithmetic.
local function quartic(K, C)
  return { 1, -(C[1][1] + C[2][2]), C[1][1] * C[2][2] - K[1][1] - K[2][2] - C[1][2] * C[2][1],
    C[1][1] * K[2][2] + C[2][2] * K[1][1] - C[1][2] * K[2][1] - K[1][2] * C[2][1],
    K[1][1] * K[2][2] - K[1][2] * K[2][1] }
end
local function cmul(a, b) return { a[1] * b[1] - a[2] * b[2], a[1] * b[2] + a[2] * b[1] } end
local function cdiv(a, b) local d = b[1] ^ 2 + b[2] ^ 2; return { (a[1] * b[1] + a[2] * b[2]) / d, (a[2] * b[1] - a[1] * b[2]) / d } end
local function roots(coef)
  local n = #coef - 1
  local z = {}
  for i = 1, n do z[i] = { 0.9 * math.cos(2 * math.pi * i / n + 0.4) * 10, 0.9 * math.sin(2 * math.pi * i / n + 0.4) * 10 } end
  for _ = 1, 500 do
    local moved = 0
    for i = 1, n do
      local f = { coef[1], 0 }
      for k = 2, n + 1 do f = cmul(f, z[i]); f[1] = f[1] + coef[k] end
      local d = { 1, 0 }
      for j = 1, n do if j ~= i then d = cmul(d, { z[i][1] - z[j][1], z[i][2] - z[j][2] }) end end
      local step = cdiv(f, d)
      z[i] = { z[i][1] - step[1], z[i][2] - step[2] }
      moved = math.max(moved, math.abs(step[1]) + math.abs(step[2]))
    end
    if moved < 1e-15 then break end
  end
  -- The coefficients are real: a real root's imaginary part is rounding (set
  -- it to 0) and complex roots come in pairs (make them exact conjugates, so
  -- that each pair sorts as a - bi, a + bi).
  for i = 1, n do if math.abs(z[i][2]) < 1e-9 * (1 + math.abs(z[i][1])) then z[i][2] = 0 end end
  for i = 1, n do
    if z[i][2] > 0 then
      local best, j = math.huge, nil
      for k = 1, n do
        local d = math.abs(z[k][1] - z[i][1]) + math.abs(z[k][2] + z[i][2])
        if k ~= i and z[k][2] < 0 and d < best then best, j = d, k end
      end
      local re, im = (z[i][1] + z[j][1]) / 2, (z[i][2] - z[j][2]) / 2
      z[i], z[j] = { re, im }, { re, -im }
    end
  end
  table.sort(z, function(a, b) if a[1] ~= b[1] then return a[1] < b[1] end return a[2] < b[2] end)
  return z
end
local function eigenvalues(K, C) return roots(quartic(K, C)) end

local model = { system = bicycle, params = p, state = state, linearize = linearize, eigenvalues = eigenvalues,
  quartic = quartic, roots = roots, front_contact_height = front_contact_height,
  front_contact_velocity = front_contact_velocity, rear_rolling = rear_rolling, frames = frames, omegas = omegas, bodies = bodies,
  index = { x = X, y = Y, yaw = YAW, lean = LEAN, pitch = PITCH, rear = REAR, steer = STEER, front = FRONT } }
if ... == "module" then return model end

-- ------------------------------------------------------------------ --
print(bicycle)
local _, why = bicycle:rule()
print(why)

-- What recording, differentiation and a constrained acceleration cost:
-- `make bench` (bench/bicycle.lua).

-- The paper's linearized equations M q'' + v C1 q' + (g K0 + v^2 K2) q = 0
-- with the matrices the paper publishes for the benchmark: the reference.
local Mp = { { 80.81722, 2.31941332208709 }, { 2.31941332208709, 0.29784188199686 } }
local C1 = { { 0, 33.86641391492494 }, { -0.85035641456978, 1.68540397397560 } }
local K0 = { { -80.95, -2.59951685249872 }, { -2.59951685249872, -0.80329488458618 } }
local K2 = { { 0, 76.59734589573222 }, { 0, 2.65431523794604 } }
local function paper(v)
  local det = Mp[1][1] * Mp[2][2] - Mp[1][2] * Mp[2][1]
  local Mi = { { Mp[2][2] / det, -Mp[1][2] / det }, { -Mp[2][1] / det, Mp[1][1] / det } }
  local K, C = { {}, {} }, { {}, {} }
  for i = 1, 2 do for j = 1, 2 do
    K[i][j] = -(Mi[i][1] * (p.g * K0[1][j] + v * v * K2[1][j]) + Mi[i][2] * (p.g * K0[2][j] + v * v * K2[2][j]))
    C[i][j] = -v * (Mi[i][1] * C1[1][j] + Mi[i][2] * C1[2][j])
  end end
  return eigenvalues(K, C)
end
local function listed(zs)   -- a complex pair once, as a +- bi
  local out = {}
  for _, z in ipairs(zs) do
    if z[2] == 0 then out[#out + 1] = ("%.6f"):format(z[1])
    elseif z[2] > 0 then out[#out + 1] = ("%.6f+-%.6fi"):format(z[1], z[2]) end
  end
  return table.concat(out, "  ")
end

print("\neigenvalues of lean and steer about upright straight running (1/s)")
print(("%6s  %-50s  %s"):format("v m/s", "nzlua (linearized numerically)", "vs the paper's"))
for _, v in ipairs{ 0, 2, 4, 4.5, 5, 6, 8 } do
  local mine, ref = eigenvalues(linearize(v)), paper(v)
  local worst = 0
  for i = 1, 4 do worst = math.max(worst, math.abs(mine[i][1] - ref[i][1]) + math.abs(mine[i][2] - ref[i][2])) end
  local stable = mine[4][1] < 0 and "  self-stable" or ""
  print(("%6.2f  %-50s  %.1e%s"):format(v, listed(mine), worst, stable))
end
print("(the paper: self-stable between the weave speed 4.292 and the capsize speed 6.024 m/s)")

-- A ride of 1 s at 5 m/s after a push to the side: the lean dies out.
local q0, qd0 = state(0, 0, 0.5, 0, -5 / p.rR)
local tr = bicycle:simulate{ q0 = q0, qd0 = qd0, t1 = 1, dt = 0.05, rtol = 1e-10, atol = 1e-12, monitors = { energy = true } }
print()
print(tr)
local lo, hi = math.huge, -math.huge
for _, e in ipairs(tr.energy) do lo, hi = math.min(lo, e), math.max(hi, e) end
print(("energy T + V: drift %.1e J over 1 s (of %.3f J)"):format(hi - lo, tr.energy[1]))
