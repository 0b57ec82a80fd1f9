-- scene_spec.lua - scenes, effects and nz.check: each effect against forces
-- derived by hand, only declared effects computed, every parameter error
-- named, and derivations checked.
local h = require "tests.helpers"
local nz = h.nz
local cs = require "tests.constraint_systems"
local E = nz.effects

local function max_diff(a, b) local m = 0; for i = 1, #a do m = math.max(m, math.abs(a[i] - b[i])) end; return m end
local function particle(mass) return { { name = "p", mass = mass, pos = function(t, q) return { q[1], q[2], 0 } end } } end

describe("effects against hand-derived forces", function()
  it("a spring between a body and a fixed point: m a = -k (|r| - l0) r/|r|", function()
    local m, k, l0 = 1.3, 7.0, 0.5
    local sc = nz.scene{ coords = { "x", "y" }, bodies = particle(m),
      effects = { E.spring{ between = { "p", { 0, 0, 0 } }, k = k, length = l0 } } }
    local q = { 0.9, -0.4 }
    local r = math.sqrt(q[1] ^ 2 + q[2] ^ 2)
    local want = { -k * (r - l0) * q[1] / r / m, -k * (r - l0) * q[2] / r / m }
    assert(max_diff(sc:accel(0, q, { 0.2, 0.1 }), want) <= 1e-13)
  end)
  it("a cubic spring on a coordinate: force -(k s + k3 s^3)", function()
    local sc = nz.scene{ coords = { "x" }, T = function(t, q, qd) return 0.5 * qd[1] ^ 2 end,
      effects = { E.spring{ coordinate = "x", k = 2, rest = 0.5, cubic = 3 } } }
    local s = 1.7 - 0.5
    assert(math.abs(sc:accel(0, { 1.7 }, { 0 })[1] + (2 * s + 3 * s ^ 3)) <= 1e-13)
  end)
  it("dampers: on a coordinate Q = -c x'; between points Rayleigh's -c s' grad s", function()
    local sc = nz.scene{ coords = { "x" }, T = function(t, q, qd) return 0.5 * qd[1] ^ 2 end,
      effects = { E.damper{ coordinate = "x", c = 0.7 } } }
    assert(math.abs(sc:accel(0, { 1 }, { 2 })[1] + 1.4) <= 1e-15)
    local m, c = 0.8, 0.3
    local sp = nz.scene{ coords = { "x", "y" }, bodies = particle(m), effects = { E.damper{ between = { "p", { 0, 0, 0 } }, c = c } } }
    local q, v = { 0.6, 0.8 }, { 0.5, -0.2 }
    local r = 1.0                         -- |q|
    local sdot = (q[1] * v[1] + q[2] * v[2]) / r
    local want = { -c * sdot * q[1] / r / m, -c * sdot * q[2] / r / m }
    assert(max_diff(sp:accel(0, q, v), want) <= 1e-14)
  end)
  it("a force at a point gives the virtual work F . dr/dq; gravity on chosen bodies", function()
    local sc = nz.scene{ coords = { "x", "y" }, bodies = particle(2.0),
      effects = { E.force{ at = "p", F = function() return { 0.4, -1.0, 5.0 } end } } }
    assert(max_diff(sc:accel(0, { 0, 0 }, { 0, 0 }), { 0.2, -0.5 }) <= 1e-15)
    local two = nz.scene{ coords = { "a", "b" },
      bodies = { { name = "one", mass = 1, pos = function(t, q) return { 0, 0, q[1] } end },
        { name = "two", mass = 1, pos = function(t, q) return { 0, 0, q[2] } end } },
      effects = { E.gravity{ g = { 0, 0, -9.81 }, bodies = { "two" } } } }
    assert(max_diff(two:accel(0, { 0, 0 }, { 0, 0 }), { 0, -9.81 }) <= 1e-15)
  end)
  it("knife edge, rolling disk and constant speed give the hand-derived motions", function()
    local function same(case, effects)
      local sc = nz.scene{ coords = case.sys.coords, T = case.sys.engine.T, V = case.sys.engine.V, effects = effects }
      for _ = 1, 4 do
        local t, q, qd = case.draw()
        assert(max_diff(sc:accel(t, q, qd), case.accel(t, q, qd)) <= 1e-11, case.name)
      end
    end
    same(cs.sleigh(), { E.knife_edge{ x = "x", y = "y", heading = "th" } })
    same(cs.rolling_disk(), { E.rolling_disk{ x = "x", y = "y", heading = "th", angle = "ph", radius = 0.3 } })
    same(cs.constant_speed(), { E.constant_speed{ coords = { "x", "y" }, speed = 1.5 } })
  end)
  it("a driven coordinate follows its motion exactly along a simulation", function()
    local sc = nz.scene{ coords = { "th", "ph" },
      T = function(t, q, qd) return 0.5 * (qd[1] ^ 2 + nz.sin(q[1]) ^ 2 * qd[2] ^ 2) end,
      effects = { E.driven{ coordinate = "ph", motion = function(t) return 2 * t + 0.1 * t * t end } } }
    local tr = sc:simulate{ q0 = { 0.5, 0 }, qd0 = { 0, 2 }, t1 = 2 }
    for i = 1, #tr.t do
      local t = tr.t[i]
      assert(math.abs(tr.q[i][2] - (2 * t + 0.1 * t * t)) <= 1e-9)
    end
  end)
  it("a ball rolling on a plane, pushed at its centre, accelerates at 5F/7m", function()
    local R, m, F = 0.3, 1.0, 0.7
    local I = 0.4 * m * R * R
    -- Three Euler angles (z-x-z): a ball must be free to turn about any axis.
    local function rot(t, q)
      local c, s = nz.cos, nz.sin
      local function mul(X, Y)
        local Z = {}
        for i = 1, 3 do Z[i] = {}; for j = 1, 3 do Z[i][j] = X[i][1] * Y[1][j] + X[i][2] * Y[2][j] + X[i][3] * Y[3][j] end end
        return Z
      end
      local A = { { c(q[3]), -s(q[3]), 0 }, { s(q[3]), c(q[3]), 0 }, { 0, 0, 1 } }
      local B = { { 1, 0, 0 }, { 0, c(q[4]), -s(q[4]) }, { 0, s(q[4]), c(q[4]) } }
      local C = { { c(q[5]), -s(q[5]), 0 }, { s(q[5]), c(q[5]), 0 }, { 0, 0, 1 } }
      return mul(mul(A, B), C)
    end
    local ball = nz.scene{ coords = { "x", "y", "psi", "theta", "phi" },
      bodies = { { name = "ball", mass = m, inertia = { I, I, I }, rot = rot, pos = function(t, q) return { q[1], q[2], R } end } },
      effects = { E.rolling_ball{ body = "ball", radius = R }, E.force{ at = "ball", F = function() return { F, 0, 0 } end } } }
    local a = ball:accel(0, { 0, 0, 0.2, 1.1, 0.4 }, { 0, 0, 0, 0, 0 })
    assert(math.abs(a[1] - 5 * F / (7 * m)) <= 1e-12 and math.abs(a[2]) <= 1e-12, ("x'' = %.15g"):format(a[1]))
  end)
end)

describe("masses, inertias, gravity and effects' numbers as functions of the params", function()
  local function pendulum_bodies()
    return nz.system{ name = "pendulum", coords = { "th" }, params = { m = 2.0, l = 1.3, g = 9.81 },
      bodies = { gravity = function(p) return { 0, -p.g, 0 } end,
        { mass = function(p) return p.m end, pos = function(t, q, p) return { p.l * nz.sin(q[1]), -p.l * nz.cos(q[1]), 0 } end } } }
  end

  it("keep the symbols in sys:show: the pendulum's l^2 m th'' + g l m sin(th) = 0", function()
    -- Lagrange by hand: T = m l^2 th'^2 / 2, V = -m g l cos th
    local text = pendulum_bodies():show{}
    assert(text:find("th:  l^2 m th'' + g l m sin(th) = 0", 1, true), text)
    local spring = nz.scene{ name = "spring", coords = { "x" }, params = { m = 1.5, k = 4, c = 0.3 },
      bodies = { { name = "b", mass = function(p) return p.m end, pos = function(t, q) return { q[1], 0, 0 } end } },
      effects = { E.spring{ coordinate = "x", k = function(p) return p.k end },
        E.damper{ coordinate = "x", c = function(p) return p.c end } } }
    text = spring:show{}
    assert(text:find("x:  m x'' + c x' + k x = 0", 1, true), text)
  end)

  it("follow sys.params: a run with other params moves as the closed forms say", function()
    -- a mass on a spring: x = x0 cos(sqrt(k/m) t)
    local osc = nz.scene{ name = "oscillator", coords = { "x" }, params = { m = 2, k = 8 },
      bodies = { { name = "b", mass = function(p) return p.m end, pos = function(t, q) return { q[1], 0, 0 } end } },
      effects = { E.spring{ coordinate = "x", k = function(p) return p.k end } } }
    for _, pk in ipairs{ { 2, 8 }, { 0.5, 18 } } do
      osc.params.m, osc.params.k = pk[1], pk[2]
      local tr = osc:simulate{ q0 = { 0.7 }, t1 = 2, dt = 0.5, rtol = 1e-12 }
      local w = math.sqrt(pk[2] / pk[1])
      for i = 1, #tr.t do
        assert(math.abs(tr.q[i][1] - 0.7 * math.cos(w * tr.t[i])) <= 1e-9,
          ("m = %g, k = %g: x(%g) = %.12g, closed form %.12g"):format(pk[1], pk[2], tr.t[i], tr.q[i][1], 0.7 * math.cos(w * tr.t[i])))
      end
    end
    -- the pendulum: th'' = -(g / l) sin th, g read through the gravity function
    local pend = pendulum_bodies()
    for _, g in ipairs{ 9.81, 1.62 } do
      pend.params.g = g
      local a = pend:accel(0, { 0.8 }, { 0.3 })[1]
      assert(math.abs(a + g / 1.3 * math.sin(0.8)) <= 1e-12, ("g = %g: th'' = %.15g"):format(g, a))
    end
    -- a compound pendulum, a rigid body whose inertia reads I:
    -- th'' = -m g l sin th / (I + m l^2)
    local rods = nz.system{ name = "compound", coords = { "th" }, params = { I = 0.05, m = 1.2, l = 0.4 },
      bodies = { gravity = { 0, -9.81, 0 }, { mass = function(p) return p.m end, inertia = function(p) return { 0.01, 0.01, p.I } end,
        rot = function(t, q) return nz.rotations.z(q[1]) end,
        pos = function(t, q, p) return { p.l * nz.sin(q[1]), -p.l * nz.cos(q[1]), 0 } end } } }
    for _, I in ipairs{ 0.05, 0.3 } do
      rods.params.I = I
      local a = rods:accel(0, { 0.8 }, { 0.3 })[1]
      assert(math.abs(a + 1.2 * 9.81 * 0.4 * math.sin(0.8) / (I + 1.2 * 0.4 ^ 2)) <= 1e-12, ("I = %g: th'' = %.15g"):format(I, a))
    end
  end)

  it("in the effects: a rolling disk's radius and a contact's radius", function()
    local case = cs.rolling_disk()
    local sc = nz.scene{ coords = case.sys.coords, T = case.sys.engine.T, V = case.sys.engine.V, params = { R = 0.3 },
      effects = { E.rolling_disk{ x = "x", y = "y", heading = "th", angle = "ph", radius = function(p) return p.R end } } }
    for _ = 1, 3 do
      local t, q, qd = case.draw()
      assert(max_diff(sc:accel(t, q, qd), case.accel(t, q, qd)) <= 1e-11)
    end
    -- a ball of radius r dropped on the floor z = 0 comes to rest with its centre at z = r
    local ball = nz.scene{ name = "ball", coords = { "z" }, params = { r = 0.25 },
      bodies = { { name = "b", mass = 1, pos = function(t, q) return { 0, 0, q[1] } end } },
      effects = { E.gravity{ g = function(p) return { 0, 0, -9.81 } end },
        E.contact{ name = "floor", at = "b", plane = { normal = { 0, 0, 1 } }, radius = function(p) return p.r end } } }
    for _, r in ipairs{ 0.25, 0.6 } do
      ball.params.r = r
      local tr = ball:simulate{ q0 = { 1 }, t1 = 1 }
      assert(math.abs(tr.q[#tr.t][1] - r) <= 1e-9, ("r = %g: rests at %.12g"):format(r, tr.q[#tr.t][1]))
    end
  end)

  it("say which body and field when the function returns no number", function()
    -- (a parameter may be set later: the error comes at the first evaluation)
    local bad = nz.system{ name = "bad", coords = { "x" }, params = { m = 1 },
      bodies = { { name = "bob", mass = function(p) return p.mass end, pos = function(t, q) return { q[1], 0, 0 } end } } }
    local ok, err = pcall(bad.accel, bad, 0, { 1 }, { 0 })
    assert(not ok and err:find("T (bodies) raised an error: bob: 'mass' = function(params) returned nil: a positive "
      .. "number expected at t = 0", 1, true), err)
    -- recorded, the mass is the parameter's graph input: a negative one is
    -- what the mass matrix says
    bad.params.mass = -1
    ok, err = pcall(bad.accel, bad, 0, { 1 }, { 0 })
    assert(not ok and err:find("the mass matrix M = d2T/dqd2 is not positive definite", 1, true), err)
    h.checkerror("effect 'spring': parameter 'k' must be a number or a function(params) returning one, got string",
      E.spring, { coordinate = "x", k = "4" })
    h.checkerror("'mass' must be a positive number or a function(params) returning one",
      nz.bodies, { { mass = "m", pos = function() return { 0, 0, 0 } end } })
  end)
end)

describe("only what a scene declares is computed", function()
  it("an effect made but not declared is never called; a declared one is", function()
    local undeclared, declared = 0, 0
    local unused = E.force{ f = function() undeclared = undeclared + 1; return { 0 } end }
    local used = E.force{ f = function() declared = declared + 1; return { 0 } end }
    local sc = nz.scene{ coords = { "x" }, T = function(t, q, qd) return 0.5 * qd[1] ^ 2 end,
      effects = { used, E.spring{ coordinate = "x", k = 1 } } }
    sc:simulate{ q0 = { 1 }, t1 = 1 }
    assert.are.equal(0, undeclared)
    assert(declared > 0)
    assert.is_nil(unused.calls)
  end)
  it("without effects there is no V, no Q and no constraint machinery", function()
    local sc = nz.scene{ coords = { "x" }, T = function(t, q, qd) return 0.5 * qd[1] ^ 2 end }
    assert.are.same({ T = 1, V = 0, Q = 0, L = 0, S = 0 }, sc.pieces)
    assert.are.equal(0, sc.nc)
  end)
end)

describe("a scene that names an effect wrongly gets an error naming the effect and the parameter", function()
  it("missing, wrong and unknown parameters", function()
    h.checkerror("effect 'spring': parameter 'k' is missing (the stiffness, a positive number)", E.spring, { coordinate = "x" })
    h.checkerror("effect 'spring': parameter 'k' must be positive, got -2", E.spring, { coordinate = "x", k = -2 })
    h.checkerror("effect 'damper': unknown parameter 'cc' (parameters: between, c, coordinate)", E.damper, { cc = 1 })
    h.checkerror("effect 'rolling_disk': parameter 'radius' is missing", E.rolling_disk, { x = "x", y = "y", heading = "t", angle = "p" })
    h.checkerror("effect 'gravity': parameter 'g' must be a vector {x, y, z}", E.gravity, { g = 9.81 })
    h.checkerror("effect 'spring': parameter 'between' must be two points {A, B}", E.spring, { between = { "a" }, k = 1 })
    h.checkerror("effect 'driven': parameter 'motion' is missing", E.driven, { coordinate = "x" })
    h.checkerror("effect 'constant_speed': parameter 'speed' must be positive", E.constant_speed, { coords = { "x" }, speed = 0 })
  end)
  it("names that the scene does not have", function()
    local T = function(t, q, qd) return 0.5 * qd[1] ^ 2 end
    h.checkerror("nz.scene 'bad': effect 'spring': parameter 'between' names no body 'bob'",
      nz.scene, { name = "bad", coords = { "x" }, T = T, effects = { E.spring{ between = { "bob", { 0, 0, 0 } }, k = 1 } } })
    h.checkerror("nz.scene 'bad': effect 'damper': parameter 'coordinate' names no coordinate 'y' (coordinates: x)",
      nz.scene, { name = "bad", coords = { "x" }, T = T, effects = { E.damper{ coordinate = "y", c = 1 } } })
    h.checkerror("nz.scene 'bad': effects[1] is not an effect: make one with nz.effects.NAME{...}",
      nz.scene, { name = "bad", coords = { "x" }, T = T, effects = { { kind = "spring" } } })
    -- one effect or one body without the list's braces: ipairs saw nothing
    -- in it, and the scene silently had no spring (x'' = 0, not -x)
    h.checkerror("nz.scene 'bad': 'effects' must be a list of effects: effects = { nz.effects.NAME{...}, ... } (one effect too goes in braces)",
      nz.scene, { name = "bad", coords = { "x" }, T = T, effects = E.spring{ coordinate = "x", k = 1 } })
    h.checkerror("nz.scene 'bad': nz.bodies: a list of bodies expected: bodies = { {mass = ..., pos = ...}, ... } (one body too goes in braces)",
      nz.scene, { name = "bad", coords = { "x" }, bodies = { mass = 1, pos = function(t, q) return { q[1], 0, 0 } end } })
    h.checkerror("effect 'rolling_ball': parameter 'body' 'p' has no rotation (rot)",
      nz.scene, { name = "bad", coords = { "x", "y" }, bodies = particle(1), effects = { E.rolling_ball{ body = "p", radius = 1 } } })
  end)
end)

describe("nz.check: a derivation by hand", function()
  local P = { M = 3.0, m = 0.8, l = 0.6, k = 40.0, g = 9.81 }
  local cart = nz.system{ name = "cart", coords = { "x", "th" }, params = P,
    T = function(t, q, qd, p) return 0.5 * (p.M + p.m) * qd[1] ^ 2 + p.m * p.l * qd[1] * qd[2] * nz.cos(q[2]) + 0.5 * p.m * p.l ^ 2 * qd[2] ^ 2 end,
    V = function(t, q, p) return 0.5 * p.k * q[1] ^ 2 - p.m * p.g * p.l * nz.cos(q[2]) end }
  local function right(t, q, qd, a)
    return { (P.M + P.m) * a[1] + P.m * P.l * nz.cos(q[2]) * a[2] - P.m * P.l * nz.sin(q[2]) * qd[2] ^ 2 + P.k * q[1],
      nz.cos(q[2]) * a[1] + P.l * a[2] + P.g * nz.sin(q[2]) }      -- divided by m l
  end
  it("accepts the right equations, and recombinations and scalings of them", function()
    assert.is_true((nz.check(cart, right, { quiet = true })))
    assert.is_true((nz.check(cart, function(t, q, qd, a) local r = right(t, q, qd, a); return { 3 * r[1] + r[2], r[1] - 2 * r[2] } end, { quiet = true })))
  end)
  it("names the wrong equation, the state, the expected and the student's values", function()
    local ok, text = nz.check(cart, function(t, q, qd, a) local r = right(t, q, qd, a); r[2] = r[2] + 0.01 * a[1]; return r end, { quiet = true })
    assert.is_false(ok)
    assert.truthy(text:find("Equation 2 is wrong: at t = ", 1, true), text)
    assert.truthy(text:find("the true accelerations are qdd = {", 1, true) and text:find("should give 0 but gives", 1, true), text)
    -- M and h beside the student's coefficients: the ratios show which term
    -- is off (here the qdd[1] term: the student's row is the system's / (m l)
    -- but for the 0.01 added to the first coefficient)
    local m1, m2 = text:match("the system's equation 2 there:  M%[2%] = {([^,]+), ([^}]+)}")
    local c1, c2 = text:match("your equation 2 there: +coefficients of qdd {([^,]+), ([^}]+)}")
    assert(m1 and c1, text)
    m1, m2, c1, c2 = tonumber(m1), tonumber(m2), tonumber(c1), tonumber(c2)
    local ml = P.m * P.l
    assert(math.abs(c2 - m2 / ml) <= 1e-5 * math.abs(c2), text)            -- the right term (6 digits shown)
    assert(math.abs(c1 - m1 / ml - 0.01) <= 1e-5, text)                     -- the wrong one, by 0.01
  end)
  it("says when the equations do not determine the accelerations", function()
    local ok, text = nz.check(cart, function(t, q, qd, a) local r = right(t, q, qd, a); return { r[1], 2 * r[1] } end, { quiet = true })
    assert.is_false(ok)
    assert.truthy(text:find("do not determine the accelerations", 1, true) and text:find("only 1 of the 2 are independent", 1, true), text)
  end)
  it("works with constraints: the sleigh's equations at the acceleration level", function()
    local case = cs.sleigh()
    local m, I, a = 2.0, 0.3, 0.4
    local ok = nz.check(case.sys, function(t, q, qd, qdd)
      local c, s = nz.cos(q[3]), nz.sin(q[3])
      local u = qd[1] * c + qd[2] * s
      local ud = qdd[1] * c + qdd[2] * s + qd[3] * (-qd[1] * s + qd[2] * c)
      return { -qdd[1] * s + qdd[2] * c - qd[3] * u, m * (ud - a * qd[3] ^ 2), (I + m * a * a) * qdd[3] + m * a * u * qd[3] }
    end, { quiet = true })
    assert.is_true(ok)
  end)
  it("explains a count mismatch and math.sin on dual numbers", function()
    h.checkerror("check: your equations must return a table of 2 expressions (one per coordinate: x, th), got 1 values",
      nz.check, cart, function() return { 0 } end, { quiet = true })
    h.checkerror("write them with nz.sin, nz.cos", nz.check, cart, function(t, q, qd, a) return { math.sin(a[1]), a[2] } end, { quiet = true })
  end)
end)
