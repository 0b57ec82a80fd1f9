-- henon_chaos.lua - the fraction of chaotic orbits of the Henon-Heiles
-- potential against the energy, from a grid of initial conditions on the
-- surface of section x = 0 run by nz.sweep on every core.
--
--   build/nzlua examples/henon_chaos.lua [n [T [out.csv]]]
--
-- Each point (E, y, py) starts at x = 0 with px > 0 from the energy, and
-- runs together with a neighbour 1e-9 away in y: the system has the two
-- copies as its four coordinates, so one simulate integrates both.  The
-- indicator is the finite-time growth of their distance, log10(d(T)/d(0)):
-- on a torus it grows about linearly in t (0 to 3 decades by T = 500), on a
-- chaotic orbit exponentially until it saturates at the size of the orbit
-- (8 to 9 decades); few orbits fall between, and an orbit counts as chaotic
-- when the distance grew by more than GROWTH = 5 decades.  Henon and Heiles
-- (1964): almost all regular at E = 1/12, about half chaotic at E = 1/8,
-- almost all chaotic near the escape energy 1/6 (the count here follows the
-- grid's points, not the area of the section, so it is close, not equal).
local nz = rawget(_G, "nz") or require "nz"

local n = tonumber(arg and arg[1]) or 16       -- n x n grid in (y, py) per energy
local T = tonumber(arg and arg[2]) or 500      -- time of the finite-time indicator
local out = arg and arg[3]                      -- results file (optional: resumes)
local D0, GROWTH = 1e-9, 5                      -- initial distance; decades that mean chaos
local energies = { 1 / 12, 1 / 10, 1 / 8, 1 / 7, 1 / 6.5 }

local function V(x, y) return (x^2 + y^2) / 2 + x^2 * y - y^3 / 3 end
sys = nz.system{
  name = "Henon-Heiles, twice", coords = { "x", "y", "x2", "y2" },
  T = function(t, q, qd) return (qd[1]^2 + qd[2]^2 + qd[3]^2 + qd[4]^2) / 2 end,
  V = function(t, q) return V(q[1], q[2]) + V(q[3], q[4]) end,
}

-- One point: nothing to compute where px^2 < 0 (outside the energy surface).
local function run(s, p)
  local px2 = 2 * p.E - p.py^2 - 2 * V(0, p.y)
  local px2b = 2 * p.E - p.py^2 - 2 * V(0, p.y + D0)
  if px2 <= 0 or px2b <= 0 then return { inside = false } end
  local tr = s:simulate{ q0 = { 0, p.y, 0, p.y + D0 }, qd0 = { math.sqrt(px2), p.py, math.sqrt(px2b), p.py },
    t1 = T, dt = T, rtol = 1e-11, atol = 1e-13 }
  local q, qd = tr.q[#tr.q], tr.qd[#tr.qd]
  local d = math.sqrt((q[1] - q[3])^2 + (q[2] - q[4])^2 + (qd[1] - qd[3])^2 + (qd[2] - qd[4])^2)
  local growth = math.log(d / D0, 10)
  return { inside = true, growth = growth, chaotic = growth > GROWTH }
end

local function linspace(a, b, m)
  local v = {}
  for i = 1, m do v[i] = a + (b - a) * (i - 1) / (m - 1) end
  return v
end

local t0 = os.time()
local rows = nz.sweep{ system = sys, run = run, out = out,
  grid = { E = energies, y = linspace(-0.42, 0.72, n), py = linspace(-0.56, 0.56, n) } }
if rows.status ~= "complete" then return end

-- Tally per energy.
local stats = {}
for _, E in ipairs(energies) do stats[E] = { inside = 0, chaotic = 0, failed = 0 } end
for _, r in ipairs(rows) do
  local s = stats[r.E]
  if r.error then s.failed = s.failed + 1
  elseif r.inside then
    s.inside = s.inside + 1
    if r.chaotic then s.chaotic = s.chaotic + 1 end
  end
end
print(("Henon-Heiles: %d x %d grid in (y, py) on x = 0 per energy, indicator log10 d(T)/d(0) at T = %g, chaotic when > %g"):format(
  n, n, T, GROWTH))
local tab = { { "E", "orbits", "chaotic", "fraction", "failed" } }
local x, y = {}, {}
for _, E in ipairs(energies) do
  local s = stats[E]
  local f = s.inside > 0 and s.chaotic / s.inside or 0 / 0
  tab[#tab + 1] = { ("%.5f"):format(E), tostring(s.inside), tostring(s.chaotic), ("%.2f"):format(f), tostring(s.failed) }
  x[#x + 1], y[#y + 1] = E, f
end
print(require("nz.system").table_text(tab))
print(("%d points (%d computed, %d resumed) in about %d s"):format(#rows, rows.computed, rows.resumed, os.time() - t0))
local ok, err = pcall(require("nz.draw.plot").lines, { series = { { name = "chaotic fraction", x = x, y = y, points = true } },
  xlabel = "energy E", ylabel = "fraction of chaotic orbits", title = "Henon-Heiles: chaos against energy",
  width = 72, height = 20 })
if not ok then print(err) end
