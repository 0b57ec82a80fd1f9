-- demo.lua - a short tour of nzlua (run by `make demo`).
print(("nzlua %s: analytical mechanics with Taylor jets\n"):format(nz.version))

-- 1. A jet is a truncated Taylor series: the motion q(t) near t0.
local t = nz.jet(0.0, 8)                       -- the variable t near 0, order 8
local q = nz.sin(t) * nz.exp(-0.1 * t)          -- a damped oscillation
print("q(t) = sin(t) exp(-t/10) near t = 0, normalized coefficients q^(j)(0)/j!:")
for j = 0, 5 do print(("  c_%d = % .15f    q^(%d)(0) = % .12f"):format(j, q:coef(j), j, q:deriv(j))) end

-- 2. A mechanical system: a heavy pendulum.  T and V are written once; the
--    equations of any order n come from the jets.
sys = nz.system{
  name = "pendulum", coords = { "th" }, params = { m = 2.0, l = 1.3, g = 9.81 },
  T = function(t, q, qd, p) return 0.5 * p.m * p.l ^ 2 * qd[1] ^ 2 end,
  V = function(t, q, p) return -p.m * p.g * p.l * nz.cos(q[1]) end,
}
print("\n" .. tostring(sys))
local th, thd = { 0.7 }, { 0.3 }
local a = sys:accel(0, th, thd)
print(("th'' = %.15f   (closed form -(g/l) sin th = %.15f)"):format(a[1], -9.81 / 1.3 * math.sin(0.7)))
print()
sys:equations(2, 0, th, thd)
print("\nThe same residual from the generalized equations of orders 1, 2, 3, 12 at th'' = 0:")
for _, n in ipairs{ 1, 2, 3, 12 } do
  print(("  n = %2d: %.15f"):format(n, sys:residual(n, 0, th, thd, { 0 })[1]))
end

-- 3. Its motion at large amplitude: rk8pd at rtol 1e-10 by default; the
--    period against the complete elliptic integral (GSL).
tr = sys:simulate{ q0 = { 2.5 }, t1 = 8, dt = 0.02, monitors = { energy = true },
  events = { { name = "up", f = function(t, q) return q[1] end, direction = 1 } } }
print("\n" .. tostring(tr))
local ev = tr.events
print(("period: simulated %.10f, from the elliptic integral %.10f"):format((ev[#ev].t - ev[1].t) / (#ev - 1),
  4 * nz.special.ellint_K(math.sin(1.25)) * math.sqrt(1.3 / 9.81)))
tr:plot{ y = { "th" }, width = 72, height = 16 }

-- 4. Outside its domain a function says so instead of returning NaN.
local ok, err = pcall(nz.log, nz.jet(-1, 3))
print("\nnz.log of a jet at -1: " .. (ok and "no error?!" or err))
print("\nMore in examples/; type `build/nzlua` for a session, help() lists what nz offers.")
