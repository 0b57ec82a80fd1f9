-- nz/model/probe.lua - a system's functions tried once when it is made, so that a
-- mistake that fails at every state is said at the user's nz.system line
-- instead of at the first accel or simulate, deep in a run.
--
-- Only what is certain is refused.  A function may be undefined at some
-- states (sqrt of a negative value, log of 0), read a global or a parameter
-- that is set after the system is made, or call the system itself: those
-- give no verdict here, and the first evaluation in the mechanics reports
-- them as before.  A definite mistake is one that no state and nothing set
-- later can change, because it is about types the engine always passes:
--   - a function of numbers only (math.cos, string.format) given a jet:
--     the engine evaluates every function on jets (help(nz.jet));
--   - a coordinate read by name (q.th, qd.th): q, qd, ... are lists;
--   - a state list taken as a number (q * 2, math.cos(q));
--   - a call of a misspelled name of nz (nz.coss, coss in a script);
--   - a value that is not a number or a jet returned (nil: a forgotten
--     return; a table), or Q not a list of one force per coordinate.
-- A function that was recorded (nz/model/record.lua) ran on traced values of the
-- same shapes already and is not tried again: a system whose functions all
-- record pays nothing here.  The others (math.* or a Lua `if` on the state,
-- compile = false) run once in Lua on jets at the classification's sample
-- state (sys.sample when given, docs: help(nz.system)).
local core = require "nz.core"
local where = require "nz.base.where"

local M = {}

-- The first frame outside the library, as "file:line" (the user's line
-- where the error happened), from inside an error handler.
local function user_location()
  for level = 3, 60 do
    local info = debug.getinfo(level, "Sl")
    if not info then break end
    if info.currentline > 0 and info.what ~= "C" and not where.is_library(info.source) then
      return ("%s:%d"):format(info.short_src, info.currentline)
    end
  end
end

-- A read of q.th, qd.name, q[k + 1]: q, qd, ... are lists of k jets.  A
-- name is a mistake whatever the state; an index past k gives nil (ipairs
-- reads it to stop) and is left to the arithmetic that follows.
local NAMED_READ = {}
local function state_list(values, slot, coords)
  local list = {}
  for i, v in ipairs(values) do list[i] = core.jet{ v, 0.5, order = 2 } end
  return setmetatable(list, { __index = function(_, key)
    if type(key) ~= "string" then return nil end
    local hint = ""
    for i, c in ipairs(coords) do
      if c == key then hint = (": '%s' is %s[%d]"):format(c, slot, i) end
    end
    error({ [NAMED_READ] = ("reads %s.%s, and %s is a list indexed by number (q[1], qd[1], ...)%s")
      :format(slot, key, slot, hint) }, 2)
  end })
end

-- The functions of numbers and jets (the C core's, and nz.smooth_abs), by
-- name: what a math.* or a misspelled name should have been.
local function jet_functions()
  local out = { "smooth_abs" }
  for name, v in pairs(core) do
    if type(v) == "function" then out[#out + 1] = name end
  end
  table.sort(out)
  return out
end

-- What an error message says about the mistake, when it is one whatever
-- the state: the advice to add, or nil (no verdict).
local function definite(msg)
  local names = jet_functions()
  local is_jet_function = {}
  for _, n in ipairs(names) do is_jet_function[n] = true end
  -- a function of numbers given a jet (or a state list, a table)
  local fname, got = msg:match("bad argument #%d+ to '([%w_.]+)' %([^)]-expected, got ([%w_.]+)%)")
  if fname and (got == "nz.jet" or got == "nz.dualjet" or got == "table") then
    local short = fname:match("([%w_]+)$")
    if got == "table" then
      return ("'%s' was given a table: q, qd, ... are lists, q[1] is a number"):format(short)
    end
    if is_jet_function[short] then
      return ("math.%s works on numbers only: write nz.%s(...), or %s(...) in the session"):format(short, short, short)
    end
    return ("'%s' takes numbers, and the engine evaluates the functions on jets (truncated Taylor series, "
      .. "help(nz.jet)): write them with nz's functions and arithmetic"):format(short)
  end
  -- a state list in arithmetic
  local list = msg:match("attempt to perform arithmetic on a table value %(local '([%w_]+)'%)")
  if list then return ("'%s' is a list (q[1], qd[1], ...), not a number"):format(list) end
  -- a call of a name of nz misspelled (nz.coss, or coss in a script)
  local kind, name = msg:match("attempt to call a nil value %((%w+) '([%w_]+)'%)")
  if (kind == "field" or kind == "global") and not is_jet_function[name] then
    local near = require("nz.base.options").nearest(name, names)
    if near then return ("there is no '%s': did you mean nz.%s?"):format(name, near) end
  end
end

local function kind(v)
  if v == nil then return "nil (no return?)" end
  return core.isjet(v) and "a jet" or ("a " .. type(v))
end

local function shape_error(v, is_Q, k)
  if is_Q then
    if type(v) ~= "table" or getmetatable(v) ~= nil then
      local list = {}
      for i = 1, math.min(k, 3) do list[i] = "Q" .. i end
      if k > 3 then list[3] = "..., Q" .. k end
      return ("returned %s: Q returns a list {%s} of forces, one per coordinate"):format(kind(v), table.concat(list, ", "))
    end
    if #v ~= k then return ("returned %d forces for %d coordinates"):format(#v, k) end
    for i = 1, k do
      if type(v[i]) ~= "number" and not core.isjet(v[i]) then
        return ("returned force %d as %s: a number or a jet expected"):format(i, kind(v[i]))
      end
    end
    return nil
  end
  if type(v) == "number" or core.isjet(v) then return nil end
  return ("returned %s: a number or a jet expected"):format(
    type(v) == "table" and "a table (one value is returned, not a list)" or kind(v))
end

local function vector_text(v) return require("nz.base.text").list(v, "%.6g") end

-- The functions of sys that were not recorded (all of them with compile =
-- false): {label, f, slots, is_Q}, in the order print(sys) lists them.
local function unrecorded(sys)
  local e = sys.engine
  local recorded = {}
  for _, r in ipairs(sys.recording or {}) do recorded[r.label] = r.recorded end
  local out = {}
  local function add(list, labels, slots, is_Q)
    for i, f in ipairs(list) do
      if not recorded[labels[i]] then out[#out + 1] = { label = labels[i], f = f, slots = slots, is_Q = is_Q } end
    end
  end
  add(e.F, e.labels.F, 2)
  add(e.V, e.labels.V, 1)
  add(e.Q, e.labels.Q, 2, true)
  for r, f in ipairs(e.constraints) do
    local slots = sys.constraint_levels[r]
    if not recorded[e.labels.constraints[r]] then
      out[#out + 1] = { label = e.labels.constraints[r], f = f, slots = slots }
    end
  end
  return out
end

-- Try each function that was not recorded once at the sample state; raise
-- the first definite mistake at the user's nz.system line.
function M.check(sys)
  local todo = unrecorded(sys)
  if #todo == 0 then return end
  local state = require("nz.model.constraints").anchor(sys)
  for _, fn in ipairs(todo) do
    local args = { core.jet{ state.t, 1, order = 2 } }
    local names = { "q", "qd", "qdd", "qddd" }
    for j = 1, fn.slots do args[j + 1] = state_list(state[j], names[j] or ("q" .. (j - 1) .. "d"), sys.coords) end
    args[fn.slots + 2] = sys.params
    local at
    local ok, res = xpcall(fn.f, function(e)
      if rawequal(e, core.interrupted) then return e end
      at = user_location()
      return e
    end, table.unpack(args, 1, fn.slots + 2))
    if not ok and rawequal(res, core.interrupted) then error(res, 0) end
    local what
    if not ok then
      if type(res) == "table" and res[NAMED_READ] then
        what = fn.label .. " " .. res[NAMED_READ]
      elseif type(res) == "string" then
        local hint = definite(res)
        if hint then what = (at and res:sub(1, #at + 2) == at .. ": " and res:sub(#at + 3) or res) .. ": " .. hint end
      end
    else
      what = shape_error(res, fn.is_Q, sys.k)
      what = what and fn.label .. " " .. what
    end
    if what then
      at = at or where.defined(fn.f)   -- the user's function, not a wrapper's
      local st = ("t = %.6g, q = %s"):format(state.t, vector_text(state[1]))
      if fn.slots >= 2 then st = st .. ", qd = " .. vector_text(state[2]) end
      error(("%snz.system '%s': %s fails at every state (tried once as the system is made, at %s): %s%s")
        :format(where.user_where(), sys.name, fn.label, st, at and (at .. ": ") or "", what), 0)
    end
  end
end

-- The first piece (T, L, V or Q) that is not finite at the state (t, q,
-- qd), on plain numbers: T = ... + 1/0 or + 0/0.  Only M = d2T/dqd2 and the
-- forces enter the motion, so such a T ran (a constant has no derivative).
-- A piece that raises there is left to the first use, which names the
-- user's line.  Its label and value, or nil.
function M.nonfinite_piece(self, t, q, qd)
  local finite = require("nz.base.args").finite
  local e = self.engine
  -- a parameter that is not a finite number is the mechanics' to name first
  for _, name in ipairs(e.param_names) do if not finite(self.params[name]) then return nil end end
  for _, list in ipairs{ { e.F, e.labels.F }, { e.V, e.labels.V, true }, { e.Q, e.labels.Q } } do
    for n, f in ipairs(list[1]) do
      local ok, v
      if list[3] then ok, v = pcall(f, t, q, self.params) else ok, v = pcall(f, t, q, qd, self.params) end
      if ok and type(v) == "table" then       -- Q: its first component that is not finite
        local first
        for i = 1, self.k do if type(v[i]) == "number" and not finite(v[i]) then first = first or v[i] end end
        v = first
      end
      if ok and type(v) == "number" and not finite(v) then return list[2][n], v end
    end
  end
end

return M
