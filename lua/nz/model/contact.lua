-- nz/model/contact.lua - unilateral contacts (issue 26, docs/theory.md §13): what
-- a contact is, and the system a run integrates them with.
--
--   nz.unilateral(gap [, {e =, mu =, mu_s =, slip =, name =, at =}])
--
-- is an entry of a system's constraints: gap(t, q, params) >= 0 (a
-- distance, so that its multiplier is the contact force), Newton's
-- restitution e (0 <= e <= 1, 0 by default: the contact stays closed once
-- reached), and Coulomb friction with mu (sliding) and mu_s (sticking,
-- mu_s >= mu, default mu) along slip(t, q, qd, params), the slip velocity
-- (or a function of (t, q) whose rate it is), or, with slip = {f1, f2}, the
-- isotropic cone on the two slip velocities along orthonormal tangent
-- directions.  nz.effects.contact and
-- nz.effects.friction make the same for a scene.
--
-- The system keeps its equalities as they are (sys.nc, sys.engine: every
-- method that ignores contacts, accel, linearize, show, sees the smooth
-- system).  A second system, sys.contact.system, holds the same pieces with
-- every contact's gap and slip function after the constraints; the
-- simulation integrates that one in the current contact mode
-- (nz/motion/contact_run.lua, src/mech/contact.c), and a system without contacts
-- has none, so it costs nothing.
local hypot = require("nz.core").hypot
local where = require "nz.base.where"

local M = {}

local Contact = { __name = "nz.unilateral" }
Contact.__index = Contact
function Contact:__tostring()
  local parts = { ("e = %g"):format(self.e) }
  if self.slip then parts[#parts + 1] = ("mu = %g, mu_s = %g"):format(self.mu, self.mu_s) end
  return ("unilateral contact '%s' (%s)"):format(self.name or "?", table.concat(parts, ", "))
end
M.Contact = Contact

local KNOWN = { e = true, mu = true, mu_s = true, slip = true, name = true, at = true }

local finite, shown = require("nz.base.args").finite, require("nz.base.args").shown

-- A contact's parameters checked, each error naming the contact and the
-- parameter with what it accepts (raised at `level`, counted from here as
-- error() counts: 3 is the caller of the caller of check).
function M.check(spec, what, level)
  local function bad(fmt, ...) error(("%s: " .. fmt):format(what, ...), level + 1) end
  if type(spec.gap) ~= "function" then bad("the gap must be a function(t, q, params) >= 0, got %s", type(spec.gap)) end
  if not (finite(spec.e) and spec.e >= 0 and spec.e <= 1) then
    bad("restitution 'e' must be a number in [0, 1] (0 plastic: the contact stays closed; 1 elastic), got %s",
      shown(spec.e))
  end
  if not (finite(spec.mu) and spec.mu >= 0) then
    bad("friction coefficient 'mu' must be a number >= 0, got %s", shown(spec.mu))
  end
  if not (finite(spec.mu_s) and spec.mu_s >= spec.mu) then
    bad("static friction coefficient 'mu_s' must be a number >= mu = %s (sticking holds at least what sliding "
      .. "does), got %s", shown(spec.mu), shown(spec.mu_s))
  end
  local cone = type(spec.slip) == "table" and #spec.slip == 2 and type(spec.slip[1]) == "function"
    and type(spec.slip[2]) == "function"
  if spec.slip ~= nil and type(spec.slip) ~= "function" and not cone then
    bad("'slip' must be a function(t, q, qd, params) giving the slip velocity, or {f1, f2}: the two slip velocities "
      .. "along orthonormal tangent directions (an isotropic cone), got %s", type(spec.slip))
  end
  if spec.mu > 0 and not spec.slip then
    bad("friction (mu = %s) needs 'slip', the slip velocity: function(t, q, qd, params) (e.g. qd[1] for a block "
      .. "sliding along x)", shown(spec.mu))
  end
  if spec.name ~= nil and type(spec.name) ~= "string" then bad("'name' must be a string, got %s", type(spec.name)) end
end

-- nz.unilateral(gap, opts): a contact for a system's constraints list.
function M.unilateral(gap, opts)
  if opts ~= nil and (type(opts) ~= "table" or getmetatable(opts) ~= nil) then
    error(("nz.unilateral: options {e =, mu =, mu_s =, slip =, name =, at =} expected, got %s"):format(type(opts)), 2)
  end
  opts = opts or {}
  require("nz.base.options").check(opts, KNOWN, function(fmt, ...) error(("nz.unilateral: " .. fmt):format(...), 4) end)
  local spec = setmetatable({ gap = gap, e = opts.e or 0, mu = opts.mu or 0, slip = opts.slip, name = opts.name,
    at = opts.at }, Contact)
  spec.mu_s = opts.mu_s or spec.mu
  M.check(spec, "nz.unilateral" .. (spec.name and (" '" .. spec.name .. "'") or ""), 3)
  return spec
end

-- A constraints field as the functions (the equalities) and the contacts.
function M.split(list)
  if type(list) ~= "table" or getmetatable(list) == Contact then
    if getmetatable(list) == Contact then return nil, { list } end
    return list, nil
  end
  local functions, contacts = {}, nil
  for _, c in ipairs(list) do
    if getmetatable(c) == Contact then
      contacts = contacts or {}
      contacts[#contacts + 1] = c
    else
      functions[#functions + 1] = c
    end
  end
  return functions, contacts
end

-- The contact system of sys (made by nz.system from def): the same pieces,
-- with every contact's gap (order 0) and slip function after the
-- constraints, each wrapped so that it receives the constraint slots
-- (t, q, qd, qdd, qddd, params) and hands the user (t, q, params) or
-- (t, q, qd, params).  sys.contact describes it for contact_run.lua.
function M.attach(sys, def, contacts, bilateral)
  local C, names, specs = {}, {}, {}
  for i, f in ipairs(bilateral or {}) do C[i] = f end
  local nb = #C
  local seen = {}
  for j, c in ipairs(contacts) do
    local name = c.name or ("contact " .. j)
    if seen[name] then
      error(("nz.system '%s': two contacts are named '%s'"):format(sys.name, name), 3)
    end
    seen[name] = true
    names[j] = name
    local gap = c.gap
    -- registered as the user's gap, so that a message about it names their
    -- function and line (nz/base/where.lua), not this wrapper's
    C[#C + 1] = where.wrap(function(t, q, qd, qdd, qddd, p) return gap(t, q, p) end, gap,
      ("contact '%s' (its gap)"):format(name))
    specs[j] = { gap = #C, e = c.e, mu = c.mu, mu_s = c.mu_s, at = c.at, name = name }
  end
  for j, c in ipairs(contacts) do
    if type(c.slip) == "function" then
      local slip = c.slip
      C[#C + 1] = where.wrap(function(t, q, qd, qdd, qddd, p) return slip(t, q, qd, p) end, slip,
        ("contact '%s' (its slip)"):format(names[j]))
      specs[j].slip = #C
    elseif c.slip then   -- an isotropic cone: both slip velocities, and |v_t| for Taylor's series (contact.h)
      local f1, f2, n = c.slip[1], c.slip[2], #C
      C[n + 1] = where.wrap(function(t, q, qd, qdd, qddd, p) return f1(t, q, qd, p) end, f1,
        ("contact '%s' (its slip)"):format(names[j]))
      C[n + 2] = where.wrap(function(t, q, qd, qdd, qddd, p) return f2(t, q, qd, p) end, f2,
        ("contact '%s' (its second slip)"):format(names[j]))
      local function speed(t, q, qd, qdd, qddd, p) return hypot(f1(t, q, qd, p), f2(t, q, qd, p)) end
      C[n + 3] = where.wrap(speed, f1, ("contact '%s' (its slip speed)"):format(names[j]))
      specs[j].slip, specs[j].slip2, specs[j].speed = n + 1, n + 2, n + 3
    end
  end
  local cdef = {}
  for key, v in pairs(def) do cdef[key] = v end
  cdef.constraints = C
  cdef.params = sys.params           -- the same table: a parameter changed is seen by both
  local csys = require("nz.base.classes").new_system(cdef)   -- its labels are the wrappers' (nz.system)
  sys.contact = { system = csys, nb = nb, contacts = specs, names = names, n = #contacts }
end

-- "N contacts" for print(sys).
function M.describe(sys)
  local c = sys.contact
  local fr = 0
  for _, s in ipairs(c.contacts) do if s.slip then fr = fr + 1 end end
  return ("%d unilateral contact%s (%s)%s"):format(c.n, c.n == 1 and "" or "s", table.concat(c.names, ", "),
    fr > 0 and (", %d with friction"):format(fr) or "")
end

return M
