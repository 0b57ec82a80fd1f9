-- demo.lua - a short tour of nzlua (run by `make demo`).
print(("nzlua %s: analytical mechanics with Taylor jets\n"):format(nz.version))

-- 1. A jet is a truncated Taylor series: the motion q(t) near t0.
local t = nz.jet(0.0, 8)                       -- the variable t near 0, order 8
local q = nz.sin(t) * nz.exp(-0.1 * t)          -- a damped oscillation
print("q(t) = sin(t) exp(-t/10) near t = 0, normalized coefficients q^(j)(0)/j!:")
for j = 0, 6 do print(("  c_%d = % .15f    q^(%d)(0) = % .12f"):format(j, q:coef(j), j, q:deriv(j))) end

-- 2. A tangent direction carries a partial derivative through every
--    coefficient: here d/dw of the series of sin(w t) at w = 2.  A constant
--    parameter gets the order of the series it meets (a result is only
--    known to the lower order of its operands).
local w = nz.jet{ 2.0, order = 4, tangents = { { 1 } } }
local y = nz.sin(w * nz.jet(0.5, 4))
print("\nd/dw of the Taylor coefficients of sin(w t) at w = 2, t0 = 0.5:")
for j = 0, 4 do print(("  d c_%d / dw = % .15f"):format(j, y:tangent(1):coef(j))) end
print(("  check, j = 0: t0 cos(w t0) = % .15f"):format(0.5 * math.cos(1.0)))

-- 3. High orders stay finite and exact: the 60th coefficient of 1/(1 - t)^2.
local g = (1 - nz.jet(0, 60)) ^ -2
print(("\n1/(1 - t)^2 at order 60: c_60 = %.17g (exact: 61)"):format(g:coef(60)))

-- 4. Outside its domain a function says so instead of returning NaN.
local ok, err = pcall(nz.log, nz.jet(-1, 3))
print("\nnz.log of a jet at -1: " .. (ok and "no error?!" or err))
print("\nType `build/nzlua` for a session; help() lists what nz offers.")
