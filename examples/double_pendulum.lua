-- double_pendulum.lua - a system built from two particles; its equations of
-- every order agree, and the table of (3.1) shows the terms per coordinate.
local g = 9.81
sys = nz.system{
  name = "double pendulum", coords = { "a", "b" },
  params = { l1 = 1.0, l2 = 0.7, m1 = 2.0, m2 = 1.0 },
  bodies = {
    gravity = { 0, -g, 0 },
    { mass = 2.0, pos = function(t, q, p) return { p.l1 * sin(q[1]), -p.l1 * cos(q[1]), 0 } end },
    { mass = 1.0, pos = function(t, q, p)
        return { p.l1 * sin(q[1]) + p.l2 * sin(q[2]), -p.l1 * cos(q[1]) - p.l2 * cos(q[2]), 0 } end },
  },
}
print(sys)
print(select(2, sys:rule()))
local t, q, qd = 0, { 0.7, -0.4 }, { 0.3, 1.1 }
local a = sys:accel(t, q, qd)
print(("accelerations: a'' = %.12f, b'' = %.12f"):format(a[1], a[2]))
print()
sys:equations(1, t, q, qd)
print()
sys:equations(2, t, q, qd)
print()
print("The residual at those accelerations, for every form and order n = 1..6:")
for _, form in ipairs(nz.forms) do
  local worst = 0
  for n = form == "wassmuth" and 2 or 1, 6 do
    local r = sys:residual(n, t, q, qd, a, form)
    worst = math.max(worst, math.abs(r[1]), math.abs(r[2]))
  end
  print(("  %-12s max |residual| = %.1e"):format(form, worst))
end
local E, H = sys:energy(t, q, qd)
print(("energy T + V = %.12f, generalized energy H = %.12f (equal: the system is scleronomic)"):format(E, H))

tr = sys:simulate{ q0 = q, qd0 = qd, t1 = 5, monitors = { energy = true } }
print(tr)
tr:plot{ y = { "a", "b" }, width = 72, height = 18 }
