-- nz/analysis/eigen_sweep.lua - sys:eigen_sweep{...}: the eigenvalues of the
-- linearized motion against a parameter (a forward speed, a spin rate, a
-- mass), the parameter values where the motion changes stability, located
-- to a tolerance, and the sweep as a table, a CSV file and a plot of the
-- real and imaginary parts (as Fig. 3 of Meijaard et al. 2007 draws the
-- bicycle's).
--
-- Each value runs sys:linearize with the options `at(value)` returns (it
-- may also set sys.params).  The motion at a value is
--   unstable  when some eigenvalue has a real part above thr,
--   stable    when every one is below -thr,
--   neutral   otherwise (every mode on the imaginary axis, as a
--             conservative system's, or a zero eigenvalue),
-- thr = 1e-8 (1 + max |A_ij|) (linearize.threshold: above what rounding
-- does to the eigenvalues, even where modes meet and the eigenvalue is
-- defective).
-- Between two neighbouring values whose status differs, the change is
-- located: by Brent's method (GSL, core.mech.root_brent) on the largest real
-- part when it changes sign (a mode crossing the imaginary axis: the
-- bicycle's weave and capsize speeds), else by bisection on the status (a
-- change to or from neutral: two modes meeting on the imaginary axis, as
-- when a top starts to sleep, where the largest real part only touches 0).
local linearize = require "nz.analysis.linearize"
local options = require "nz.base.options"

local M = {}

local Sweep = {}
Sweep.__index = Sweep

local function fail(sys, ...) require("nz.base.where").method_error("eigen_sweep", sys, ...) end

local finite = require("nz.base.args").finite

-- The eigenvalues at one value, their largest real part and the status.
local function at_value(sys, opts, v)
  local lopts = opts.at(v)
  if type(lopts) ~= "table" then fail(sys, "at(%g) must return the options of sys:linearize (a table), got %s", v, type(lopts)) end
  options.check(lopts, linearize.OPTIONS, function(fmt, ...) fail(sys, "at(%g) returned " .. fmt, v, ...) end)
  local lin = sys:linearize(lopts)
  local ev = lin:eigenvalues()
  local top, which = -math.huge, nil
  for _, e in ipairs(ev) do
    if e[1] > top then top, which = e[1], e end
  end
  local thr = linearize.threshold(lin.A)
  return { value = v, eigenvalues = ev, abscissa = top, status = linearize.stability(top, thr), leading = which,
    residual = lin.residual, threshold = thr }
end

-- Where the status changes between the rows a and b (a.value < b.value).
local function locate(sys, opts, a, b, tol)
  local mech = require("nz.core").mech
  local how, x, there
  if a.status ~= "neutral" and b.status ~= "neutral" then
    how = "Brent's method on the largest real part"
    x = mech.root_brent(function(v) return at_value(sys, opts, v).abscissa end, a.value, b.value, tol)
    there = at_value(sys, opts, x)
  else
    how = "bisection on the status"
    local lo, hi, rlo, rhi = a.value, b.value, a, b
    while hi - lo > tol do
      local mid = 0.5 * (lo + hi)
      if mid <= lo or mid >= hi then break end
      local r = at_value(sys, opts, mid)
      if r.status == a.status then lo, rlo = mid, r else hi, rhi = mid, r end
    end
    x = 0.5 * (lo + hi)
    -- the mode that changes is read where it has left the axis: the end of
    -- the last bracket that is not neutral
    there = rlo.status ~= "neutral" and rlo or rhi
  end
  local lead = there.leading
  return { value = x, from = a.status, to = b.status, how = how,
    kind = math.abs(lead[2]) > there.threshold and "oscillatory" or "real", frequency = math.abs(lead[2]), eigenvalue = lead }
end

-- A run of neutral rows between an unstable and a stable row (either way
-- round) is one change through the axis when the largest real part has a
-- simple root there: Brent's root, with the two statuses found just on
-- either side of it (a hundredth of the bracket away, wider than the
-- neutral band ~ threshold / slope).  nil when the rows around the root are
-- neutral too: a neutral interval, whose two edges are changes of their own.
local function through(sys, opts, a, b, tol)
  local c = locate(sys, opts, a, b, tol)
  local d = 0.01 * (b.value - a.value)
  if at_value(sys, opts, c.value - d).status == a.status and at_value(sys, opts, c.value + d).status == b.status then
    return c
  end
end

-- The changes of stability along the rows.
local function crossings(sys, opts, rows, tol)
  local out = {}
  local function pairwise(i, j)
    for m = i, j - 1 do
      if rows[m].status ~= rows[m + 1].status then out[#out + 1] = locate(sys, opts, rows[m], rows[m + 1], tol) end
    end
  end
  local i = 1
  while i < #rows do
    local j = i + 1
    if rows[i].status ~= "neutral" then
      while j < #rows and rows[j].status == "neutral" do j = j + 1 end
    end
    local c = j > i + 1 and rows[j].status ~= "neutral" and rows[j].status ~= rows[i].status
      and through(sys, opts, rows[i], rows[j], tol)
    if c then out[#out + 1] = c else pairwise(i, j) end
    i = j
  end
  return out
end

local function run(sys, opts)
  local values = opts.values
  if type(values) ~= "table" or #values < 2 then fail(sys, "values: a list of at least 2 increasing numbers expected") end
  for i, v in ipairs(values) do
    if not finite(v) then fail(sys, "values[%d] is not a finite number", i) end
    if i > 1 and v <= values[i - 1] then fail(sys, "values must increase (values[%d] = %g after %g)", i, v, values[i - 1]) end
  end
  if type(opts.at) ~= "function" then
    fail(sys, "at: a function of the parameter value returning the options of sys:linearize expected")
  end
  local span = values[#values] - values[1]
  local tol = opts.tol or 1e-10 * span
  if not finite(tol) or tol <= 0 then fail(sys, "tol must be a positive number") end
  local sw = setmetatable({ system = sys, parameter = opts.parameter or "parameter", rows = {}, crossings = {},
    tol = tol }, Sweep)
  for i, v in ipairs(values) do sw.rows[i] = at_value(sys, opts, v) end
  sw.crossings = crossings(sys, opts, sw.rows, tol)
  return sw
end

local SWEEP_OPTIONS = options.declare("sys:eigen_sweep", { "values", "at", "parameter", "tol" })

function M.sweep(sys, opts)
  if type(opts) ~= "table" then fail(sys, "options expected: sys:eigen_sweep{ values = {...}, at = function(v) return {...} end }") end
  options.check(opts, SWEEP_OPTIONS, function(...) fail(sys, ...) end)
  -- at(v) may set sys.params: they are restored after the sweep, as
  -- nz.sweep does, even when it fails
  local saved = {}
  for key, val in pairs(sys.params) do saved[key] = val end
  local ok, res = pcall(run, sys, opts)
  for key in pairs(sys.params) do if saved[key] == nil then sys.params[key] = nil end end
  for key, val in pairs(saved) do sys.params[key] = val end
  if not ok then error(res, 0) end
  return res
end

-- The eigenvalues of a row as text: a complex pair once, as re +- im i,
-- and what is rounding shown as 0 by the rule that decides the stability
-- (linearize.eigenvalue_text: print(lin) shows the same numbers).
local function listed(ev, thr)
  local out = {}
  for _, e in ipairs(ev) do out[#out + 1] = linearize.eigenvalue_text(e[1], e[2], thr) end
  return table.concat(out, ", ")
end

function Sweep:__tostring()
  local t = { { self.parameter, "eigenvalues", "stability" } }
  for _, r in ipairs(self.rows) do t[#t + 1] = { ("%.6g"):format(r.value), listed(r.eigenvalues, r.threshold), r.status } end
  local lines = { ("eigenvalues of '%s' against %s"):format(self.system.name, self.parameter),
    require("nz.base.text").table(t, "  ") }
  if #self.crossings == 0 then
    lines[#lines + 1] = "  no change of stability between these values"
  end
  for _, c in ipairs(self.crossings) do
    lines[#lines + 1] = ("  %s = %.12g: %s -> %s (%s%s; located to %.1e by %s)"):format(self.parameter, c.value, c.from,
      c.to, c.kind == "oscillatory" and "an oscillatory mode" or "a real mode",
      c.kind == "oscillatory" and (", %.6g rad/s"):format(c.frequency) or "", self.tol, c.how)
  end
  return table.concat(lines, "\n")
end

-- The sweep as CSV: the parameter, then re and im of each eigenvalue (as
-- sorted: growth rate first), then the status; one row per value.
function Sweep:csv(file)
  local n = 0
  for _, r in ipairs(self.rows) do n = math.max(n, #r.eigenvalues) end
  local head = { self.parameter }
  for j = 1, n do head[#head + 1] = ("re%d,im%d"):format(j, j) end
  head[#head + 1] = "status"
  local lines = { table.concat(head, ",") }
  for _, r in ipairs(self.rows) do
    local row = { require("nz.base.formula").number(r.value) }
    for j = 1, n do
      local e = r.eigenvalues[j]
      row[#row + 1] = e and (require("nz.base.formula").number(e[1]) .. "," .. require("nz.base.formula").number(e[2])) or ","
    end
    row[#row + 1] = r.status
    lines[#lines + 1] = table.concat(row, ",")
  end
  local text = table.concat(lines, "\n") .. "\n"
  if file then
    local f = assert(io.open(file, "w"))
    f:write(text)
    f:close()
    return file
  end
  return text
end

-- The real parts and the (positive) imaginary parts against the parameter,
-- as points (modes are not followed from one value to the next), with the
-- changes of stability marked on the axis.  opts: file, title, width, height,
-- quiet.
local PLOT_OPTIONS = options.declare("sw:plot", { "file", "title", "width", "height", "quiet" })

function Sweep:plot(opts)
  opts = opts or {}
  local function bad(fmt, ...) error(("%ssw:plot: " .. fmt):format(require("nz.base.where").user_where(), ...), 0) end
  if type(opts) ~= "table" then bad("options {file =, title =, width =, height =, quiet =} expected, got %s", type(opts)) end
  options.check(opts, PLOT_OPTIONS, bad)
  if opts.title ~= nil and type(opts.title) ~= "string" then bad("title = %s: a string expected", tostring(opts.title)) end
  if opts.quiet ~= nil and type(opts.quiet) ~= "boolean" then bad("quiet = %s: true or false expected", tostring(opts.quiet)) end
  local re = { name = "Re(lambda)", x = {}, y = {}, style = "points pt 7 ps 0.4" }
  local im = { name = "Im(lambda)", x = {}, y = {}, style = "points pt 6 ps 0.4" }
  for _, r in ipairs(self.rows) do
    for _, e in ipairs(r.eigenvalues) do
      re.x[#re.x + 1], re.y[#re.y + 1] = r.value, e[1]
      if e[2] > 0 then im.x[#im.x + 1], im.y[#im.y + 1] = r.value, e[2] end
    end
  end
  local series = { re }
  if #im.x > 0 then series[2] = im end
  for _, c in ipairs(self.crossings) do
    series[#series + 1] = { name = ("%s = %.6g"):format(self.parameter, c.value), x = { c.value, c.value },
      y = { 0, 0 }, style = "points pt 2 ps 1.5" }
  end
  local out = require("nz.draw.plot").lines{ series = series, file = opts.file, width = opts.width, height = opts.height,
    title = opts.title or ("eigenvalues of %s against %s"):format(self.system.name, self.parameter),
    xlabel = self.parameter, ylabel = "eigenvalue (1/s)", quiet = opts.quiet }
  -- the terminal's plot is printed already: nothing for the session to print
  -- again (quiet = true: not printed, returned, as tr:plot does)
  if opts.file or opts.quiet then return out end
end

-- sw.plot{} (a dot) is named as such (nz/base/where.lua); help finds the methods here.
require("nz.base.where").methods(Sweep, "sw", "eigenvalue sweep")
M.Sweep = Sweep

return M
