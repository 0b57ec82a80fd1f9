-- simulate_loop_spec.lua - the stepping loop (src/ode/ode_run.c, driven by
-- lua/nz/motion/run.lua): the output grid, fixed steps landing on the output
-- times, the accelerations and monitors recorded at each point, events
-- (recorded as graphs or called in Lua) located in time order, projection
-- (the violation computed in C, or in Lua at the levels above q'), pauses,
-- the interrupt and failures.  Checked against a loop written in the test
-- (tests/helpers.lua's reference_run: the same integrator stepped from Lua,
-- no code of the loop shared) to the bit, against closed forms and against
-- identities (the energy monitor is sys:energy, the violation is
-- constraints.violation).
local h = require "tests.helpers"
local nz = h.nz
local simulate = require "nz.motion.simulate"
local mech = require("nz.core").mech
local constraints = require "nz.model.constraints"
local systems = require "tests.constraint_systems"

local g = 9.81

-- Numbers compared by their exact bits (%a: 0 and -0 differ, NaN is NaN).
local function bits(x) return ("%a"):format(x) end

-- The first difference between a and b under path, or nil.
local function differ(a, b, path)
  if type(a) ~= type(b) then return ("%s: %s against %s"):format(path, type(a), type(b)) end
  if type(a) == "number" then
    if bits(a) ~= bits(b) then return ("%s: %s against %s"):format(path, bits(a), bits(b)) end
    return nil
  end
  if type(a) ~= "table" then
    if a ~= b then return ("%s: %s against %s"):format(path, tostring(a), tostring(b)) end
    return nil
  end
  for key, v in pairs(a) do
    local d = differ(v, b[key], path .. "." .. tostring(key))
    if d then return d end
  end
  for key in pairs(b) do
    if a[key] == nil then return ("%s.%s: only in the second"):format(path, tostring(key)) end
  end
  return nil
end

-- The run of sys:simulate{dense = false} and the loop written in the test
-- agree to the bit: every point's t, q, qd, q'', lambda, and the steps.
local function same_as_reference(sys, opts, ref_extra)
  local o = { dense = false }
  for key, v in pairs(opts) do o[key] = v end
  local tr = sys:simulate(o)
  local r = {}
  for key, v in pairs(opts) do r[key] = v end
  for key, v in pairs(ref_extra or {}) do r[key] = v end
  local ref = h.reference_run(sys, r)
  for _, key in ipairs{ "t", "q", "qd", "qdd", "lambda" } do
    local d = differ(ref[key], tr[key], "tr." .. key)
    assert(d == nil, d)
  end
  assert.are.equal(ref.stats.steps, tr.stats.steps)
  assert.are.equal(ref.stats.nfev, tr.stats.nfev)
  return tr, ref
end

-- The constraints' classification at the start, as simulate makes it.
local function classified(sys, t0, q0, qd0)
  local orders, linear = constraints.orders(sys, { t = t0, q = q0, qd = qd0 })
  return { orders = orders, linear = linear }
end

local pendulum = nz.system{ name = "pendulum", coords = { "th" },
  T = function(t, q, qd) return 0.5 * qd[1] ^ 2 end,
  V = function(t, q) return -g * nz.cos(q[1]) end }

-- Two coupled oscillators with a driven term, 2 DOF.
local coupled = nz.system{ name = "coupled", coords = { "x", "y" },
  T = function(t, q, qd) return 0.5 * (qd[1] ^ 2 + 2 * qd[2] ^ 2) end,
  V = function(t, q) return 0.5 * (q[1] ^ 2 + 3 * q[2] ^ 2) + 0.4 * (q[1] - q[2]) ^ 2 - 0.1 * nz.sin(t) * q[1] end }

-- The pendulum's quarter period K(k)/w, k = sin(th0/2), by the
-- arithmetic-geometric mean (K = pi / (2 agm(1, sqrt(1 - k^2)))).
local function quarter_period(th0)
  local a, b = 1, math.sqrt(1 - math.sin(th0 / 2) ^ 2)
  for _ = 1, 40 do a, b = (a + b) / 2, math.sqrt(a * b) end
  return math.pi / (2 * a) / math.sqrt(g)
end

describe("the comparison itself", function()
  it("sees one ulp, a sign of zero, a missing point and a different status", function()
    local a = { t = { 0, 0.5 }, q = { { 1 }, { 0.25 } }, status = "done" }
    assert.is_nil(differ(a, { t = { 0, 0.5 }, q = { { 1 }, { 0.25 } }, status = "done" }, "tr"))
    assert.truthy(differ(a, { t = { 0, 0.5 }, q = { { 1 }, { 0.25 + 2 ^ -54 } }, status = "done" }, "tr"))
    assert.truthy(differ(a, { t = { -0.0, 0.5 }, q = { { 1 }, { 0.25 } }, status = "done" }, "tr"))
    assert.truthy(differ(a, { t = { 0, 0.5 }, q = { { 1 } }, status = "done" }, "tr"))
    assert.truthy(differ(a, { t = { 0, 0.5 }, q = { { 1 }, { 0.25 } }, status = "failed" }, "tr"))
  end)
end)

describe("the loop against one written in the test, to the bit", function()
  it("adaptive rk8pd on an output grid with dt; the energy monitor is sys:energy at each point", function()
    local tr = same_as_reference(pendulum, { q0 = { 1.2 }, t1 = 5, dt = 0.05, monitors = { energy = true } })
    assert.are.equal(101, #tr.t)
    assert.are.equal(5, tr.t[#tr.t])                       -- the last point is t1 itself
    for n = 1, #tr.t do
      local E, H = pendulum:energy(tr.t[n], tr.q[n], tr.qd[n])
      assert.are.equal(bits(E), bits(tr.energy[n]))
      assert.are.equal(bits(H), bits(tr.generalized_energy[n]))
    end
  end)
  it("a grid that does not divide the span, and more points than the loop buffers (1024)", function()
    local tr = same_as_reference(coupled, { q0 = { 0.3, -0.2 }, qd0 = { 0, 0.1 }, t1 = 3.05, dt = 0.001 })
    assert.are.equal(3051, #tr.t)
  end)
  for _, method in ipairs{ "rk2", "rk4", "rkf45", "rkck", "rk8pd", "rk1imp", "rk2imp", "rk4imp", "bsimp", "msadams", "msbdf" } do
    it(method .. ", adaptive, on two coupled oscillators", function()
      local low = method == "rk2" or method == "rk1imp" or method == "rk2imp"   -- few steps at a low order
      same_as_reference(coupled, { q0 = { 0.3, -0.2 }, qd0 = { 0, 0.1 }, t1 = 1, dt = 0.25, method = method,
        rtol = low and 1e-5 or 1e-8, atol = low and 1e-7 or 1e-10 })
    end)
  end
  for _, method in ipairs{ "rk4", "rk8pd", "rk2imp", "rk4imp" } do
    it(method .. " at a fixed step that does not divide dt (the steps land on each output time)", function()
      local tr = same_as_reference(pendulum, { q0 = { 0.7 }, t1 = 2, dt = 0.1, step = 0.03, method = method })
      -- ceil(0.1 / 0.03) = 4 equal steps per output interval
      assert.are.equal(80, tr.stats.steps)
    end)
  end
  it("a first step h0 and an output grid coarser than the span", function()
    same_as_reference(pendulum, { q0 = { 0.7 }, t1 = 1, dt = 3, h0 = 1e-6 })
  end)
end)

describe("constrained systems", function()
  it("a holonomic pendulum in Cartesian coordinates: multipliers, and the violation is constraints.violation", function()
    local s = systems.cartesian_pendulum()
    math.randomseed(4)
    local t0, q0, qd0 = s.draw()
    local tr = same_as_reference(s.sys, { t0 = t0, q0 = q0, qd0 = qd0, t1 = 2, dt = 0.1 }, classified(s.sys, t0, q0, qd0))
    assert(#tr.violation == #tr.t and #tr.lambda[1] == 1)
    for n = 1, #tr.t do
      assert.are.equal(bits(constraints.violation(s.sys, tr.t[n], tr.q[n], tr.qd[n])), bits(tr.violation[n]))
    end
  end)
  it("Baumgarte's stabilization", function()
    local s = systems.cartesian_pendulum()
    math.randomseed(5)
    local t0, q0, qd0 = s.draw()
    local extra = classified(s.sys, t0, q0, qd0)
    extra.alpha, extra.beta = 5, 5
    same_as_reference(s.sys, { t0 = t0, q0 = q0, qd0 = qd0, t1 = 1, dt = 0.1, baumgarte = 5 }, extra)
  end)
  it("Appell's constraint, nonlinear in the velocities: Newton starts from the last root", function()
    local s = systems.appell()
    math.randomseed(6)
    local t0, q0, qd0 = s.draw()
    same_as_reference(s.sys, { t0 = t0, q0 = q0, qd0 = qd0, t1 = 1, dt = 0.1 }, classified(s.sys, t0, q0, qd0))
  end)
  it("a moving constraint with the work monitor, bsimp: the work is the state's, and T + V - W is constant", function()
    local d = systems.driven_hoop()
    local hoop, W = d.sys, d.W
    local q0, qd0 = { 0.7, 0 }, { 0.3, W }
    local extra = classified(hoop, 0, q0, qd0)
    extra.work = true
    local tr, ref = same_as_reference(hoop, { q0 = q0, qd0 = qd0, t1 = 1, dt = 0.1, method = "bsimp",
      monitors = { work = true } }, extra)
    assert(#tr.work == #tr.t)
    for n = 1, #tr.t do
      assert.are.equal(bits(ref.y[n][2 * hoop.k + 1]), bits(tr.work[n]))
      -- (Rumyantsev: T + V - W is constant along every motion)
      assert(math.abs(tr.energy[n] - tr.work[n] - tr.energy[1]) < 1e-8, n)
    end
  end)
  it("a constraint nonlinear in q''' (level 3, q''' solved): every root on the constraint, and the branch", function()
    local M, Q = 1.3, { 0.7, -0.4, 2.0 }
    local sys = nz.system{ name = "hamel3", coords = { "q1", "q2", "q3" },
      T = function(t, q, qd) return 0.5 * M * (qd[1] ^ 2 + qd[2] ^ 2 + qd[3] ^ 2) end,
      Q = function() return { Q[1], Q[2], Q[3] } end,
      constraints = { function(t, q, qd, qdd, qddd) return qddd[3] - qddd[1] * qddd[2] end } }
    local tr = sys:simulate{ q0 = { 0.2, -0.1, 0.3 }, qd0 = { 0.4, -0.5, 0.6 }, qdd0 = { 0.3, -0.2, 0.5 }, t1 = 1, dt = 0.25 }
    assert(tr.top and #tr.top == #tr.t and tr.branch)
    for n = 1, #tr.t do
      local r = tr.top[n]
      assert(math.abs(r[3] - r[1] * r[2]) < 1e-12, n)
    end
  end)
  it("a servo constraint of order 4 against its closed form (the state holds q'', q''' and the multiplier)", function()
    -- m x'' = F1 + lambda, m y'' = F2 + 2 lambda and x'''' + 2 y'''' = cos t
    -- give lambda'' = m cos t / 5: lambda = -m cos t / 5 + c1 t + c0 with
    -- lambda(0) = l0 and lambda'(0) = m x'''(0); x and y by integrating twice.
    local mass, F1, F2, l0 = 1.7, 0.3, -0.45, 0.385
    local sys = nz.system{ name = "servo4", coords = { "x", "y" },
      T = function(t, q, qd) return 0.5 * mass * (qd[1] ^ 2 + qd[2] ^ 2) end,
      Q = function() return { F1, F2 } end,
      constraints = { function(t, q, qd, qdd, qddd, q4d, params) return q4d[1] + 2 * q4d[2] - nz.cos(t) end } }
    local q0, qd0, x3 = { -0.3, 0.8 }, { 0.05, 0.4 }, 0.3
    local tr = sys:simulate{ q0 = q0, qd0 = qd0, qdd0 = { (F1 + l0) / mass, (F2 + 2 * l0) / mass },
      q3d0 = { x3, 2 * x3 }, t1 = 2, dt = 0.1 }
    assert(tr.higher and #tr.higher == #tr.t)
    local c0, c1 = l0 + mass / 5, mass * x3
    local worst = 0
    for n, t in ipairs(tr.t) do
      local x = q0[1] + qd0[1] * t + (F1 + c0) * t ^ 2 / (2 * mass) + c1 * t ^ 3 / (6 * mass) + (math.cos(t) - 1) / 5
      local y = q0[2] + qd0[2] * t + (F2 + 2 * c0) * t ^ 2 / (2 * mass) + 2 * c1 * t ^ 3 / (6 * mass)
        + 2 * (math.cos(t) - 1) / 5
      worst = math.max(worst, math.abs(tr.q[n][1] - x), math.abs(tr.q[n][2] - y))
    end
    assert(worst < 1e-8, worst)
  end)
end)

describe("events (recorded once as graphs, or called in Lua), located in C", function()
  -- th crosses 0 at odd multiples of the quarter period; qd at its multiples
  -- by two, rising at the left turns (th at its minimum).
  local three = {
    { f = function(t, q) return q[1] end, name = "zero" },
    { f = function(t, q, qd) return qd[1] end, direction = 1, name = "left turn" },
    { f = function(t, q, qd) return qd[1] end, direction = -1, name = "right turn" } }
  for _, method in ipairs{ "rk8pd", "taylor", "msadams", "rk4" } do
    it(("several events, either way, rising and falling, at the quarter periods K(k)/w (%s)"):format(method), function()
      local K = quarter_period(1)
      local tr = pendulum:simulate{ q0 = { 1 }, t1 = 5, dt = 0.1, method = method, events = three,
        step = method == "rk4" and 0.001 or nil, rtol = method == "msadams" and 1e-12 or nil }
      assert.are.equal("done", tr.status)
      assert.are.equal(math.floor((5 / K + 1) / 2) + math.floor(5 / (2 * K)), #tr.events)
      local last = -1
      for i, ev in ipairs(tr.events) do
        assert(ev.t >= last, "in time order")
        last = ev.t
        local want_t, want_dir
        if ev.name == "zero" then
          want_t = (2 * math.floor(ev.t / (2 * K)) + 1) * K
          want_dir = ev.qd[1] > 0 and 1 or -1
        else
          want_t = 2 * K * math.floor(ev.t / (2 * K) + 0.5)
          want_dir = ev.name == "left turn" and 1 or -1
          assert((ev.name == "left turn") == (ev.q[1] < 0), ev.name)
        end
        assert(math.abs(ev.t - want_t) < 1e-8, ("%s: event %d (%s) at %.12g, expected %.12g"):format(method, i, ev.name,
          ev.t, want_t))
        assert(ev.direction == want_dir, ("%s: event %d (%s) said %s"):format(method, i, ev.name, tostring(ev.direction)))
      end
    end)
  end
  it("a stopping event: the point where it stops ends the trajectory (with the monitors recorded there)", function()
    for _, dense in ipairs{ true, false } do
      local tr = pendulum:simulate{ q0 = { 1 }, t1 = 5, dt = 0.1, monitors = { energy = true }, dense = dense,
        events = { { f = function(t, q) return q[1] end, direction = -1, stop = true, name = "down" } } }
      assert.are.equal(#tr.t, #tr.energy)
      assert.are.equal("stopped", tr.status)
      assert.are.equal(1, #tr.events)
      assert.are.equal(tr.events[1].t, tr.t[#tr.t])
      assert(tr.t[#tr.t - 1] < tr.t[#tr.t], "no point after the event")
      assert(math.abs(tr.t[#tr.t] - quarter_period(1)) < 1e-9, tr.t[#tr.t])
      assert(math.abs(tr.q[#tr.q][1]) < 1e-10, tr.q[#tr.q][1])
    end
  end)
  it("two events in one step: both, in time order; a stop ends the run at its time, after the earlier one", function()
    -- fixed steps of 0.1: t = 0.33 and t = 0.36 fall in the step [0.3, 0.4]
    local tr = pendulum:simulate{ q0 = { 0.5 }, t1 = 1, dt = 0.5, step = 0.1, method = "rk4",
      events = { function(t) return t - 0.36 end, function(t) return t - 0.33 end, function(t) return t - 0.72 end } }
    assert.are.equal(3, #tr.events)
    assert.are.equal("event 2", tr.events[1].name)
    assert.are.equal("event 1", tr.events[2].name)
    assert.are.equal("event 3", tr.events[3].name)
    assert(math.abs(tr.events[1].t - 0.33) < 1e-11 and math.abs(tr.events[2].t - 0.36) < 1e-11, tr.events[2].t)
    -- the later one stops: the earlier one in the same step is seen first
    local c = pendulum:simulate{ q0 = { 0.5 }, t1 = 1, dt = 0.5, step = 0.1, method = "rk4",
      events = { { f = function(t) return t - 0.36 end, stop = true }, function(t) return t - 0.33 end } }
    assert.are.equal(2, #c.events)
    assert.are.equal("stopped", c.status)
    -- the earlier one stops: the later one is not seen
    local d = pendulum:simulate{ q0 = { 0.5 }, t1 = 1, dt = 0.5, step = 0.1, method = "rk4",
      events = { function(t) return t - 0.36 end, { f = function(t) return t - 0.33 end, stop = true } } }
    assert.are.equal(1, #d.events)
    assert(math.abs(d.t[#d.t] - 0.33) < 1e-11, d.t[#d.t])
  end)
  it("an event at an output time (a step lands on the zero)", function()
    local tr = pendulum:simulate{ q0 = { 1 }, t1 = 0.1, dt = 0.005, dense = false, events = { function(t) return t - 0.05 end } }
    assert.are.equal(1, #tr.events)
    assert.are.equal(0.05, tr.events[1].t)
    assert.are.equal(21, #tr.t)
  end)
  it("a parameter and a branch written with nz.ifelse are recorded; events and projection together", function()
    local s = systems.cartesian_pendulum()
    math.randomseed(7)
    local t0, q0, qd0 = s.draw()
    s.sys.params.level = 0.2
    local tr = s.sys:simulate{ t0 = t0, q0 = q0, qd0 = qd0, t1 = 20, rtol = 1e-6, atol = 1e-8, project = true,
      events = { function(t, q, qd, params) return nz.ifelse(nz.gt(q[2], 0), 1, q[2] + params.level) end,
                 { f = function(t, q) return q[1] end, direction = 1 } } }
    s.sys.params.level = nil
    assert(tr.projections >= 2, tr.projections)
    assert(#tr.events >= 2, #tr.events)
    for _, ev in ipairs(tr.events) do
      if ev.name == "event 2" then assert(math.abs(ev.q[1]) < 1e-6, ev.q[1]) end
    end
  end)
  it("events on a system with a moving constraint and the work monitor, bsimp: at the turns of th", function()
    local d = systems.driven_hoop()
    local tr = d.sys:simulate{ q0 = { 0.7, 0 }, qd0 = { 0.3, d.W }, t1 = 2, dt = 0.1, method = "bsimp",
      monitors = { work = true }, events = { function(t, q, qd) return qd[1] end } }
    assert(#tr.events >= 1)
    for _, ev in ipairs(tr.events) do assert(math.abs(ev.qd[1]) < 1e-7, ev.qd[1]) end
  end)
  it("the located times of the events' Lua functions (a system not recorded) are those of the graphs to 1e-10", function()
    local plain = nz.system{ name = "pendulum", coords = { "th" }, compile = false,
      T = function(t, q, qd) return 0.5 * qd[1] ^ 2 end,
      V = function(t, q) return -g * nz.cos(q[1]) end }
    local opts = { q0 = { 1 }, t1 = 5, events = { function(t, q) return q[1] * q[1] - 0.25 end } }
    local a, b = plain:simulate(opts), pendulum:simulate(opts)
    assert.truthy(a.stats.events_why:find("compile = false", 1, true), a.stats.events_why)
    assert.is_nil(b.stats.events_why)
    assert.are.equal(#a.events, #b.events)
    assert(#a.events >= 8, #a.events)
    for i = 1, #a.events do assert(math.abs(a.events[i].t - b.events[i].t) < 1e-10, i) end
  end)
  it("an event function that branches in Lua is called in Lua, says why, and is located as a recorded one", function()
    local ev = function(t, q) if q[1] > 0.5 then return 1 end return q[1] - 0.25 end
    local tr = pendulum:simulate{ q0 = { 1 }, t1 = 2, events = { { f = ev, name = "branchy" } } }
    assert.truthy(tr.stats.events_why:find("event 'branchy' cannot be recorded (compares a traced value", 1, true),
      tr.stats.events_why)
    assert.truthy(tr.stats.events_why:find("simulate_loop_spec.lua:", 1, true), tr.stats.events_why)
    -- where it changes sign it is q - 0.25: the same crossings
    local plain = pendulum:simulate{ q0 = { 1 }, t1 = 2, events = { { f = function(t, q) return q[1] - 0.25 end } } }
    assert.are.equal(#plain.events, #tr.events)
    assert(#tr.events >= 1)
    for i = 1, #tr.events do assert(math.abs(plain.events[i].t - tr.events[i].t) < 1e-10, i) end
    h.checkerror("simulate 'pendulum': event 1: 'direction' must be 1 (rising), -1 (falling) or 0 (either way), got 0.5",
      pendulum.simulate, pendulum, { q0 = { 1 }, t1 = 0.2, events = { { f = function(t) return t end, direction = 0.5 } } })
  end)
  it("an event that fails mid-run where its graph fails: the message from its Lua function, the part kept", function()
    -- nz.sqrt(q) records; where q < 0 the graph fails and the Lua function
    -- raises, with the event's name, the time and the state
    local ok, msg = pcall(pendulum.simulate, pendulum, { q0 = { 1 }, t1 = 2, dt = 0.1,
      events = { { f = function(t, q) return nz.sqrt(q[1]) - 0.5 end, name = "root" } } })
    assert.are.equal(false, ok)
    assert.truthy(msg:find("simulate 'pendulum': event 'root' raised an error at t = ", 1, true), msg)
    assert.truthy(msg:find("'sqrt' of a negative value", 1, true), msg)
    assert.are.equal("failed", nz.last.status)
    assert(#nz.last.events >= 1, #nz.last.events)
    -- it fails where th turns negative: after its first zero
    assert(nz.last.t[#nz.last.t] < quarter_period(1) + 0.1, nz.last.t[#nz.last.t])
  end)
end)

describe("projection (the violation computed in C, or in Lua above q')", function()
  it("a holonomic pendulum in Cartesian coordinates over a long run projects several times", function()
    local s = systems.cartesian_pendulum()
    math.randomseed(7)
    local t0, q0, qd0 = s.draw()
    local tr = s.sys:simulate{ t0 = t0, q0 = q0, qd0 = qd0, t1 = 20, rtol = 1e-7, atol = 1e-9, project = true }
    assert(tr.projections >= 5, tr.projections)
    for n = 1, #tr.t do assert(tr.violation[n] <= simulate.PROJECT_TOL * 1.0001, tr.violation[n]) end
  end)
  it("a fixed step (rk4) and a multistep method (msbdf, reset at each projection)", function()
    local s = systems.cartesian_pendulum()
    math.randomseed(8)
    local t0, q0, qd0 = s.draw()
    local b = s.sys:simulate{ t0 = t0, q0 = q0, qd0 = qd0, t1 = 5, dt = 0.1, step = 0.01, method = "rk4", project = true }
    assert(b.projections >= 5, b.projections)
    for n = 1, #b.t do assert(b.violation[n] <= simulate.PROJECT_TOL * 1.0001, b.violation[n]) end
    local c = s.sys:simulate{ t0 = t0, q0 = q0, qd0 = qd0, t1 = 1, method = "msbdf", rtol = 1e-7, atol = 1e-9, project = true }
    assert(c.projections >= 2, c.projections)
  end)
  it("nonholonomic: the rolling disk (rkf45) and the Chaplygin sleigh (msbdf)", function()
    -- tolerances loose enough for the velocity constraints to drift past
    -- the projection's tolerance within 20 s
    for _, c in ipairs{ { systems.rolling_disk, { method = "rkf45", rtol = 1e-3, atol = 1e-5, dt = 5 } },
                        { systems.sleigh, { method = "msbdf", rtol = 1e-5, atol = 1e-7 } } } do
      local s, opts = c[1](), c[2]
      math.randomseed(9)
      opts.t0, opts.q0, opts.qd0 = s.draw()
      opts.t1, opts.project = 20, true
      local b = s.sys:simulate(opts)
      assert(b.projections >= 2, s.name .. ": " .. b.projections)
    end
  end)
  it("msadams keeps the rolling disk on its constraints without projecting: its restarts no longer drift", function()
    -- each projection restarts msadams at order 1; while those first steps
    -- went unchecked each restart drifted past the projection's tolerance
    -- (1e-6 for a multistep method) again: 99 projections in 20 s at rtol
    -- 1e-4.  Held to a thousandth of the tolerance (src/ode/ode.c), the
    -- start drifts less than that tolerance over the whole run.
    local s = systems.rolling_disk()
    math.randomseed(9)
    local opts = { method = "msadams", rtol = 1e-4, atol = 1e-6 }
    opts.t0, opts.q0, opts.qd0 = s.draw()
    opts.t1, opts.project = 20, true
    local b = s.sys:simulate(opts)
    assert(b.projections == 0, b.projections)
    for n = 1, #b.t do assert(b.violation[n] <= 1e-6, b.violation[n]) end
  end)
  it("the violation in C is constraints.violation's, to the bit, on and off the constraints", function()
    local m, R, W = 0.3, 0.5, 4.0
    local hoop = { sys = nz.system{ name = "driven hoop", coords = { "th", "ph" },
      T = function(t, q, qd) return 0.5 * m * R * R * (qd[1] ^ 2 + nz.sin(q[1]) ^ 2 * qd[2] ^ 2) end,
      constraints = { function(t, q) return q[2] - W * t end } },
      draw = function() return 0.3, { 0.2, 1.2 }, { 0.1, W } end }
    math.randomseed(10)
    local checked = 0
    for _, s in ipairs{ systems.cartesian_pendulum(), systems.rolling_disk(), systems.sleigh(), systems.appell(), hoop } do
      local orders = {}
      for r, c in ipairs(constraints.classify(s.sys)) do orders[r] = c.order end
      for trial = 1, 20 do
        local t, q, qd = s.draw()
        local y = {}
        for i = 1, s.sys.k do   -- off the constraints by up to 1e-3 .. 1 after the first trials
          local eps = trial <= 2 and 0 or 10 ^ (-3 * math.random())
          y[i], y[s.sys.k + i] = q[i] + eps * (math.random() - 0.5), qd[i] + eps * (math.random() - 0.5)
        end
        local q2, qd2 = {}, {}
        for i = 1, s.sys.k do q2[i], qd2[i] = y[i], y[s.sys.k + i] end
        local want = constraints.violation(s.sys, t, q2, qd2)
        local got = mech.ode_run_violation(s.sys.engine, orders, t, y)
        assert.are.equal(bits(want), bits(got))
        checked = checked + 1
      end
    end
    assert.are.equal(100, checked)
  end)
  it("at level p >= 3 the loop asks Lua for the violation: projected, every point within the tolerance", function()
    -- a constraint nonlinear in q''' beside a circle: at rtol 1e-6 the circle
    -- drifts past PROJECT_TOL within 1 s (higher_order_spec measures it)
    local h3 = require("tests.constraint_systems").hamel3_on_circle()
    local s3, q0, qd0 = h3.sys, h3.q0, h3.qd0
    local tr = s3:simulate{ q0 = q0, qd0 = qd0, qdd0 = { 0.138, -0.416, 0.5 }, t1 = 1, dt = 0.25, rtol = 1e-6,
      atol = 1e-8, project = true }
    assert(tr.projections >= 1, "projections: " .. tr.projections)
    for n = 1, #tr.t do assert(tr.violation[n] <= simulate.PROJECT_TOL * 1.0001, tr.violation[n]) end
  end)
end)

describe("the options of the loop", function()
  it("no internal option is offered among the options", function()
    local ok, err = pcall(pendulum.simulate, pendulum, { q0 = { 1 }, t1 = 1, nope = 1 })
    assert.are.equal(false, ok)
    local list = err:match("unknown option 'nope' %(options: ([^)]*)%)")
    assert.truthy(list, err)
    assert.truthy(list:find("q0", 1, true), list)
    for name in list:gmatch("[^, ]+") do assert(name:sub(1, 1) ~= "_", name) end
  end)
  it("the memory cap refuses a grid too fine, with the limit and a dt that fits", function()
    local saved = simulate.MAX_MEMORY
    simulate.MAX_MEMORY = 5e4                   -- 80 bytes a point (1 DOF): 1001 points do not fit
    local ok, err = pcall(pendulum.simulate, pendulum, { q0 = { 1 }, t1 = 1, dt = 0.001 })
    simulate.MAX_MEMORY = saved
    assert.are.equal(false, ok)
    assert.truthy(tostring(err):find("are kept in memory (require('nz.motion.simulate').MAX_MEMORY)", 1, true), err)
    assert.truthy(tostring(err):find("simulate_loop_spec.lua:", 1, true), err)
  end)
end)

describe("pauses of the loop change nothing", function()
  it("a pause after every step (the progress bar's) and the long-run checks (at 16, 32, ... steps)", function()
    -- progress = true makes the loop return every PROGRESS_PAUSE seconds: 0
    -- returns after every step.  The run stays under the bar's 0.5 s, so
    -- nothing is drawn.  Whatever the pauses, the run is the same.
    local said, saved_warn, saved_limits, saved_pause = {}, simulate.warn, simulate.LONG_RUN, simulate.PROGRESS_PAUSE
    simulate.warn = function(msg) said[#said + 1] = msg end
    simulate.LONG_RUN = { steps = 50, seconds = math.huge, check_steps = 16 }
    local opts = { q0 = { 0.3 }, t1 = 1, dt = 0.1, step = 0.01, method = "rk4" }
    local ok, quiet = pcall(pendulum.simulate, pendulum, opts)
    simulate.PROGRESS_PAUSE = 0
    opts.progress = true
    local ok2, paused = pcall(pendulum.simulate, pendulum, opts)
    simulate.warn, simulate.LONG_RUN, simulate.PROGRESS_PAUSE = saved_warn, saved_limits, saved_pause
    assert(ok and ok2, tostring(quiet) .. tostring(paused))
    for _, key in ipairs{ "t", "q", "qd", "qdd", "lambda" } do
      local d = differ(quiet[key], paused[key], key)
      assert(d == nil, d)
    end
    -- 100 steps projected from the check at 16 steps > 50: said once by each
    -- run, in the same words but for the duration, which is measured
    assert.are.equal(2, #said)
    local function words(msg) return (msg:gsub("^[^:]*:%d+: ", ""):gsub("steps and [^%(]*%(", "steps and ... (")) end
    assert.are.equal(words(said[1]), words(said[2]))
    assert.truthy(said[2]:find("after 16 steps", 1, true), said[2])
    assert.are.equal(said[2], paused.warnings[1])
  end)
end)

describe("a run that stops keeps what it computed", function()
  local hook = function() end
  -- hook changes after the system is made: a recording would not see it (these
  -- tests are about the loop's failure paths, with functions run by Lua)
  local hooked = nz.system{ name = "hooked", coords = { "th" }, compile = false,
    T = function(t, q, qd) return 0.5 * qd[1] ^ 2 end,
    V = function(t, q) hook(t, q); return -g * nz.cos(q[1]) end }
  after_each(function()
    hook = function() end
    mech._set_interrupt(false)
  end)

  it("the interrupt (as Ctrl-C requests it) stops before the next step: the points before it, to the bit", function()
    local fired = false
    hook = function(t) if t > 0.5 and not fired then fired = true; mech._set_interrupt(true) end end
    local tr = hooked:simulate{ q0 = { 0.385 }, t1 = 1, dt = 0.05, dense = false }
    mech._set_interrupt(false)
    hook = function() end
    assert.are.equal("interrupted", tr.status)
    assert(#tr.t >= 10 and tr.t[#tr.t] <= 0.55, ("%d points up to t = %g"):format(#tr.t, tr.t[#tr.t]))
    assert.truthy(tr.message:find("stopped by Ctrl-C at t = ", 1, true), tr.message)
    local ref = h.reference_run(hooked, { q0 = { 0.385 }, t1 = 1, dt = 0.05 })
    for n = 1, #tr.t do assert.are.equal(bits(ref.q[n][1]), bits(tr.q[n][1])) end
  end)
  it("the interrupt object raised in a user function", function()
    hook = function(t) if t > 0.5 then error(nz.interrupted) end end
    local tr = hooked:simulate{ q0 = { 0.385 }, t1 = 1, dt = 0.1, dense = false }
    assert.are.equal("interrupted", tr.status)
    assert(tr.t[#tr.t] <= 0.6 and #tr.t >= 5, tr.t[#tr.t])
  end)
  it("an error in a user function mid-run: the message, the part in nz.last", function()
    hook = function(t) if t > 0.5 then error("a deliberate failure") end end
    local ok, msg = pcall(hooked.simulate, hooked, { q0 = { 0.385 }, t1 = 1, dt = 0.1 })
    assert.are.equal(false, ok)
    assert.truthy(msg:find("system 'hooked': V raised an error: a deliberate failure at t = ", 1, true), msg)
    assert.truthy(msg:find("is kept in nz.last", 1, true), msg)
    assert.are.equal("failed", nz.last.status)
    assert(#nz.last.t >= 5, #nz.last.t)
  end)
  it("a NaN from a user function mid-run (the integrator's failure)", function()
    local nan = nz.system{ name = "nan", coords = { "th" },
      T = function(t, q, qd) return 0.5 * qd[1] ^ 2 end,
      V = function(t, q) if t > 0.3 then return q[1] * (0 / 0) end; return -g * nz.cos(q[1]) end }
    local ok, msg = pcall(nan.simulate, nan, { q0 = { 0.385 }, t1 = 1, dt = 0.1 })
    assert.are.equal(false, ok)
    assert.truthy(msg:find("system 'nan'", 1, true), msg)
  end)
  it("a run that stops making progress: the message, M's singular values and the state", function()
    -- M = 1 - t/2 vanishes at t = 2 (simulate_options_spec)
    local sys = nz.system{ name = "degenerating", coords = { "x" },
      T = function(t, q, qd) return 0.5 * (1 - t / 2) * qd[1] ^ 2 end }
    local ok, msg = pcall(sys.simulate, sys, { q0 = { 0 }, qd0 = { 1 }, t1 = 3 })
    assert.are.equal(false, ok)
    assert.truthy(msg:find("simulate 'degenerating': the integrator (rk8pd) stopped making progress", 1, true), msg)
    assert.truthy(msg:find("singular values from", 1, true), msg)
  end)
end)
