-- chain.lua - the n-link planar pendulum the benchmarks share (bench/mech.lua,
-- accel_scaling.lua, pendulum18.lua; bench/pendulum_c.c is the same model
-- written by hand in C): k particles of mass 1 + 0.1 i, each hanging from the
-- previous by a link of 0.5, absolute angles, gravity 9.81 along -y.
local nz = rawget(_G, "nz") or require "nz"

-- chain(k [, fields]): the system; fields are added to nz.system's table
-- (native = true, compile = false, ...).
return function(k, fields)
  local bodies = { gravity = { 0, -9.81, 0 } }
  for i = 1, k do
    bodies[i] = { mass = 1 + 0.1 * i, pos = function(t, q)
      local x, y = 0, 0
      for j = 1, i do x = x + 0.5 * nz.sin(q[j]); y = y - 0.5 * nz.cos(q[j]) end
      return { x, y, 0 }
    end }
  end
  local coords = {}
  for i = 1, k do coords[i] = "th" .. i end
  local def = { name = ("%d-link pendulum"):format(k), coords = coords, bodies = bodies }
  for key, v in pairs(fields or {}) do def[key] = v end
  return nz.system(def)
end
