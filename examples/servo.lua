-- servo.lua - a program (servo) constraint of second order, linear in the
-- accelerations: x'' + 2 y'' = sin t imposed on a particle under a constant
-- force: n = 2 (Tsenov); the multiplier is the servo's effort.
local m = 0.9
servo = nz.scene{ name = "servo constraint", coords = { "x", "y" },
  T = function(t, q, qd) return 0.5 * m * (qd[1] ^ 2 + qd[2] ^ 2) end,
  effects = { nz.effects.force{ f = function() return { 0.4, -1.1 } end },
    nz.effects.constraint{ f = function(t, q, qd, qdd) return qdd[1] + 2 * qdd[2] - sin(t) end } } }
tr = servo:report{ q = { 0, 0 }, qd = { 0, 0 }, simulate = { t1 = 6, rtol = 1e-12, atol = 1e-12 }, plot = { y = { "lambda1" } } }
local worst = 0
for i = 1, #tr.t do worst = math.max(worst, math.abs(tr.qdd[i][1] + 2 * tr.qdd[i][2] - math.sin(tr.t[i]))) end
print(("program x'' + 2 y'' = sin t along the motion: largest error %.1e"):format(worst))
