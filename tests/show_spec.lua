-- show_spec.lua - sys:show: the equations of motion as formulas.  The
-- smallest systems against text written by hand here; every system (free,
-- holonomic, nonholonomic linear and nonlinear in the velocities, Hamel's
-- second-order constraint) by a round trip: the formulas printed in Lua
-- syntax, loaded back as a Lua function, equal the engine's residual
-- (sys:residual, with the multipliers) at random states.
local h = require "tests.helpers"
local nz = h.nz
local cs = require "tests.constraint_systems"

local function pendulum()
  return nz.system{ name = "pendulum", coords = { "th" }, params = { m = 1, g = 9.81, l = 2 },
    T = function(t, q, qd, P) return 0.5 * P.m * P.l ^ 2 * qd[1] ^ 2 end,
    V = function(t, q, P) return -P.m * P.g * P.l * nz.cos(q[1]) end }
end

local function double_pendulum()
  return nz.system{ name = "double pendulum", coords = { "th1", "th2" }, params = { m1 = 1, m2 = 1.5, l1 = 1, l2 = 0.7, g = 9.81 },
    T = function(t, q, qd, P)
      -- from the bobs' positions: x1 = l1 sin th1, y1 = -l1 cos th1, x2 = x1 + l2 sin th2, ...
      local x1d, y1d = P.l1 * nz.cos(q[1]) * qd[1], P.l1 * nz.sin(q[1]) * qd[1]
      local x2d, y2d = x1d + P.l2 * nz.cos(q[2]) * qd[2], y1d + P.l2 * nz.sin(q[2]) * qd[2]
      return 0.5 * P.m1 * (x1d ^ 2 + y1d ^ 2) + 0.5 * P.m2 * (x2d ^ 2 + y2d ^ 2)
    end,
    V = function(t, q, P) return -P.m1 * P.g * P.l1 * nz.cos(q[1]) - P.m2 * P.g * (P.l1 * nz.cos(q[1]) + P.l2 * nz.cos(q[2])) end }
end

local function spherical_pendulum()
  return nz.system{ name = "spherical pendulum", coords = { "th", "ph" }, params = { m = 1.2, g = 9.81, l = 0.8 },
    T = function(t, q, qd, P) return 0.5 * P.m * P.l ^ 2 * (qd[1] ^ 2 + nz.sin(q[1]) ^ 2 * qd[2] ^ 2) end,
    V = function(t, q, P) return -P.m * P.g * P.l * nz.cos(q[1]) end }
end

local function knife_edge()
  return nz.system{ name = "knife edge", coords = { "x", "y", "th" }, params = { m = 1.2, J = 0.05 },
    T = function(t, q, qd, P) return 0.5 * P.m * (qd[1] ^ 2 + qd[2] ^ 2) + 0.5 * P.J * qd[3] ^ 2 end,
    constraints = { function(t, q, qd) return nz.sin(q[3]) * qd[1] - nz.cos(q[3]) * qd[2] end } }
end

describe("sys:show: the equations as text", function()
  it("the simple pendulum: l^2 m th'' + g l m sin(th) = 0", function()
    local text = pendulum():show{}
    assert.truthy(text:find("  th:  l^2 m th'' + g l m sin(th) = 0", 1, true), text)
    assert.truthy(text:find("n = 1, Nielsen's equations", 1, true), text)
  end)

  it("the double pendulum: coefficients of q'' collected, like terms with their parameters' sum", function()
    local text = double_pendulum():show{}
    -- derived by hand from T: M11 = (m1 + m2) l1^2, M12 = m2 l1 l2 cos(th1 - th2),
    -- h1 = m2 l1 l2 sin(th1 - th2) th2'^2 + (m1 + m2) g l1 sin th1
    assert.truthy(text:find("th1:  l1^2 (m1 + m2) th1'' + l1 l2 m2 cos(th1 - th2) th2'' + l1 l2 m2 sin(th1 - th2) th2'^2"
      .. " + g l1 (m1 + m2) sin(th1) = 0", 1, true), text)
    assert.truthy(text:find("th2:  l1 l2 m2 cos(th1 - th2) th1'' + l2^2 m2 th2'' - l1 l2 m2 sin(th1 - th2) th1'^2"
      .. " + g l2 m2 sin(th2) = 0", 1, true), text)
  end)

  it("the spherical pendulum: sin and cos of th, th' ph' cross term", function()
    local text = spherical_pendulum():show{}
    -- M = m l^2 diag(1, sin^2 th); h_th = -m l^2 sin cos ph'^2 + m g l sin th,
    -- h_ph = 2 m l^2 sin cos th' ph'
    assert.truthy(text:find("th:  l^2 m th'' - l^2 m cos(th) sin(th) ph'^2 + g l m sin(th) = 0", 1, true), text)
    assert.truthy(text:find("ph:  l^2 m sin(th)^2 ph'' + 2 l^2 m cos(th) sin(th) th' ph' = 0", 1, true), text)
  end)

  it("the Cartesian pendulum and the knife edge: the multipliers on the right, the constraints listed", function()
    local p = nz.system{ name = "cartesian pendulum", coords = { "x", "y" }, params = { m = 1, g = 9.81, L = 1.3 },
      T = function(t, q, qd, P) return 0.5 * P.m * (qd[1] ^ 2 + qd[2] ^ 2) end,
      V = function(t, q, P) return P.m * P.g * q[2] end,
      constraints = { function(t, q, qd, qdd, qddd, P) return q[1] ^ 2 + q[2] ^ 2 - P.L ^ 2 end } }
    local text = p:show{}
    assert.truthy(text:find("  x:  m x'' = 2 lambda1 x\n  y:  m y'' + g m = 2 lambda1 y\n", 1, true), text)
    assert.truthy(text:find("(1)  x^2 + y^2 - L^2 = 0   (order 0: A = dPhi/dq)", 1, true), text)
    local ke = knife_edge():show{}
    assert.truthy(ke:find("  x :  m x'' = lambda1 sin(th)\n  y :  m y'' = -lambda1 cos(th)\n  th:  J th'' = 0\n", 1, true), ke)
    assert.truthy(ke:find("(1)  sin(th) x' - cos(th) y' = 0   (order 1: A = dPhi/dq')", 1, true), ke)
  end)

  it("Hamel's particle: the multiplier's coefficients hold the accelerations (A = dPhi/dq'')", function()
    local text = cs.hamel().sys:show{}
    assert.truthy(text:find("q1:  1.5 q1'' - 0.7 = -lambda1 q2''", 1, true), text)
    assert.truthy(text:find("q3:  1.5 q3'' - 2 = lambda1", 1, true), text)
    assert.truthy(text:find("(1)  -q1'' q2'' + q3'' = 0   (order 2", 1, true), text)
  end)

  it("mass = true and bias = true print M and h; long equations name their repeated parts", function()
    local text = double_pendulum():show{ mass = true, bias = true }
    assert.truthy(text:find("M[th1, th1] = l1^2 (m1 + m2)", 1, true), text)
    assert.truthy(text:find("M[th1, th2] = l1 l2 m2 cos(th1 - th2)", 1, true), text)
    assert.truthy(text:find("h[th2] = l2 m2 (-l1 sin(th1 - th2) th1'^2 + g sin(th2))", 1, true), text)
    local named = double_pendulum():show{ names = true }
    assert.truthy(named:find("where\n  c1 = cos(th1 - th2)\n  s1 = sin(th1 - th2)", 1, true), named)
    assert.truthy(named:find("l1 l2 m2 c1 th2''", 1, true), named)
  end)

  it("reduced = true: Tsenov's equations without multipliers, which vanish on the motion", function()
    local text = knife_edge():show{ reduced = true }
    -- by hand: the blade's direction (cos th, sin th) removes the lateral reaction
    assert.truthy(text:find("x :  m cos(th) x'' + m sin(th) y'' = 0", 1, true), text)
    assert.truthy(text:find("th:  J th'' = 0", 1, true), text)
    local formula = require "nz.base.formula"
    for _, sys in ipairs{ knife_edge(), cs.sleigh().sys, cs.rolling_disk().sys, cs.cartesian_pendulum().sys, cs.program().sys } do
      local show = require "nz.presentation.show"
      local eq = show.equations(sys)
      local red = assert(show.reduced(sys, eq))
      assert.are.equal(sys.k - sys.nc, #red.equations)
      local fs = {}
      for n, e in ipairs(red.equations) do
        fs[n] = assert(load("return function(t, q, qd, qdd, lambda, params) return " .. formula.print(e, "lua") .. " end",
          "=(reduced)", "t", { math = math, nz = nz }))()
      end
      for _ = 1, 5 do
        -- a state on the constraints, drawn by hand (tests/constraint_systems.lua), and its accelerations
        local t, q, qd
        if sys.name == "knife edge" then
          local th, v = 2 * math.random() - 1, 2 * math.random() - 1
          t, q, qd = 0, { math.random(), math.random(), th }, { v * math.cos(th), v * math.sin(th), math.random() }
        else
          local c = ({ sleigh = cs.sleigh, ["rolling disk"] = cs.rolling_disk, ["cartesian pendulum"] = cs.cartesian_pendulum,
            program = cs.program })[sys.name]()
          t, q, qd = c.draw()
        end
        local qdd = sys:accel(t, q, qd)
        for n, f in ipairs(fs) do
          local v = f(t, q, qd, qdd, {}, sys.params)
          -- terms of size ~1-10: rounding only (bound 1e-12)
          assert(math.abs(v) <= 1e-12, ("%s: reduced equation %d leaves %.3g on the motion"):format(sys.name, n, v))
        end
      end
    end
  end)

  it("appell = true: Appell's S, whose derivatives in q'' give the equations", function()
    -- a particle in a plane under gravity, in polar coordinates: S = m/2 |a|^2
    -- up to terms free of the accelerations, |a|^2 = (r'' - r th'^2)^2 + (r th'' + 2 r' th')^2
    local polar = nz.system{ name = "polar", coords = { "r", "th" }, params = { m = 2 },
      T = function(t, q, qd, P) return 0.5 * P.m * (qd[1] ^ 2 + q[1] ^ 2 * qd[2] ^ 2) end }
    local text = polar:show{ appell = true }
    assert.truthy(text:find("S = -m r th'^2 r'' + 0.5 m r''^2 + 2 m r r' th' th'' + 0.5 m r^2 th''^2", 1, true), text)
    local show, formula = require "nz.presentation.show", require "nz.base.formula"
    for _, sys in ipairs{ double_pendulum(), spherical_pendulum(), polar } do
      local eq = show.equations(sys)
      local S = show.appell(sys, eq)
      local force = show.forces(sys, eq)
      -- dS/dq''_i = (M q'' + h)_i + (dV/dq - Q)_i: S loaded back as Lua and
      -- differenced in q''_i (exact up to rounding: S is quadratic in q'')
      local f = assert(load("return function(t, q, qd, qdd, lambda, params) return " .. formula.print(S, "lua") .. " end",
        "=(S)", "t", { math = math, nz = nz }))()
      for _ = 1, 5 do
        local q, qd, qdd = {}, {}, {}
        for i = 1, sys.k do q[i], qd[i], qdd[i] = math.random() + 0.3, math.random() - 0.5, math.random() - 0.5 end
        local res = sys:residual(1, 0, q, qd, qdd)
        for i = 1, sys.k do
          -- S is quadratic in q'': the central difference is exact up to rounding
          local hh = 1e-3
          local up, dn = { table.unpack(qdd) }, { table.unpack(qdd) }
          up[i], dn[i] = up[i] + hh, dn[i] - hh
          local dS = (f(0, q, qd, up, {}, sys.params) - f(0, q, qd, dn, {}, sys.params)) / (2 * hh)
          -- dS/dq''_i = (M q'' + h)_i - (force part of h)_i: compare with the
          -- residual less the applied forces (-dV/dq + Q) of the formula
          local fi = assert(load("return function(t, q, qd, qdd, lambda, params) return " .. formula.print(force[i], "lua") .. " end",
            "=(F)", "t", { math = math, nz = nz }))()(0, q, qd, qdd, {}, sys.params)
          assert(math.abs(dS - (res[i] + fi)) <= 1e-9 * (1 + math.abs(res[i])), ("%s: dS/dq''_%d %.15g, residual + forces %.15g"):format(
            sys.name, i, dS, res[i] + fi))
        end
      end
    end
  end)

  it("refuses a system it cannot read, and unknown options", function()
    local lua_only = nz.system{ name = "not recorded", coords = { "x" }, compile = false, T = function(t, q, qd) return qd[1] ^ 2 end }
    h.checkerror("the system is not recorded", lua_only.show, lua_only, {})
    -- V with a Lua branch on the state runs in Lua beside a recorded T: the
    -- graph's M and h lack V, so the formula would be x'' = 0 while the
    -- motion is x'' = -2x (the first version printed exactly that)
    local branch = nz.system{ name = "branch", coords = { "x" }, T = function(t, q, qd) return 0.5 * qd[1] ^ 2 end,
      V = function(t, q) if q[1] > 0 then return q[1] ^ 2 else return 0 end end }
    assert.are.equal(-2, branch:accel(0, { 1 }, { 0 })[1])
    h.checkerror("V runs in Lua: compares a traced value", branch.show, branch, {})
    local p = pendulum()
    h.checkerror("unknown option 'latex'", p.show, p, { latex = true })
  end)
end)

describe("sys:show{tex = true}", function()
  it("an aligned block with Greek letters, dots and \\sin", function()
    local tex = pendulum():show{ tex = true }
    assert.are.equal("\\begin{aligned}\n  l^{2} \\, m \\, \\ddot{\\theta} + g \\, l \\, m \\, \\sin\\left(\\theta\\right) &= 0\n\\end{aligned}", tex)
    local dp = double_pendulum():show{ tex = true }
    -- balanced braces and \left( ... \right) pairs
    local depth, lefts, rights = 0, 0, 0
    for ch in dp:gmatch("[{}]") do depth = depth + (ch == "{" and 1 or -1); assert(depth >= 0, dp) end
    assert.are.equal(0, depth)
    for _ in dp:gmatch("\\left") do lefts = lefts + 1 end
    for _ in dp:gmatch("\\right") do rights = rights + 1 end
    assert.are.equal(lefts, rights)
    assert.truthy(dp:find("\\ddot{\\theta}_{1}", 1, true) or dp:find("\\ddot{\\theta_{1}}", 1, true), dp)
  end)
  it("the mass matrix, the bias, Appell's S and Tsenov's reduced equations in LaTeX too (they were left out)", function()
    local tex = pendulum():show{ tex = true, mass = true, bias = true, appell = true }
    assert.truthy(tex:find("% the mass matrix M(q)\n\\begin{aligned}\n  M_{\\theta \\theta} &= l^{2} \\, m\n\\end{aligned}", 1, true), tex)
    assert.truthy(tex:find("h_{\\theta} &= g \\, l \\, m \\, \\sin\\left(\\theta\\right)", 1, true), tex)
    assert.truthy(tex:find("S &= 0.5 \\, l^{2} \\, m \\, \\ddot{\\theta}^{2}", 1, true), tex)
    local knife = nz.system{ name = "knife", coords = { "x", "y", "th" },
      T = function(t, q, qd) return 0.5 * (qd[1] ^ 2 + qd[2] ^ 2 + qd[3] ^ 2) end,
      constraints = { function(t, q, qd) return qd[2] * nz.cos(q[3]) - qd[1] * nz.sin(q[3]) end } }
    -- y dependent: x'' + tan(th) y'' = 0 multiplied by cos(th), by hand
    local red = knife:show{ tex = true, reduced = true }
    assert.truthy(red:find("\\cos\\left(\\theta\\right) \\, \\ddot{x} + \\sin\\left(\\theta\\right) \\, \\ddot{y} &= 0", 1, true), red)
    for block in red:gmatch("\\begin{aligned}(.-)\\end{aligned}") do assert.is_nil(block:find("\\begin", 1, true)) end
  end)
end)

describe("sys:show{lua = true}: the formulas loaded back equal the engine's residual", function()
  local systems = {
    { pendulum(), 0 }, { double_pendulum(), 0 }, { spherical_pendulum(), 0 }, { knife_edge(), 1 },
    { cs.cartesian_pendulum().sys, 1 }, { cs.sleigh().sys, 1 }, { cs.appell().sys, 1 }, { cs.rolling_disk().sys, 2 },
    { cs.hamel().sys, 1 }, { cs.driven_hoop().sys, 1 }, { cs.program().sys, 1 },
  }
  for _, entry in ipairs(systems) do
    local sys = entry[1]
    it(sys.name, function()
      local chunk = sys:show{ lua = true }
      local f = assert(load(chunk, "=(show)", "t", { math = math, nz = nz }))()
      for _ = 1, 20 do
        local t, q, qd, qdd, lambda = 3 * math.random(), {}, {}, {}, {}
        for i = 1, sys.k do q[i], qd[i], qdd[i] = 2 * math.random() - 1, 2 * math.random() - 1, 2 * math.random() - 1 end
        for r = 1, sys.nc do lambda[r] = 2 * math.random() - 1 end
        local want = sys:residual(1, t, q, qd, qdd, sys.nc > 0 and lambda or nil)
        local got = f(t, q, qd, qdd, lambda, sys.params)
        for i = 1, sys.k do
          -- the same terms summed in another order: rounding only, terms of size ~10
          assert(math.abs(got[i] - want[i]) <= 1e-12 * (1 + math.abs(want[i])),
            ("%s, equation %d: formula %.17g, engine %.17g"):format(sys.name, i, got[i], want[i]))
        end
      end
    end)
  end
end)

-- ------------------------------------------------------------------ --
-- The equations of order n (docs/theory.md (3.1), (4.1)-(4.2))

local ms = require "tests.mech_systems"
local show, formula = require "nz.presentation.show", require "nz.base.formula"

-- A polynomial as a Lua function of the state (higher = {q''', q^(4), ...};
-- frozen: the velocities held in F_0 of R_1).
local function as_lua(P)
  return assert(load("return function(t, q, qd, qdd, lambda, params, higher, frozen) return " .. formula.print(P, "lua")
    .. " end", "=(formula)", "t", { math = math, nz = nz }))()
end

-- Every system the tests define, with a drawn state: {name, sys, draw}.
local function every_system()
  local list = {}
  for _, c in ipairs(ms.all()) do list[#list + 1] = c end
  for _, c in ipairs(cs.linear_at_acceleration_level()) do list[#list + 1] = c end
  list[#list + 1] = cs.hamel()
  list[#list + 1] = cs.driven_hoop()
  return list
end

-- A random state with n derivatives above q'' (higher) and multipliers.
local function state(c, n)
  local t, q, qd = c.draw()
  local sys, qdd, higher, lambda = c.sys, {}, {}, {}
  for i = 1, sys.k do qdd[i] = 2 * math.random() - 1 end
  for j = 1, n do
    higher[j] = {}
    for i = 1, sys.k do higher[j][i] = 2 * math.random() - 1 end
  end
  for r = 1, sys.nc do lambda[r] = 2 * math.random() - 1 end
  return t, q, qd, qdd, higher, lambda
end

-- q_i^(j) of a state, j = 0, 1, ...
local function level(j, q, qd, qdd, higher) return ({ q, qd, qdd })[j + 1] or higher[j - 2] end

-- Does P hold a derivative above q'' (in a function's argument too)?
local function holds_above(P, top)
  for _, t in ipairs(P.terms) do
    for _, x in ipairs(t.f) do
      local a = x.a
      if a.kind == "sym" and a.info and a.info.slot and a.info.slot > top then return true end
      for _, sub in ipairs{ a.arg, a.a, a.b, a.c, a.base, a.poly } do
        if type(sub) == "table" and sub.terms and holds_above(sub, top) then return true end
      end
    end
  end
  return false
end

-- The equation lines of sys:show's text (coordinate: ... = ...).
local function equation_lines(text)
  local out = {}
  for line in text:gmatch("[^\n]+") do
    if line:find("^with the constraints") or line:find("^the terms") then break end
    if line:match("^  %S+%s*:  ") then out[#out + 1] = line end
  end
  return table.concat(out, "\n")
end

describe("sys:show{n = ...}: Dolapchiev's equations of order n as formulas", function()
  it("the pendulum at n = 3: (3.1)'s terms by hand, collected to the equation of every order", function()
    local text = pendulum():show{ n = 3 }
    -- T = m l^2 th'^2 / 2: T''' = m l^2 (th' th'''' + 3 th'' th'''), so
    -- dT'''/dth''' = 3 m l^2 th'' and (1/3)(3 m l^2 th'' - 4 * 0) = -m g l sin th
    assert.truthy(text:find("equations of order n = 3 of 'pendulum', Dolapchiev's equations with the jerk q''':", 1, true), text)
    assert.truthy(text:find("(1/3) (dT'''/dq''' - 4 dT/dq) = Q + A^T lambda", 1, true), text)
    assert.truthy(text:find("  th:  l^2 m th'' + g l m sin(th) = 0", 1, true), text)
    assert.truthy(text:find("  dT'''/dth''' = 3 l^2 m th''\n  dT/dth       = 0\n  Q_th         = -g l m sin(th)", 1, true), text)
    assert.truthy(pendulum():show{ n = 1 }:find("Nielsen's equations:\n  dT'/dq' - 2 dT/dq = Q", 1, true))
    assert.truthy(pendulum():show{ n = 2 }:find("Tsenov's equations:\n  (1/2) (dT''/dq'' - 3 dT/dq) = Q", 1, true))
    assert.truthy(pendulum():show{ n = 12 }:find("dT^(12)/dth^(12) = 12 l^2 m th''", 1, true))
  end)

  it("every order collects to the equations of n = 1, and its terms hold nothing above q'' ((2.1))", function()
    -- parameters by name: their coefficients are exact in every order
    -- (literal numbers are multiplied out in the recording, and (3 c)/3 may
    -- differ from c in its last digit)
    local cartesian = nz.system{ name = "cartesian pendulum", coords = { "x", "y" }, params = { m = 1.5, g = 9.81, L = 1.3 },
      T = function(t, q, qd, P) return 0.5 * P.m * (qd[1] ^ 2 + qd[2] ^ 2) end,
      V = function(t, q, P) return P.m * P.g * q[2] end,
      constraints = { function(t, q, qd, qdd, qddd, P) return q[1] ^ 2 + q[2] ^ 2 - P.L ^ 2 end } }
    for _, sys in ipairs{ pendulum(), double_pendulum(), spherical_pendulum(), knife_edge(), cartesian } do
      local base = equation_lines(sys:show{})
      for _, n in ipairs{ 1, 2, 3, 7 } do
        -- the same text: coefficients of parameters by name are exact
        assert.are.equal(base, equation_lines(sys:show{ n = n }), ("%s, n = %d"):format(sys.name, n))
        local eq = show.equations(sys, n)
        for i = 1, sys.k do
          assert.is_false(holds_above(eq.order.top[i], 2), ("%s, n = %d: dT^(n)/dq^(n) holds a derivative above q''"):format(sys.name, n))
          assert.is_false(holds_above(eq.lhs[i], 2), ("%s, n = %d: equation %d"):format(sys.name, n, i))
        end
      end
    end
  end)

  it("the Lua form of order n equals sys:residual(n, ...) for every system of the tests, n = 1, 2, 3, 7", function()
    for _, c in ipairs(every_system()) do
      local sys = c.sys
      for _, n in ipairs{ 1, 2, 3, 7 } do
        local chunk = sys:show{ n = n, lua = true }
        assert.truthy(chunk:find(("residuals of order %d"):format(n), 1, true), chunk)
        -- like terms that cancel up to the rounding of the recording's
        -- numbers leave nothing ((3 c)/3 - c: 2e-16 sin(a - b) a' b' in the
        -- double pendulum from its bodies at n = 2, before)
        local text = sys:show{ n = n }
        assert.falsy(text:find("%de%-1[3-9]"), text)
        local f = assert(load(chunk, "=(show)", "t", { math = math, nz = nz }))()
        -- (4.2): dR_n/dq^(n) less the forces, another graph (through F_0)
        local eq = show.equations(sys, n)
        local appell = {}
        for i = 1, sys.k do appell[i] = as_lua(eq.order.appell(i)) end
        for _ = 1, 5 do
          local t, q, qd, qdd, higher, lambda = state(c, n)
          local lam = sys.nc > 0 and lambda or nil
          local want = sys:residual(n, t, q, qd, qdd, lam, { higher = higher })
          local want_appell = sys:residual(n, t, q, qd, qdd, { form = "appell", higher = higher })
          local got = f(t, q, qd, qdd, lambda, sys.params, higher)
          for i = 1, sys.k do
            -- the same terms summed in another order: rounding only
            assert(math.abs(got[i] - want[i]) <= 1e-12 * (1 + math.abs(want[i])),
              ("%s, n = %d, equation %d: formula %.17g, engine %.17g"):format(sys.name, n, i, got[i], want[i]))
            local a = appell[i](t, q, qd, qdd, lambda, sys.params, higher)
            assert(math.abs(a - want_appell[i]) <= 1e-12 * (1 + math.abs(want_appell[i])),
              ("%s, n = %d, (4.2) %d: formula %.17g, engine %.17g"):format(sys.name, n, i, a, want_appell[i]))
          end
        end
      end
    end
  end)

  it("appell = true with n: R_2 is Appell's S, R_n differentiated in q^(n) gives the equations", function()
    local polar = nz.system{ name = "polar", coords = { "r", "th" }, params = { m = 2 },
      T = function(t, q, qd, P) return 0.5 * P.m * (qd[1] ^ 2 + q[1] ^ 2 * qd[2] ^ 2) end }
    for _, sys in ipairs{ double_pendulum(), spherical_pendulum(), polar } do
      -- two paths: S from M and h, R_2 from F'' and F_0'' on the graph
      local S = sys:show{ appell = true }:match("\n  S = ([^\n]*)")
      local R2 = sys:show{ n = 2, appell = true }:match("\n  R_2 = ([^\n]*)")
      assert.are.equal(S, R2, sys.name)
    end
    -- dR_n/dq_i^(n) = residual (form "appell") + the forces Q - dV/dq: R_n
    -- is at most quadratic in q^(n) for n >= 2, so the central difference is
    -- exact up to rounding
    for _, c in ipairs{ ms.double_pendulum(true), ms.charged_drag(), ms.relativistic(), cs.sleigh(), cs.hamel() } do
      local sys = c.sys
      for _, n in ipairs{ 2, 3, 7 } do
        local eq = show.equations(sys, n)
        local R = as_lua(eq.order.R())
        local force = {}
        for i = 1, sys.k do force[i] = as_lua(eq.order.force[i]) end
        for _ = 1, 3 do
          local t, q, qd, qdd, higher = state(c, n)
          local want = sys:residual(n, t, q, qd, qdd, { form = "appell", higher = higher })
          for i = 1, sys.k do
            local x = level(n, q, qd, qdd, higher)
            local keep, h = x[i], 1e-3
            x[i] = keep + h
            local up = R(t, q, qd, qdd, {}, sys.params, higher)
            x[i] = keep - h
            local dn = R(t, q, qd, qdd, {}, sys.params, higher)
            x[i] = keep
            local dR = (up - dn) / (2 * h)
            local f = force[i](t, q, qd, qdd, {}, sys.params, higher)
            assert(math.abs(dR - (want[i] + f)) <= 1e-9 * (1 + math.abs(dR)),
              ("%s, n = %d: dR_n/dq_%d^(n) %.15g, residual + forces %.15g"):format(sys.name, n, i, dR, want[i] + f))
          end
        end
      end
    end
  end)

  it("R_n from its derivatives in q^(n) is R_n(q^(n)) - R_n(0) of the whole R_n", function()
    -- the whole R_n = (F^(n) - (n + 1) F_0^(n)) / n read from the graph,
    -- less its value at q^(n) = 0, against the printed part
    for _, c in ipairs{ ms.double_pendulum(false), ms.spherical_pendulum(), ms.charged_drag() } do
      local sys = c.sys
      for _, n in ipairs{ 2, 3, 5 } do
        local eq = show.equations(sys, n)
        local g, rd = eq.order.graph, eq.order.reader
        local whole = as_lua(formula.div(formula.sub(rd.poly(g.Fn), formula.mul(formula.const(n + 1), rd.poly(g.F0n))),
          formula.const(n)))
        local part = as_lua(eq.order.R())
        for _ = 1, 3 do
          local t, q, qd, qdd, higher = state(c, n + 1)
          local x = level(n, q, qd, qdd, higher)
          local at = whole(t, q, qd, qdd, {}, sys.params, higher)
          local saved = { table.unpack(x) }
          for i = 1, sys.k do x[i] = 0 end
          local at0 = whole(t, q, qd, qdd, {}, sys.params, higher)
          for i = 1, sys.k do x[i] = saved[i] end
          local got = part(t, q, qd, qdd, {}, sys.params, higher)
          assert(math.abs(got - (at - at0)) <= 1e-11 * (1 + math.abs(at) + math.abs(at0)),
            ("%s, n = %d: R_n's part %.15g, R_n - R_n(0) %.15g"):format(sys.name, n, got, at - at0))
        end
      end
    end
  end)

  it("R_1 keeps the velocities held in T_0 apart (the graph's frozen input): by hand for the spherical pendulum", function()
    local sys = spherical_pendulum()
    local text = sys:show{ n = 1, appell = true }
    assert.truthy(text:find("ph'_0", 1, true), text)
    local tex = sys:show{ n = 1, appell = true, tex = true }
    assert.truthy(tex:find("\\dot{\\varphi}_{0}^{2}", 1, true), tex)
    -- T = m l^2 (th'^2 + sin^2 th ph'^2) / 2; T_0 holds the velocities v:
    -- T' = m l^2 (th' th'' + sin th cos th th' ph'^2 + sin^2 th ph' ph''),
    -- T_0' = m l^2 sin th cos th th' v_ph^2, R_1 = T' - 2 T_0'
    local R1 = as_lua(show.equations(sys, 1).order.R())
    local m, l = sys.params.m, sys.params.l
    for _ = 1, 5 do
      local q, qd, qdd, v = { math.random() + 0.2, math.random() }, { math.random() - 0.5, math.random() - 0.5 },
        { math.random() - 0.5, math.random() - 0.5 }, { math.random() - 0.5, math.random() - 0.5 }
      local s, co = math.sin(q[1]), math.cos(q[1])
      local want = m * l ^ 2 * (qd[1] * qdd[1] + s * co * qd[1] * qd[2] ^ 2 + s * s * qd[2] * qdd[2])
        - 2 * m * l ^ 2 * s * co * qd[1] * v[2] ^ 2
      local got = R1(0, q, qd, qdd, {}, sys.params, {}, v)
      assert(math.abs(got - want) <= 1e-14 * (1 + math.abs(want)), ("R_1 %.17g, by hand %.17g"):format(got, want))
    end
  end)

  it("tex = true, mass, bias and reduced with n", function()
    local tex = pendulum():show{ n = 3, tex = true, appell = true }
    assert.truthy(tex:find("\\frac{\\partial T^{(3)}}{\\partial \\theta^{(3)}} &= 3 \\, l^{2} \\, m \\, \\ddot{\\theta}", 1, true), tex)
    assert.truthy(tex:find("R_{3} &= l^{2} \\, m \\, \\ddot{\\theta} \\, \\theta^{(3)}", 1, true), tex)
    -- every comment line is one (a title over two lines stays a comment)
    for line in tex:gmatch("[^\n]+") do assert.truthy(line:find("^%%") or line:find("^ ") or line:find("^\\"), line) end
    local depth = 0
    for ch in tex:gmatch("[{}]") do depth = depth + (ch == "{" and 1 or -1); assert(depth >= 0, tex) end
    assert.are.equal(0, depth)
    -- a sum of parameters that are all negative keeps its sign in front
    assert.truthy(double_pendulum():show{ n = 2 }:find("Q_th1       = -g l1 (m1 + m2) sin(th1)", 1, true))
    local text = double_pendulum():show{ n = 4, mass = true, bias = true }
    assert.truthy(text:find("M[th1, th2] = l1 l2 m2 cos(th1 - th2)", 1, true), text)
    assert.truthy(text:find("h[th2] = l2 m2 (-l1 sin(th1 - th2) th1'^2 + g sin(th2))", 1, true), text)
    local red = knife_edge():show{ n = 2, reduced = true }
    assert.truthy(red:find("x :  m cos(th) x'' + m sin(th) y'' = 0", 1, true), red)
  end)

  it("refuses an order that is not an integer from 1 to 100, and leaves the system's graph alone", function()
    local p = pendulum()
    for _, bad in ipairs{ 0, 2.5, 101, "3" } do
      h.checkerror("option 'n': an integer order from 1 to 100 expected", p.show, p, { n = bad })
    end
    h.checkerror("unknown option 'm' (did you mean 'n'?)", p.show, p, { m = 3 })
    -- F^(n) is built in a graph of its own: the system's recording keeps
    -- its layout, whose slots and frozen velocities are all it accepts
    local c = p.engine.recording
    local nodes = c:info().nodes
    p:show{ n = 9 }
    assert.are.equal(c:nslots(), p.engine.recording:nslots())
    h.checkerror("no such slot in the recording", c.slot, c, c:nslots(), 1)
    h.checkerror("no such coordinate", c.frozen, c, 2)
    assert(c:info().nodes - nodes < 20, "show{n = 9} built " .. (c:info().nodes - nodes) .. " nodes in the system's graph")
  end)
end)
