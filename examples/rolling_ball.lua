-- rolling_ball.lua - a homogeneous ball rolling without slipping on a plane,
-- pushed by a constant horizontal force F at its centre: it accelerates at
-- 5 F / (7 m), not F / m (part of the work goes into rotation).
local m, R, F = 1.0, 0.3, 0.7
local function rot(t, q) return nz.rotations.euler_zxz(q[3], q[4], q[5]) end   -- body to space, z-x-z
local I = 0.4 * m * R * R
ball = nz.scene{ name = "rolling ball", coords = { "x", "y", "psi", "theta", "phi" },
  bodies = { { name = "ball", mass = m, inertia = { I, I, I }, rot = rot, pos = function(t, q) return { q[1], q[2], R } end } },
  effects = { nz.effects.rolling_ball{ body = "ball", radius = R },
    nz.effects.force{ at = "ball", F = function() return { F, 0, 0 } end } } }
tr = ball:report{ q = { 0, 0, 0.1, 1.2, 0.3 }, qd = { 0, 0, 0, 0, 0 }, simulate = { t1 = 1.5, dt = 0.05 }, plot = { y = { "x" } } }
print(("acceleration of the centre: %.12f (5 F / 7 m = %.12f)"):format(tr.qdd[#tr.qdd][1], 5 * F / (7 * m)))
