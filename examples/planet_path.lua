-- planet_path.lua - a lecturer's question: "what path does the planet follow,
-- without asking when?"  Jacobi's principle of least action answers it: with
-- the energy H = h conserved, the path is the motion of a reduced system in
-- which the angle phi plays the part of time (the Jacobi-Whittaker
-- reduction, Rumyantsev eq. 2.8-2.12; docs/theory.md §9).  Time comes back
-- afterwards, integrated along the path: dt/dphi = sqrt(G / (h + L0)).
--
-- Kepler's problem with mu = 1, a = 1, e = 0.6, in polar coordinates.
local mu, a, e = 1.0, 1.0, 0.6
kepler = nz.system{ name = "Kepler", coords = { "r", "phi" },
  T = function(t, q, qd) return 0.5 * (qd[1] ^ 2 + q[1] ^ 2 * qd[2] ^ 2) end,
  V = function(t, q) return -mu / q[1] end }

-- Is there an energy integral?  (It is what the reduction needs.)
print(kepler:energy_integral())

-- The energy of the orbit: at periapsis r = a (1 - e), v = sqrt(mu (1 + e) / r).
local rp = a * (1 - e)
local h = 0.5 * mu * (1 + e) / rp - mu / rp
path = kepler:jacobi_whittaker{ h = h, independent = "phi" }
print()
print(path)

-- The path r(phi), from periapsis (dr/dphi = 0) once around.
tr = path:simulate{ q0 = { rp }, qd0 = { 0 }, t0 = 0, t1 = 2 * math.pi, dt = 2 * math.pi / 400, rtol = 1e-13, atol = 1e-13 }
local p, worst = a * (1 - e * e), 0
for i = 1, #tr.t do worst = math.max(worst, math.abs(tr.q[i][1] - p / (1 + e * math.cos(tr.t[i])))) end
print(("\nthe path against the conic r = p / (1 + e cos phi), p = a (1 - e^2): largest difference %.1e"):format(worst))

-- When?  The time along the path (path:elapsed integrates it with the path).
local t = path:elapsed(tr)
local period = 2 * math.pi * math.sqrt(a ^ 3 / mu)
print(("period: integrated along the path %.15f, Kepler's third law 2 pi sqrt(a^3/mu) %.15f"):format(t[#t], period))
local i = 101                                  -- phi = pi / 2
local E = 2 * math.atan(math.sqrt((1 - e) / (1 + e)) * math.tan(tr.t[i] / 2))
print(("time to phi = pi/2: %.15f, Kepler's equation E - e sin E: %.15f"):format(t[i], math.sqrt(a ^ 3 / mu) * (E - e * math.sin(E))))

-- The orbit in the plane (terminal plot).
local xs, ys = {}, {}
for n = 1, #tr.t do xs[n], ys[n] = tr.q[n][1] * math.cos(tr.t[n]), tr.q[n][1] * math.sin(tr.t[n]) end
local drawn, why = pcall(require("nz.draw.plot").lines, { series = { { name = "the path", x = xs, y = ys } },
  title = "the planet's path, found without time", xlabel = "x", ylabel = "y", width = 80, height = 24 })
if not drawn then print(why) end
