-- examples_spec.lua - every example runs (exit 0) and prints its key figure
-- within bounds: the examples are part of the documentation, so they must
-- never go stale.  Where an example only reports on itself (a residual, a
-- violation monitor), the test captures its trajectories and checks the
-- motion against a closed form or a hand derivation written here.
local h = require "tests.helpers"

-- The wrapper run(name, true) puts around an example: every trajectory that
-- sys:simulate returns is kept and, after the example's own output, printed
-- as a Lua chunk, so that a test can check the motion itself against a hand
-- derivation instead of the figures the example prints about itself.
local CAPTURE = [[
local sim = require "nz.motion.simulate"
local simulate, runs = sim.simulate, {}
sim.simulate = function(...) local tr = simulate(...); runs[#runs + 1] = tr; return tr end
dofile(...)
local function list(rows)
  local out = {}
  for i, row in ipairs(rows) do
    if type(row) == "table" then
      local r = {}
      for j, v in ipairs(row) do r[j] = ("%.17g"):format(v) end
      out[i] = "{" .. table.concat(r, ",") .. "}"
    else
      out[i] = ("%.17g"):format(row)
    end
  end
  return "{" .. table.concat(out, ",") .. "}"
end
io.write("\n--trajectories--\nreturn {")
for _, tr in ipairs(runs) do
  io.write("{t=", list(tr.t), ",q=", list(tr.q), ",qd=", list(tr.qd), ",qdd=", list(tr.qdd), ",lambda=", list(tr.lambda), "},")
end
io.write("}\n")
]]

-- run(name): the example's output.  run(name, true): its output and the
-- list of the trajectories it computed.
local function run(name, capture)
  local cmd = h.nzlua .. " examples/" .. name
  local wrapper
  if capture then
    wrapper = os.tmpname()
    local f = assert(io.open(wrapper, "w"))
    f:write(CAPTURE)
    f:close()
    cmd = ("%s %s examples/%s"):format(h.nzlua, wrapper, name)
  end
  local code, out, err = h.run(cmd)
  if wrapper then os.remove(wrapper) end
  assert(code == 0, ("examples/%s exited with %d:\n%s"):format(name, code, err))
  if not capture then return out end
  local text, chunk = out:match("^(.*)\n%-%-trajectories%-%-\n(.*)$")
  assert(chunk, "no trajectories captured from examples/" .. name)
  return text, assert(load(chunk))()
end

local function max_over(tr, f)
  local worst = 0
  for i = 1, #tr.t do worst = math.max(worst, math.abs(f(tr.t[i], tr.q[i], tr.qd[i], tr.qdd[i], tr.lambda[i]))) end
  return worst
end

local function number_after(text, label)
  local v = text:match(label:gsub("%p", "%%%0") .. "%s*([%-%d%.e+]+)")
  assert(v, ("no number after %q in:\n%s"):format(label, text))
  return tonumber(v)
end

local function rule(out, n)
  assert.truthy(out:find(("Dolapchiev's rule: n = %d"):format(n), 1, true), out)
  assert.truthy(out:find("residual of order", 1, true) and out:find("cost:", 1, true), out)
end

describe("examples", function()
  it("demo.lua: the pendulum's acceleration matches -(g/l) sin th", function()
    local out = run("demo.lua")
    local a = number_after(out, "th'' =")
    assert(math.abs(a - (-9.81 / 1.3 * math.sin(0.7))) < 1e-12, out)
    -- At th'' = 0 the residual of every order is Lagrange's, m l^2 th'' +
    -- m g l sin th, that is m g l sin 0.7 (docs/theory.md §3: all orders agree).
    local want = 2.0 * 9.81 * 1.3 * math.sin(0.7)
    for _, n in ipairs{ 1, 2, 3, 12 } do
      local r = number_after(out, ("n = %2d:"):format(n))
      assert(math.abs(r - want) <= 1e-13 * want, ("n = %d: residual %.17g, m g l sin 0.7 = %.17g"):format(n, r, want))
    end
    assert(math.abs(number_after(out, "period: simulated") - number_after(out, "from the elliptic integral")) < 1e-8, out)
  end)
  it("simple_pendulum.lua: the simulated period is the elliptic integral's", function()
    local out = run("simple_pendulum.lua")
    rule(out, 1)
    assert(math.abs(number_after(out, "period: simulated") - number_after(out, "elliptic integral")) < 1e-9, out)
  end)
  it("double_pendulum.lua: the accelerations along the motion are the hand-derived ones; every form agrees", function()
    local out, runs = run("double_pendulum.lua", true)
    local n = 0
    for v in out:gmatch("max |residual| = ([%d%.e+%-]+)") do n = n + 1; assert(tonumber(v) < 1e-12, out) end
    assert.are.equal(7, n)
    assert(number_after(out, "energy T + V: drift up to") < 1e-8, out)
    -- By hand (l1 = 1, l2 = 0.7, m1 = 2, m2 = 1, g = 9.81), d = a - b:
    -- (m1+m2) l1^2 a'' + m2 l1 l2 cos d b'' = -m2 l1 l2 sin d b'^2 - (m1+m2) g l1 sin a
    -- m2 l1 l2 cos d a'' + m2 l2^2 b''     =  m2 l1 l2 sin d a'^2 - m2 g l2 sin b
    local l1, l2, m1, m2, g = 1.0, 0.7, 2.0, 1.0, 9.81
    local function hand(q, qd)
      local d = q[1] - q[2]
      local A, B, C = (m1 + m2) * l1 * l1, m2 * l1 * l2 * math.cos(d), m2 * l2 * l2
      local e = -m2 * l1 * l2 * math.sin(d) * qd[2] ^ 2 - (m1 + m2) * g * l1 * math.sin(q[1])
      local f = m2 * l1 * l2 * math.sin(d) * qd[1] ^ 2 - m2 * g * l2 * math.sin(q[2])
      local det = A * C - B * B
      return (e * C - B * f) / det, (A * f - B * e) / det
    end
    local a1, b1 = hand({ 0.7, -0.4 }, { 0.3, 1.1 })
    assert(math.abs(number_after(out, "a'' =") - a1) <= 1e-11 and math.abs(number_after(out, "b'' =") - b1) <= 1e-11, out)
    -- Along the whole simulated motion (201 points), the recorded q'' are
    -- the hand formula's at the recorded states, to rounding of |q''| ~ 10:
    -- measured 2.2e-13, bound 1e-12.
    local tr = runs[1]
    assert(#tr.t > 100, "no motion captured")
    local worst = max_over(tr, function(_, q, qd, qdd)
      local a, b = hand(q, qd)
      return math.max(math.abs(qdd[1] - a), math.abs(qdd[2] - b))
    end)
    assert(worst <= 1e-12, ("q'' along the motion off the hand derivation by %.3g"):format(worst))
  end)
  it("spherical_pendulum.lua: energy and the vertical momentum are conserved", function()
    local out = run("spherical_pendulum.lua")
    rule(out, 1)
    assert(number_after(out, "momentum about the vertical: drift") < 1e-8, out)
    assert(number_after(out, "energy T + V: drift up to") < 1e-8, out)
  end)
  it("bead_hoop.lua: Jacobi's integral is conserved, T + V is not, T + V - work is", function()
    local out = run("bead_hoop.lua")
    assert(number_after(out, "T2 - T0 + V: drift") < 1e-9, out)
    assert(number_after(out, "T + V: changes by") > 0.1, out)
    assert(number_after(out, "T + V - work: drift") < 1e-9, out)
  end)
  it("kepler.lua: the period from periapsis passages", function()
    local out = run("kepler.lua")
    assert(math.abs(number_after(out, "period: simulated") - 2 * math.pi) < 1e-9, out)
  end)
  it("bicycle.lua: the linearized Whipple bicycle's matrices, Table 2 and its weave and capsize speeds are the paper's", function()
    local out = run("bicycle.lua")
    -- M, C1, K0, K2 against the published 14 digits (measured 2.6e-13 at worst, K0 of size 81)
    local n = 0
    for d in out:gmatch("largest difference (%S+)") do
      assert(tonumber(d) <= 1e-12, out)
      n = n + 1
    end
    assert(n == 4, out)
    -- the table: eleven speeds, stable between the weave and capsize speeds only
    local rows = 0
    for line in out:gmatch("[^\n]+") do
      local v, status = line:match("^%s*(%d+)%.00%s.*%s(%a+)$")
      if v then
        rows = rows + 1
        assert(status == ((tonumber(v) == 5 or tonumber(v) == 6) and "stable" or "unstable"), line)
      end
    end
    assert(rows == 11, out)
    assert(math.abs(number_after(out, "weave speed") - 4.29238253634111) < 1e-12, out)
    assert(math.abs(number_after(out, "capsize speed") - 6.02426201538837) < 1e-12, out)
    assert(number_after(out, "constraint violation: max") < 1e-9, out)
  end)
  it("planet_path.lua: the path without time is the conic, and the time along it gives the period", function()
    local out = run("planet_path.lua")
    assert.truthy(out:find("H = T + V is a first integral", 1, true), out)
    assert(number_after(out, "largest difference") < 1e-11, out)
    local quad, law = out:match("integrated along the path (%S+), Kepler's third law 2 pi sqrt%(a%^3/mu%) (%S+)")
    assert(quad and math.abs(tonumber(quad) - tonumber(law)) < 1e-12, out)
    local t1, t2 = out:match("time to phi = pi/2: (%S+), Kepler's equation E %- e sin E: (%S+)")
    assert(t1 and math.abs(tonumber(t1:sub(1, -2)) - tonumber(t2)) < 1e-12, out)
  end)
  it("henon_section.lua: regular orbits on curves, a chaotic one filling a region", function()
    local out = run("henon_section.lua")
    local regular, chaotic = 0, 0
    for cells, kind in out:gmatch("%s(%d+)%s+(%a+)\n") do
      if kind == "regular" then regular = regular + 1 elseif kind == "chaotic" then chaotic = chaotic + 1 end
      assert(tonumber(cells) > 0)
    end
    assert(regular >= 3 and chaotic >= 1, out)
  end)
  it("heavy_top.lua: the spin about the axis is conserved #slow", function()
    local out = run("heavy_top.lua")
    rule(out, 1)
    assert(number_after(out, "drift") < 1e-8, out)
  end)
  it("chaplygin_sleigh.lua: n = 1, three ways give the same th'', and the motion is the closed form's", function()
    local out, runs = run("chaplygin_sleigh.lua", true)
    assert.truthy(out:find("Dolapchiev's rule: n = 1", 1, true), out)
    local a = tonumber(out:match("multipliers%): [%-%d%.]+ [%-%d%.]+ ([%-%d%.]+)"))
    local b = tonumber(out:match("elimination%): [%-%d%.]+ [%-%d%.]+ ([%-%d%.]+)"))
    local c = number_after(out, "(I + m a^2) =")
    assert(math.abs(a - c) < 1e-11 and math.abs(b - c) < 1e-11, out)
    -- Closed form: with J = I + m a^2 the energy m u^2 + J w^2 = m U^2 is
    -- kept, and u' = a w^2 = (a m / J)(U^2 - u^2) gives u = U tanh(k t + c),
    -- k = a m U / J, and w = sign(w0) sqrt(m / J) U sech(k t + c),
    -- c = atanh(u0 / U): the rotation dies out like 2 sqrt(m/J) U exp(-k t).
    local m, I, a, th0, u0, w0 = 2.0, 0.3, 0.4, 0.3, 1.2, 0.7
    local J = I + m * a * a
    local U = math.sqrt(u0 * u0 + J * w0 * w0 / m)
    local k, c = a * m * U / J, 0.5 * math.log((U + u0) / (U - u0))
    local tr = runs[1]
    assert(#tr.t > 100, "no motion captured")
    -- rtol 1e-10 over 20 s, yet measured 3.7e-14 at most (the motion
    -- is attracted to w = 0, so errors decay); bound 3e-13.
    local worst = max_over(tr, function(t, q, qd)
      local u = qd[1] * math.cos(q[3]) + qd[2] * math.sin(q[3])
      local x = k * t + c
      return math.max(math.abs(u - U * math.tanh(x)), math.abs(qd[3] - math.sqrt(m / J) * U / math.cosh(x)))
    end)
    assert(worst <= 3e-13, ("sleigh: (u, w) off the closed form by %.3g"):format(worst))
    assert(math.abs(number_after(out, "final turning rate th' =") - math.sqrt(m / J) * U / math.cosh(20 * k + c)) <= 3e-13, out)
  end)
  it("rolling_disk.lua: the contact point runs on the predicted circle", function()
    local out = run("rolling_disk.lua")
    rule(out, 1)
    assert(number_after(out, "largest deviation") < 1e-9, out)
  end)
  it("rolling_ball.lua: the centre accelerates at 5F/7m #slow", function()
    local out = run("rolling_ball.lua")
    rule(out, 1)
    assert(math.abs(number_after(out, "acceleration of the centre:") - 0.5) < 1e-10, out)
  end)
  it("constant_speed.lua: n = 2, the speed is held, and the motion is the hand-derived one", function()
    local out, runs = run("constant_speed.lua", true)
    rule(out, 2)
    assert(number_after(out, "largest deviation") < 1e-9, out)
    -- By hand: the constraint |v| = 1.5 lets the force act only across v
    -- (Appell-Chetaev: its reaction is along dPhi/dv, parallel to v), so
    -- a = -(k/m) (r - (r.v) v / |v|^2), with m = 0.7, k = 3.
    local m, k, v = 0.7, 3.0, 1.5
    local function hand(q, qd)
      local rv, vv = q[1] * qd[1] + q[2] * qd[2], qd[1] ^ 2 + qd[2] ^ 2
      return { -k / m * (q[1] - rv * qd[1] / vv), -k / m * (q[2] - rv * qd[2] / vv) }
    end
    local tr = runs[1]
    assert(#tr.t > 100, "no motion captured")
    local worst = max_over(tr, function(_, q, qd, qdd)
      local a = hand(q, qd)
      return math.max(math.abs(qdd[1] - a[1]), math.abs(qdd[2] - a[2]))
    end)
    -- Rounding: measured 4.9e-15, bound 1e-13.
    assert(worst <= 1e-13, ("q'' along the motion off the hand derivation by %.3g"):format(worst))
    -- And the motion: RK4 on the hand equations, h = 1e-3 from the same start
    -- to t = 10 (global error ~1e-11 here), against the recorded end point.
    local x, h_ = { 1, 0, 0, v }, 1e-3
    local function f(y) local a = hand({ y[1], y[2] }, { y[3], y[4] }); return { y[3], y[4], a[1], a[2] } end
    for _ = 1, 10000 do
      local k1 = f(x)
      local k2 = f({ x[1] + h_ / 2 * k1[1], x[2] + h_ / 2 * k1[2], x[3] + h_ / 2 * k1[3], x[4] + h_ / 2 * k1[4] })
      local k3 = f({ x[1] + h_ / 2 * k2[1], x[2] + h_ / 2 * k2[2], x[3] + h_ / 2 * k2[3], x[4] + h_ / 2 * k2[4] })
      local k4 = f({ x[1] + h_ * k3[1], x[2] + h_ * k3[2], x[3] + h_ * k3[3], x[4] + h_ * k3[4] })
      for i = 1, 4 do x[i] = x[i] + h_ / 6 * (k1[i] + 2 * k2[i] + 2 * k3[i] + k4[i]) end
    end
    local n = #tr.t
    assert(tr.t[n] == 10, "the run does not end at t = 10")
    local d = math.max(math.abs(tr.q[n][1] - x[1]), math.abs(tr.q[n][2] - x[2]), math.abs(tr.qd[n][1] - x[3]), math.abs(tr.qd[n][2] - x[4]))
    -- Measured 2.9e-12 (rtol 1e-10 over 10 s); bound 2e-11.
    assert(d <= 2e-11, ("state at t = 10 off the hand equations' by %.3g"):format(d))
  end)
  it("appell.lua: n = 2, the constraint computed from q' holds, and q'' is the hand-derived one", function()
    local out, runs = run("appell.lua", true)
    rule(out, 2)
    local m, c, g = 1.3, 0.6, 9.81
    local tr = runs[1]
    assert(#tr.t > 10, "no motion captured")
    -- The constraint itself, z'^2 = c^2 (x'^2 + y'^2), from the recorded q':
    -- rtol 1e-10 on speeds ~10: measured 1.3e-13, bound 1e-12.
    local phi = max_over(tr, function(_, _, qd) return qd[3] ^ 2 - c * c * (qd[1] ^ 2 + qd[2] ^ 2) end)
    assert(phi <= 1e-12, ("Appell's constraint violated by %.3g"):format(phi))
    -- By hand: m a = (0, 0, -m g) + lambda dPhi/dv with dPhi/dv parallel to
    -- n = (-c^2 x', -c^2 y', z'), and the differentiated constraint says
    -- n . a = 0, so a = (0, 0, -g) + (g z' / |n|^2) n.
    local worst = max_over(tr, function(_, _, qd, qdd)
      local n = { -c * c * qd[1], -c * c * qd[2], qd[3] }
      local s = g * qd[3] / (n[1] ^ 2 + n[2] ^ 2 + n[3] ^ 2)
      return math.max(math.abs(qdd[1] - s * n[1]), math.abs(qdd[2] - s * n[2]), math.abs(qdd[3] - (-g + s * n[3])))
    end)
    -- Rounding: measured 7.6e-15, bound 1e-13.
    assert(worst <= 1e-13, ("q'' along the motion off the hand derivation by %.3g"):format(worst))
    assert(number_after(out, "max") < 1e-9, out)
  end)
  it("hamel.lua: n = 3, the closed-form equations hold at the root, and the branch is kept", function()
    local out = run("hamel.lua")
    assert.truthy(out:find("Dolapchiev's rule: n = 3", 1, true), out)
    for v in out:gmatch("Q3 q%d''%s*=%s*([%-%d%.e+]+)") do assert(math.abs(tonumber(v)) < 1e-12, out) end
    assert.truthy(out:find("from the unconstrained accelerations", 1, true), out)
    assert(number_after(out, "largest change of q'' along the motion:") < 1e-10, out)
  end)
  it("servo.lua: n = 2; the servo's effort lambda(t) and the motion are the closed forms", function()
    local out, runs = run("servo.lua", true)
    rule(out, 2)
    assert(number_after(out, "largest error") < 1e-9, out)
    -- By hand: m q'' = F + lambda A with F = (0.4, -1.1), A = (1, 2) and
    -- A . q'' = sin t give lambda = (m sin t - A . F) / |A|^2
    -- = 0.18 sin t + 0.36 (m = 0.9), and from rest at the origin
    -- x = (0.76 t^2 / 2 + 0.18 (t - sin t)) / m,
    -- y = (-0.38 t^2 / 2 + 0.36 (t - sin t)) / m.
    local m = 0.9
    local tr = runs[1]
    assert(#tr.t > 100, "no motion captured")
    local dl = max_over(tr, function(t, _, _, _, lambda) return lambda[1] - (0.18 * math.sin(t) + 0.36) end)
    -- Measured 2.2e-16 (the solve is exact for a linear constraint); bound 1e-14.
    assert(dl <= 1e-14, ("lambda off its closed form by %.3g"):format(dl))
    -- Positions up to ~16, and q'' is exact: measured 7.1e-15; bound 1e-13.
    local dq = max_over(tr, function(t, q)
      local x = (0.76 * t * t / 2 + 0.18 * (t - math.sin(t))) / m
      local y = (-0.38 * t * t / 2 + 0.36 * (t - math.sin(t))) / m
      return math.max(math.abs(q[1] - x), math.abs(q[2] - y))
    end)
    assert(dq <= 1e-13, ("the motion off its closed form by %.3g"):format(dq))
  end)
  it("jerk_servo.lua: n = 3, a consistent start, and the motion at level 3 follows the closed form", function()
    local out = run("jerk_servo.lua")
    rule(out, 3)
    assert(number_after(out, "residual of order 3 at the start: max |r| =") < 1e-14, out)
    -- measured 5.3e-15 (rk8pd, rtol 1e-10, t1 = 6)
    assert(number_after(out, "largest error against the closed form:") < 1e-12, out)
  end)
  it("henon_chaos.lua: the fraction of chaotic orbits grows with the energy, as Henon and Heiles found", function()
    local out = run("henon_chaos.lua")
    local fractions = {}
    for E, orbits, chaotic, fraction, failed in out:gmatch("\n%s*([%d.]+)%s+(%d+)%s+(%d+)%s+([%d.]+)%s+(%d+)") do
      fractions[#fractions + 1] = { E = tonumber(E), f = tonumber(fraction), orbits = tonumber(orbits), failed = tonumber(failed) }
    end
    assert.are.equal(5, #fractions, out)
    for i, r in ipairs(fractions) do
      assert.are.equal(0, r.failed, out)
      assert.truthy(r.orbits > 50, out)
      if i > 1 then assert(r.f >= fractions[i - 1].f, "the fraction falls with the energy:\n" .. out) end
    end
    -- measured 0.00, 0.04, 0.55, 0.75, 0.84 (16 x 16 grid, T = 500); Henon
    -- and Heiles (1964): regular at E = 1/12, about half chaotic at 1/8
    assert(fractions[1].f <= 0.05, out)
    assert(fractions[3].f > 0.3 and fractions[3].f < 0.8, out)
    assert(fractions[5].f > 0.7, out)
    assert.truthy(out:find("chaotic fraction", 1, true), out)
  end)
  -- Contacts: the figures each example prints, and its captured
  -- motion against the closed form written here.
  it("sphere_particle.lua: it leaves where cos th = (2/3) cos th0, after sliding with N = m g (3 cos th - 2 cos th0)", function()
    local out, runs = run("sphere_particle.lua", true)
    local th0, g, R = 0.25, 9.81, 1.0
    assert(math.abs(number_after(out, "cos th =") - 2 / 3 * math.cos(th0)) <= 1e-9, out)
    assert(number_after(out, "largest difference") <= 1e-8, out)
    -- on the sphere (r = R) while it slides: its energy g z + v^2/2 = g R cos th0
    local tr, tleave = runs[1], number_after(out, "leaves the sphere at t =")
    local worst = max_over(tr, function(t, q, qd)
      if t >= tleave then return 0 end
      return math.max(math.abs(math.sqrt(q[1] ^ 2 + q[2] ^ 2) - R), math.abs(g * q[2] + 0.5 * (qd[1] ^ 2 + qd[2] ^ 2) - g * R * math.cos(th0)))
    end)
    assert(worst <= 1e-9, ("on the sphere with its energy until it leaves: %.3g"):format(worst))
  end)
  it("bouncing_ball.lua: bounce times and heights of the closed form, then at rest after the accumulation time", function()
    local out, runs = run("bouncing_ball.lua", true)
    local g, R, h, e = 9.81, 0.05, 1.0, 0.7
    assert(number_after(out, "largest difference from the closed form") <= 1e-9, out)
    assert(math.abs(number_after(out, "energy kept per bounce:") - e * e) <= 1e-12, out)
    local tinf = math.sqrt(2 * h / g) * (1 + e) / (1 - e)
    assert(math.abs(number_after(out, "the impacts accumulate at") - tinf) <= 1e-6, out)
    local tr = runs[1]
    assert(max_over(tr, function(t, q, qd) return t > tinf and math.max(math.abs(q[1] - R), math.abs(qd[1])) or 0 end) == 0,
      "at rest on the floor after the accumulation time")
    -- between bounces a free flight: y'' = -g, and never below the floor
    assert(max_over(tr, function(t, q, qd, qdd) return t < tinf - 1e-3 and math.abs(qdd[1] + g) or 0 end) <= 1e-9)
    assert(max_over(tr, function(t, q) return math.min(0, q[1] - R) end) <= 1e-12)
  end)
  it("block_slope.lua: it stops at v0/(g (sin a + mu cos a)), then sticks, or slides back at g (sin a - mu cos a)", function()
    local out, runs = run("block_slope.lua", true)
    local g, alpha, mu, v0 = 9.81, 0.4, 0.3, 2.5
    local dec, acc = g * (math.sin(alpha) + mu * math.cos(alpha)), g * (math.sin(alpha) - mu * math.cos(alpha))
    local ts, xs = v0 / dec, v0 ^ 2 / (2 * dec)
    for _, what in ipairs{ "sticks %(slip%+ %-> stick%)", "slips %(slip%+ %-> slip%-%)" } do
      local t, x = out:match("t = ([%d.]+)  slope " .. what .. " at x = ([%d.]+)")
      assert(t and math.abs(tonumber(t) - ts) <= 1e-9 and math.abs(tonumber(x) - xs) <= 1e-9, out)
    end
    for r, sticks in ipairs{ true, false } do
      local worst = max_over(runs[r], function(t, q)
        local want = t <= ts and v0 * t - dec * t * t / 2 or sticks and xs or xs - acc * (t - ts) ^ 2 / 2
        return q[1] - want
      end)
      assert(worst <= 1e-9, ("x(t) against the closed form: %.3g"):format(worst))
    end
  end)
  it("pendulum_stop.lua: e = 1 keeps its energy through the impacts; e < 1 amplitudes as 1 - cos th = e^2k (1 - cos th0)", function()
    local out = run("pendulum_stop.lua")
    assert(number_after(out, "each at an odd quarter period within") <= 1e-8, out)
    assert(number_after(out, "T + V drifts by") <= 1e-8, out)
    local e, th0, n = 0.6, 1.1, 0
    local c = 1 - math.cos(th0)
    local table_text = out:match("closed form: 1 %- cos th_k = e%^2k %(1 %- cos th0%)\n(.-)\n%s*[^%s%d]")
    assert(table_text, out)
    for k, sim, closed in ("\n" .. table_text):gmatch("\n%s+(%d+)%s+([%d.]+)%s+([%d.]+)") do
      n, c = n + 1, c * e * e
      assert(math.abs(tonumber(sim) - math.acos(1 - c)) <= 1e-9 and math.abs(tonumber(closed) - math.acos(1 - c)) <= 1e-11,
        ("swing %s: %s against %.12f"):format(k, sim, math.acos(1 - c)))
    end
    assert(n >= 5, out)
  end)
  it("squeezer.lua: every stepper's row of the table is within its tolerance's reach of the Test Set", function()
    local out = run("squeezer.lua")
    -- The table: method, tolerance, steps, error of the angles (rad) and of
    -- the angular velocities (rad/s) at t = 0.03 against the Test Set's
    -- reference (tests/squeezer_spec.lua checks the runs themselves).
    local rows = {}
    for method, eq in out:gmatch("\n(%a[%w]*)%s+[%w .%-+]-%s+%d+%s+([%d.e+-]+)%s+[%d.e+-]+") do rows[method] = tonumber(eq) end
    for _, m in ipairs{ "rk8pd", "taylor", "rkf45", "rkck", "bsimp", "rk4imp", "msadams", "msbdf", "rk2imp", "rk4" } do
      assert(rows[m], m .. " is missing from the table:\n" .. out)
    end
    -- measured 1.4e-9 (rk8pd at 1e-10: the reference's own accuracy)
    assert(rows.rk8pd < 3e-9 and rows.taylor < 3e-9 and rows.msbdf < 3e-5 and rows.rk2imp < 5e-3, out)
    assert(number_after(out, "differ from the Test Set's reference by at most") < 3e-9, out)
  end)
  it("every example in examples/ has a test here and a line in examples/README.md", function()
    local index = assert(io.open("examples/README.md")):read("a")
    local spec = assert(io.open("tests/examples_spec.lua")):read("a")
    local p = io.popen("ls examples/*.lua")
    for path in p:lines() do
      local name = path:match("examples/(.*)")
      assert(index:find("`" .. name .. "`", 1, true), name .. " is missing from examples/README.md")
      assert(spec:find('run("' .. name .. '"', 1, true), name .. " has no test in tests/examples_spec.lua")
    end
    p:close()
  end)
end)
