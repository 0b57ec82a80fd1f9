-- heavy_top.lua - a heavy symmetric top as a rigid body (Euler angles z-x-z):
-- T from its rotation matrix and inertia tensor, velocities from the jets.
local m, lc, A, C, g = 1.5, 0.4, 0.3, 0.2, 9.81
local function rot(t, q) return nz.rotations.euler_zxz(q[1], q[2], q[3]) end   -- body to space, z-x-z
top = nz.scene{ name = "heavy symmetric top", coords = { "psi", "theta", "phi" },
  bodies = { { name = "top", mass = m, inertia = { A - m * lc * lc, A - m * lc * lc, C }, rot = rot,
    pos = function(t, q) local R = rot(t, q); return { lc * R[1][3], lc * R[2][3], lc * R[3][3] } end } },
  effects = { nz.effects.gravity{ g = { 0, 0, -g } } } }
tr = top:report{ q = { 0, 0.5, 0 }, qd = { 0, 0, 40 }, simulate = { t1 = 1, dt = 0.01, monitors = { energy = true } },
  plot = { y = { "theta" } } }
local lo, hi = math.huge, -math.huge
for i = 1, #tr.t do local w3 = tr.qd[i][3] + tr.qd[i][1] * math.cos(tr.q[i][2]); lo, hi = math.min(lo, w3), math.max(hi, w3) end
print(("spin about the axis w3 = phi' + psi' cos theta: drift %.1e"):format(hi - lo))
