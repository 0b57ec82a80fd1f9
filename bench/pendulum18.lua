-- pendulum18.lua - an 18-link pendulum built with bodies, one simulated
-- second with rk8pd at rtol = atol = 1e-10: the time from starting the
-- script to the end of that second.  Issue 10's target: under 1 s.  (For
-- scale: SymPy's KanesMethod took 3 min 36 s to form this right-hand side.)
--
-- It first simulates 0.05 s (a probe); when the whole second is expected to
-- take over 60 s it stops there and prints the extrapolation, labelled so:
-- the probe's time per right-hand side times the number of right-hand sides
-- the same integration takes in C (build/pendulum_c sim, the same model,
-- method and control).  bench/run.sh also prints the wall time of the
-- whole script (`date` around it).
--   build/nzlua bench/pendulum18.lua [links]
local cpu_start = os.clock()         -- CPU time since the process started
local root = (arg and arg[0] or ""):match("^(.-)bench/[^/]*$") or ""
package.path = root .. "?.lua;" .. package.path
local nz = rawget(_G, "nz") or require "nz"
local timing = require "bench.timing"
local wall_start = timing.now()

-- An argument sets another number of links (a quick run of the full path).
local K, T1, TOL, PROBE, LIMIT = math.tointeger(tonumber(arg and arg[1]) or 18), 1.0, 1e-10, 0.05, 60
assert(K and K >= 1 and K <= 32, "bench/pendulum18.lua [links]: links must be an integer 1..32")

-- The n-link pendulum of bench/mech.lua (bench/chain.lua).
local chain = require "bench.chain"

-- Both clocks around f: CPU seconds, wall seconds, f's result.
local function timed(f)
  local c, w = os.clock(), timing.now()
  local r = f()
  return os.clock() - c, timing.now() - w, r
end

local build_cpu, build_wall, sys = timed(function() return chain(K) end)
local q0, qd0 = {}, {}
for i = 1, K do q0[i], qd0[i] = 0.7 * math.sin(1.3 * i + 0.5), 0 end   -- bench/pendulum_c.c's start, at rest
local function run(t1)
  return sys:simulate{ q0 = q0, qd0 = qd0, t1 = t1, dt = t1, method = "rk8pd", rtol = TOL, atol = TOL }
end

local probe_cpu, probe_wall, probe = timed(function() return run(PROBE) end)

-- The C baseline (outside every timed part): time, steps and final state.
local function c_sim(t1)
  local out = timing.run(("%sbuild/pendulum_c sim %d %g %g"):format(root, K, t1, TOL))
  local f = {}            -- after "sim": K T1 TOL seconds steps rejected nfev y...
  for x in out:gsub("^sim ", ""):gmatch("%S+") do f[#f + 1] = assert(tonumber(x), "build/pendulum_c sim: " .. out) end
  assert(f[1] == K and #f == 7 + 2 * K, "build/pendulum_c sim: unexpected output: " .. out)
  local y = {}
  for i = 8, #f do y[#y + 1] = f[i] end
  return { seconds = f[4], steps = f[5], rejected = f[6], nfev = f[7], y = y }
end
local _, c_wall, c = timed(function() return c_sim(T1) end)

local per_rhs, per_rhs_cpu = probe_wall / probe.stats.nfev, probe_cpu / probe.stats.nfev
local expected = build_wall + per_rhs * c.nfev

print(("%d-link pendulum from bodies, rk8pd at rtol = atol = %g, t = 0..%g: time from starting the script"):format(K, TOL, T1))
print("target (issue 10): under 1 s from starting the script (wall)")
print(("%-38s %11s %11s %7s %5s %6s"):format("", "wall", "CPU", "steps", "rej", "nfev"))
local function row(what, wall, cpu, steps, rej, nfev)
  print(("%-38s %11s %11s %7s %5s %6s"):format(what, timing.fmt(wall, 11), cpu and timing.fmt(cpu, 11) or "",
    steps or "", rej or "", nfev or ""))
end
row("making the system (bodies)", build_wall, build_cpu)
row(("probe: simulate t = 0..%g"):format(PROBE), probe_wall, probe_cpu, probe.stats.steps, probe.stats.rejected, probe.stats.nfev)
local full
if expected <= LIMIT then
  local sim_cpu, sim_wall, tr = timed(function() return run(T1) end)
  full = tr
  row(("simulate t = 0..%g"):format(T1), sim_wall, sim_cpu, tr.stats.steps, tr.stats.rejected, tr.stats.nfev)
  -- From the start of the script, less the probe and the C baseline.
  row("SCRIPT START TO t = 1 (less the probe)", (timing.now() - wall_start) - probe_wall - c_wall, os.clock() - probe_cpu)
else
  row("EXTRAPOLATED: simulate t = 0..1", per_rhs * c.nfev, per_rhs_cpu * c.nfev, nil, nil, c.nfev)
  row("EXTRAPOLATED: script start to t = 1", expected + cpu_start, build_cpu + per_rhs_cpu * c.nfev + cpu_start)
end
row("C: GSL rk8pd, t = 0..1 (median of 9)", c.seconds, nil, c.steps, c.rejected, c.nfev)
local t_nz = full and full.stats.wall or per_rhs * c.nfev
print(("ratio nzlua/C for the simulate of t = 0..1: %.0fx%s"):format(t_nz / c.seconds, full and "" or " (extrapolated)"))
if full then
  local d = 0
  local n = #full.t
  for i = 1, K do d = math.max(d, math.abs(full.q[n][i] - c.y[i]), math.abs(full.qd[n][i] - c.y[K + i])) end
  print(("final state, max |nzlua - C| over q and qd: %.2e"):format(d))
end
local g = timing.graph_line(sys, per_rhs, "RHS")
if g then print(g) end
print(("notes: when over %d s, extrapolated: the probe's time per RHS (%s wall, %s CPU) times C's RHS"):format(LIMIT,
  timing.fmt(per_rhs, 0), timing.fmt(per_rhs_cpu, 0)))
print("  count for t = 0..1 (same model, method, control, start; the motion speeds up from rest, so the")
print("  probe's own steps would undercount; its fixed costs make it an overestimate).  C: its own median,")
print("  run outside every timed part.  CPU = os.clock; the script start adds the interpreter's own start.")
