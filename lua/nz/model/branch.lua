-- nz/model/branch.lua - branches written without a Lua `if`, in Lua.
--
-- The comparisons, ifelse, max, min, clamp and sign are in C (src/lua/lua_jet.c,
-- nz_jet_compare and nz_jet_select); what is here is built from the
-- operations every number type has (+ - * and sqrt), so that a recorded
-- graph holds it without a node of its own.
local core = require "nz.core"

local M = {}

-- sqrt(x^2 + eps^2) - eps: |x| - eps + O(eps) away from 0 (within eps of |x|
-- everywhere), smooth at 0, where it is x^2 / (2 eps) + O(x^4).  eps may be a
-- parameter (any number type); a plain number must be positive and finite.
function M.smooth_abs(x, eps)
  if type(eps) == "number" then
    if not (eps > 0 and eps < math.huge) then
      error(("bad argument #2 to 'smooth_abs' (a positive finite width expected, got %s)"):format(tostring(eps)), 2)
    end
  elseif eps == nil then
    error("bad argument #2 to 'smooth_abs' (a positive width eps expected, got no value)", 2)
  end
  return core.sqrt(x * x + eps * eps) - eps
end

return M
