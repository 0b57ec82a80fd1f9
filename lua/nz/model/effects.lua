-- nz/model/effects.lua - the effects a scene can declare (nz.scene{effects = ...}).
--
-- An effect is a table made by one of the constructors below; it checks its
-- parameters when made (an error names the effect and the parameter) and,
-- when the scene is built, contributes pieces through the ordinary system
-- definition: V, Q, T functions and constraints.  Nothing in the engine
-- knows an effect by name, and an effect that a scene does not declare costs
-- nothing.  Points are body names, functions (t, q, params) -> {x, y, z}
-- (moving supports) or fixed {x, y, z}; coordinates are given by name.  A
-- number that enters the equations (a stiffness, a radius, the gravity) may
-- also be a function of the params (k = function(p) return p.k end), read
-- at each evaluation as a body's mass is (nz/model/bodies.lua): the
-- equations keep the parameter's symbol and follow sys.params.
local core = require "nz.core"
local hyperdual = require "nz.model.hyperdual"

local M = {}
local Effect = { __name = "nz.effect" }
Effect.__index = Effect
function Effect:__tostring() return ("effect '%s'"):format(self.kind) end
M.Effect = Effect

local function param_error(kind, param, msg, ...)
  error(("effect '%s': parameter '%s' %s"):format(kind, param, msg:format(...)), 4)   -- the user's line
end

-- Check args against spec {name = {type = "number"|"point"|"coordinate"|
-- "function"|"vector"|"coordinates", required =, positive =, nonnegative =,
-- param = (a function of the params is taken too, and checked where it is
-- used)}}.
local function check(kind, args, spec)
  if type(args) ~= "table" then error(("effect '%s': a table of parameters expected"):format(kind), 3) end
  for key in pairs(args) do
    if not spec[key] then
      local names = {}
      for k in pairs(spec) do names[#names + 1] = k end
      table.sort(names)
      error(("effect '%s': unknown parameter '%s' (parameters: %s)"):format(kind, tostring(key), table.concat(names, ", ")), 3)
    end
  end
  for name, s in pairs(spec) do
    local v = args[name]
    if v == nil then
      if s.required then param_error(kind, name, "is missing (%s)", s.doc or s.type) end
    elseif s.param and type(v) == "function" then
      -- a function of the params: its value is checked where it is read
    elseif s.type == "number" then
      if type(v) ~= "number" or v ~= v then
        param_error(kind, name, "must be a number%s, got %s", s.param and " or a function(params) returning one" or "", type(v))
      end
      if s.positive and not (v > 0) then param_error(kind, name, "must be positive, got %g", v) end
      if s.nonnegative and not (v >= 0) then param_error(kind, name, "must not be negative, got %g", v) end
      if s.max and not (v <= s.max) then param_error(kind, name, "must be at most %g (%s), got %g", s.max, s.doc, v) end
    elseif s.type == "function" then
      if type(v) ~= "function" then param_error(kind, name, "must be a function, got %s", type(v)) end
    elseif s.type == "string" then
      if type(v) ~= "string" then param_error(kind, name, "must be a string, got %s", type(v)) end
    elseif s.type == "table" then
      if type(v) ~= "table" then param_error(kind, name, "must be a table %s, got %s", s.doc or "", type(v)) end
    elseif s.type == "coordinate" then
      if type(v) ~= "string" then param_error(kind, name, "must be a coordinate name, got %s", type(v)) end
    elseif s.type == "coordinates" then
      if type(v) ~= "table" or #v == 0 then param_error(kind, name, "must be a list of coordinate names") end
    elseif s.type == "vector" then
      if type(v) ~= "table" or #v ~= 3 then
        param_error(kind, name, "must be a vector {x, y, z}%s", s.param and " or a function(params) returning one" or "")
      end
    elseif s.type == "point" or s.type == "pair" then
      local pts = s.type == "pair" and v or { v }
      if s.type == "pair" and (type(v) ~= "table" or #v ~= 2) then param_error(kind, name, "must be two points {A, B}") end
      for _, p in ipairs(pts) do
        local ok = type(p) == "string" or type(p) == "function" or (type(p) == "table" and #p == 3)
        if not ok then param_error(kind, name, "must hold points: a body name, a function(t, q, params) or {x, y, z}") end
      end
    end
  end
end

local function define(kind, spec, contribute, doc)
  M[kind] = function(args)
    check(kind, args, spec)
    local o = setmetatable({ kind = kind }, Effect)
    for k, v in pairs(args) do o[k] = v end
    o.contribute = contribute
    return o
  end
  M.docs = M.docs or {}
  M.docs[kind] = doc
  M.specs = M.specs or {}        -- the parameters, for help(nz.effects.NAME)
  M.specs[kind] = spec
end

-- ------------------------------------------------------------------ --
-- Helpers the contributions share (the scene is `sc`: sc.body(name),  --
-- sc.coordinate(name) -> index, sc.k, sc.fail(effect, param, msg))      --

local function point_fn(sc, e, param, p)
  if type(p) == "function" then return p end
  if type(p) == "string" then
    local b = sc.body(p)
    if not b then sc.fail(e, param, "names no body '%s'", p) end
    return b.pos
  end
  local fixed = { p[1], p[2], p[3] }
  return function() return fixed end
end

local function distance(ra, rb)
  local d = { ra[1] - rb[1], ra[2] - rb[2], ra[3] - rb[3] }
  return core.sqrt(d[1] * d[1] + d[2] * d[2] + d[3] * d[3])
end

-- f evaluated at (t + eta dt, q + eta dq): value and eta-part.
local function along(f, t, q, p, dt, dq)
  local ql = {}
  for i = 1, #q do ql[i] = hyperdual.new(q[i], dq and dq[i] or 0) end
  local r = f(hyperdual.new(t, dt or 0), ql, p)
  if type(r) == "table" and not hyperdual.is(r) then     -- a point {x, y, z}
    local v, d = {}, {}
    for i = 1, #r do v[i], d[i] = hyperdual.parts(r[i]) end
    return v, d
  end
  return hyperdual.parts(r)
end

local function unit(k, i) local e = {}; for j = 1, k do e[j] = j == i and 1 or 0 end; return e end

-- A parameter given as a number or a function of the params: its value.
local value = require("nz.model.bodies").value

-- ------------------------------------------------------------------ --
-- Forces                                                               --

M.DEFAULT_GRAVITY = { 0, 0, -9.81 }
define("gravity", { g = { type = "vector", param = true, doc = "{gx, gy, gz}, default {0, 0, -9.81}" },
  bodies = { type = "coordinates", doc = "names of the bodies it acts on (default all)" } },
  function(e, sc)
    local g = e.g or M.DEFAULT_GRAVITY
    local list = {}
    for _, name in ipairs(e.bodies or sc.body_names) do
      local b = sc.body(name)
      if not b then sc.fail(e, "bodies", "names no body '%s'", name) end
      list[#list + 1] = b
    end
    return { V = require("nz.model.bodies").potential(list, g) }
  end, "uniform gravity on the bodies: V = -sum m g . r")

define("spring", {
  between = { type = "pair", doc = "two points {A, B}" }, coordinate = { type = "coordinate" },
  k = { type = "number", required = true, positive = true, param = true, doc = "the stiffness, a positive number" },
  length = { type = "number", nonnegative = true, param = true }, rest = { type = "number", param = true },
  cubic = { type = "number", param = true }, energy = { type = "function" } },
  function(e, sc)
    local function law(s, p)
      if e.energy then return e.energy(s) end
      local k, k3 = value(e.k, p), value(e.cubic or 0, p)
      return 0.5 * k * s * s + 0.25 * k3 * s * s * s * s
    end
    if e.coordinate then
      local j = sc.coordinate(e, "coordinate", e.coordinate)
      return { V = function(t, q, p) return law(q[j] - value(e.rest or 0, p), p) end }
    end
    if not e.between then sc.fail(e, "between", "is missing: give two points {A, B} or a coordinate") end
    local a, b = point_fn(sc, e, "between", e.between[1]), point_fn(sc, e, "between", e.between[2])
    return { V = function(t, q, p) return law(distance(a(t, q, p), b(t, q, p)) - value(e.length or 0, p), p) end }
  end, "a spring between two points (or on a coordinate): V = k s^2/2 + cubic s^4/4, or energy(s)")

define("damper", {
  between = { type = "pair" }, coordinate = { type = "coordinate" },
  c = { type = "number", required = true, positive = true, param = true, doc = "the damping coefficient" } },
  function(e, sc)
    if e.coordinate then
      local j = sc.coordinate(e, "coordinate", e.coordinate)
      return { Q = function(t, q, qd, p)
        local Q = {}
        for i = 1, sc.k do Q[i] = 0 end
        Q[j] = -value(e.c, p) * qd[j]
        return Q
      end }
    end
    if not e.between then sc.fail(e, "between", "is missing: give two points {A, B} or a coordinate") end
    local a, b = point_fn(sc, e, "between", e.between[1]), point_fn(sc, e, "between", e.between[2])
    local function s(t, q, p) return distance(a(t, q, p), b(t, q, p)) end
    -- Rayleigh's D = c s'^2 / 2: Q_i = -dD/dq'_i = -c s' ds/dq_i.
    return { Q = function(t, q, qd, p)
      local _, sdot = along(s, t, q, p, 1, qd)
      local c = value(e.c, p)
      local Q = {}
      for i = 1, sc.k do
        local _, ds = along(s, t, q, p, 0, unit(sc.k, i))
        Q[i] = -c * sdot * ds
      end
      return Q
    end }
  end, "viscous damping (Rayleigh dissipation c s'^2/2) between two points or on a coordinate")

define("force", {
  f = { type = "function", doc = "function(t, q, qd, params) returning k generalized forces" },
  at = { type = "point" }, F = { type = "function", doc = "function(t, q, qd, params) returning {Fx, Fy, Fz}" } },
  function(e, sc)
    if e.f then return { Q = e.f } end
    if not (e.at and e.F) then sc.fail(e, "F", "is missing: give f (generalized forces) or at = point and F") end
    local r = point_fn(sc, e, "at", e.at)
    -- Virtual work: Q_i = F . dr/dq_i.
    return { Q = function(t, q, qd, p)
      local F = e.F(t, q, qd, p)
      local Q = {}
      for i = 1, sc.k do
        local _, dr = along(r, t, q, p, 0, unit(sc.k, i))
        Q[i] = F[1] * dr[1] + F[2] * dr[2] + F[3] * dr[3]
      end
      return Q
    end }
  end, "an external force: generalized f(t, q, qd), or a force F(t, q, qd) applied at a point")

-- ------------------------------------------------------------------ --
-- Constraints                                                          --

define("driven", { coordinate = { type = "coordinate", required = true },
  motion = { type = "function", required = true, doc = "function(t) giving the coordinate" } },
  function(e, sc)
    local j = sc.coordinate(e, "coordinate", e.coordinate)
    return { constraints = { function(t, q) return q[j] - e.motion(t) end } }
  end, "a prescribed motion q_j = motion(t) (a rheonomic holonomic constraint; lambda is the drive's force)")

define("knife_edge", { x = { type = "coordinate", required = true }, y = { type = "coordinate", required = true },
  heading = { type = "coordinate", required = true } },
  function(e, sc)
    local x, y, th = sc.coordinate(e, "x", e.x), sc.coordinate(e, "y", e.y), sc.coordinate(e, "heading", e.heading)
    return { constraints = { function(t, q, qd) return -qd[x] * core.sin(q[th]) + qd[y] * core.cos(q[th]) end } }
  end, "no velocity across a blade at (x, y) with the given heading")

define("rolling_disk", { x = { type = "coordinate", required = true }, y = { type = "coordinate", required = true },
  heading = { type = "coordinate", required = true }, angle = { type = "coordinate", required = true },
  radius = { type = "number", required = true, positive = true, param = true } },
  function(e, sc)
    local x, y = sc.coordinate(e, "x", e.x), sc.coordinate(e, "y", e.y)
    local th, ph = sc.coordinate(e, "heading", e.heading), sc.coordinate(e, "angle", e.angle)
    return { constraints = {
      function(t, q, qd, qdd, qddd, p) return qd[x] - value(e.radius, p) * qd[ph] * core.cos(q[th]) end,
      function(t, q, qd, qdd, qddd, p) return qd[y] - value(e.radius, p) * qd[ph] * core.sin(q[th]) end,
    } }
  end, "a vertical disk rolling without slipping: x' = R ph' cos th, y' = R ph' sin th")

define("rolling_ball", { body = { type = "coordinate", required = true, doc = "the name of the ball's body (with rot)" },
  radius = { type = "number", required = true, positive = true, param = true } },
  function(e, sc)
    local b = sc.body(e.body)
    if not b then sc.fail(e, "body", "names no body '%s'", e.body) end
    if not b.rot then sc.fail(e, "body", "'%s' has no rotation (rot): a ball needs one", e.body) end
    -- The contact point's velocity v + omega x (0, 0, -R) vanishes, with
    -- omega = vee(R' R^T) in space axes: v_x - R omega_y = 0, v_y + R omega_x = 0.
    local function contact(comp)
      return function(t, q, qd, qdd, qddd, p)   -- params after the four levels (slot rule)
        local ql = {}
        for i = 1, #q do ql[i] = hyperdual.new(q[i], qd[i]) end
        local tl = hyperdual.new(t, 1)
        local r, Rm = b.pos(tl, ql, p), b.rot(tl, ql, p)
        local Rv, Rd = {}, {}
        for i = 1, 3 do
          Rv[i], Rd[i] = {}, {}
          for j = 1, 3 do Rv[i][j], Rd[i][j] = hyperdual.parts(Rm[i][j]) end
        end
        local function W(i, j) return Rd[i][1] * Rv[j][1] + Rd[i][2] * Rv[j][2] + Rd[i][3] * Rv[j][3] end
        local omega = { W(3, 2), W(1, 3), W(2, 1) }
        local _, vx = hyperdual.parts(r[1])
        local _, vy = hyperdual.parts(r[2])
        local R = value(e.radius, p)
        if comp == 1 then return vx - R * omega[2] end
        return vy + R * omega[1]
      end
    end
    return { constraints = { contact(1), contact(2) } }
  end, "a ball (a body with rot) rolling without slipping on the plane z = const")

define("constant_speed", { coords = { type = "coordinates", required = true },
  speed = { type = "number", required = true, positive = true, param = true } },
  function(e, sc)
    local idx = {}
    for i, name in ipairs(e.coords) do idx[i] = sc.coordinate(e, "coords", name) end
    return { constraints = { function(t, q, qd, qdd, qddd, p)
      local s = 0
      for _, j in ipairs(idx) do s = s + qd[j] * qd[j] end
      local v = value(e.speed, p)
      return s - v * v
    end } }
  end, "the speed in the given coordinates is held constant (nonlinear, first order)")

define("constraint", { f = { type = "function", required = true, doc = "Phi(t, q, qd, qdd, qddd, params)" } },
  function(e) return { constraints = { e.f } } end, "any constraint Phi(t, q, qd, qdd, ...) = 0 (its order is found)")

-- ------------------------------------------------------------------ --
-- Contacts (issue 26, nz/model/contact.lua): unilateral constraints         --

local function dot3(a, b) return a[1] * b[1] + a[2] * b[2] + a[3] * b[3] end

local function unit3(kind, sc, e, param, v)
  local n = math.sqrt(dot3(v, v))
  if not (n > 0) then param_error(kind, param, "must be a nonzero vector {x, y, z}") end
  return { v[1] / n, v[2] / n, v[3] / n }
end

define("contact", {
  name = { type = "string", doc = "its name (in tr.events, and for nz.effects.friction)" },
  gap = { type = "function", doc = "function(t, q, params): the distance, >= 0 (or give at and plane/sphere)" },
  at = { type = "point", doc = "the point that touches: a body, a function(t, q, params) or {x, y, z}" },
  plane = { type = "table", doc = "{point = {x, y, z}, normal = {x, y, z}}: at stays on the normal's side" },
  sphere = { type = "table", doc = "{center = {x, y, z}, radius = R}: at stays outside" },
  radius = { type = "number", nonnegative = true, param = true, doc = "the touching body's radius (default 0)" },
  e = { type = "number", nonnegative = true, max = 1, doc = "Newton's restitution in [0, 1] (default 0: plastic)" } },
  function(e, sc)
    local name = e.name or "contact"
    local gap, at = e.gap, e.at and point_fn(sc, e, "at", e.at)
    if not gap then
      if not at or not (e.plane or e.sphere) then
        sc.fail(e, "gap", "is missing: give gap = function(t, q, params), or at = a point with plane = {...} or sphere = {...}")
      end
      if e.plane then
        local p0, pn = e.plane.point or { 0, 0, 0 }, e.plane.normal
        if type(pn) ~= "table" or #pn ~= 3 then sc.fail(e, "plane", "must be {point = {x, y, z}, normal = {x, y, z}}") end
        local n = unit3("contact", sc, e, "plane", pn)
        gap = function(t, q, p)
          local r = at(t, q, p)
          return n[1] * (r[1] - p0[1]) + n[2] * (r[2] - p0[2]) + n[3] * (r[3] - p0[3]) - value(e.radius or 0, p)
        end
      else
        local c, R = e.sphere.center or { 0, 0, 0 }, e.sphere.radius
        if type(R) ~= "function" and (type(R) ~= "number" or not (R > 0)) then
          sc.fail(e, "sphere", "must be {center = {x, y, z}, radius = R > 0 (or a function(params))}")
        end
        gap = function(t, q, p) return distance(at(t, q, p), c) - value(R, p) - value(e.radius or 0, p) end
      end
    end
    local spec = require("nz.model.contact").unilateral(gap, { e = e.e or 0, name = name })
    spec.at = at                            -- drawn by tr:animate
    spec.point, spec.normal = at, e.plane and unit3("contact", sc, e, "plane", e.plane.normal)
    return { constraints = { spec } }
  end, "a unilateral contact: gap(t, q) >= 0 (or a point against a plane or a sphere), restitution e")

define("friction", {
  contact = { type = "string", required = true, doc = "the name of the contact (nz.effects.contact{name = ...})" },
  mu = { type = "number", required = true, nonnegative = true, doc = "Coulomb's sliding coefficient" },
  mu_s = { type = "number", nonnegative = true, doc = "the sticking coefficient, >= mu (default mu)" },
  slip = { type = "function", doc = "function(t, q, qd, params): the slip velocity (or of (t, q): its rate)" },
  tangent = { type = "vector", doc = "{x, y, z}: slip = tangent . (velocity of the contact's point)" } },
  function(e, sc)
    return { friction = { contact = e.contact, mu = e.mu, mu_s = e.mu_s or e.mu, slip = e.slip, tangent = e.tangent } }
  end, "Coulomb friction at a contact: sliding with mu, sticking within mu_s (planar)")

-- A friction effect put on its contact (nz.scene, once every effect is in):
-- the contact spec gets mu, mu_s and the slip velocity.
function M.attach_friction(sc, contacts, f)
  local spec
  for _, c in ipairs(contacts) do if c.name == f.contact then spec = c end end
  local names = {}
  for _, c in ipairs(contacts) do names[#names + 1] = c.name end
  local e = { kind = "friction" }
  if not spec then
    sc.fail(e, "contact", "names no contact '%s' (contacts: %s)", f.contact,
      #names > 0 and table.concat(names, ", ") or "none: declare nz.effects.contact{name = ...}")
  end
  if spec.slip then sc.fail(e, "contact", "'%s' has friction already", f.contact) end
  local slip = f.slip
  if not slip then
    if not (f.tangent and spec.point) then
      sc.fail(e, "slip", "is missing: give slip = function(t, q, qd, params), or tangent = {x, y, z} on a contact with 'at'")
    end
    local tv, r = unit3("friction", sc, e, "tangent", f.tangent), spec.point
    slip = function(t, q, qd, p)
      local _, v = along(r, t, q, p, 1, qd)
      return tv[1] * v[1] + tv[2] * v[2] + tv[3] * v[3]
    end
  end
  if f.mu_s < f.mu then
    sc.fail(e, "mu_s", "must be >= mu = %g (sticking holds at least what sliding does), got %g", f.mu, f.mu_s)
  end
  spec.mu, spec.mu_s, spec.slip = f.mu, f.mu_s, slip
end

return M
