-- nz/repl.lua - what the nzlua session adds to plain Lua: short names for the
-- mathematical functions, and readable printing of values typed at the prompt.
local M = {}

-- Functions that the session offers without the nz. prefix (sin(x), help()).
M.global_names = {
  "jet", "dual", "exp", "log", "sqrt", "sin", "cos", "tan", "asin", "acos", "atan",
  "atan2", "sinh", "cosh", "tanh", "abs", "hypot", "help",
}

-- `quit` and `exit` typed alone say how to leave (plain Lua would print nil).
local leave = setmetatable({}, { __tostring = function() return "leave with Ctrl-D, or os.exit()" end,
  __call = function() os.exit(0) end })

function M.install_globals(env, nz)
  for _, name in ipairs(M.global_names) do env[name] = nz[name] end
  env.pi = math.pi
  env.quit, env.exit = leave, leave
end

local MAX_ITEMS = 12

-- A float as the shortest decimal that reads back exactly (%.15g, %.16g
-- or %.17g: math.pi is 3.141592653589793), keeping Lua's ".0" mark of an
-- integral float.
function M.number(v)
  if math.type(v) == "integer" then return tostring(v) end
  -- the C library says "nan", "-nan" or "inf": the same words everywhere
  if v ~= v then return "NaN" end
  if math.abs(v) == math.huge then return v > 0 and "inf" or "-inf" end
  local s
  for digits = 15, 17 do
    s = ("%." .. digits .. "g"):format(v)
    if tonumber(s) == v then break end
  end
  if s:match("^%-?%d+$") then s = s .. ".0" end
  return s
end

local function is_identifier(s)
  return type(s) == "string" and s:match("^[%a_][%w_]*$") ~= nil
end

-- A short one-line picture of a value; tables show their first few entries.
local function format(v, depth)
  local t = type(v)
  if t == "string" then return depth > 0 and ("%q"):format(v) or v end
  if t == "number" then return M.number(v) end
  if t ~= "table" or getmetatable(v) and getmetatable(v).__tostring then return tostring(v) end
  if depth >= 2 then return "{...}" end
  local parts, n = {}, #v
  for i = 1, math.min(n, MAX_ITEMS) do parts[#parts + 1] = format(v[i], depth + 1) end
  local keys = {}
  for k in pairs(v) do
    if not (math.type(k) == "integer" and k >= 1 and k <= n) then keys[#keys + 1] = k end
  end
  table.sort(keys, function(a, b) return tostring(a) < tostring(b) end)
  for _, k in ipairs(keys) do
    if #parts >= MAX_ITEMS then parts[#parts + 1] = "..."; break end
    local key = is_identifier(k) and k or ("[" .. format(k, depth + 1) .. "]")
    parts[#parts + 1] = key .. " = " .. format(v[k], depth + 1)
  end
  return "{" .. table.concat(parts, ", ") .. "}"
end

M.format = function(v) return format(v, 0) end

-- What a function printed itself during the chunk being run.  A function
-- that prints its result and also returns it for scripts (nz.check's ok,
-- text; tr:residuals' table; nz.workprecision's rows) ends with
-- `return repl.shown(...)`: typed at the prompt, those same values are not
-- printed a second time.  The session forgets them before each chunk
-- (M.begin), so the values kept in a variable and typed later do print.
-- Weak: a record never keeps a script's tables alive.
local shown = setmetatable({}, { __mode = "v" })

function M.shown(...)
  shown = setmetatable({ n = select("#", ...), ... }, { __mode = "v" })
  return ...
end

function M.begin() shown = setmetatable({}, { __mode = "v" }) end

local function already_shown(...)
  local n = select("#", ...)
  if shown.n ~= n then return false end
  for i = 1, n do
    if not rawequal(shown[i], (select(i, ...))) then return false end
  end
  return true
end

-- Print the values of an expression typed at the prompt, tab-separated,
-- and keep the first in `_` (as GSL Shell and IPython do).  Nothing at all
-- is printed when every value is nil: a function that printed its result
-- and returned nothing leaves no stray "nil"; nor when the values are those
-- the function printed itself (M.shown).
function M.print(...)
  local n = select("#", ...)
  local any = false
  for i = 1, n do if select(i, ...) ~= nil then any = true end end
  if not any then return end
  rawset(_G, "_", (...))
  if already_shown(...) then return end
  local parts = {}
  for i = 1, n do parts[i] = format((select(i, ...)), 0) end
  print(table.concat(parts, "\t"))
end

-- nz.print(...): what the session shows, from a script.
function M.show(...)
  local n = select("#", ...)
  local parts = {}
  for i = 1, n do parts[i] = format((select(i, ...)), 0) end
  print(table.concat(parts, "\t"))
end

return M
