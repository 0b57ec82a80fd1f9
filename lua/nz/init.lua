-- nz/init.lua - assembles the nz module from the C core and the Lua parts.
-- Receives nothing: the C core is required as "nz.core" (see src/lua_nz.c).
local core = require "nz.core"

local nz = {}
for name, value in pairs(core) do nz[name] = value end

nz.help = require("nz.help").bind(nz)

return nz
