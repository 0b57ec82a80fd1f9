-- branch_spec.lua - branches that can be recorded: nz.lt/le/gt/ge, nz.ifelse,
-- nz.max, nz.min, nz.clamp, nz.sign, nz.smooth_abs.  Each result is checked
-- against an independent path: the branch chosen by comparing values in Lua
-- and computed directly, the closed form, a Taylor polynomial evaluated a
-- little after t0, or a system written without the branch.
local h = require "tests.helpers"
local nz = h.nz
local hd = require "nz.model.hyperdual"

-- Every coefficient of value and tangents of got equals want's (want of
-- order >= got's; a direction want lacks is zero), bit for bit: a selection
-- copies, it computes nothing.
local function assert_same_jet(got, want, what)
  assert(nz.isjet(got), ("%s: a jet expected, got %s"):format(what, type(got)))
  for j = 0, got:order() do
    assert(got:coef(j) == want:coef(j),
      ("%s: coefficient %d is %.17g, expected %.17g"):format(what, j, got:coef(j), want:coef(j)))
  end
  for d = 1, got:ntangents() do
    for j = 0, got:order() do
      local w = d <= want:ntangents() and want:tangent(d):coef(j) or 0
      assert(got:tangent(d):coef(j) == w,
        ("%s: tangent %d coefficient %d is %.17g, expected %.17g"):format(what, d, j, got:tangent(d):coef(j), w))
    end
  end
end

-- A constant jet of the given shape: value v, everything else 0.
local function assert_constant(got, v, order, ntan, what)
  assert(nz.isjet(got), ("%s: a jet expected, got %s"):format(what, type(got)))
  assert.are.equal(order, got:order(), what .. ": order")
  assert.are.equal(ntan, got:ntangents(), what .. ": tangents")
  assert.are.equal(v, got:value(), what .. ": value")
  for j = 1, order do assert.are.equal(0, got:coef(j), what .. ": coefficient " .. j) end
  for d = 1, ntan do
    for j = 0, order do assert.are.equal(0, got:tangent(d):coef(j), what .. ": tangent " .. d) end
  end
end

describe("comparisons nz.lt, nz.le, nz.gt, nz.ge", function()
  it("give 1 or 0 as numbers for numbers, as Lua's operators say", function()
    for _, p in ipairs { { 1, 2 }, { 2, 1 }, { 3, 3 }, { -0.5, 0.25 } } do
      local a, b = p[1], p[2]
      assert.are.equal(a < b and 1 or 0, nz.lt(a, b))
      assert.are.equal(a <= b and 1 or 0, nz.le(a, b))
      assert.are.equal(a > b and 1 or 0, nz.gt(a, b))
      assert.are.equal(a >= b and 1 or 0, nz.ge(a, b))
      assert.are.equal("number", math.type(nz.gt(a, b)) and "number")
    end
  end)
  it("give a constant jet of the result shape for jets, whatever the operands' tangents", function()
    local x = nz.sin(nz.jet(0.3, 6, 1, 2))          -- order 6, 2 tangents
    local y = nz.cos(nz.jet(0.3, 4, 1, 1))          -- order 4, 1 tangent
    local xv, yv = math.sin(0.3), math.cos(0.3)
    assert_constant(nz.gt(x, y), xv > yv and 1 or 0, 4, 2, "gt(sin, cos)")
    assert_constant(nz.lt(x, y), xv < yv and 1 or 0, 4, 2, "lt(sin, cos)")
    assert_constant(nz.ge(x, 0.1), 1, 6, 2, "ge(sin, 0.1)")   -- a number is exact to every order
    assert_constant(nz.le(0.1, y), 1, 4, 1, "le(0.1, cos)")
  end)
  it("at a tie in value, the series that grows after t0 wins (x = t - t0 against 0)", function()
    local t0 = 0.7
    local x = nz.jet(t0, 3) - t0                     -- value 0, c_1 = 1
    assert.are.equal(0, x:value())
    assert.are.equal(1, nz.gt(x, 0):value())
    assert.are.equal(1, nz.ge(x, 0):value())
    assert.are.equal(0, nz.lt(x, 0):value())
    assert.are.equal(0, nz.le(x, 0):value())
    assert.are.equal(0, nz.gt(-x, 0):value())
    assert.are.equal(1, nz.lt(-x, 0):value())
    -- A tie through c_1: the first coefficient that differs decides.
    assert.are.equal(1, nz.gt(x * x, 0):value())
    assert.are.equal(1, nz.lt(-(x ^ 3), 0):value())
    -- A dual number (order 0) knows only the value: a tie is equality.
    local d = nz.dual(0, 1)
    assert.are.equal(0, nz.gt(d, 0):value())
    assert.are.equal(1, nz.ge(d, 0):value())
  end)
  it("the tie rule agrees with the functions evaluated just after t0", function()
    -- sin t and t - t^3/6 agree to order 4 at 0; sin t is above from order 5 on.
    for _, K in ipairs { 5, 7 } do
      local t = nz.jet(0, K)
      local a, b = nz.sin(t), t - t ^ 3 / 6
      local s = 1e-2
      local above = math.sin(s) > s - s ^ 3 / 6
      assert.is_true(above)
      assert.are.equal(above and 1 or 0, nz.gt(a, b):value(), "order " .. K)
      assert.are.equal(0, nz.lt(a, b):value(), "order " .. K)
    end
    -- Up to order 4 the known coefficients are equal: neither is above.
    local t = nz.jet(0, 4)
    local a, b = nz.sin(t), t - t ^ 3 / 6
    for j = 0, 4 do assert(math.abs(a:coef(j) - b:coef(j)) == 0, "series equal to order 4") end
    assert.are.equal(0, nz.gt(a, b):value())
    assert.are.equal(1, nz.ge(a, b):value())
    assert.are.equal(1, nz.le(a, b):value())
  end)
end)

describe("nz.ifelse, nz.max, nz.min, nz.clamp on jets", function()
  local x = nz.sin(nz.jet(0.3, 7, 1, 2)) * 2         -- 0.591..., order 7, 2 tangents
  local y = nz.exp(nz.jet(0.3, 5, 2, 2)) - 0.8        -- 0.549..., order 5, tangent 2
  local z = nz.cos(nz.jet(0.3, 6, 1, 1))              -- 0.955..., order 6, tangent 1
  local xv, yv = 2 * math.sin(0.3), math.exp(0.3) - 0.8
  assert(xv > yv and z:value() > xv)

  it("ifelse picks the whole branch, tangents included, in the shape of both branches", function()
    local r = nz.ifelse(1, x, y)
    assert.are.equal(5, r:order())
    assert.are.equal(2, r:ntangents())
    assert_same_jet(r, x, "ifelse(1, x, y)")
    assert_same_jet(nz.ifelse(0, x, y), y, "ifelse(0, x, y)")
    assert_same_jet(nz.ifelse(nz.gt(x, y), x, y), x, "ifelse(gt(x, y), x, y)")
    assert_same_jet(nz.ifelse(nz.lt(x, y), x, y), y, "ifelse(lt(x, y), x, y)")
    -- Any nonzero value is true, a jet's value included.
    assert_same_jet(nz.ifelse(-2.5, y, x), y, "ifelse(-2.5, y, x)")
    assert_same_jet(nz.ifelse(nz.jet(0, 3), y, x), x, "ifelse(t at 0, y, x): value 0 is false")
  end)
  it("a number branch is the constant of the other branch's shape", function()
    assert_constant(nz.ifelse(0, x, 4.5), 4.5, 7, 2, "ifelse(0, x, 4.5)")
    assert_same_jet(nz.ifelse(1, x, 4.5), x, "ifelse(1, x, 4.5)")
    assert.are.equal(4.5, nz.ifelse(z, 4.5, 2))        -- number branches give a number
    assert.are.equal(2, nz.ifelse(nz.gt(y, z), 4.5, 2))
  end)
  it("max and min equal the larger and smaller operand computed directly", function()
    -- Lua's own comparison of the values chooses; the results are bit for bit
    -- the chosen jet, in the result shape.
    for _, p in ipairs { { x, y }, { y, x }, { x, z }, { z, y } } do
      local a, b = p[1], p[2]
      local big, small = a:value() > b:value() and a or b, a:value() < b:value() and a or b
      assert_same_jet(nz.max(a, b), big, "max")
      assert_same_jet(nz.min(a, b), small, "min")
      assert.are.equal(math.min(a:order(), b:order()), nz.max(a, b):order())
      assert.are.equal(math.max(a:ntangents(), b:ntangents()), nz.min(a, b):ntangents())
    end
    assert_constant(nz.max(y, 0.6), 0.6, 5, 2, "max(y, 0.6)")
    assert_same_jet(nz.min(0.6, y), y, "min(0.6, y)")
  end)
  it("max and min at a tie in value follow the motion after t0", function()
    local t0 = 1.3
    local u = nz.sin(nz.jet(t0, 5, 1, 1) - t0)          -- value 0, growing
    assert_same_jet(nz.max(u, 0), u, "max(u, 0)")
    assert_constant(nz.min(u, 0), 0, 5, 1, "min(u, 0)")
    assert_constant(nz.max(-u, 0), 0, 5, 1, "max(-u, 0)")
    -- relu(u) = max(u, 0) at its kink: the derivative (along t0 here) of
    -- the side taken, 1, and 0 for min.
    assert.are.equal(1, nz.max(u, 0):tangent(1):value())
    assert.are.equal(0, nz.min(u, 0):tangent(1):value())
  end)
  it("clamp is lo below, hi above, x between, each computed directly", function()
    assert_same_jet(nz.clamp(x, y, z), x, "clamp(x, y, z): inside")
    assert_same_jet(nz.clamp(y, x, z), x, "clamp(y, x, z): below")
    assert_same_jet(nz.clamp(z, y, x), x, "clamp(z, y, x): above")
    assert_constant(nz.clamp(x, -1, 0.5), 0.5, 7, 2, "clamp(x, -1, 0.5)")
    assert_constant(nz.clamp(x, 0.75, 2), 0.75, 7, 2, "clamp(x, 0.75, 2)")
    assert_same_jet(nz.clamp(x, 0, 1), x, "clamp(x, 0, 1)")
    assert.are.equal(5, nz.clamp(x, y, z):order())
    for _, v in ipairs { -3, 0.2, 7 } do
      assert.are.equal(math.min(math.max(v, 0), 1), nz.clamp(v, 0, 1))
    end
  end)
  it("the issue's branch: k1 q^2 on one side of 0, k2 q^2 on the other", function()
    local k1, k2 = 3.0, 5.0
    local function V(q) return nz.ifelse(nz.gt(q, 0), k1 * q ^ 2, k2 * q ^ 2) end
    for _, q0 in ipairs { 0.4, -0.4 } do
      local q = nz.jet(q0, 4, 1, 1)
      assert_same_jet(V(q), (q0 > 0 and k1 or k2) * q ^ 2, "V at " .. q0)
    end
  end)
end)

describe("nz.sign", function()
  it("is -1, 0, +1 on numbers", function()
    assert.are.equal(-1, nz.sign(-2.5))
    assert.are.equal(0, nz.sign(0))
    assert.are.equal(1, nz.sign(1e-300))
  end)
  it("has every derivative 0 and no tangent: a step", function()
    local x = nz.sin(nz.jet(0.3, 6, 1, 1)) - 0.5        -- value -0.204...
    assert_constant(nz.sign(x), -1, 6, 1, "sign(sin - 0.5)")
    assert_constant(nz.sign(-x), 1, 6, 1, "sign(0.5 - sin)")
  end)
  it("follows the tie rule at a zero value, and is 0 on the zero series", function()
    local u = nz.jet(2, 3, 1, 1) - 2
    assert_constant(nz.sign(u), 1, 3, 1, "sign(t - t0)")
    assert_constant(nz.sign(-(u ^ 3)), -1, 3, 1, "sign(-(t - t0)^3)")
    assert_constant(nz.sign(u * 0), 0, 3, 1, "sign(0 series)")
    -- sign(x) x is |x| on the side the motion takes, where abs refuses.
    h.checkerror("'abs' is not differentiable at 0", nz.abs, u)
    assert_same_jet(nz.sign(-u) * -u, u, "sign(-u) (-u)")
  end)
end)

describe("nz.smooth_abs", function()
  it("is sqrt(x^2 + eps^2) - eps, within eps of |x|", function()
    for _, x in ipairs { -3, -0.01, 0, 1e-3, 2.5 } do
      for _, e in ipairs { 1e-3, 0.1, 1 } do
        local got, want = nz.smooth_abs(x, e), math.sqrt(x * x + e * e) - e
        assert(math.abs(got - want) <= 4e-16 * math.max(want, e), ("smooth_abs(%g, %g)"):format(x, e))
        assert(math.abs(x) - got <= e and got <= math.abs(x), "within eps below |x|")
      end
    end
  end)
  it("has the derivative x / sqrt(x^2 + eps^2), also at 0", function()
    for _, x in ipairs { -0.3, 0, 0.02, 4 } do
      local e = 0.05
      local want = x / math.sqrt(x * x + e * e)
      local d = nz.smooth_abs(nz.dual(x, 1), e):tangent(1):value()
      local j = nz.smooth_abs(nz.jet(x, 3), e):coef(1)
      assert(math.abs(d - want) <= 1e-15, ("dual at %g: %.17g against %.17g"):format(x, d, want))
      assert(math.abs(j - want) <= 1e-15, ("jet at %g: %.17g against %.17g"):format(x, j, want))
    end
    -- At 0 the second coefficient is 1/(2 eps): x^2/(2 eps) + O(x^4).
    assert(math.abs(nz.smooth_abs(nz.jet(0, 4), 0.05):coef(2) - 10) <= 1e-13)
  end)
  it("refuses a width that is not positive", function()
    h.checkerror("bad argument #2 to 'smooth_abs' (a positive finite width expected, got 0", nz.smooth_abs, 1, 0)
    h.checkerror("bad argument #2 to 'smooth_abs' (a positive finite width expected, got -1", nz.smooth_abs, 1, -1)
    h.checkerror("bad argument #2 to 'smooth_abs' (a positive width eps expected, got no value)", nz.smooth_abs, 1)
  end)
end)

describe("nested dual numbers (lua/nz/model/hyperdual.lua)", function()
  -- q + eta d: the eta part of f is df/dq d.
  local function at(q) return hd.new(nz.jet(q, 3, 1, 1), 1) end
  it("compare looks at v only and gives a plain constant", function()
    assert.are.equal(0, nz.gt(hd.new(1, 100), hd.new(2, -100)))
    assert.are.equal(1, nz.lt(hd.new(1, 100), 2))
    assert.are.equal(-1, nz.sign(hd.new(-3, 5)))
  end)
  it("select takes v and d from the same branch: the derivative of the branch taken", function()
    for _, q0 in ipairs { 0.5, 1.5 } do
      local q = at(q0)
      -- q^2 against sin q: q^2 < sin q at 0.5, q^2 > sin q at 1.5.
      local m = nz.max(q ^ 2, nz.sin(q))
      local r = q0 ^ 2 > math.sin(q0)
      local dv, dd = hd.parts(m)
      assert_same_jet(dv, r and nz.jet(q0, 3, 1, 1) ^ 2 or nz.sin(nz.jet(q0, 3, 1, 1)), "max value part")
      assert_same_jet(dd, r and 2 * nz.jet(q0, 3, 1, 1) or nz.cos(nz.jet(q0, 3, 1, 1)), "max eta part")
      local n = nz.min(q ^ 2, nz.sin(q))
      local _, nd = hd.parts(n)
      assert_same_jet(nd, r and nz.cos(nz.jet(q0, 3, 1, 1)) or 2 * nz.jet(q0, 3, 1, 1), "min eta part")
    end
  end)
  it("ifelse and clamp dispatch to the nested dual", function()
    local q = at(0.3)
    local v, d = hd.parts(nz.ifelse(nz.gt(q, 0), 3 * q, q * q))
    assert_same_jet(v, 3 * nz.jet(0.3, 3, 1, 1), "ifelse value part")
    assert_constant(d, 3, 3, 1, "ifelse eta part: d(3 q) = 3")
    local cv, cd = hd.parts(nz.clamp(q, 0.5, 1))
    assert_constant(cv, 0.5, 3, 1, "clamp below: value part lo")
    assert.are.equal(0, cd)
    cv, cd = hd.parts(nz.clamp(q, 0, 1))
    assert_same_jet(cv, nz.jet(0.3, 3, 1, 1), "clamp inside: value")
    assert.are.equal(1, cd)
    h.checkerror("bad argument #2 to 'clamp' (the lower bound 2 is above the upper bound 1", nz.clamp, q, 2, 1)
  end)
end)

describe("a system written with a branch", function()
  it("has the accelerations of the branch taken, as written without it", function()
    local k1, k2, m = 3.0, 5.0, 2.0
    local branchy = nz.system{ coords = { "x" }, params = { m = m },
      T = function(t, q, qd, p) return 0.5 * p.m * qd[1] ^ 2 end,
      V = function(t, q) return 0.5 * nz.ifelse(nz.gt(q[1], 0), k1 * q[1] ^ 2, k2 * q[1] ^ 2) end }
    for _, x in ipairs { 0.4, -0.4 } do
      local a = branchy:accel(0, { x }, { 0.1 })[1]
      local k = x > 0 and k1 or k2
      assert(math.abs(a - (-k * x / m)) <= 1e-14, ("accel at %g: %.17g, expected %.17g"):format(x, a, -k * x / m))
    end
  end)
  it("bodies whose positions branch (nested duals) move as the branch taken", function()
    local function sys_for(pos)
      return nz.system{ coords = { "x" }, bodies = { gravity = { 0, -9.81, 0 },
        { mass = 1.5, pos = pos } } }
    end
    local branchy = sys_for(function(t, q)
      return { q[1], nz.ifelse(nz.ge(q[1], 0), 0.5 * q[1] ^ 2, -0.25 * q[1] ^ 2), 0 } end)
    local right = sys_for(function(t, q) return { q[1], 0.5 * q[1] ^ 2, 0 } end)
    local left = sys_for(function(t, q) return { q[1], -0.25 * q[1] ^ 2, 0 } end)
    for _, x in ipairs { 0.6, -0.6 } do
      local got = branchy:accel(0, { x }, { 0.3 })[1]
      local want = (x >= 0 and right or left):accel(0, { x }, { 0.3 })[1]
      assert(math.abs(got - want) <= 1e-14 * math.abs(want), ("at %g: %.17g against %.17g"):format(x, got, want))
    end
  end)
end)

describe("wrong arguments name the function and the argument", function()
  it("for each branch function", function()
    h.checkerror("bad argument #1 to 'ifelse' (number or jet expected, got boolean): a Lua comparison",
      nz.ifelse, true, 1, 2)
    h.checkerror("write the condition with nz.gt(x, 0)", nz.ifelse, 1 > 0, 1, 2)
    h.checkerror("bad argument #3 to 'ifelse' (number or jet expected, got nil)", nz.ifelse, 1, 2)
    h.checkerror("bad argument #2 to 'ifelse' (number or jet expected, got table)", nz.ifelse, 1, {}, 2)
    h.checkerror("bad argument #2 to 'max' (number or jet expected, got string)", nz.max, 1, "x")
    h.checkerror("bad argument #1 to 'min' (number or jet expected, got table)", nz.min, {}, 1)
    h.checkerror("bad argument #3 to 'clamp' (number or jet expected, got nil)", nz.clamp, 1, 0)
    h.checkerror("bad argument #2 to 'gt' (number or jet expected, got boolean)", nz.gt, 1, false)
    h.checkerror("bad argument #1 to 'lt' (number or jet expected, got nil)", nz.lt)
    h.checkerror("bad argument #1 to 'sign' (number or jet expected, got string)", nz.sign, "x")
    h.checkerror("bad argument #2 to 'clamp' (the lower bound 3 is above the upper bound 2", nz.clamp, 1, 3, 2)
    -- Equal values, but the lower bound grows: above the upper one after t0.
    h.checkerror("bad argument #2 to 'clamp' (the lower bound 0 is above the upper bound 0",
      nz.clamp, 0, nz.jet(0, 2), 0)
  end)
  it("NaN is named, never a silent branch", function()
    local nan = 0 / 0
    h.checkerror("bad argument #1 to 'ifelse' (got NaN", nz.ifelse, nan, 1, 2)
    h.checkerror("bad argument #1 to 'ifelse' (got NaN", nz.ifelse, nan, nz.jet(0, 2), 2)
    h.checkerror("bad argument #2 to 'ge' (got NaN", nz.ge, 1, nan)
    h.checkerror("bad argument #1 to 'max' (got NaN", nz.max, nan, nz.jet(0, 2))
    h.checkerror("bad argument #1 to 'sign' (got NaN", nz.sign, nan)
  end)
end)
