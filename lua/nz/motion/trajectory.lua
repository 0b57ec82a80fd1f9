-- nz/motion/trajectory.lua - what sys:simulate returns: the motion on the output
-- grid (tr.t[i], tr.q[i][j], tr.qd[i][j], tr.qdd[i][j], tr.lambda[i][r]),
-- what it cost (tr.stats), how it ended (tr.status), the constraint
-- violation, and the monitors a scene asked for.  Methods: a summary
-- (tostring), column, csv, plot, residuals, consistency, section, animate.
local core = require "nz.core"
local plot = require "nz.draw.plot"

local Trajectory = { __name = "nz.trajectory" }
Trajectory.__index = Trajectory

local M = { Trajectory = Trajectory }

-- The points are kept in C (tr._points: q, q', q'' and the multipliers of
-- each point in one array of doubles, src/lua/lua_points.c, which the loop
-- appends to) and tr.t.  tr.q, tr.qd, tr.qdd and tr.lambda are views of
-- them: point i's table is made when tr.q[i] is first read, then kept (the
-- same table at every read), so a run with many output points pays for its
-- numbers, not for four tables per point.  A view has the length of tr.t,
-- and ipairs, pairs and table.unpack see every point.  tr._lambda_cols,
-- when set, lists the stored multipliers tr.lambda shows, in order (a
-- contact run leaves out the rows that are no forces: contact_run.lua).
local GROUPS = { q = 1, qd = 2, qdd = 3, lambda = 4 }

local function rows(tr, group)
  local function row(self, i)
    local r = tr._points and core.mech.points_row(tr._points, i, group)
    local cols = group == GROUPS.lambda and tr._lambda_cols
    if r and cols then
      local kept = {}
      for c, j in ipairs(cols) do kept[c] = r[j] end
      r = kept
    end
    if r then rawset(self, i, r) end
    return r
  end
  return setmetatable({}, {
    __index = function(self, i) return math.type(i) == "integer" and row(self, i) or nil end,
    __len = function() return #tr.t end,
    __pairs = function(self)
      return function(_, i)
        i = i + 1
        if i <= #tr.t then return i, self[i] end
      end, self, 0
    end,
  })
end

function M.new(sys, opts)
  local tr = setmetatable({
    system = sys, coords = sys.coords, method = opts.method, rtol = opts.rtol, atol = opts.atol,
    step = opts.step, t = {}, violation = sys.nc > 0 and {} or nil,
    energy = nil, generalized_energy = nil, work = nil, events = {},
    stats = { steps = 0, rejected = 0, nfev = 0, njev = 0, wall = 0 },
    status = "running",
  }, Trajectory)
  for name, group in pairs(GROUPS) do tr[name] = rows(tr, group) end
  return tr
end

-- A point appended from Lua (as the loop in C appends its points: the
-- values first, t last); returns its index.
function M.append(tr, t, q, qd, qdd, lambda)
  tr._points = tr._points or core.mech.points_new(#q, #lambda)
  core.mech.points_push(tr._points, q, qd, qdd, lambda)
  local n = #tr.t + 1
  tr.t[n] = t
  return n
end

-- Column j of q, qd, qdd or lambda (src) as a new list: from the points in
-- C where the trajectory keeps them, else from its points' tables.
local function column_of(self, src, j)
  if self._points then
    if src == "lambda" and self._lambda_cols then j = self._lambda_cols[j] end
    return j and core.mech.points_column(self._points, GROUPS[src], j) or {}
  end
  local out, points = {}, self[src]
  for i = 1, #self.t do out[i] = points[i][j] end
  return out
end

function Trajectory:__len() return #self.t end

local function short(v) return require("nz.base.text").list(v, "%.6g") end

local function max_abs_change(list)
  if not list or #list == 0 then return nil end
  local m = 0
  for i = 2, #list do m = math.max(m, math.abs(list[i] - list[1])) end
  return m
end

function Trajectory:__tostring()
  local n = #self.t
  local s = self.stats
  local lines = {
    ("trajectory of '%s': %d points, t = %s .. %s, method %s (%s)"):format(self.system.name, n,
      n > 0 and ("%.6g"):format(self.t[1]) or "?", n > 0 and ("%.6g"):format(self.t[n]) or "?", self.method,
      (self.method == "variational" and ("order %d, "):format(s.order) or "")
        .. (self.step and ("fixed step %g"):format(self.step) or ("rtol %g, atol %g"):format(self.rtol, self.atol))),
    ("  cost: %d steps (%d rejected), %d right-hand sides, %d Jacobians, %.3f s"):format(
      s.steps, s.rejected, s.nfev, s.njev, s.wall),
    ("  status: %s%s"):format(self.status, self.message and (": " .. self.message) or ""),
  }
  if n > 0 then lines[#lines + 1] = ("  final q = %s, qd = %s"):format(short(self.q[n]), short(self.qd[n])) end
  if self.violation and #self.violation > 0 then
    local m = 0
    for i = 1, #self.violation do m = math.max(m, self.violation[i]) end
    lines[#lines + 1] = ("  constraint violation: max %.3g, final %.3g"):format(m, self.violation[#self.violation])
  end
  local dE = max_abs_change(self.energy)
  if dE then lines[#lines + 1] = ("  energy T + V: drift up to %.3g; generalized energy H: drift up to %.3g"):format(dE, max_abs_change(self.generalized_energy)) end
  if self.work then
    local c = {}
    for i = 1, #self.work do c[i] = self.energy[i] - self.work[i] end
    lines[#lines + 1] = ("  work of moving constraints: %.6g; T + V - work: drift up to %.3g"):format(self.work[#self.work], max_abs_change(c))
  end
  if #self.events > 0 then lines[#lines + 1] = ("  events: %d (first '%s' at t = %.10g)"):format(#self.events, self.events[1].name, self.events[1].t) end
  if self.contacts then lines[#lines + 1] = require("nz.motion.contact_run").summary(self) end
  return table.concat(lines, "\n")
end

-- The names of the multipliers' columns: lambda1, lambda2, ..., and with
-- contacts (nz/motion/contact_run.lua) each contact's N.name and T.name.
local function lambda_names(self)
  if self.lambda_names then return self.lambda_names end
  local names = {}
  for r = 1, self.system.nc do names[r] = "lambda" .. r end
  return names
end

-- The derivatives above q'' a run holds (constraints of order p >= 3,
-- whose state holds q'' .. q^(p-1)): the highest order m of q^(m) that
-- tr:column gives, and how: the state's levels (tr.higher: q''' ..
-- q^(p-1)), the root of a level nonlinear in q^(p) (tr.top), or, for a
-- constraint of order 3 linear in q''', q''' from the equations of level 3
-- at each point (sys:reduced with the point's q'' and lambda, computed when
-- asked).  2 when the run holds nothing above q''.
local function highest(self)
  local m = 2
  if self.higher and self.higher[1] then m = 2 + #self.higher[1] end
  if self.top then m = m + 1
  elseif self.system.nc > 0 and not self.higher then
    local ok, p = pcall(require("nz.model.constraints").level, self.system)
    if ok and p == 3 then m = 3 end
  end
  return m
end

-- A name as a message shows it: in single quotes, or double ones when it
-- has primes ("x'''", never 'x''''').
local function quoted(name)
  name = tostring(name)
  return name:find("'", 1, true) and ('"' .. name .. '"') or ("'" .. name .. "'")
end

-- The names tr:column takes for this trajectory, for a message.
local function quantities(self)
  local names = { "t" }
  for m = 0, highest(self) do
    for _, c in ipairs(self.coords) do names[#names + 1] = c .. ("'"):rep(m) end
  end
  for _, name in ipairs(lambda_names(self)) do names[#names + 1] = name end
  if self.energy then names[#names + 1] = "E"; names[#names + 1] = "H" end
  if self.work then names[#names + 1] = "work" end
  if self.violation then names[#names + 1] = "violation" end
  return table.concat(names, ", ")
end

-- A wrong name is the caller's mistake: said at the user's line (tr:plot
-- and tr:column are called from the user's code; level 2 named trajectory.lua
-- when tr:plot asked), with the names this trajectory has.
local function column_error(fmt, ...)
  error(require("nz.base.where").user_where() .. fmt:format(...), 0)
end

-- q^(m) of coordinate j at every point, m >= 3 (see highest).
local function level_values(self, j, m)
  local out = {}
  if self.higher and self.higher[1] and m - 2 <= #self.higher[1] then
    for i = 1, #self.t do out[i] = self.higher[i][m - 2][j] end
    return out
  end
  if self.top then
    for i = 1, #self.t do out[i] = self.top[i][j] end
    return out
  end
  if not self._q3d then           -- level 3, linear in q''': from its equations, once
    local sys, q3d = self.system, {}
    for i = 1, #self.t do
      q3d[i] = sys:reduced(self.t[i], self.q[i], self.qd[i], nil, { qdd = self.qdd[i], lambdas = { self.lambda[i] } })
    end
    self._q3d = q3d
  end
  for i = 1, #self.t do out[i] = self._q3d[i][j] end
  return out
end

-- Values of a named quantity over the trajectory: a coordinate name, its
-- velocity "name'", acceleration "name''" (and "name'''", ... where the
-- run holds them), "t", "E" (T + V), "H", "work", "violation", or
-- "lambda1", "lambda2", ...
function Trajectory:column(name)
  if name == "t" then return self.t end
  if type(name) ~= "string" then
    column_error("trajectory: a quantity is named by a string, got %s (quantities: %s)", type(name), quantities(self))
  end
  local lists = { E = self.energy, H = self.generalized_energy, work = self.work, violation = self.violation }
  if lists[name] then return lists[name] end
  if lists[name] == nil and (name == "E" or name == "H" or name == "work") then
    column_error("trajectory: '%s' was not recorded: ask for it with monitors = {energy = true, work = true} "
      .. "in simulate (quantities of this one: %s)", name, quantities(self))
  end
  for r, lname in ipairs(lambda_names(self)) do
    if lname == name then return column_of(self, "lambda", r) end
  end
  local base, primes = name:match("^(.-)('*)$")
  for j, c in ipairs(self.coords) do
    if c == base then
      local m = #primes
      if m >= 3 and m <= highest(self) then return level_values(self, j, m) end
      local src = ({ [0] = "q", "qd", "qdd" })[m]
      if not src then
        column_error("trajectory: no quantity %s: this run holds the derivatives up to %s only (constraints of "
          .. "order 3 or more give a run q''' and above) (quantities: %s)", quoted(name), c .. ("'"):rep(highest(self)),
          quantities(self))
      end
      return column_of(self, src, j)
    end
  end
  column_error("trajectory: no quantity %s (quantities: %s)", quoted(name), quantities(self))
end

-- The header and the rows of tr:csv, to the open file f.
local function write_csv(self, f)
  local head, cols = { "t" }, { self.t }
  local function add(name, col) head[#head + 1], cols[#cols + 1] = name, col end
  for m, src in ipairs{ "q", "qd", "qdd" } do
    for j, c in ipairs(self.coords) do add(c .. ("'"):rep(m - 1), column_of(self, src, j)) end
  end
  -- q''' and above where the run holds them (constraints of order >= 3), as tr:column gives them
  for m = 3, highest(self) do
    for j, c in ipairs(self.coords) do add(c .. ("'"):rep(m), level_values(self, j, m)) end
  end
  local names, width = lambda_names(self), #(self.lambda[1] or {})
  for r = 1, width do add(names[r] or ("lambda" .. r), column_of(self, "lambda", r)) end
  for _, name in ipairs{ "violation", "E", "H", "work" } do
    local ok, col = pcall(self.column, self, name)
    if ok and col then add(name, col) end
  end
  assert(f:write(table.concat(head, ","), "\n"))
  -- each number in the shortest form that reads back exactly (as the session prints it)
  local number = require("nz.base.formula").number
  local row = {}
  for i = 1, #self.t do
    for c = 1, #cols do row[c] = number(cols[c][i]) end
    assert(f:write(table.concat(row, ","), "\n"))
  end
  assert(f:flush())
end

-- CSV with a header naming every column.  Written to a file beside `file`
-- and renamed onto it at the end: Ctrl-C or a kill while writing leaves the
-- previous file (or none), never one cut in the middle of a row.  Ctrl-C
-- removes the file beside; SIGTERM is held until the write and the rename
-- are done (then it ends the process), so it leaves nothing behind either.
-- Whether path names a directory (reading it fails with EISDIR).
local function is_directory(path)
  local f = io.open(path, "r")
  if not f then return false end
  local got, _, code = f:read(1)
  f:close()
  return got == nil and code == 21
end

local function write_beside(self, file)
  local tmp, why = core.mech.temp_beside(file)
  if not tmp then return false, why end
  local f, err = io.open(tmp, "w")
  if not f then os.remove(tmp); return false, err end
  local ok, failure = pcall(write_csv, self, f)
  f:close()
  if ok then ok, failure = os.rename(tmp, file) end
  if not ok then os.remove(tmp) end
  return ok, failure
end

-- Without a file, the CSV text: typed at the prompt the session shows it,
-- a script can io.write it (as sw:csv() does).
function Trajectory:csv(file)
  if file == nil then
    local parts = {}
    local buffer = { write = function(b, ...)
      for i = 1, select("#", ...) do parts[#parts + 1] = select(i, ...) end
      return b
    end, flush = function(b) return b end }
    write_csv(self, buffer)
    return table.concat(parts)
  end
  if type(file) ~= "string" then
    error(("bad argument #1 to 'csv' (a file name, or nothing for the CSV text, expected, got %s)"):format(type(file)), 2)
  end
  if is_directory(file) then
    error(("tr:csv: cannot write '%s': it is a directory: give the name of a file to write, as "
      .. "tr:csv(\"%s/run.csv\")"):format(file, (file:gsub("/+$", ""))), 2)
  end
  core.mech.hold_term(true)
  local called, ok, failure = pcall(write_beside, self, file)
  if not called then ok, failure = false, ok end
  core.mech.hold_term(false)
  if not ok then
    if rawequal(failure, core.interrupted) then error(failure, 0) end   -- Ctrl-C stays Ctrl-C
    error(("tr:csv: cannot write '%s': %s"):format(file, tostring(failure)), 2)
  end
  return file
end

-- tr:plot{ y = {"th", "x"}, x = "t", file = "out.svg", title = ... }
-- tr:plot{ phase = "th" } draws th' against th.  Default: every coordinate
-- against t, in the terminal, sized to it.  A conserved quantity (E, H) is
-- drawn as its drift from its first value: its own ticks would all read the
-- same digits.  Draws and returns nothing in the terminal (the session
-- prints nothing more); returns the file's name when writing one.
local PLOT_OPTIONS = require("nz.base.options").declare("tr:plot", { y = true, x = true, phase = true, file = true,
  title = true, xlabel = true, ylabel = true, legend = true, size = true, width = true, height = true, quiet = true,
  drift = true })
local CONSERVED = { E = true, H = true }

-- The terminal's columns and lines (COLUMNS and LINES, else stty), or nil.
local function terminal_size()
  local cols, lines = tonumber(os.getenv("COLUMNS")), tonumber(os.getenv("LINES"))
  if cols and lines then return cols, lines end
  local p = io.popen("stty size 2>/dev/null </dev/tty")
  local out = p and p:read("a") or ""
  if p then p:close() end
  local l, c = out:match("(%d+)%s+(%d+)")
  return tonumber(c), tonumber(l)
end

-- The values of tr:plot's options, checked before anything is drawn (the
-- sizes and the file are plot.lines's to check).
local function check_plot_options(opts)
  local function bad(key, want)
    local v = opts[key]
    error(("%strajectory:plot: %s = %s: %s"):format(require("nz.base.where").user_where(), key,
      require("nz.base.text").literal(v), want), 0)
  end
  local y = opts.y
  local names = type(y) == "table" and #y > 0
  for _, v in ipairs(type(y) == "table" and y or {}) do names = names and type(v) == "string" end
  if y ~= nil and type(y) ~= "string" and not names then
    bad("y", "a quantity's name or a list of names expected, e.g. y = {\"th\", \"th'\"}")
  end
  for _, key in ipairs{ "x", "phase", "title", "xlabel", "ylabel" } do
    if opts[key] ~= nil and type(opts[key]) ~= "string" then bad(key, "a string expected") end
  end
  for _, key in ipairs{ "legend", "quiet", "drift" } do
    if opts[key] ~= nil and type(opts[key]) ~= "boolean" then bad(key, "true or false expected") end
  end
  local size = opts.size
  if size ~= nil and not (type(size) == "table" and #size == 2 and type(size[1]) == "number" and type(size[2]) == "number") then
    bad("size", "{width, height} expected (characters in the terminal, pixels in a file)")
  end
end

function Trajectory:plot(opts)
  opts = opts or {}
  require("nz.base.options").check(opts, PLOT_OPTIONS, function(fmt, ...)
    error(("%strajectory:plot: " .. fmt):format(require("nz.base.where").user_where(), ...), 0)
  end)
  check_plot_options(opts)
  local series = {}
  local ylabel = opts.ylabel
  if opts.phase then
    series[1] = { name = opts.phase .. "' vs " .. opts.phase, x = self:column(opts.phase), y = self:column(opts.phase .. "'") }
    ylabel = ylabel or (opts.phase .. "'")
  else
    local ys = opts.y or self.coords
    if type(ys) == "string" then ys = { ys } end
    local x = self:column(opts.x or "t")
    for i, name in ipairs(ys) do
      local y = self:column(name)
      if opts.drift ~= false and (CONSERVED[name] or opts.drift) then
        local d, y0 = {}, y[1]
        for n = 1, #y do d[n] = y[n] - y0 end
        y, name = d, ("%s - %s(0)"):format(name, name)
      end
      series[i] = { name = name, x = x, y = y }
    end
    if not ylabel then
      local names = {}
      for i, s in ipairs(series) do names[i] = s.name end
      ylabel = table.concat(names, ", ")
    end
    if self.contacts then require("nz.motion.contact_run").marks(self, series, opts.x or "t") end
  end
  local width, height = opts.width, opts.height
  if type(opts.size) == "table" then width, height = opts.size[1], opts.size[2] end
  if not opts.file and not (width and height) then
    local cols, lines = terminal_size()
    width = width or (cols and math.max(40, math.min(cols - 1, 200))) or 100
    height = height or (lines and math.max(12, math.min(lines - 3, 60))) or 30
  end
  local out = plot.lines{
    series = series, file = opts.file, width = width, height = height, quiet = opts.quiet,
    title = opts.title or self.system.name, xlabel = opts.xlabel or opts.phase or opts.x or "t", ylabel = ylabel,
    legend = opts.legend,
  }
  if opts.file or opts.quiet then return out end
end

-- tr:section and tr:animate (nz/presentation/views.lua), tr:residuals and
-- tr:consistency (nz/analysis/defect.lua) are attached to this class by those
-- modules, which sit above this one (docs/architecture.md).

-- tr.plot{...} (a dot) is named as such by every method (nz/base/where.lua).
require("nz.base.where").methods(Trajectory, "tr", "trajectory")

return M
