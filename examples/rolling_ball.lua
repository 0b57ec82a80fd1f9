-- rolling_ball.lua - a homogeneous ball rolling without slipping on a plane,
-- pushed by a constant horizontal force F at its centre: it accelerates at
-- 5 F / (7 m), not F / m (part of the work goes into rotation).
local m, R, F = 1.0, 0.3, 0.7
local function rot(t, q)
  local Rz1 = { { cos(q[3]), -sin(q[3]), 0 }, { sin(q[3]), cos(q[3]), 0 }, { 0, 0, 1 } }
  local Rx = { { 1, 0, 0 }, { 0, cos(q[4]), -sin(q[4]) }, { 0, sin(q[4]), cos(q[4]) } }
  local Rz2 = { { cos(q[5]), -sin(q[5]), 0 }, { sin(q[5]), cos(q[5]), 0 }, { 0, 0, 1 } }
  local function mul(X, Y)
    local Z = {}
    for i = 1, 3 do Z[i] = {}; for j = 1, 3 do Z[i][j] = X[i][1] * Y[1][j] + X[i][2] * Y[2][j] + X[i][3] * Y[3][j] end end
    return Z
  end
  return mul(mul(Rz1, Rx), Rz2)
end
local I = 0.4 * m * R * R
local ball = nz.scene{ name = "rolling ball", coords = { "x", "y", "psi", "theta", "phi" },
  bodies = { { name = "ball", mass = m, inertia = { I, I, I }, rot = rot, pos = function(t, q) return { q[1], q[2], R } end } },
  effects = { nz.effects.rolling_ball{ body = "ball", radius = R },
    nz.effects.force{ at = "ball", F = function() return { F, 0, 0 } end } } }
local tr = ball:report{ q = { 0, 0, 0.1, 1.2, 0.3 }, qd = { 0, 0, 0, 0, 0 }, simulate = { t1 = 1.5, dt = 0.05 }, plot = { y = { "x" } } }
print(("acceleration of the centre: %.12f (5 F / 7 m = %.12f)"):format(tr.qdd[#tr.qdd][1], 5 * F / (7 * m)))
