-- scene_cost.lua - only what a scene declares is computed: the same motion
-- (a pendulum) as scenes that differ in what they declare, reported as the
-- cost of one right-hand-side evaluation (wall time / evaluations, over a
-- run of at least half a second; the median of three runs).
local nz = rawget(_G, "nz") or require "nz"
local E = nz.effects
local g, l = 9.81, 1.0

local bob = { name = "bob", mass = 1.0, pos = function(t, q) return { l * nz.sin(q[1]), 0, -l * nz.cos(q[1]) } end }

local function angle_scene()
  return nz.scene{ name = "pendulum", coords = { "th" }, bodies = { bob }, effects = { E.gravity{} } }
end

local scenes = {
  { "angle, gravity only", angle_scene, {} },
  { "same, with 12 unused effects made", function()
      local unused = {}
      for i = 1, 4 do
        unused[#unused + 1] = E.spring{ coordinate = "th", k = i }
        unused[#unused + 1] = E.damper{ coordinate = "th", c = i }
        unused[#unused + 1] = E.force{ f = function() return { i } end }
      end
      return angle_scene()
    end, {} },
  { "same, with a zero damper declared", function()
      return nz.scene{ name = "pendulum", coords = { "th" }, bodies = { bob }, effects = { E.gravity{}, E.damper{ coordinate = "th", c = 1e-300 } } }
    end, {} },
  { "same, monitors energy + work", angle_scene, { monitors = { energy = true, work = true } } },
  { "Cartesian, no constraint (free fall)", function()
      return nz.scene{ name = "falling bob", coords = { "x", "z" },
        bodies = { { name = "bob", mass = 1.0, pos = function(t, q) return { q[1], 0, q[2] } end } },
        effects = { E.gravity{} } }
    end, { cartesian = true } },
  { "Cartesian + holonomic constraint", function()
      return nz.scene{ name = "cartesian pendulum", coords = { "x", "z" },
        bodies = { { name = "bob", mass = 1.0, pos = function(t, q) return { q[1], 0, q[2] } end } },
        effects = { E.gravity{}, E.constraint{ f = function(t, q) return q[1] ^ 2 + q[2] ^ 2 - l * l end } } }
    end, { cartesian = true } },
}

local function cost(make, extra)
  local sys = make()
  local th0 = 1.0
  local o = { t1 = 20, dt = 0.5, progress = false }
  if extra.cartesian then o.q0, o.qd0 = { l * math.sin(th0), -l * math.cos(th0) }, { 0, 0 }
  else o.q0, o.qd0 = { th0 }, { 0 } end
  o.monitors = extra.monitors
  local runs = {}
  for r = 1, 3 do
    local wall, nfev = 0, 0
    repeat
      local tr = sys:simulate(o)
      wall, nfev = wall + tr.stats.wall, nfev + tr.stats.nfev
    until wall >= 0.5
    runs[r] = wall / nfev
  end
  table.sort(runs)
  return runs[2]
end

print("Cost of one right-hand-side evaluation, by what the scene declares (pendulum, rk8pd)")
print(("%-36s %14s %10s"):format("scene", "us per eval", "relative"))
local base
for _, s in ipairs(scenes) do
  local c = cost(s[2], s[3])
  base = base or c
  print(("%-36s %14.2f %9.2fx"):format(s[1], 1e6 * c, c / base))
end
