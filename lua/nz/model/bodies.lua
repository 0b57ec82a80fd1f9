-- nz/model/bodies.lua - kinetic energy, gravity potential and acceleration energy
-- of particles and rigid bodies whose positions (and orientations) are Lua
-- functions of (t, q).  Velocities come from the jets (nz/model/hyperdual.lua), not
-- from the user.  A mass, an inertia and the gravity are numbers or
-- functions of the params (mass = function(p) return p.m end): called with
-- the params at each evaluation, so that while a system records its
-- functions they read the parameters' graph inputs (nz/model/record.lua) and
-- the equations keep the symbols (sys:show prints m, not 2), and a run with
-- other params moves otherwise.
local core = require "nz.core"
local hyperdual = require "nz.model.hyperdual"

local M = {}

local function fail(i, msg, ...)
  error(("nz.bodies: body %d: " .. msg):format(i, ...), 4)
end

-- A value of a body's: a number, or (while a function of the params
-- returns it) a parameter's graph input or a jet.
local function is_value(x) return type(x) == "number" or core.isjet(x) end

local function check_vector(v, n, what, i)
  if type(v) ~= "table" or #v ~= n then fail(i, "'%s' must be a list of %d numbers", what, n) end
  for j = 1, n do if not is_value(v[j]) then fail(i, "'%s'[%d] must be a number", what, j) end end
end

-- The inertia tensor in body axes: {I1, I2, I3} (principal) or a 3x3 table.
-- Raises through `fail` (its level counts from M.validate's caller).
local function inertia_matrix(I, i)
  if type(I) ~= "table" then fail(i, "'inertia' must be {I1, I2, I3}, a 3x3 matrix or a function(params) returning one") end
  if type(I[1]) ~= "table" then
    check_vector(I, 3, "inertia", i)
    return { { I[1], 0, 0 }, { 0, I[2], 0 }, { 0, 0, I[3] } }
  end
  for r = 1, 3 do check_vector(I[r], 3, "inertia row " .. r, i) end
  for r = 1, 3 do for c = 1, 3 do
    local a, b = I[r][c], I[c][r]
    if type(a) == "number" and type(b) == "number" and math.abs(a - b) > 1e-12 * (math.abs(a) + 1) then
      fail(i, "'inertia' must be symmetric (entry %d,%d differs from %d,%d)", r, c, c, r)
    end
  end end
  return I
end

-- A number given as a number or as a function of the params: its value.
function M.value(v, p)
  if type(v) == "function" then return v(p) end
  return v
end

-- A body's mass, inertia matrix and the gravity for params p, a function's
-- result checked where it is used (the error names the body and the field).
local function evaluated_error(body, what, want, got)
  error(("%s: '%s' = function(params) returned %s: %s expected"):format(body.name, what,
    type(got) == "number" and tostring(got) or type(got), want), 0)
end

local function mass_of(b, p)
  if type(b.mass) ~= "function" then return b.mass end
  local m = b.mass(p)
  if not is_value(m) or (type(m) == "number" and not (m > 0)) then evaluated_error(b, "mass", "a positive number", m) end
  return m
end

local function inertia_of(b, p)
  if type(b.inertia) ~= "function" then return b.inertia end
  local I = b.inertia(p)
  local ok, matrix = pcall(inertia_matrix, I, 0)
  if not ok then evaluated_error(b, "inertia", "{I1, I2, I3} or a symmetric 3x3 matrix of numbers", I) end
  return matrix
end

local function gravity_of(g, p)
  if type(g) ~= "function" then return g end
  local v = g(p)
  if type(v) ~= "table" or #v ~= 3 or not (is_value(v[1]) and is_value(v[2]) and is_value(v[3])) then
    evaluated_error({ name = "gravity" }, "gravity", "a vector {gx, gy, gz}", v)
  end
  return v
end
M.mass_of, M.inertia_of, M.gravity_of = mass_of, inertia_of, gravity_of

local function validate(spec)
  if type(spec) ~= "table" then error("nz.bodies: a table of bodies expected", 3) end
  local bodies = {}
  for i, b in ipairs(spec) do
    if type(b) ~= "table" then fail(i, "a table {mass = ..., pos = ...} expected") end
    for key in pairs(b) do
      if key ~= "mass" and key ~= "pos" and key ~= "rot" and key ~= "inertia" and key ~= "name" then
        fail(i, "unknown field '%s' (expected mass, pos, rot, inertia, name)", tostring(key))
      end
    end
    if type(b.mass) ~= "function" and (type(b.mass) ~= "number" or not (b.mass > 0)) then
      fail(i, "'mass' must be a positive number or a function(params) returning one")
    end
    if type(b.pos) ~= "function" then fail(i, "'pos' must be a function(t, q, params) returning {x, y, z}") end
    if (b.rot == nil) ~= (b.inertia == nil) then fail(i, "a rigid body needs both 'rot' and 'inertia'") end
    if b.rot ~= nil and type(b.rot) ~= "function" then fail(i, "'rot' must be a function(t, q, params) returning a 3x3 rotation matrix") end
    local inertia = b.inertia
    if inertia ~= nil and type(inertia) ~= "function" then inertia = inertia_matrix(inertia, i) end
    bodies[i] = { mass = b.mass, pos = b.pos, rot = b.rot, inertia = inertia, name = b.name or ("body " .. i) }
  end
  if #bodies == 0 then
    -- a single body given bare: a table with fields, not a list
    if spec.mass ~= nil or spec.pos ~= nil then
      error("nz.bodies: a list of bodies expected: bodies = { {mass = ..., pos = ...}, ... } (one body too goes in braces)", 3)
    end
    error("nz.bodies: no bodies given", 3)
  end
  if spec.gravity ~= nil and type(spec.gravity) ~= "function" then check_vector(spec.gravity, 3, "gravity", 0) end
  return bodies, spec.gravity
end

local function point(body, r)
  if type(r) ~= "table" or #r ~= 3 then
    error(("%s: 'pos' must return {x, y, z}, got %s"):format(body.name, type(r) == "table" and (#r .. " values") or type(r)), 0)
  end
  return r
end

-- r and r' of a body at (t, q, q'): evaluate pos at (t + eta, q + eta q').
local function lifted_args(t, q, qd)
  local ql = {}
  for i = 1, #q do ql[i] = hyperdual.new(q[i], qd[i]) end
  return hyperdual.new(t, 1), ql
end

local function kinetic(bodies)
  return function(t, q, qd, p)
    local tl, ql = lifted_args(t, q, qd)
    local T = 0
    for _, b in ipairs(bodies) do
      local r = point(b, b.pos(tl, ql, p))
      local v2 = 0
      for j = 1, 3 do local _, d = hyperdual.parts(r[j]); v2 = v2 + d * d end
      T = T + 0.5 * mass_of(b, p) * v2
      if b.rot then
        -- Body angular velocity from Omega = R^T R' (skew): omega = vee(Omega).
        local R = b.rot(tl, ql, p)
        local Rv, Rd = {}, {}
        for r_ = 1, 3 do
          Rv[r_], Rd[r_] = {}, {}
          for c = 1, 3 do Rv[r_][c], Rd[r_][c] = hyperdual.parts(R[r_][c]) end
        end
        local function Om(a, c)
          local s = 0
          for k = 1, 3 do s = s + Rv[k][a] * Rd[k][c] end
          return s
        end
        local w = { Om(3, 2), Om(1, 3), Om(2, 1) }
        local I = inertia_of(b, p)
        for a = 1, 3 do for c = 1, 3 do
          if I[a][c] ~= 0 then T = T + 0.5 * I[a][c] * w[a] * w[c] end
        end end
      end
    end
    return T
  end
end

local function potential(bodies, g)
  return function(t, q, p)
    local V = 0
    local gv = gravity_of(g, p)
    for _, b in ipairs(bodies) do
      local r = point(b, b.pos(t, q, p))
      local m = mass_of(b, p)
      for j = 1, 3 do if gv[j] ~= 0 then V = V - m * gv[j] * r[j] end end
    end
    return V
  end
end

-- Appell's acceleration energy S = sum m |r''|^2 / 2 along the motion: the
-- engine passes q as series, and r'' is the second derivative of r's series.
local function acceleration_energy(bodies)
  return function(t, q, p)
    local S = 0
    for _, b in ipairs(bodies) do
      local r = point(b, b.pos(t, q, p))
      for j = 1, 3 do
        if core.isjet(r[j]) and r[j]:order() >= 2 then
          local a = r[j]:derivative():derivative()
          S = S + 0.5 * mass_of(b, p) * a * a
        end
      end
    end
    return S
  end
end

M.validate = validate
M.kinetic = kinetic
M.potential = potential
M.acceleration_energy = acceleration_energy

-- nz.bodies{ {mass = m, pos = f [, rot = g, inertia = I]}, ..., gravity = {gx, gy, gz} }
-- (m, I and the gravity numbers or functions of the params)
-- returns {T = ..., V = ... (with gravity), S = ... (particles only)}.
function M.bodies(spec)
  local bodies, g = validate(spec)
  local particles_only = true
  for _, b in ipairs(bodies) do if b.rot then particles_only = false end end
  return {
    T = kinetic(bodies),
    V = g and potential(bodies, g) or nil,
    S = particles_only and acceleration_energy(bodies) or nil,
  }
end

return M
