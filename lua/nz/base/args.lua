-- nz/base/args.lua - the arguments of nz's methods and functions, checked before
-- the C mechanics reads them, so that an error is in Lua's own style ("bad
-- argument #2 to 'accel' (...)"), counts the arguments as the user writes
-- them (self not counted) and starts with the user's file:line.  Below the
-- modules that check arguments (systems, runs, analyses): it requires none
-- of them.
local core = require "nz.core"
local text = require "nz.base.text"
local user_where = require("nz.base.where").user_where

local M = {}

-- A value as a message shows it after "got" (NaN as "NaN" on every C
-- library; "0" as the string "0", so that it is not read as a number): the
-- one way every module shows a value it refuses.
function M.shown(v)
  if type(v) == "number" then return text.number(v) end
  if type(v) == "string" then return ("the string %q"):format(v) end
  if type(v) == "boolean" or v == nil then return tostring(v) end
  if type(v) == "table" and getmetatable(v) == nil then
    return #v == 1 and "a table of 1 entry" or ("a table of %d entries"):format(#v)
  end
  return type(v)
end
local shown = M.shown

function M.error(fname, i, msg, ...)
  error(("%sbad argument #%d to '%s' (%s)"):format(user_where(), i, fname, msg:format(...)), 0)
end
local arg_error = M.error

-- v - v is 0 for a finite number, NaN for an infinite one or NaN; the
-- checks run on every call of a method (sys:accel from a loop), so they
-- use no global and no library function.
local type, getmetatable = type, getmetatable
local function finite(v) return type(v) == "number" and v - v == 0 end
M.finite = finite

function M.number(fname, i, name, v)
  if not finite(v) then arg_error(fname, i, "%s: a finite number expected, got %s", name, shown(v)) end
end

-- A list of n finite numbers (n = the system's coordinates by default).
function M.vector(sys, fname, i, name, v, n, what)
  n = n or sys.k
  if type(v) ~= "table" or getmetatable(v) ~= nil or #v ~= n then
    arg_error(fname, i, "%s: a table of %d number%s expected (%s), got %s", name, n, n == 1 and "" or "s",
      what or ("one per coordinate: " .. table.concat(sys.coords, ", ")), shown(v))
  end
  for j = 1, n do
    local x = v[j]
    if type(x) ~= "number" or x - x ~= 0 then
      arg_error(fname, i, "%s[%d]: a finite number expected, got %s", name, j, shown(x))
    end
  end
end

-- The state t, q, qd of a method, its t being argument `first`.
function M.state(sys, fname, first, t, q, qd, qd_optional)
  M.number(fname, first, "t", t)
  M.vector(sys, fname, first + 1, "q", q)
  if not (qd == nil and qd_optional) then M.vector(sys, fname, first + 2, "qd", qd) end
end

-- An options table with only the given keys; keys[key](value) checks each.
function M.options(fname, i, opts, keys)
  if opts == nil then return end
  if type(opts) ~= "table" then arg_error(fname, i, "options: a table expected, got %s", shown(opts)) end
  require("nz.base.options").check(opts, keys, function(...) arg_error(fname, i, ...) end)
  for key, v in pairs(opts) do
    local ok, want = keys[key](v)
    if not ok then arg_error(fname, i, "option '%s': %s expected, got %s", tostring(key), want, shown(v)) end
  end
end

-- Checkers of one option's value: ok, and what was expected.
function M.positive(v) return finite(v) and v > 0, "a positive finite number" end
function M.count(v) return finite(v) and v >= 1 and v == math.floor(v), "a whole number >= 1" end
function M.boolean(v) return type(v) == "boolean", "true or false" end

-- n (argument #1) of residual, equations and the defect: nil for the rule's n.
function M.order(fname, n)
  local max = core.mech.max_order
  if n ~= nil and not (type(n) == "number" and n == math.floor(n) and n >= 1 and n <= max) then
    arg_error(fname, 1, "n: an integer order from 1 to %d expected, got %s", max, shown(n))
  end
end

return M
