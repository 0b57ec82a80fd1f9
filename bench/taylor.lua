-- taylor.lua - Henon-Heiles written as a user would, integrated over
-- t = 0..2000 by Taylor's method on its recorded graph (core.mech.taylor_run,
-- the series as machine code: native = true, src/graph/series_native.c) at tol = 1e-9, 1e-12, 1e-15, against GSL's
-- rk8pd with a hand-written C right-hand side (build/henon_c, which runs
-- 1e-12 and 1e-15) and against nzlua's own rk8pd (sys:simulate, its RHS as
-- machine code).  Issue 11's target: taylor 3x faster than rk8pd-in-C at
-- 1e-15, with an energy error no larger.
--   build/nzlua bench/taylor.lua
local root = (arg and arg[0] or ""):match("^(.-)bench/[^/]*$") or ""
package.path = root .. "?.lua;" .. package.path
local nz = rawget(_G, "nz") or require "nz"
local timing = require "bench.timing"
local mech = require("nz.core").mech

local sys = nz.system{
  name = "Henon-Heiles", coords = { "x", "y" }, native = true,
  T = function(t, q, qd) return (qd[1]^2 + qd[2]^2) / 2 end,
  V = function(t, q) local x, y = q[1], q[2]; return (x^2 + y^2) / 2 + x^2 * y - y^3 / 3 end,
}
local q0, qd0, T1 = { 0, 0.1 }, { 0.5, 0 }, 2000
local function H(q, qd) local x, y = q[1], q[2]; return (qd[1]^2 + qd[2]^2) / 2 + (x^2 + y^2) / 2 + x^2 * y - y^3 / 3 end
local E0 = H(q0, qd0)

local function taylor(tol, dt)
  return mech.taylor_run(sys.engine, { t1 = T1, dt = dt or T1, q0 = q0, qd0 = qd0, tol = tol })
end
local function rk8pd(tol)
  return sys:simulate{ q0 = q0, qd0 = qd0, t1 = T1, dt = T1, method = "rk8pd", rtol = tol, atol = tol }
end
local function end_error(q, qd) return math.abs(H(q, qd) - E0) / E0 end

-- The C program: "tol seconds steps rejected nfev x y xd yd" per tolerance.
local function c_rows()
  local rows = {}
  for line in timing.run(root .. "build/henon_c 5"):gmatch("[^\n]+") do
    local f = {}
    for x in line:gmatch("%S+") do f[#f + 1] = tonumber(x) end
    if #f == 9 and f[1] then rows[f[1]] = { seconds = f[2], steps = f[3], nfev = f[5], y = { f[6], f[7], f[8], f[9] } } end
  end
  return rows
end

print(("Henon-Heiles from Lua, t = 0..2000, E = %.4f: Taylor (series as machine code) against GSL rk8pd"):format(E0))
print("target (issue 11): taylor at least 3x faster than rk8pd with a C RHS at 1e-15, energy error no larger")
print(("%-6s %-13s %11s %8s %6s %8s %11s %11s %9s"):format("tol", "method", "time", "steps", "order", "nfev",
  "dE/E end", "dE/E max", "C/this"))
rk8pd(1e-12)          -- compiles the RHS's machine code (or loads it from the cache) before timing
taylor(1e-9)          -- and the series' machine code
for _, tol in ipairs{ 1e-9, 1e-12, 1e-15 } do
  local before = c_rows()
  local tr
  local t = timing.per_call(function() tr = taylor(tol) end, { sample = 0, budget = 3, samples = 5 })
  -- the energy along the way, on a grid of dt = 1 (dense output: the same steps)
  local dense = taylor(tol, 1)
  local worst = 0
  for i = 1, #dense.t do worst = math.max(worst, end_error(dense.q[i], dense.qd[i])) end
  local after = c_rows()
  local c = before[tol]
  local cs = c and (c.seconds + after[tol].seconds) / 2
  local n = #tr.t
  print(("%-6.0e %-13s %11s %8d %6d %8d %11.2e %11.2e %9s"):format(tol, "taylor", timing.fmt(t, 11), tr.stats.steps,
    tr.stats.order, tr.stats.nfev, end_error(tr.q[n], tr.qd[n]), worst, cs and ("%.2fx"):format(cs / t) or "-"))
  local rr
  local tz = timing.per_call(function() rr = rk8pd(tol) end, { sample = 0, budget = 3, samples = 5 })
  local m = #rr.t
  print(("%-6s %-13s %11s %8d %6s %8d %11.2e %11s %9s"):format("", "rk8pd nzlua", timing.fmt(tz, 11), rr.stats.steps,
    "8", rr.stats.nfev, end_error(rr.q[m], rr.qd[m]), "", cs and ("%.2fx"):format(cs / tz) or "-"))
  if c then
    print(("%-6s %-13s %11s %8d %6s %8d %11.2e %11s %9s"):format("", "rk8pd C", timing.fmt(cs, 11), c.steps, "8",
      c.nfev, end_error({ c.y[1], c.y[2] }, { c.y[3], c.y[4] }), "", "1.00x"))
  end
end

-- Dense output: a fine grid costs the Horner evaluations, not steps (the
-- run's time in C, stats.seconds: the Lua tables of the result apart).
local function c_time(dt)
  local ts = {}
  for i = 1, 5 do ts[i] = taylor(1e-15, dt).stats.seconds end
  return timing.median(ts)
end
local t_coarse, t_fine = c_time(T1), c_time(0.01)
print(("dense output at 1e-15, the run in C: dt = 2000 %s, dt = 0.01 (200001 points) %s: +%.1f %%, same steps")
  :format(timing.fmt(t_coarse, 0), timing.fmt(t_fine, 0), 100 * (t_fine / t_coarse - 1)))
-- The same through sys:simulate, the trajectory included (its points kept
-- in C: src/lua/lua_points.c; q'' solved at each point): processor time,
-- the least of 5 runs.
local function simulate_time(dt)
  local best = math.huge
  for _ = 1, 5 do
    collectgarbage()
    local c0 = os.clock()
    sys:simulate{ q0 = q0, qd0 = qd0, t1 = T1, dt = dt, method = "taylor", rtol = 1e-15, atol = 1e-15, progress = false }
    best = math.min(best, os.clock() - c0)
  end
  return best
end
local s_coarse, s_fine = simulate_time(T1), simulate_time(0.01)
print(("sys:simulate at 1e-15 (processor time): dt = 2000 %s, dt = 0.01 (200001 points) %s: %.1fx"):format(
  timing.fmt(s_coarse, 0), timing.fmt(s_fine, 0), s_fine / s_coarse))
-- Where the time goes: one series of the motion per step.
local tr = taylor(1e-15)
local p = tr.stats.order + 1
local ts = timing.per_call(function() mech.motion_series(sys.engine, 0, q0, qd0, p) end, { budget = 1 })
print(("per step at 1e-15: %s (%d steps); one series to order %d from Lua: %s (its Lua call and result"):format(
  timing.fmt(t_coarse / tr.stats.steps, 0), tr.stats.steps, p, timing.fmt(ts, 0)))
print(("  tables included); rk8pd in C: %s per step of 13 RHS calls"):format(
  timing.fmt(c_rows()[1e-15].seconds / c_rows()[1e-15].steps, 0)))
print("notes: wall-clock medians; C: the mean of two medians of 5 runs, just before and just after the taylor")
print("  row.  dE/E: relative energy error at t = 2000 (end) and over the grid t = 0, 1, ..., 2000 (max; taylor")
print("  only: rk8pd's output grid would change its steps).  Taylor: order and step from the tolerance (Jorba-Zou),")
print("  no rejected steps; the series of the plan of q'' run as machine code (compiled before timing).")
