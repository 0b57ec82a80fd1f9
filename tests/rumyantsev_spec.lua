-- rumyantsev_spec.lua - time as a coordinate (Rumyantsev 1978; docs/theory.md
-- §9): the parametric system (eq. 1.14-1.17) against the equations of the
-- original system for several parametrizations, Rumyantsev's identity
-- sum x'_alpha E_alpha = 0, and the parametric system integrated; the
-- energy integral's verdict and reasons, and the two forms of the energy
-- theorem along trajectories; the Jacobi-Whittaker reduction (eq. 2.8-2.12)
-- against closed forms: the Kepler orbit (a conic, and the period by
-- quadrature), a particle in a uniform field (a parabola), the knife edge on
-- an inclined plane (a nonholonomic constraint; its closed form and the
-- original system's own motion, point by point).
local h = require "tests.helpers"
local nz = h.nz
local cs = require "tests.constraint_systems"

local g = 9.81

-- A bead on a hoop of radius R turned about its vertical diameter by a
-- motor: (th, ph) with the moving constraint ph = W t.
local R, mb, W = 0.5, 0.3, 6.0
local function driven_bead()
  return nz.system{ name = "bead on a driven hoop", coords = { "th", "ph" },
    T = function(t, q, qd) return 0.5 * mb * R * R * (qd[1] ^ 2 + nz.sin(q[1]) ^ 2 * qd[2] ^ 2) end,
    V = function(t, q) return -mb * g * R * nz.cos(q[1]) end,
    constraints = { function(t, q) return q[2] - W * t end } }
end

-- The same bead as one coordinate: T rheonomic in form (T0 = m R^2 W^2 sin^2 th / 2).
local function bead()
  return nz.system{ name = "bead on a turning hoop", coords = { "th" },
    T = function(t, q, qd) return 0.5 * mb * R * R * (qd[1] ^ 2 + W * W * nz.sin(q[1]) ^ 2) end,
    V = function(t, q) return -mb * g * R * nz.cos(q[1]) end }
end

local mu = 1.0
local function kepler()
  return nz.system{ name = "Kepler", coords = { "r", "phi" },
    T = function(t, q, qd) return 0.5 * (qd[1] ^ 2 + q[1] ^ 2 * qd[2] ^ 2) end,
    V = function(t, q) return -mu / q[1] end }
end

-- x'' (q, q', q'') of a motion q(t) read with t = t(tau): x' = q' t', x'' = q'' t'^2 + q' t''.
local function extended(q, qd, qdd, t, tp, tpp)
  local x, xd, xdd = {}, {}, {}
  for i = 1, #q do x[i], xd[i], xdd[i] = q[i], qd[i] * tp, qdd[i] * tp * tp + qd[i] * tpp end
  local k = #q
  x[k + 1], xd[k + 1], xdd[k + 1] = t, tp, tpp
  return x, xd, xdd
end

describe("the parametric system (time as a coordinate, eq. 1.14-1.17)", function()
  -- (t', t'') at the point: tau = t, then two other monotone parametrizations
  local parametrizations = { { 1, 0 }, { 1.6, 0.6 }, { 0.4, -2 } }

  it("a moving constraint: all k + 1 equations vanish on the original motion, for any parametrization", function()
    local sys = driven_bead()
    local p = sys:parametric{}
    assert.are.same({ "th", "ph", "t" }, p.coords)
    local t, q, qd = 0.7, { 0.4, W * 0.7 }, { 0.3, W }
    local qdd, lam = sys:accel(t, q, qd)
    -- the hand-derived motion: th'' = W^2 sin th cos th - (g/R) sin th, ph'' = 0
    assert.near(W * W * math.sin(0.4) * math.cos(0.4) - g / R * math.sin(0.4), qdd[1], 1e-13)
    for _, tt in ipairs(parametrizations) do
      local tp, tpp = tt[1], tt[2]
      local x, xd, xdd = extended(q, qd, qdd, t, tp, tpp)
      -- a holonomic constraint's multiplier scales with t' (its gradient
      -- does not), the equations with t' (eq. 1.18)
      local r = p:residual(1, 0.2, x, xd, xdd, { lam[1] * tp })
      -- terms of size m R^2 th'' ~ 0.4: rounding only (bound 1e-13)
      for a = 1, 3 do assert(math.abs(r[a]) <= 1e-13, ("t' = %g: equation %d leaves %.3g"):format(tp, a, r[a])) end
    end
  end)

  it("Appell's constraint, nonlinear in the velocities (Chetaev's rule): the same, with lambda scaled by t'^2", function()
    local c = cs.appell()
    local p = c.sys:parametric{ time = "time" }
    assert.are.same({ "x", "y", "z", "time" }, p.coords)
    for _ = 1, 5 do
      local t, q, qd = c.draw()
      local qdd, lam = c.sys:accel(t, q, qd)
      local want = c.accel(t, q, qd)          -- by hand (tests/constraint_systems.lua)
      for i = 1, 3 do assert.near(want[i], qdd[i], 1e-12) end
      for _, tt in ipairs(parametrizations) do
        local x, xd, xdd = extended(q, qd, qdd, t, tt[1], tt[2])
        local r = p:residual(1, 0, x, xd, xdd, { lam[1] * tt[1] ^ 2 })
        -- terms of size m g ~ 13: bound 1e-12
        for a = 1, 4 do assert(math.abs(r[a]) <= 1e-12, ("equation %d leaves %.3g"):format(a, r[a])) end
      end
    end
  end)

  it("Rumyantsev's identity: sum_alpha x'_alpha E_alpha = 0 at any state, on or off the motion", function()
    -- E_alpha: the residuals of (1.17) with any multiplier.  Lambda is
    -- homogeneous of degree 1 in x' and a first-order constraint
    -- f(t, q, x'/t') of degree 0, so the sum vanishes identically (which is
    -- why the last equation follows from the others); a holonomic one enters
    -- through its rate Phi_x x' (degree 1), so there the state must keep it:
    -- x'_ph = W x'_t
    local p = driven_bead():parametric{}
    local pa = cs.appell().sys:parametric{}
    for _ = 1, 10 do
      for _, sys in ipairs{ p, pa } do
        local x, xd, xdd = {}, {}, {}
        for i = 1, sys.k do x[i], xd[i], xdd[i] = math.random() + 0.2, math.random() - 0.5, 4 * math.random() - 2 end
        xd[sys.k] = 0.5 + math.random()      -- t' > 0
        if sys == p then xd[2] = W * xd[3] end
        local r = sys:residual(1, 0.1, x, xd, xdd, { 3 * math.random() - 1.5 })
        local s, size = 0, 0
        for a = 1, sys.k do s, size = s + xd[a] * r[a], size + math.abs(xd[a] * r[a]) end
        assert(math.abs(s) <= 1e-13 * (1 + size), ("%s: sum x' E = %.3g (terms %.3g)"):format(sys.name, s, size))
      end
    end
  end)

  it("with tau fixing t = tau(s), the parametric system is integrated and follows the original motion", function()
    local sys = driven_bead()
    -- t = s + s^2/4: t' = 1 + s/2
    local p = sys:parametric{ tau = function(s) return s + s * s / 4 end }
    local tr = p:simulate{ q0 = { 0.4, 0, 0 }, qd0 = { 0, W, 1 }, t1 = 2, dt = 0.5, rtol = 1e-12, atol = 1e-12 }
    assert.are.equal("done", tr.status)
    -- s = 0, 0.5, ..., 2 gives t = 0, 0.5625, 1.25, 2.0625, 3: on a grid of 1/16
    local tr0 = sys:simulate{ q0 = { 0.4, 0 }, qd0 = { 0, W }, t1 = 3, dt = 1 / 16, rtol = 1e-12, atol = 1e-12 }
    for i = 1, #tr.t do
      local s = tr.t[i]
      local t = s + s * s / 4
      assert.near(t, tr.q[i][3], 1e-11)
      local n = math.floor(t * 16 + 0.5) + 1
      assert.are.equal(t, tr0.t[n])
      -- both to rtol 1e-12 over 3 s of a motion with rates ~5: bound 1e-9
      assert(math.abs(tr.q[i][1] - tr0.q[n][1]) <= 1e-9, ("s = %g: th %.15g vs %.15g"):format(s, tr.q[i][1], tr0.q[n][1]))
      assert(math.abs(tr.q[i][2] - W * t) <= 1e-9, ("s = %g: ph %.15g vs W t = %.15g"):format(s, tr.q[i][2], W * t))
    end
  end)

  it("refuses what does not carry over, with the reason", function()
    local prog = cs.program().sys
    h.checkerror("constraint 1 is of order 2", prog.parametric, prog, {})
    local sys = driven_bead()
    h.checkerror("a coordinate is already named 'th'", sys.parametric, sys, { time = "th" })
    h.checkerror("unknown option 'taus'", sys.parametric, sys, { taus = 1 })
  end)
end)

describe("the energy integral and the energy theorem (eq. 1.19, 2.1-2.2, 3.3-3.7)", function()
  it("says when H = h is a first integral and why not", function()
    local k = kepler():energy_integral()
    assert.is_true(k.holds)
    assert.are.equal("H = T + V", k.quantity)
    local b = bead():energy_integral()
    assert.is_true(b.holds)
    assert.are.equal("H = T2 - T0 + V (Jacobi's integral)", b.quantity)
    assert.truthy(tostring(b):find("T + V is not conserved", 1, true))
    local d = driven_bead():energy_integral()
    assert.is_false(d.holds)
    assert.truthy(d.reasons[1]:find("constraint 1 moves", 1, true), d.reasons[1])
    local sleigh = cs.sleigh().sys:energy_integral()
    assert.is_true(sleigh.holds)
    local ramp = nz.system{ name = "ramp", coords = { "x" }, T = function(t, q, qd) return 0.5 * qd[1] ^ 2 end,
      V = function(t, q) return t * q[1] end }
    local r = ramp:energy_integral()
    assert.is_false(r.holds)
    assert.truthy(r.reasons[1]:find("L depends on t explicitly", 1, true), r.reasons[1])
    local damped = nz.system{ name = "damped", coords = { "x" }, T = function(t, q, qd) return 0.5 * qd[1] ^ 2 end,
      Q = function(t, q, qd) return { -0.3 * qd[1] } end }
    local dd = damped:energy_integral()
    assert.is_false(dd.holds)
    assert.truthy(dd.reasons[1]:find("the forces Q do work", 1, true), dd.reasons[1])
    local appell = cs.appell().sys:energy_integral()   -- homogeneous of degree 2
    assert.is_true(appell.holds)
  end)

  it("along trajectories: Jacobi's integral for the turning hoop, T + V - integral R_0 dt for the driven one", function()
    local b = bead()
    local tr = b:simulate{ q0 = { 0.4 }, qd0 = { 0 }, t1 = 5, rtol = 1e-12, atol = 1e-12, monitors = { energy = true } }
    local e = b:energy_theorem(tr)
    -- H = T2 - T0 + V kept to the integrator's tolerance (measured 1.1e-12 J
    -- of H = -1.56 J), T + V changes by 2.2 J: bounds 1e-10 and 0.01
    assert(e.H_drift <= 1e-10, ("H drift %.3g"):format(e.H_drift))
    assert(e.T_V_change >= 0.01, ("T + V changes by %.3g"):format(e.T_V_change))
    local d = driven_bead()
    local td = d:simulate{ q0 = { 0.4, 0 }, qd0 = { 0, W }, t1 = 5, rtol = 1e-12, atol = 1e-12,
      monitors = { energy = true, work = true } }
    local ed = d:energy_theorem(td)
    assert.is_false(ed.integral.holds)
    assert(ed.T_V_change >= 0.01, ("T + V changes by %.3g"):format(ed.T_V_change))
    -- W integrated with the motion (rtol 1e-12): measured 2e-14 J; bound 1e-11
    assert(ed.T_V_minus_work_drift <= 1e-11, ("T + V - W drift %.3g"):format(ed.T_V_minus_work_drift))
    h.checkerror("the trajectory has no energies", d.energy_theorem, d, d:simulate{ q0 = { 0.4, 0 }, qd0 = { 0, W }, t1 = 0.1 })
  end)

  it("forces Q that do work: T + V - W constant, W the work of Q, against the work summed from the motion", function()
    -- m x'' + c x' + k x = F cos(w t): d(T + V)/dt = Q x' with Q = -c x' +
    -- F cos(w t).  The first version integrated only R_0 into W (zero
    -- here), so T + V - W drifted by the whole change of T + V (4 J) while
    -- energy_integral's advice said it was constant.
    local m, k, c, F, w = 2.0, 8.0, 0.4, 1.5, 1.3
    local osc = nz.system{ name = "forced", coords = { "x" },
      T = function(t, q, qd) return 0.5 * m * qd[1] ^ 2 end,
      V = function(t, q) return 0.5 * k * q[1] ^ 2 end,
      Q = function(t, q, qd) return { -c * qd[1] + F * nz.cos(w * t) } end }
    local verdict = osc:energy_integral()
    assert.is_false(verdict.holds)
    assert.truthy(tostring(verdict):find("W = integral (R_0 + sum_i Q_i q'_i) dt", 1, true), tostring(verdict))
    local tr = osc:simulate{ q0 = { 1 }, qd0 = { 0 }, t1 = 30, dt = 0.01, method = "bsimp", rtol = 1e-12, atol = 1e-12,
      monitors = { energy = true, work = true } }
    local e = osc:energy_theorem(tr)
    assert(e.T_V_change >= 1, ("T + V changes by %.3g"):format(e.T_V_change))
    -- bsimp at 1e-12 stops at each of the 3000 output points (3983 steps):
    -- each step's error is up to ~1e-12 of the 4 J at stake, and they add
    -- up: measured 1.0e-10 J (6.9e-14 with dt = 0.15, 405 steps); bound 1e-9
    assert(e.T_V_minus_work_drift <= 1e-9, ("T + V - W drift %.3g"):format(e.T_V_minus_work_drift))
    -- a second path: the power Q x' from the recorded motion, summed by
    -- Simpson's rule over the 3000 output steps (error ~ dt^4 times the
    -- power's fourth derivative, ~1e-9 here)
    local function P(i) local t, v = tr.t[i], tr.qd[i][1]; return (-c * v + F * math.cos(w * t)) * v end
    local n, sum = #tr.t - 1, 0
    for i = 0, n do sum = sum + ((i == 0 or i == n) and 1 or (i % 2 == 1 and 4 or 2)) * P(i + 1) end
    local Wsimpson = sum * 0.01 / 3
    assert(math.abs(tr.work[#tr.t] - Wsimpson) <= 1e-7, ("W = %.12g, Simpson %.12g"):format(tr.work[#tr.t], Wsimpson))
  end)
end)

describe("the Jacobi-Whittaker reduction (eq. 2.8-2.12)", function()
  it("Kepler: the path r(phi) is the conic p / (1 + e cos phi), the period by quadrature 2 pi sqrt(a^3 / mu)", function()
    local sys = kepler()
    for _, e in ipairs{ 0, 0.3, 0.6 } do
      local a = 1.0
      local rp = a * (1 - e)
      local vp = math.sqrt(mu * (1 + e) / rp)
      local hh = 0.5 * vp * vp - mu / rp
      local path = sys:jacobi_whittaker{ h = hh, independent = "phi" }
      assert.are.same({ "r" }, path.coords)
      local tr = path:simulate{ q0 = { rp }, qd0 = { 0 }, t0 = 0, t1 = 2 * math.pi, dt = 2 * math.pi / 500,
        rtol = 1e-13, atol = 1e-13 }
      local p, worst = a * (1 - e * e), 0
      for i = 1, #tr.t do worst = math.max(worst, math.abs(tr.q[i][1] - p / (1 + e * math.cos(tr.t[i])))) end
      -- rtol 1e-13 over one turn: measured 8.1e-14 at worst (e = 0.6); bound 1e-11
      assert(worst <= 1e-11, ("e = %g: path off the conic by %.3g"):format(e, worst))
      local t = path:elapsed(tr)
      local period = 2 * math.pi * math.sqrt(a ^ 3 / mu)
      -- the time integrated with the path (rtol 1e-13): measured 4.9e-14 of
      -- the period at worst (e = 0.3); bound 1e-12
      assert(math.abs(t[#t] - period) <= 1e-12 * period, ("e = %g: period %.15g, want %.15g"):format(e, t[#t], period))
      -- and Kepler's equation at a quarter of the way: t(phi) from the eccentric anomaly
      local i = 126                            -- phi = pi/2
      local E = 2 * math.atan(math.sqrt((1 - e) / (1 + e)) * math.tan(tr.t[i] / 2))
      local tk = math.sqrt(a ^ 3 / mu) * (E - e * math.sin(E))
      -- measured 1.8e-14 at worst; bound 1e-12
      assert(math.abs(t[i] - tk) <= 1e-12, ("e = %g: t(pi/2) %.15g, Kepler's equation %.15g"):format(e, t[i], tk))
    end
  end)

  -- The time along the path is integrated with it (one more coordinate,
  -- under the stepper's error control), not read off the output grid: it
  -- was the integral of a quintic interpolant between output points, off
  -- by 5e-4 of the period with 8 of them (e = 0.6).
  local function orbit(e, N, tol)
    local a, sys = 1.0, kepler()
    local rp = a * (1 - e)
    local hh = 0.5 * mu * (1 + e) / rp - mu / rp
    local path = sys:jacobi_whittaker{ h = hh, independent = "phi" }
    local tr = path:simulate{ q0 = { rp }, qd0 = { 0 }, t0 = 0, t1 = 2 * math.pi, dt = 2 * math.pi / N, rtol = tol, atol = tol }
    return path, tr, path:elapsed(tr), 2 * math.pi * math.sqrt(a ^ 3 / mu)
  end
  -- Kepler's equation: t = sqrt(a^3/mu) (E - e sin E), tan(E/2) =
  -- sqrt((1 - e)/(1 + e)) tan(phi/2); the worst difference along the orbit.
  local function kepler_error(e, tr, t)
    local worst = 0
    for i = 1, #tr.t do
      local E = 2 * math.atan(math.sqrt((1 - e) / (1 + e)) * math.tan(tr.t[i] / 2))
      if E < 0 then E = E + 2 * math.pi end
      if i == #tr.t then E = 2 * math.pi end
      worst = math.max(worst, math.abs(t[i] - (E - e * math.sin(E))))
    end
    return worst
  end
  it("Kepler's period from 8 output points at rtol 1e-13 is 2 pi a^1.5 / sqrt(mu)", function()
    for _, e in ipairs{ 0, 0.3, 0.6 } do
      local _, _, t, period = orbit(e, 8, 1e-13)
      -- measured 1.4e-16, 4.9e-14, 2.0e-14 of the period; bound 1e-12
      assert(math.abs(t[#t] - period) <= 1e-12 * period, ("e = %g: period %.15g, want %.15g"):format(e, t[#t], period))
    end
  end)
  it("on an ellipse the time's error is at the rtol's level on coarse and fine grids alike", function()
    local e, errors = 0.6, {}
    for _, N in ipairs{ 8, 64, 4000 } do
      local _, tr, t, period = orbit(e, N, 1e-10)
      errors[N] = kepler_error(e, tr, t) / period
      -- measured 1.55e-11, 1.62e-11, 1.62e-11 (rtol 1e-10); bound 1e-9
      assert(errors[N] <= 1e-9, ("N = %d: off Kepler's equation by %.3g of the period"):format(N, errors[N]))
    end
    -- the grid does not set it: 8 points are as good as 4000
    assert(errors[8] <= 3 * errors[4000], ("8 points: %.3g, 4000: %.3g"):format(errors[8], errors[4000]))
    -- and a tighter rtol lowers it (measured 2.0e-14 at 1e-13)
    local _, tr, t, period = orbit(e, 64, 1e-13)
    assert(kepler_error(e, tr, t) / period <= 1e-12)
  end)
  it("path:elapsed refuses a trajectory whose points are not the output grid", function()
    local path, tr = orbit(0.3, 8, 1e-10)
    tr.t[4] = tr.t[4] + 0.1
    h.checkerror("path:elapsed: the trajectory's points are not the output grid of path:simulate (t4 = ", path.elapsed, path, tr)
  end)

  it("a particle in a uniform field: the parabola y(x), and t = (x - x0) / vx", function()
    local m = 2.0
    local sys = nz.system{ name = "projectile", coords = { "x", "y" },
      T = function(t, q, qd) return 0.5 * m * (qd[1] ^ 2 + qd[2] ^ 2) end, V = function(t, q) return m * g * q[2] end }
    local vx, vy = 3.0, 4.0
    local hh = 0.5 * m * (vx * vx + vy * vy)     -- at y = 0
    local path = sys:jacobi_whittaker{ h = hh, independent = "x" }
    local tr = path:simulate{ q0 = { 0 }, qd0 = { vy / vx }, t0 = 0, t1 = 2, dt = 0.05, rtol = 1e-13, atol = 1e-13 }
    local t = path:elapsed(tr)
    for i = 1, #tr.t do
      local x = tr.t[i]
      assert.near(vy / vx * x - g * x * x / (2 * vx * vx), tr.q[i][1], 1e-12)
      assert.near(x / vx, t[i], 1e-12)
    end
  end)

  it("the knife edge on an inclined plane (a nonholonomic constraint, eq. 2.11): its closed form and the original motion", function()
    -- x down the slope (gravity g sin al along +x), heading th, blade along
    -- (cos th, sin th): sin th x' - cos th y' = 0; th = w t, and from rest
    -- x = (g sin al / 2w^2) sin^2(w t), y = (g sin al / 2w^2)(w t - sin w t cos w t)
    local m, I, al, w = 1.2, 0.05, 0.3, 2.0
    local gs = g * math.sin(al)
    local sys = nz.system{ name = "knife edge", coords = { "x", "y", "th" },
      T = function(t, q, qd) return 0.5 * m * (qd[1] ^ 2 + qd[2] ^ 2) + 0.5 * I * qd[3] ^ 2 end,
      V = function(t, q) return -m * gs * q[1] end,
      constraints = { function(t, q, qd) return nz.sin(q[3]) * qd[1] - nz.cos(q[3]) * qd[2] end } }
    local energy = sys:energy_integral()
    assert.is_true(energy.holds)
    local hh = 0.5 * I * w * w
    local path = sys:jacobi_whittaker{ h = hh, independent = "th" }
    assert.are.same({ "x", "y" }, path.coords)
    local tr = path:simulate{ q0 = { 0, 0 }, qd0 = { 0, 0 }, t0 = 0, t1 = 3, dt = 0.05, rtol = 1e-13, atol = 1e-13 }
    local t = path:elapsed(tr)
    local orig = sys:simulate{ q0 = { 0, 0, 0 }, qd0 = { 0, 0, w }, t1 = 1.5, dt = 0.025, rtol = 1e-13, atol = 1e-13 }
    local c = gs / (2 * w * w)
    for i = 1, #tr.t do
      local th = tr.t[i]
      assert.near(c * math.sin(th) ^ 2, tr.q[i][1], 1e-11)
      assert.near(c * (th - math.sin(th) * math.cos(th)), tr.q[i][2], 1e-11)
      assert.near(th / w, t[i], 1e-11)
      -- the original system at the same time (th = w t: the grids meet)
      assert.near(orig.q[i][1], tr.q[i][1], 1e-11)
      assert.near(orig.q[i][2], tr.q[i][2], 1e-11)
    end
  end)

  it("refuses without an energy integral, and with bad options", function()
    local d = driven_bead()
    h.checkerror("H = h is not a first integral of this system", d.jacobi_whittaker, d, { h = 1, independent = "th" })
    local k = kepler()
    h.checkerror("independent = 'psi' is not a coordinate", k.jacobi_whittaker, k, { h = -0.5, independent = "psi" })
    h.checkerror("h: the value of the energy integral", k.jacobi_whittaker, k, { independent = "phi" })
    local path = k:jacobi_whittaker{ h = -0.5, independent = "phi" }
    -- r = 10 is beyond the reach of h = -0.5 (h + mu / r < 0)
    h.checkerror("the motion does not reach here", path.time_rate, path, 0, { 10 }, { 0 })
  end)
  it("an energy h below what the start allows is said so, with h + L0 and the start, not as sqrt's domain error", function()
    -- Kepler from r0 = 1 at rest in r: L0 = mu / r0, so h = -2 leaves h + L0 = -1 < 0 there
    -- (it was "L raised an error: lua/nz/analysis/rumyantsev.lua:346: 'sqrt' of a negative value (got -0.5)")
    local k, hh, r0 = kepler(), -2, 1
    local path = k:jacobi_whittaker{ h = hh, independent = "phi" }
    local line = debug.getinfo(1, "l").currentline + 1
    local ok, err = pcall(function() return (path:simulate{ q0 = { r0 }, qd0 = { 0 }, t1 = 1 }) end)
    assert.is_false(ok)
    err = tostring(err)
    assert.truthy(err:find(("^[^:]*rumyantsev_spec.lua:%d: "):format(line)), err)
    assert.falsy(err:find("sqrt", 1, true), err)
    assert.falsy(err:find("rumyantsev.lua", 1, true), err)
    local e = hh + mu / r0
    assert.truthy(err:find(("the energy h = %.6g is too low here: raise h above %.6g (= -L0 here), or start where "
      .. "h + L0 > 0"):format(hh, -mu / r0), 1, true), err)
    assert.truthy(err:find(("h + L0 = %.6g is not positive at r = %.6g, phi = 0"):format(e, r0), 1, true), err)
    assert.truthy(err:find(("at t = 0, q = {%.6g}, qd = {0}"):format(r0), 1, true), err)
    -- from r0 = 0.4 the same h is allowed (h + mu / r0 = 0.5 > 0)
    local tr = path:simulate{ q0 = { 0.4 }, qd0 = { 0 }, t1 = 0.1 }
    assert.are.equal("done", tr.status)
  end)
end)
