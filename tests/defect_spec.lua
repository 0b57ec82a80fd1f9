-- defect_spec.lua - tr:residuals and sys:residuals_of measure the motion:
-- the equations evaluated on the curve through the points (lua/nz/analysis/defect.lua),
-- checked against motions known in closed form, curves that are not motions
-- with their defect derived by hand, an integrator written here (RK4), and
-- the scaling the integration's order predicts.  tr:consistency keeps the
-- check of the forms against the run's own q''.
local h = require "tests.helpers"
local nz = h.nz

local g = 9.81
local function pendulum()
  return nz.system{ name = "pendulum", coords = { "th" }, params = { m = 1, l = 1, g = g },
    T = function(t, q, qd, p) return 0.5 * p.m * p.l ^ 2 * qd[1] ^ 2 end,
    V = function(t, q, p) return -p.m * p.g * p.l * nz.cos(q[1]) end }
end

-- The classical Runge-Kutta method of order 4, written here, on the
-- pendulum th'' = -g sin th as the first-order system (th, w): the points
-- of a motion that nzlua did not compute.
local function rk4_pendulum(step, t1)
  local pts = { t = { 0 }, q = { { 2.5 } }, qd = { { 0 } } }
  local th, w = 2.5, 0
  local function f(a, b) return b, -g * math.sin(a) end
  for i = 1, math.floor(t1 / step + 0.5) do
    local k1a, k1b = f(th, w)
    local k2a, k2b = f(th + step / 2 * k1a, w + step / 2 * k1b)
    local k3a, k3b = f(th + step / 2 * k2a, w + step / 2 * k2b)
    local k4a, k4b = f(th + step * k3a, w + step * k3b)
    th = th + step / 6 * (k1a + 2 * k2a + 2 * k3a + k4a)
    w = w + step / 6 * (k1b + 2 * k2b + 2 * k3b + k4b)
    pts.t[i + 1], pts.q[i + 1], pts.qd[i + 1] = i * step, { th }, { w }
  end
  return pts
end

describe("tr:residuals measures the motion", function()
  local sys = pendulum()
  local function run(rtol)
    return sys:simulate{ q0 = { 2.5 }, qd0 = { 0 }, t1 = 10, dt = 0.01, method = "rkf45", rtol = rtol }
  end

  it("far from zero for the pendulum from th = 2.5 with rkf45 at rtol 1e-3, where the forms agree to rounding", function()
    local tr = run(1e-3)
    local r = tr:residuals(1, { quiet = true })
    -- The equation's terms are of size m l^2 |th''| ~ g sin 2.5 = 5.9; the
    -- run's error per unit time at rtol 1e-3 is of order 1e-2 of that.
    assert(r[1].max >= 0.05 and r[1].rms >= 5e-3, ("defect max %.3g, RMS %.3g"):format(r[1].max, r[1].rms))
    -- well above what the curve through the points adds
    assert(r[1].max >= 5 * r[1].floor, ("defect %.3g, floor %.3g"):format(r[1].max, r[1].floor))
    assert.are.equal("th", r[1].coordinate)
    assert(r[1].t_max > 0 and r[1].t_max < 10)
    assert.are.equal(2 * (#tr.t - 1), #r.t)
    -- the old check, under its own name: the solver's q'' came from these
    -- equations, so it is rounding whatever the run did
    local c = tr:consistency(1, { quiet = true })
    assert(c[1].max <= 1e-12, ("consistency %.3g"):format(c[1].max))
    assert.truthy(tostring(c):find("not the motion", 1, true), tostring(c))
    -- the printout says what is measured and how it scales
    local text = tostring(r):gsub("%s+", " ")
    for _, words in ipairs{ "Defect of the motion of 'pendulum'", "no right-hand side enters",
      "the error made per unit time", "not the error accumulated", "floor:", "It falls as rtol tightens",
      "tr:consistency(n)" } do
      assert.truthy(text:find(words, 1, true), text)
    end
  end)

  it("falls as the tolerance tightens, as the order of rkf45 predicts", function()
    -- rkf45 keeps each step's estimated error (of its order-4 solution,
    -- ~h^5) near rtol, so h ~ rtol^(1/5), and it steps with the order-5
    -- solution: the error it makes per unit time is ~h^5 ~ rtol (exponent
    -- 1).  Points 0.01 apart are read off the steps' interpolant (q from q,
    -- q', q'' at step ends: its q'' errs by ~h^4 ~ rtol^(4/5)).  So the
    -- defect falls as rtol^a with a between 4/5 and 1; measured over two
    -- decades 0.82 and 0.70 (rtol 1e-3 .. 1e-7).  Asserted: 0.6 <= a <= 1.2.
    local rms = {}
    for i, rtol in ipairs{ 1e-3, 1e-5, 1e-7 } do rms[i] = run(rtol):residuals(1, { quiet = true })[1].rms end
    for i = 1, 2 do
      local a = math.log(rms[i] / rms[i + 1], 10) / 2
      assert(a >= 0.6 and a <= 1.2, ("rtol 1e%d -> 1e%d: RMS %.3g -> %.3g, exponent %.3g"):format(
        -1 - 2 * i, -3 - 2 * i, rms[i], rms[i + 1], a))
    end
  end)

  it("is the same for every order n: the forms are identities along any curve (theory (2.1))", function()
    local dp = require("tests.mech_systems").double_pendulum(false).sys
    local tr = dp:simulate{ q0 = { 1.2, -0.5 }, qd0 = { 0.3, 0.8 }, t1 = 2, dt = 0.02, method = "rkf45", rtol = 1e-4 }
    local r1 = tr:residuals(1, { quiet = true })
    assert(r1[1].max >= 1e-3, ("order 1: %.3g"):format(r1[1].max))
    for _, n in ipairs{ 2, 3, 12, 40 } do
      local rn = tr:residuals(n, { quiet = true })
      local worst = 0
      for i = 1, #r1.t do
        for j = 1, 2 do worst = math.max(worst, math.abs(rn.dynamic[i][j] - r1.dynamic[i][j])) end
      end
      -- terms of size ~50 (q'' ~ 10, masses ~1): rounding ~1e-14
      assert(worst <= 1e-12, ("order %d differs from order 1 by %.3g"):format(n, worst))
    end
  end)

  it("a constrained run: the projected equations fall with rtol and Phi on the curve follows the points", function()
    local case = require("tests.constraint_systems").cartesian_pendulum()
    local rms, l = {}, 1.3
    for i, rtol in ipairs{ 1e-3, 1e-6 } do
      local tr = case.sys:simulate{ q0 = { l * math.sin(2), -l * math.cos(2) }, qd0 = { 0, 0 }, t1 = 5, dt = 0.01,
        method = "rkf45", rtol = rtol }
      local r = tr:residuals(nil, { quiet = true })
      rms[i] = r[1].rms + r[2].rms
      -- the curve passes through the points: its x^2 + y^2 - l^2 drifts as theirs
      local drift = 0
      for j = 1, #tr.t do drift = math.max(drift, math.abs(tr.q[j][1] ^ 2 + tr.q[j][2] ^ 2 - l * l)) end
      local phi = r.constraints[1].max
      assert(phi >= 0.5 * drift and phi <= 2 * drift, ("Phi on the curve %.3g, at the points %.3g"):format(phi, drift))
      assert.truthy(tostring(r):find("least-squares", 1, true))
    end
    assert(rms[1] >= 100 * rms[2], ("RMS %.3g at rtol 1e-3, %.3g at 1e-6"):format(rms[1], rms[2]))
  end)

  it("sys:report shows the defect of its run beside the forms' rounding", function()
    local lines = {}
    local saved = _G.print       -- report prints with the global print (busted gives a spec its own _ENV)
    _G.print = function(...) lines[#lines + 1] = table.concat({ ... }, "\t") end
    local ok, err = pcall(sys.report, sys, { q = { 2.5 }, simulate = { t1 = 5, dt = 0.01, method = "rkf45", rtol = 1e-3 },
      plot = false })
    _G.print = saved
    assert(ok, err)
    local out = table.concat(lines, "\n")
    assert.truthy(out:find("at the solved accelerations (the forms agree)", 1, true), out)
    local d = tonumber(out:match("defect of the motion %(tr:residuals%): max (%S+), above the floor"))
    assert(d and d >= 0.05, out)
  end)

  it("a run stopped by an event is measured up to its end", function()
    local tr = sys:simulate{ q0 = { 2.5 }, qd0 = { 0 }, t1 = 10, dt = 0.01, method = "rkf45", rtol = 1e-8,
      events = { { name = "down", f = function(t, q) return q[1] end, stop = true } } }
    assert.are.equal("stopped", tr.status)
    local r = tr:residuals(1, { quiet = true })
    assert.are.equal(#tr.t - 1, r.intervals + r.skipped + r.dropped)
    assert(r[1].max == r[1].max and r[1].max <= 1e-3, ("defect %.3g"):format(r[1].max))
  end)
end)

describe("sys:residuals_of: the defect of points from anywhere", function()
  local sys = pendulum()

  it("an RK4 written here: the defect falls by 2^4 when its step is halved", function()
    -- A fixed-step method of order p leaves global errors e = h^p e_p(t) +
    -- O(h^(p+1)) on a smooth curve (Hairer-Norsett-Wanner II.8), so the
    -- defect e' - J e of the points is h^p d_p(t) + O(h^(p+1)): halving h
    -- divides it by 2^4 = 16.  The curve through the points adds ~h^7 (V')
    -- and ~h^6 (Q''), below that at these steps (its floor, reported).
    local res = {}
    for i, step in ipairs{ 0.0125, 0.00625 } do
      local pts = rk4_pendulum(step, 10)
      res[i] = {
        both = sys:residuals_of{ t = pts.t, q = pts.q, qd = pts.qd, quiet = true },
        positions = sys:residuals_of{ t = pts.t, q = pts.q, quiet = true },
      }
    end
    local function ratio(what, get)
      local a, b = get(res[1][what]), get(res[2][what])
      local order = math.log(a / b, 2)
      assert(math.abs(order - 4) <= 0.25, ("%s: %.4g -> %.4g, order %.3g"):format(what, a, b, order))
    end
    ratio("both", function(r) return r[1].rms end)
    ratio("both", function(r) return r.kinematic[1].rms end)
    ratio("positions", function(r) return r[1].rms end)
    assert(res[2].both[1].rms >= 10 * res[2].both[1].floor)
    assert.is_nil(res[1].positions.kinematic)
    assert.truthy(tostring(res[1].both):find("falls by 2^p", 1, true))
  end)

  it("exact points of a harmonic oscillator: the defect is rounding", function()
    -- x = A cos(w t + c), m x'' + k x = 0 with k = m w^2.  Points 0.02
    -- apart: the curve's own error in V' is ~h^7 w^8 A / 8! ~ 1e-16, and
    -- the data's rounding, eps |x'| times the weights of V' (~10/h), is
    -- ~1e-13; through q alone Q'' takes ~eps |x| 40/h^2 ~ 2e-11.
    local m, w, A, c = 0.8, 1.3, 0.7, 0.3
    local osc = nz.system{ name = "oscillator", coords = { "x" },
      T = function(t, q, qd) return 0.5 * m * qd[1] ^ 2 end, V = function(t, q) return 0.5 * m * w * w * q[1] ^ 2 end }
    local t, q, qd = {}, {}, {}
    for j = 1, 501 do
      t[j] = (j - 1) * 0.02
      q[j], qd[j] = { A * math.cos(w * t[j] + c) }, { -A * w * math.sin(w * t[j] + c) }
    end
    local r = osc:residuals_of{ t = t, q = q, qd = qd, quiet = true }
    assert(r[1].max <= 1e-12 and r.kinematic[1].max <= 1e-12, ("defect %.3g, kinematic %.3g"):format(r[1].max,
      r.kinematic[1].max))
    -- the floor, estimated from the points, covers what exact points show
    assert(r[1].max <= 2 * r[1].floor, ("defect %.3g, floor %.3g"):format(r[1].max, r[1].floor))
    local p = osc:residuals_of{ t = t, q = q, quiet = true }
    assert(p[1].max <= 1e-10 and p[1].max <= 2 * p[1].floor, ("positions alone: %.3g, floor %.3g"):format(p[1].max, p[1].floor))
    -- the same points from a CSV file (numbers written to read back
    -- exactly) give the same numbers; with one coordinate q may be numbers
    local file = os.tmpname()
    local f = assert(io.open(file, "w"))
    f:write("t,x,x',note\n")
    for j = 1, #t do f:write(("%.17g,%.17g,%.17g,point %d\n"):format(t[j], q[j][1], qd[j][1], j)) end
    f:close()
    local from_csv = osc:residuals_of{ csv = file, quiet = true }
    os.remove(file)
    assert.are.equal(r[1].max, from_csv[1].max)
    assert.are.equal(r.kinematic[1].rms, from_csv.kinematic[1].rms)
    local plain = {}
    for j = 1, #t do plain[j] = q[j][1] end
    assert.are.equal(p[1].rms, osc:residuals_of{ t = t, q = plain, quiet = true }[1].rms)
  end)

  it("a curve on a circle that is not a motion: the defect is the tangential force it lacks", function()
    -- A particle of mass m on the circle x^2 + y^2 = R^2, no forces.  On
    -- x = R cos th(t), y = R sin th(t) the equations m q'' - A^T lambda
    -- leave, with lambda chosen by least squares (A radial), the
    -- tangential part m R th'' (-sin th, cos th): 0 for th = w t (a
    -- motion), m R a (-sin th, cos th) for th = a t^2 / 2.  Points 0.01
    -- apart up to t = 2 (th' <= 3.8): the curve's own error, ~h^7 |v^(8)| /
    -- 8! in V' and ~h^8 |x^(8)| / 8! in Q, is largest in the one-sided
    -- stencils at the ends: measured 1.9e-10 in the equations, 1.3e-13 in Phi.
    local m, R = 1.7, 0.6
    local ring = nz.system{ name = "ring", coords = { "x", "y" },
      T = function(t, q, qd) return 0.5 * m * (qd[1] ^ 2 + qd[2] ^ 2) end,
      constraints = { function(t, q) return q[1] ^ 2 + q[2] ^ 2 - R * R end } }
    local function points(th, thd)
      local t, q, qd = {}, {}, {}
      for j = 1, 201 do
        t[j] = (j - 1) * 0.01
        local a, b = th(t[j]), thd(t[j])
        q[j], qd[j] = { R * math.cos(a), R * math.sin(a) }, { -R * b * math.sin(a), R * b * math.cos(a) }
      end
      return { t = t, q = q, qd = qd, quiet = true }
    end
    local w, a = 2.3, 1.9
    local motion = ring:residuals_of(points(function(t) return w * t end, function() return w end))
    assert(motion[1].max <= 1e-11 and motion[2].max <= 1e-11, ("%.3g %.3g"):format(motion[1].max, motion[2].max))
    assert(motion.constraints[1].max <= 1e-12, ("Phi %.3g"):format(motion.constraints[1].max))
    local speeding = ring:residuals_of(points(function(t) return a * t * t / 2 end, function(t) return a * t end))
    local worst = 0
    for i, s in ipairs(speeding.t) do
      local th = a * s * s / 2
      local want = { -m * R * a * math.sin(th), m * R * a * math.cos(th) }
      for j = 1, 2 do worst = math.max(worst, math.abs(speeding.dynamic[i][j] - want[j])) end
    end
    assert(worst <= 1e-9, ("the tangential force m R a by hand, off by %.3g"):format(worst))
    assert(speeding.constraints[1].max <= 1e-12, ("Phi %.3g"):format(speeding.constraints[1].max))
  end)

  it("a trajectory written by tr:csv reads back: the same defect as tr:residuals", function()
    local tr = sys:simulate{ q0 = { 2.5 }, qd0 = { 0 }, t1 = 3, dt = 0.01, method = "rkf45", rtol = 1e-4 }
    local file = os.tmpname()
    tr:csv(file)
    local r = sys:residuals_of{ csv = file, quiet = true }
    os.remove(file)
    local want = tr:residuals(1, { quiet = true })
    assert.are.equal(want[1].max, r[1].max)
    assert.are.equal(want.kinematic[1].rms, r.kinematic[1].rms)
  end)
end)

describe("the names and the errors", function()
  local sys = pendulum()
  local tr = sys:simulate{ q0 = { 2.5 }, qd0 = { 0 }, t1 = 1 }
  local SPEC = "tests/defect_spec.lua"
  local function fails(want, f)
    local ok, err = pcall(f)
    assert.are.equal(false, ok)
    assert.truthy(err:find("^" .. SPEC:gsub("%p", "%%%0") .. ":%d+: "), err)
    assert.truthy(err:find(want, 1, true), ("expected %q in: %s"):format(want, err))
  end

  it("tr:residuals(0), tr:consistency(1.5): the error names the function called; too few points are named", function()
    fails("bad argument #1 to 'residuals' (n: an integer order from 1 to 100 expected, got 0)", function()
      return tr:residuals(0) end)
    fails("bad argument #1 to 'residuals' (n: an integer order from 1 to 100 expected, got the string \"2\")",
      function() return tr:residuals("2") end)
    fails("bad argument #1 to 'consistency' (n: an integer order from 1 to 100 expected, got 1.5)", function()
      return tr:consistency(1.5) end)
    fails("bad argument #2 to 'residuals' (unknown option 'quite' (did you mean 'quiet'?)", function()
      return tr:residuals(1, { quite = true }) end)
    fails("tr:residuals: the 3 points of this run are too few for the curve through them (8 in a run at least): "
      .. "simulate with a smaller dt", function()
      return sys:simulate{ q0 = { 2.5 }, t1 = 0.02, dt = 0.01 }:residuals() end)
    fails("bad argument #1 to 'residuals_of' (n: an integer order from 1 to 100 expected, got 0)", function()
      return sys:residuals_of{ t = { 0 }, q = { 0 }, n = 0 } end)
  end)

  it("sys:residuals_of names what is wrong with the points", function()
    local t, q = {}, {}
    for j = 1, 10 do t[j], q[j] = j / 10, { 0.2 } end
    fails("sys:residuals_of 'pendulum': a table {t = {...}, q = {{...}, ...} [, qd = ...]} or {csv = \"file\"} "
      .. "expected, got 3", function() return sys:residuals_of(3) end)
    fails("unknown option 'qdd' (did you mean 'qd'?) (options: t, q, qd, csv, n, quiet)", function()
      return sys:residuals_of{ t = t, q = q, qdd = q } end)
    fails("q[3]: a list of 1 number expected (one per coordinate: th), got a list of 2", function()
      local bad = { table.unpack(q) }
      bad[3] = { 1, 2 }
      return sys:residuals_of{ t = t, q = bad } end)
    fails("qd: one entry per time expected (10), got 9", function()
      return sys:residuals_of{ t = t, q = q, qd = { table.unpack(q, 1, 9) } } end)
    fails("t[4] = 0.3 does not come after t[3] = 0.3: the times must increase", function()
      local bad = { table.unpack(t) }
      bad[4] = bad[3]
      return sys:residuals_of{ t = bad, q = q } end)
    fails("t[2]: a finite number expected, got NaN", function()
      local bad = { table.unpack(t) }
      bad[2] = 0 / 0
      return sys:residuals_of{ t = bad, q = q } end)
    fails("5 points: the curve through them is of degree 7 and needs at least 8", function()
      return sys:residuals_of{ t = { 1, 2, 3, 4, 5 }, q = { 1, 2, 3, 4, 5 } } end)
    fails("give either csv or t, q (and qd), not both", function()
      return sys:residuals_of{ csv = "x.csv", t = t, q = q } end)
    fails("csv: cannot read '/nonexistent/x.csv'", function() return sys:residuals_of{ csv = "/nonexistent/x.csv" } end)
    local file = os.tmpname()
    local f = assert(io.open(file, "w"))
    f:write("t,x\n0,1\n")
    f:close()
    fails("has no column 'th' (its columns: t, x): a header naming t and every coordinate (th) expected",
      function() return sys:residuals_of{ csv = file } end)
    f = assert(io.open(file, "w"))
    f:write("t,th\n0,1\n0.1,oops\n")
    f:close()
    fails("line 3, column 'th': a finite number expected, got \"oops\"", function() return sys:residuals_of{ csv = file } end)
    os.remove(file)
  end)

  it("sys:equations without qdd says that its last column is the rounding of the solve, not a check", function()
    local text = sys:equations(2, 0, { 0.7 }, { 0.3 }, nil, { quiet = true })
    assert.truthy(text:find("= rounding", 1, true), text)
    assert.truthy(text:find("not a check of a motion", 1, true), text)
    assert.falsy(text:find("residual ", 1, true), text)
    -- with the accelerations given, the column is the residual at them:
    -- m l^2 qdd + m g l sin q = 0.2 + 9.81 sin 0.7
    local text2, r = sys:equations(2, 0, { 0.7 }, { 0.3 }, { 0.2 }, { quiet = true })
    assert.truthy(text2:find("= residual", 1, true), text2)
    assert.near(0.2 + g * math.sin(0.7), r[1], 1e-13)
  end)
end)
