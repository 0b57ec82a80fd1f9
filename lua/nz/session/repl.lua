-- nz/session/repl.lua - what the nzlua session adds to plain Lua: short names for the
-- mathematical functions, and readable printing of values typed at the prompt.
local text = require "nz.base.text"
local display = require "nz.draw.display"
local frontend = require "nz.base.frontend"

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

-- A number and a value as the session shows them (nz/base/text.lua,
-- nz/draw/display.lua: the picture is the display layer's, shared with the
-- notebook).
M.number = text.number
M.format = display.format

-- What a function printed itself during the chunk being run: kept by the
-- front-end (nz/base/frontend.lua), below the modules that print.
M.shown = frontend.shown
M.begin = frontend.begin
local already_shown = frontend.already_shown

-- Whether the values of an expression typed at the prompt (or of a cell's
-- last expression) are to be shown, keeping the first in `_` (as GSL Shell
-- and IPython do).  Not when every value is nil (a function that printed
-- its result and returned nothing leaves no stray "nil"), nor when they are
-- the values the function printed itself (M.shown).
local function to_show(...)
  local n = select("#", ...)
  local any = false
  for i = 1, n do if select(i, ...) ~= nil then any = true end end
  if not any then return false end
  rawset(_G, "_", (...))
  return not already_shown(...)
end

-- Their bundle (nz/draw/display.lua), or nil when there is nothing to show.
function M.result(...)
  if to_show(...) then return display.of_values(...) end
end

-- Print them on the front-end in use.  The terminal: tab-separated, as
-- print does, with no bundle made (a value typed costs what it did).
function M.print(...)
  if not to_show(...) then return end
  if frontend.current() == frontend.terminal then
    print(display.format_values(...))
  else
    display.show(display.of_values(...), "result")
  end
end

-- A chunk of several lines typed as one (a notebook's cell), as a
-- function named `name`: the whole text as an expression whose values are
-- shown (as the session tries a line), else its statements with the last
-- line(s) as such an expression when they are one (the last expression's
-- value shows, as in IPython), else its statements; nil and the message
-- when it does not compile.  The expression is called through a function
-- so that an error in a library call still has the chunk's frame (as
-- src/app/nzlua.c's addreturn does for a line).
function M.chunk(code, name)
  local function expression(e) return "return (function(...) return ... end)(" .. e .. "\n)" end
  local f = load(expression(code), "=" .. name)
  if f then return f end
  local lines = {}
  for line in (code .. "\n"):gmatch("([^\n]*)\n") do lines[#lines + 1] = line end
  while #lines > 0 and not lines[#lines]:find("%S") do lines[#lines] = nil end
  for k = #lines - 1, 1, -1 do
    local head, tail = table.concat(lines, "\n", 1, k), table.concat(lines, "\n", k + 1)
    if load(head, "=" .. name) then
      f = load(head .. "\n" .. expression(tail), "=" .. name)
      if f then return f end
    end
  end
  return load(code, "=" .. name)
end

-- nz.print(...): what the session shows, from a script.
M.show = display.print

return M
