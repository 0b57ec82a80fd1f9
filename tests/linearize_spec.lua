-- linearize_spec.lua - sys:linearize (issue 12, first part: systems without
-- constraints): the state matrix against closed forms (the double
-- pendulum's M, K and eigenfrequencies, the inverted pendulum, a bead on a
-- hoop driven at a held rate below and above the critical rate and at its
-- off-axis equilibrium), and what it refuses.
local h = require "tests.helpers"
local nz = h.nz

local g, l, m = 9.81, 1.0, 1.0

local function double_pendulum()
  return nz.system{ name = "double pendulum", coords = { "a", "b" },
    T = function(t, q, qd)
      local a, b, ad, bd = q[1], q[2], qd[1], qd[2]
      return 0.5 * m * l ^ 2 * ad ^ 2 + 0.5 * m * (l ^ 2 * ad ^ 2 + l ^ 2 * bd ^ 2 + 2 * l ^ 2 * ad * bd * nz.cos(a - b))
    end,
    V = function(t, q) return -m * g * l * (2 * nz.cos(q[1]) + nz.cos(q[2])) end }
end

-- A bead on a hoop of radius 1 turned about its vertical diameter; ph' is
-- held (a motor), so ph is ignorable and left out of the state.
local hoop = nz.system{ name = "driven hoop", coords = { "th", "ph" },
  T = function(t, q, qd) return 0.5 * (qd[1] ^ 2 + nz.sin(q[1]) ^ 2 * qd[2] ^ 2) + 0.5 * qd[2] ^ 2 end,
  V = function(t, q) return -g * nz.cos(q[1]) end }

-- The angular frequencies (|im|, one per pair) and the growth rates.
local function spectrum(lin)
  local w, grow = {}, {}
  for _, e in ipairs(lin:eigenvalues()) do
    if e[2] > 0 then w[#w + 1] = e[2] end
    grow[#grow + 1] = e[1]
  end
  table.sort(w)
  return w, grow
end

describe("sys:linearize without constraints", function()
  it("the double pendulum: M, K and C in closed form, eigenfrequencies sqrt((g/l)(2 -+ sqrt 2))", function()
    local lin = double_pendulum():linearize{ q = { 0, 0 } }
    assert.are.same({ "a", "b", "a'", "b'" }, lin.state)
    -- M = m l^2 [2 1; 1 1], K = m g l [2 0; 0 1], C = 0 (at rest); the
    -- entries come from exact jets: rounding only (bound 1e-12)
    local Mw, Kw = { { 2, 1 }, { 1, 1 } }, { { 2 * g, 0 }, { 0, g } }
    for i = 1, 2 do
      for j = 1, 2 do
        assert.near(Mw[i][j], lin.M[i][j], 1e-12)
        assert.near(Kw[i][j], lin.K[i][j], 1e-12)
        assert.near(0, lin.C[i][j], 1e-12)
      end
    end
    local w, grow = spectrum(lin)
    assert.near(math.sqrt(g / l * (2 - math.sqrt(2))), w[1], 1e-12)
    assert.near(math.sqrt(g / l * (2 + math.sqrt(2))), w[2], 1e-12)
    for _, r in ipairs(grow) do assert(math.abs(r) <= 1e-12, ("growth rate %.3g of a conservative system"):format(r)) end
    assert.truthy(tostring(lin):find("neutral", 1, true))
    -- the mode shapes: b / a = sqrt 2 in phase (slow), -sqrt 2 (fast)
    local modes = lin:modes()
    table.sort(modes, function(x, y) return x.omega < y.omega end)
    local function ratio(md) return md.shape[2] / md.shape[1] * (math.abs(md.phase[2] - md.phase[1]) > 1.5 and -1 or 1) end
    assert.near(math.sqrt(2), ratio(modes[1]), 1e-10)
    assert.near(-math.sqrt(2), ratio(modes[2]), 1e-10)
  end)

  it("the inverted pendulum: one mode grows at sqrt(g/l)", function()
    local p = nz.system{ name = "pendulum", coords = { "th" },
      T = function(t, q, qd) return 0.5 * m * l ^ 2 * qd[1] ^ 2 end,
      V = function(t, q) return -m * g * l * nz.cos(q[1]) end }
    local _, grow = spectrum(p:linearize{ q = { math.pi } })
    table.sort(grow)
    assert.near(-math.sqrt(g / l), grow[1], 1e-12)
    assert.near(math.sqrt(g / l), grow[2], 1e-12)
    assert.truthy(tostring(p:linearize{ q = { math.pi } }):find("unstable", 1, true))
  end)

  it("a bead on a driven hoop: omega^2 = g - W^2 below the critical rate, a growing mode above, W^2 sin^2 th* off-axis", function()
    for _, W in ipairs{ 2, 3 } do          -- W^2 < g: the bottom is stable
      local w = spectrum(hoop:linearize{ q = { 0, 0 }, qd = { 0, W }, coords = { "th" }, hold = { "ph" } })
      assert.near(math.sqrt(g - W * W), w[1], 1e-12)
    end
    local W = 4                            -- W^2 > g: the bottom is unstable ...
    local lin = hoop:linearize{ q = { 0, 0 }, qd = { 0, W }, coords = { "th" }, hold = { "ph" } }
    assert.are.same({ "th", "th'" }, lin.state)
    local _, grow = spectrum(lin)
    table.sort(grow)
    assert.near(math.sqrt(W * W - g), grow[2], 1e-12)
    -- ... and the bead rests at cos th* = g / W^2, where it oscillates at W sin th*
    local ths = math.acos(g / (W * W))
    lin = hoop:linearize{ q = { ths, 0 }, qd = { 0, W }, coords = { 1 }, hold = { 2 } }
    assert(lin.residual <= 1e-12, ("th* is not an equilibrium: %.3g"):format(lin.residual))
    local w = spectrum(lin)
    assert.near(W * math.sin(ths), w[1], 1e-12)
  end)

  it("says what it refuses: constraints, a coordinate left out that appears, a speed neither kept nor held", function()
    local cs = require "tests.constraint_systems"
    local pend = cs.cartesian_pendulum().sys
    h.checkerror("systems with constraints are not handled yet", pend.linearize, pend, { q = { 0, -1 } })
    local dp = double_pendulum()
    h.checkerror("coordinate 'b' is left out but appears in the equation of a''", dp.linearize, dp,
      { q = { 0, 0 }, coords = { "a" } })
    h.checkerror("the speed of 'ph' is left out but appears", hoop.linearize, hoop,
      { q = { 0.3, 0 }, qd = { 0, 2 }, coords = { "th" } })
    h.checkerror("'x' is not a coordinate", dp.linearize, dp, { q = { 0, 0 }, coords = { "x" } })
  end)

  it("sys:equilibrium: Newton from a guess to the hoop's off-axis equilibrium and to the double pendulum's inverted one", function()
    local W = 4
    local q, rep = hoop:equilibrium{ q = { 0.8, 0 }, qd = { 0, W }, coords = { "th" } }
    -- cos th* = g / W^2; Newton stops at kept accelerations <= 1e-12
    -- (g-sized terms): th within ~1e-13 of it
    assert.near(math.acos(g / (W * W)), q[1], 1e-12)
    assert(rep.residual <= 1e-12 and rep.iterations >= 1)
    local dp = double_pendulum()
    q = dp:equilibrium{ q = { 3.0, -3.2 } }
    assert.near(math.pi, q[1], 1e-12)
    assert.near(-math.pi, q[2], 1e-12)
    -- the inverted double pendulum is unstable: two modes grow
    local grow = 0
    for _, e in ipairs(dp:linearize{ q = q }:eigenvalues()) do if e[1] > 1e-9 then grow = grow + 1 end end
    assert.are.equal(2, grow)
    h.checkerror("sys:equilibrium 'driven hoop': the accelerations do not depend on the kept coordinates",
      hoop.equilibrium, hoop, { q = { 0.8, 0 }, qd = { 0, W } })
  end)
end)
