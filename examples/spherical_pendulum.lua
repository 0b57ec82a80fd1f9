-- spherical_pendulum.lua - two coordinates, two first integrals: the energy
-- and the momentum about the vertical, m l^2 sin^2(theta) phi'.
local g, l, m = 9.81, 1.0, 1.0
sph = nz.scene{ name = "spherical pendulum", coords = { "theta", "phi" },
  bodies = { { name = "bob", mass = m, pos = function(t, q)
    return { l * sin(q[1]) * cos(q[2]), l * sin(q[1]) * sin(q[2]), -l * cos(q[1]) } end } },
  effects = { nz.effects.gravity{ g = { 0, 0, -g } } } }
tr = sph:report{ q = { 1.0, 0 }, qd = { 0, 2.0 }, simulate = { t1 = 10, monitors = { energy = true } },
  plot = { y = { "theta" } } }
local lo, hi = math.huge, -math.huge
for i = 1, #tr.t do
  local Lz = m * l * l * math.sin(tr.q[i][1]) ^ 2 * tr.qd[i][2]
  lo, hi = math.min(lo, Lz), math.max(hi, Lz)
end
print(("momentum about the vertical: drift %.1e"):format(hi - lo))
