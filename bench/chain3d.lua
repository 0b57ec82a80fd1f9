-- chain3d.lua - a 3-D chain of rigid bodies for bench/scale.lua, beside the
-- planar chain of point masses (bench/chain.lua): links of length 0.5 and
-- mass 1 + 0.1 i (thin rods of radius 0.02), each hanging from the end of
-- the previous by a universal joint: two angles per link, a_i about the
-- previous link's x axis, then b_i about the new y axis, so that link i's
-- orientation is R_i = R_(i-1) Rx(a_i) Ry(b_i) (nz.rotations) and the chain
-- of k coordinates has k / 2 links; gravity 9.81 along -z.
local nz = rawget(_G, "nz") or require "nz"
local rot = nz.rotations

local L, RADIUS = 0.5, 0.02

-- chain3d(k [, fields]): the system of k coordinates (k even); fields are
-- added to nz.system's table (native = true, ...).
return function(k, fields)
  assert(k >= 2 and k % 2 == 0, "chain3d: an even number of coordinates expected")
  local links = k // 2
  -- R_i and the position of joint i (the top of link i) from the angles.
  local function frames(q, upto)
    local R, joint = { { 1, 0, 0 }, { 0, 1, 0 }, { 0, 0, 1 } }, { 0, 0, 0 }
    for i = 1, upto do
      if i > 1 then
        for r = 1, 3 do joint[r] = joint[r] - L * R[r][3] end   -- the end of link i - 1
      end
      R = rot.mul(rot.mul(R, rot.x(q[2 * i - 1])), rot.y(q[2 * i]))
    end
    return R, joint
  end
  local bodies = { gravity = { 0, 0, -9.81 } }
  for i = 1, links do
    local m = 1 + 0.1 * i
    local along, across = m * L * L / 12, m * RADIUS * RADIUS / 2
    bodies[i] = { mass = m, inertia = { along, along, across },
      pos = function(t, q)
        local R, joint = frames(q, i)
        return { joint[1] - 0.5 * L * R[1][3], joint[2] - 0.5 * L * R[2][3], joint[3] - 0.5 * L * R[3][3] }
      end,
      rot = function(t, q) return (frames(q, i)) end }
  end
  local coords = {}
  for i = 1, links do coords[2 * i - 1], coords[2 * i] = "a" .. i, "b" .. i end
  local def = { name = ("%d-link 3-D chain"):format(links), coords = coords, bodies = bodies }
  for key, v in pairs(fields or {}) do def[key] = v end
  return nz.system(def)
end
