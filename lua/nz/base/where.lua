-- nz/base/where.lua - where in the user's code a library call came from, so that
-- messages about the user's input start with the user's file:line, as Lua's
-- own errors do (one place for simulate, the system's methods and the
-- constraint checks).
local M = {}

-- Whether a chunk's source is one of the library's own files (embedded as
-- "lua/nz/NAME.lua", or loaded from a checkout).
function M.is_library(src) return src:find("^@?lua/nz/[%w_/]+%.lua$") or src:find("/lua/nz/[%w_/]+%.lua$") end

-- The first frame outside the library (debug.getinfo's "Sl"), or nil.
local function user_frame()
  for level = 3, 50 do
    local info = debug.getinfo(level, "Sl")
    if not info then break end
    if info.currentline > 0 and not M.is_library(info.source) then return info end
  end
end

-- The library's wrappers of a user's function (a contact's gap handed the
-- constraint slots): the function each stands for and what to call it,
-- so that a message about the wrapper names the user's function, where it
-- is defined and what it is.
local wrapped = setmetatable({}, { __mode = "k" })

-- wrapper, registered as standing for fn, called label ("contact 'floor'
-- (its gap)").
function M.wrap(wrapper, fn, label)
  wrapped[wrapper] = { fn = fn, label = label }
  return wrapper
end

-- The user's function f stands for (f itself when it wraps none), and its
-- label (nil when none was given).
function M.unwrap(f)
  local w = wrapped[f]
  if w then return w.fn, w.label end
  return f
end

-- "file:line" where the user's function behind f is defined, or nil.
function M.defined(f)
  local info = debug.getinfo(M.unwrap(f), "S")
  return info.what == "Lua" and ("%s:%d"):format(info.short_src, info.linedefined) or nil
end

-- "file:line: " of the first frame outside the library, or "".
function M.user_where()
  local info = user_frame()
  return info and (info.short_src .. ":" .. info.currentline .. ": ") or ""
end

-- The error of a method of a system about its input: "file:line: sys:NAME
-- 'system': ..." (sys:show, sys:export, sys:linearize, ... say it so).
function M.method_error(name, sys, fmt, ...)
  error(("%ssys:%s '%s': " .. fmt):format(M.user_where(), name, sys.name, ...), 0)
end

-- A method called with a dot (sys.simulate{...}) instead of a colon gets
-- its first argument as the object and no object at all: every method of
-- `class` checks its self first, one wrapper for all, and says what to
-- write.  noun names the object in the message ("sys", "tr") and `what`
-- says what it is ("system", "trajectory").  The wrapper
-- tail-calls the method, so the method's error levels still point at the
-- user's line.
local getmetatable = getmetatable     -- the check runs on every call: no global lookup

local function dot_error(noun, what, name, self)
  local args = type(self) == "table" and "{...}" or "(...)"    -- x.f{...} or x.f(...) was written
  -- the object's name as the user wrote it, when their file can be read
  -- (typed at the prompt it cannot: the message then says sys or tr)
  local info, object = user_frame(), nil
  if info and info.source:sub(1, 1) == "@" then
    local f = io.open(info.source:sub(2))
    if f then
      local n = 0
      for line in f:lines() do
        n = n + 1
        if n == info.currentline then
          object = line:match("([%w_]+)%." .. name .. "%s*[%({]")
          break
        end
      end
      f:close()
    end
  end
  local write = object and (object .. ":" .. name .. args) or ("%s:%s%s (%s: your %s)"):format(noun, name, args, noun, what)
  error(("%s%s called with a dot: write %s, with a colon, so that the method gets its %s")
    :format(M.user_where(), object and (object .. "." .. name) or name, write, what), 0)
end

-- Each method is wrapped once: a class whose methods several modules
-- attach (the trajectory's: nz/motion/trajectory.lua, views.lua, defect.lua)
-- calls this after each of them.
local wrapped = setmetatable({}, { __mode = "k" })
function M.methods(class, noun, what)
  for name, f in pairs(class) do
    if type(f) == "function" and not name:match("^__") and not wrapped[f] then
      local method = function(self, ...)
        if getmetatable(self) ~= class then dot_error(noun, what, name, self) end
        return f(self, ...)
      end
      wrapped[method] = true
      class[name] = method
    end
  end
end

return M
