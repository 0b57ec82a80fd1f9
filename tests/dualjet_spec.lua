-- dualjet_spec.lua - the state direction of the Lua evaluator (userdata
-- "nz.dualjet", src/lua/lua_dualjet.c): numbers v + eta d over jets.
--
-- Checked against what shares no code with it: the recorded graph's
-- eta-part (src/graph/graph.c: the same system with and without compile = false),
-- central differences of the jets' own evaluation along the direction, the
-- rules written out with plain jets, and the exact Jacobian of an implicit
-- integration on the recorded path.
local h = require "tests.helpers"
local nz = h.nz
local mech = require("nz.core").mech
local hd = require "nz.model.hyperdual"

local function uniform(a, b) return a + (b - a) * math.random() end

-- A random jet around v: order K, D tangents.
local function random_jet(v, K, D)
  local c = { v, order = K }
  for j = 1, K do c[j + 1] = uniform(-0.5, 0.5) * 0.6 ^ j end
  if D > 0 then
    c.tangents = {}
    for d = 1, D do
      c.tangents[d] = {}
      for j = 1, K + 1 do c.tangents[d][j] = uniform(-1, 1) * 0.6 ^ (j - 1) end
    end
  end
  return nz.jet(c)
end

-- Worst difference of two lists of jets, relative to each series' size.
local function worst(got, want)
  local w = 0
  for o = 1, #want do
    local a, b = got[o], want[o]
    for d = 0, b:ntangents() do
      local sa = d == 0 and a or a:tangent(d)
      local sb = d == 0 and b or b:tangent(d)
      local scale = 1
      for j = 0, b:order() do scale = math.max(scale, math.abs(sb:coef(j))) end
      for j = 0, b:order() do w = math.max(w, math.abs(sa:coef(j) - sb:coef(j)) / scale) end
    end
  end
  return w
end

-- One potential per operation, of t and q1, q2 (in [-1, 1]); numbers on
-- either side of every binary operation.
local ops = {
  { "add", function(t, q) return q[1] + q[2] + t + 2.5 + (3 + q[1]) end },
  { "sub", function(t, q) return q[1] - q[2] - t + (1 - q[1]) + (q[2] - 2) end },
  { "mul", function(t, q) return q[1] * q[2] * t + 3 * q[1] + q[2] * 0.5 end },
  { "div", function(t, q) return q[1] / (2 + q[2] * q[2]) + 1 / (3 + q[1]) + q[2] / 4 end },
  { "unary minus", function(t, q) return -q[1] * q[2] + -(t * q[2]) end },
  { "pow by a number", function(t, q) return q[1] ^ 3 + (2 + q[2]) ^ 0.5 + (3 + q[1]) ^ -1.5 + q[2] ^ 2 end },
  { "pow of two variables", function(t, q) return (2 + q[1] * q[1]) ^ q[2] end },
  { "pow of a number", function(t, q) return 2 ^ (q[1] * q[2]) + nz.pow(1.5, q[1]) end },
  { "nz.pow", function(t, q) return nz.pow(2 + q[1] * q[1], 1.5) + nz.pow(2 + q[2], q[1]) end },
  { "exp", function(t, q) return nz.exp(q[1] * q[2]) end },
  { "log", function(t, q) return nz.log(2 + q[1] * q[1] + t) end },
  { "sqrt", function(t, q) return nz.sqrt(3 + q[1] * q[2]) end },
  { "sin", function(t, q) return nz.sin(q[1] * q[2] + t) end },
  { "cos", function(t, q) return nz.cos(q[1] - q[2]) end },
  { "tan", function(t, q) return nz.tan(0.5 * q[1] + 0.2 * q[2]) end },
  { "asin", function(t, q) return nz.asin(0.5 * nz.sin(q[1] + q[2])) end },
  { "acos", function(t, q) return nz.acos(0.5 * nz.cos(q[1] * q[2])) end },
  { "atan", function(t, q) return nz.atan(q[1] + 2 * q[2]) end },
  { "sinh", function(t, q) return nz.sinh(q[1] * q[2]) end },
  { "cosh", function(t, q) return nz.cosh(q[1] - q[2]) end },
  { "tanh", function(t, q) return nz.tanh(q[1] + q[2]) end },
  { "abs", function(t, q) return nz.abs(q[1] - 2) * q[2] + nz.abs(q[2] + 2) * q[1] end },
  { "sign", function(t, q) return nz.sign(q[1] - 2) * q[2] + nz.sign(q[2] + 2) * q[1] * q[1] end },
  { "atan2", function(t, q) return nz.atan2(q[1], 2 + q[2]) + nz.atan2(q[2], -2) + nz.atan2(1.5, q[1] + 3) end },
  { "hypot", function(t, q) return nz.hypot(q[1], q[2] + 2) + nz.hypot(q[1], 3) + nz.hypot(2, q[2]) end },
  { "lt, gt and ifelse", function(t, q)
      return nz.ifelse(nz.lt(q[1], q[2]), q[1] * q[2], nz.sin(q[1])) + nz.gt(q[1], 0) * q[2] end },
  { "le, ge and ifelse with a number branch", function(t, q)
      return nz.ifelse(nz.ge(q[1], 0), 1, q[2] * q[2]) + nz.ifelse(nz.le(q[2], q[1]), q[1], 2) end },
  { "max and min", function(t, q) return nz.max(q[1] * q[1], nz.sin(q[2])) + nz.min(q[1], 0.3) * q[2] end },
  { "clamp", function(t, q) return nz.clamp(q[1] * q[2], -0.2, 0.2) + nz.clamp(q[1], -2, 2) * q[2] end },
}

local function twins(f)
  local def = { coords = { "x", "y" }, T = function(t, q, qd) return 0.5 * (qd[1] ^ 2 + qd[2] ^ 2) end, V = f }
  local a = nz.system(def)
  def.compile = false
  return a, nz.system(def)
end

local function random_args(K, D)
  local q = { uniform(-1, 1), uniform(-1, 1) }
  local t = random_jet(uniform(0, 1), K, D)
  local lv = { { random_jet(q[1], K, D), random_jet(q[2], K, D) } }
  local dt = random_jet(uniform(-1, 1), K, D)
  local dlv = { { random_jet(uniform(-1, 1), K, D), random_jet(uniform(-1, 1), K, D) } }
  return t, lv, dt, dlv
end

describe("every operation of the dualjet against the recorded graph", function()
  it("agrees on values and eta-parts, jets of order 0..6 with 0..3 tangents", function()
    math.randomseed(tonumber(os.getenv("NZ_TEST_SEED")) or 20261125)
    for _, op in ipairs(ops) do
      local graph, lua = twins(op[2])
      for _, r in ipairs(graph.recording) do
        assert(r.recorded, ("%s: %s was not recorded: %s"):format(op[1], r.label, tostring(r.why)))
      end
      for trial = 0, 6 do
        local t, lv, dt, dlv = random_args(trial, trial % 4)
        local va, da = mech.piece(graph.engine, "V", 1, t, lv, dt, dlv)
        local vb, db = mech.piece(lua.engine, "V", 1, t, lv, dt, dlv)
        local e = math.max(worst(vb, va), worst(db, da))
        assert(e <= 1e-13, ("%s, order %d: the Lua evaluator is off the graph by %.3g"):format(op[1], trial, e))
        -- the eta-part is not zero (the test would not see a dropped one)
        assert(worst(db, { nz.jet{ 0, order = trial } }) > 1e-6 or op[1]:find("ifelse"), op[1] .. ": eta-part zero")
      end
    end
  end)
end)

describe("the eta-part is the derivative along the direction", function()
  -- f(x + eta d) = f(x) + eta f'(x) d: the eta-part of every coefficient and
  -- tangent is the central difference of the jets' own evaluation (no
  -- direction) at x +- h d.
  it("matches central differences for every operation", function()
    math.randomseed(tonumber(os.getenv("NZ_TEST_SEED")) or 20261126)
    local step = 1e-5
    for _, op in ipairs(ops) do
      local _, lua = twins(op[2])
      local t, lv, dt, dlv = random_args(3, 2)
      local _, d = mech.piece(lua.engine, "V", 1, t, lv, dt, dlv)
      local function at(s)
        local shifted = { { lv[1][1] + s * dlv[1][1], lv[1][2] + s * dlv[1][2] } }
        return mech.piece(lua.engine, "V", 1, t + s * dt, shifted)[1]
      end
      local plus, minus = at(step), at(-step)
      local diff = (plus - minus) / (2 * step)
      local e = worst(d, { diff })
      assert(e <= 1e-7, ("%s: eta-part off the central difference by %.3g"):format(op[1], e))
    end
  end)
end)

describe("dualjets written out with jets", function()
  local v, d = nz.jet(0.7, 2, 1, 2), nz.jet{ 0.3, 0.1, order = 2, tangents = { { 0, 0.5 } } }
  local x = mech.dualjet(v, d)
  local y = nz.jet(1.3, 2, 2, 2)
  local function same(got, wv, wd, what)
    assert.are.equal("userdata", type(got), what)
    local gv, gd = got:parts()
    local e = math.max(worst({ gv }, { wv }), worst({ gd }, { wd }))
    assert(e <= 1e-14, ("%s: off by %.3g"):format(what, e))
  end
  it("mixes numbers, jets and dualjets on either side", function()
    same(x + 2.5, v + 2.5, d, "x + 2.5")
    same(2.5 + x, v + 2.5, d, "2.5 + x")
    same(x - y, v - y, d, "x - jet")
    same(y - x, y - v, -d, "jet - x")
    same(3 * x, 3 * v, 3 * d, "3 x")
    same(x * y, v * y, d * y, "x jet")
    same(y / x, y / v, -y * d / (v * v), "jet / x")
    same(x / 4, v / 4, d / 4, "x / 4")
    same(x ^ 2.5, v ^ 2.5, 2.5 * v ^ 1.5 * d, "x^2.5")
    same(2.5 ^ x, 2.5 ^ v, 2.5 ^ v * math.log(2.5) * d, "2.5^x")
    same(-x, -v, -d, "-x")
    local w, e = nz.jet(-0.4, 2, 1, 2), nz.jet{ 1, -1, order = 2 }
    local z = mech.dualjet(w, e)
    same(x * z, v * w, d * w + v * e, "x z")
    same(x / z, v / w, (d - (v / w) * e) / w, "x / z")
    same(nz.sin(x), nz.sin(v), nz.cos(v) * d, "sin x")
    same(nz.abs(z), -w, -e, "abs of a negative value")
    same(nz.atan2(x, z), nz.atan2(v, w), (w * d - v * e) / (v * v + w * w), "atan2")
    same(nz.hypot(x, z), nz.hypot(v, w), (v * d + w * e) / nz.hypot(v, w), "hypot")
  end)
  it("compares and branches on the value part only", function()
    assert.is_true(x < 1)
    assert.is_true(0.5 < x)
    assert.is_true(nz.jet(0.5, 1) < x)     -- a jet against a dualjet
    assert.is_true(x <= nz.jet(0.7, 3))
    assert.is_true(x == nz.jet(0.7, 1))
    assert.is_true(nz.isjet(nz.sign(x)))   -- a step: a plain jet
    assert.are.equal(1, nz.sign(x):value())
    assert.are.equal(1, nz.lt(x, 1):value())
    same(nz.ifelse(nz.gt(x, 1), 5, x), v, d, "ifelse takes x")
    local m = nz.max(x, 0.9)               -- 0.9 chosen: eta-part zero
    same(m, v * 0 + 0.9, d * 0, "max takes the number")
    same(nz.clamp(x, 0, 0.5), v * 0 + 0.5, d * 0, "clamp above")
    same(nz.clamp(x, 0.8, 1), v * 0 + 0.8, d * 0, "clamp below")
    same(nz.clamp(x, mech.dualjet(nz.jet(0.8, 2), nz.jet{ 2, order = 2 }), 1), v * 0 + nz.jet(0.8, 2), d * 0 + 2, "clamp below a dualjet bound")
    same(nz.clamp(x, 0, 1), v, d, "clamp inside")
    same(nz.min(x, mech.dualjet(nz.jet(0.1, 2), nz.jet{ 3, order = 2 })), v * 0 + nz.jet(0.1, 2), d * 0 + 3, "min takes the other dualjet")
  end)
  it("is the value and the eta-part of nested dual numbers (bodies' velocities)", function()
    -- r(q) = sin q along q' with q = x: r' = cos(x) q', a dualjet.
    local qd = mech.dualjet(nz.jet(0.2, 2), nz.jet{ 1, order = 2 })
    local r = nz.sin(hd.new(x, qd))
    local rv, rd = hd.parts(r)
    same(rv, nz.sin(v), nz.cos(v) * d, "position")
    local qv, qe = qd:parts()
    same(rd, nz.cos(v) * qv, -nz.sin(v) * d * qv + nz.cos(v) * qe, "velocity")
    assert.is_true(hd.new(x, 1) < 1)
  end)
  it("names the function and the value in errors, as the jets do", function()
    h.checkerror("'log' of a non-positive value (got -1)", nz.log, mech.dualjet(nz.jet(-1, 1), 1))
    h.checkerror("'sqrt' of a negative value (got -1)", nz.sqrt, mech.dualjet(nz.jet(-1, 1), 1))
    h.checkerror("'abs' is not differentiable at 0", nz.abs, mech.dualjet(nz.jet(0, 1), 1))
    h.checkerror("'division' by a series whose constant term is zero", function() return x / mech.dualjet(nz.jet(0, 1), 1) end)
    h.checkerror("bad argument #2 to 'add' (number, jet or dualjet expected, got table)", function() return x + {} end)
    h.checkerror("bad argument #2 to 'clamp' (the lower bound 2 is above the upper bound 1", nz.clamp, x, 2, 1)
    h.checkerror("bad argument #1 to 'ifelse' (number or jet expected, got boolean)", nz.ifelse, true, x, 1)
  end)
end)

describe("the exact Jacobian of an implicit integration", function()
  -- A double pendulum from bodies: the Lua evaluator's direction runs
  -- through nz/model/hyperdual.lua's nested duals whose parts are dualjets.
  local function pendulum(compile)
    return nz.system{ coords = { "a", "b" }, compile = compile, bodies = { gravity = { 0, -9.81, 0 },
      { mass = 1, pos = function(t, q) return { nz.sin(q[1]), -nz.cos(q[1]), 0 } end },
      { mass = 0.5, pos = function(t, q)
          return { nz.sin(q[1]) + 0.8 * nz.sin(q[2]), -nz.cos(q[1]) - 0.8 * nz.cos(q[2]), 0 } end } } }
  end
  local lua, graph = pendulum(false), pendulum(true)
  it("agrees with the recorded path", function()
    local ja = mech.ode_new(lua.engine, { method = "bsimp", orders = {}, linear = {} })
    local jb = mech.ode_new(graph.engine, { method = "bsimp", orders = {}, linear = {} })
    local y = { 0.9, -0.4, 0.3, 1.1 }
    local A, adt = mech.ode_jacobian(ja, lua.engine, 0.2, y)
    local B, bdt = mech.ode_jacobian(jb, graph.engine, 0.2, y)
    for i = 1, 4 do
      assert(math.abs(adt[i] - bdt[i]) <= 1e-12)
      for j = 1, 4 do
        assert(math.abs(A[i][j] - B[i][j]) <= 1e-12 * math.max(1, math.abs(B[i][j])),
          ("J[%d][%d]: %.17g against %.17g"):format(i, j, A[i][j], B[i][j]))
      end
    end
  end)
  it("takes the same steps in a bsimp run", function()
    local run = { q0 = { 0.9, -0.4 }, qd0 = { 0.3, 1.1 }, t1 = 1, dt = 0.1, method = "bsimp", rtol = 1e-8, atol = 1e-8 }
    local ta, tb = lua:simulate(run), graph:simulate(run)
    assert.are.equal(tb.stats.steps, ta.stats.steps)
    assert.are.equal(#tb.t, #ta.t)
    for n = 1, #tb.t do
      for i = 1, 2 do
        assert(math.abs(ta.q[n][i] - tb.q[n][i]) <= 1e-10, ("q[%d] at t = %g"):format(i, tb.t[n]))
      end
    end
  end)
end)
