-- nz/presentation/view3d.lua - tr:animate{ view = "3d" }: the bodies of a
-- system in space, frame by frame.  In a notebook an interactive three.js
-- scene (nz/draw/three.lua) with the same motion as an animated GIF inside
-- (what an exported page shows where the scene cannot be drawn); in the
-- terminal and to a file the GIF's drawing, the scene seen from a fixed
-- direction (views.lua's frames, projected here).
--
-- What is drawn, from the bodies (nz/model/bodies.lua) at each frame's
-- state: a particle as a sphere; a rigid body as its ellipsoid of inertia
-- (the uniform solid ellipsoid of the body's mass and principal moments:
-- semi-axes a_i^2 = 5 (I_j + I_k - I_i) / (2 m)), turned by its rot, with
-- its body axes; links from the origin through the bodies in turn (as the
-- plane view draws them; links = false: none); each contact's point while
-- it is held; each body's path; a grid across the up direction (against
-- gravity when the system has one, else z) under everything.
local bodies_mod = require "nz.model.bodies"
local plot = require "nz.draw.plot"

local M = {}

-- The direction the scene is first seen from, in the frame (h1, h2, up) of
-- the up direction: from 30 degrees above the floor, between h1 and -h2
-- (for z up: from x, -y and above, as a textbook draws axes).
local EYE_AZIMUTH, EYE_ELEVATION = math.rad(-55), math.rad(28)
-- A flat body's thinnest semi-axis, as a share of its largest (a body whose
-- moments are those of a lamina or impossible ones draws as a thin disk).
local THINNEST = 0.06
-- A particle's radius and a contact's dot, as shares of the scene's size.
local PARTICLE, DOT = 0.045, 0.02

local function dot(a, b) return a[1] * b[1] + a[2] * b[2] + a[3] * b[3] end
local function cross(a, b) return { a[2] * b[3] - a[3] * b[2], a[3] * b[1] - a[1] * b[3], a[1] * b[2] - a[2] * b[1] } end
local function unit(v) local n = math.sqrt(dot(v, v)); return { v[1] / n, v[2] / n, v[3] / n } end
local function mat_vec(R, v)
  return { R[1][1] * v[1] + R[1][2] * v[2] + R[1][3] * v[3], R[2][1] * v[1] + R[2][2] * v[2] + R[2][3] * v[3],
    R[3][1] * v[1] + R[3][2] * v[2] + R[3][3] * v[3] }
end

-- The eigenvalues and eigenvectors (the columns of E) of a symmetric 3x3
-- matrix, by Jacobi's rotations (Golub and Van Loan, Matrix Computations,
-- 8.5): a body's principal moments and axes in its own axes.
local function principal(I)
  local A = { { I[1][1], I[1][2], I[1][3] }, { I[2][1], I[2][2], I[2][3] }, { I[3][1], I[3][2], I[3][3] } }
  local E = { { 1, 0, 0 }, { 0, 1, 0 }, { 0, 0, 1 } }
  for _ = 1, 50 do
    local p, q, big = 1, 2, 0
    for r = 1, 2 do for c = r + 1, 3 do
      if math.abs(A[r][c]) > big then p, q, big = r, c, math.abs(A[r][c]) end
    end end
    if big <= 1e-15 * (math.abs(A[1][1]) + math.abs(A[2][2]) + math.abs(A[3][3])) then break end
    local theta = (A[q][q] - A[p][p]) / (2 * A[p][q])
    local t = (theta >= 0 and 1 or -1) / (math.abs(theta) + math.sqrt(theta * theta + 1))
    local c = 1 / math.sqrt(t * t + 1)
    local s = t * c
    for k = 1, 3 do      -- A <- J^T A J, E <- E J, J the rotation in the (p, q) plane
      local akp, akq = A[k][p], A[k][q]
      A[k][p], A[k][q] = c * akp - s * akq, s * akp + c * akq
    end
    for k = 1, 3 do
      local apk, aqk = A[p][k], A[q][k]
      A[p][k], A[q][k] = c * apk - s * aqk, s * apk + c * aqk
    end
    for k = 1, 3 do
      local ekp, ekq = E[k][p], E[k][q]
      E[k][p], E[k][q] = c * ekp - s * ekq, s * ekp + c * ekq
    end
  end
  return { A[1][1], A[2][2], A[3][3] }, E
end

-- A rigid body's ellipsoid of inertia: semi-axes and the principal axes in
-- the body's axes (nil for a particle).
local function ellipsoid(b, params)
  local m, I = bodies_mod.mass_of(b, params), bodies_mod.inertia_of(b, params)
  local moments, E = principal(I)
  local semi, largest = {}, 0
  for i = 1, 3 do
    local j, k = i % 3 + 1, (i + 1) % 3 + 1
    semi[i] = math.sqrt(math.max(0, 5 * (moments[j] + moments[k] - moments[i]) / (2 * m)))
    largest = math.max(largest, semi[i])
  end
  for i = 1, 3 do semi[i] = math.max(semi[i], THINNEST * largest) end
  return semi, E
end

-- The up direction: against the gravity of the bodies (nz.system{bodies =
-- {gravity = ...}}) or of a scene's gravity effect, else z.
local function up_of(sys)
  local g = sys.bodies and sys.bodies.gravity or sys.gravity
  if g then
    local v = bodies_mod.gravity_of(g, sys.params)
    if type(v[1]) == "number" and dot(v, v) > 0 then return unit{ -v[1], -v[2], -v[3] } end
  end
  return { 0, 0, 1 }
end

-- The contacts with a point, and each one's point at (t, q) while it is held.
local function contact_points(tr, t, q)
  local out = {}
  if not tr.contacts then return out end
  local mode
  for _, m in ipairs(tr.contacts.modes) do if m.t <= t then mode = m.states end end
  for j, s in ipairs(tr.system.contact.contacts) do
    if s.at then out[#out + 1] = (mode and mode[j] ~= "open") and s.at(t, q, tr.system.params) or false end
  end
  return out
end

-- The state of the bodies at (t, q): positions, rotations (false for a
-- particle) and the contacts' points.
local function state(tr, list, t, q)
  local p, R = {}, {}
  for k, b in ipairs(list) do
    p[k] = b.pos(t, q, tr.system.params)
    R[k] = b.rot and b.rot(t, q, tr.system.params) or false
  end
  return { t = t, p = p, R = R, c = contact_points(tr, t, q) }
end

-- Everything the scene shows: the bodies' shapes, each frame's state, the
-- up direction, the eye's direction, the scene's centre and size, the grid.
function M.model(tr, idx, opts)
  local sys = tr.system
  local list = bodies_mod.validate(sys.bodies)
  local frames = {}
  for f, i in ipairs(idx) do frames[f] = state(tr, list, tr.t[i], tr.q[i]) end
  -- (h1, h2, up) right-handed, h1 the axis after up's nearest in x, y, z,
  -- z -> (x, y, z), y -> (z, x, y): the scene is seen as the same system
  -- with z up would be
  local up = up_of(sys)
  local a = 1
  for i = 2, 3 do if math.abs(up[i]) > math.abs(up[a]) then a = i end end
  local h1 = { 0, 0, 0 }
  h1[a % 3 + 1] = 1
  local along = dot(h1, up)
  h1 = unit{ h1[1] - along * up[1], h1[2] - along * up[2], h1[3] - along * up[3] }
  local h2 = cross(up, h1)
  local ce, se = math.cos(EYE_ELEVATION), math.sin(EYE_ELEVATION)
  local ca, sa = math.cos(EYE_AZIMUTH), math.sin(EYE_AZIMUTH)
  local eye = {}
  for a = 1, 3 do eye[a] = ce * (ca * h1[a] + sa * h2[a]) + se * up[a] end
  -- the box of every centre (and the origin the links start from)
  local lo, hi = { math.huge, math.huge, math.huge }, { -math.huge, -math.huge, -math.huge }
  local function grow(v, r)
    for a = 1, 3 do lo[a], hi[a] = math.min(lo[a], v[a] - r), math.max(hi[a], v[a] + r) end
  end
  if opts.links ~= false then grow({ 0, 0, 0 }, 0) end
  local shapes, extent = {}, 0
  for k, b in ipairs(list) do
    if b.rot then
      local semi, E = ellipsoid(b, sys.params)
      shapes[k] = { semi = semi, E = E }
      extent = math.max(extent, semi[1], semi[2], semi[3])
    end
  end
  for _, f in ipairs(frames) do
    for k, p in ipairs(f.p) do grow(p, shapes[k] and math.max(table.unpack(shapes[k].semi)) or 0) end
    for _, c in ipairs(f.c) do if c then grow(c, 0) end end
  end
  local center = { (lo[1] + hi[1]) / 2, (lo[2] + hi[2]) / 2, (lo[3] + hi[3]) / 2 }
  local size = math.max(math.sqrt((hi[1] - lo[1]) ^ 2 + (hi[2] - lo[2]) ^ 2 + (hi[3] - lo[3]) ^ 2) / 2, extent, 1e-3)
  local radius = PARTICLE * 2 * size
  for k in ipairs(list) do shapes[k] = shapes[k] or { semi = { radius, radius, radius } } end
  -- the grid: under the lowest point of every frame, across up
  local floor = math.huge
  for _, f in ipairs(frames) do
    for k, p in ipairs(f.p) do floor = math.min(floor, dot(p, up) - math.max(table.unpack(shapes[k].semi))) end
    for _, c in ipairs(f.c) do if c then floor = math.min(floor, dot(c, up)) end end
  end
  if opts.links ~= false then floor = math.min(floor, 0) end
  local lift = floor - dot(center, up)
  local step = 10 ^ math.floor(math.log(size / 2, 10))
  return { list = list, frames = frames, shapes = shapes, up = up, eye = eye, center = center, size = size,
    dot = DOT * 2 * size, links = opts.links ~= false,
    grid = { center = { center[1] + lift * up[1], center[2] + lift * up[2], center[3] + lift * up[3] },
      size = 2 * math.ceil(1.5 * size / step) * step, divisions = 2 * math.ceil(1.5 * size / step) } }
end

-- JSON of the model for the player (numbers to 6 digits: a picture).
local function json(model, width, height, fps)
  local js_string = require("nz.draw.three").js_string
  local function num(x) return ("%.6g"):format(x) end
  local function vec(v) local o = {}; for i = 1, #v do o[i] = num(v[i]) end; return "[" .. table.concat(o, ",") .. "]" end
  local function mat(R)
    if not R then return "0" end
    return vec{ R[1][1], R[1][2], R[1][3], R[2][1], R[2][2], R[2][3], R[3][1], R[3][2], R[3][3] }
  end
  local bodies = {}
  for k, b in ipairs(model.list) do
    local s = model.shapes[k]
    bodies[k] = ('{"name":%s,"colour":%s,"semi":%s,"principal":%s,"axes":%s}'):format(js_string(b.name),
      js_string(plot.COLOURS[(k - 1) % #plot.COLOURS + 1]), vec(s.semi), s.E and mat(s.E) or "null",
      s.E and num(1.6 * math.max(table.unpack(s.semi))) or "0")
  end
  local frames = {}
  for f, fr in ipairs(model.frames) do
    local p, R, c = {}, {}, {}
    for k = 1, #fr.p do p[k], R[k] = vec(fr.p[k]), mat(fr.R[k]) end
    for j = 1, #fr.c do c[j] = fr.c[j] and vec(fr.c[j]) or "0" end
    frames[f] = ('{"t":%s,"p":[%s],"R":[%s],"c":[%s]}'):format(num(fr.t), table.concat(p, ","), table.concat(R, ","),
      table.concat(c, ","))
  end
  local contacts = {}
  for j = 1, #(model.frames[1].c) do contacts[j] = "1" end
  return ('{"width":%d,"height":%d,"fps":%s,"up":%s,"eye":%s,"center":%s,"radius":%s,"dot":%s,"links":%s,'
    .. '"grid":{"center":%s,"size":%s,"divisions":%d},"bodies":[%s],"contacts":[%s],"frames":[%s]}'):format(
    width, height, num(fps), vec(model.up), vec(model.eye), vec(model.center), num(model.size), num(model.dot),
    tostring(model.links), vec(model.grid.center), num(model.grid.size), model.grid.divisions,
    table.concat(bodies, ","), table.concat(contacts, ","), table.concat(frames, ","))
end

-- The scene from the eye's direction, for views.lua's frames: draw(t, q)
-- in the plane of the picture (right, screen-up): each body's centre a
-- point, a rigid body the three principal sections of its ellipsoid and
-- its axes, the links from the origin (a pivot there), the contacts' points.
local SECTION_SEGMENTS = 24
local function projection(tr, model)
  local f = { -model.eye[1], -model.eye[2], -model.eye[3] }
  local right = unit(cross(f, model.up))
  local screen_up = cross(right, f)
  local function xy(v) return { dot(v, right), dot(v, screen_up) } end
  return function(t, q)
    local s = state(tr, model.list, t, q)
    local points, segments = {}, {}
    local prev = { 0, 0 }
    for k, b in ipairs(model.list) do
      local c = xy(s.p[k])
      points[#points + 1] = { c[1], c[2], body = b.name }
      if model.links then segments[#segments + 1] = { prev[1], prev[2], c[1], c[2] } end
      prev = c
      local shape = model.shapes[k]
      if shape.E then
        local RE = {}
        for r = 1, 3 do RE[r] = mat_vec(s.R[k], { shape.E[1][r], shape.E[2][r], shape.E[3][r] }) end
        for a = 1, 3 do        -- the section across principal axis a
          local u, w = RE[a % 3 + 1], RE[(a + 1) % 3 + 1]
          local su, sw = shape.semi[a % 3 + 1], shape.semi[(a + 1) % 3 + 1]
          local last
          for n = 0, SECTION_SEGMENTS do
            local phi = 2 * math.pi * n / SECTION_SEGMENTS
            local v = {}
            for i = 1, 3 do v[i] = s.p[k][i] + su * math.cos(phi) * u[i] + sw * math.sin(phi) * w[i] end
            local here = xy(v)
            if last then segments[#segments + 1] = { last[1], last[2], here[1], here[2] } end
            last = here
          end
        end
      end
    end
    for _, c in ipairs(s.c) do
      if c then local p = xy(c); points[#points + 1] = { p[1], p[2] } end
    end
    return { points = points, segments = segments, pivots = model.links and { { 0, 0 } } or nil }
  end
end

-- tr:animate{ view = "3d", ... } (views.lua has checked the options; frames
-- draws views.lua's frames of a drawing function, as tr:animate does).
function M.animate(tr, opts, idx, draw_frames)
  local model = M.model(tr, idx, opts)
  local draw = projection(tr, model)
  local frontend = require "nz.base.frontend"
  if opts.file or not frontend.accepts("text/html") then return draw_frames(tr, opts, draw) end
  -- a notebook: the scene, with the GIF of the same frames inside
  local display = require "nz.draw.display"
  local gif = plot.drawn("gif", function(o) return draw_frames(tr, o, draw) end, opts, opts.width, opts.height)
  local width, height = (opts.width or 60) * 8, (opts.height or 30) * 16
  local name = tr.system.name
  display.show(display.bundle{
    ["text/html"] = function()
      return require("nz.draw.three").html(json(model, width, height, opts.fps or 20), width, height, gif,
        ("3-D view of %s"):format(name))
    end,
    ["image/gif"] = gif,
    ["text/plain"] = ("3-D view of '%s': %d frames"):format(name, #idx),
  })
  return frontend.shown(#idx, {})
end

return M
