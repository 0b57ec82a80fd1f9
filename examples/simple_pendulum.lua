-- simple_pendulum.lua - a pendulum at large amplitude as a scene (a body and
-- gravity); its period from the simulated motion against the complete
-- elliptic integral: P = 4 K(sin(th0/2)) sqrt(l/g).
local g, l, th0 = 9.81, 1.0, 2.0
pend = nz.scene{ name = "simple pendulum", coords = { "th" },
  bodies = { { name = "bob", mass = 1.0, pos = function(t, q) return { l * sin(q[1]), 0, -l * cos(q[1]) } end } },
  effects = { nz.effects.gravity{ g = { 0, 0, -g } } } }
tr = pend:report{ q = { th0 }, plot = { phase = "th" },
  simulate = { t1 = 10, dt = 0.02, events = { { name = "up", f = function(t, q) return q[1] end, direction = 1 } } } }
local ev = tr.events
print(("period: simulated %.12f, elliptic integral %.12f"):format((ev[#ev].t - ev[1].t) / (#ev - 1),
  4 * nz.special.ellint_K(math.sin(th0 / 2)) * math.sqrt(l / g)))
