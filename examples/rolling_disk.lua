-- rolling_disk.lua - a vertical disk rolling without slipping (two linear
-- nonholonomic constraints): its contact point runs on a circle of radius
-- R ph' / th'.
local m, R, Id, Ia = 1.2, 0.3, 0.05, 0.08
disk = nz.scene{ name = "vertical rolling disk", coords = { "x", "y", "th", "ph" },
  T = function(t, q, qd) return 0.5 * m * (qd[1] ^ 2 + qd[2] ^ 2) + 0.5 * Id * qd[3] ^ 2 + 0.5 * Ia * qd[4] ^ 2 end,
  effects = { nz.effects.rolling_disk{ x = "x", y = "y", heading = "th", angle = "ph", radius = R } } }
local w, phd = 0.7, 3.0
tr = disk:report{ q = { 0, 0, 0, 0 }, qd = { R * phd, 0, w, phd }, simulate = { t1 = 10, dt = 0.05 },
  plot = { x = "x", y = { "y" } } }
-- centre of the circle: (0, R ph'/th') from this start
local rho, worst = R * phd / w, 0
for i = 1, #tr.t do worst = math.max(worst, math.abs(math.sqrt(tr.q[i][1] ^ 2 + (tr.q[i][2] - rho) ^ 2) - rho)) end
print(("path radius %.12f (R ph'/th' = %.12f), largest deviation %.1e"):format(rho, R * phd / w, worst))
