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
-- The example linearizes the nonlinear equations about upright straight
-- running (sys:linearize, exact), prints the benchmark's matrices M, C1,
-- K0, K2 beside the paper's, the eigenvalues of lean and steer for v = 0..10
-- m/s (the paper's Table 2), the weave and capsize speeds (sys:eigen_sweep)
-- and a plot of the eigenvalues against the speed, then rides 5 s at 5 m/s.
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

bicycle = nz.system{
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

-- The linearization about upright straight running at speed v
-- (sys:linearize: exact, from the jets, no differences): lean and steer
-- kept with their rates, the rear wheel's rate held at -v/rR (the speed's
-- own perturbation decouples at first order), pitch solved from the front
-- wheel's contact, the other rates from the rolling constraints, and x, y,
-- yaw and the wheel angles left out (they do not appear: checked).
local function linearize(v)
  return bicycle:linearize{ q = { 0, 0, 0, 0, 0, 0, 0, 0 }, qd = { 0, 0, 0, 0, 0, -v / p.rR, 0, 0 },
    coords = { "lean", "steer" }, speeds = { "lean", "steer" }, hold = { "rear" } }
end

-- The benchmark's matrices of M q'' + v C1 q' + (g K0 + v^2 K2) q = 0 from
-- two linearizations: K = g K0 at v = 0, and C = C1, K = g K0 + K2 at v = 1.
local function matrices()
  local l0, l1 = linearize(0), linearize(1)
  local C1, K0, K2 = { {}, {} }, { {}, {} }, { {}, {} }
  for i = 1, 2 do for j = 1, 2 do
    C1[i][j], K0[i][j], K2[i][j] = l1.C[i][j], l0.K[i][j] / p.g, l1.K[i][j] - l0.K[i][j]
  end end
  return l0.M, C1, K0, K2
end

-- The eigenvalues against the speed, and where the motion changes stability.
local function sweep(values, tol)
  return bicycle:eigen_sweep{ parameter = "v", values = values, tol = tol,
    at = function(v) return { q = { 0, 0, 0, 0, 0, 0, 0, 0 }, qd = { 0, 0, 0, 0, 0, -v / p.rR, 0, 0 },
      coords = { "lean", "steer" }, speeds = { "lean", "steer" }, hold = { "rear" } } end }
end

local model = { system = bicycle, params = p, state = state, linearize = linearize, matrices = matrices, sweep = sweep,
  front_contact_height = front_contact_height,
  front_contact_velocity = front_contact_velocity, rear_rolling = rear_rolling, frames = frames, omegas = omegas, bodies = bodies,
  index = { x = X, y = Y, yaw = YAW, lean = LEAN, pitch = PITCH, rear = REAR, steer = STEER, front = FRONT } }
if ... == "module" then return model end

-- ------------------------------------------------------------------ --
print(bicycle)
local _, why = bicycle:rule()
print(why)

-- What recording, differentiation and a constrained acceleration cost:
-- `make bench` (bench/bicycle.lua).

-- The paper's matrices for the benchmark (its section 5, 14 digits), beside
-- those of the nonlinear model linearized at upright straight running.
local published = {
  M = { { 80.81722, 2.31941332208709 }, { 2.31941332208709, 0.29784188199686 } },
  C1 = { { 0, 33.86641391492494 }, { -0.85035641456978, 1.68540397397560 } },
  K0 = { { -80.95, -2.59951685249872 }, { -2.59951685249872, -0.80329488458618 } },
  K2 = { { 0, 76.59734589573222 }, { 0, 2.65431523794604 } },
}
print()
print(linearize(5))
print("\nM q'' + v C1 q' + (g K0 + v^2 K2) q = 0 in q = (lean, steer): nzlua's linearization and the paper's")
local mine = {}
mine.M, mine.C1, mine.K0, mine.K2 = matrices()
for _, name in ipairs{ "M", "C1", "K0", "K2" } do
  local worst = 0
  for i = 1, 2 do
    for j = 1, 2 do worst = math.max(worst, math.abs(mine[name][i][j] - published[name][i][j])) end
    print(("%-3s %20.14f %20.14f    paper %20.14f %20.14f"):format(i == 1 and name or "", mine[name][i][1], mine[name][i][2],
      published[name][i][1], published[name][i][2]))
  end
  print(("    largest difference %.1e"):format(worst))
end

-- The paper's Table 2 from v = 0 to 10 m/s, and the speeds where upright
-- running becomes stable (weave) and unstable again (capsize).
local values = {}
for i = 0, 100 do values[#values + 1] = i / 10 end
local sw = sweep(values, 1e-12)
print()
print(("%6s  %s"):format("v m/s", "eigenvalues of lean and steer (1/s)"))
for _, row in ipairs(sw.rows) do
  if row.value == math.floor(row.value) then
    local out = {}
    for _, z in ipairs(row.eigenvalues) do
      if z[2] == 0 then out[#out + 1] = ("%.14f"):format(z[1])
      elseif z[2] > 0 then out[#out + 1] = ("%.14f +- %.14fi"):format(z[1], z[2]) end
    end
    print(("%6.2f  %s  %s"):format(row.value, table.concat(out, "  "), row.status))
  end
end
for _, c in ipairs(sw.crossings) do
  print(("%s speed %.14f m/s: %s -> %s"):format(c.to == "stable" and "weave" or "capsize", c.value, c.from, c.to))
end
print("(the paper, Table 2: weave speed 4.29238253634111, capsize speed 6.02426201538837 m/s)")
local drawn, why = pcall(sw.plot, sw, { width = 100, height = 28 })   -- in the terminal (gnuplot)
if not drawn then print(why) end

-- A ride of 5 s at 5 m/s (inside the self-stable range) after a push to the
-- side: the bicycle weaves (lean and steer oscillate at ~4.5 rad/s) and the
-- lean dies out, as the eigenvalues say (weave -0.78 +- 4.46i, capsize -0.32).
local q0, qd0 = state(0, 0, 0.5, 0, -5 / p.rR)
tr = bicycle:simulate{ q0 = q0, qd0 = qd0, t1 = 5, dt = 0.05, rtol = 1e-10, atol = 1e-12, monitors = { energy = true } }
print()
print(tr)
print("\n  t (s)   lean (rad)   steer (rad)")
for i = 1, #tr.t, 10 do
  print(("%7.2f  %11.6f  %12.6f"):format(tr.t[i], tr.q[i][LEAN], tr.q[i][STEER]))
end
local lo, hi = math.huge, -math.huge
for _, e in ipairs(tr.energy) do lo, hi = math.min(lo, e), math.max(hi, e) end
print(("energy T + V: drift %.1e J over 5 s (of %.3f J)"):format(hi - lo, tr.energy[1]))
bike = model   -- kept for the session: nzlua -i examples/bicycle.lua
