-- nz/model/contact_check.lua - what nz.system notices about a system's
-- unilateral contacts (nz/model/contact.lua) once they are recorded.
--
-- Two contacts with the same gap are one contact twice: both are held
-- together and share its force (nz/motion/contact_run.lua), which is
-- rarely what was meant: the usual reason is friction in two directions
-- written as two contacts, which the isotropic cone slip = {f1, f2} of one
-- contact does.  The gaps are compared by their values and gradients at two
-- states (the sample's, or made up), on the recorded functions.
local core = require "nz.core"

local mech = core.mech
local M = {}

-- The states the gaps are compared at: the system's sample, and one made up
-- (high-entropy numbers, not 0 or 1).
local function states(sys)
  local k, out = sys.k, {}
  if sys.sample and type(sys.sample.q) == "table" and #sys.sample.q == k then
    out[1] = { t = sys.sample.t or 0, q = sys.sample.q, qd = sys.sample.qd or {} }
  end
  local q, qd = {}, {}
  for i = 1, k do q[i], qd[i] = 0.2385 + 0.1173 * i, -0.3117 + 0.0771 * i end
  out[#out + 1] = { t = 0.4321, q = q, qd = qd }
  return out
end

-- Gap j's value and gradient at state s, or nil where it cannot be evaluated.
local function probe(csys, r, s)
  local qd = {}
  for i = 1, csys.k do qd[i] = s.qd[i] or 0 end
  local ok, v, dq = pcall(mech.constraint_state_gradient, csys.engine, r, 0, s.t, s.q, qd)
  if not ok or v ~= v then return nil end
  local out = { v }
  for i = 1, #dq do out[#out + 1] = dq[i] end
  return out
end

local function same(a, b)
  if not a or not b then return false end
  local scale = 0
  for i = 1, #a do scale = math.max(scale, math.abs(a[i]), math.abs(b[i])) end
  for i = 1, #a do
    if math.abs(a[i] - b[i]) > 1e-12 * scale then return false end
  end
  return true
end

-- The pairs of contacts of sys with the same gap: {{name_a, name_b}, ...}.
function M.same_gaps(sys)
  local c = sys.contact
  local csys, pairs_found = c.system, {}
  local values = {}
  for j, s in ipairs(c.contacts) do
    values[j] = {}
    for x, st in ipairs(states(sys)) do values[j][x] = probe(csys, s.gap, st) end
  end
  for a = 1, c.n do
    for b = a + 1, c.n do
      local alike = #values[a] > 0
      for x = 1, #values[a] do alike = alike and same(values[a][x], values[b][x]) end
      if alike then pairs_found[#pairs_found + 1] = { c.names[a], c.names[b] } end
    end
  end
  return pairs_found
end

-- The line nz.system says for them (nil when there are none).
function M.notice(sys)
  local found = M.same_gaps(sys)
  if #found == 0 then return nil end
  local said = {}
  for i, p in ipairs(found) do said[i] = ("'%s' and '%s'"):format(p[1], p[2]) end
  return ("nz.system '%s': contacts %s have the same gap: one contact twice, held together and sharing its force; "
    .. "for friction in two directions give one contact slip = {f1, f2} (an isotropic cone)"):format(sys.name,
    table.concat(said, ", "))
end

return M
