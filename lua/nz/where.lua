-- nz/where.lua - where in the user's code a library call came from, so that
-- messages about the user's input start with the user's file:line, as Lua's
-- own errors do (one place for simulate, the system's methods and the
-- constraint checks).
local M = {}

-- Whether a chunk's source is one of the library's own files (embedded as
-- "lua/nz/NAME.lua", or loaded from a checkout).
function M.is_library(src) return src:find("^@?lua/nz/[%w_]+%.lua$") or src:find("/lua/nz/[%w_]+%.lua$") end

-- "file:line: " of the first frame outside the library, or "".
function M.user_where()
  for level = 2, 50 do
    local info = debug.getinfo(level, "Sl")
    if not info then break end
    if info.currentline > 0 and not M.is_library(info.source) then return info.short_src .. ":" .. info.currentline .. ": " end
  end
  return ""
end

return M
