-- shape.lua - the code's shape, held to the limits a newcomer can read:
-- no source file over MAX_FILE lines, no C function over MAX_C_FUNCTION,
-- no Lua function over MAX_LUA_FUNCTION, and no circle of includes between
-- the C files of src/ (a file's .c and .h count as one: native_cache.c
-- including native_object.h, and native_object.c including native_cache.h,
-- is a circle; a private header X_impl.h, the insides X.c shares with the
-- files split from it, counts as X's own).
--
--   lua5.4 tools/shape.lua             what breaks the limits (nothing when none)
--   lua5.4 tools/shape.lua --sizes     the largest files and functions
--   dofile("tools/shape.lua")          the functions, for tests/layers_spec.lua
local M = {}

-- tools/circles.lua, beside this file wherever it is run from.
local circles = dofile((debug.getinfo(1, "S").source:match("^@(.*/)") or "./") .. "circles.lua")

M.MAX_FILE = 1200
M.MAX_C_FUNCTION = 150
M.MAX_LUA_FUNCTION = 200

local function list(cmd)
  local p = assert(io.popen(cmd))
  local out = {}
  for line in p:lines() do out[#out + 1] = line end
  p:close()
  table.sort(out)
  return out
end

local function lines_of(path)
  local t = {}
  for l in io.lines(path) do t[#t + 1] = l end
  return t
end

-- The functions of a C file written in the project's style (the signature
-- from column 0, the body from a "{" and to a "}" each alone in column 0):
-- {name, first line, lines}.
function M.c_functions(lines)
  local out, i = {}, 1
  while i <= #lines do
    if lines[i] == "{" then
      local j = i - 1
      while j > 1 and not lines[j]:match("%(") do j = j - 1 end
      while j > 1 and lines[j]:match("^%s") do j = j - 1 end      -- a signature on several lines
      local name = lines[j]:match("([%w_]+)%s*%(") or "?"
      local k = i + 1
      while k <= #lines and lines[k] ~= "}" do k = k + 1 end
      out[#out + 1] = { name = name, at = j, lines = k - j + 1 }
      i = k + 1
    else
      i = i + 1
    end
  end
  return out
end

-- The lines of a Lua file with the text of its long strings and long
-- comments blanked ([[ ... ]], [==[ ... ]==], --[[ ... ]]): help texts
-- hold lines that begin with "function".
local function code_lines(lines)
  local out, close = {}, nil
  for i, l in ipairs(lines) do
    local kept, pos = {}, 1
    while pos <= #l do
      if close then
        local _, e = l:find(close, pos, true)
        if not e then pos = #l + 1 else close, pos = nil, e + 1 end
      else
        local a, e, eq = l:find("%[(=*)%[", pos)
        if not a then kept[#kept + 1] = l:sub(pos); pos = #l + 1
        else kept[#kept + 1] = l:sub(pos, a - 1); close, pos = "]" .. eq .. "]", e + 1 end
      end
    end
    out[i] = table.concat(kept)
  end
  return out
end

-- The functions of a Lua file (a `function` or `local function` line and
-- the `end` at its indentation): {name, first line, lines}.
function M.lua_functions(lines)
  local out = {}
  lines = code_lines(lines)
  for i, l in ipairs(lines) do
    local ind, rest = l:match("^(%s*)(.*)$")
    local name = rest:match("^local%s+function%s+([%w_.:]+)") or rest:match("^function%s+([%w_.:]+)")
      or rest:match("^local%s+([%w_]+)%s*=%s*function") or rest:match("^([%w_.]+)%s*=%s*function")
    if name and not rest:match("%f[%w]end%s*[%),]*$") then
      for k = i + 1, #lines do
        local e = lines[k]
        if e == ind .. "end" or e:sub(1, #ind + 3) == ind .. "end" and e:sub(#ind + 4, #ind + 4):match("^[%),]?$") then
          out[#out + 1] = { name = name, at = i, lines = k - i + 1 }
          break
        end
      end
    end
  end
  return out
end

-- The includes of src/: {[unit] = {units it includes}}, a unit being a
-- path without its extension (src/graph/native_cache), a private header
-- X_impl.h belonging to X.
function M.includes(root)
  root = root or "."
  local units = {}
  for _, path in ipairs(list(("cd %s && find src -name '*.c' -o -name '*.h'"):format(root))) do
    local unit = path:gsub("%.[ch]$", ""):gsub("_impl$", "")
    units[unit] = units[unit] or {}
    for l in io.lines(root .. "/" .. path) do
      local inc = l:match('^#include%s+"([%w_/]+)%.h"')
      if inc then
        local target = ("src/" .. inc):gsub("_impl$", "")
        if target ~= unit then units[unit][target] = true end
      end
    end
  end
  return units
end

-- Circles in the include graph: a list of messages.
function M.include_circles(units)
  local names = {}
  for u in pairs(units) do names[#names + 1] = u end
  table.sort(names)
  return circles(names, function(u)
    local targets = {}
    for t in pairs(units[u] or {}) do targets[#targets + 1] = t end
    table.sort(targets)
    return targets
  end, "includes")
end

-- Every file and function over its limit, and every include circle: a
-- list of messages (empty when the code keeps its shape).
function M.violations(root)
  root = root or "."
  local bad = {}
  local files = list(("cd %s && find src lua -name '*.c' -o -name '*.h' -o -name '*.lua'"):format(root))
  for _, path in ipairs(files) do
    local lines = lines_of(root .. "/" .. path)
    if #lines > M.MAX_FILE then bad[#bad + 1] = ("%s: %d lines (at most %d)"):format(path, #lines, M.MAX_FILE) end
    local fs, max = path:match("%.lua$") and M.lua_functions(lines) or M.c_functions(lines),
      path:match("%.lua$") and M.MAX_LUA_FUNCTION or M.MAX_C_FUNCTION
    if not path:match("%.h$") then
      for _, f in ipairs(fs) do
        if f.lines > max then
          bad[#bad + 1] = ("%s:%d: function '%s' has %d lines (at most %d)"):format(path, f.at, f.name, f.lines, max)
        end
      end
    end
  end
  for _, b in ipairs(M.include_circles(M.includes(root))) do bad[#bad + 1] = b end
  return bad
end

-- The n largest files and functions, for a look at where the code grows.
function M.largest(root, n)
  root = root or "."
  local files, funcs = {}, {}
  for _, path in ipairs(list(("cd %s && find src lua -name '*.c' -o -name '*.lua'"):format(root))) do
    local lines = lines_of(root .. "/" .. path)
    files[#files + 1] = { path, #lines }
    for _, f in ipairs(path:match("%.lua$") and M.lua_functions(lines) or M.c_functions(lines)) do
      funcs[#funcs + 1] = { ("%s:%d %s"):format(path, f.at, f.name), f.lines }
    end
  end
  table.sort(files, function(a, b) return a[2] > b[2] end)
  table.sort(funcs, function(a, b) return a[2] > b[2] end)
  local out = {}
  for i = 1, math.min(n, #files) do out[#out + 1] = ("file %6d  %s"):format(files[i][2], files[i][1]) end
  for i = 1, math.min(n, #funcs) do out[#out + 1] = ("function %6d  %s"):format(funcs[i][2], funcs[i][1]) end
  return out
end

if arg and arg[0] and arg[0]:match("shape%.lua$") and not debug.getinfo(3) then
  if arg[1] == "--sizes" then
    for _, l in ipairs(M.largest(".", 12)) do print(l) end
  else
    local bad = M.violations(".")
    for _, b in ipairs(bad) do print(b) end
    os.exit(#bad == 0 and 0 or 1)
  end
end

return M
