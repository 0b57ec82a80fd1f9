-- sphere_particle.lua - a particle released near the top of a smooth sphere
-- slides down, held by the sphere while the sphere pushes, and leaves it
-- where the push would have to become a pull: cos th = (2/3) cos th0 (the
-- classical answer, from the energy and the normal force m (g cos th -
-- v^2/R)).  A unilateral contact (nz.effects.contact: the point outside a
-- sphere) closes at rest at the start and opens there by itself, located
-- where its normal force reaches zero; then the particle flies a parabola.
local g, R, th0 = 9.81, 1.0, 0.25
particle = nz.scene{ name = "particle on a sphere", coords = { "x", "z" },
  bodies = { { name = "p", mass = 0.2, pos = function(t, q) return { q[1], 0, q[2] } end } },
  effects = { nz.effects.gravity{ g = { 0, 0, -g } },
              nz.effects.contact{ name = "sphere", at = "p", sphere = { center = { 0, 0, 0 }, radius = R } } } }
print(particle)
tr = particle:simulate{ q0 = { R * sin(th0), R * cos(th0) }, t1 = 1.2, dt = 0.005 }
print(tr)
local leave
for _, ev in ipairs(tr.events) do if ev.kind == "opens" then leave = ev end end
local th = math.atan(leave.q[1], leave.q[2])
print(("leaves the sphere at t = %.12f, th = %.12f rad: cos th = %.12f, (2/3) cos th0 = %.12f"):format(
  leave.t, th, math.cos(th), 2 / 3 * math.cos(th0)))
-- the normal force while it slides: m g (3 cos th - 2 cos th0), zero where it leaves
local N, worst = tr:column("N.sphere"), 0
for i, t in ipairs(tr.t) do
  if t < leave.t then
    local thi = math.atan(tr.q[i][1], tr.q[i][2])
    worst = math.max(worst, math.abs(N[i] - 0.2 * g * (3 * math.cos(thi) - 2 * math.cos(th0))))
  end
end
print(("normal force against m g (3 cos th - 2 cos th0): largest difference %.3g N"):format(worst))
tr:plot{ y = { "x", "z" }, title = "a particle leaves a sphere" }
