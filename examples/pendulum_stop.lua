-- pendulum_stop.lua - a pendulum released at th0 hits a rigid stop (a wall
-- at the vertical, nz.unilateral: the bob's distance l sin th from it >= 0).
-- Elastic (e = 1) it conserves its energy through every impact, which come
-- at odd quarter periods K(sin(th0/2)) sqrt(l/g); with e < 1 each impact
-- keeps e^2 of the energy, so the amplitudes follow 1 - cos th_k+1 =
-- e^2 (1 - cos th_k).  The amplitudes are located by an event of the user's
-- (th' = 0) beside the contact's events.
local g, l, th0 = 9.81, 0.8, 1.1
local function pendulum(e)
  return nz.system{ name = ("pendulum and stop, e = %g"):format(e), coords = { "th" },
    T = function(t, q, qd) return 0.5 * l ^ 2 * qd[1] ^ 2 end,
    V = function(t, q) return -g * l * nz.cos(q[1]) end,
    constraints = { nz.unilateral(function(t, q) return l * nz.sin(q[1]) end, { e = e, name = "stop" }) } }
end
local quarter = nz.special.ellint_K(math.sin(th0 / 2)) * math.sqrt(l / g)
stop = pendulum(1)
tr = stop:simulate{ q0 = { th0 }, t1 = 100 * quarter, dt = 0.02, monitors = { energy = true } }
print(tr)
local n, worst = 0, 0
for _, ev in ipairs(tr.events) do
  if ev.kind == "impact" then
    n = n + 1
    worst = math.max(worst, math.abs(ev.t - (2 * n - 1) * quarter))
  end
end
print(("e = 1: %d impacts, each at an odd quarter period within %.3g s; T + V drifts by %.3g"):format(n, worst,
  (function() local d = 0; for i = 1, #tr.energy do d = math.max(d, math.abs(tr.energy[i] - tr.energy[1])) end; return d end)()))
local e = 0.6
damped = pendulum(e)
tr = damped:simulate{ q0 = { th0 }, t1 = 6, dt = 0.01,
  events = { { name = "apex", f = function(t, q, qd) return qd[1] end, direction = -1 } } }
print(tr)
print("  swing   amplitude (simulated)   closed form: 1 - cos th_k = e^2k (1 - cos th0)")
local c, k = 1 - math.cos(th0), 0
for _, ev in ipairs(tr.events) do
  if ev.name == "apex" then
    k, c = k + 1, c * e * e
    print(("  %5d   %.12f          %.12f"):format(k, ev.q[1], math.acos(1 - c)))
  end
end
tr:plot{ y = { "th" }, title = "a pendulum against a stop, e = 0.6" }
