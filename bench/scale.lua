-- scale.lua - research-size systems: what the machine code and the runs
-- cost as the number of coordinates n grows, for the planar n-link
-- pendulum of point masses from bodies (bench/chain.lua: masses 1 + 0.1 i,
-- links 0.5) against the same model written by hand in C (bench/pendulum_c.c:
-- M and h by formula, Cholesky, GSL's rk8pd), and for a 3-D chain of rigid
-- bodies with rotations (bench/chain3d.lua, n / 2 links, no C baseline).
--
-- For each n, each emitter of machine code (straight-line, compact:
-- NZLUA_COMPACT) runs in a process of its own with a fresh cache and the C
-- compiler timed (bench/cc_cpu.sh): the compiler's processor seconds for
-- the plan of M and h and for its Taylor series, the seconds `native =
-- true` waited, then sys:accel per call and runs of rk8pd and taylor from
-- rest at th_i = 0.7 sin(1.3 i + 0.5) over t = 0..T1.  Growth exponents are
-- least-squares slopes of log(figure) against log(n) over the rows.
--
--   build/nzlua bench/scale.lua          (make bench runs it)
-- Settings (environment): BENCH_SCALE_MAX (largest n, default 64; 128 adds
-- minutes), BENCH_SCALE_STRAIGHT_NODES (straight-line code is compiled and
-- timed for plans up to this many nodes, default 12000: its compile of the
-- 64-link plan and series costs minutes of cc), BENCH_SCALE_3D_MAX (largest
-- n of the 3-D chain, default 16).
local root = (arg and arg[0] or ""):match("^(.-)bench/[^/]*$") or ""
package.path = root .. "?.lua;" .. package.path
local nz = rawget(_G, "nz") or require "nz"
local timing = require "bench.timing"

local T1, TOLS = 0.5, { 1e-10, 1e-14 }
local MODELS = { planar = require "bench.chain", ["3-D"] = require "bench.chain3d" }

local function state(model, n)
  local q, qd, amp = {}, {}, model == "planar" and 0.7 or 0.3
  for i = 1, n do q[i], qd[i] = amp * math.sin(1.3 * i + 0.5), 0 end
  return q, qd
end

-- ------------------------------------------------------------------ --
-- The child: one model, one n, one emitter (set by the parent's          --
-- environment); prints key = value lines.                                --

local function child(model, n)
  local sys = MODELS[model](n, { native = true })
  local q, qd = state(model, n)
  sys:accel(0, q, qd)                  -- compiles M and h's plan, waiting for it
  local info = sys:graph_info()
  print("nodes", info.nodes)
  local runs = {}
  for i, tol in ipairs(TOLS) do        -- the first taylor step compiles the series
    runs[i] = function(method) return sys:simulate{ q0 = q, qd0 = qd, t1 = T1, dt = T1, method = method, rtol = tol, atol = tol } end
  end
  runs[1]("taylor")
  info = sys:graph_info()
  print("plan_nodes", info.mass_bias_nodes)
  print("waited", info.native_waited)
  print("machine", info.native_plans, info.native_series, tostring(info.native_why))
  local qv, qdv = state(model, n)
  for i = 1, n do qdv[i] = 0.9 * math.cos(0.7 * i + 0.2) end
  print("accel", (timing.per_call(function() sys:accel(0, qv, qdv) end, { budget = 1, clock = os.clock })))
  for i, tol in ipairs(TOLS) do
    for _, method in ipairs{ "rk8pd", "taylor" } do
      local tr
      local t = timing.per_call(function() tr = runs[i](method) end, { budget = 2, samples = 3, clock = os.clock })
      local last = #tr.t
      print(("%s_%g"):format(method, tol), t, tr.stats.steps, table.concat(tr.q[last], " "))
    end
  end
end

if arg and arg[1] == "child" then
  child(arg[2], math.tointeger(tonumber(arg[3])))
  return
end

-- ------------------------------------------------------------------ --
-- The parent                                                             --

local MAX = math.tointeger(tonumber(os.getenv("BENCH_SCALE_MAX") or "64")) or 64
local STRAIGHT_NODES = tonumber(os.getenv("BENCH_SCALE_STRAIGHT_NODES") or "12000")
local MAX3D = math.tointeger(tonumber(os.getenv("BENCH_SCALE_3D_MAX") or "16")) or 16
local here = timing.run("pwd"):gsub("%s+$", "")
local abs_root = root:sub(1, 1) == "/" and root or here .. "/" .. root

-- One child run with an emitter ("0" straight-line, "1" compact, "" the
-- one nzlua picks by size): its figures, the compiler's seconds for the
-- plan and for the series, and the emitter of each (plan_kind, series_kind).
local function measure(model, n, compact)
  local dir = os.tmpname()
  os.remove(dir)
  assert(os.execute("mkdir -m 700 " .. dir))
  local log = dir .. "/cc.log"
  local cmd = ("env %s NZLUA_CACHE=%s/cache CC=%sbench/cc_cpu.sh NZ_BENCH_CC_LOG=%s NZLUA_CC_TIMEOUT=3600 "
    .. "%sbuild/nzlua %sbench/scale.lua child %s %d"):format(compact ~= "" and "NZLUA_COMPACT=" .. compact or "", dir, abs_root, log, abs_root, abs_root, model, n)
  local out = timing.run(cmd)
  local r = { plan_cc = 0, series_cc = 0 }
  for line in out:gmatch("[^\n]+") do
    local f = {}
    for w in line:gmatch("%S+") do f[#f + 1] = w end
    if f[1] == "machine" then r.plans, r.series = tonumber(f[2]), tonumber(f[3])
    elseif f[1]:match("^rk8pd_") or f[1]:match("^taylor_") then
      local q = {}
      for i = 4, #f do q[#q + 1] = tonumber(f[i]) end
      r[f[1]] = { seconds = tonumber(f[2]), steps = tonumber(f[3]), q = q }
    else r[f[1]] = tonumber(f[2]) end
  end
  for line in (timing.run("cat " .. log .. " 2>/dev/null")):gmatch("[^\n]+") do
    local u, s, head = line:match("^(%S+) (%S+) (.*)$")
    local secs = tonumber(u) + tonumber(s)
    local part = head:find("nzlua%-series") and "series" or "plan"
    r[part .. "_cc"] = r[part .. "_cc"] + secs
    r[part .. "_kind"] = head:find("compact code") and "compact" or "straight"
  end
  os.execute("rm -rf " .. dir)
  return r
end

-- The C program's ns per accel at n (before and after a row: the mean).
local function c_accel(n)
  local out = timing.run(("PENDULUM_C_CPU=1 %sbuild/pendulum_c accel %d"):format(root, n))
  return tonumber(out:match("accel %d+ ([%d.]+)")) * 1e-9
end
local function c_sim(n, tol)
  local out = timing.run(("PENDULUM_C_CPU=1 %sbuild/pendulum_c sim %d %g %g"):format(root, n, T1, tol))
  local f = {}
  for x in out:gsub("^sim ", ""):gmatch("%S+") do f[#f + 1] = tonumber(x) end
  local y = {}
  for i = 8, 7 + n do y[#y + 1] = f[i] end
  return { seconds = f[4], steps = f[5], q = y }
end

-- Least-squares slope of log(y) against log(x) over the rows that have y.
local function exponent(rows, get)
  local xs, ys = {}, {}
  for _, r in ipairs(rows) do
    local y = get(r)
    if y and y > 0 then xs[#xs + 1], ys[#ys + 1] = math.log(r.n), math.log(y) end
  end
  if #xs < 2 then return "" end
  local mx, my = 0, 0
  for i = 1, #xs do mx, my = mx + xs[i] / #xs, my + ys[i] / #xs end
  local sxy, sxx = 0, 0
  for i = 1, #xs do sxy, sxx = sxy + (xs[i] - mx) * (ys[i] - my), sxx + (xs[i] - mx) ^ 2 end
  return ("%.2f"):format(sxy / sxx)
end

local function fmt(s, w) return s and timing.fmt(s, w) or (" "):rep(w - 1) .. "-" end
local function ratio(a, b, w) return (a and b) and ("%" .. (w - 1) .. ".2fx"):format(a / b) or (" "):rep(w - 1) .. "-" end
local function num(v, w, f) return v and ("%" .. w .. (f or "d")):format(v) or (" "):rep(w - 1) .. "-" end

-- The largest difference between two final states (the same model, method
-- and tolerance: they agree to about the tolerance).
local function gap(a, b)
  if not (a and b) then return nil end
  local d = 0
  for i = 1, #a.q do d = math.max(d, math.abs(a.q[i] - b.q[i])) end
  return d
end

local function rows_of(model, sizes)
  local rows = {}
  for _, n in ipairs(sizes) do
    -- the emitters nzlua picks by size (native_tables.h), then each part
    -- with the other emitter (straight-line code only for plans up to
    -- STRAIGHT_NODES)
    local r = { n = n }
    r.default = measure(model, n, "")
    r.nodes, r.plan_nodes = r.default.nodes, r.default.plan_nodes
    local d = r.default
    if d.plan_kind == "straight" or d.series_kind == "straight" then r.forced_compact = measure(model, n, "1") end
    if (d.plan_kind == "compact" or d.series_kind == "compact") and r.plan_nodes <= STRAIGHT_NODES then
      r.forced_straight = measure(model, n, "0")
    end
    local function with(part, kind)
      for _, key in ipairs{ "default", "forced_compact", "forced_straight" } do
        local m = r[key]
        if m and m[part .. "_kind"] == kind then return m end
      end
    end
    r.plan = { straight = with("plan", "straight"), compact = with("plan", "compact") }
    r.series = { straight = with("series", "straight"), compact = with("series", "compact") }
    if model == "planar" then
      local before = c_accel(n)
      r.c = { accel = (before + c_accel(n)) / 2 }
      for _, tol in ipairs(TOLS) do r.c[("rk8pd_%g"):format(tol)] = c_sim(n, tol) end
    end
    rows[#rows + 1] = r
    io.stderr:write(("bench/scale.lua: %s n = %d done\n"):format(model, n))
  end
  return rows
end

local function compile_table(title, rows)
  print(title)
  print(("%4s %8s %8s | %9s %9s %9s %9s | %9s %9s"):format("n", "graph", "plan", "plan st", "plan cp", "series st",
    "series cp", "wait", "wait cp"))
  local function cc(r, part, kind) return r[part][kind] and r[part][kind][part .. "_cc"] end
  for _, r in ipairs(rows) do
    print(("%4d %8d %8d | %9s %9s %9s %9s | %9s %9s"):format(r.n, r.nodes, r.plan_nodes,
      num(cc(r, "plan", "straight"), 8, ".2f") .. "s", num(cc(r, "plan", "compact"), 8, ".2f") .. "s",
      num(cc(r, "series", "straight"), 8, ".2f") .. "s", num(cc(r, "series", "compact"), 8, ".2f") .. "s",
      num(r.default.waited, 8, ".2f") .. "s", num(r.forced_compact and r.forced_compact.waited, 8, ".2f") .. "s"))
  end
  print(("%4s %8s %8s | %9s %9s %9s %9s |"):format("exp", exponent(rows, function(r) return r.nodes end),
    exponent(rows, function(r) return r.plan_nodes end),
    exponent(rows, function(r) return cc(r, "plan", "straight") end),
    exponent(rows, function(r) return cc(r, "plan", "compact") end),
    exponent(rows, function(r) return cc(r, "series", "straight") end),
    exponent(rows, function(r) return cc(r, "series", "compact") end)))
end

local function per_step(run) return run and run.seconds / run.steps end

local function speed_table(title, rows, with_c)
  print(title)
  print(("%4s | %10s %10s %7s %10s %7s | %10s %10s %7s | %10s %7s %10s %7s"):format("n", "accel st", "accel cp", "cp/st",
    with_c and "accel C" or "", with_c and "nz/C" or "", "rk8pd", with_c and "C rk8pd" or "/step", with_c and "nz/C" or "",
    "taylor", with_c and "/C rk8" or "steps", "taylor14", with_c and "/C rk8" or "steps"))
  for _, r in ipairs(rows) do
    local d, s, c = r.default, r.plan.straight, r.plan.compact
    local c10, c14 = r.c and r.c["rk8pd_1e-10"], r.c and r.c["rk8pd_1e-14"]
    local rk, ty, ty14 = d["rk8pd_1e-10"], d["taylor_1e-10"], d["taylor_1e-14"]
    print(("%4d | %10s %10s %7s %10s %7s | %10s %10s %7s | %10s %7s %10s %7s  %s"):format(r.n,
      fmt(s and s.accel, 10), fmt(c and c.accel, 10), ratio(c and c.accel, s and s.accel, 7),
      with_c and fmt(r.c.accel, 10) or "", with_c and ratio(d.accel, r.c.accel, 7) or "",
      fmt(rk.seconds, 10), with_c and fmt(c10.seconds, 10) or fmt(per_step(rk), 10),
      with_c and ratio(rk.seconds, c10.seconds, 7) or "",
      fmt(ty.seconds, 10), with_c and ratio(ty.seconds, c10.seconds, 7) or num(ty.steps, 7),
      fmt(ty14.seconds, 10), with_c and ratio(ty14.seconds, c14.seconds, 7) or num(ty14.steps, 7),
      ("plan %s, series %s"):format(d.plan_kind or "?", d.series_kind or "?")))
  end
  print(("%4s | %10s %10s %7s %10s %7s | %10s %10s %7s | %10s %7s %10s %7s"):format("exp",
    exponent(rows, function(r) return r.plan.straight and r.plan.straight.accel end),
    exponent(rows, function(r) return r.plan.compact and r.plan.compact.accel end), "",
    with_c and exponent(rows, function(r) return r.c.accel end) or "", "",
    exponent(rows, function(r) return per_step(r.default["rk8pd_1e-10"]) end),
    with_c and exponent(rows, function(r) return per_step(r.c["rk8pd_1e-10"]) end) or "", "",
    exponent(rows, function(r) return per_step(r.default["taylor_1e-10"]) end), "",
    exponent(rows, function(r) return per_step(r.default["taylor_1e-14"]) end), ""))
end

local sizes, sizes3 = {}, {}
for _, n in ipairs{ 4, 8, 16, 32, 64, 128 } do
  if n <= MAX then sizes[#sizes + 1] = n end
  if n <= MAX3D then sizes3[#sizes3 + 1] = n end
end
local planar = rows_of("planar", sizes)
local chain3 = rows_of("3-D", sizes3)

print("Research-size systems: the planar n-link pendulum from bodies against hand-written C, and a 3-D chain of rigid bodies")
print(("(n coordinates; the 3-D chain has n / 2 links of two angles each); runs from rest, t = 0..%g, rtol = atol"):format(T1))
print()
compile_table("Machine code: the compiler's processor seconds (bench/cc_cpu.sh) for the plan of M and h and for its Taylor\n"
  .. "series, straight-line (st) and compact (cp, NZLUA_COMPACT=1) code; graph and plan in nodes; wait: the wall\n"
  .. "seconds native = true waited for both; exp: growth exponent d log / d log n", planar)
print()
speed_table("Speed (machine code; the emitter nzlua picks by size unless a column says which): sys:accel per call, and\n"
  .. "runs of rk8pd (1e-10) and taylor (1e-10, 1e-14) against GSL's rk8pd on the hand-written C right-hand side at\n"
  .. "the same tolerance", planar, true)
print()
compile_table("3-D chain of rigid bodies: machine code as above", chain3)
print()
speed_table("3-D chain: speed (rk8pd's column /step: seconds per step; taylor's: steps)", chain3, false)
print()
local worst = 0
for _, r in ipairs(planar) do
  for _, tol in ipairs(TOLS) do
    local key = ("rk8pd_%g"):format(tol)
    worst = math.max(worst, gap(r.default[key], r.c[key]) or 0)
  end
end
print(("agreement: the final positions of rk8pd in nzlua and in C differ by at most %.1e (the same model, method and tolerances)"):format(worst))
print(("notes: processor time, medians (timing.lua with os.clock; C: PENDULUM_C_CPU, median of 9, its accel run before and"
  .. " after each row: on a shared machine wall time measures the other processes); straight-line"
  .. " code is compiled for plans up to %d nodes (BENCH_SCALE_STRAIGHT_NODES); sizes up to %d (BENCH_SCALE_MAX), the 3-D"
  .. " chain up to %d (BENCH_SCALE_3D_MAX)"):format(STRAIGHT_NODES, MAX, MAX3D))
