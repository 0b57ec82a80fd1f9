-- nz/workprecision.lua - what accuracy costs in time: the same motion with
-- each method at each tolerance, its error against a reference (a closed
-- form, or the most accurate method at a much tighter tolerance), the wall
-- time and the right-hand-side evaluations it took; a table, and the
-- work-precision diagram (error against time, log-log, a line per method).
-- "taylor" (Taylor's method) runs where it applies: a recorded system, free
-- or with constraints of order 0, 1, 2.
local plot = require "nz.plot"
local core = require "nz.core"

local M = {}

M.defaults = {
  methods = { "rk4", "rkf45", "rkck", "rk8pd", "rk4imp", "bsimp", "msadams", "msbdf", "taylor" },
  tols = { 1e-4, 1e-6, 1e-8, 1e-10 },
  reference_method = "rk8pd", reference_tol = 1e-13,
}

local function max_error(tr, ref)
  local worst = 0
  for i = 1, #tr.t do
    local want = ref(tr.t[i], i)
    for j = 1, #want do worst = math.max(worst, math.abs(tr.q[i][j] - want[j])) end
  end
  return worst
end

-- nz.workprecision(sys, {q0 =, qd0 =, t0 =, t1 =, dt =, methods = {...},
--   tols = {...}, reference = function(t) return q end (optional),
--   plot = true | "file.svg", quiet = false, simulate = {extra options}})
-- Returns the rows {method, tol, error, time, nfev, steps, status}.
function M.run(sys, opts)
  if type(opts) ~= "table" then error("workprecision: options {q0 =, t1 =, ...} expected", 2) end
  local methods = opts.methods or M.defaults.methods
  local tols = opts.tols or M.defaults.tols
  local base = { q0 = opts.q0, qd0 = opts.qd0, t0 = opts.t0, t1 = opts.t1, dt = opts.dt, progress = false }
  for k, v in pairs(opts.simulate or {}) do base[k] = v end
  local function run(method, tol)
    local o = {}
    for k, v in pairs(base) do o[k] = v end
    o.method, o.rtol, o.atol = method, tol, tol * 1e-2
    return sys:simulate(o)
  end
  local reference, ref_text = opts.reference, "closed form"
  if not reference then
    local ref = run(opts.reference_method or M.defaults.reference_method, opts.reference_tol or M.defaults.reference_tol)
    reference = function(_, i) return ref.q[i] end
    ref_text = ("%s at rtol %g"):format(opts.reference_method or M.defaults.reference_method,
      opts.reference_tol or M.defaults.reference_tol)
  end
  -- Taylor's method runs recorded systems with constraints of order 0, 1, 2
  -- (nz/simulate.lua): where it does not apply its rows say why instead of
  -- failing.
  local function taylor_skip()
    if sys.nc > 0 and require("nz.constraints").level(sys) then return "constraints of order 3 or more" end
    if not sys.recording then return "not recorded" end
    if base.monitors and base.monitors.work then return "work monitor" end
  end
  local rows, stopped = {}, false
  for _, method in ipairs(methods) do
    for _, tol in ipairs(tols) do
      local skip = method == "taylor" and taylor_skip()
      local ok, tr
      if not skip then ok, tr = pcall(run, method, tol) end
      -- Ctrl-C: the run in progress is marked and nothing more is started
      -- (the rows measured so far are kept and returned)
      if (ok and tr.status == "interrupted") or (not ok and tr == core.interrupted) or core.mech.interrupted() then
        rows[#rows + 1] = { method = method, tol = tol, status = "interrupted", message = "stopped by Ctrl-C" }
        stopped = true
        break
      end
      if method == "taylor" and not ok and not skip then
        skip = tostring(tr):match("method 'taylor' cannot run this system: ([^;\n]*)")
      end
      local row = { method = method, tol = tol }
      if skip then
        row.status, row.message = "skipped", "skipped: " .. skip
      elseif ok then
        row.error, row.time, row.nfev, row.steps, row.status = max_error(tr, reference), tr.stats.wall, tr.stats.nfev, tr.stats.steps, tr.status
        -- the grid set the steps: a GSL stepper without dense output
        -- (msadams, msbdf, dense = false) stopped at about every output
        -- point, or the interpolant's error control made many points step
        -- ends (nz/simulate.lua says which in tr.stats.grid_why)
        row.grid = method ~= "taylor" and tr.stats.grid_why ~= nil
        row.grid_why = row.grid and tr.stats.grid_why or nil
      else
        row.status, row.message = "failed", tostring(tr):match("^[^\n]*")
      end
      rows[#rows + 1] = row
    end
    if stopped then break end
  end
  rows.interrupted = stopped or nil
  local text = ("Work-precision of '%s', t = %g .. %g, error = max over the output grid of |q - q_ref| (reference: %s)\n%s")
    :format(sys.name, base.t0 or 0, base.t1, ref_text, M.table(rows))
  -- the rows print as their table (print(rows) in a script, rows typed at the prompt)
  setmetatable(rows, { __tostring = function() return text end })
  if not opts.quiet then print(text) end
  if opts.plot and not stopped then
    M.diagram(rows, { file = type(opts.plot) == "string" and opts.plot or nil, title = "work-precision: " .. sys.name })
  end
  if opts.quiet then return rows end
  return require("nz.repl").shown(rows)       -- typed at the prompt: the table once
end

function M.table(rows)
  local t = { { "method", "tol", "error", "time (s)", "rhs evals", "steps" } }
  local skipped, taylor, grid = {}, false, false
  for _, r in ipairs(rows) do
    if r.status == "skipped" then           -- one row per method, not per tolerance
      if not skipped[r.method] then t[#t + 1] = { r.method, "all", "-", "-", "-", r.message } end
      skipped[r.method] = true
    elseif r.status == "failed" then
      t[#t + 1] = { r.method, ("%g"):format(r.tol), "failed", "-", "-", r.message or "" }
    elseif r.status == "interrupted" then
      t[#t + 1] = { r.method, ("%g"):format(r.tol), "interrupted", "-", "-", "stopped by Ctrl-C: the rows above were measured" }
    else
      t[#t + 1] = { r.method, ("%g"):format(r.tol), ("%.2e"):format(r.error), ("%.4f"):format(r.time),
        tostring(r.nfev), tostring(r.steps) .. (r.grid and " (grid)" or "") }
      taylor = taylor or r.method == "taylor"
      grid = grid or r.grid
    end
  end
  local text = require("nz.system").table_text(t)
  if next(skipped) then
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
  local advice = M.recommend(rows)
  if advice then text = text .. "\n" .. advice end
  return text
end

-- One line: the cheapest method (least time) reaching each accuracy, the
-- accuracies being the decades the measured errors span.
function M.recommend(rows)
  local done = {}
  for _, r in ipairs(rows) do
    if r.status ~= "failed" and r.status ~= "skipped" and r.status ~= "interrupted" and r.error and r.time then
      done[#done + 1] = r
    end
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
    local best
    for _, r in ipairs(done) do
      if r.error <= level and (not best or r.time < best.time) then best = r end
    end
    if best and best ~= last then
      parts[#parts + 1] = ("error <= 1e%d: %s at tol %g (%.3g s)"):format(e, best.method, best.tol, best.time)
      last = best
    end
  end
  if #parts == 0 then return nil end
  return "cheapest for each accuracy: " .. table.concat(parts, "; ")
end

-- Error against time, log-log, one line per method.
function M.diagram(rows, opts)
  local by, order = {}, {}
  for _, r in ipairs(rows) do
    if r.status ~= "failed" and r.status ~= "skipped" and r.error > 0 and r.time > 0 then
      if not by[r.method] then
        order[#order + 1] = r.method
        -- a mark of its own per method (the terminal's plot has no colours)
        by[r.method] = { name = r.method, x = {}, y = {}, labels = {}, style = ("linespoints pt %d"):format(#order) }
      end
      local s = by[r.method]
      s.x[#s.x + 1], s.y[#s.y + 1] = r.time, r.error
      s.labels[#s.labels + 1] = ("%g"):format(r.tol)     -- each point says its tolerance
    end
  end
  local series = {}
  for i, m in ipairs(order) do series[i] = by[m] end
  local out = plot.lines{ series = series, logx = true, logy = true, file = opts.file, quiet = opts.quiet,
    xlabel = "wall time (s)", ylabel = "max error", title = opts.title, width = opts.width, height = opts.height }
  if opts.file or opts.quiet then return out end
end

return M
