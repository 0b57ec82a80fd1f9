-- appell.lua - Appell's nonlinear constraint z'^2 = c^2 (x'^2 + y'^2) on a
-- heavy particle (docs/theory.md §6): first order, nonlinear: n = 2.
local m, c, g = 1.3, 0.6, 9.81
appell = nz.scene{ name = "Appell's particle", coords = { "x", "y", "z" },
  bodies = { { name = "p", mass = m, pos = function(t, q) return { q[1], q[2], q[3] } end } },
  effects = { nz.effects.gravity{ g = { 0, 0, -g } },
    nz.effects.constraint{ f = function(t, q, qd) return qd[3] ^ 2 - c * c * (qd[1] ^ 2 + qd[2] ^ 2) end } } }
tr = appell:report{ q = { 0, 0, 1 }, qd = { 1.0, 0.5, -c * math.sqrt(1.25) }, simulate = { t1 = 2 }, plot = { y = { "z" } } }
local worst = 0
for _, v in ipairs(tr.violation) do worst = math.max(worst, v) end
print(("constraint violation along the motion: max %.1e"):format(worst))
