-- rolling_disk.lua - a vertical disk rolling without slipping (two linear
-- nonholonomic constraints): its contact point runs on a circle of radius
-- R ph' / th'.  The disk is a body: its centre at height R, turned by the
-- heading th about z and by the rolling angle ph about its own axis (body
-- z), so that T = m (x'^2 + y'^2)/2 + Id th'^2/2 + Ia ph'^2/2 comes from its
-- rotation and inertia {Id, Id, Ia}; tr:animate{ view = "3d" } shows it.
local m, R, Id, Ia = 1.2, 0.3, 0.05, 0.08
local rot = nz.rotations
disk = nz.scene{ name = "vertical rolling disk", coords = { "x", "y", "th", "ph" },
  bodies = { { name = "disk", mass = m, inertia = { Id, Id, Ia },
    pos = function(t, q) return { q[1], q[2], R } end,
    -- the axis (body z) horizontal, across the heading: (-sin th, cos th, 0)
    rot = function(t, q) return rot.mul(rot.mul(rot.z(q[3]), rot.x(-math.pi / 2)), rot.z(q[4])) end } },
  effects = { nz.effects.rolling_disk{ x = "x", y = "y", heading = "th", angle = "ph", radius = R } } }
local w, phd = 0.7, 3.0
tr = disk:report{ q = { 0, 0, 0, 0 }, qd = { R * phd, 0, w, phd }, simulate = { t1 = 10, dt = 0.05 },
  plot = { x = "x", y = { "y" } } }
-- centre of the circle: (0, R ph'/th') from this start
local rho, worst = R * phd / w, 0
for i = 1, #tr.t do worst = math.max(worst, math.abs(math.sqrt(tr.q[i][1] ^ 2 + (tr.q[i][2] - rho) ^ 2) - rho)) end
print(("path radius %.12f (R ph'/th' = %.12f), largest deviation %.1e"):format(rho, R * phd / w, worst))
