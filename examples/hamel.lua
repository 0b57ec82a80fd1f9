-- hamel.lua - Hamel's second-order constraint q3'' = q1'' q2'' (docs/theory.md §10):
-- nonlinear in the accelerations, so the rule asks for the equations with q'''
-- (n = 3), and the accelerations are a root of a nonlinear system.
local m, Q = 1.5, { 0.7, -0.4, 2.0 }
hamel = nz.system{
  name = "Hamel's particle", coords = { "q1", "q2", "q3" },
  T = function(t, q, qd) return 0.5 * m * (qd[1] ^ 2 + qd[2] ^ 2 + qd[3] ^ 2) end,
  Q = function() return { Q[1], Q[2], Q[3] } end,
  constraints = { function(t, q, qd, qdd) return qdd[3] - qdd[1] * qdd[2] end },
}
print(hamel:constraints())
local n, why = hamel:rule()
print("\n" .. why)
local q, qd = { 0, 0, 0 }, { 0.4, -0.5, 0.6 }
local a, lambda, report = hamel:accel(0, q, qd)
print(("\nroot reached from the %s accelerations in %d iterations: q'' = (%.12f, %.12f, %.12f), lambda = %.12f")
  :format(report.start, report.iterations, a[1], a[2], a[3], lambda[1]))
print("the closed-form equations of Liu-Jin-Mei at that root:")
print(("  m q1''(1 + q2''^2) - Q1 - Q3 q2'' = %.1e"):format(m * a[1] * (1 + a[2] ^ 2) - Q[1] - Q[3] * a[2]))
print(("  m q2''(1 + q1''^2) - Q2 - Q3 q1'' = %.1e"):format(m * a[2] * (1 + a[1] ^ 2) - Q[2] - Q[3] * a[1]))
for _, order in ipairs{ n, 1 } do
  local r = hamel:residual(order, 0, q, qd, a, lambda)
  print(("residual of order %d: max |r| = %.1e"):format(order, math.max(math.abs(r[1]), math.abs(r[2]), math.abs(r[3]))))
end

-- Along the motion the accelerations stay on the root reached at the start.
tr = hamel:simulate{ q0 = q, qd0 = qd, t1 = 10 }
print(tr)
tr:plot{ y = { "q1", "q2", "q3" }, width = 72, height = 18 }
local worst = 0
for i = 1, #tr.t do for j = 1, 3 do worst = math.max(worst, math.abs(tr.qdd[i][j] - a[j])) end end
print(("largest change of q'' along the motion: %.1e (one root branch)"):format(worst))
