-- jet_spec.lua - the jet engine through Lua: closed-form series, identities
-- to order 40, tangents against finite differences and against the Taylor
-- series itself, mixed arithmetic, shapes, and every domain error.
local h = require "tests.helpers"
local nz = h.nz
local eps = 2.220446049250313e-16

-- A generic smooth jet with O(1) coefficients and a wide radius of
-- convergence, at order K: x(t) = 0.7 + 0.3 t - 0.2 t^2 + 0.05 t^3.
local function generic(K, tangents)
  return nz.jet{ 0.7, 0.3, -0.2, 0.05, order = K, tangents = tangents }
end

local function fact(n) local f = 1.0; for i = 2, n do f = f * i end; return f end

describe("jet construction and access", function()
  it("nz.jet(t0, K) is the variable t0 + (t - t0)", function()
    local t = nz.jet(2.385, 5)
    assert.are.equal(5, t:order())
    assert.are.equal(2.385, t:value())
    assert.are.equal(1, t:coef(1))
    assert.are.equal(0, t:coef(2))
    assert.are.equal(0, t:ntangents())
  end)
  it("nz.jet{...} takes coefficients, an order and tangents", function()
    local x = nz.jet{ 1, 2, order = 4, tangents = { { 0, 1 } } }
    assert.are.same({ 1, 2, 0, 0, 0 }, x:coefs())
    assert.are.equal(1, x:ntangents())
    assert.are.same({ 0, 1, 0, 0, 0 }, x:tangent(1):coefs())
  end)
  it("deriv(j) is j! coef(j)", function()
    local y = nz.exp(nz.jet(0.385, 12))
    for j = 0, 12 do
      assert(math.abs(y:deriv(j) - math.exp(0.385)) <= 8 * eps * math.exp(0.385),
        ("deriv(%d) = %.17g, expected exp(0.385)"):format(j, y:deriv(j)))
    end
  end)
  it("accepts order 0 (dual numbers) and order 1024", function()
    local d = nz.dual(2.385, 2, 3)
    assert.are.equal(0, d:order())
    assert.are.equal(3, d:ntangents())
    local y = d * d
    assert.are.equal(2 * 2.385, y:tangent(2):value())
    assert.are.equal(0, y:tangent(1):value())
    assert.are.equal(1024, nz.jet(0, 1024):order())
  end)
  it("derivative() shifts the series: the coefficients of dx/dt", function()
    local y = nz.sin(nz.jet(0.385, 6, 1, 1))
    local d = y:derivative()
    assert.are.equal(5, d:order())
    h.assert_series(d, nz.cos(nz.jet(0.385, 5)), 5, 8 * eps, "d/dt sin")
    h.assert_series(d:tangent(1), -nz.sin(nz.jet(0.385, 5)), 5, 8 * eps, "d/dt of the tangent")
    h.checkerror("'derivative' of a jet of order 0: its derivative is unknown", function() return nz.dual(1, 1):derivative() end)
  end)
  it("prints readably", function()
    assert.are.equal("jet{0, 1, 0; order 2}", tostring(nz.jet(0, 2)))
    assert.truthy(tostring(nz.jet(1, 1, 1, 1)):find("d1: 1, 0", 1, true))
    assert.truthy(tostring(nz.jet(0, 20)):find(", ...; order 20", 1, true))
  end)
  it("prints each coefficient in the shortest digits that read back exactly, as the session prints numbers", function()
    -- sin t = t - t^3/6 + t^5/120: -1/6 needs 17 digits, 1/120 16; 0.1 stays 0.1
    assert.are.equal("jet{0, 1, 0, -0.16666666666666666, 0, 0.008333333333333333; order 5}", tostring(nz.sin(nz.jet(0, 5))))
    assert.are.equal("jet{0.1, 1; order 1}", tostring(nz.jet(0.1, 1)))
    -- every coefficient and tangent read back from the text is the jet's, bit for bit
    local x = nz.exp(nz.sin(nz.jet(0.385, 6, 1, 2)) / 3)
    local text = tostring(x)
    local value, d1 = text:match("^jet{(.-); order 6; d1: (.-); d2")
    local j = 0
    for c in value:gmatch("[^, ]+") do assert.are.equal(x:coef(j), tonumber(c)); j = j + 1 end
    assert.are.equal(7, j)
    j = 0
    for c in d1:gmatch("[^, ]+") do assert.are.equal(x:tangent(1):coef(j), tonumber(c)); j = j + 1 end
    -- and with no more digits than that: one digit fewer reads back another number
    for c in value:gmatch("[^, ]+") do
      local digits = #c:gsub("^%-", ""):gsub("e.*$", ""):gsub("^0%.0*", ""):gsub("%.", "")
      if digits > 15 then
        assert.are_not.equal(tonumber(c), tonumber(("%." .. (digits - 1) .. "g"):format(tonumber(c))), c)
      end
    end
  end)
  it("rejects bad arguments with a clear message", function()
    h.checkerror("bad argument #2 to 'jet' (the order must be a whole number from 0 to 1024, got 2000)", nz.jet, 0, 2000)
    h.checkerror("the order must be a whole number from 0 to 1024, got -1", nz.jet, 0, -1)
    -- a fractional, NaN or huge order says so (not Lua's "number has no integer representation")
    h.checkerror("the order must be a whole number from 0 to 1024, got 2.5", nz.jet, 0, 2.5)
    h.checkerror("the order must be a whole number from 0 to 1024, got NaN", nz.jet, 0, 0 / 0)
    h.checkerror("the order must be a whole number from 0 to 1024, got 1e+300", nz.jet, 0, 1e300)
    h.checkerror("field 'order' must be a whole number from 0 to 1024, got 2.5", nz.jet, { 1, 2, order = 2.5 })
    h.checkerror("the tangent direction must be a whole number from 1 to 1024, got 0", nz.jet, 0, 3, 0)
    -- a tangent count below the direction: why the lower bound is what it is
    h.checkerror("bad argument #4 to 'jet' (the tangent count must be a whole number from 5 (the tangent direction: "
      .. "direction d needs d tangents) to 1024, got 2)", nz.jet, 0, 3, 5, 2)
    h.checkerror("entry 2 is a string, number expected", nz.jet, { 1, "x" })
    h.checkerror("3 coefficients given for order 1", nz.jet, { 1, 2, 3, order = 1 })
    h.checkerror("coefficient index between 0 and 2 expected, got 3", function() return nz.jet(0, 2):coef(3) end)
    h.checkerror("direction between 1 and 0 expected, got 1", function() return nz.jet(0, 2):tangent(1) end)
    h.checkerror("number or jet expected, got string", nz.sin, "x")
    h.checkerror("overflows a double; use coef(200)", function() return nz.exp(nz.jet(0, 200) * 1e3):deriv(200) end)
  end)
  it("rejects NaN and inf where a jet is made", function()
    h.checkerror("bad argument #1 to 'jet' (finite number expected, got NaN)", nz.jet, 0 / 0, 3)
    h.checkerror("bad argument #1 to 'jet' (finite number expected, got inf)", nz.jet, math.huge, 3)
    h.checkerror("bad argument #1 to 'dual' (finite number expected, got NaN)", nz.dual, 0 / 0, 1)
    h.checkerror("bad argument #1 to 'dual' (finite number expected, got -inf)", nz.dual, -math.huge, 1)
    h.checkerror("(coefficients: entry 2 is NaN, finite number expected)", nz.jet, { 1, 0 / 0, 3 })
    h.checkerror("(tangent series: entry 1 is inf, finite number expected)", nz.jet,
      { 1, 2, tangents = { { math.huge } } })
  end)
end)

describe("deriv never returns a derivative the doubles cannot hold", function()
  -- exp(t0 + s): every derivative is exp(t0), c_j = exp(t0) / j!.
  local e = math.exp(0.5)
  it("up to order 170 the coefficients are normal doubles: j! c_j = exp(t0)", function()
    local y = nz.exp(nz.jet(0.5, 170))
    for _, j in ipairs { 100, 150, 165, 170 } do
      -- c_j is a sum of j rounded terms and j! is j - 1 more roundings.
      assert(math.abs(y:deriv(j) - e) <= 4 * j * eps * e,
        ("deriv(%d) = %.17g, expected exp(0.5) = %.17g"):format(j, y:deriv(j), e))
    end
  end)
  it("order 180, where c_j underflows to 0 (the issue's case), is an error, not 0", function()
    local y = nz.exp(nz.jet(0.5, 180))
    h.checkerror("'deriv': coefficient 180 is 0, and 180! times a coefficient that underflowed to 0 can be 9.9e+05",
      function() return y:deriv(180) end)
    -- From 171 on, 1/j! is below the smallest normal double, 2.2250738585072014e-308.
    h.checkerror("'deriv': coefficient 175 (", function() return y:deriv(175) end)
    h.checkerror("has underflowed below the smallest normal double, so 171! times it has lost its digits",
      function() return y:deriv(171) end)
  end)
  it("the scaled jet the message suggests gives the coefficients exactly", function()
    -- exp(0.5 + 10 s) has c_j = exp(0.5) 10^j / j!, a normal double at j = 180.
    local y = nz.exp(nz.jet{ 0.5, 10, order = 180 })
    local want = e
    for i = 1, 180 do want = want * 10 / i end
    assert(math.abs(y:coef(180) - want) <= 4 * 180 * eps * want,
      ("coef(180) = %.17g, closed form %.17g"):format(y:coef(180), want))
  end)
  it("a polynomial's zero coefficient is 0 where j! c_j cannot hide anything", function()
    -- j! times the smallest subnormal (4.9e-324) is below 2.2e-16 up to j = 170.
    assert.are.equal(0, nz.jet{ 1, 2, 3, order = 200 }:deriv(170))
    h.checkerror("derivative 171 cannot be told from 0", function() return nz.jet{ 1, 2, 3, order = 200 }:deriv(171) end)
  end)
  it("derivative() that overflows is an error", function()
    h.checkerror("'derivative' overflows", function() return nz.jet{ 0, 0, 1e308 }:derivative() end)
  end)
end)

describe("series against closed forms", function()
  local K = 40
  local function check(name, got, want, tol)
    h.assert_series(got, want, K, tol or 64 * eps, name)
  end
  it("exp(0.385 + t)", function()
    check("exp", nz.exp(nz.jet(0.385, K)), function(j) return math.exp(0.385) / fact(j) end)
  end)
  it("log(1 + t)", function()
    check("log(1+t)", nz.log(1 + nz.jet(0, K)), function(j) return j == 0 and 0 or (-1) ^ (j + 1) / j end)
  end)
  it("1 / (1 - t)", function()
    check("1/(1-t)", 1 / (1 - nz.jet(0, K)), function() return 1 end)
  end)
  it("atan(t)", function()
    check("atan", nz.atan(nz.jet(0, K)),
      function(j) return j % 2 == 1 and (-1) ^ ((j - 1) // 2) / j or 0 end)
  end)
  it("sin and cos at 0.385", function()
    local s, c = nz.sin(nz.jet(0.385, K)), nz.cos(nz.jet(0.385, K))
    local ds = { math.sin(0.385), math.cos(0.385), -math.sin(0.385), -math.cos(0.385) }
    check("sin", s, function(j) return ds[j % 4 + 1] / fact(j) end)
    check("cos", c, function(j) return ds[(j + 1) % 4 + 1] / fact(j) end)
  end)
  it("sinh and cosh at 0.385", function()
    check("sinh", nz.sinh(nz.jet(0.385, K)), function(j) return (j % 2 == 0 and math.sinh(0.385) or math.cosh(0.385)) / fact(j) end)
    check("cosh", nz.cosh(nz.jet(0.385, K)), function(j) return (j % 2 == 1 and math.sinh(0.385) or math.cosh(0.385)) / fact(j) end)
  end)
  it("(1 + t)^a for real a, and sqrt(1 + t)", function()
    local function binom(a) return function(j) local c = 1; for i = 0, j - 1 do c = c * (a - i) / (i + 1) end; return c end end
    check("(1+t)^-2.75", (1 + nz.jet(0, K)) ^ -2.75, binom(-2.75))
    check("sqrt(1+t)", nz.sqrt(1 + nz.jet(0, K)), binom(0.5))
    check("(1+t)^3", (1 + nz.jet(0, K)) ^ 3, binom(3))
    check("(1+t)^-3", (1 + nz.jet(0, K)) ^ -3, binom(-3))
  end)
  it("asin(t) and acos(t)", function()
    local function asin_c(j)
      if j % 2 == 0 then return 0 end
      local m = (j - 1) // 2
      return fact(2 * m) / (4 ^ m * fact(m) ^ 2 * j)
    end
    check("asin", nz.asin(nz.jet(0, K)), asin_c)
    check("acos", nz.acos(nz.jet(0, K)), function(j) return j == 0 and math.pi / 2 or -asin_c(j) end)
  end)
  it("atan2(sin t, cos t) = t and hypot(cos t, sin t) = 1", function()
    local t = nz.jet(0.385, K)
    check("atan2", nz.atan2(nz.sin(t), nz.cos(t)), t)
    check("hypot", nz.hypot(nz.cos(t), nz.sin(t)), function(j) return j == 0 and 1 or 0 end)
    check("hypot 3-4-5", nz.hypot(3e200 * (1 + t), 4e200 * (1 + t)) / 1e200, 5 * (1 + t))
  end)
  it("x^y with a jet exponent is exp(y log x)", function()
    local t = nz.jet(0.385, K)
    check("2^t", 2 ^ t, function(j) return 2 ^ 0.385 * math.log(2) ^ j / fact(j) end)
  end)
  it("t^t against its own differential equation, solved here in plain numbers", function()
    -- y = t^t solves y' = y (1 + log t).  With the closed-form series
    -- log(t0 + s) = log t0 + sum_{j>=1} (-1)^(j+1) s^j / (j t0^j), matching
    -- coefficients of s^(k-1) gives k y_k = sum_{j<k} u_j y_{k-1-j}, u = 1 + log t:
    -- a recurrence in Lua numbers that shares no code with the jet engine.
    local t0 = 0.385
    local u = { [0] = 1 + math.log(t0) }
    for j = 1, K do u[j] = (j % 2 == 1 and 1 or -1) / (j * t0 ^ j) end
    local y = { [0] = t0 ^ t0 }
    for k = 1, K do
      local s = 0
      for j = 0, k - 1 do s = s + u[j] * y[k - 1 - j] end
      y[k] = s / k
    end
    local t = nz.jet(t0, K)
    -- The coefficients grow like t0^-j (radius of convergence t0): compare
    -- relative to each coefficient's own size.
    h.assert_series(t ^ t, function(j) return y[j] end, K, 64 * eps, "t^t", function(j) return math.abs(y[j]) end)
    -- And the first three derivatives derived by hand, with L = 1 + log t0:
    -- d/dt t^t = t^t L, d2/dt2 = t^t (L^2 + 1/t0), d3/dt3 = t^t (L^3 + 3 L / t0 - 1/t0^2).
    local L, tt, z = 1 + math.log(t0), t0 ^ t0, t ^ t
    local want = { tt * L, tt * (L ^ 2 + 1 / t0), tt * (L ^ 3 + 3 * L / t0 - 1 / t0 ^ 2) }
    for j = 1, 3 do
      assert(math.abs(z:deriv(j) - want[j]) <= 16 * eps * math.abs(want[j]) * t0 ^ -j,
        ("(t^t) derivative %d = %.17g, hand derivation %.17g"):format(j, z:deriv(j), want[j]))
    end
  end)
  it("numbers give numbers", function()
    assert.are.equal(math.sin(0.385), nz.sin(0.385))
    assert.are.equal(math.atan(2, -3), nz.atan2(2, -3))
    assert.are.equal(5, nz.hypot(3, 4))
    assert.are.equal("number", type(nz.exp(1)))
    assert.are.equal(math.sqrt(2), nz.pow(2, 0.5))
  end)
end)

describe("identities to order 40", function()
  local K = 40
  local x = generic(K)
  -- Identities hold exactly for truncated series; rounding is a few ulps of
  -- the coefficients' scale, which here is O(1) (x has radius > 1 in t).
  local tol = 256 * eps
  local cases = {
    { "sin^2 + cos^2 = 1", function() return nz.sin(x) ^ 2 + nz.cos(x) ^ 2 end, function(j) return j == 0 and 1 or 0 end },
    { "cosh^2 - sinh^2 = 1", function() return nz.cosh(x) ^ 2 - nz.sinh(x) ^ 2 end, function(j) return j == 0 and 1 or 0 end },
    { "exp(log x) = x", function() return nz.exp(nz.log(x)) end, x },
    { "log(exp x) = x", function() return nz.log(nz.exp(x)) end, x },
    { "tan = sin / cos", function() return nz.tan(x) end, function(j) return (nz.sin(x) / nz.cos(x)):coef(j) end },
    { "tanh = sinh / cosh", function() return nz.tanh(x) end, function(j) return (nz.sinh(x) / nz.cosh(x)):coef(j) end },
    { "sqrt(x)^2 = x", function() return nz.sqrt(x) ^ 2 end, x },
    { "(x^a)^(1/a) = x, a = 2.385", function() return (x ^ 2.385) ^ (1 / 2.385) end, x },
    { "asin(sin x) = x", function() return nz.asin(nz.sin(x)) end, x },
    { "acos(cos x) = x", function() return nz.acos(nz.cos(x)) end, x },
    { "atan(tan x) = x", function() return nz.atan(nz.tan(x)) end, x },
    { "(x * x) / x = x", function() return (x * x) / x end, x },
    { "x^3 = x * x * x", function() return x ^ 3 end, function(j) return (x * x * x):coef(j) end },
    { "x^-2 = 1 / (x * x)", function() return x ^ -2 end, function(j) return (1 / (x * x)):coef(j) end },
    { "abs(-x) = x", function() return nz.abs(-x) end, x },
  }
  for _, c in ipairs(cases) do
    it(c[1], function() h.assert_series(c[2](), c[3], K, tol, c[1]) end)
  end
  it("order 150: exp(t) gives 1/j! to rounding in every coefficient", function()
    -- 1/150! is about 1.7e-263, still a normal double: relative accuracy is
    -- checked coefficient by coefficient, not against an O(1) scale.
    local inv_fact = function(j) local f = 1.0; for i = 2, j do f = f / i end; return f end
    h.assert_series(nz.exp(nz.jet(0, 150)), inv_fact, 150, 64 * eps, "exp at order 150", inv_fact)
  end)
  it("order 500: composite functions stay finite", function()
    local x = generic(500)
    local y = nz.sin(nz.exp(x) / (1 + x * x)) + nz.sqrt(nz.cosh(x))
    for j = 0, 500 do
      local c = y:coef(j)
      assert(c == c and math.abs(c) < math.huge, ("coefficient %d is %s"):format(j, c))
    end
  end)
end)

describe("tangent directions", function()
  local K = 8
  local dx = { 1, 0.5, -0.25, 0.125 }     -- direction of perturbation, itself a series
  local base = { 0.7, 0.3, -0.2, 0.05 }
  local function shifted(s)
    local c = {}
    for j = 1, 4 do c[j] = base[j] + s * dx[j] end
    return nz.jet{ c[1], c[2], c[3], c[4], order = K }
  end
  local funcs = {
    exp = nz.exp, log = nz.log, sqrt = nz.sqrt, sin = nz.sin, cos = nz.cos, tan = nz.tan,
    asin = nz.asin, acos = nz.acos, atan = nz.atan, sinh = nz.sinh, cosh = nz.cosh,
    tanh = nz.tanh, abs = nz.abs,
    ["x^2.385"] = function(x) return x ^ 2.385 end,
    ["x^-3"] = function(x) return x ^ -3 end,
    ["x^5"] = function(x) return x ^ 5 end,
    ["x^x"] = function(x) return x ^ x end,
    ["1/x"] = function(x) return 1 / x end,
    ["x*x"] = function(x) return x * x end,
    ["atan2(x, 1-x)"] = function(x) return nz.atan2(x, 1 - x) end,
    ["hypot(x, 2x^2)"] = function(x) return nz.hypot(x, 2 * x * x) end,
  }
  for name, f in pairs(funcs) do
    it(name .. ": tangent agrees with central finite differences", function()
      local y = f(nz.jet{ base[1], base[2], base[3], base[4], order = K, tangents = { dx } })
      -- Central differences: truncation O(s^2 f''') ~ 1e-10 and rounding
      -- O(eps / s) ~ 1e-11 with s = 1e-5, so 1e-8 leaves a safe margin.
      local s = 1e-5
      local yp, ym = f(shifted(s)), f(shifted(-s))
      h.assert_series(y:tangent(1), function(j) return (yp:coef(j) - ym:coef(j)) / (2 * s) end, K, 1e-8,
        name .. " tangent vs finite differences")
    end)
    it(name .. ": tangent d/dt0 equals the next Taylor coefficient", function()
      -- With x = t0 + s seeded along t0, d c_j / d t0 = (j + 1) c_{j+1}.
      local t = nz.jet(0.55, K + 1, 1, 1)
      local y = f(t)
      h.assert_series(function(j) return y:tangent(1):coef(j) end,
        function(j) return (j + 1) * y:coef(j + 1) end, K, 512 * eps, name .. " d/dt0")
    end)
  end
  it("a dual number gives the first derivative exactly", function()
    local y = nz.sin(nz.dual(0.385, 1)) * nz.exp(nz.dual(0.385, 1))
    local want = (math.cos(0.385) + math.sin(0.385)) * math.exp(0.385)
    assert(math.abs(y:tangent(1):value() - want) <= 4 * eps * want)
  end)
  it("operands of different shapes combine at the lower order, larger tangent count", function()
    local a, b = nz.jet(1, 5, 2, 3), nz.jet(2, 3)
    local z = a * b
    assert.are.equal(3, z:order())
    assert.are.equal(3, z:ntangents())
    -- z = (1 + s)(2 + s) with a seeded along direction 2: dz = 1 * (2 + s).
    assert.are.same({ 2, 1, 0, 0 }, z:tangent(2):coefs())
    assert.are.same({ 0, 0, 0, 0 }, z:tangent(1):coefs())
  end)
end)

describe("mixed jet and number arithmetic", function()
  local x = generic(6, { { 1, 2 } })
  local c = nz.jet{ 2.385, order = 6 }
  local pairs_ = {
    { "2.385 + x", function() return 2.385 + x end, function() return c + x end },
    { "x + 2.385", function() return x + 2.385 end, function() return x + c end },
    { "2.385 - x", function() return 2.385 - x end, function() return c - x end },
    { "x - 2.385", function() return x - 2.385 end, function() return x - c end },
    { "2.385 * x", function() return 2.385 * x end, function() return c * x end },
    { "x * 2.385", function() return x * 2.385 end, function() return x * c end },
    { "2.385 / x", function() return 2.385 / x end, function() return c / x end },
    { "x / 2.385", function() return x / 2.385 end, function() return x / c end },
    { "2.385 ^ x", function() return 2.385 ^ x end, function() return c ^ x end },
    { "atan2(2.385, x)", function() return nz.atan2(2.385, x) end, function() return nz.atan2(c, x) end },
    { "hypot(x, 2.385)", function() return nz.hypot(x, 2.385) end, function() return nz.hypot(x, c) end },
  }
  for _, p in ipairs(pairs_) do
    it(p[1] .. " equals the jet-jet operation", function()
      local a, b = p[2](), p[3]()
      h.assert_series(a, b, 6, 4 * eps, p[1])
      h.assert_series(a:tangent(1), b:tangent(1), 6, 4 * eps, p[1] .. " (tangent)")
    end)
  end
  it("comparisons compare values", function()
    local a, b = nz.jet(1, 3), nz.jet(2, 1)
    assert.is_true(a < b)
    assert.is_true(a <= b)
    assert.is_false(b < a)
    assert.is_true(a < 1.5)
    assert.is_true(0.5 < a)
    assert.is_true(a == nz.jet(1, 5))
    assert.is_true(-a < a)
    local hd = require("nz.model.hyperdual").new(nz.jet(1.5, 2), 1)
    assert.is_true(a < hd)        -- a jet against a nested dual number: by value
    assert.is_false(hd <= a)
  end)
end)

describe("domain errors name the function and the value", function()
  it("log of a non-positive value", function()
    h.checkerror("'log' of a non-positive value (got -1.5)", nz.log, -1.5)
    h.checkerror("'log' of a non-positive value (got 0)", nz.log, nz.jet(0, 3))
  end)
  it("sqrt: negative, and at 0 with derivatives", function()
    h.checkerror("'sqrt' of a negative value (got -2)", nz.sqrt, -2)
    h.checkerror("'sqrt' is not differentiable at 0", nz.sqrt, nz.jet(0, 1))
    h.checkerror("'sqrt' is not differentiable at 0", nz.sqrt, nz.dual(0, 1))
    assert.are.equal(0, nz.sqrt(nz.jet{ 0 }):value())   -- order 0, no tangents: fine
  end)
  it("division by a series with zero constant term", function()
    h.checkerror("'division' by a series whose constant term is zero (divisor value 0)",
      function() return 1 / nz.jet(0, 2) end)
    h.checkerror("'division' by a series whose constant term is zero",
      function() return nz.jet(1, 2) / 0 end)
  end)
  it("asin and acos outside [-1, 1], and at +-1 with derivatives", function()
    h.checkerror("'asin' of a value outside [-1, 1] (got 1.5)", nz.asin, 1.5)
    h.checkerror("'acos' of a value outside [-1, 1] (got -2)", nz.acos, nz.jet(-2, 1))
    h.checkerror("'asin' is not differentiable at 1", nz.asin, nz.jet(1, 1))
  end)
  it("powers", function()
    h.checkerror("'pow' of a negative base (got -2) to a non-integer or jet exponent (0.5)",
      function() return nz.jet(-2, 2) ^ 0.5 end)
    h.checkerror("'pow' of zero to a negative exponent (-1)", function() return nz.jet(0, 2) ^ -1 end)
    h.checkerror("'pow' is not differentiable at 0", function() return nz.jet(0, 2) ^ 0.5 end)
    h.checkerror("'pow' of a negative base", function() return nz.jet(-1, 2) ^ nz.jet(2, 2) end)
    assert.are.same({ 0, 0, 1 }, (nz.jet(0, 2) ^ 2):coefs())  -- integer powers are fine at 0
  end)
  it("abs, atan2 and hypot at their singular points", function()
    h.checkerror("'abs' is not differentiable at 0", nz.abs, nz.jet(0, 1))
    h.checkerror("'atan2' at (0, 0) is not differentiable", nz.atan2, nz.jet(0, 1), nz.jet(0, 1))
    h.checkerror("'hypot' at (0, 0) is not differentiable", nz.hypot, nz.jet(0, 1), 0)
  end)
  it("overflow is an error, never inf", function()
    h.checkerror("'exp' overflows: a coefficient of the result is not finite (argument value 800)",
      nz.exp, nz.jet(800, 2))
    h.checkerror("'exp' overflows", nz.exp, 800)
    h.checkerror("'mul' overflows", function() return nz.jet(1e300, 1) * 1e300 end)
  end)
  it("NaN names the argument that carried it, never 'overflows'", function()
    local nan = 0 / 0
    h.checkerror("bad argument #2 to 'mul' (got NaN: the NaN came from an earlier computation",
      function() return nz.jet(0.25, 3) * nan end)
    h.checkerror("bad argument #1 to 'sub' (got NaN", function() return nan - nz.jet(0.25, 3) end)
    h.checkerror("bad argument #1 to 'log' (got NaN", nz.log, nan)            -- not "non-positive"
    h.checkerror("bad argument #2 to 'atan2' (got NaN", nz.atan2, nz.jet(1, 3), nan)
    h.checkerror("bad argument #1 to 'sin' (got NaN", nz.sin, nan)
    h.checkerror("bad argument #2 to 'mul' (got inf: the infinity came from", function() return nz.jet(0.25, 3) * math.huge end)
    -- Finite operands whose terms overflow and cancel: c_1 = 10 * 1e308 - 1e300 * 1e300.
    h.checkerror("'mul' of finite arguments gives NaN: terms of a coefficient overflowed and cancelled (inf - inf)",
      function() return nz.jet{ 10, -1e300 } * nz.jet{ 1e300, 1e308 } end)
  end)
end)
