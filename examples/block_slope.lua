-- block_slope.lua - a block on a slope of angle alpha with Coulomb friction
-- (mu sliding, mu_s sticking).  Started up the slope at v0 it slides, friction
-- and gravity slowing it at g (sin alpha + mu cos alpha): it stops after
-- v0^2 / (2 g (sin alpha + mu cos alpha)).  There the slip velocity reaches
-- zero and nzlua decides (the contact's LCP at rest): with tan alpha <= mu_s
-- the friction needed to hold it, m g sin alpha, is within mu_s m g cos alpha
-- and it sticks for good; on a steeper slope it slides back at g (sin alpha -
-- mu cos alpha).
local g, alpha, mu, v0, m = 9.81, 0.4, 0.3, 2.5, 1.5
local function pos(t, q)   -- x along the slope, y off it
  return { q[1] * cos(alpha) - q[2] * sin(alpha), 0, q[1] * sin(alpha) + q[2] * cos(alpha) }
end
local function block(mu_s)
  return nz.scene{ name = ("block, mu_s = %g"):format(mu_s), coords = { "x", "y" },
    bodies = { { name = "block", mass = m, pos = pos } },
    effects = { nz.effects.gravity{ g = { 0, 0, -g } },
                nz.effects.contact{ name = "slope", gap = function(t, q) return q[2] end, at = "block" },
                nz.effects.friction{ contact = "slope", mu = mu, mu_s = mu_s,
                  slip = function(t, q, qd) return qd[1] end } } }
end
local dec = g * (sin(alpha) + mu * cos(alpha))
print(("tan alpha = %.4f; closed form: it stops at t = %.12f after x = %.12f"):format(math.tan(alpha), v0 / dec,
  v0 ^ 2 / (2 * dec)))
for _, mu_s in ipairs{ 0.5, 0.35 } do
  slope = block(mu_s)
  tr = slope:simulate{ q0 = { 0, 0 }, qd0 = { v0, 0 }, t1 = 1.5, dt = 0.01 }
  print(tr)
  for _, ev in ipairs(tr.events) do
    print(("  t = %.12f  %s %s (%s -> %s) at x = %.12f"):format(ev.t, ev.name, ev.kind, ev.from, ev.to, ev.q[1]))
  end
  print(("  friction at the end: %.9f N (m g sin alpha = %.9f N, mu m g cos alpha = %.9f N)"):format(
    tr:column("T.slope")[#tr.t], m * g * sin(alpha), mu * m * g * cos(alpha)))
end
tr:plot{ y = { "x", "x'" }, title = "a block slides up a slope and back (mu_s < tan alpha)" }
