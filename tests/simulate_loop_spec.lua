-- simulate_loop_spec.lua - the stepping loop in C (src/ode/ode_run.c) against
-- the loop in Lua (lua/nz/motion/simulate.lua, run()): two paths that share the
-- integrator but not the loop (output grid, fixed steps landing on the
-- output times, accelerations recorded at each point, stall detection,
-- interrupt, failures).  Each run is made twice, forced through each loop
-- by the internal option _loop, and everything the trajectory holds must
-- agree to the bit: times, states, accelerations, multipliers, monitors,
-- violations, statistics, status, messages and warnings.
local h = require "tests.helpers"
local nz = h.nz
local simulate = require "nz.motion.simulate"
local mech = require("nz.core").mech
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

-- What a trajectory holds, without what may differ by design: the wall
-- time, the loop's name, and the system (the same object in both).
local function content(tr)
  local c = {}
  for key, v in pairs(tr) do
    if key ~= "system" and key ~= "stats" then c[key] = v end
  end
  if tr.warnings then
    c.warnings = {}
    for i, w in ipairs(tr.warnings) do c.warnings[i] = w:gsub("steps and [^%(]*%(", "steps and ... (") end
  end
  c.stats = { steps = tr.stats.steps, rejected = tr.stats.rejected, nfev = tr.stats.nfev, njev = tr.stats.njev }
  return c
end

local function with_loop(opts, loop)
  local o = {}
  for key, v in pairs(opts) do o[key] = v end
  o._loop = loop
  -- the Lua loop has no dense output: both loops stop at every output point
  if o.dense == nil then o.dense = false end
  return o
end

-- Runs whose long-run notice depends on steps only: the clock's criterion
-- (seconds) would make the two runs' warnings differ with the machine's load.
local function by_steps(f, ...)
  local saved = simulate.LONG_RUN
  simulate.LONG_RUN = { steps = saved.steps, seconds = math.huge, check_steps = saved.check_steps }
  local r = table.pack(pcall(f, ...))
  simulate.LONG_RUN = saved
  if not r[1] then error(r[2], 0) end
  return table.unpack(r, 2, r.n)
end

-- Run opts through both loops; returns the two trajectories, after checking
-- that each went through the loop asked for and that they agree to the bit.
-- (Both runs are made on one line: warnings and messages start with it.)
local function both(sys, opts)
  local trs = {}
  for _, loop in ipairs{ "lua", "c" } do trs[loop] = by_steps(sys.simulate, sys, with_loop(opts, loop)) end
  local a, b = trs.lua, trs.c
  assert.are.equal("lua", a.stats.loop)
  assert.are.equal("c", b.stats.loop)
  assert(#a.t >= 2, ("only %d points"):format(#a.t))
  local d = differ(content(a), content(b), "tr")
  assert(d == nil, d)
  return a, b
end

-- Both loops fail (pcall), with the same message, keeping the same part in nz.last.
local function both_fail(sys, opts)
  local r = {}
  for i, loop in ipairs{ "lua", "c" } do r[i] = { pcall(by_steps, sys.simulate, sys, with_loop(opts, loop)) }; r[i][3] = nz.last end
  local ok1, err1, last1, ok2, err2, last2 = r[1][1], r[1][2], r[1][3], r[2][1], r[2][2], r[2][3]
  assert.are.equal(false, ok1)
  assert.are.equal(false, ok2)
  assert.are.equal(tostring(err1), tostring(err2))
  assert.are.equal("c", last2.stats.loop)
  local d = differ(content(last1), content(last2), "nz.last")
  assert(d == nil, d)
  return tostring(err1), last1
end

local pendulum = nz.system{ name = "pendulum", coords = { "th" },
  T = function(t, q, qd) return 0.5 * qd[1] ^ 2 end,
  V = function(t, q) return -g * nz.cos(q[1]) end }

-- Two coupled oscillators with a driven term, 2 DOF.
local coupled = nz.system{ name = "coupled", coords = { "x", "y" },
  T = function(t, q, qd) return 0.5 * (qd[1] ^ 2 + 2 * qd[2] ^ 2) end,
  V = function(t, q) return 0.5 * (q[1] ^ 2 + 3 * q[2] ^ 2) + 0.4 * (q[1] - q[2]) ^ 2 - 0.1 * nz.sin(t) * q[1] end }

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

describe("the C loop and the Lua loop give the same run, to the bit", function()
  it("adaptive rk8pd with both monitors on an output grid with dt", function()
    local _, b = both(pendulum, { q0 = { 1.2 }, t1 = 5, dt = 0.05, monitors = { energy = true } })
    assert.are.equal(101, #b.t)
    assert.are.equal(5, b.t[#b.t])                       -- the last point is t1 itself
  end)
  it("a grid that does not divide the span, and more points than the C loop buffers (1024)", function()
    local _, b = both(coupled, { q0 = { 0.3, -0.2 }, qd0 = { 0, 0.1 }, t1 = 3.05, dt = 0.001 })
    assert.are.equal(3051, #b.t)
  end)
  for _, method in ipairs{ "rk2", "rk4", "rkf45", "rkck", "rk8pd", "rk1imp", "rk2imp", "rk4imp", "bsimp", "msadams", "msbdf" } do
    it(method .. ", adaptive, on two coupled oscillators", function()
      local low = method == "rk2" or method == "rk1imp" or method == "rk2imp"   -- few steps at a low order
      both(coupled, { q0 = { 0.3, -0.2 }, qd0 = { 0, 0.1 }, t1 = 1, dt = 0.25, method = method,
        rtol = low and 1e-5 or 1e-8, atol = low and 1e-7 or 1e-10 })
    end)
  end
  for _, method in ipairs{ "rk4", "rk8pd", "rk2imp", "rk4imp" } do
    it(method .. " at a fixed step that does not divide dt (the steps land on each output time)", function()
      local _, b = both(pendulum, { q0 = { 0.7 }, t1 = 2, dt = 0.1, step = 0.03, method = method })
      -- ceil(0.1 / 0.03) = 4 equal steps per output interval
      assert.are.equal(80, b.stats.steps)
    end)
  end
  it("a first step h0 and an output grid coarser than the span", function()
    both(pendulum, { q0 = { 0.7 }, t1 = 1, dt = 3, h0 = 1e-6 })
  end)
end)

describe("constrained systems", function()
  it("a holonomic pendulum in Cartesian coordinates: violation, multipliers (no projection)", function()
    local s = systems.cartesian_pendulum()
    math.randomseed(4)
    local t0, q0, qd0 = s.draw()
    local a = both(s.sys, { t0 = t0, q0 = q0, qd0 = qd0, t1 = 2, dt = 0.1 })
    assert(#a.violation == #a.t and #a.lambda[1] == 1)
  end)
  it("Baumgarte's stabilization", function()
    local s = systems.cartesian_pendulum()
    math.randomseed(5)
    local t0, q0, qd0 = s.draw()
    both(s.sys, { t0 = t0, q0 = q0, qd0 = qd0, t1 = 1, dt = 0.1, baumgarte = 5 })
  end)
  it("Appell's constraint, nonlinear in the velocities: Newton starts from the last root in both", function()
    local s = systems.appell()
    math.randomseed(6)
    local t0, q0, qd0 = s.draw()
    both(s.sys, { t0 = t0, q0 = q0, qd0 = qd0, t1 = 1, dt = 0.1 })
  end)
  it("a moving constraint with the work monitor, bsimp", function()
    local h = systems.driven_hoop()
    local hoop, W = h.sys, h.W
    local a = both(hoop, { q0 = { 0.7, 0 }, qd0 = { 0.3, W }, t1 = 1, dt = 0.1, method = "bsimp", monitors = { work = true } })
    assert(#a.work == #a.t)
  end)
  it("a constraint nonlinear in q''' (level 3, q''' solved): the roots and the branch", function()
    local M, Q = 1.3, { 0.7, -0.4, 2.0 }
    local sys = nz.system{ name = "hamel3", coords = { "q1", "q2", "q3" },
      T = function(t, q, qd) return 0.5 * M * (qd[1] ^ 2 + qd[2] ^ 2 + qd[3] ^ 2) end,
      Q = function() return { Q[1], Q[2], Q[3] } end,
      constraints = { function(t, q, qd, qdd, qddd) return qddd[3] - qddd[1] * qddd[2] end } }
    local a = both(sys, { q0 = { 0.2, -0.1, 0.3 }, qd0 = { 0.4, -0.5, 0.6 }, qdd0 = { 0.3, -0.2, 0.5 }, t1 = 1, dt = 0.25 })
    assert(a.top and #a.top == #a.t and a.branch)
  end)
  it("a servo constraint of order 4 (the state holds q'', q''' and the multiplier)", function()
    local mass, F1, F2, l0 = 1.7, 0.3, -0.45, 0.385
    local sys = nz.system{ name = "servo4", coords = { "x", "y" },
      T = function(t, q, qd) return 0.5 * mass * (qd[1] ^ 2 + qd[2] ^ 2) end,
      Q = function() return { F1, F2 } end,
      constraints = { function(t, q, qd, qdd, qddd, q4d, params) return q4d[1] + 2 * q4d[2] - nz.cos(t) end } }
    local a = both(sys, { q0 = { -0.3, 0.8 }, qd0 = { 0.05, 0.4 }, qdd0 = { (F1 + l0) / mass, (F2 + 2 * l0) / mass },
      q3d0 = { 0.3, 0.6 }, t1 = 0.5, dt = 0.1 })
    assert(a.higher and #a.higher == #a.t)
  end)
end)

describe("events in the C loop (recorded once as graphs, evaluated in C after every step)", function()
  -- th crosses 0 about every 1 s at this amplitude; qd crosses 0 at the turns.
  it("several events, either way, rising and falling, none stopping; each says which way it crossed", function()
    local a, b = both(pendulum, { q0 = { 1 }, t1 = 5, dt = 0.1, events = {
      { f = function(t, q) return q[1] end, name = "zero" },
      { f = function(t, q, qd) return qd[1] end, direction = 1, name = "left turn" },
      { f = function(t, q, qd) return qd[1] end, direction = -1, name = "right turn" } } })
    assert.are.equal("done", b.status)
    local n = {}
    for _, ev in ipairs(b.events) do n[ev.name] = (n[ev.name] or 0) + 1 end
    assert(n.zero >= 4 and n["left turn"] >= 2 and n["right turn"] >= 2, #b.events)
    -- the turns alternate: a rising qd is a left turn (th at its minimum)
    for _, ev in ipairs(b.events) do
      if ev.name == "left turn" then assert(ev.q[1] < 0) end
      if ev.name == "right turn" then assert(ev.q[1] > 0) end
    end
    assert.are.equal(#a.events, #b.events)
    -- each says which way it crossed: th through 0 the way th' goes there,
    -- the turns as their filters ask; the same with events located in C on
    -- Taylor's polynomial, and on a GSL stepper's interpolant
    local function check_directions(tr, what)
      for i, ev in ipairs(tr.events) do
        local want = ev.name == "zero" and (ev.qd[1] > 0 and 1 or -1) or ev.name == "left turn" and 1 or -1
        assert(ev.direction == want, ("%s: event %d (%s at t = %.6f) crossed %s, said %s"):format(what, i, ev.name, ev.t,
          want, tostring(ev.direction)))
      end
    end
    check_directions(a, "the Lua loop")
    check_directions(b, "the C loop")
    for _, method in ipairs{ "taylor", "rk8pd" } do
      local tr = pendulum:simulate{ q0 = { 1 }, t1 = 5, dt = 0.1, method = method, events = {
        { f = function(t, q) return q[1] end, name = "zero" },
        { f = function(t, q, qd) return qd[1] end, direction = 1, name = "left turn" },
        { f = function(t, q, qd) return qd[1] end, direction = -1, name = "right turn" } } }
      assert.are.equal(#b.events, #tr.events)
      check_directions(tr, method .. " with dense output")
    end
  end)
  it("a stopping event: the point where it stops ends the trajectory (with the monitors recorded there)", function()
    local _, b = both(pendulum, { q0 = { 1 }, t1 = 5, dt = 0.1, monitors = { energy = true },
      events = { { f = function(t, q) return q[1] end, direction = -1, stop = true, name = "down" } } })
    assert.are.equal(#b.t, #b.energy)
    assert.are.equal("stopped", b.status)
    assert.are.equal(1, #b.events)
    assert.are.equal(b.events[1].t, b.t[#b.t])
    assert(math.abs(b.q[#b.q][1]) < 1e-10, b.q[#b.q][1])
  end)
  it("two events in one step: both, in their order; the C loop resumes with the next event of the step", function()
    -- fixed steps of 0.1: t = 0.33 and t = 0.36 fall in the step [0.3, 0.4]
    local _, b = both(pendulum, { q0 = { 0.5 }, t1 = 1, dt = 0.5, step = 0.1, method = "rk4",
      events = { function(t) return t - 0.36 end, function(t) return t - 0.33 end, function(t) return t - 0.72 end } })
    assert.are.equal(3, #b.events)
    assert.are.equal("event 1", b.events[1].name)          -- in the order of the list, not of time
    assert.are.equal("event 2", b.events[2].name)
    assert(math.abs(b.events[1].t - 0.36) < 1e-11 and math.abs(b.events[2].t - 0.33) < 1e-11, b.events[2].t)
    -- the first of the two stops: the second, in the same step, is not seen
    local _, c = both(pendulum, { q0 = { 0.5 }, t1 = 1, dt = 0.5, step = 0.1, method = "rk4",
      events = { { f = function(t) return t - 0.36 end, stop = true }, function(t) return t - 0.33 end } })
    assert.are.equal(1, #c.events)
    assert.are.equal("stopped", c.status)
  end)
  it("an event at an output time (a step lands on the zero)", function()
    local _, b = both(pendulum, { q0 = { 1 }, t1 = 0.1, dt = 0.005, events = { function(t) return t - 0.05 end } })
    assert.are.equal(1, #b.events)
    assert.are.equal(0.05, b.events[1].t)
    assert.are.equal(21, #b.t)
  end)
  it("a parameter and a branch written with nz.ifelse are recorded; events and projection together", function()
    local s = systems.cartesian_pendulum()
    math.randomseed(7)
    local t0, q0, qd0 = s.draw()
    s.sys.params.level = 0.2
    local _, b = both(s.sys, { t0 = t0, q0 = q0, qd0 = qd0, t1 = 20, rtol = 1e-6, atol = 1e-8, project = true,
      events = { function(t, q, qd, params) return nz.ifelse(nz.gt(q[2], 0), 1, q[2] + params.level) end,
                 { f = function(t, q) return q[1] end, direction = 1 } } })
    s.sys.params.level = nil
    assert(b.projections >= 2, b.projections)
    assert(#b.events >= 2, #b.events)
  end)
  it("events on a system with a moving constraint and the work monitor, bsimp", function()
    local h = systems.driven_hoop()
    local hoop, W = h.sys, h.W
    local _, b = both(hoop, { q0 = { 0.7, 0 }, qd0 = { 0.3, W }, t1 = 2, dt = 0.1, method = "bsimp", monitors = { work = true },
      events = { function(t, q, qd) return qd[1] end } })
    assert(#b.events >= 1)
  end)
  it("the located times are those of the events' Lua functions (a system not recorded) to 1e-10", function()
    local plain = nz.system{ name = "pendulum", coords = { "th" }, compile = false,
      T = function(t, q, qd) return 0.5 * qd[1] ^ 2 end,
      V = function(t, q) return -g * nz.cos(q[1]) end }
    local opts = { q0 = { 1 }, t1 = 5, events = { function(t, q) return q[1] * q[1] - 0.25 end } }
    local a, b = plain:simulate(opts), pendulum:simulate(opts)
    assert.are.equal("lua", a.stats.loop)
    assert.truthy(a.stats.loop_why:find("compile = false", 1, true), a.stats.loop_why)
    assert.are.equal("c", b.stats.loop)
    assert.are.equal(#a.events, #b.events)
    assert(#a.events >= 8, #a.events)
    for i = 1, #a.events do assert(math.abs(a.events[i].t - b.events[i].t) < 1e-10, i) end
  end)
  it("an event function that branches in Lua keeps the run in the Lua loop, and says why", function()
    local ev = function(t, q) if q[1] > 0.5 then return 1 end return q[1] - 0.25 end
    local tr = pendulum:simulate{ q0 = { 1 }, t1 = 2, events = { { f = ev, name = "branchy" } } }
    assert.are.equal("lua", tr.stats.loop)
    assert.truthy(tr.stats.loop_why:find("event 'branchy' cannot be recorded (compares a traced value", 1, true), tr.stats.loop_why)
    assert.truthy(tr.stats.loop_why:find("simulate_loop_spec.lua:", 1, true), tr.stats.loop_why)
    assert(#tr.events >= 1)
    h.checkerror("'_loop' = \"c\": this run needs the Lua loop (event 'branchy' cannot be recorded", pendulum.simulate,
      pendulum, { q0 = { 1 }, t1 = 2, events = { { f = ev, name = "branchy" } }, _loop = "c" })
    h.checkerror("'_loop' (internal, for tests) must be \"lua\" or \"c\", got \"fast\"", pendulum.simulate, pendulum,
      { q0 = { 1 }, t1 = 0.2, _loop = "fast" })
    h.checkerror("simulate 'pendulum': event 1: 'direction' must be 1 (rising), -1 (falling) or 0 (either way), got 0.5",
      pendulum.simulate, pendulum, { q0 = { 1 }, t1 = 0.2, events = { { f = function(t) return t end, direction = 0.5 } } })
  end)
  it("an event that fails mid-run where its graph fails: the same message, from its Lua function", function()
    -- nz.sqrt(q) records; where q < 0 the graph fails and the Lua function
    -- raises, with the event's name, the time and the state
    local msg, last = both_fail(pendulum, { q0 = { 1 }, t1 = 2, dt = 0.1,
      events = { { f = function(t, q) return nz.sqrt(q[1]) - 0.5 end, name = "root" } } })
    assert.truthy(msg:find("simulate 'pendulum': event 'root' raised an error at t = ", 1, true), msg)
    assert.truthy(msg:find("'sqrt' of a negative value", 1, true), msg)
    assert.are.equal("failed", last.status)
    assert(#last.events >= 1, #last.events)
  end)
end)

describe("projection in the C loop (the violation computed in C)", function()
  it("a holonomic pendulum in Cartesian coordinates over a long run projects several times", function()
    local s = systems.cartesian_pendulum()
    math.randomseed(7)
    local t0, q0, qd0 = s.draw()
    local _, b = both(s.sys, { t0 = t0, q0 = q0, qd0 = qd0, t1 = 20, rtol = 1e-7, atol = 1e-9, project = true })
    assert(b.projections >= 5, b.projections)
    for n = 1, #b.t do assert(b.violation[n] <= simulate.PROJECT_TOL * 1.0001, b.violation[n]) end
  end)
  it("a fixed step (rk4) and a multistep method (msbdf, reset at each projection)", function()
    local s = systems.cartesian_pendulum()
    math.randomseed(8)
    local t0, q0, qd0 = s.draw()
    local _, b = both(s.sys, { t0 = t0, q0 = q0, qd0 = qd0, t1 = 5, dt = 0.1, step = 0.01, method = "rk4", project = true })
    assert(b.projections >= 5, b.projections)
    local _, c = both(s.sys, { t0 = t0, q0 = q0, qd0 = qd0, t1 = 1, method = "msbdf", rtol = 1e-7, atol = 1e-9, project = true })
    assert(c.projections >= 2, c.projections)
  end)
  it("nonholonomic: the rolling disk (rkf45, msadams) and the Chaplygin sleigh (msbdf)", function()
    -- tolerances loose enough for the velocity constraints to drift past
    -- the projection's tolerance within 20 s
    for _, c in ipairs{ { systems.rolling_disk, { method = "rkf45", rtol = 1e-3, atol = 1e-5, dt = 5 } },
                        { systems.rolling_disk, { method = "msadams", rtol = 1e-4, atol = 1e-6 } },
                        { systems.sleigh, { method = "msbdf", rtol = 1e-5, atol = 1e-7 } } } do
      local s, opts = c[1](), c[2]
      math.randomseed(9)
      opts.t0, opts.q0, opts.qd0 = s.draw()
      opts.t1, opts.project = 20, true
      local _, b = both(s.sys, opts)
      assert(b.projections >= 2, s.name .. ": " .. b.projections)
    end
  end)
  it("the violation in C is constraints.violation's, to the bit, on and off the constraints", function()
    local m, R, W = 0.3, 0.5, 4.0
    local hoop = { sys = nz.system{ name = "driven hoop", coords = { "th", "ph" },
      T = function(t, q, qd) return 0.5 * m * R * R * (qd[1] ^ 2 + nz.sin(q[1]) ^ 2 * qd[2] ^ 2) end,
      constraints = { function(t, q) return q[2] - W * t end } },
      draw = function() return 0.3, { 0.2, 1.2 }, { 0.1, W } end }
    local constraints = require "nz.model.constraints"
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
  it("at level p >= 3 projection stays in the Lua loop: taken by default, refused when the C loop is forced", function()
    local mass, F1, F2, l0 = 1.7, 0.3, -0.45, 0.385
    local sys = nz.system{ name = "servo4", coords = { "x", "y" },
      T = function(t, q, qd) return 0.5 * mass * (qd[1] ^ 2 + qd[2] ^ 2) end,
      Q = function() return { F1, F2 } end,
      constraints = { function(t, q, qd, qdd, qddd, q4d, params) return q4d[1] + 2 * q4d[2] - nz.cos(t) end } }
    local opts = { q0 = { -0.3, 0.8 }, qd0 = { 0.05, 0.4 }, qdd0 = { (F1 + l0) / mass, (F2 + 2 * l0) / mass },
      q3d0 = { 0.3, 0.6 }, t1 = 0.5, dt = 0.1, project = true }
    local tr = sys:simulate(opts)
    assert.are.equal("lua", tr.stats.loop)
    assert.truthy(tr.stats.loop_why:find("project = true with constraints of order 4", 1, true), tr.stats.loop_why)
    opts._loop = "c"
    h.checkerror("'_loop' = \"c\": this run needs the Lua loop (project = true with constraints of order 4", sys.simulate, sys, opts)
  end)
end)

describe("which loop runs", function()
  it("the C loop by default, with events and with projection", function()
    assert.are.equal("c", pendulum:simulate{ q0 = { 1 }, t1 = 0.2 }.stats.loop)
    local tr = pendulum:simulate{ q0 = { 1 }, t1 = 0.2, events = { function(t) return t - 0.1 end } }
    assert.are.equal("c", tr.stats.loop)
    assert.is_nil(tr.stats.loop_why)
    assert.are.equal(1, #tr.events)
    local s = systems.cartesian_pendulum()
    math.randomseed(7)
    local t0, q0, qd0 = s.draw()
    assert.are.equal("c", s.sys:simulate{ t0 = t0, q0 = q0, qd0 = qd0, t1 = 0.5, project = true }.stats.loop)
  end)
  it("the internal option is not offered among the options", function()
    local ok, err = pcall(pendulum.simulate, pendulum, { q0 = { 1 }, t1 = 1, nope = 1 })
    assert.are.equal(false, ok)
    local list = err:match("unknown option 'nope' %(options: ([^)]*)%)")
    assert.truthy(list, err)
    assert.truthy(list:find("q0", 1, true), list)
    assert.falsy(list:find("_loop", 1, true), list)
  end)
end)

describe("the limits hold for both loops", function()
  it("the memory cap refuses the same grid with the same message", function()
    local saved = simulate.MAX_MEMORY
    simulate.MAX_MEMORY = 1e5                   -- 464 bytes a point (1 DOF): 1001 points do not fit
    local errs = {}
    for i, loop in ipairs{ "lua", "c" } do
      errs[i] = select(2, pcall(pendulum.simulate, pendulum, { q0 = { 1 }, t1 = 1, dt = 0.001, _loop = loop }))
    end
    simulate.MAX_MEMORY = saved
    assert.truthy(tostring(errs[1]):find("are kept in memory (require('nz.motion.simulate').MAX_MEMORY)", 1, true), errs[1])
    assert.are.equal(errs[1], errs[2])
  end)
end)

describe("pauses of the C loop change nothing", function()
  it("a pause after every step (the progress bar's) and the long-run checks (at 16, 32, ... steps)", function()
    -- progress = true makes the C loop return every PROGRESS_PAUSE seconds:
    -- 0 returns after every step.  The run stays under the bar's 0.5 s, so
    -- nothing is drawn.  Whatever the pauses, the run is the same.
    local said, saved_warn, saved_limits, saved_pause = {}, simulate.warn, simulate.LONG_RUN, simulate.PROGRESS_PAUSE
    simulate.warn = function(msg) said[#said + 1] = msg end
    simulate.LONG_RUN = { steps = 50, seconds = math.huge, check_steps = 16 }
    simulate.PROGRESS_PAUSE = 0
    local ok, a, b = pcall(both, pendulum, { q0 = { 0.3 }, t1 = 1, dt = 0.1, step = 0.01, method = "rk4", progress = true })
    simulate.warn, simulate.LONG_RUN, simulate.PROGRESS_PAUSE = saved_warn, saved_limits, saved_pause
    assert(ok, tostring(a))
    -- 100 steps projected from the check at 16 steps > 50: said once by each
    -- loop, in the same words but for the duration, which is measured
    assert.are.equal(2, #said)
    local function words(msg) return (msg:gsub("steps and [^%(]*%(", "steps and ... (")) end
    assert.are.equal(words(said[1]), words(said[2]))
    assert.truthy(said[2]:find("after 16 steps", 1, true), said[2])
    assert.are.equal(said[2], b.warnings[1])
    assert.are.equal(1, #a.warnings)
  end)
end)

describe("a run that stops keeps the same part in both loops", function()
  local hook = function() end
  -- hook changes after the system is made: a recording would not see it (these
  -- tests are about the loops' failure paths, with functions run by Lua)
  local hooked = nz.system{ name = "hooked", coords = { "th" }, compile = false,
    T = function(t, q, qd) return 0.5 * qd[1] ^ 2 end,
    V = function(t, q) hook(t, q); return -g * nz.cos(q[1]) end }
  after_each(function()
    hook = function() end
    mech._set_interrupt(false)
  end)

  it("the interrupt (as Ctrl-C requests it) stops before the next step: status and points", function()
    local trs = {}
    for _, loop in ipairs{ "lua", "c" } do
      local fired = false
      hook = function(t) if t > 0.5 and not fired then fired = true; mech._set_interrupt(true) end end
      trs[loop] = by_steps(hooked.simulate, hooked, { q0 = { 0.385 }, t1 = 1, dt = 0.05, _loop = loop, dense = false })
      mech._set_interrupt(false)
    end
    assert.are.equal("interrupted", trs.c.status)
    assert(#trs.c.t >= 10 and trs.c.t[#trs.c.t] <= 0.55, ("%d points up to t = %g"):format(#trs.c.t, trs.c.t[#trs.c.t]))
    local d = differ(content(trs.lua), content(trs.c), "tr")
    assert(d == nil, d)
    assert.truthy(trs.c.message:find("stopped by Ctrl-C at t = ", 1, true), trs.c.message)
  end)
  it("the interrupt object raised in a user function", function()
    local trs = {}
    for _, loop in ipairs{ "lua", "c" } do
      hook = function(t) if t > 0.5 then error(nz.interrupted) end end
      trs[loop] = by_steps(hooked.simulate, hooked, { q0 = { 0.385 }, t1 = 1, dt = 0.1, _loop = loop, dense = false })
    end
    assert.are.equal("interrupted", trs.c.status)
    local d = differ(content(trs.lua), content(trs.c), "tr")
    assert(d == nil, d)
  end)
  it("an error in a user function mid-run: the same message, the same part in nz.last", function()
    hook = function(t) if t > 0.5 then error("a deliberate failure") end end
    local msg, last = both_fail(hooked, { q0 = { 0.385 }, t1 = 1, dt = 0.1 })
    assert.truthy(msg:find("system 'hooked': V raised an error: a deliberate failure at t = ", 1, true), msg)
    assert.truthy(msg:find("is kept in nz.last", 1, true), msg)
    assert.are.equal("failed", last.status)
    assert(#last.t >= 5, #last.t)
  end)
  it("a NaN from a user function mid-run (the integrator's failure)", function()
    hook = function(t) if t > 0.3 then return 0 / 0 end end
    local nan = nz.system{ name = "nan", coords = { "th" },
      T = function(t, q, qd) return 0.5 * qd[1] ^ 2 end,
      V = function(t, q) if t > 0.3 then return q[1] * (0 / 0) end; return -g * nz.cos(q[1]) end }
    local msg = both_fail(nan, { q0 = { 0.385 }, t1 = 1, dt = 0.1 })
    assert.truthy(msg:find("system 'nan'", 1, true), msg)
  end)
  it("a run that stops making progress: the same message, M's singular values and the state", function()
    -- M = 1 - t/2 vanishes at t = 2 (simulate_options_spec)
    local sys = nz.system{ name = "degenerating", coords = { "x" },
      T = function(t, q, qd) return 0.5 * (1 - t / 2) * qd[1] ^ 2 end }
    local msg = both_fail(sys, { q0 = { 0 }, qd0 = { 1 }, t1 = 3 })
    assert.truthy(msg:find("simulate 'degenerating': the integrator (rk8pd) stopped making progress", 1, true), msg)
  end)
end)
