-- nz/init.lua - assembles the nz module from the C core and the Lua parts.
-- Receives nothing: the C core is required as "nz.core" (see src/lua/lua_nz.c).
local core = require "nz.core"

local nz = {}

for name, value in pairs(core) do nz[name] = value end
nz.mech = nil                  -- the C mechanics is reached through nz.system

local system = require "nz.system"
nz.system = system.system
nz.forms = system.forms
nz.nielsen_op = system.nielsen_op
nz.euler_op = system.euler_op
nz.partial = system.partial
nz.top_coefficient = system.top_coefficient
nz.bodies = require("nz.model.bodies").bodies
nz.methods = core.mech.ode_methods()
nz.workprecision = require("nz.analysis.workprecision").run
nz.longrun = require("nz.analysis.longrun").run
nz.effects = require "nz.model.effects"
-- a contact in a system's constraints (nz/model/contact.lua, loaded when used)
function nz.unilateral(gap, opts) return require("nz.model.contact").unilateral(gap, opts) end
nz.scene = require("nz.model.scene").scene
nz.check = require("nz.analysis.check").check
nz.rotations = require "nz.model.rotations"
nz.smooth_abs = require("nz.model.branch").smooth_abs
nz.sweep = require("nz.motion.sweep").sweep

nz.format = require("nz.draw.display").format  -- a value as the session shows it
nz.print = require("nz.draw.display").print    -- print values as the session does (a notebook: with its tables as HTML)

nz.help = require("nz.session.help").bind(nz)

-- nz.last: the trajectory of the last run that was interrupted or failed,
-- kept on the base floor (nz/base/session.lua) by the runs themselves.
local session = require "nz.base.session"
setmetatable(nz, {
  __index = function(_, key) if key == "last" then return session.last end end,
  __newindex = function(t, key, v) if key == "last" then session.last = v else rawset(t, key, v) end end,
})

return nz
