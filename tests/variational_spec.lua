-- variational_spec.lua - method = "variational" (src/ode/variational.h):
-- variational integrators built from the Lagrangian, against what follows
-- from their construction: the oscillator's discrete solution in closed
-- form, the energy bounded (no drift), the momentum map of a symmetry kept
-- to rounding (the discrete Noether theorem), holonomic constraints held to
-- rounding (RATTLE), the order of the compositions measured, the forces of
-- the discrete Lagrange-d'Alembert principle converging at order 2; the
-- Newton path (any Lagrangian) giving the explicit path's numbers where
-- both apply; and what the method refuses.
local h = require "tests.helpers"
local nz = h.nz

local function oscillator(compile)
  return nz.system{ name = "oscillator", coords = { "x" }, compile = compile,
    T = function(t, q, qd) return qd[1] ^ 2 / 2 end, V = function(t, q) return q[1] ^ 2 / 2 end }
end

local L, G = 1.3, 9.81
local function cartesian_pendulum(compile)
  return nz.system{ name = "cartesian pendulum", coords = { "x", "y" }, compile = compile,
    T = function(t, q, qd) return (qd[1] ^ 2 + qd[2] ^ 2) / 2 end,
    V = function(t, q) return G * q[2] end,
    constraints = { function(t, q) return q[1] ^ 2 + q[2] ^ 2 - L ^ 2 end } }
end

describe("method 'variational'", function()
  it("the oscillator from q'0 = 0 lands on cos(N theta), cos(theta) = 1 - h^2/2, by Verlet and by Newton", function()
    local step, N = 0.1, 1000
    local theta = 2 * math.asin(step / 2)   -- cos(theta) = 1 - h^2/2 (acos near 1 would lose digits)
    for _, compile in ipairs{ true, false } do
      local tr = oscillator(compile):simulate{ method = "variational", step = step, q0 = { 1 }, qd0 = { 0 }, t1 = N * step,
        dt = step }
      assert.equal(N + 1, #tr.t)
      local worst = 0
      for n = 1, #tr.t do worst = math.max(worst, math.abs(tr.q[n][1] - math.cos((n - 1) * theta))) end
      -- the trapezoidal rule's own solution (the midpoint rule would be
      -- cos(theta) = (1 - h^2/4)/(1 + h^2/4), 2.3e-3 away after these
      -- 1000 steps); rounding only: measured 4.5e-14 on both paths, and
      -- the closed form's cos((n - 1) theta) carries ~1e-14 at n theta ~ 100
      assert(worst <= 1e-12, ("%s: |q_n - cos(n theta)| up to %.3g"):format(compile and "Verlet" or "Newton", worst))
      assert.equal(2, tr.stats.order)
      assert.equal(N, tr.stats.steps)
      if compile then
        -- explicit: one q'' a step (the last step's end serves the next)
        assert.equal(N + 1, tr.stats.nfev)
        assert.equal(0, tr.stats.njev)
      else
        assert(tr.stats.njev >= N, "Newton's Jacobians: " .. tr.stats.njev)
      end
    end
  end)

  it("Kepler, e = 0.5, 2000 orbits at P/400: energy bounded, angular momentum kept to 1e-11 #slow", function()
    local e = 0.5
    local rp, vp = 1 - e, math.sqrt((1 + e) / (1 - e))
    local P = 2 * math.pi
    local kepler, energy = h.kepler()
    local tr = kepler:simulate{ method = "variational", step = P / 400, q0 = { rp, 0 }, qd0 = { 0, vp },
      t1 = 2000 * P, dt = P / 8 }
    local E0, L0, n = vp ^ 2 / 2 - 1 / rp, rp * vp, #tr.t
    local first, last, dL = 0, 0, 0
    for i = 1, n do
      local q, v = tr.q[i], tr.qd[i]
      local dE = math.abs(energy(q, v) - E0)
      if i <= n / 10 then first = math.max(first, dE) end
      if i > n - n / 10 then last = math.max(last, dE) end
      dL = math.max(dL, math.abs(q[1] * v[2] - q[2] * v[1] - L0))
    end
    -- measured: 3.36e-4 in both tenths (ratio 1.000), a drift would grow
    -- it 10x between them; angular momentum 1.4e-15 (x p_y - y p_x is
    -- the discrete momentum map of the rotations, exactly conserved)
    assert(last <= 1.5 * first, ("energy error %.3g in the last tenth against %.3g in the first"):format(last, first))
    assert(first < 1e-3, ("energy error %.3g in the first tenth (h = P/400, order 2)"):format(first))
    assert(dL <= 1e-11, ("angular momentum moved by %.3g"):format(dL))
  end)

  it("the Cartesian pendulum holds x^2 + y^2 = l^2 to 1e-11 over 2000 s (RATTLE), and Newton's path agrees #slow", function()
    local th0 = 1.0
    local q0 = { L * math.sin(th0), -L * math.cos(th0) }
    local tr = cartesian_pendulum():simulate{ method = "variational", step = 0.01, q0 = q0, qd0 = { 0, 0 }, t1 = 2000,
      dt = 0.1 }
    local worst, dE, tangent = 0, 0, 0
    for n = 1, #tr.t do
      local q, v = tr.q[n], tr.qd[n]
      worst = math.max(worst, math.abs(q[1] ^ 2 + q[2] ^ 2 - L ^ 2))
      tangent = math.max(tangent, math.abs(q[1] * v[1] + q[2] * v[2]))
      dE = math.max(dE, math.abs((v[1] ^ 2 + v[2] ^ 2) / 2 + G * q[2] - G * q0[2]))
    end
    -- measured 1.2e-14 (position) and 6.7e-16 (the velocity on the
    -- tangent); energy bounded at 1.4e-3 (order 2 at h = 0.01)
    assert(worst <= 1e-11, ("x^2 + y^2 - l^2 up to %.3g"):format(worst))
    assert(tangent <= 1e-11, ("x x' + y y' up to %.3g"):format(tangent))
    assert(dE <= 1e-2, ("energy error %.3g"):format(dE))
    -- the same discrete equations by Newton (compile = false: the jets of
    -- the Lua functions), 20 s: measured 5.7e-14 from RATTLE's
    local tn = cartesian_pendulum(false):simulate{ method = "variational", step = 0.01, q0 = q0, qd0 = { 0, 0 },
      t1 = 20, dt = 0.1 }
    local diff, wn = 0, 0
    for n = 1, #tn.t do
      local q = tn.q[n]
      wn = math.max(wn, math.abs(q[1] ^ 2 + q[2] ^ 2 - L ^ 2))
      diff = math.max(diff, math.abs(q[1] - tr.q[n][1]), math.abs(q[2] - tr.q[n][2]))
    end
    assert(wn <= 1e-11, ("Newton: x^2 + y^2 - l^2 up to %.3g"):format(wn))
    assert(diff <= 1e-10, ("Newton's path %.3g from RATTLE's"):format(diff))
  end)

  it("the compositions have orders 4, 6, 8: the error falls 2^p-fold when h halves", function()
    local osc, T1 = oscillator(), 20
    for _, p in ipairs{ 2, 4, 6, 8 } do
      local err = {}
      for j, step in ipairs{ 0.2, 0.1 } do
        local tr = osc:simulate{ method = "variational", order = p, step = step, q0 = { 1 }, qd0 = { 0 }, t1 = T1, dt = T1 }
        local n = #tr.t
        err[j] = math.abs(tr.q[n][1] - math.cos(T1)) + math.abs(tr.qd[n][1] + math.sin(T1))
        assert.equal(p, tr.stats.order)
        assert.truthy(tostring(tr):find(("method variational (order %d, fixed step %g)"):format(p, step), 1, true))
      end
      -- measured log2 ratios 1.99, 3.99, 6.00, 8.02 (errors 9.9e-3 to 3.3e-13
      -- at h = 0.1: above the rounding at every order)
      local rate = math.log(err[1] / err[2], 2)
      assert(math.abs(rate - p) <= 0.15, ("order %d: error ratio 2^%.3f (%.3g at h = 0.2, %.3g at 0.1)"):format(p, rate,
        err[1], err[2]))
    end
  end)

  it("a mass matrix that depends on q (the spherical pendulum): p_phi kept to rounding, the energy bounded", function()
    local sph = nz.system{ name = "spherical pendulum", coords = { "th", "ph" },
      T = function(t, q, qd) return (qd[1] ^ 2 + nz.sin(q[1]) ^ 2 * qd[2] ^ 2) / 2 end,
      V = function(t, q) return -G * nz.cos(q[1]) end }
    local tr = sph:simulate{ method = "variational", step = 0.01, q0 = { 1.0, 0 }, qd0 = { 0, 2.0 }, t1 = 100, dt = 0.1 }
    local function E(q, v) return (v[1] ^ 2 + math.sin(q[1]) ^ 2 * v[2] ^ 2) / 2 - G * math.cos(q[1]) end
    local function pphi(q, v) return math.sin(q[1]) ^ 2 * v[2] end
    local E0, P0, n = E(tr.q[1], tr.qd[1]), pphi(tr.q[1], tr.qd[1]), #tr.t
    local dP, first, last = 0, 0, 0
    for i = 1, n do
      local dE = math.abs(E(tr.q[i], tr.qd[i]) - E0)
      if i <= n / 10 then first = math.max(first, dE) end
      if i > n - n / 10 then last = math.max(last, dE) end
      dP = math.max(dP, math.abs(pphi(tr.q[i], tr.qd[i]) - P0))
    end
    -- phi is cyclic: its discrete momentum is the same at every step
    -- (measured 8.9e-16); the energy oscillates within 7.8e-4
    assert(dP <= 1e-13, ("p_phi moved by %.3g"):format(dP))
    assert(last <= 1.5 * first, ("energy error %.3g in the last tenth against %.3g in the first"):format(last, first))
    assert(tr.stats.njev > 0, "the Newton path (M depends on q)")
  end)

  it("forces by the discrete Lagrange-d'Alembert principle: a damped oscillator converges at order 2", function()
    local c = 0.3
    local damped = nz.system{ name = "damped oscillator", coords = { "x" },
      T = function(t, q, qd) return qd[1] ^ 2 / 2 end, V = function(t, q) return q[1] ^ 2 / 2 end,
      Q = function(t, q, qd) return { -c * qd[1] } end }
    -- x'' + c x' + x = 0 from x = 1, x' = 0
    local z, wd = c / 2, math.sqrt(1 - c * c / 4)
    local function x(t) return math.exp(-z * t) * (math.cos(wd * t) + z / wd * math.sin(wd * t)) end
    local T1, err = 10, {}
    for j, step in ipairs{ 0.02, 0.01 } do
      local tr = damped:simulate{ method = "variational", step = step, q0 = { 1 }, qd0 = { 0 }, t1 = T1, dt = 0.5 }
      err[j] = 0
      for n = 1, #tr.t do err[j] = math.max(err[j], math.abs(tr.q[n][1] - x(tr.t[n]))) end
    end
    -- measured 2^2.000: 4.2e-5 at h = 0.02, 1.05e-5 at 0.01 (Q = -c x' on
    -- the Newton path: h of M q'' + h = 0 depends on q')
    local rate = math.log(err[1] / err[2], 2)
    assert(math.abs(rate - 2) <= 0.1, ("error ratio 2^%.3f (%.3g, %.3g)"):format(rate, err[1], err[2]))
    assert(err[2] <= 1e-4, ("error %.3g at h = 0.01"):format(err[2]))
  end)

  it("events are located, as for rk4: the pendulum's zero at its quarter period", function()
    local pend = nz.system{ name = "pendulum", coords = { "th" },
      T = function(t, q, qd) return qd[1] ^ 2 / 2 end, V = function(t, q) return -G * nz.cos(q[1]) end }
    local tr = pend:simulate{ method = "variational", step = 1e-3, q0 = { 1.0 }, qd0 = { 0 }, t1 = 3, dt = 0.1,
      events = { { f = function(t, q, qd) return q[1] end, name = "zero" } } }
    local quarter = nz.special.ellint_K(math.sin(0.5)) / math.sqrt(G)
    -- 3 s span 2.8 half periods: zeros at K/w, 3K/w, 5K/w; the method's
    -- own phase error at h = 1e-3 is about 2e-7
    assert.equal(3, #tr.events)
    for i, ev in ipairs(tr.events) do
      local want = (2 * i - 1) * quarter
      assert(math.abs(ev.t - want) <= 1e-5, ("zero %d at %.10g, want %.10g"):format(i, ev.t, want))
    end
  end)

  it("refuses what it does not do, from the user's line", function()
    local osc = oscillator()
    h.checkerror("method 'variational' takes a fixed step: give 'step' = h", osc.simulate, osc,
      { method = "variational", q0 = { 1 }, t1 = 1 })
    h.checkerror("'order' must be 2, 4, 6 or 8", osc.simulate, osc, { method = "variational", step = 0.1, order = 3,
      q0 = { 1 }, t1 = 1 })
    h.checkerror("'order' applies to method 'variational' (2, 4, 6 or 8); method 'rk8pd'", osc.simulate, osc,
      { method = "rk8pd", order = 4, q0 = { 1 }, t1 = 1 })
    h.checkerror("method 'variational' does not integrate the 'work' monitor", osc.simulate, osc,
      { method = "variational", step = 0.1, monitors = { work = true }, q0 = { 1 }, t1 = 1 })
    h.checkerror("'h0' does not apply to method 'variational'", osc.simulate, osc,
      { method = "variational", step = 0.1, h0 = 0.1, q0 = { 1 }, t1 = 1 })
    local rd = require("tests.constraint_systems").rolling_disk()
    h.checkerror("method 'variational' takes holonomic constraints (on q and t), and constraint 1 is on q' "
      .. "(nonholonomic", rd.sys.simulate, rd.sys, { method = "variational", step = 0.01, q0 = { 0, 0, 0, 0 },
        qd0 = { 0.6, 0, 0.7, 2 }, t1 = 1 })
    -- constraints on q'' (order 2) and of order 3: the discrete principle
    -- holds a constraint on the positions only
    local program = require("tests.constraint_systems").program()
    h.checkerror("method 'variational' takes holonomic constraints (on q and t), and constraint 1 is of order 2 (on "
      .. "q''): take rk8pd, or taylor", program.sys.simulate, program.sys, { method = "variational", step = 0.01,
        q0 = { 0, 0 }, qd0 = { 0, 0 }, t1 = 1 })
    local jerk = nz.system{ name = "jerk", coords = { "x", "y" },
      T = function(t, q, qd) return (qd[1] ^ 2 + qd[2] ^ 2) / 2 end,
      constraints = { function(t, q, qd, qdd, q3) return q3[1] + q3[2] end } }
    h.checkerror("method 'variational' takes holonomic constraints (on q and t), and this system's are of order 3: "
      .. "take rk8pd, or taylor", jerk.simulate, jerk, { method = "variational", step = 0.01, q0 = { 0, 0 }, t1 = 1 })
    local pend = cartesian_pendulum()
    h.checkerror("method 'variational' takes no 'project' or 'baumgarte'", pend.simulate, pend,
      { method = "variational", step = 0.01, project = true, q0 = { L, 0 }, qd0 = { 0, 0 }, t1 = 1 })
    local ball = nz.system{ name = "ball", coords = { "y" },
      T = function(t, q, qd) return qd[1] ^ 2 / 2 end, V = function(t, q) return G * q[1] end,
      constraints = { nz.unilateral(function(t, q) return q[1] end) } }
    h.checkerror("method 'variational' does not take unilateral contacts", ball.simulate, ball,
      { method = "variational", step = 0.01, q0 = { 1 }, qd0 = { 0 }, t1 = 1 })
  end)

  it("a step that fails says why, where, and keeps what was computed", function()
    -- a step of 2 s for a pendulum of period ~2.2 s: Newton finds no root
    local sph = nz.system{ name = "spherical pendulum", coords = { "th", "ph" },
      T = function(t, q, qd) return (qd[1] ^ 2 + nz.sin(q[1]) ^ 2 * qd[2] ^ 2) / 2 end,
      V = function(t, q) return -G * nz.cos(q[1]) end }
    h.checkerror("system 'spherical pendulum': method 'variational': the discrete Euler-Lagrange equations did not "
      .. "converge at t = 0, q = {1, 0}, qd = {0, 2} (Newton: 40 iterations", sph.simulate, sph,
      { method = "variational", step = 2, q0 = { 1.0, 0 }, qd0 = { 0, 2.0 }, t1 = 10, dt = 2 })
    -- a user function's error is its own, on both paths
    for _, compile in ipairs{ true, false } do
      local wall = nz.system{ name = "wall", coords = { "x" }, compile = compile,
        T = function(t, q, qd) return qd[1] ^ 2 / 2 end, V = function(t, q) return 1 / nz.sqrt(q[1]) end }
      h.checkerror("system 'wall': V raised an error: 'sqrt' of a negative value", wall.simulate, wall,
        { method = "variational", step = 0.05, q0 = { 1 }, qd0 = { -30 }, t1 = 10, dt = 0.05 })
      assert.equal(1, #nz.last.t)
      assert.truthy(tostring(nz.last):find("method variational (order 2, fixed step 0.05)", 1, true), tostring(nz.last))
    end
  end)
end)
