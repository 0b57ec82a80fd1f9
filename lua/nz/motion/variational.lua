-- nz/motion/variational.lua - what method 'variational' (the variational
-- integrators of src/ode/variational.h) needs to know of a system: whether
-- its discrete Euler-Lagrange equations are Stormer and Verlet's explicit
-- scheme.  They are when the mass matrix M of M q'' + h = 0 is constant
-- and h does not depend on q': then the system's equations are those of
-- L = q'^T M q' / 2 - U(t, q) with forces Q(t, q) (a part of T linear in q'
-- without curl is a gauge term: it changes L by a total derivative), and
-- the trapezoidal discrete Lagrangian of that L gives q'' = -M^-1 h(t, q)
-- once a step.  Read off the recording, which says it exactly: M's nodes
-- reach no input but the parameters, h's no input of q'.  A system made
-- with compile = false, or one whose T, V or Q runs in Lua, takes the
-- Newton path (always right, dearer).
local record = require "nz.model.record"

local M = {}

-- The input numbers (0 = t, then the parameters, then slot j of q_i) that
-- the nodes roots depend on, in the graph dump nodes (compiled:nodes(),
-- ids 0-based).
local function inputs_of(nodes, roots)
  local seen, found, stack = {}, {}, {}
  for _, id in ipairs(roots) do stack[#stack + 1] = id end
  while #stack > 0 do
    local id = table.remove(stack)
    if id >= 0 and not seen[id] then
      seen[id] = true
      local n = id + 1
      if nodes.op[n] == "input" then found[nodes.a[n]] = true
      elseif nodes.op[n] ~= "const" then
        for _, f in ipairs{ "a", "b", "c" } do
          local x = nodes[f][n]
          if x and x >= 0 then stack[#stack + 1] = x end
        end
      end
    end
  end
  return found
end

local verdicts = setmetatable({}, { __mode = "k" })

-- Whether the Stormer-Verlet form applies to the system whose definition
-- table is engine (the system's, sys).
function M.verlet(sys, engine)
  local c = engine.recording
  if not c or record.mass_bias_in_lua(sys) then return false end
  if verdicts[c] ~= nil then return verdicts[c] end
  local k, np = sys.k, #(engine.recording_params or {})
  local ids = c:mass_bias_outputs(k)
  local ok = ids ~= nil
  if ok then
    local nodes, mass, bias = c:nodes(), {}, {}
    for n = 1, k * k do mass[n] = ids[n] end
    for i = 1, k do bias[i] = ids[k * k + i] end
    for input in pairs(inputs_of(nodes, mass)) do
      if input == 0 or input > np then ok = false end            -- M moves with t, q or q'
    end
    local h_inputs = inputs_of(nodes, bias)
    for i = 1, k do
      if h_inputs[1 + np + k + (i - 1)] then ok = false end        -- h depends on q'_i
    end
  end
  verdicts[c] = ok
  return ok
end

return M
