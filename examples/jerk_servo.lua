-- jerk_servo.lua - a servo constraint on the jerk, x''' + 2 y''' = sin t, on a
-- particle under a constant force: third order, linear in q''' (n = 3).  Under
-- it q'' is part of the state: the motion is integrated at level 3 with the
-- state (q, qd, qdd, lambda), and (6.2) differentiated once gives q''' and
-- lambda'.  sys:project completes the start (qdd0 and the multiplier).
local m, F = 1.7, { 0.3, -0.45 }
servo = nz.system{
  name = "servo on the jerk", coords = { "x", "y" },
  T = function(t, q, qd) return 0.5 * m * (qd[1] ^ 2 + qd[2] ^ 2) end,
  Q = function() return { F[1], F[2] } end,
  constraints = { function(t, q, qd, qdd, qddd) return qddd[1] + 2 * qddd[2] - sin(t) end },
}
print(servo:constraints())
local _, why = servo:rule()
print("\n" .. why)
local q0, qd0 = { 0.1, 0.2 }, { 0.3, -0.1 }
local q, qd, start = servo:project(0, q0, qd0, { qdd = { 0.2, 0.1 } })
print(("\nconsistent start: qdd0 = (%.12f, %.12f), lambda0 = %.12f"):format(start.qdd[1], start.qdd[2], start.lambda[1]))
for _, order in ipairs{ 3, 1 } do
  local r = servo:residual(order, 0, q, qd, start.qdd, start.lambda)
  print(("residual of order %d at the start: max |r| = %.1e"):format(order, math.max(math.abs(r[1]), math.abs(r[2]))))
end

-- rtol 1e-12: the motion is compared with its closed form to ~1e-13 below
tr = servo:simulate{ q0 = q, qd0 = qd, qdd0 = start.qdd, t1 = 6, rtol = 1e-12, atol = 1e-12 }
print(tr)
tr:plot{ y = { "lambda1" }, width = 72, height = 14 }
-- By hand: 5 lambda' / m = sin t, so lambda = lambda0 + m (1 - cos t) / 5 and
-- x = x0 + vx t + (F1 + lambda0) t^2/(2m) + (t^2/2 - 1 + cos t)/5 (y: 2 lambda, F2).
local worst, l0 = 0, start.lambda[1]
for i, t in ipairs(tr.t) do
  local s = t * t / 2 - 1 + math.cos(t)
  local x = q0[1] + qd0[1] * t + (F[1] + l0) * t * t / (2 * m) + s / 5
  local y = q0[2] + qd0[2] * t + (F[2] + 2 * l0) * t * t / (2 * m) + 2 * s / 5
  worst = math.max(worst, math.abs(tr.q[i][1] - x), math.abs(tr.q[i][2] - y),
    math.abs(tr.lambda[i][1] - (l0 + m * (1 - math.cos(t)) / 5)))
end
print(("largest error against the closed form: %.1e"):format(worst))
