-- constant_speed.lua - a particle held at constant speed in the field of a
-- spring: a first-order constraint nonlinear in the velocities, so the rule
-- asks for Tsenov's equations (n = 2).
local m, k, v = 0.7, 3.0, 1.5
particle = nz.scene{ name = "particle at constant speed", coords = { "x", "y" },
  T = function(t, q, qd) return 0.5 * m * (qd[1] ^ 2 + qd[2] ^ 2) end,
  effects = { nz.effects.spring{ coordinate = "x", k = k }, nz.effects.spring{ coordinate = "y", k = k },
    nz.effects.constant_speed{ coords = { "x", "y" }, speed = v } } }
tr = particle:report{ q = { 1, 0 }, qd = { 0, v }, simulate = { t1 = 10, rtol = 1e-12, atol = 1e-12 }, plot = { x = "x", y = { "y" } } }
local worst = 0
for i = 1, #tr.t do worst = math.max(worst, math.abs(math.sqrt(tr.qd[i][1] ^ 2 + tr.qd[i][2] ^ 2) - v)) end
print(("speed held at %.3f: largest deviation %.1e"):format(v, worst))
