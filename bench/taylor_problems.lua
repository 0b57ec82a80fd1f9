-- taylor_problems.lua - Taylor's method against rk8pd on the long runs of
-- issue 11: Kepler (e = 0.6) over 1000 orbits and the pendulum at 2.5 rad
-- over 1000 periods against their closed forms; the Chaplygin sleigh and
-- the rolling disk over 1000 s and Hamel's particle against what they
-- conserve.  One row per method and tolerance: time (median of a few runs),
-- steps, right-hand sides or series, the error against the reference, the
-- drift of the invariant, and rk8pd's time over taylor's.  A method that
-- refuses a problem (taylor and a constraint of order 3, say) prints its
-- reason in the row.
--   build/nzlua bench/taylor_problems.lua
local root = (arg and arg[0] or ""):match("^(.-)bench/[^/]*$") or ""
package.path = root .. "?.lua;" .. package.path
local nz = rawget(_G, "nz") or require "nz"
local timing = require "bench.timing"
local cs = require "tests.constraint_systems"

local function span(xs) local lo, hi = math.huge, -math.huge; for _, v in ipairs(xs) do lo, hi = math.min(lo, v), math.max(hi, v) end; return hi - lo end

-- Each problem: the system, the start, t1, dt (the grid the invariant is
-- watched on), the error of a trajectory against the reference and its
-- invariant's drift.
local problems = {}

-- Kepler in Cartesian coordinates (mu = a = 1, period 2 pi), from
-- periapsis: after 1000 orbits it is at periapsis again, (a (1 - e), 0)
-- (Kepler's equation at M = 2000 pi gives E = 0 exactly).
do
  local e = 0.6
  local rp, vp = 1 - e, math.sqrt((1 + e) / (1 - e))
  local sys = nz.system{ name = "Kepler e=0.6", coords = { "x", "y" }, native = true,
    T = function(t, q, qd) return 0.5 * (qd[1] ^ 2 + qd[2] ^ 2) end,
    V = function(t, q) return -1 / nz.sqrt(q[1] ^ 2 + q[2] ^ 2) end }
  local E0 = 0.5 * vp ^ 2 - 1 / rp
  problems[#problems + 1] = { name = "Kepler, e = 0.6, 1000 orbits", sys = sys, q0 = { rp, 0 }, qd0 = { 0, vp },
    t1 = 2000 * math.pi, dt = 2 * math.pi, tols = { 1e-12, 1e-15 },
    error = function(tr) local n = #tr.t; return math.sqrt((tr.q[n][1] - rp) ^ 2 + tr.q[n][2] ^ 2) end,
    error_name = "position at the end",
    drift = function(tr)
      local E = {}
      for i = 1, #tr.t do E[i] = 0.5 * (tr.qd[i][1] ^ 2 + tr.qd[i][2] ^ 2) - 1 / math.sqrt(tr.q[i][1] ^ 2 + tr.q[i][2] ^ 2) end
      return span(E) / math.abs(E0)
    end, drift_name = "energy (relative)" }
end

-- The pendulum released from rest at 2.5 rad: after 1000 periods (P = 4
-- K(k) / w, k = sin 1.25) it is at rest at 2.5 rad again.
do
  local g, th0 = 9.81, 2.5
  local sys = nz.system{ name = "pendulum", coords = { "th" }, native = true,
    T = function(t, q, qd) return 0.5 * qd[1] ^ 2 end, V = function(t, q) return -g * nz.cos(q[1]) end }
  local P = 4 * nz.special.ellint_K(math.sin(th0 / 2)) / math.sqrt(g)
  local E0 = -g * math.cos(th0)
  problems[#problems + 1] = { name = "pendulum at 2.5 rad, 1000 periods", sys = sys, q0 = { th0 }, qd0 = { 0 },
    t1 = 1000 * P, dt = P, tols = { 1e-12, 1e-15 },
    error = function(tr) local n = #tr.t; return math.abs(tr.q[n][1] - th0) + math.abs(tr.qd[n][1]) / (g * math.sin(th0)) end,
    error_name = "angle + phase (s) at the end",
    drift = function(tr)
      local E = {}
      for i = 1, #tr.t do E[i] = 0.5 * tr.qd[i][1] ^ 2 - g * math.cos(tr.q[i][1]) end
      return span(E) / math.abs(E0)
    end, drift_name = "energy (relative)" }
end

-- Constrained systems: what they conserve (no closed form at the end).
local function constrained(case, q0, qd0, invariant, name)
  return { name = case.name .. ", 1000 s", sys = case.sys, q0 = q0, qd0 = qd0, t1 = 1000, dt = 1, tols = { 1e-10, 1e-12 },
    drift = function(tr)
      local v = {}
      for i = 1, #tr.t do v[i] = invariant(tr.q[i], tr.qd[i]) end
      return span(v)
    end, drift_name = name }
end
do
  local sl = cs.sleigh()
  -- T = (m u^2 + (I + m a^2) w^2) / 2 along the constraint, conserved
  problems[#problems + 1] = constrained(sl, { 0, 0, 0 }, { 1, 0, 0.5 },
    function(q, qd) return sl.sys:energy(0, q, qd) end, "energy")
  local rd = cs.rolling_disk()
  problems[#problems + 1] = constrained(rd, { 0, 0, 0, 0 }, { 0.3 * 2, 0, 0.7, 2 },
    function(q, qd) return qd[3] + qd[4] end, "th' + ph' (both constant)")
  local hm = cs.hamel()
  problems[#problems + 1] = { name = hm.name .. ", 10 s", sys = hm.sys, q0 = { 0, 0, 0 }, qd0 = { 0.3, -0.2, 0.1 },
    t1 = 10, dt = 0.1, tols = { 1e-10, 1e-12 },
    drift = function(tr)
      -- the constraint q3'' = q1'' q2'' along the trajectory, from its accelerations
      local worst = 0
      for i = 1, #tr.t do
        local a = tr.qdd[i]
        worst = math.max(worst, math.abs(a[3] - a[1] * a[2]))
      end
      return worst
    end, drift_name = "|q3'' - q1'' q2''| max" }
end

local function run(p, method, tol)
  return p.sys:simulate{ q0 = p.q0, qd0 = p.qd0, t1 = p.t1, dt = p.dt, method = method, rtol = tol, atol = tol }
end

print("Taylor's method against rk8pd on long runs (issue 11): wall-clock medians, both right-hand sides / series")
print("in C (machine code once earned); error against the closed form, drift of the invariant over the grid")
for _, p in ipairs(problems) do
  print(("\n%s (%s%s)"):format(p.name, p.error_name and ("error: " .. p.error_name .. "; ") or "", "drift: " .. p.drift_name))
  print(("%-6s %-7s %11s %8s %6s %9s %11s %11s %10s"):format("tol", "method", "time", "steps", "order", "rhs/ser",
    "error", "drift", "rk8pd/this"))
  for _, tol in ipairs(p.tols) do
    local rows, t_rk = {}, nil
    for _, method in ipairs{ "rk8pd", "taylor" } do
      local ok, tr = pcall(run, p, method, tol)
      if not ok then
        local why = tostring(tr):gsub("\n.*", ""):gsub("^.-simulate '[^']*': ", "")
        rows[#rows + 1] = ("%-6.0e %-7s refused: %s"):format(tol, method, why:sub(1, 100))
      else
        local t = timing.per_call(function() tr = run(p, method, tol) end, { sample = 0, budget = 3, samples = 3 })
        if method == "rk8pd" then t_rk = t end
        rows[#rows + 1] = ("%-6.0e %-7s %11s %8d %6s %9d %11s %11.2e %10s"):format(tol, method, timing.fmt(t, 11),
          tr.stats.steps, method == "taylor" and tostring(tr.stats.order) or "8", tr.stats.nfev,
          p.error and ("%.2e"):format(p.error(tr)) or "-", p.drift(tr),
          t_rk and ("%.2fx"):format(t_rk / t) or "-")
      end
    end
    for _, r in ipairs(rows) do print(r) end
  end
end
print("\nnotes: rk8pd/this > 1: taylor is faster.  Kepler (Cartesian) and the pendulum are made with native = true:")
print("  both methods run machine code from the first step (the first run compiles, the timed ones do not); the")
print("  constrained systems are tests/constraint_systems.lua's, with the default (compile once it pays).")
