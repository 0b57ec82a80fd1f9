-- linearize_spec.lua - sys:linearize (systems without
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

  it("says what it refuses: a coordinate left out that appears, a speed neither kept nor held", function()
    local dp = double_pendulum()
    h.checkerror("coordinate 'b' is left out but appears in the equation of a''", dp.linearize, dp,
      { q = { 0, 0 }, coords = { "a" } })
    h.checkerror("the speed of 'ph' is left out but appears", hoop.linearize, hoop,
      { q = { 0.3, 0 }, qd = { 0, 2 }, coords = { "th" } })
    h.checkerror("'x' is not a coordinate", dp.linearize, dp, { q = { 0, 0 }, coords = { "x" } })
    -- a misspelled option was dropped: the linearization kept every
    -- coordinate and speed, and said nothing
    h.checkerror("sys:linearize 'driven hoop': unknown option 'held' (did you mean 'hold'?)", hoop.linearize, hoop,
      { q = { 0, 0 }, qd = { 0, 2 }, coords = { "th" }, held = { "ph" } })
    h.checkerror("sys:equilibrium 'driven hoop': unknown option 'hodl' (did you mean 'hold'?)", hoop.equilibrium, hoop,
      { q = { 1, 0 }, qd = { 0, 4 }, coords = { "th" }, hodl = { "ph" } })
  end)
  it("a singular M is reported as accel reports it: the eigenvalues of M at that state", function()
    -- The spherical pendulum at its pole: M = diag(1, sin^2 th) is singular.
    -- linearize's path (the exact Jacobian) once filled no diagnosis and said
    -- "eigenvalues from 0 to 0" where accel said "from 0 to 1".
    local sp = nz.system{ name = "sph", coords = { "th", "ph" },
      T = function(t, q, qd) return 0.5 * (qd[1] ^ 2 + nz.sin(q[1]) ^ 2 * qd[2] ^ 2) end,
      V = function(t, q) return g * nz.cos(q[1]) end }
    local Mm = sp:mass(0, { 0, 0 })
    local mid, half = 0.5 * (Mm[1][1] + Mm[2][2]), math.sqrt(0.25 * (Mm[1][1] - Mm[2][2]) ^ 2 + Mm[1][2] ^ 2)
    local want = ("(eigenvalues from %.3g to %.3g, condition number infinite)"):format(mid - half, mid + half)
    local ok, err = pcall(sp.linearize, sp, { q = { 0, 0 }, qd = { 0, 0 } })
    assert.is_false(ok)
    assert.truthy(err:find("system 'sph': the mass matrix M = d2T/dqd2 is not positive definite at t = 0, q = {0, 0}", 1, true), err)
    assert.truthy(err:find(want, 1, true), err .. "\nwanted " .. want)
    -- the same words as accel's at that state
    local _, aerr = pcall(sp.accel, sp, 0, { 0, 0 }, { 0, 0 })
    assert.are.equal(aerr:match("%(eigenvalues.-%)"), err:match("%(eigenvalues.-%)"))
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

  it("a degenerate equilibrium (V = x^4) keeps x: A = [0 1; 0 0], a Jordan block said as such, not an ignorable x", function()
    -- x'' = -4 x^3: dx''/dx = 0 at x = 0 only; dropping x as ignorable (the
    -- first version did) left one "neutral" mode and hid the double zero
    local quartic = nz.system{ name = "quartic", coords = { "x" }, T = function(t, q, qd) return 0.5 * qd[1] ^ 2 end,
      V = function(t, q) return q[1] ^ 4 end }
    local lin = quartic:linearize{ q = { 0 }, qd = { 0 } }
    assert.are.same({ "x", "x'" }, lin.state)
    assert.are.same({ { 0, 1 }, { 0, 0 } }, lin.A)
    assert.truthy(tostring(lin):find("the eigenvalue 0 is 2-fold with 1 eigenvector (a Jordan block)", 1, true), tostring(lin))
    -- a coordinate absent from the equations everywhere is still dropped
    local free = nz.system{ name = "free x", coords = { "x", "y" }, T = function(t, q, qd) return 0.5 * (qd[1] ^ 2 + qd[2] ^ 2) end,
      V = function(t, q) return 0.5 * q[2] ^ 2 end }
    local lf = free:linearize{ q = { 0.3, 0 }, qd = { 0, 0 } }
    assert.are.same({ "y", "x'", "y'" }, lf.state)
    assert.is_nil(tostring(lf):find("Jordan", 1, true))
  end)
end)

-- ------------------------------------------------------------------ --
-- With constraints

-- A pendulum of length L in Cartesian coordinates (x, y), y up: one
-- holonomic constraint x^2 + y^2 = L^2.
local L = 1.3
local function cartesian_pendulum()
  return nz.system{ name = "cartesian pendulum", coords = { "x", "y" },
    T = function(t, q, qd) return 0.5 * m * (qd[1] ^ 2 + qd[2] ^ 2) end,
    V = function(t, q) return m * g * q[2] end,
    constraints = { function(t, q) return q[1] ^ 2 + q[2] ^ 2 - L * L end } }
end

-- A thin disk of radius a rolling without slipping on a horizontal plane
-- and free to lean: (x, y) the contact point, psi the heading, th the lean
-- from the vertical, phi the spin about the axle.  With the lean frame
-- l = Rz(psi) Rx(th): the angular velocity has components th', phi' + psi'
-- sin th, psi' cos th along l1 (heading), l2 (axle), l3 (up the disk); the
-- centre is G = (x, y, 0) + a l3; the contact point of the disk moves at
-- (x', y', 0) - a phi' l1 (derived in the comment of examples: the terms in
-- psi' and th' cancel), so rolling is x' = a phi' cos psi, y' = a phi' sin psi.
local ma, a = 1.5, 0.4
local A_d, C_d = ma * a * a / 4, ma * a * a / 2      -- about a diameter, about the axle
local function leaning_disk()
  return nz.system{ name = "leaning disk", coords = { "x", "y", "psi", "th", "phi" },
    T = function(t, q, qd)
      local psi, th = q[3], q[4]
      local xd, yd, psid, thd, phid = qd[1], qd[2], qd[3], qd[4], qd[5]
      local s, c, sp, cp = nz.sin(th), nz.cos(th), nz.sin(psi), nz.cos(psi)
      -- G = (x + a s sp, y - a s cp, a c)
      local gx = xd + a * (c * thd * sp + s * cp * psid)
      local gy = yd - a * (c * thd * cp - s * sp * psid)
      local gz = -a * s * thd
      local w1, w2, w3 = thd, phid + psid * s, psid * c
      return 0.5 * ma * (gx ^ 2 + gy ^ 2 + gz ^ 2) + 0.5 * (A_d * (w1 ^ 2 + w3 ^ 2) + C_d * w2 ^ 2)
    end,
    V = function(t, q) return ma * g * a * nz.cos(q[4]) end,
    constraints = { function(t, q, qd) return qd[1] - a * qd[5] * nz.cos(q[3]) end,
                    function(t, q, qd) return qd[2] - a * qd[5] * nz.sin(q[3]) end } }
end

-- A heavy symmetric top on a fixed pivot in Cardan angles (no gimbal lock
-- upright): R = Rx(al) Ry(be) Rz(ga), the body's angular velocity has
-- (al' cos be, be') across the axis (up to a turn by ga) and ga' + al' sin be
-- along it; the centre of mass at l on the axis: height l cos al cos be.
local At, Ct, mt, lt = 0.02, 0.008, 0.5, 0.04        -- A about the pivot across the axis
local function top()
  return nz.system{ name = "sleeping top", coords = { "al", "be", "ga" },
    T = function(t, q, qd)
      local be = q[2]
      return 0.5 * At * ((qd[1] * nz.cos(be)) ^ 2 + qd[2] ^ 2) + 0.5 * Ct * (qd[3] + qd[1] * nz.sin(be)) ^ 2
    end,
    V = function(t, q) return mt * g * lt * nz.cos(q[1]) * nz.cos(q[2]) end }
end

describe("sys:linearize with constraints", function()
  it("the Cartesian pendulum: y dependent (chosen, Newton), x' kept; +-i sqrt(g/L), M = m, K = m g / L", function()
    local p = cartesian_pendulum()
    -- start off the constraint (y = -1): y is solved from it
    local lin = p:linearize{ q = { 0, -1 }, coords = { "x" } }
    assert.are.same({ "x", "x'" }, lin.state)
    assert.are.same({ 2 }, lin.dependent)
    assert.are.same({ 2 }, lin.dependent_speeds)
    assert.near(-L, lin.q[2], 1e-15)
    assert(lin.position_newton[1] >= 1)
    -- at the bottom y' = -x x'/y = 0 along x': the reduced mass is m, and
    -- x'' = -(g/L) x: exact jets, rounding only (bound 1e-13)
    assert.near(m, lin.M[1][1], 1e-13)
    assert.near(m * g / L, lin.K[1][1], 1e-13)
    assert.near(0, lin.C[1][1], 1e-13)
    local w = spectrum(lin)
    assert.near(math.sqrt(g / L), w[1], 1e-13)
    -- named: dependent = {"x"} cannot work at the bottom (x does not move the constraint there)
    h.checkerror("do not fix the dependent coordinates {x} here", p.linearize, p,
      { q = { 0, -L }, coords = { "y" }, dependent = { "x" } })
    -- off the bottom at 0.5 rad: not an equilibrium, said in the printout
    local lin2 = p:linearize{ q = { L * math.sin(0.5), -L * math.cos(0.5) }, coords = { "x" } }
    assert(lin2.residual > 1, "x'' = -g sin cos there")
    assert.truthy(tostring(lin2):find("not an equilibrium", 1, true))
  end)

  it("sys:equilibrium with a holonomic constraint: the pendulum's rest from x = 0.3, y solved at every step", function()
    local p = cartesian_pendulum()
    local q, rep = p:equilibrium{ q = { 0.3, -1.2 }, coords = { "x" } }
    -- x'' = -(g/L^2) x y... vanishes at x = 0 (y = -L); Newton converges
    -- quadratically to a kept acceleration <= 1e-12 (g-sized terms)
    assert.near(0, q[1], 1e-12)
    assert.near(-L, q[2], 1e-14)
    assert(rep.residual <= 1e-12 and rep.iterations >= 2)
  end)

  it("the leaning disk rolling upright: omega^2 = ((C + m a^2) C W^2 / A - m g a) / (A + m a^2), stable above W^2 = g / (3a)", function()
    local disk = leaning_disk()
    local function at(W)
      return { q = { 0, 0, 0, 0, 0 }, qd = { 0, 0, 0, 0, W }, coords = { "th" }, speeds = { "th", "psi" }, hold = { "phi" } }
    end
    for _, W in ipairs{ 2, 5, 9 } do
      local lin = disk:linearize(at(W))
      assert.are.same({ "th", "th'", "psi'" }, lin.state)
      assert.are.same({ 1, 2 }, lin.dependent_speeds)
      assert.near(a * W, lin.qd[1], 1e-14)    -- x' solved from rolling
      -- the linearized equations (derived in the header of this block):
      -- (A + m a^2) th'' = (C + m a^2) W psi' + m g a th, A psi'' = -C W th'
      local k2 = ((C_d + ma * a * a) * C_d * W * W / A_d - ma * g * a) / (A_d + ma * a * a)
      local ev = lin:eigenvalues()
      table.sort(ev, function(u, v) return u[1] + u[2] < v[1] + v[2] end)
      local want = k2 > 0 and { { 0, -math.sqrt(k2) }, { 0, 0 }, { 0, math.sqrt(k2) } }
        or { { -math.sqrt(-k2), 0 }, { 0, 0 }, { math.sqrt(-k2), 0 } }
      -- exact jets: rounding only, bound 1e-12 of rates ~10 1/s
      for i = 1, 3 do
        assert(math.abs(ev[i][1] - want[i][1]) + math.abs(ev[i][2] - want[i][2]) <= 1e-12,
          ("W = %g: eigenvalue %d is %.15g%+.15gi, want %.15g%+.15gi"):format(W, i, ev[i][1], ev[i][2], want[i][1], want[i][2]))
      end
    end
    -- the stability limit of the thin disk: W^2 = m g a A / (C (C + m a^2)) = g / (3a)
    local values = {}
    for i = 1, 12 do values[i] = i end
    local sw = disk:eigen_sweep{ parameter = "W", values = values, tol = 1e-10, at = at }
    assert.are.equal(1, #sw.crossings)
    local c = sw.crossings[1]
    assert.are.same({ "unstable", "neutral" }, { c.from, c.to })
    -- bisection to 1e-10 on the status; below the limit the growth rate is
    -- the square root of a quantity linear in W (the threshold of
    -- "unstable", ~2e-7, moves the limit by ~1e-14), and at the limit three
    -- eigenvalues meet at 0, where the rounding zeros of A are made exact
    -- (linearize.lua): measured 2.3e-12 off; bound 2e-10
    assert(math.abs(c.value - math.sqrt(g / (3 * a))) <= 2e-10, ("limit %.15g, want %.15g"):format(c.value, math.sqrt(g / (3 * a))))
  end)

  it("the sleeping top: M = A I, C = [0 Cn; -Cn 0], K = -m g l I; stable above n = 2 sqrt(A m g l) / C", function()
    local tp = top()
    local function at(n) return { q = { 0, 0, 0 }, qd = { 0, 0, n }, coords = { "al", "be" }, hold = { "ga" } } end
    local n = 60
    local lin = tp:linearize(at(n))
    assert.are.same({ "al", "be", "al'", "be'" }, lin.state)
    local Mw = { { At, 0 }, { 0, At } }
    local Cw = { { 0, Ct * n }, { -Ct * n, 0 } }
    local Kw = { { -mt * g * lt, 0 }, { 0, -mt * g * lt } }
    for i = 1, 2 do
      for j = 1, 2 do
        assert.near(Mw[i][j], lin.M[i][j], 1e-15)
        assert.near(Cw[i][j], lin.C[i][j], 1e-14)
        assert.near(Kw[i][j], lin.K[i][j], 1e-14)
      end
    end
    -- frequencies w = (C n +- sqrt(C^2 n^2 - 4 A m g l)) / (2 A)
    local disc = math.sqrt((Ct * n) ^ 2 - 4 * At * mt * g * lt)
    local w = spectrum(lin)
    assert.near((Ct * n - disc) / (2 * At), w[1], 1e-11)
    assert.near((Ct * n + disc) / (2 * At), w[2], 1e-11)
    local values = {}
    for i = 0, 10 do values[#values + 1] = 10 * i end
    local sw = tp:eigen_sweep{ parameter = "n", values = values, tol = 1e-9, at = at }
    assert.are.equal(1, #sw.crossings)
    assert.are.same({ "unstable", "neutral", "oscillatory" }, { sw.crossings[1].from, sw.crossings[1].to, sw.crossings[1].kind })
    -- two modes meet on the imaginary axis (a Krein collision): the growth
    -- rate below is ~sqrt(n_c - n), so the status threshold moves the limit
    -- by ~1e-13 and bisection to 1e-9 decides: measured 5.4e-11; bound 2e-9
    local nc = 2 * math.sqrt(At * mt * g * lt) / Ct
    assert(math.abs(sw.crossings[1].value - nc) <= 2e-9, ("sleeping limit %.12g, want %.12g"):format(sw.crossings[1].value, nc))
  end)

  it("print(lin) and print(sw) head the stability column, show rounding as 0 by one rule, and explain a@p", function()
    local tp = top()
    local function at(n) return { q = { 0, 0, 0 }, qd = { 0, 0, n }, coords = { "al", "be" }, hold = { "ga" } } end
    local lin = tp:linearize(at(60))
    local text = tostring(lin)
    assert.truthy(text:find("   stability   shape (al, be)\n", 1, true), text)
    -- the sleeping top's modes are circles: al and be of equal amplitude a quarter period apart
    assert.truthy(text:find("0 %+%- 23%.584i%s+23%.584%s.-neutral%s+1@1%.6, 1\n"), text)
    assert.truthy(text:find("a@p: amplitude a, ahead of the largest by p radians", 1, true), text)
    for line in text:match("\n(  shape: .*)$"):gmatch("[^\n]+") do
      assert(#line <= 80, ("a line of notes wider than 80 columns: %s"):format(line))
    end
    -- a conservative gyroscopic system: every eigenvalue on the imaginary axis, at
    -- w = (C n +- sqrt(C^2 n^2 - 4 A m g l)) / (2 A) (closed form), and shown so: 0 +- wi
    local sw = tp:eigen_sweep{ parameter = "n", values = { 0, 20, 40 }, at = at }
    local stext = tostring(sw)
    assert.truthy(stext:find("\n  n%s+eigenvalues   stability\n"), stext)
    for _, n in ipairs{ 20, 40 } do
      local disc = math.sqrt((Ct * n) ^ 2 - 4 * At * mt * g * lt)
      local row = ("\n  %d%%s+0 %%+%%- %s, 0 %%+%%- %si%%s+neutral\n"):format(n,
        ("%.6gi"):format((Ct * n + disc) / (2 * At)):gsub("%.", "%%."), ("%.6g"):format((Ct * n - disc) / (2 * At)):gsub("%.", "%%."))
      assert.truthy(stext:find(row), ("n = %d: no row %q in\n%s"):format(n, row, stext))
    end
    assert.falsy(stext:find("e%-1%d"), stext)      -- no rounding noise (1e-15 +- ...)
  end)

  it("says what it refuses with constraints: too few speeds left to solve, a kept speed held, a dependent coordinate kept", function()
    local disk = leaning_disk()
    h.checkerror("the speed of 'psi' is left out but appears in the equation of th''", disk.linearize, disk,
      { q = { 0, 0, 0, 0, 0 }, qd = { 0, 0, 0, 0, 5 }, coords = { "th" }, hold = { "phi" } })
    h.checkerror("velocity constraints cannot be solved for the speeds left free", disk.linearize, disk,
      { q = { 0, 0, 0, 0, 0 }, qd = { 0, 0, 0, 0, 5 }, coords = { "th" }, speeds = { "x", "th", "psi" }, hold = { "phi" } })
    -- two dependent velocity constraints: the speeds are listed as they were tried (once "(, x, y)")
    local dup = nz.system{ name = "dup", coords = { "x", "y" }, T = function(t, q, qd) return 0.5 * (qd[1] ^ 2 + qd[2] ^ 2) end,
      V = function(t, q) return g * q[2] end,
      constraints = { function(t, q, qd) return qd[1] + qd[2] end, function(t, q, qd) return 2 * (qd[1] + qd[2]) end } }
    h.checkerror("the 2 velocity constraints cannot be solved for the speeds left free (x, y) here", dup.linearize, dup,
      { q = { 0, -1 }, qd = { 1, -1 } })
    local p = cartesian_pendulum()
    h.checkerror("'y' is both kept (coords) and dependent", p.linearize, p,
      { q = { 0, -L }, coords = { "y" }, dependent = { "y" } })
    -- psi is ignorable (the plane is the same in every direction), th is not
    disk:linearize{ q = { 0, 0, 0, 0.3, 0 }, qd = { 0, 0, 0, 0, 5 }, coords = { "th" }, speeds = { "th", "psi" }, hold = { "phi" } }
    h.checkerror("coordinate 'th' is left out but appears in the equation of th''", disk.linearize, disk,
      { q = { 0, 0, 0, 0.3, 0 }, qd = { 0, 0, 0, 0, 5 }, coords = {}, speeds = { "th", "psi" }, hold = { "phi" } })
  end)

  it("sys:eigen_sweep on the driven hoop: the bottom stops being stable at the critical rate W = sqrt(g)", function()
    local values = {}
    for i = 0, 12 do values[#values + 1] = i / 2 end
    local sw = hoop:eigen_sweep{ parameter = "W", values = values, tol = 1e-12,
      at = function(W) return { q = { 0, 0 }, qd = { 0, W }, coords = { "th" }, hold = { "ph" } } end }
    assert.are.equal(1, #sw.crossings)
    local c = sw.crossings[1]
    assert.are.same({ "neutral", "unstable", "real" }, { c.from, c.to, c.kind })
    -- +-sqrt(g - W^2) passes through 0: growth ~sqrt(2 sqrt(g) (W - W_c)), so
    -- the status threshold (~1e-7) moves the limit by ~1e-15; bisection to
    -- 1e-12: measured 2.6e-13 off
    assert(math.abs(c.value - math.sqrt(g)) <= 2e-12, ("critical rate %.15g, want %.15g"):format(c.value, math.sqrt(g)))
    for _, row in ipairs(sw.rows) do
      assert.are.equal(row.value < math.sqrt(g) and "neutral" or "unstable", row.status, "W = " .. row.value)
    end
  end)

  it("sys:eigen_sweep refuses bad options with the reason", function()
    local tp = top()
    h.checkerror("values must increase", tp.eigen_sweep, tp, { values = { 1, 1 }, at = function() return {} end })
    h.checkerror("unknown option 'valus'", tp.eigen_sweep, tp, { valus = { 1, 2 } })
    h.checkerror("at(1) must return the options of sys:linearize", tp.eigen_sweep, tp,
      { values = { 1, 2 }, at = function() return 3 end })
    h.checkerror("at(1) returned unknown option 'bogus'", tp.eigen_sweep, tp,
      { values = { 1, 2 }, at = function() return { q = { 0, 0, 0 }, bogus = 1 } end })
  end)

  it("sys:eigen_sweep through the axis: the damped oscillator's one change at c = 0, and its params restored", function()
    -- m x'' + c x' + k x = 0: lambda = -c/2m +- i sqrt(k/m - c^2/4m^2), so
    -- the only change is unstable -> stable at c = 0, at 2 rad/s.  A row at
    -- c = 0 itself is neutral; the first version reported two changes, at
    -- the edges of the neutral band (c = -+2e-7), each "located to 2e-10".
    local osc = nz.system{ name = "damped", coords = { "x" }, params = { m = 2, k = 8, c = 0.4 },
      T = function(t, q, qd, p) return 0.5 * p.m * qd[1] ^ 2 end,
      V = function(t, q, p) return 0.5 * p.k * q[1] ^ 2 end,
      Q = function(t, q, qd, p) return { -p.c * qd[1] } end }
    local values = {}
    for i = 0, 10 do values[#values + 1] = -1 + 0.2 * i end
    local sw = osc:eigen_sweep{ parameter = "c", values = values, tol = 1e-12,
      at = function(c) osc.params.c = c; return { q = { 0 }, qd = { 0 } } end }
    assert.are.equal("neutral", sw.rows[6].status)
    assert.are.equal(1, #sw.crossings)
    local c = sw.crossings[1]
    assert.are.same({ "unstable", "stable", "oscillatory" }, { c.from, c.to, c.kind })
    assert(math.abs(c.value) <= 1e-11, ("c = %.3g, want 0"):format(c.value))
    assert(math.abs(c.frequency - 2) <= 1e-9, ("frequency %.15g, want 2"):format(c.frequency))
    assert.are.equal(0.4, osc.params.c)
    -- and restored when at() fails half-way
    assert.is_false(pcall(osc.eigen_sweep, osc, { values = { 0, 1 },
      at = function(v) osc.params.c = v; if v > 0 then error("stop") end; return { q = { 0 } } end }))
    assert.are.equal(0.4, osc.params.c)
  end)
end)
