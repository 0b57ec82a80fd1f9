-- nz/analysis/longrun.lua - what accuracy costs over time: the same motion
-- over a long span with each method a user names, the error of its first
-- integrals (the energy T + V, and any the user gives as functions of t, q,
-- q') against time on log-log axes, the growth exponent fitted to it and
-- the processor time per period.  Beside nz.workprecision, whose timing
-- and evaluator it shares (one evaluator for the study, a warm-up run per
-- method not timed, processor time) and whose tolerance-to-options rule it
-- reads (a variational integrator of order p at step = tol^(1/p)).
--
-- The growth: the error of a non-symplectic method with a biased step
-- drifts (grows as t), a method whose error is the rounding alone follows
-- Brouwer's law (a random walk, t^(1/2)), and a variational integrator's
-- stays bounded (t^0) for times exponentially long in 1/h.  The exponent
-- is a least-squares fit on log-log axes of the error's RMS over windows
-- of a factor sqrt(10) in time, from `from` to t1: a random walk's single
-- values scatter by a factor of a few, its RMS over hundreds of samples far
-- less.
local plot = require "nz.draw.plot"
local args = require "nz.base.args"
local text = require "nz.base.text"
local options = require "nz.base.options"
local workprecision = require "nz.analysis.workprecision"

local M = {}

M.defaults = { methods = { "rk8pd", "taylor", "variational" }, tol = 1e-10, samples = 1000 }

local function any() return true end
local function list(v) return type(v) == "table" and getmetatable(v) == nil and #v > 0, "a non-empty list" end
local function positive(v) return type(v) == "number" and v > 0 and v < math.huge, "a positive number" end
local OPTIONS = options.declare("nz.longrun", {
  q0 = any, qd0 = any, t0 = any, t1 = any,       -- simulate checks these
  methods = list, tol = positive, period = positive, from = positive,
  samples = function(v) return math.type(v) == "integer" and v >= 10, "an integer >= 10" end,
  integrals = function(v) return type(v) == "table" and getmetatable(v) == nil, "a table {energy = true, name = function(t, q, qd) ... end}" end,
  plot = workprecision.checks.plot, quiet = workprecision.checks.quiet, simulate = workprecision.checks.simulate,
})

-- The methods as {label, options of simulate}: a name as nz.workprecision
-- takes it (at the study's tol), or a table of simulate's options with a
-- method (and a name, else one is made from them).
local function entries(opts, bad)
  local names, out, seen = workprecision.method_names(), {}, {}
  local function known(m)
    for _, n in ipairs(names) do if n == m then return true end end
    return false
  end
  for i, m in ipairs(opts.methods or M.defaults.methods) do
    local e
    if type(m) == "string" then
      if not known(m) then
        local near = options.nearest(m, names)
        bad("option 'methods': methods[%d] = '%s' is not a method%s (the methods: %s)", i, m,
          near and (" (did you mean '" .. near .. "'?)") or "", table.concat(names, " "))
      end
      e = { label = m, sim = workprecision.method_options(m, opts.tol or M.defaults.tol) }
    elseif type(m) == "table" and getmetatable(m) == nil and type(m.method) == "string" then
      local sim, parts = {}, {}
      for k, v in pairs(m) do if k ~= "name" then sim[k] = v end end
      for _, k in ipairs{ "order", "step", "rtol" } do
        if m[k] then parts[#parts + 1] = ("%s %.3g"):format(k, m[k]) end
      end
      e = { label = m.name or (m.method .. (#parts > 0 and (" " .. table.concat(parts, " ")) or "")), sim = sim }
    else
      bad("option 'methods': methods[%d] must be a method's name or a table {method = ..., step = ..., rtol = ...} "
        .. "of simulate's options, got %s", i, args.shown(m))
    end
    if seen[e.label] then bad("option 'methods': '%s' is listed twice (methods[%d] and methods[%d])", e.label, seen[e.label], i) end
    seen[e.label] = i
    out[#out + 1] = e
  end
  return out
end

-- The first integrals: {name, f(t, q, qd)}, the energy T + V first unless
-- integrals.energy = false.
local function integral_list(sys, opts, bad)
  local spec, out = opts.integrals or {}, {}
  if spec.energy ~= false then
    out[1] = { name = "energy", f = function(t, q, qd) return (sys:energy(t, q, qd)) end }
  end
  local names = {}
  for name, f in pairs(spec) do
    if name ~= "energy" then
      if type(name) ~= "string" or type(f) ~= "function" then
        bad("option 'integrals': each entry must be name = function(t, q, qd) returning a number (energy = true or "
          .. "false for T + V), got %s = %s", tostring(name), type(f))
      end
      names[#names + 1] = name
    elseif f ~= true and f ~= false then
      bad("option 'integrals': energy must be true or false, got %s", args.shown(f))
    end
  end
  table.sort(names)
  for _, name in ipairs(names) do out[#out + 1] = { name = name, f = spec[name] } end
  if #out == 0 then bad("option 'integrals': nothing to watch (energy = false and no function)") end
  return out
end

local function check(sys, opts)
  local bad = workprecision.check_call("longrun", sys, opts, OPTIONS, "{q0 =, t1 =, methods =, ...}")
  for _, key in ipairs{ "method", "rtol", "atol", "step", "order", "dt" } do
    if opts.simulate and opts.simulate[key] ~= nil then
      bad("option 'simulate': '%s' is set by the study for each run (methods =, tol =, samples =): drop it", key)
    end
  end
  return entries(opts, bad), integral_list(sys, opts, bad)
end

-- The growth of an error series e (samples at times x since t0) from
-- `from` on: the RMS over windows [a, a sqrt(10)), and the slope of their
-- logarithms against the windows' geometric middles by least squares (nil
-- with fewer than two windows, or an error that is 0 throughout).
function M.growth(x, e, from)
  local wins, xs, ys = {}, {}, {}
  local a, last = from, x[#x]
  while a < last * (1 - 1e-12) do
    local b = math.min(last, a * math.sqrt(10))
    local s, n = 0, 0
    for i = 1, #x do
      if x[i] >= a and (x[i] < b or (b == last and x[i] <= b)) then s, n = s + e[i] ^ 2, n + 1 end
    end
    if n > 0 then
      local rms = math.sqrt(s / n)
      wins[#wins + 1] = { from = a, to = b, rms = rms, n = n }
      if rms > 0 then xs[#xs + 1], ys[#ys + 1] = math.log(math.sqrt(a * b)), math.log(rms) end
    end
    a = b
  end
  if #xs < 2 then return nil, wins end
  local n, sx, sy, sxx, sxy = #xs, 0, 0, 0, 0
  for i = 1, n do sx, sy, sxx, sxy = sx + xs[i], sy + ys[i], sxx + xs[i] ^ 2, sxy + xs[i] * ys[i] end
  return (n * sxy - sx * sy) / (n * sxx - sx * sx), wins
end

-- One method's run, timed (processor time), and its rows: one per integral.
local function measure(sys, e, integrals, base, unit, from)
  local o = {}
  for k, v in pairs(base) do o[k] = v end
  for k, v in pairs(e.sim) do o[k] = v end
  workprecision.fit_step(o)
  local c0 = os.clock()
  local ok, tr = pcall(sys.simulate, sys, o)
  local seconds = os.clock() - c0
  if not ok then
    local rows = {}
    for _, I in ipairs(integrals) do
      rows[#rows + 1] = { method = e.label, integral = I.name, status = "failed", message = tostring(tr):match("^[^\n]*") }
    end
    return rows
  end
  local rows, t0, span = {}, tr.t[1], tr.t[#tr.t] - tr.t[1]
  local x = {}
  for i = 2, #tr.t do x[i - 1] = (tr.t[i] - t0) / unit end
  for _, I in ipairs(integrals) do
    -- the integral at point i: a finite number, or an error that says where
    local function value(i)
      local v = I.f(tr.t[i], tr.q[i], tr.qd[i])
      if not args.finite(v) then
        args.error("longrun", 2, "option 'integrals': '%s' gave %s at t = %s, q = %s, qd = %s (method %s): a finite "
          .. "number expected", I.name, args.shown(v), text.number(tr.t[i]), text.list(tr.q[i], "%.6g"),
          text.list(tr.qd[i], "%.6g"), e.label)
      end
      return v
    end
    local v0 = value(1)
    local scale = v0 ~= 0 and math.abs(v0) or 1
    local err = {}
    for i = 2, #tr.t do err[i - 1] = math.abs(value(i) - v0) / scale end
    local exponent, wins = M.growth(x, err, from)
    rows[#rows + 1] = { method = e.label, integral = I.name, status = tr.status, relative = v0 ~= 0,
      exponent = exponent, windows = wins, error = #wins > 0 and wins[#wins].rms or nil, final = err[#err],
      seconds = seconds, per_unit = seconds / (span / unit), steps = tr.stats.steps, nfev = tr.stats.nfev, x = x, e = err }
  end
  return rows
end

-- The table: one row per method and integral.
function M.table(rows)
  local study = rows.study or {}
  local per = study.period and "per period" or "per unit of t"
  local t = { { "method", "integral", "error", "at t1", "grows as", "time (s)", per, "steps", "rhs evals" } }
  for _, r in ipairs(rows) do
    if r.status == "failed" then
      t[#t + 1] = { r.method, r.integral, "failed", "-", "-", "-", "-", "-", r.message or "" }
    else
      t[#t + 1] = { r.method, r.integral, r.error and ("%.2e"):format(r.error) or "-", ("%.2e"):format(r.final),
        r.exponent and ("t^%.2f"):format(r.exponent) or "-", ("%.3g"):format(r.seconds), ("%.3g"):format(r.per_unit),
        tostring(r.steps), tostring(r.nfev) }
    end
  end
  local out = text.table(t)
  return out .. ("\nerror: |I(t) - I(t0)|, relative to |I(t0)| where that is not 0, its RMS over the last window "
    .. "(a factor sqrt(10) in time) and at t1; grows as: the slope of log(RMS) against log(t - t0) over windows of a "
    .. "factor sqrt(10) from %g %s on (a drift grows as t^1, the rounding's random walk as t^0.5 (Brouwer's law), a "
    .. "variational integrator's bounded error as t^0); time: processor time of the one run (a warm-up run per method "
    .. "before it, not timed)"):format(study.from or 0, study.period and "periods" or "units of t")
end

-- Error against time, log-log, a line per method and integral.
function M.diagram(rows, opts)
  opts = opts or {}
  local series, study = {}, rows.study or {}
  for _, r in ipairs(rows) do
    if r.x then
      -- at most ~200 points: the largest error of each of 200 bins equal on the log axis
      local x, y, lo, hi = {}, {}, math.huge, 0
      for _, v in ipairs(r.x) do if v > 0 then lo, hi = math.min(lo, v), math.max(hi, v) end end
      local bins, best = 200, {}
      for i, v in ipairs(r.x) do
        if v > 0 and r.e[i] > 0 then
          local b = hi > lo and math.floor((math.log(v) - math.log(lo)) / (math.log(hi) - math.log(lo)) * (bins - 1)) or 0
          if not best[b] or r.e[i] > r.e[best[b]] then best[b] = i end
        end
      end
      for b = 0, bins - 1 do
        if best[b] then x[#x + 1], y[#y + 1] = r.x[best[b]], r.e[best[b]] end
      end
      series[#series + 1] = { name = ("%s, %s%s"):format(r.method, r.integral, r.exponent and
        (" (slope %.2f)"):format(r.exponent) or ""), x = x, y = y, style = "lines" }
    end
  end
  return plot.lines{ series = series, logx = true, logy = true, file = opts.file, quiet = opts.quiet,
    xlabel = study.period and "t - t0 (periods)" or "t - t0", ylabel = "error of the integral",
    title = opts.title, width = opts.width, height = opts.height }
end

-- nz.longrun(sys, {q0 =, qd0 =, t0 =, t1 =, methods = {...}, tol =, period =,
--   from =, samples =, integrals = {energy = true, name = function(t, q, qd)},
--   plot =, quiet =, simulate = {...}})
function M.run(sys, opts)
  local list, integrals = check(sys, opts)
  local samples = opts.samples or M.defaults.samples
  local t0 = opts.t0 or 0
  local span = opts.t1 - t0
  local unit = opts.period or 1
  local dt = span / samples
  local from = opts.from or math.max(opts.period and 10 or 0, 10 * dt / unit)
  local base = { q0 = opts.q0, qd0 = opts.qd0, t0 = opts.t0, t1 = opts.t1, dt = dt, progress = false }
  for k, v in pairs(opts.simulate or {}) do base[k] = v end
  local restore = workprecision.one_evaluator(sys)
  local rows = { study = { period = opts.period, from = from, span = span, samples = samples } }
  local ok, err = pcall(function()
    -- not timed: a run per method over a hundredth of the span (the plans built and compiled)
    for _, e in ipairs(list) do
      local o = {}
      for k, v in pairs(base) do o[k] = v end
      for k, v in pairs(e.sim) do o[k] = v end
      o.t1, o.dt = t0 + span / 100, dt
      workprecision.fit_step(o)
      pcall(sys.simulate, sys, o)
    end
    workprecision.wait_for_compiles(sys)
    for _, e in ipairs(list) do
      for _, r in ipairs(measure(sys, e, integrals, base, unit, from)) do rows[#rows + 1] = r end
    end
  end)
  restore()
  if not ok then error(err, 0) end
  rows.study.evaluator = workprecision.evaluator_text(sys, workprecision.native_state(sys))
  local text = ("Long run of '%s', t = %g .. %g%s: the error of its first integrals against time\nevaluator: %s\n%s")
    :format(sys.name, t0, opts.t1, opts.period and (" (%g periods of %g)"):format(span / opts.period, opts.period) or "",
      rows.study.evaluator, M.table(rows))
  setmetatable(rows, { __tostring = function() return text end })
  if not opts.quiet then require("nz.base.frontend").print(text) end
  if opts.plot then
    M.diagram(rows, { file = type(opts.plot) == "string" and opts.plot or nil,
      title = ("long run: %s"):format(sys.name) })
  end
  if opts.quiet then return rows end
  return require("nz.base.frontend").shown(rows)
end

return M
