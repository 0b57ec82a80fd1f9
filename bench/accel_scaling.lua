-- accel_scaling.lua - sys:accel of the n-link pendulum of bench/mech.lua
-- (built with bodies) against the same accelerations written by hand in C
-- (build/pendulum_c, run here so that both are timed in the same run), for
-- k = 2, 4, 8, 16 (and 32 when it is expected to take under 20 s), with the
-- growth exponent of each between successive k.  Issue 10's target: within
-- 5x at k = 8 and k = 16.  Also checks that both compute the same
-- accelerations at k = 8 (to 1e-10 relative), so that they time one model.
--   build/nzlua bench/accel_scaling.lua
local root = (arg and arg[0] or ""):match("^(.-)bench/[^/]*$") or ""
package.path = root .. "?.lua;" .. package.path
local nz = rawget(_G, "nz") or require "nz"
local timing = require "bench.timing"

-- The n-link pendulum of bench/mech.lua (bench/chain.lua).
local chain_of = require "bench.chain"
local function chain(k, native) return chain_of(k, { native = native }) end

-- The state of bench/pendulum_c.c.
local function state(k)
  local q, qd = {}, {}
  for i = 1, k do q[i], qd[i] = 0.7 * math.sin(1.3 * i + 0.5), 0.9 * math.cos(0.7 * i + 0.2) end
  return q, qd
end

-- The C program's time per call for each k.  It runs again beside each
-- row (before and after nzlua's measurements, the mean of the two): on a
-- shared machine the speed drifts by 2x within a minute, and a ratio is
-- only fair between neighbours.
local c_out
local function c_times()
  c_out = timing.run(root .. "build/pendulum_c")
  local ns = {}
  for k, v in c_out:gmatch("\n%s*(%d+)%s+([%d.]+)") do ns[tonumber(k)] = tonumber(v) * 1e-9 end
  return ns
end
local c_ns = c_times()

-- The agreement at k = 8, at the C program's own state.
local q8, qd8, a8 = timing.vector(c_out, "q8"), timing.vector(c_out, "qd8"), timing.vector(c_out, "qdd8")
local sq8, sqd8 = state(8)
for i = 1, 8 do
  assert(q8[i] == sq8[i] and qd8[i] == sqd8[i], "bench/pendulum_c.c and this file must use the same state")
end
local a = chain(8):accel(0, q8, qd8)
local num, den = 0, 0
for i = 1, 8 do num, den = math.max(num, math.abs(a[i] - a8[i])), math.max(den, math.abs(a8[i])) end
local rel = num / den

print("sys:accel of the n-link pendulum from bodies (bench/mech.lua) against hand-written C (M, h by formula, Cholesky)")
print("target (issue 10): ratio nzlua/C within 5x at k = 8 and k = 16; growth = d log(time) / d log(k)")
print("interpreted: the graphs run by the C interpreter; native: compiled to machine code (native = true, cached)")
print("in simulate: the engine's cost per right-hand side inside a run (rk4, fixed step, no Lua per step)")
print(("%4s %12s %12s %12s %9s %9s %12s %9s %5s %8s %8s  %s"):format("k", "interpreted", "native", "C", "ratio i", "ratio n",
  "in simulate", "ratio s", "runs", "growth n", "growth C", "graph"))
local last
local ks = { 2, 4, 8, 16, 32 }
for _, k in ipairs(ks) do
  if k == 32 and last and last.t * 2 ^ 3 * 6 > 20 then
    print(("%4d  (skipped: about %.0f s per call expected)"):format(k, last.t * 8))
    break
  end
  local q, qd = state(k)
  local c_before = c_times()[k]
  local sysi, sysn = chain(k, false), chain(k, true)
  sysn:accel(0, q, qd)           -- compiles (or loads from the cache) before timing
  local ti, n = timing.per_call(function() sysi:accel(0, q, qd) end, { budget = 1.0 })
  local t = timing.per_call(function() sysn:accel(0, q, qd) end, { budget = 1.0 })
  local growth = last and math.log(t / last.t) / math.log(k / last.k)
  local g = timing.graph_line(sysi, ti, "accel") or ""
  local nfev = 0
  local ts = timing.per_call(function()
    local tr = sysn:simulate{ q0 = q, qd0 = qd, t1 = 2, step = 0.01, dt = 2, method = "rk4" }
    nfev = tr.stats.nfev
  end, { budget = 1.0 })
  ts = ts / nfev
  c_ns[k] = (c_before + c_times()[k]) / 2
  local growth_c = last and math.log(c_ns[k] / c_ns[last.k]) / math.log(k / last.k)
  print(("%4d %12s %12s %12s %8.1fx %8.1fx %12s %8.1fx %5d %8s %8s  %s"):format(k, timing.fmt(ti, 12), timing.fmt(t, 12),
    timing.fmt(c_ns[k], 12), ti / c_ns[k], t / c_ns[k], timing.fmt(ts, 12), ts / c_ns[k], n,
    growth and ("%.2f"):format(growth) or "", growth_c and ("%.2f"):format(growth_c) or "", g))
  last = { k = k, t = t, growth = growth }
end
print(("agreement at k = 8: max |qdd nzlua - qdd C| / max |qdd C| = %.1e (%s 1e-10)"):format(rel,
  rel <= 1e-10 and "within" or "NOT within: the two models differ"))
print("notes: wall-clock medians; C: median of 9 loops of >= 10 ms each, run just before and just after the row")
print("  (the mean of the two: the machine's speed drifts); state th_i = 0.7 sin(1.3 i + 0.5),")
print("  thd_i = 0.9 cos(0.7 i + 0.2); runs = timed samples of nzlua (one call or more each)")
