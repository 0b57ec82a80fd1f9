-- bead_hoop.lua - a bead on a hoop turned by a motor at the constant rate W
-- (docs/theory.md §9).  As one coordinate with a rheonomic T: Jacobi's integral
-- T2 - T0 + V is conserved, T + V is not.  With the motor as a driven
-- coordinate (a moving constraint): T + V minus the work of the motor is.
local g, R, m, W = 9.81, 0.5, 0.3, 6.0
bead = nz.system{ name = "bead on a turning hoop", coords = { "th" },
  T = function(t, q, qd) return 0.5 * m * R * R * (qd[1] ^ 2 + W * W * sin(q[1]) ^ 2) end,
  V = function(t, q) return -m * g * R * cos(q[1]) end }
tr = bead:report{ q = { 0.4 }, qd = { 0 }, simulate = { t1 = 5, monitors = { energy = true } } }
local function span(v) local lo, hi = math.huge, -math.huge; for _, x in ipairs(v) do lo, hi = math.min(lo, x), math.max(hi, x) end; return hi - lo end
print(("Jacobi's integral H = T2 - T0 + V: drift %.1e; T + V: changes by %.3f"):format(span(tr.generalized_energy), span(tr.energy)))

driven = nz.scene{ name = "bead on a hoop with its motor", coords = { "th", "ph" },
  bodies = { { name = "bead", mass = m, pos = function(t, q)
    return { R * sin(q[1]) * cos(q[2]), R * sin(q[1]) * sin(q[2]), -R * cos(q[1]) } end } },
  effects = { nz.effects.gravity{ g = { 0, 0, -g } }, nz.effects.driven{ coordinate = "ph", motion = function(t) return W * t end } } }
local td = driven:simulate{ q0 = { 0.4, 0 }, qd0 = { 0, W }, t1 = 5, monitors = { work = true } }
print(td)
local c = {}
for i = 1, #td.t do c[i] = td.energy[i] - td.work[i] end
print(("work of the motor: %.6f; T + V - work: drift %.1e"):format(td.work[#td.work], span(c)))
