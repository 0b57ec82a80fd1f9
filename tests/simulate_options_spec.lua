-- simulate_options_spec.lua - sys:simulate never hangs and never lies:
-- every option is validated (which option, what it got, what it accepts,
-- the caller's file:line first), failures carry one location, events that
-- raise say where, project = true keeps the statistics and a multistep
-- history, the work monitor's Jacobian row, a run that stops making
-- progress fails with the state, and a long run says so.  Steps are
-- counted, never wall time.
local h = require "tests.helpers"
local nz = h.nz
local simulate = require "nz.motion.simulate"
local nz_mech = require("nz.core").mech

local THIS = "tests/simulate_options_spec.lua"

local pendulum = nz.system{ name = "pendulum", coords = { "th" },
  T = function(t, q, qd) return 0.5 * qd[1] ^ 2 end,
  V = function(t, q) return -9.81 * nz.cos(q[1]) end }

-- A knife edge on an inclined plane (linear nonholonomic constraint).
local function knife()
  return nz.system{ name = "knife edge", coords = { "x", "y", "th" },
    T = function(t, q, qd) return 0.5 * 1.3 * (qd[1] ^ 2 + qd[2] ^ 2) + 0.5 * 0.2 * qd[3] ^ 2 end,
    V = function(t, q) return -1.3 * 2.385 * q[1] end,
    constraints = { function(t, q, qd) return -qd[1] * nz.sin(q[3]) + qd[2] * nz.cos(q[3]) end } }
end

-- The error of f(...) (which must fail), with the line of this file that called it.
local function failure(f, ...)
  local line = debug.getinfo(2, "l").currentline
  local ok, msg = pcall(f, ...)
  assert(not ok, "expected an error")
  return tostring(msg), line
end

-- Call simulate from this line and return the message: it must start with
-- this file and line (the user's call), never lua/nz/motion/simulate.lua.
local function option_error(sys, opts)
  local ok, msg = pcall(sys.simulate, sys, opts)
  local line = debug.getinfo(1, "l").currentline - 1
  assert(not ok, "expected an error for these options")
  msg = tostring(msg)
  local prefix = ("%s:%d: simulate '%s': "):format(THIS, line, sys.name)
  assert(msg:sub(1, #prefix) == prefix, ("expected the message to start with %q, got %q"):format(prefix, msg))
  assert(not msg:find("lua/nz/", 1, true), "the library's location leaked: " .. msg)
  return msg
end

local function contains(msg, ...)
  for _, s in ipairs{ ... } do
    assert(msg:find(s, 1, true), ("expected %q in %q"):format(s, msg))
  end
end

describe("simulate validates its options", function()
  local nan = 0 / 0
  local cases = {
    { "rtol = atol = 1e-300", { rtol = 1e-300, atol = 1e-300 }, { "'rtol'", "1e-300", "between 1e-15 and 1" } },
    { "rtol = inf", { rtol = math.huge }, { "'rtol'", "inf", "positive finite" } },
    { "step = 1e-300", { step = 1e-300 }, { "'step'", "1e-300", "at most 1e+09" } },
    { "h0 = 0", { h0 = 0 }, { "'h0'", "got 0", "positive finite" } },
    { "h0 < 0", { h0 = -0.25 }, { "'h0'", "got -0.25" } },
    { "h0 = NaN", { h0 = nan }, { "'h0'", "got NaN" } },   -- "NaN" on every C library, never "-nan"
    { "t1 = math.huge", { t1 = math.huge }, { "'t1' must be a number greater than t0 = 0", "finite", "got inf" } },
    { "dt = 1e-9 over a long span", { t1 = 100, dt = 1e-9 }, { "'dt'", "1e+11 output points", "at most 1 GB", "dt >= 8e-06" } },
    { "event_tol < 0", { event_tol = -1e-9 }, { "'event_tol'", "-1e-09" } },
    { "events = 'x'", { events = "x" }, { "'events'", "\"x\"", "list of functions" } },
    { "method = {}", { method = {} }, { "'method'", "a table", "rk8pd", "msbdf" } },
    { "method = 'euler'", { method = "euler" }, { "unknown method 'euler'", "rk8pd", "option 'method'" } },
    { "monitors = 'energy'", { monitors = "energy" }, { "'monitors'", "\"energy\"", "{energy = true, work = true}" } },
    { "t0 = '0'", { t0 = "0" }, { "'t0'", "\"0\"", "finite number" } },
    { "t0 = NaN", { t0 = nan }, { "'t0'", "got NaN" } },
    { "a fixed step with msadams", { method = "msadams", step = 1e-3 }, { "'step'", "'msadams'", "drop 'step'" } },
    { "a fixed step with msbdf", { method = "msbdf", step = 1e-3 }, { "'step'", "'msbdf'", "one-step method" } },
    { "a fixed step with bsimp", { method = "bsimp", step = 1e-3 }, { "'step'", "'bsimp'", "rk4imp" } },
    { "project = 'yes'", { project = "yes" }, { "'project'", "\"yes\"", "true or false" } },
    { "progress = 'yes'", { progress = "yes" }, { "'progress'", "\"yes\"", "true or false" } },
    { "check = 3", { check = 3 }, { "'check'", "got 3", "true or false" } },
    { "guess = 5", { guess = 5 }, { "'guess'", "got 5", "{lambda = {...}" } },
  }
  for _, c in ipairs(cases) do
    it(c[1] .. ": says which option, what it got and what it accepts, from the caller's line", function()
      local opts = { q0 = { 1 }, t1 = 1 }
      for k, v in pairs(c[2]) do opts[k] = v end
      contains(option_error(pendulum, opts), table.unpack(c[3]))
    end)
  end

  it("a negative Baumgarte gain is refused (the violation would grow)", function()
    local sys = knife()
    local msg = option_error(sys, { q0 = { 0, 0, 0 }, qd0 = { 0, 0, 1.7 }, t1 = 1, baumgarte = { alpha = -2.5, beta = 3 } })
    contains(msg, "'baumgarte'", "alpha = -2.5", ">= 0")
  end)

  it("options that do nothing for the system are said once (a warning, not an error)", function()
    local said = {}
    local saved = simulate.warn
    simulate.warn = function(msg) said[#said + 1] = msg end
    local sys = nz.system{ name = "free particle", coords = { "x" }, T = function(t, q, qd) return 0.5 * qd[1] ^ 2 end }
    local ok, tr = pcall(sys.simulate, sys, { q0 = { 0.3 }, qd0 = { 1.1 }, t1 = 0.5, project = true, baumgarte = 2 })
    local tr2 = sys:simulate{ q0 = { 0.3 }, qd0 = { 1.1 }, t1 = 0.5, project = true }
    simulate.warn = saved
    assert(ok, tostring(tr))
    assert.are.equal(2, #said)                  -- project and baumgarte, once each
    contains(said[1], THIS .. ":", "'project' does nothing", "no constraints")
    contains(said[2], "'baumgarte' does nothing")
    assert.are.equal(1, #tr2.warnings)          -- still recorded on the trajectory
    -- x = x0 + v t: the run itself is unaffected.
    assert(math.abs(tr.q[#tr.q][1] - (0.3 + 1.1 * 0.5)) <= 1e-12)
  end)

  it("a fixed step with rtol, atol or h0: each does nothing, said once", function()
    local said = {}
    local saved = simulate.warn
    simulate.warn = function(msg) said[#said + 1] = msg end
    local sys = nz.system{ name = "falling", coords = { "x" }, T = function(t, q, qd) return 0.5 * qd[1] ^ 2 end,
      V = function(t, q) return 2.385 * q[1] end }
    local line = debug.getinfo(1, "l").currentline + 1
    local ok, tr = pcall(sys.simulate, sys, { q0 = { 0.3 }, qd0 = { 1.1 }, t1 = 0.5, step = 0.0625, rtol = 1e-6, atol = 1e-9, h0 = 0.01 })
    sys:simulate{ q0 = { 0.3 }, qd0 = { 1.1 }, t1 = 0.5, step = 0.0625, rtol = 1e-6 }
    simulate.warn = saved
    assert(ok, tostring(tr))
    -- rtol, atol, h0 once each; not again on the second run; and the step,
    -- longer than the output spacing (200 points: dt = 0.0025), is cut to it
    assert.are.equal(4, #said)
    for i, key in ipairs{ "rtol", "atol", "h0" } do
      contains(said[i], ("%s:%d: simulate 'falling': warning: '%s' does nothing with a fixed 'step' = 0.0625"):format(THIS, line, key),
        "drop 'step' for adaptive steps")
    end
    contains(said[4], "'step' = 0.0625 is longer than the output spacing 'dt' = 0.0025: every output point ends a step, "
      .. "so the steps are 0.0025")
    contains(tostring(tr), "fixed step 0.0025")
    -- x = x0 + v t - g t^2 / 2 (g = 2.385): the run itself is unaffected (rk8pd is exact on a quadratic)
    assert(math.abs(tr.q[#tr.q][1] - (0.3 + 1.1 * 0.5 - 2.385 * 0.125)) <= 1e-12)
  end)
end)

describe("simulate's failures name the user's code first", function()
  it("an event that raises: its own file:line, then the system, the event, the time and the state", function()
    local line = debug.getinfo(1, "l").currentline + 2
    local msg = failure(pendulum.simulate, pendulum, { q0 = { 1 }, t1 = 1, events = {
      { name = "touchdown", f = function(t, q) if t > 0.25 then error("event blew up") end return q[1] + 2 end } } })
    contains(msg, ("%s:%d: simulate 'pendulum': event 'touchdown' raised an error at t = "):format(THIS, line),
      ", q = {", ", qd = {", ": event blew up")
    assert(not msg:find("lua/nz/", 1, true), msg)
  end)

  it("a system made with compile = false whose start is singular says so (the run's summary read a recording it has not)", function()
    -- q1''' = 0.2 q1 q2'''^2: nonlinear in q''', and at q2''' = 0 its
    -- derivative in q''' has no q2''' part, so (6.2) is singular at the start
    local jerk = nz.system{ name = "jerk", coords = { "x", "y" }, compile = false,
      T = function(t, q, qd) return 0.5 * 1.7 * (qd[1] ^ 2 + qd[2] ^ 2) end,
      Q = function() return { 0.3, -0.45 } end,
      constraints = { function(t, q, qd, qdd, qddd) return qddd[1] - 0.2 * q[1] * qddd[2] ^ 2 end } }
    local msg = failure(jerk.simulate, jerk, { q0 = { 0.6, -0.2 }, qd0 = { 0.3, 1.1 },
      qdd0 = { 0.3 / 1.7, -0.45 / 1.7 }, t1 = 1, dt = 0.1 })
    contains(msg, "system 'jerk': a constraint nonlinear in q^(3)", "is singular")
    assert(not msg:find("attempt to index", 1, true), msg)
  end)

  it("an event that returns no number says so with the state", function()
    local msg = option_error(pendulum, { q0 = { 1 }, t1 = 1, events = { function() return "up" end } })
    contains(msg, "event 'event 1' must return a finite number, got the string \"up\" at t = 0, q = {1}, qd = {0}")
  end)

  it("a function that fails during the run: one location (where the user's function raised), no library prefix", function()
    local line
    local sys = nz.system{ name = "breaks", coords = { "x" }, T = function(t, q, qd)
      if t > 0.5 then line = debug.getinfo(1, "l").currentline; error("T gave up") end
      return 0.5 * qd[1] ^ 2
    end }
    local ok, msg = pcall(sys.simulate, sys, { q0 = { 1 }, qd0 = { 1 }, t1 = 1 })
    assert(not ok)
    msg = tostring(msg)
    contains(msg, ("%s:%d: system 'breaks': T raised an error"):format(THIS, line), "T gave up", "kept in nz.last")
    assert(not msg:find("lua/nz/", 1, true), msg)
    local _, prefixes = msg:gsub(THIS .. ":%d+: system", "")
    assert.are.equal(1, prefixes)
  end)

  it("an event at an output time (g = t - 0.05 with dt = 0.005) is not missed", function()
    local tr = pendulum:simulate{ q0 = { 1 }, t1 = 1, dt = 0.005, events = { { f = function(t) return t - 0.05 end, stop = true } } }
    assert.are.equal("stopped", tr.status)
    assert(math.abs(tr.t[#tr.t] - 0.05) <= 1e-12)
  end)
end)

describe("project = true", function()
  it("msbdf on a knife edge to t1 = 5 finishes in a few thousand steps and keeps its statistics", function()
    local sys = knife()
    -- Before: a projection and a restart at order 1 after every step
    -- (897,269 right-hand sides for t = 1.6, "1 steps").  Measured now:
    -- 2,524 steps, 1 projection.
    local tr = sys:simulate{ q0 = { 0, 0, 0 }, qd0 = { 0, 0, 1.7 }, t1 = 5, method = "msbdf", project = true }
    assert.are.equal("done", tr.status)
    assert(tr.stats.steps > 100 and tr.stats.steps < 6000, ("%d steps"):format(tr.stats.steps))
    assert(tr.projections <= 10, ("%d projections"):format(tr.projections))
    -- Closed form (G = 2.385, w = 1.7): th = w t, x = G/(2 w^2) sin^2(w t).
    local t, G, w = tr.t[#tr.t], 2.385, 1.7
    assert(math.abs(tr.q[#tr.q][1] - G / (2 * w * w) * math.sin(w * t) ^ 2) <= 1e-6)
    assert(math.abs(tr.q[#tr.q][3] - w * t) <= 1e-6)
  end)

  it("a one-step method counts every step (a reset never zeroes the statistics)", function()
    local sys = knife()
    local with = sys:simulate{ q0 = { 0, 0, 0 }, qd0 = { 0, 0, 1.7 }, t1 = 2, method = "rk4imp", rtol = 1e-12, atol = 1e-14, project = true }
    assert(with.stats.steps >= 100, ("%d steps"):format(with.stats.steps))   -- dt = 0.01: at least one step per output
    assert(with.stats.nfev > with.stats.steps)
  end)

  it("nz_ode_reset keeps steps and rejections", function()
    local ode = nz_mech.ode_new(pendulum.engine, { method = "rk8pd", orders = {}, linear = {} })
    local t, hh, y = 0, 1e-3, { 1, 0 }
    for _ = 1, 5 do t, hh, y = nz_mech.ode_step(ode, pendulum.engine, t, 1, hh, y) end
    local before = nz_mech.ode_stats(ode).steps
    assert(before >= 5)
    nz_mech.ode_reset(ode)
    for _ = 1, 3 do t, hh, y = nz_mech.ode_step(ode, pendulum.engine, t, 1, hh, y) end
    assert(nz_mech.ode_stats(ode).steps >= before + 3)
  end)
end)

describe("the work monitor's Jacobian row", function()
  -- Bead on a hoop turning at Omega = w0 + alpha t (T has T0 = m R^2 Omega^2
  -- sin^2 th / 2): by hand from (9.1), R_0 = m R^2 (Omega alpha sin^2 th
  -- + Omega^2 sin 2th th'), so
  --   dR_0/dth  = m R^2 (Omega alpha sin 2th + 2 Omega^2 cos 2th th')
  --   dR_0/dth' = m R^2 Omega^2 sin 2th
  --   dR_0/dt   = m R^2 (alpha^2 sin^2 th + 2 Omega alpha sin 2th th').
  it("bead on a turning hoop: the row of W' = R_0 matches the hand derivation", function()
    local g, R, m, w0, alpha = 9.81, 0.5, 0.3, 2.0, 0.7
    local sys = nz.system{ name = "hoop", coords = { "th" },
      T = function(t, q, qd) return 0.5 * m * R * R * (qd[1] ^ 2 + (w0 + alpha * t) ^ 2 * nz.sin(q[1]) ^ 2) end,
      V = function(t, q) return -m * g * R * nz.cos(q[1]) end }
    local t, th, thd = 1.385, 0.7, -1.3
    local ode = nz_mech.ode_new(sys.engine, { method = "bsimp", orders = {}, linear = {}, work = true })
    local J, dfdt = nz_mech.ode_jacobian(ode, sys.engine, t, { th, thd, 0.25 })
    local W = m * R * R
    local Om = w0 + alpha * t
    local want = { W * (Om * alpha * math.sin(2 * th) + 2 * Om * Om * math.cos(2 * th) * thd), W * Om * Om * math.sin(2 * th), 0 }
    -- Central differences inside (h ~ 6e-6): error ~ h^2 |R_0'''| ~ 1e-10.
    for j = 1, 3 do
      assert(math.abs(J[3][j] - want[j]) <= 1e-8 * (1 + math.abs(want[j])),
        ("dR_0/dy_%d = %.12g, by hand %.12g"):format(j, J[3][j], want[j]))
    end
    local dRdt = W * (alpha * alpha * math.sin(th) ^ 2 + 2 * Om * alpha * math.sin(2 * th) * thd)
    assert(math.abs(dfdt[3] - dRdt) <= 1e-8 * (1 + math.abs(dRdt)))
  end)

  -- (A check of the knife edge's row against differences of
  -- sys:reaction_power compared the engine with itself; the row of a
  -- constrained system with a nonzero work is exercised by the driven hoop
  -- in integrator_battery_spec.lua, checked against Jacobi's integral.)

  it("bsimp with the work monitor on a knife edge: few rejections, T + V - W conserved", function()
    local sys = knife()
    -- Before: steps of 1e-7 after the first (bsimp's runaway test weighed
    -- the change of W ~ 1e-26 by |W|); measured now: 204 steps, 0 rejected.
    local tr = sys:simulate{ q0 = { 0, 0, 0 }, qd0 = { 0, 0, 1.7 }, t1 = 10, method = "bsimp", monitors = { work = true } }
    assert(tr.stats.steps < 1000, ("%d steps"):format(tr.stats.steps))
    assert(tr.stats.rejected <= 0.05 * tr.stats.steps, ("%d of %d rejected"):format(tr.stats.rejected, tr.stats.steps))
    for i = 1, #tr.t do
      assert(math.abs(tr.energy[i] - tr.work[i] - tr.energy[1]) <= 1e-8)
    end
  end)
end)

describe("a run that stops making progress", function()
  -- T = (1 - t/2) qd^2 / 2: M = 1 - t/2 vanishes at t = 2 while the
  -- momentum (1 - t/2) qd stays 1, so qd = 1 / (1 - t/2) blows up and the
  -- steps shrink to nothing just before t = 2.  The stall detector stops
  -- the run there, with M's singular value, which is 1 - t/2 at the t it
  -- names, and 1 at the start.  Both evaluators see the same M (the jets
  -- take it as a derivative along q'', exactly) and stop at the same step.
  for _, compile in ipairs{ true, false } do
    local sys = nz.system{ name = "degenerating", coords = { "x" }, compile = compile,
      T = function(t, q, qd) return 0.5 * (1 - t / 2) * qd[1] ^ 2 end }
    for _, method in ipairs{ "rk8pd", "rkf45", "msbdf" } do
      it(method .. (compile and "" or " (in Lua)") .. " stops with the time, the state and M's singular values", function()
        local ok, msg = pcall(sys.simulate, sys, { q0 = { 0 }, qd0 = { 1 }, t1 = 3, method = method })
        assert(not ok, "expected a failure")
        msg = tostring(msg)
        contains(msg, THIS .. ":", "simulate 'degenerating': the integrator (" .. method .. ") stopped making progress",
          "at t = 1.99999", "smallest 1 at the start")
        local t = tonumber(msg:match("at t = ([%d.e+-]+),"))
        local smin = tonumber(msg:match("singular values from ([%d.e+-]+) to"))
        -- the message rounds to 3 digits
        assert(t and smin and math.abs(smin - (1 - t / 2)) <= 5e-3 * (1 - t / 2), msg)
        -- the window is 1000 steps and the collapse takes a few thousand
        -- (measured 2,201 to 6,307)
        assert(nz.last.stats.steps < 30000, ("%d steps"):format(nz.last.stats.steps))
      end)
    end
  end
  it("a step GSL cannot make stops the run too, with the time and state", function()
    -- T = qd^2 (1 + log q) / 2: M = 1 + log q vanishes at q = 1/e, which the
    -- motion from q = 0.5, qd = -1 reaches in finite time (qd^2 (1 + log q)
    -- is conserved, so qd blows up); here GSL refuses a step before the
    -- steps stall, on either evaluator.
    for _, compile in ipairs{ true, false } do
      local rec = nz.system{ name = "singular", coords = { "q" }, compile = compile,
        T = function(t, q, qd) return 0.5 * qd[1] ^ 2 * (1 + nz.log(q[1])) end }
      local ok, msg = pcall(rec.simulate, rec, { q0 = { 0.5 }, qd0 = { -1 }, t1 = 10 })
      assert(not ok, "expected a failure")
      contains(tostring(msg), THIS .. ":", "'singular': the integrator (rk8pd)", "at t = 0.0907", "q = {0.367879")
    end
  end)
end)

describe("a long run says so once, and goes on", function()
  it("rk1imp at rtol 1e-10 on the pendulum: projected steps and a cheaper method, by step count", function()
    local said = {}
    local saved = simulate.warn
    simulate.warn = function(msg) said[#said + 1] = msg end
    local ok, tr = pcall(pendulum.simulate, pendulum, { q0 = { 1 }, t1 = 100, method = "rk1imp",
      events = { { f = function(t) return t - 0.01 end, stop = true } } })
    simulate.warn = saved
    assert(ok, tostring(tr))
    assert.are.equal("stopped", tr.status)          -- the run went on until the event
    -- rk1imp needs ~3.2e5 steps per unit of time at rtol 1e-10 (measured
    -- 15,887 to t = 0.05): t1 = 100 projects to ~3e7 > 1e7 steps, which
    -- the check at 2048 steps sees (steps, not the clock; the clock's
    -- criterion, 60 s, gives the same single message).
    assert.are.equal(1, #said)
    contains(said[1], THIS .. ":", "warning: at its pace so far this run will take about", "steps", "rk1imp", "rk8pd", "looser rtol")
    assert.is_nil(said[1]:find("larger 'dt'", 1, true))      -- the adaptive steps cost here, not the grid
    assert.are.equal(said[1], tr.warnings[1])
  end)

  -- The advice follows what drives the step count.  The threshold is
  -- lowered to 5e4 steps and the clock's criterion switched off, so the
  -- decision counts steps; each run stops at an event after the check.
  local function warned_on(opts, t_stop)
    local said, saved_warn, saved_limits = {}, simulate.warn, simulate.LONG_RUN
    simulate.warn = function(msg) said[#said + 1] = msg end
    simulate.LONG_RUN = { steps = 5e4, seconds = math.huge, check_steps = 2000 }
    opts.q0, opts.events = { 1 }, { { f = function(t) return t - t_stop end, stop = true } }
    local ok, tr = pcall(pendulum.simulate, pendulum, opts)
    simulate.warn, simulate.LONG_RUN = saved_warn, saved_limits
    assert(ok, tostring(tr))
    assert.are.equal(1, #said)
    return said[1], tr
  end
  it("driven by the output grid (dt = 1e-4 over 10 s, rk8pd): a larger dt, not a looser rtol", function()
    -- rk8pd at rtol 1e-10 needs ~1e3 steps for 10 s of this pendulum; the
    -- 1e5 outputs force one step each: ~1e5 projected > 5e4.
    -- (dense = false: with dense output the grid no longer sets the steps)
    local msg, tr = warned_on({ t1 = 10, dt = 1e-4, method = "rk8pd", dense = false }, 0.3)
    contains(msg, "the steps are set by the output grid ('dt' = 0.0001", "a larger 'dt'")
    assert.is_nil(msg:find("looser rtol", 1, true))
    assert(tr.stats.steps <= 1.5 * 0.3 / 1e-4, tr.stats.steps)        -- one step per output, give or take
  end)
  it("fixed steps (step = 1e-3 over 100 s, rk4): a larger step; rtol does nothing", function()
    -- 100 / 1e-3 = 1e5 fixed steps > 5e4, seen at the check after 2048 steps.
    local msg, tr = warned_on({ t1 = 100, step = 1e-3, method = "rk4" }, 2.5)
    contains(msg, "at step = 0.001", "the steps are fixed ('step' = 0.001; rtol does nothing", "a larger 'step'")
    assert.is_nil(msg:find("looser rtol", 1, true))
    assert.is_nil(msg:find("rtol = ", 1, true))
    assert.are.equal(2500, tr.stats.steps)                            -- 2.5 / 1e-3 fixed steps
  end)
  it("method 'variational' (step = 1e-3 over 100 s): a larger step or a higher order, never adaptive steps", function()
    local msg, tr = warned_on({ t1 = 100, step = 1e-3, method = "variational" }, 2.5)
    contains(msg, "with variational at step = 0.001", "a larger 'step' (the variational integrator's error, bounded in "
      .. "time, grows as step^2), or order = 4 at a larger step (its error falls as step^4; a step is 5 substeps)")
    assert.is_nil(msg:find("drop 'step'", 1, true))
    assert.is_nil(msg:find("rtol", 1, true))
    assert.are.equal(2500, tr.stats.steps)
  end)
  it("the projection is the pace of the last window, not the start-up spread over the run", function()
    -- A clock that the work drives: each call of Q costs 1 ms for the first
    -- 3600 calls (a slow start: the first steps, plans built, a graph
    -- evaluated before its machine code is ready), then 1 us.  The whole
    -- run's cost on that clock is known at its end, and the notice at 2048
    -- steps must project it from the pace after the start: rk4, 8000 fixed
    -- steps.  Spreading the start over the run (elapsed / fraction done, as
    -- it did) projects 4x too much.
    local calls = 0
    local function cost(n) return 1e-3 * math.min(n, 3600) + 1e-6 * math.max(0, n - 3600) end
    local sys = nz.system{ name = "slow start", coords = { "x" }, compile = false,
      T = function(t, q, qd) return 0.5 * qd[1] ^ 2 end, V = function(t, q) return 0.5 * q[1] ^ 2 end,
      Q = function() calls = calls + 1; return { 0 } end }
    local mech = require("nz.core").mech
    local said, saved_warn, saved_limits, saved_now = {}, simulate.warn, simulate.LONG_RUN, mech.now
    simulate.warn = function(msg) said[#said + 1] = msg end
    simulate.LONG_RUN = { steps = 5e3, seconds = math.huge, check_steps = 2000 }
    mech.now = function() return cost(calls) end
    calls = 0                          -- the run's calls only (nz.system made a few)
    local ok, tr = pcall(sys.simulate, sys, { q0 = { 1 }, t1 = 8, step = 1e-3, method = "rk4" })
    simulate.warn, simulate.LONG_RUN, mech.now = saved_warn, saved_limits, saved_now
    assert(ok, tostring(tr))
    assert.are.equal(1, #said)
    -- the message rounds to seconds: 4 s (it said 14 s)
    local said_s = tonumber(said[1]:match("steps and (%d+) s"))
    assert(said_s and math.abs(said_s - cost(calls)) <= 1, said[1])
    contains(said[1], "at the pace of its last 1024 steps", "after 2048 steps")
    local projected, actual = tr.stats.long_run.seconds, cost(calls)
    -- the pace is steady after the start: the projection is the run's cost
    -- (measured 3.692603 s against 3.692605 s)
    assert(math.abs(projected - actual) <= 1e-3 * actual, ("projected %.6g s, the run cost %.6g s"):format(projected, actual))
  end)
  it("a chaotic but not stiff motion (the double pendulum, rk8pd) is not told to take an implicit method", function()
    -- 20 % of rk8pd's steps are rejected, but by accuracy: its steps times
    -- the Jacobian's spectral radius stay far below its stability boundary 5.17
    local g = 9.81
    local dp = nz.system{ name = "double pendulum", coords = { "a", "b" },
      bodies = { gravity = { 0, -g, 0 },
        { mass = 2.0, pos = function(t, q) return { nz.sin(q[1]), -nz.cos(q[1]), 0 } end },
        { mass = 1.0, pos = function(t, q) return { nz.sin(q[1]) + 0.7 * nz.sin(q[2]), -nz.cos(q[1]) - 0.7 * nz.cos(q[2]), 0 } end } } }
    local said, saved_warn, saved_limits = {}, simulate.warn, simulate.LONG_RUN
    simulate.warn = function(msg) said[#said + 1] = msg end
    simulate.LONG_RUN = { steps = 5e4, seconds = math.huge, check_steps = 2000 }
    local ok, tr = pcall(dp.simulate, dp, { q0 = { 0.7, -0.4 }, qd0 = { 0.3, 1.1 }, t1 = 1e4, dt = 1,
      events = { { f = function(t) return t - 60 end, stop = true } } })
    simulate.warn, simulate.LONG_RUN = saved_warn, saved_limits
    assert(ok, tostring(tr))
    assert.are.equal(1, #said)
    for _, word in ipairs{ "bsimp", "msbdf", "stiff", "implicit" } do
      assert.is_nil(said[1]:find(word, 1, true), said[1])
    end
    contains(said[1], "cheaper: a looser rtol")
    -- measured h |lambda|max = 0.20 (h = 0.026, |lambda| = 7.6; 20 % of the
    -- steps rejected)
    local lr = tr.stats.long_run
    assert(lr.stiff == false and lr.h_rho < 0.5, ("h rho = %.3g"):format(lr.h_rho))
  end)
  it("a stiff system under an explicit method (rk8pd): the advice names the implicit ones, which take far fewer steps", function()
    -- x'' + 1e4 x' + x = 0: the fast mode e^(-1e4 t) is gone after 1e-3 s,
    -- yet rk8pd's stability keeps its steps near 3e-4 for the whole run
    -- (a looser rtol hardly changes that); bsimp's grow with the slow mode.
    local stiff = nz.system{ name = "stiff", coords = { "x" }, T = function(t, q, qd) return 0.5 * qd[1] ^ 2 end,
      V = function(t, q) return 0.5 * q[1] ^ 2 end, Q = function(t, q, qd) return { -1e4 * qd[1] } end }
    local said, saved_warn, saved_limits = {}, simulate.warn, simulate.LONG_RUN
    simulate.warn = function(msg) said[#said + 1] = msg end
    simulate.LONG_RUN = { steps = 5e4, seconds = math.huge, check_steps = 2000 }
    local ok, tr = pcall(stiff.simulate, stiff, { q0 = { 1 }, t1 = 100, method = "rk8pd",
      events = { { f = function(t) return t - 2 end, stop = true } } })
    simulate.warn, simulate.LONG_RUN = saved_warn, saved_limits
    assert(ok, tostring(tr))
    assert.are.equal(1, #said)
    -- the evidence: rk8pd's steps h times the Jacobian's spectral radius
    -- (1e4) sit at its stability boundary 5.17 (measured h |lambda| = 5.2)
    contains(said[1], "cheaper: bsimp or msbdf (its steps are held by stability, not accuracy: h |lambda|max = ",
      "against rk8pd's stability boundary 5.2")
    assert.is_true(tr.stats.long_run.stiff)
    local x = tonumber(said[1]:match("h |lambda|max = ([%d.e+-]+)"))
    assert(x >= 3 and x <= 6.5, said[1])
    local implicit = stiff:simulate{ q0 = { 1 }, t1 = 2, method = "bsimp" }
    assert(implicit.stats.steps * 20 < tr.stats.steps, ("bsimp %d steps, rk8pd %d"):format(implicit.stats.steps, tr.stats.steps))
  end)
end)

describe("the output points a run keeps fit in MAX_MEMORY", function()
  local five = nz.system{ name = "five pendulums", coords = { "a", "b", "c", "d", "e" },
    T = function(t, q, qd) local s = 0; for i = 1, 5 do s = s + qd[i] ^ 2 end; return 0.5 * s end,
    V = function(t, q) local s = 0; for i = 1, 5 do s = s - 9.81 * nz.cos(q[i]) end; return s end }
  -- The estimate bounds what the points really keep, measured by the
  -- collector (retained bytes after the run), and not by more than 2x.
  local cases = {
    { pendulum, { q0 = { 1 }, t1 = 5, dt = 1e-3 } },
    { pendulum, { q0 = { 1 }, t1 = 5, dt = 1e-3, monitors = { energy = true, work = true } } },
    { five, { q0 = { 1, 0.3, -0.7, 2.385, 0.1 }, t1 = 5, dt = 1e-3 } },
  }
  for i, case in ipairs(cases) do
    it("case " .. i .. ": the bytes per point estimated bound the bytes measured", function()
      local sys, opts = case[1], case[2]
      collectgarbage(); collectgarbage()
      local before = collectgarbage("count")
      local tr = sys:simulate(opts)
      collectgarbage(); collectgarbage()
      local in_c = require("nz.core").mech.points_bytes(tr._points)   -- the points' array, outside Lua's heap
      local measured = ((collectgarbage("count") - before) * 1024 + in_c) / #tr.t
      local estimate = simulate.point_bytes(sys, { monitors = opts.monitors or {} })
      assert(measured <= estimate and estimate <= 2 * measured, ("measured %.0f, estimated %d"):format(measured, estimate))
    end)
  end
  it("dt = 1e-5 over 1000 s (1e8 points, ~8 GB) is refused, with the bound and a dt that fits", function()
    local ok, msg = pcall(pendulum.simulate, pendulum, { q0 = { 1 }, t1 = 1000, dt = 1e-5 })
    assert(not ok)
    -- 1 coordinate: 3 doubles x 16 + 1 series (t) x 32 = 80 bytes
    contains(tostring(msg), THIS .. ":", "simulate 'pendulum': 'dt' = 1e-05 over [0, 1000] asks for 1e+08 output points",
      "of about 80 bytes each (8 GB); at most 1 GB are kept in memory", "MAX_MEMORY", "take dt >= 8e-05")
  end)
  it("the bound depends on what each point holds (monitors), by MAX_MEMORY", function()
    local saved = simulate.MAX_MEMORY
    simulate.MAX_MEMORY = 2e5               -- 2001 points of 80 bytes fit, of 240 (five series more) do not
    local ok1, tr = pcall(pendulum.simulate, pendulum, { q0 = { 1 }, t1 = 2.385, dt = 2.385 / 2000 })
    local ok2, msg = pcall(pendulum.simulate, pendulum, { q0 = { 1 }, t1 = 2.385, dt = 2.385 / 2000,
      monitors = { energy = true, work = true } })
    simulate.MAX_MEMORY = saved
    assert(ok1, tostring(tr))
    assert.are.equal(2001, #tr.t)
    assert(not ok2)
    contains(tostring(msg), "asks for 2e+03 output points of about 240 bytes each")
  end)
end)
