-- longrun.lua - long runs at machine precision: Kepler (e = 0.5, a = 1)
-- over 1e6 orbits with Taylor's method at rtol = atol = 1e-15, the energy's
-- relative error against the orbits and its growth exponent (Brouwer's
-- law: a random walk of roundings, orbits^0.5; the target: at most 5e-13
-- at 1e5 orbits and 2e-12 at 1e6, growing no faster than orbits^0.6 from
-- 10 orbits on), beside rk8pd at 1e-13 over 1e5 orbits (a drift) and the
-- variational integrators at P/400 over 1e4 orbits (bounded), and
-- Henon-Heiles' energy with Taylor over t = 1e6.
--
-- The error at N orbits is the largest |E - E0| / |E0| of the samples up
-- to N; the exponent the slope of the RMS over windows of a factor
-- sqrt(10) in orbits (nz.longrun's fit: nz/analysis/longrun.lua), from 10
-- orbits on.  Each long run is sampled twice: its first 1e4 orbits 8 times
-- an orbit (a run of its own: Taylor's steps do not depend on the output
-- grid, read off each step's polynomial), the rest every 10 orbits.  Time:
-- processor time of one run (os.clock), the machine code compiled before.
--   build/nzlua bench/longrun.lua
local root = (arg and arg[0] or ""):match("^(.-)bench/[^/]*$") or ""
package.path = root .. "?.lua;" .. package.path
local nz = rawget(_G, "nz") or require "nz"
local growth = require("nz.analysis.longrun").growth
-- these runs are long on purpose: no long-run notice
local long_run = require("nz.motion.simulate").LONG_RUN
long_run.steps, long_run.seconds = math.huge, math.huge

local e = 0.5
local rp, vp = 1 - e, math.sqrt((1 + e) / (1 - e))
local P = 2 * math.pi
local kepler = nz.system{ name = "Kepler e=0.5", coords = { "x", "y" }, native = true,
  T = function(t, q, qd) return (qd[1] ^ 2 + qd[2] ^ 2) / 2 end,
  V = function(t, q) return -1 / nz.sqrt(q[1] ^ 2 + q[2] ^ 2) end }
local E0 = vp ^ 2 / 2 - 1 / rp
local function kepler_error(q, v) return math.abs((v[1] ^ 2 + v[2] ^ 2) / 2 - 1 / math.sqrt(q[1] ^ 2 + q[2] ^ 2) - E0) / math.abs(E0) end

-- One run of N periods sampled every `every` periods: x (periods), e, the
-- processor seconds and the run's statistics.
local function run(sys, opts, N, every, err)
  local o = { t1 = N * P, dt = every * P, progress = false }
  for k, v in pairs(opts) do o[k] = v end
  local c0 = os.clock()
  local tr = sys:simulate(o)
  local seconds = os.clock() - c0
  local x, es = {}, {}
  for i = 2, #tr.t do x[i - 1], es[i - 1] = (tr.t[i] - tr.t[1]) / P, err(tr.q[i], tr.qd[i]) end
  return x, es, seconds, tr.stats
end

-- The samples of both runs joined: the fine one up to its end, the coarse
-- one after it.
local function joined(xf, ef, xc, ec)
  local x, es, last = {}, {}, xf[#xf]
  for i = 1, #xf do x[i], es[i] = xf[i], ef[i] end
  for i = 1, #xc do if xc[i] > last then x[#x + 1], es[#es + 1] = xc[i], ec[i] end end
  return x, es
end

local function worst_up_to(x, es, n)
  local w = 0
  for i = 1, #x do if x[i] <= n * (1 + 1e-12) then w = math.max(w, es[i]) end end
  return w
end

local function row(name, x, es, seconds, stats, N, marks)
  local slope = growth(x, es, 10)
  local cells = { ("%-34s"):format(name) }
  for _, n in ipairs(marks) do cells[#cells + 1] = n <= N and ("%10.2e"):format(worst_up_to(x, es, n)) or ("%10s"):format("-") end
  cells[#cells + 1] = ("%9s"):format(slope and ("^%.2f"):format(slope) or "-")
  cells[#cells + 1] = ("%10.1f us"):format(1e6 * seconds / N)
  cells[#cells + 1] = ("%7.1f"):format(stats.steps / N)
  cells[#cells + 1] = ("%8.0f ns"):format(1e9 * seconds / stats.steps)
  print(table.concat(cells, " "))
end

local marks = { 1e4, 1e5, 1e6 }
local start = { q0 = { rp, 0 }, qd0 = { 0, vp } }
local function with(o) for k, v in pairs(start) do o[k] = v end return o end
-- compile (or load) the machine code before timing
kepler:simulate(with{ method = "taylor", rtol = 1e-15, atol = 1e-15, t1 = 10 * P, progress = false })
kepler:simulate(with{ method = "rk8pd", rtol = 1e-13, atol = 1e-13, t1 = 10 * P, progress = false })

print("Kepler e = 0.5: relative energy error, the largest up to N orbits, its growth (orbits^x, fit from 10 orbits),")
print("processor time per orbit, steps per orbit and time per step")
print("target (Brouwer's law, taylor at 1e-15): <= 5e-13 at 1e5 orbits, <= 2e-12 at 1e6, growth <= orbits^0.6")
print(("%-34s %10s %10s %10s %9s %13s %7s %11s"):format("method", "1e4 orbits", "1e5", "1e6", "growth", "time/orbit",
  "steps", "time/step"))
-- the adaptive methods: their first 1e4 orbits finely, then to N orbits
for _, m in ipairs{ { "taylor rtol = atol = 1e-15", "taylor", 1e-15, 1e6 }, { "rk8pd rtol = atol = 1e-13", "rk8pd", 1e-13, 1e5 } } do
  local o = with{ method = m[2], rtol = m[3], atol = m[3] }
  local xf, ef = run(kepler, o, 1e4, 1 / 8, kepler_error)
  local xc, ec, seconds, stats = run(kepler, o, m[4], 10, kepler_error)
  local x, es = joined(xf, ef, xc, ec)
  row(m[1], x, es, seconds, stats, m[4], marks)
end
for _, p in ipairs{ 2, 4 } do
  local x, es, seconds, stats = run(kepler, with{ method = "variational", order = p, step = P / 400 }, 1e4, 1 / 8,
    kepler_error)
  row(("variational order %d, step P/400"):format(p), x, es, seconds, stats, 1e4, marks)
end
print("(rk8pd: fewer steps at a looser dense output would not change its drift; the variational integrators'")
print(" error is the O(h^p) oscillation of the energy, bounded: growth ~ ^0.00)")

-- Henon-Heiles (E = 0.1297, bounded), Taylor at 1e-15 over t = 1e6.
local hh = nz.system{ name = "Henon-Heiles", coords = { "x", "y" }, native = true,
  T = function(t, q, qd) return (qd[1] ^ 2 + qd[2] ^ 2) / 2 end,
  V = function(t, q) local x, y = q[1], q[2]; return (x ^ 2 + y ^ 2) / 2 + x ^ 2 * y - y ^ 3 / 3 end }
local function H(q, v) local x, y = q[1], q[2]; return (v[1] ^ 2 + v[2] ^ 2) / 2 + (x ^ 2 + y ^ 2) / 2 + x ^ 2 * y - y ^ 3 / 3 end
local hq0, hqd0 = { 0, 0.1 }, { 0.5, 0 }
local HE0 = H(hq0, hqd0)
local function hh_error(q, v) return math.abs(H(q, v) - HE0) / HE0 end
do
  local o = { method = "taylor", rtol = 1e-15, atol = 1e-15, q0 = hq0, qd0 = hqd0 }
  hh:simulate{ method = "taylor", rtol = 1e-15, atol = 1e-15, q0 = hq0, qd0 = hqd0, t1 = 10, progress = false }
  -- time units, not orbits: P = 1 for the columns (every = 1/P of a unit)
  local saved = P
  P = 1
  local xf, ef = run(hh, o, 1e4, 1, hh_error)
  local xc, ec, seconds, stats = run(hh, o, 1e6, 10, hh_error)
  P = saved
  local x, es = joined(xf, ef, xc, ec)
  print()
  print(("%-34s %10s %10s %10s %9s %13s %7s %11s"):format("Henon-Heiles, t = 0 .. 1e6", "t = 1e4", "1e5", "1e6",
    "growth", "time/unit", "steps", "time/step"))
  row("taylor rtol = atol = 1e-15", x, es, seconds, stats, 1e6, marks)
end
print("notes: processor time of one run each (os.clock), machine code compiled before; the error at N is the largest")
print("  of the samples up to N (8 an orbit up to 1e4 orbits, one every 10 after)")
