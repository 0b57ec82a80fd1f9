-- nz/model/scene.lua - nz.scene{...}: a system assembled from bodies and the
-- effects the scene declares (lua/nz/model/effects.lua).  Only what is declared
-- is built, so only what is declared is ever computed.
local bodies = require "nz.model.bodies"
local effects = require "nz.model.effects"

local M = {}

local known = { name = true, coords = true, bodies = true, effects = true, T = true, V = true, Q = true,
  L = true, constraints = true, params = true, sample = true }

local function list_of(v)
  if v == nil then return {} end
  if type(v) == "function" then return { v } end
  return { table.unpack(v) }
end

-- nz.scene{ name =, coords = {...}, bodies = { {name =, mass =, pos = [, rot =, inertia =]}, ... },
--           effects = { nz.effects.gravity{}, nz.effects.spring{...}, ... },
--           T =, V =, Q =, L =, constraints = (extra pieces), params =, sample = }
function M.scene(def)
  if type(def) ~= "table" then error("nz.scene: a table {coords = ..., bodies = ..., effects = ...} expected", 2) end
  local name = def.name or "scene"
  for key in pairs(def) do
    if not known[key] then error(("nz.scene '%s': unknown field '%s'"):format(name, tostring(key)), 2) end
  end
  local coords = def.coords
  if type(coords) ~= "table" or #coords == 0 then error(("nz.scene '%s': 'coords' must list the coordinates"):format(name), 2) end
  local index = {}
  for i, c in ipairs(coords) do index[c] = i end

  local T, V, Q, L, C = list_of(def.T), list_of(def.V), list_of(def.Q), list_of(def.L), list_of(def.constraints)
  local S
  local by_name, names = {}, {}
  if def.bodies then
    local ok, list = pcall(bodies.validate, def.bodies)
    -- validate's position is this line, not the user's: keep only its text
    if not ok then error(("nz.scene '%s': %s"):format(name, tostring(list):gsub("^[^:]*:%d+: ", "")), 2) end
    local particles = true
    for i, b in ipairs(list) do
      local n = def.bodies[i].name or ("body " .. i)
      if by_name[n] then error(("nz.scene '%s': two bodies are named '%s'"):format(name, n), 2) end
      by_name[n], names[#names + 1] = b, n
      if b.rot then particles = false end
    end
    T[#T + 1] = bodies.kinetic(list)
    if particles then S = bodies.acceleration_energy(list) end
  end

  local sc = { k = #coords, body_names = names }
  function sc.body(n) return by_name[n] end
  function sc.fail(e, param, msg, ...)
    error(("nz.scene '%s': effect '%s': parameter '%s' %s"):format(name, e.kind, param, msg:format(...)), 0)
  end
  function sc.coordinate(e, param, c)
    return index[c] or sc.fail(e, param, "names no coordinate '%s' (coordinates: %s)", tostring(c), table.concat(coords, ", "))
  end

  local kinds, frictions = {}, {}
  -- one effect given bare would be a table ipairs sees nothing in: the scene
  -- would silently have no effects
  if def.effects ~= nil and (type(def.effects) ~= "table" or getmetatable(def.effects) == effects.Effect) then
    error(("nz.scene '%s': 'effects' must be a list of effects: effects = { nz.effects.NAME{...}, ... }%s"):format(name,
      getmetatable(def.effects) == effects.Effect and " (one effect too goes in braces)" or ""), 2)
  end
  for i, e in ipairs(def.effects or {}) do
    if getmetatable(e) ~= effects.Effect then
      error(("nz.scene '%s': effects[%d] is not an effect: make one with nz.effects.NAME{...}"):format(name, i), 2)
    end
    local ok, pieces = pcall(e.contribute, e, sc)
    if not ok then error(pieces, 2) end
    for _, f in ipairs(list_of(pieces.T)) do T[#T + 1] = f end
    for _, f in ipairs(list_of(pieces.V)) do V[#V + 1] = f end
    for _, f in ipairs(list_of(pieces.Q)) do Q[#Q + 1] = f end
    for _, f in ipairs(list_of(pieces.constraints)) do C[#C + 1] = f end
    if pieces.friction then frictions[#frictions + 1] = pieces.friction end
    kinds[#kinds + 1] = e.kind
  end
  -- friction goes on its contact (nz/model/contact.lua), once every contact is in
  local contacts = select(2, require("nz.model.contact").split(C)) or {}
  for _, f in ipairs(frictions) do
    local ok, err = pcall(effects.attach_friction, sc, contacts, f)
    if not ok then error(err, 2) end
  end
  local sys = require("nz.base.classes").new_system{ name = name, coords = coords, T = #T > 0 and T or nil, V = #V > 0 and V or nil,
    Q = #Q > 0 and Q or nil, L = #L > 0 and L or nil, S = S, constraints = #C > 0 and C or nil,
    params = def.params, sample = def.sample }
  sys.effects = kinds
  sys.bodies = def.bodies      -- kept for drawing (tr:animate)
  -- the gravity of the first gravity effect, for drawing: tr:animate{
  -- view = "3d" } puts up against it
  for _, e in ipairs(def.effects or {}) do
    if e.kind == "gravity" then sys.gravity = e.g or effects.DEFAULT_GRAVITY; break end
  end
  return sys
end

return M
