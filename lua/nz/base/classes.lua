-- nz/base/classes.lua - what the modules below nz's face need of it.  The face
-- (system.lua, which attaches every method to a system, and init.lua,
-- which assembles nz) requires all of them, so none of them may require
-- the face back: a model that makes a system of its own (a path, a
-- parametric system, a contact's), a function that checks that it was
-- given a system, reach the face through this table, which system.lua
-- fills when it loads.
local M = {}

-- The class of systems: system.lua attaches the methods to it.
M.System = { __name = "nz.system" }
M.System.__index = M.System

function M.is_system(x) return getmetatable(x) == M.System end

-- nz.system(def): set by system.lua.
M.new_system = nil

return M
