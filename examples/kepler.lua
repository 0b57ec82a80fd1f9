-- kepler.lua - Kepler's problem in polar coordinates (e = 0.6): the period
-- between periapsis passages (events) against 2 pi sqrt(a^3 / mu).
local mu, e, a = 1.0, 0.6, 1.0
kepler = nz.system{ name = "Kepler", coords = { "r", "phi" },
  T = function(t, q, qd) return 0.5 * (qd[1] ^ 2 + q[1] ^ 2 * qd[2] ^ 2) end,
  V = function(t, q) return -mu / q[1] end }
local rp = a * (1 - e)
tr = kepler:report{ q = { rp, 0 }, qd = { 0, math.sqrt(mu * (1 + e) / rp) / rp }, plot = { y = { "r" } },
  simulate = { t1 = 20, dt = 0.05, monitors = { energy = true },
    events = { { name = "periapsis", f = function(t, q, qd) return qd[1] end, direction = 1 } } } }
local ev = tr.events
print(("period: simulated %.12f, 2 pi sqrt(a^3/mu) %.12f"):format((ev[#ev].t - ev[1].t) / (#ev - 1), 2 * math.pi * math.sqrt(a ^ 3 / mu)))
