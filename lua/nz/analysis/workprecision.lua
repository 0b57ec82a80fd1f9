-- nz/analysis/workprecision.lua - what accuracy costs in time: the same motion with
-- each method at each tolerance, its error against a reference (a closed
-- form, or the most accurate method at a much tighter tolerance), the time
-- and the right-hand-side evaluations it took; a table, and the
-- work-precision diagram (error against time or work, log-log, a line per
-- method).  "taylor" (Taylor's method) runs where it applies: a recorded
-- system, free or with constraints of order 0, 1, 2.
--
-- How a point's time is measured (as DiffEqDevTools' WorkPrecisionSet, the
-- tool of the SciMLBenchmarks, does it; one run timed once, as before,
-- followed the machine's noise: rk8pd at 1e-6 on Kepler measured 9.4, 0.5
-- and 4.6 ms in three studies, and the first study of a process paid the
-- compiler):
--  1. One evaluator for the whole study.  A recorded system's plans run as
--     machine code once compiled, by default only once interpreting them
--     has cost what compiling would: methods timed before that switch were
--     compared with methods timed after it.  The study compiles every plan
--     a method uses at its first use (as native = true does) and restores
--     the system's own setting afterwards; a system made with native =
--     false (or under NZLUA_NATIVE=0) runs interpreted throughout.
--     graph_info() after the warm-up and after the timing says which
--     evaluator ran; the title says it.
--  2. Not timed: the reference run and a warm-up run per method, which
--     build the plans the method uses (mass matrix, Jacobian, series,
--     constraint rows) and compile them; their seconds and the compiler's
--     are reported apart.  Then the study waits for compiles still running
--     (native_wait, where the engine compiles in the background).
--  3. Each point runs at least MIN_RUNS times and until it has spent
--     `budget` seconds; the next run is always the point that has spent
--     least so far, so that each point's runs spread over the whole timing
--     and a spell of load on the machine falls on every point alike.  The
--     collector is stopped during a run (the garbage of the runs before is
--     not collected inside the next one) and a full collection runs between
--     runs once the heap has grown by half (at least 8 MB) since the last:
--     its cost is neither timed nor counted in the budget, which is the
--     runs' own time, so the number of runs does not depend on how big the
--     session's heap is (in a large heap a full collection costs more than
--     a run).  A point also stops after WALL_BUDGET times its budget of
--     wall time, whatever it measured.
--  4. A run's time is the processor time of the call (os.clock: this
--     process only, so the time another program holds the core is not
--     counted; the checks of sys:simulate and the trajectory's assembly
--     are included, about 0.1-0.2 ms, since the clock is read around the
--     call).  The least wall time of the stepping (tr.stats.wall) is kept
--     in each row too: in four Kepler studies at load average 4 both
--     minima moved alike, by at most 3 %.
--  5. A point's time is the minimum of its runs, as DiffEqDevTools takes it
--     (and BenchmarkTools: Chen & Revels, "Robust benchmarking in noisy
--     environments", 2016): noise (interrupts, caches, page faults) only
--     ever adds time, so the minimum estimates the method's own cost and is
--     what varies least from one study to the next: at most 2.2 % between
--     four Kepler studies in one process at load average 4.3 on 2 cores,
--     where the median was 4-7 % above the minimum.  The diagram draws the
--     minimum; the table gives the median and the maximum beside it.  (A
--     machine's speed itself changes: under heavier load every point of a
--     study moved by the same 30 % from one study to the next; the ratios
--     between the points, which the diagram compares, stayed.)
local plot = require "nz.draw.plot"
local core = require "nz.core"
local options = require "nz.base.options"
local args = require "nz.base.args"

local M = {}

M.defaults = {
  methods = { "rk4", "rkf45", "rkck", "rk8pd", "rk4imp", "bsimp", "msadams", "msbdf", "taylor" },
  tols = { 1e-4, 1e-6, 1e-8, 1e-10 },
  reference_method = "rk8pd", reference_tol = 1e-13,
  budget = 0.2,       -- seconds of timed runs per point
  x = "time",         -- the diagram's x axis
}
M.MIN_RUNS = 3        -- runs of each point at least, however long they take
M.MAX_RUNS = 1000     -- ... and at most (runs of microseconds stop here)
M.WALL_BUDGET = 10    -- a point stops after this many budgets of wall time (collections, load)
-- Two points are within the noise of each other when the slower one's
-- fastest run is no slower than the faster one's median run, or when their
-- minima differ by less than NOISE_FLOOR.  The floor is the machine's:
-- the processor speed it gives a piece of code depends on what else runs
-- (the other hyperthread, the hypervisor), unequally for two methods; on
-- this 2-core machine at load average 6.7 the ratio of rkf45's to rk8pd's
-- time on Kepler at 1e-6 was 1.14 in one study and 0.84 in the next, a
-- second later, each study's runs within 8 % of their minimum.
M.NOISE_FLOOR = 0.2

-- What the diagram's x axis can show.
M.X = { time = "processor time (s), minimum of the runs", nfev = "right-hand-side evaluations", steps = "steps" }

local function max_error(tr, ref)
  local worst = 0
  for i = 1, #tr.t do
    local want = ref(tr.t[i], i)
    for j = 1, #want do worst = math.max(worst, math.abs(tr.q[i][j] - want[j])) end
  end
  return worst
end

-- The methods a study can run: GSL's steppers, taylor, and the
-- variational integrators of orders 2 ("variational"), 4, 6, 8
-- ("variational4", ...).
local function method_names()
  local names = {}
  for i, m in ipairs(core.mech.ode_methods()) do names[i] = m.name end
  for _, m in ipairs{ "taylor", "variational", "variational4", "variational6", "variational8" } do names[#names + 1] = m end
  return names
end
M.method_names = method_names

-- The options of sys:simulate that run `method` at the study's tolerance
-- tol: rtol = tol, atol = tol / 100; a variational integrator of order p
-- (fixed steps, no tolerance) at step = tol^(1/p), so that its error, C
-- h^p, spans the same decades as the others' when C is about 1.
-- A fixed step no longer than the output spacing, which sets the steps
-- anyway (simulate would say so once): the options o of one run.
function M.fit_step(o)
  if not o.step then return o end
  local dt = o.dt or (o.t1 - (o.t0 or 0)) / require("nz.motion.settings").defaults.points
  if o.step > dt then o.step = dt end
  return o
end

function M.method_options(method, tol)
  local p = method == "variational" and 2 or tonumber(method:match("^variational(%d)$"))
  if p then return { method = "variational", order = p, step = tol ^ (1 / p) } end
  return { method = method, rtol = tol, atol = tol * 1e-2 }
end

-- The options' checkers (the methods' names are read at each check).
local function is_method(v)
  local names = method_names()
  for _, m in ipairs(names) do if m == v then return true end end
  return false, "a method (" .. table.concat(names, " ") .. ")"
end
local function any() return true end
local function list(v) return type(v) == "table" and getmetatable(v) == nil and #v > 0, "a non-empty list" end
local function tolerance(v)
  local min_tol = require("nz.motion.simulate").MIN_RTOL
  return type(v) == "number" and v >= min_tol and v < 1, ("a tolerance from %g to 1 (each run takes rtol = tol, "
    .. "atol = tol / 100)"):format(min_tol)
end
-- The checkers of the options a study shares with nz.longrun.
M.checks = {
  plot = function(v)
    return v == true or v == false or (type(v) == "string" and (v:match("%.svg$") or v:match("%.png$"))),
      "true, or a file name ending in .svg or .png"
  end,
  quiet = function(v) return type(v) == "boolean", "true or false" end,
  simulate = function(v) return type(v) == "table" and getmetatable(v) == nil, "a table of simulate's options" end,
}
local OPTIONS = options.declare("nz.workprecision", {
  q0 = any, qd0 = any, t0 = any, t1 = any, dt = any,      -- simulate checks these
  methods = list, tols = list, reference = function(v) return type(v) == "function", "a function(t) returning q" end,
  reference_method = is_method, reference_tol = tolerance,
  budget = function(v) return type(v) == "number" and v > 0 and v < math.huge, "seconds per point, a positive number" end,
  x = function(v) return M.X[v] ~= nil, "\"time\", \"nfev\" or \"steps\"" end,
  plot = M.checks.plot, quiet = M.checks.quiet, simulate = M.checks.simulate,
})

-- A study's call (nz.workprecision, nz.longrun) checked before anything
-- runs: sys a system, opts a table of the options declared; each error
-- from the caller's line, naming what is wrong ("bad argument #2 to
-- 'workprecision' (...)").  Returns bad(fmt, ...), which raises such an
-- error about the options.
function M.check_call(name, sys, opts, declared, shape)
  local function bad(fmt, ...) args.error(name, 2, fmt, ...) end
  if not require("nz.base.classes").is_system(sys) then
    args.error(name, 1, "a system from nz.system{...} expected, got %s", args.shown(sys))
  end
  if type(opts) ~= "table" then bad("options %s expected, got %s", shape, args.shown(opts)) end
  args.options(name, 2, opts, declared)
  return bad
end

-- The options, checked before anything runs.
local function check(sys, opts)
  local bad = M.check_call("workprecision", sys, opts, OPTIONS, "{q0 =, t1 =, ...}")
  local names = method_names()
  local method = is_method
  -- the lists entry by entry, naming the entry
  local seen = {}
  for i, m in ipairs(opts.methods or {}) do
    local ok = method(m)
    if not ok then
      local near = type(m) == "string" and options.nearest(m, names)
      bad("option 'methods': methods[%d] = %s is not a method%s (the methods: %s)", i,
        type(m) == "string" and ("'" .. m .. "'") or args.shown(m),
        near and (" (did you mean '" .. near .. "'?)") or "", table.concat(names, " "))
    end
    if seen[m] then bad("option 'methods': '%s' is listed twice (methods[%d] and methods[%d])", m, seen[m], i) end
    seen[m] = i
  end
  seen = {}
  for i, tol in ipairs(opts.tols or {}) do
    local ok, want = tolerance(tol)
    if not ok then bad("option 'tols': tols[%d] = %s: %s expected", i, args.shown(tol), want) end
    if seen[tol] then bad("option 'tols': %g is listed twice (tols[%d] and tols[%d])", tol, seen[tol], i) end
    seen[tol] = i
  end
  -- the study sets these for every run: in 'simulate' they would be overwritten
  for _, key in ipairs{ "method", "rtol", "atol", "step", "order" } do
    if opts.simulate and opts.simulate[key] ~= nil then
      bad("option 'simulate': '%s' is set by the study for each run (methods =, tols = ; atol = tol / 100; a "
        .. "variational integrator of order p: step = tol^(1/p)): drop it", key)
    end
  end
end

-- The evaluator: machine code for every plan the study uses, unless the
-- system said never (native = false, or NZLUA_NATIVE=0 in the environment,
-- which sets the mode when the system is made).  Returns a function that
-- restores the system's own mode (-1: in the background once a plan is
-- used, 1: at first use, 0: never; graph_info's native_mode).
function M.one_evaluator(sys)
  local c = sys.recording and sys.engine.recording
  if not c then return function() end end
  local own = c:info().native_mode
  if own == 0 then return function() end end
  c:set_native(true)
  return function() c:set_native(own == 1 or nil) end
end

function M.wait_for_compiles(sys)
  local c = sys.recording and sys.engine.recording
  if c and c.native_wait then c:native_wait() end
end

function M.native_state(sys)
  if not sys.recording then return nil end
  local info = sys:graph_info()
  return { plans = info.native_plans or 0, series = info.native_series or 0, seconds = info.native_seconds or 0,
    why = info.native_why, mode = sys.engine.recording:info().native_mode }
end

-- What the timed runs ran on, in words.
function M.evaluator_text(sys, state)
  if not state then return "Lua functions (the system is not recorded: compile = false)" end
  if state.plans == 0 then
    return "interpreted graphs" .. (state.why and (" (no machine code: " .. state.why .. ")")
      or state.mode == 0 and " (machine code off: native = false, or NZLUA_NATIVE=0)" or " (no plan was compiled)")
  end
  local what = ("machine code (%d plan%s%s)"):format(state.plans, state.plans == 1 and "" or "s",
    state.series > 0 and (", of them " .. state.series .. " series") or "")
  if state.why then what = what .. "; some interpreted: " .. state.why end
  return what
end

local function sorted_stats(times)
  local s = { table.unpack(times) }
  table.sort(s)
  local n = #s
  local median = n % 2 == 1 and s[(n + 1) // 2] or (s[n // 2] + s[n // 2 + 1]) / 2
  return s[1], median, s[n]
end

local function interrupted(ok, tr)
  return (ok and tr.status == "interrupted") or (not ok and tr == core.interrupted) or core.mech.interrupted()
end

-- Not timed: one run per method at its loosest tolerance that runs (the
-- tolerances that fail before it are the method's failed rows, not tried
-- again).  Returns outcome[method] = {skip = why} or {[tol] = message},
-- or the (method, tol) that Ctrl-C stopped.
local function warm_up(sys, opts, methods, tols, run)
  -- Taylor's method runs recorded systems with constraints of order 0, 1, 2
  -- (nz/motion/simulate.lua): where it does not apply its rows say why instead of
  -- failing.
  local function taylor_skip()
    if sys.nc > 0 and require("nz.model.constraints").level(sys) then return "constraints of order 3 or more" end
    if not sys.recording then return "not recorded" end
    if opts.simulate and opts.simulate.monitors and opts.simulate.monitors.work then return "work monitor" end
  end
  local loosest = { table.unpack(tols) }
  table.sort(loosest, function(a, b) return a > b end)
  local outcome, failures, ran = {}, {}, 0
  for _, method in ipairs(methods) do
    local o = { skip = method == "taylor" and taylor_skip() or nil }
    outcome[method] = o
    for _, tol in ipairs(o.skip and {} or loosest) do
      local ok, tr = pcall(run, method, tol)
      if interrupted(ok, tr) then return nil, method, tol end
      if ok then ran = ran + 1; break end
      o.skip = method == "taylor" and tostring(tr):match("method 'taylor' cannot run this system: ([^;\n]*)")
        or method:match("^variational") and tostring(tr):match("method 'variational' (.-): take ") or nil
      if o.skip then break end
      o[tol] = tostring(tr)
      failures[#failures + 1] = o[tol]
    end
  end
  -- nothing ran, and every method failed alike: the study's input is wrong
  -- (q0, t1, an option in 'simulate'): one error, simulate's own, which
  -- names the option from the caller's line
  if ran == 0 and #failures > 0 then
    local same = true
    for _, f in ipairs(failures) do same = same and f == failures[1] end
    if same then error(failures[1], 0) end
  end
  return outcome
end

-- The timed runs of the points (those with p.active): each at least
-- MIN_RUNS times and until it has spent `budget` seconds, the next run
-- always the point that has spent least so far.  p.times gets each run's
-- processor time, p.tr the first run's trajectory.  Returns the point
-- that Ctrl-C stopped, if one did.
local function time_points(points, budget, run)
  local now = core.mech.now
  local function next_point()
    local pick
    for _, p in ipairs(points) do
      if p.active and #p.times >= M.MIN_RUNS and (p.spent >= budget or #p.times >= M.MAX_RUNS
          or p.wall_spent >= M.WALL_BUDGET * budget) then
        p.active = false
      end
      if p.active and (not pick or p.spent < pick.spent) then pick = p end
    end
    return pick
  end
  local heap = collectgarbage("count")
  for p in next_point do
    local t0 = now()
    if collectgarbage("count") > 1.5 * heap + 8192 then   -- kB
      collectgarbage()
      heap = collectgarbage("count")
    end
    collectgarbage("stop")
    local c0 = os.clock()
    local ok, tr = pcall(run, p.row.method, p.row.tol)
    local cpu = os.clock() - c0
    collectgarbage("restart")
    p.spent = p.spent + cpu
    p.wall_spent = p.wall_spent + (now() - t0)
    if interrupted(ok, tr) then return p end
    if not ok then
      p.row.status, p.row.message, p.active = "failed", tostring(tr):match("^[^\n]*"), false
    else
      p.tr = p.tr or tr
      p.times[#p.times + 1] = cpu
      p.wall = math.min(p.wall or math.huge, tr.stats.wall)
    end
  end
end

-- A timed point's row: its error against the reference, its work, and the
-- minimum, median and maximum of its times.
local function measured_row(p, reference)
  local r, tr = p.row, p.tr
  r.error, r.nfev, r.steps, r.status = max_error(tr, reference), tr.stats.nfev, tr.stats.steps, tr.status
  r.time, r.time_median, r.time_max = sorted_stats(p.times)
  r.runs, r.wall = #p.times, p.wall      -- wall: the least wall time of the stepping (tr.stats.wall)
  -- the grid set the steps: a GSL stepper without dense output
  -- (msadams, msbdf, dense = false) stopped at about every output
  -- point, or the interpolant's error control made many points step
  -- ends (nz/motion/simulate.lua says which in tr.stats.grid_why)
  r.grid = r.method ~= "taylor" and not r.method:match("^variational") and tr.stats.grid_why ~= nil
  r.grid_why = r.grid and tr.stats.grid_why or nil
  return r
end

-- The study itself (M.run checks the options and sets the evaluator).
local function measure(sys, opts, methods, tols, budget, run)
  local now = core.mech.now
  local study = { budget = budget, x = opts.x or M.defaults.x }
  local rows = { study = study }
  local function stopped(method, tol)
    rows[#rows + 1] = { method = method, tol = tol, status = "interrupted", message = "stopped by Ctrl-C" }
    rows.interrupted = true
  end

  -- 1. not timed: the reference, and a warm-up run per method
  local before, untimed0 = M.native_state(sys), now()
  local reference = opts.reference
  study.reference = "closed form"
  if not reference then
    local method, tol = opts.reference_method or M.defaults.reference_method, opts.reference_tol or M.defaults.reference_tol
    local ref = run(method, tol)
    reference = function(_, i) return ref.q[i] end
    study.reference, study.reference_run = ("%s at rtol %g"):format(method, tol), true
  end
  local outcome, method, tol = warm_up(sys, opts, methods, tols, run)
  if not outcome then
    stopped(method, tol)
    study.evaluator = M.evaluator_text(sys, M.native_state(sys))
    return rows
  end
  M.wait_for_compiles(sys)
  local warm = M.native_state(sys)
  study.untimed_seconds = now() - untimed0
  study.compile_seconds = warm and (warm.seconds - before.seconds) or 0
  study.compiled = warm and (warm.plans - before.plans) or 0

  -- 2. the timed runs
  local points = {}
  for _, m in ipairs(methods) do
    for _, t in ipairs(tols) do
      local o = outcome[m]
      local p = { row = { method = m, tol = t }, times = {}, spent = 0, wall_spent = 0 }
      if o.skip then
        p.row.status, p.row.message = "skipped", "skipped: " .. o.skip
      elseif o[t] then
        p.row.status, p.row.message = "failed", o[t]:match("^[^\n]*")
      else
        p.active = true
      end
      points[#points + 1] = p
    end
  end
  local cut = time_points(points, budget, run)
  -- a plan compiled during the timed runs (one the warm-up did not use):
  -- the times before it ran on another evaluator; every point again
  local final = M.native_state(sys)
  if not cut and final and final.plans ~= warm.plans then
    M.wait_for_compiles(sys)
    study.retimed, warm = true, M.native_state(sys)
    for _, p in ipairs(points) do
      if p.tr then p.times, p.spent, p.wall_spent, p.active, p.tr, p.wall = {}, 0, 0, true, nil, nil end
    end
    cut = time_points(points, budget, run)
    final = M.native_state(sys)
  end
  study.evaluator = M.evaluator_text(sys, final)
  study.evaluator_changed = final and final.plans ~= warm.plans or nil

  for _, p in ipairs(points) do
    if p == cut then
      stopped(p.row.method, p.row.tol)
    elseif p.tr then
      rows[#rows + 1] = measured_row(p, reference)
    elseif p.row.status then        -- skipped, or failed in the warm-up or its first timed run
      rows[#rows + 1] = p.row
    end
  end
  M.flag(rows)
  return rows
end

-- nz.workprecision(sys, {q0 =, qd0 =, t0 =, t1 =, dt =, methods = {...},
--   tols = {...}, reference = function(t) return q end (optional),
--   budget = 0.2, x = "time" | "nfev" | "steps",
--   plot = true | "file.svg", quiet = false, simulate = {extra options}})
-- Returns the rows {method, tol, error, time (the minimum), time_median,
-- time_max, runs, wall, nfev, steps, status, flag}; rows.study says how
-- they were measured.
function M.run(sys, opts)
  check(sys, opts)
  local methods = opts.methods or M.defaults.methods
  local tols = opts.tols or M.defaults.tols
  local budget = opts.budget or M.defaults.budget
  local base = { q0 = opts.q0, qd0 = opts.qd0, t0 = opts.t0, t1 = opts.t1, dt = opts.dt, progress = false }
  for k, v in pairs(opts.simulate or {}) do base[k] = v end
  local function run(method, tol)
    local o = {}
    for k, v in pairs(base) do o[k] = v end
    for k, v in pairs(M.method_options(method, tol)) do o[k] = v end
    M.fit_step(o)
    return sys:simulate(o)
  end
  local restore = M.one_evaluator(sys)
  local ok_study, rows = pcall(measure, sys, opts, methods, tols, budget, run)
  restore()
  if not ok_study then error(rows, 0) end
  local study = rows.study
  local text = ("Work-precision of '%s', t = %g .. %g, error = max over the output grid of |q - q_ref| (reference: %s)\n"
    .. "evaluator: %s\n%s"):format(sys.name, base.t0 or 0, base.t1, study.reference, study.evaluator, M.table(rows))
  -- the rows print as their table (print(rows) in a script, rows typed at the prompt)
  setmetatable(rows, { __tostring = function() return text end })
  if not opts.quiet then require("nz.base.frontend").print(text) end   -- (a notebook: its table as HTML too)
  if opts.plot and not rows.interrupted then
    M.diagram(rows, { file = type(opts.plot) == "string" and opts.plot or nil, x = opts.x,
      title = ("work-precision: %s (%s)"):format(sys.name, (study.evaluator:match("^[^(;]*"):gsub("%s+$", ""))) })
  end
  if opts.quiet then return rows end
  return require("nz.base.frontend").shown(rows)       -- typed at the prompt: the table once
end

local function measured(r)
  return r.status ~= "failed" and r.status ~= "skipped" and r.status ~= "interrupted" and r.error and r.time
end

-- Mark each row whose error is larger than at a looser tolerance of the
-- same method (r.flag says by how much): the error does not follow the
-- tolerance there (the method's error control, roundoff, or the
-- reference's own error), and the point is not one of the method's line.
function M.flag(rows)
  local by = {}
  for _, r in ipairs(rows) do
    if measured(r) then
      by[r.method] = by[r.method] or {}
      table.insert(by[r.method], r)
    end
  end
  for _, list in pairs(by) do
    table.sort(list, function(a, b) return a.tol > b.tol end)
    local best
    for _, r in ipairs(list) do
      r.flag = nil
      if best and r.error > best.error then
        r.flag = ("error %.2g at tol %g is larger than %.2g at tol %g"):format(r.error, r.tol, best.error, best.tol)
      end
      if not best or r.error < best.error then best = r end
    end
  end
  return rows
end

-- What the untimed part spent on machine code: compiling, or loading
-- objects the cache already had (microseconds).
local function compiled_text(study)
  local n = study.compiled or 0
  if n == 0 then return "" end
  local plans = ("%d plan%s"):format(n, n == 1 and "" or "s")
  if study.compile_seconds < 1e-3 then return ", " .. plans .. " of machine code from the cache" end
  return (", of which %.3g s compiling %s to machine code"):format(study.compile_seconds, plans)
end

function M.table(rows)
  M.flag(rows)
  local t = { { "method", "tol", "error", "time (s)", "median", "max", "runs", "rhs evals", "steps" } }
  local skipped, taylor, variational, grid, flagged = {}, false, false, false, {}
  for _, r in ipairs(rows) do
    if r.status == "skipped" then           -- one row per method, not per tolerance
      if not skipped[r.method] then t[#t + 1] = { r.method, "all", "-", "-", "-", "-", "-", "-", r.message } end
      skipped[r.method] = true
    elseif r.status == "failed" then
      t[#t + 1] = { r.method, ("%g"):format(r.tol), "failed", "-", "-", "-", "-", "-", r.message or "" }
    elseif r.status == "interrupted" then
      t[#t + 1] = { r.method, ("%g"):format(r.tol), "interrupted", "-", "-", "-", "-", "-",
        "stopped by Ctrl-C: the other rows shown were measured" }
    else
      t[#t + 1] = { r.method, ("%g"):format(r.tol), ("%.2e"):format(r.error) .. (r.flag and " !" or ""),
        ("%.3g"):format(r.time), r.time_median and ("%.3g"):format(r.time_median) or "-",
        r.time_max and ("%.3g"):format(r.time_max) or "-", tostring(r.runs or 1),
        tostring(r.nfev), tostring(r.steps) .. (r.grid and " (grid)" or "") }
      taylor = taylor or r.method == "taylor"
      variational = variational or r.method:match("^variational") ~= nil
      grid = grid or r.grid
      if r.flag then flagged[#flagged + 1] = ("%s at %g"):format(r.method, r.tol) end
    end
  end
  local text = require("nz.base.text").table(t)
  local study = rows.study
  if study then
    text = text .. ("\ntime: processor time of a run (this process only), the minimum of the runs (drawn), their "
      .. "median and maximum beside it; each point ran at least %d times and until it had spent %g s (budget), "
      .. "its runs spread over the whole timing%s"):format(M.MIN_RUNS, study.budget,
        rows.interrupted and " (until Ctrl-C stopped the study: fewer runs where the table says so)" or "")
    text = text .. ("\nnot timed: %sa warm-up run per method (%.3g s in all%s)"):format(
      study.reference_run and "the reference run and " or "", study.untimed_seconds or 0,
      compiled_text(study))
    if study.retimed then text = text .. "; a plan compiled during the timed runs: every point was timed again" end
    if study.evaluator_changed then
      text = text .. "\nwarning: a plan was compiled during the timed runs, twice: the times mix two evaluators"
    end
  end
  if #flagged > 0 then
    text = text .. "\n!: the error grew as the tolerance tightened (" .. table.concat(flagged, ", ")
      .. "): the error does not follow the tolerance there (the method's error control, roundoff, or the "
      .. "reference's own error); the diagram draws these points apart, off the method's line"
  end
  if skipped.taylor then
    text = text .. "\nskipped: taylor runs recorded systems with constraints of order 0, 1 and 2 only"
  end
  if grid then
    text = text .. "\n(grid): the output grid, not the tolerance, set these steps (msadams and msbdf, and every "
      .. "stepper with dense = false, stop at every output time; the others read their points off an interpolant "
      .. "unless its error control made many of them step ends); a larger dt shows the method's own cost"
  end
  if taylor then
    text = text .. "\ntaylor: rhs evals counts the series of the motion (one per step, of order ~ -ln(tol)/2 + 1);"
      .. " its output points come off each step's polynomial (dt adds no steps)"
  end
  if variational then
    text = text .. "\nvariational (of order p: variational, variational4, 6, 8): fixed steps, step = tol^(1/p); rhs "
      .. "evals counts the evaluations of q'' (or of the Lagrangian, where Newton's method solves the steps)"
  end
  local advice = M.recommend(rows)
  if advice then text = text .. "\n" .. advice end
  return text
end

-- Whether b's time is within the noise of a's (a the faster): b's fastest
-- run is no slower than a's median one, or the two minima are within
-- NOISE_FLOOR of each other.
function M.within_noise(a, b)
  if a.time > b.time then a, b = b, a end
  return b.time <= (a.time_median or a.time) or b.time <= a.time * (1 + M.NOISE_FLOOR)
end

-- One line: the cheapest method (least time) reaching each accuracy, the
-- accuracies being the decades the measured errors span, and the methods
-- within the noise of it.  Flagged rows are left out (their error does not
-- follow their tolerance).
function M.recommend(rows)
  M.flag(rows)
  local done = {}
  for _, r in ipairs(rows) do
    if measured(r) and not r.flag then done[#done + 1] = r end
  end
  if #done == 0 then return nil end
  local lo, hi = math.huge, 0
  for _, r in ipairs(done) do
    if r.error > 0 then lo, hi = math.min(lo, r.error), math.max(hi, r.error) end
  end
  if hi == 0 then return nil end
  local parts, last = {}, nil
  for e = math.ceil(math.log(hi, 10)), math.floor(math.log(math.max(lo, 1e-300), 10)), -2 do
    local level = 10 ^ e
    -- each method's cheapest row reaching the level
    local best, per = nil, {}
    for _, r in ipairs(done) do
      if r.error <= level then
        if not per[r.method] or r.time < per[r.method].time then per[r.method] = r end
        if not best or r.time < best.time then best = r end
      end
    end
    if best and best ~= last then
      local ties = {}
      for _, r in pairs(per) do
        if r ~= best and M.within_noise(best, r) then ties[#ties + 1] = r end
      end
      table.sort(ties, function(a, b) return a.time < b.time end)
      local part = ("error <= 1e%d: %s at tol %g (%.3g s)"):format(e, best.method, best.tol, best.time)
      if #ties > 0 then
        local names = {}
        for i, r in ipairs(ties) do names[i] = ("%s at tol %g (%.3g s)"):format(r.method, r.tol, r.time) end
        local last_name = table.remove(names)
        part = part .. ", within the noise of " .. (#names > 0 and table.concat(names, ", ") .. " and " or "") .. last_name
      end
      parts[#parts + 1] = part
      last = best
    end
  end
  if #parts == 0 then return nil end
  return "cheapest for each accuracy: " .. table.concat(parts, "; ")
end

-- Error against time (or work: x = "nfev" | "steps"), log-log, one line per
-- method; the flagged points apart, with their method and tolerance.
function M.diagram(rows, opts)
  opts = opts or {}
  M.flag(rows)
  local x = opts.x or (rows.study and rows.study.x) or "time"
  if not M.X[x] then
    error(require("nz.base.where").user_where() .. ("workprecision diagram: x = %s: \"time\", \"nfev\" or \"steps\" expected")
      :format(tostring(x)), 0)
  end
  local field = ({ time = "time", nfev = "nfev", steps = "steps" })[x]
  local by, order, odd, left_out = {}, {}, nil, false
  for _, r in ipairs(rows) do
    if measured(r) and r.error > 0 and r[field] > 0 then
      -- taylor's evaluations are series, not right-hand sides: not on the same axis
      if x == "nfev" and r.method == "taylor" then
        left_out = true
      else
        if not by[r.method] then
          order[#order + 1] = r.method
          -- a mark of its own per method (the terminal's plot has no colours)
          by[r.method] = { name = r.method, x = {}, y = {}, labels = {}, style = ("linespoints pt %d"):format(#order) }
        end
        local s = by[r.method]
        if r.flag then s = odd or { name = "error grew as tol tightened", x = {}, y = {}, labels = {} }; odd = s end
        s.x[#s.x + 1], s.y[#s.y + 1] = r[field], r.error
        -- each point says its tolerance (a flagged one its method too)
        s.labels[#s.labels + 1] = r.flag and ("%s %g"):format(r.method, r.tol) or ("%g"):format(r.tol)
      end
    end
  end
  local series = {}
  for i, m in ipairs(order) do series[i] = by[m] end
  if odd then
    odd.style = ("points pt %d"):format(#order + 1)
    series[#series + 1] = odd
  end
  local title = opts.title
  if left_out then title = (title and title .. "; " or "") .. "taylor left out: its evaluations are series" end
  local out = plot.lines{ series = series, logx = true, logy = true, file = opts.file, quiet = opts.quiet,
    xlabel = M.X[x], ylabel = "max error", title = title, width = opts.width, height = opts.height }
  if opts.file or opts.quiet then return out end
end

return M
