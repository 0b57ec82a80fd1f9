-- nz/repl.lua - what the nzlua session adds to plain Lua: short names for the
-- mathematical functions, and readable printing of values typed at the prompt.
local M = {}

-- Functions that the session offers without the nz. prefix (sin(x), help()).
M.global_names = {
  "jet", "dual", "exp", "log", "sqrt", "sin", "cos", "tan", "asin", "acos", "atan",
  "atan2", "sinh", "cosh", "tanh", "abs", "hypot", "help",
}

function M.install_globals(env, nz)
  for _, name in ipairs(M.global_names) do env[name] = nz[name] end
  env.pi = math.pi
end

local MAX_ITEMS = 12

-- A float as the shortest of %.15g / %.17g that reads back exactly, keeping
-- Lua's ".0" mark of an integral float.
function M.number(v)
  if math.type(v) == "integer" then return tostring(v) end
  -- the C library says "nan", "-nan" or "inf": the same words everywhere
  if v ~= v then return "NaN" end
  if math.abs(v) == math.huge then return v > 0 and "inf" or "-inf" end
  local s = ("%.15g"):format(v)
  if tonumber(s) ~= v then s = ("%.17g"):format(v) end
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

-- Print the values of an expression typed at the prompt, tab-separated.
function M.print(...)
  local n = select("#", ...)
  local parts = {}
  for i = 1, n do parts[i] = format((select(i, ...)), 0) end
  print(table.concat(parts, "\t"))
end

return M
