-- nz/motion/simulate.lua - sys:simulate{...}: integrate the motion with a GSL
-- stepper (src/ode/ode.c), one step at a time, so that this loop decides the
-- output grid, locates events, projects onto the constraints, records the
-- monitors a scene asked for (and nothing else), shows progress on a
-- terminal, and keeps what it computed when interrupted or when it fails.
-- A run goes through the same loop written in C (src/ode/ode_run.c, run_c
-- below), which watches the events (recorded once as graphs) and the drift
-- off the constraints after every step, and returns here only to locate an
-- event, to project, to hand over output points, draw the progress, warn of
-- a long run, or stop; the two give the same trajectory to the bit
-- (tests/simulate_loop_spec.lua).  The Lua loop (run below) remains for an
-- event function that cannot be recorded and for projection with
-- constraints of order >= 3 (tr.stats.loop_why says which).
-- method = "taylor" (Taylor's method, src/ode/taylor.c) is an integrator of
-- the same interface (src/ode/stepper.h) and runs in the same C loop, which
-- locates its events on the step's polynomial itself ("located" below); it
-- has no Lua loop.
-- The option _loop = "lua" | "c" forces one: internal, for tests and bench/.
local core = require "nz.core"
local constraints = require "nz.model.constraints"
local record_graph = require "nz.model.record"
local trajectory = require "nz.motion.trajectory"

local mech = core.mech
local M = {}

-- Defaults chosen so that a first run is accurate: an 8th-order adaptive
-- method at tight tolerances (documented in help(nz.system)).
M.defaults = { method = "rk8pd", rtol = 1e-10, atol = 1e-12, points = 200, event_tol = 1e-12 }

-- q3d0, q4d0, ...: the start of higher levels (constraints of order >= 3).
local function level_option(key) return type(key) == "string" and key:match("^q%d+d0$") ~= nil end
local known = require("nz.base.options").declare("sys:simulate", {
  q0 = true, qd0 = true, t0 = true, t1 = true, dt = true, method = true, rtol = true, atol = true,
  step = true, events = true, project = true, baumgarte = true, monitors = true, progress = true,
  check = true, h0 = true, event_tol = true, guess = true, qdd0 = true, dense = true,
  _loop = true,   -- internal, for tests and bench/loop_cost.lua: "lua" or "c" forces a loop (see M.simulate)
}, level_option)
local known_monitors = { energy = true, work = true }

-- Limits that keep a run finite and its memory bounded.
M.MAX_MEMORY = 1e9        -- bytes of output points kept in memory (see point_bytes)
M.MAX_FIXED_STEPS = 1e9   -- steps of a fixed-step run
M.MIN_RTOL = 1e-15        -- below this (~5 eps) no stepper can make progress
M.PROJECT_TOL = 1e-10     -- project = true projects when the violation exceeds this
M.PROJECT_MULTISTEP = 100  -- ... times max(rtol, atol) for msadams and msbdf (up to 1e-6)
-- Locating an event: bisect where one end's value is below this fraction of
-- the other's (src/ode/ode_run.c's NZ_RUN_SECANT_RATIO).
M.SECANT_RATIO = 1e-12
-- A long run is announced (once) when the first steps project more than
-- this many steps or seconds; LONG_RUN.check_steps: when to look first
-- (then at every doubling), so that the decision counts steps.
M.LONG_RUN = { steps = 1e7, seconds = 60, check_steps = 2000 }
-- A run whose last STALL.window steps advanced t by less than STALL.fraction
-- of the span makes no progress (it would need > window / fraction steps).
M.STALL = { window = 1000, fraction = 1e-10 }
-- The C loop (src/ode/ode_run.c) returns this often (seconds) while the progress
-- bar may show, so that the bar moves.
M.PROGRESS_PAUSE = 0.2

-- Warnings go to stderr once and into tr.warnings (tests replace M.warn).
function M.warn(msg) io.stderr:write(msg, "\n") end

-- The first frame outside the library (the user's call): "file:line: ".
local user_where = require("nz.base.where").user_where
local options = require "nz.base.options"

-- A message with its library location prefixes ("lua/nz/motion/simulate.lua:229: ")
-- removed; whether what is left starts with some (user's) file:line.
local function strip_library(msg)
  repeat
    local rest = msg:match("^@?lua/nz/[%w_/]+%.lua:%d+: (.*)$") or msg:match("^[^:\n]*/lua/nz/[%w_/]+%.lua:%d+: (.*)$")
    if rest then msg = rest end
  until not rest
  return msg
end
local function located(msg) return msg:find("^[^%s:]+:%d+: ") ~= nil end

local function fail(sys, msg, ...) error(user_where() .. ("simulate '%s': " .. msg):format(sys.name, ...), 0) end

local function show(v)
  if type(v) == "string" then return ("%q"):format(v) end
  if type(v) == "number" then return require("nz.base.text").number(v) end
  if type(v) == "table" then return "a table" end
  return tostring(v)
end

local function finite(v) return type(v) == "number" and v == v and math.abs(v) ~= math.huge end
M.show, M.finite = show, finite   -- an option's value in a message; a finite number (nz/motion/sweep.lua too)

local function check_vector(sys, v, what)
  if type(v) ~= "table" or #v ~= sys.k then
    fail(sys, "'%s' must be a table of %d numbers (one per coordinate: %s), got %s", what, sys.k,
      table.concat(sys.coords, ", "), show(v))
  end
  for i = 1, sys.k do
    if not finite(v[i]) then fail(sys, "'%s'[%d] must be a finite number, got %s", what, i, show(v[i])) end
  end
end

-- A positive finite number (nil allowed when optional).
local function check_positive(sys, cfg, key, what, optional)
  local v = cfg[key]
  if v == nil and optional then return end
  if not finite(v) or not (v > 0) then fail(sys, "'%s' (%s) must be a positive finite number, got %s", key, what, show(v)) end
end

local function method_names()
  local names = {}
  for i, m in ipairs(mech.ode_methods()) do names[i] = m.name end
  return names
end

local function is_method(name)
  for _, m in ipairs(method_names()) do if m == name then return true end end
  return false
end

-- The spacing of doubles at t: the smallest step that moves it.
local function ulp(t) return math.abs(t) * 2.220446049250313e-16 end

local function check_times(sys, cfg)
  if not finite(cfg.t0) then fail(sys, "'t0' (the start time) must be a finite number, got %s", show(cfg.t0)) end
  if not finite(cfg.t1) or not (cfg.t1 > cfg.t0) then
    fail(sys, "'t1' must be a number greater than t0 = %g (the end time, finite), got %s", cfg.t0, show(cfg.t1))
  end
  -- a span of a few ulps of t leaves the steps no room: t + h rounds to t
  -- (and the failure would read as a singular motion)
  local spacing = ulp(math.max(math.abs(cfg.t0), math.abs(cfg.t1)))
  if cfg.t1 - cfg.t0 < 1e4 * spacing then
    fail(sys, "t0 = %.17g and t1 = %.17g: the span %.3g is only %.3g times the smallest step a double can take at that "
      .. "time (%.3g): start the time at 0 (t0 = 0, t1 = %.17g) and shift it back afterwards", cfg.t0, cfg.t1,
      cfg.t1 - cfg.t0, (cfg.t1 - cfg.t0) / spacing, spacing, cfg.t1 - cfg.t0)
  end
  cfg.dt = cfg.dt or (cfg.t1 - cfg.t0) / cfg.points
  check_positive(sys, cfg, "dt", "the output spacing")
end

local function check_stepping(sys, cfg)
  if cfg.method == "taylor" then
    -- Taylor's method (src/ode/taylor.c): order and step from rtol/atol,
    -- no fixed step and no first step to give.
    for _, key in ipairs{ "step", "h0" } do
      if cfg[key] ~= nil then
        fail(sys, "'%s' does not apply to method 'taylor', which takes its order and steps from rtol/atol: drop '%s'", key, key)
      end
    end
    check_positive(sys, cfg, "rtol", "the relative tolerance")
    if not (cfg.rtol >= M.MIN_RTOL and cfg.rtol < 1) then
      fail(sys, "'rtol' must be between %g and 1 (double precision cannot do better), got %s", M.MIN_RTOL, show(cfg.rtol))
    end
    if not finite(cfg.atol) or not (cfg.atol >= 0 and cfg.atol < 1) then
      fail(sys, "'atol' (the absolute tolerance) must be a finite number in [0, 1), got %s", show(cfg.atol))
    end
    check_positive(sys, cfg, "event_tol", "the tolerance on event times")
    return
  end
  if type(cfg.method) ~= "string" then
    fail(sys, "'method' must be the name of a GSL stepper (%s) or \"taylor\", got %s", table.concat(method_names(), " "), show(cfg.method))
  end
  if not is_method(cfg.method) then
    fail(sys, "unknown method '%s'; GSL's steppers are: %s; and taylor (Taylor's method: the series of the motion, with or without constraints) (option 'method')", cfg.method, table.concat(method_names(), " "))
  end
  check_positive(sys, cfg, "rtol", "the relative tolerance")
  if not (cfg.rtol >= M.MIN_RTOL and cfg.rtol <= 1) then
    fail(sys, "'rtol' must be between %g and 1 (double precision cannot do better), got %s", M.MIN_RTOL, show(cfg.rtol))
  end
  if not finite(cfg.atol) or not (cfg.atol >= 0) then
    fail(sys, "'atol' (the absolute tolerance) must be a finite number >= 0, got %s", show(cfg.atol))
  end
  check_positive(sys, cfg, "h0", "the first step", true)
  check_positive(sys, cfg, "event_tol", "the tolerance on event times")
  if cfg.step ~= nil then
    check_positive(sys, cfg, "step", "a fixed step size")
    local nsteps = (cfg.t1 - cfg.t0) / cfg.step
    if nsteps > M.MAX_FIXED_STEPS then
      fail(sys, "'step' = %g over [%g, %g] means %.3g steps; at most %g: take step >= %.3g (or drop 'step' for adaptive steps)",
        cfg.step, cfg.t0, cfg.t1, nsteps, M.MAX_FIXED_STEPS, (cfg.t1 - cfg.t0) / M.MAX_FIXED_STEPS)
    end
    if cfg.method == "msadams" or cfg.method == "msbdf" then
      fail(sys, "'step' (a fixed step) does not work with method '%s', which chooses its own steps and order: "
        .. "drop 'step' and set rtol/atol, or take a one-step method (rk4, rk8pd, rk4imp, ...)", cfg.method)
    end
    -- bsimp extrapolates over sub-steps that only its error control keeps
    -- honest: at a fixed step on a knife edge its error grew from 1e-13 at
    -- t = 1 to 0.82 at t = 10 (rk4 and rk4imp at the same step: 4e-12), with
    -- an exact Jacobian; refused rather than silently wrong.
    if cfg.method == "bsimp" then
      fail(sys, "'step' (a fixed step) is refused with method 'bsimp': without its error control its "
        .. "extrapolation can drift far from the motion; drop 'step' and set rtol/atol, or take rk4imp "
        .. "or rk2imp for fixed implicit steps", cfg.method)
    end
  end
end

local function check_monitors(sys, cfg)
  cfg.monitors = cfg.monitors or {}
  if type(cfg.monitors) ~= "table" then
    fail(sys, "'monitors' must be a table such as {energy = true, work = true}, got %s", show(cfg.monitors))
  end
  for key in pairs(cfg.monitors) do
    if not known_monitors[key] then fail(sys, "unknown monitor '%s' (monitors: energy, work)", tostring(key)) end
  end
  if cfg.monitors.work then cfg.monitors.energy = true end   -- T + V - work needs T + V
end

local function check_stabilization(sys, cfg)
  if cfg.project ~= nil and type(cfg.project) ~= "boolean" then
    fail(sys, "'project' must be true or false, got %s", show(cfg.project))
  end
  if cfg.baumgarte ~= nil and cfg.baumgarte ~= false then
    local b = cfg.baumgarte
    if type(b) == "number" then b = { alpha = b, beta = b } end
    if type(b) ~= "table" or not finite(b.alpha) or not finite(b.beta or b.alpha) then
      fail(sys, "'baumgarte' must be {alpha = a, beta = b} (or one number for both), got %s", show(cfg.baumgarte))
    end
    cfg.alpha, cfg.beta = b.alpha, b.beta or b.alpha
    if cfg.alpha < 0 or cfg.beta < 0 then
      fail(sys, "'baumgarte' gains must be >= 0 (a negative gain makes the violation grow), got alpha = %g, beta = %g",
        cfg.alpha, cfg.beta)
    end
  end
end

local function check_events(sys, cfg)
  cfg.events = cfg.events or {}
  if type(cfg.events) ~= "table" then
    fail(sys, "'events' must be a list of functions or {f = function(t, q, qd) ... end, stop =, direction =, name =} tables, got %s",
      show(cfg.events))
  end
  local events = {}
  for i, ev in ipairs(cfg.events) do
    if type(ev) == "function" then ev = { f = ev } end
    if type(ev) ~= "table" or type(ev.f) ~= "function" then
      fail(sys, "event %d must be {f = function(t, q, qd) ... end [, stop = true, direction = 1 or -1, name = ...]}, got %s", i, show(ev))
    end
    local dir = ev.direction or 0
    if dir ~= 0 and dir ~= 1 and dir ~= -1 then
      fail(sys, "event %d: 'direction' must be 1 (rising), -1 (falling) or 0 (either way), got %s", i, show(ev.direction))
    end
    events[i] = { f = ev.f, stop = ev.stop, name = ev.name or ("event " .. i), direction = dir, index = i }
  end
  cfg.events = events
end

-- Options that are switches or tables, checked by type (what they do is
-- checked where they are used).
local function check_switches(sys, cfg)
  if cfg._loop ~= nil and cfg._loop ~= "lua" and cfg._loop ~= "c" then
    fail(sys, "'_loop' (internal, for tests) must be \"lua\" or \"c\", got %s", show(cfg._loop))
  end
  for _, key in ipairs{ "progress", "check", "dense" } do
    if cfg[key] ~= nil and type(cfg[key]) ~= "boolean" then
      fail(sys, "'%s' must be true or false, got %s", key, show(cfg[key]))
    end
  end
  if cfg.guess ~= nil and (type(cfg.guess) ~= "table" or getmetatable(cfg.guess) ~= nil) then
    fail(sys, "'guess' must be a table {lambda = {...}, q3d = {...}} (Newton's first start for the top level), got %s",
      show(cfg.guess))
  end
end

-- Options that do nothing for this system: said once per system and option.
-- They go into the trajectory's warnings every run.
local warned = setmetatable({}, { __mode = "k" })
local function warn_once(sys, cfg, key, msg)
  msg = user_where() .. ("simulate '%s': warning: "):format(sys.name) .. msg
  cfg.warnings[#cfg.warnings + 1] = msg
  warned[sys] = warned[sys] or {}
  if warned[sys][key] then return end
  warned[sys][key] = true
  M.warn(msg)
end

local function validate(sys, o)
  if type(o) ~= "table" then fail(sys, "a table {q0 = ..., qd0 = ..., t1 = ...} expected, got %s", show(o)) end
  options.check(o, known, function(...) fail(sys, ...) end, level_option)
  check_vector(sys, o.q0, "q0")
  if o.qd0 ~= nil then check_vector(sys, o.qd0, "qd0") end
  local cfg = {}
  for k, v in pairs(M.defaults) do cfg[k] = v end
  for k, v in pairs(o) do cfg[k] = v end
  if cfg.t0 == nil then cfg.t0 = 0 end
  check_times(sys, cfg)
  check_stepping(sys, cfg)
  check_monitors(sys, cfg)
  check_stabilization(sys, cfg)
  check_events(sys, cfg)
  check_switches(sys, cfg)
  cfg.warnings = {}
  if sys.nc == 0 and not sys.contact then      -- (contacts refuse them: nz/motion/contact_run.lua)
    if cfg.project then warn_once(sys, cfg, "project", "'project' does nothing: the system has no constraints") end
    if cfg.alpha then warn_once(sys, cfg, "baumgarte", "'baumgarte' does nothing: the system has no constraints") end
  end
  -- a fixed step takes no error control and no first step
  if cfg.step ~= nil then
    for _, key in ipairs{ "rtol", "atol", "h0" } do
      if o[key] ~= nil then
        warn_once(sys, cfg, "step+" .. key, ("'%s' does nothing with a fixed 'step' = %s: drop '%s', or drop 'step' for adaptive steps")
          :format(key, show(cfg.step), key))
      end
    end
    -- Both loops take equal steps no longer than 'step' that land on each
    -- output point: dt / ceil(dt / step).  That is the step the trajectory
    -- reports; one longer than the output spacing is said once.
    cfg.step_used = cfg.dt / math.max(1, math.ceil(cfg.dt / cfg.step - 1e-9))
    if cfg.step > cfg.dt * (1 + 1e-9) then
      warn_once(sys, cfg, "step>dt", ("'step' = %s is longer than the output spacing 'dt' = %s: every output point ends a "
        .. "step, so the steps are %s; give a larger 'dt' for longer steps"):format(show(cfg.step), show(cfg.dt),
        show(cfg.step_used)))
    end
  end
  return cfg
end

-- Progress on a terminal only, after half a second, at most 5 times a second.
local function progress_bar(cfg, t0, t1)
  local enabled = cfg.progress
  if enabled == nil then enabled = require("nz.base.frontend").progress() end   -- a terminal, or a notebook
  if not enabled then return function() end, function() end, false end
  local start, last = mech.now(), 0
  local shown = false
  -- steps: a function, asked only when the bar is drawn (not on every step).
  local function update(t, steps)
    local now = mech.now()
    if now - start < 0.5 or now - last < 0.2 then return end
    last, shown = now, true
    local frac = (t - t0) / (t1 - t0)
    local width = 30
    local fill = math.floor(frac * width + 0.5)
    io.stderr:write(("\r[%s%s] %3d%%  t = %-10.4g steps %d  (Ctrl-C stops, keeping what is done)")
      :format(("#"):rep(fill), (" "):rep(width - fill), math.floor(100 * frac), t, steps()))
  end
  local function done()
    if shown then io.stderr:write("\r\27[K") end      -- erase the line (a terminal: see above)
  end
  return update, done, true
end

-- Constraints of order >= 3 (constraints.level): the state is
-- (q, qd, qdd, .., q^(p-1), lambda, .., lambda^(p-3)) (src/mech/constrained_series.h).
-- Check what the start needs and return the part of y after q, qd.
-- top: a constraint of order p nonlinear in q^(p); then the state is only
-- q .. q^(p-1) ((q^(p), lambda) are solved at each time).
local function start_levels(sys, cfg, orders, p, qd0, top)
  for key, what in pairs{ work = "the 'work' monitor", alpha = "'baumgarte'" } do
    if (key == "work" and cfg.monitors.work) or (key ~= "work" and cfg[key]) then
      fail(sys, "%s is not available with constraints of order %d (the state holds qdd and the multipliers): leave it out", what, p)
    end
  end
  local k, levels = sys.k, { cfg.q0, qd0 }
  for j = 2, p - 1 do
    local name = constraints.level_name(j) .. "0"
    if cfg[name] == nil then
      fail(sys, "constraints of order %d make %s part of the state: give '%s' = {...} (sys:project(t0, q0, qd0) returns a consistent one as report.%s)",
        p, constraints.level_name(j), name, constraints.level_name(j))
    end
    check_vector(sys, cfg[name], name)
    levels[j + 1] = cfg[name]
  end
  for key in pairs(cfg) do
    local j = type(key) == "string" and (key == "qdd0" and 2 or tonumber(key:match("^q(%d+)d0$")))
    if j and j >= p then fail(sys, "'%s' is not part of the state (constraints of order %d need levels up to q^(%d))", key, p, p - 1) end
  end
  local tail = {}
  for j = 3, p do for i = 1, k do tail[#tail + 1] = levels[j][i] end end
  if top then
    if cfg.check ~= false then constraints.check_top_start(sys, cfg.t0, levels, p) end
    return tail
  end
  local probe = { table.unpack(levels) }
  probe[p + 1] = {}
  for i = 1, k do probe[p + 1][i] = 0 end
  local bad = mech.series_closure(sys.engine, orders, p, cfg.t0, probe)
  if bad then
    fail(sys, "constraint %d: its gradient dPhi/dq^(m) depends on q''' or higher, so (6.2) differentiated %d times needs derivatives above q^(%d) and the motion does not close at level %d; a gradient that depends on q, qd, qdd at most works for any order", bad, p - 2, p, p)
  end
  local lambdas = constraints.start_lambdas(sys, cfg.t0, levels, p, cfg.check == false and math.huge or nil)
  for j = 1, p - 2 do for r = 1, sys.nc do tail[#tail + 1] = lambdas[j][r] end end
  return tail
end

-- The order of each stepper (msadams and msbdf: their highest), for advice.
local method_order = { rk2 = 2, rk4 = 4, rkf45 = 5, rkck = 5, rk8pd = 8, rk1imp = 1, rk2imp = 2, rk4imp = 4,
  bsimp = 6, msadams = 12, msbdf = 5 }

local function duration_short(seconds)
  if seconds < 1e-3 then return ("%.3g us"):format(1e6 * seconds) end
  if seconds < 1 then return ("%.3g ms"):format(1e3 * seconds) end
  return ("%.3g s"):format(seconds)
end

local function duration(seconds)
  if seconds < 120 then return ("%.0f s"):format(seconds) end
  if seconds < 7200 then return ("%.0f min"):format(seconds / 60) end
  if seconds < 2 * 86400 then return ("%.1f h"):format(seconds / 3600) end
  return ("%.0f days"):format(seconds / 86400)
end

-- What would make the run cheaper, from what drives its step count: a
-- fixed `step` (rtol does nothing there), the output grid (every dt is at
-- least one step, whatever the tolerance), or the adaptive steps, which
-- for an order-p method grow like rtol^(-1/p): then a low order at a tight
-- tolerance is what costs.  nsteps: the steps taken up to tt.  An implicit
-- method is named only on evidence of stiffness (stiff, below): a chaotic
-- but non-stiff motion gets no such hint.
local IMPLICIT = {}   -- as the engine classifies its steppers (src/ode/ode.c)
for _, m in ipairs(mech.ode_methods()) do IMPLICIT[m.name] = m.implicit end

-- Where an explicit method's stability region ends on the negative real
-- axis (h |lambda| beyond it grows a mode whatever the tolerance; Hairer,
-- Norsett and Wanner I, section IV.2): |R(-x)| = 1 for the stability
-- polynomial R(z) = 1 + z b^T (I - z A)^-1 1 of each tableau, computed
-- once (rk2, rk4: e^z's Taylor polynomials; rkf45 and rkck advance with
-- their fifth-order weights in GSL; rk8pd is Prince-Dormand 8(7) 13M).
local STABILITY_BOUNDARY = { rk2 = 2.0, rk4 = 2.79, rkf45 = 3.67, rkck = 3.73, rk8pd = 5.17 }

-- Taylor's method of order p: its stability polynomial is e^z's Taylor
-- polynomial of degree p; the boundary is where |sum_{j<=p} (-x)^j / j!|
-- first exceeds 1 (scanned, then bisected).
local function taylor_boundary(p)
  local function amp(x)
    local s, term = 1, 1
    for j = 1, p do term = term * (-x) / j; s = s + term end
    return math.abs(s)
  end
  local lo, hi = 0, 0.5
  while amp(hi) <= 1 and hi < 100 do lo, hi = hi, hi + 0.5 end
  for _ = 1, 40 do
    local mid = 0.5 * (lo + hi)
    if amp(mid) <= 1 then lo = mid else hi = mid end
  end
  return lo
end

-- The evidence of stiffness at the run's current pace: its average step h
-- over the last window of steps times the spectral radius rho of the
-- motion's Jacobian at the current state (ev.rho, nil when it could not be
-- had), against the explicit method's stability boundary.  An explicit
-- method whose step sits at that boundary (h rho >= half of it) is held
-- there by stability, not by accuracy: at rtol 1e-10 accuracy alone keeps
-- an order-8 step near h |lambda| ~ 0.06, and the step control settles
-- just under the boundary when stability holds it (rk8pd on x'' + 1e4 x' +
-- x = 0: 5.2).  An implicit method on a motion
-- that an explicit one would step as far (h rho below 1) is no help.
local function stiffness(cfg, ev)
  if not (ev and ev.rho and ev.h) then return nil end
  local boundary = cfg.method == "taylor" and taylor_boundary(mech.taylor_order(cfg.rtol))
    or STABILITY_BOUNDARY[cfg.method]
  local x = ev.h * ev.rho
  if boundary then
    return { stiff = x >= 0.5 * boundary, x = x, boundary = boundary }
  end
  return { stiff = x >= 1, x = x }                -- an implicit method
end

local function stiff_words(cfg, s)
  return s.boundary and ("its steps are held by stability, not accuracy: h |lambda|max = %.2g against %s's "
    .. "stability boundary %.2g, and a looser rtol hardly helps"):format(s.x, cfg.method, s.boundary)
    or ("the motion is stiff here: h |lambda|max = %.2g"):format(s.x)
end

local function cheaper(cfg, nsteps, tt, ev)
  local s = stiffness(cfg, ev)
  local stiff = s and s.stiff
  if cfg.method == "taylor" then
    -- its steps do not depend on the grid, and hardly on the tolerance
    -- (Jorba-Zou): the order does, and a step costs about its square
    local p, lp = mech.taylor_order(cfg.rtol), mech.taylor_order(cfg.rtol * 1e3)
    return ("%sa looser rtol (taylor's order comes from it: rtol = %g takes order %d instead of %d, "
      .. "about %.2gx cheaper per step), or rk8pd"):format(stiff and ("bsimp or msbdf (%s), or "):format(stiff_words(cfg, s)) or "",
      cfg.rtol * 1e3, lp, p, (p / lp) ^ 2)
  end
  if cfg.step then
    return ("the steps are fixed ('step' = %g; rtol does nothing for fixed steps): a larger 'step', "
      .. "or adaptive steps (drop 'step')"):format(cfg.step)
  end
  local outputs = math.floor((tt - cfg.t0) / cfg.dt + 1e-9)
  if outputs > 0 and nsteps <= 1.5 * outputs and not cfg.dense_on then   -- dense output: the grid adds no step
    return ("the steps are set by the output grid ('dt' = %g: %d outputs in %d steps; rtol and the method change "
      .. "nothing): a larger 'dt'"):format(cfg.dt, outputs, nsteps)
  end
  local p = method_order[cfg.method] or 4
  local advice = {}
  if stiff and not IMPLICIT[cfg.method] then
    advice[#advice + 1] = ("bsimp or msbdf (%s)"):format(stiff_words(cfg, s))
  elseif stiff and cfg.method ~= "bsimp" and cfg.method ~= "msbdf" and p < 5 then
    advice[#advice + 1] = ("a higher-order implicit method (%s is of order %d): bsimp (%s)"):format(cfg.method, p,
      stiff_words(cfg, s))
  elseif p < 5 then
    advice[#advice + 1] = ("a higher-order method (%s is of order %d): rk8pd"):format(cfg.method, p)
  elseif IMPLICIT[cfg.method] and s and not stiff then
    advice[#advice + 1] = ("rk8pd (the motion is not stiff here: h |lambda|max = %.2g)"):format(s.x)
  end
  advice[#advice + 1] = ("a looser rtol (the steps grow like rtol^(-1/%d) for this method; rtol = %g takes %.2gx fewer steps)")
    :format(p, cfg.rtol * 1e3, 1e3 ^ (1 / p))
  return table.concat(advice, ", or ")
end

-- Seconds the run has waited for the compiler so far (native = true; 0 when
-- the system is not recorded): a one-time cost, not the run's pace.  A
-- compile in the background costs the run nothing.
local function compile_seconds(sys)
  local c = sys.engine.compiled
  return c and c:info().native_waited or 0
end

-- Which evaluator ran the steps (tr.stats.evaluator), from the loop's
-- nz_run_native_from: machine code from step `from` on, none (0), or no
-- machine code at all (-1); and that step, when machine code took over
-- during the run.
local function evaluator(sys, from)
  if from == 1 then return "machine code" end
  if from > 1 then
    return ("interpreted graph for steps 1-%d, machine code from step %d (compiled in the background)")
      :format(from - 1, from), from
  end
  local info = sys.engine.compiled and sys.engine.compiled:info()
  if from == 0 then
    return "interpreted graph" .. (info.native_compiling > 0 and " (machine code was still compiling)" or "")
  end
  if not info then return "jets, the functions in Lua (compile = false)" end
  if info.native_mode == 0 then return "interpreted graph (native = false)" end
  return "jets (a function of the system runs in Lua: print(sys) says which)"
end

-- A run that will take long says so once, with what would be cheaper
-- (tr.warnings, and the terminal): nsteps steps have brought it to tt,
-- wall0 was its start, done() clears the progress bar's line.  It looks at
-- every doubling of the step count; pace holds the step count, t, clock
-- and compile time of the previous look, so that the projection is the
-- pace of the last window (half the steps so far): the run's start-up (the
-- first calls, plans built, a graph evaluated before its machine code is
-- ready) is not spread over what remains.  evidence(tt) gives the
-- spectral radius of the motion's Jacobian at the current state (one
-- Jacobian and its eigenvalues, once, when the notice is given).  True when
-- it said so.
local function long_run_notice(sys, cfg, tr, nsteps, tt, wall0, done, compiled0, pace, evidence)
  local now, compiled = mech.now(), compile_seconds(sys)
  local elapsed = now - wall0 - (compiled - compiled0)
  local dsteps, dt_run = nsteps - pace.steps, tt - pace.t
  local dwall = now - pace.wall - (compiled - pace.compiled)
  pace.steps, pace.t, pace.wall, pace.compiled = nsteps, tt, now, compiled
  if not (dsteps > 0 and dt_run > 0) then return false end
  local windows = (cfg.t1 - tt) / dt_run          -- windows like the last one still to go
  local steps, seconds = nsteps + windows * dsteps, elapsed + windows * math.max(dwall, 0)
  if not ((nsteps >= M.LONG_RUN.check_steps and steps > M.LONG_RUN.steps)
      or (elapsed >= 1 and seconds > M.LONG_RUN.seconds)) then return false end
  local h = dt_run / dsteps
  local ok, rho = pcall(evidence, tt)
  local ev = { h = h, rho = ok and rho or nil }
  local s = stiffness(cfg, ev)
  -- what it said, in numbers (tr.stats.long_run)
  pace.notice = { steps = steps, seconds = seconds, h = h, rho = ev.rho, h_rho = s and s.x, stiff = s and s.stiff }
  local msg = ("%ssimulate '%s': warning: at its pace so far this run will take about %.3g steps and %s, at the pace of its "
    .. "last %d steps, %s each (t = %.4g of [%g, %g] after %d steps) with %s%s; it goes on (Ctrl-C stops it and keeps what is "
    .. "done); cheaper: %s"):format(user_where(), sys.name, steps, duration(seconds), dsteps, duration_short(dwall / dsteps), tt,
    cfg.t0, cfg.t1, nsteps, cfg.method, cfg.step and (" at step = %g"):format(cfg.step) or (" at rtol = %g"):format(cfg.rtol),
    cheaper(cfg, nsteps, tt, ev))
  tr.warnings[#tr.warnings + 1] = msg
  done()                                  -- the progress bar's line, if shown
  M.warn(msg)
  return true
end

-- " at t = ..., q = {...}, qd = {...}" as the engine's messages say it.
local function num(v)
  local text = ("%.15g"):format(v)
  return tonumber(text) == v and text or ("%.17g"):format(v)
end
local function nums(v) return require("nz.base.text").list(v, num) end
local function state_text(t, q, qd) return (" at t = %s, q = %s, qd = %s"):format(num(t), nums(q), nums(qd)) end

-- simulate{guess = {lambda = {...}, q3d = {...}}}: Newton's first start for
-- (q^(p), lambda) under a constraint nonlinear in q^(p) (q^(p) = 0 if absent).
local function top_guess(sys, g, p)
  local name = constraints.level_name(p)
  if type(g) ~= "table" or type(g.lambda) ~= "table" then
    fail(sys, "'guess' must be {lambda = {...}, %s = {...}} (Newton's first start for the multipliers and q^(%d))", name, p)
  end
  local x = {}
  for i = 1, sys.k do x[i] = g[name] and g[name][i] or 0 end
  for r = 1, sys.nc do x[sys.k + r] = g.lambda[r] end
  for i = 1, sys.k + sys.nc do
    if type(x[i]) ~= "number" or x[i] ~= x[i] then
      fail(sys, "'guess' must be {lambda = {%d numbers}, %s = {%d numbers}}", sys.nc, name, sys.k)
    end
  end
  return x
end

-- The bytes one output point keeps (record below): a slot in each series
-- (t, q, qd, qdd, lambda, and the monitors'), counted twice for the arrays'
-- doubling, and the tables of q, qd, qdd, lambda, the higher levels and
-- q^(p), each a 64-byte header and 16 bytes per number rounded up to a power
-- of two.  Measured (collectgarbage, 10001 points): 410 bytes for a 1-DOF
-- pendulum (this gives 464), 482 with both monitors (560), 494 for a
-- constrained 2-DOF one (560), 691 for 5 DOF (800).
local function pow2(n) local c = n > 0 and 1 or 0; while c < n do c = 2 * c end; return c end
function M.point_bytes(sys, cfg, p, top)
  local k, nc = sys.k, sys.nc
  local series, tables, numbers = 5, 4, 3 * pow2(k) + pow2(nc)
  if nc > 0 then series = series + 1 end                                  -- violation
  if cfg.monitors.energy then series = series + 2 end
  if cfg.monitors.work then series = series + 1 end
  if p and p > 3 then series, tables, numbers = series + 1, tables + p - 2, numbers + (p - 3) * pow2(k) end
  if top then series, tables, numbers = series + 1, tables + 1, numbers + pow2(k) end
  return 32 * series + 64 * tables + 16 * numbers
end

-- The output points a run keeps must fit in M.MAX_MEMORY bytes.
local function check_memory(sys, cfg, p, top)
  local npoints = math.floor((cfg.t1 - cfg.t0) / cfg.dt + 1e-9) + 1
  local bytes = M.point_bytes(sys, cfg, p, top)
  if npoints * bytes > M.MAX_MEMORY then
    fail(sys, "'dt' = %g over [%g, %g] asks for %.3g output points of about %d bytes each (%.3g GB); at most %.3g GB "
      .. "are kept in memory (require('nz.motion.simulate').MAX_MEMORY): take dt >= %.3g, or a shorter span",
      cfg.dt, cfg.t0, cfg.t1, npoints, bytes, npoints * bytes / 1e9, M.MAX_MEMORY / 1e9,
      (cfg.t1 - cfg.t0) / math.floor(M.MAX_MEMORY / bytes - 1))
  end
end

local function split(y, k)
  local q, qd = {}, {}
  for i = 1, k do q[i], qd[i] = y[i], y[k + i] end
  return q, qd
end

-- The end of a run (every method): interrupted at t, it returns the
-- partial trajectory (also in nz.last); failed, it raises the error with one
-- location, the user's, and keeps the part computed in nz.last; else tr.
local function finish(sys, cfg, tr, ok, err, t)
  if ok then return tr end
  if rawequal(err, core.interrupted) then     -- by identity: a user's message may say "interrupted!"
    tr.status, tr.message = "interrupted", ("stopped by Ctrl-C at t = %.6g; the trajectory is partial "
      .. "(t1 = %g not reached), the part computed so far is kept"):format(t, cfg.t1)
    io.stderr:write(("simulate '%s': %s (%d points, also in nz.last)\n"):format(sys.name, tr.message, #tr.t))
    require("nz").last = tr
    return tr
  end
  -- The engine's messages come with the library's line
  -- (lua/nz/motion/simulate.lua:...), which says nothing.
  local msg = strip_library(tostring(err))
  if not located(msg) then msg = user_where() .. msg end
  tr.status, tr.message = "failed", msg
  require("nz").last = tr
  error(("%s\n(the trajectory computed so far, %d points up to t = %.6g, is kept in nz.last)"):format(
    msg, #tr.t, tr.t[#tr.t] or cfg.t0), 0)
end

function M.simulate(sys, opts)
  -- A script that Ctrl-C interrupted during an earlier simulate (which
  -- returned its partial trajectory) stops here: a later run would
  -- otherwise stop at once and return a 1-point trajectory as if it were
  -- the answer.  The session clears the request at every prompt.
  if mech.interrupted() then error(core.interrupted, 0) end
  local cfg = validate(sys, opts)
  local k, engine = sys.k, sys.engine
  local orders, linear, p, top = {}, {}, nil, nil
  if sys.nc > 0 then
    orders, linear = constraints.orders(sys, { t = cfg.t0, q = cfg.q0, qd = cfg.qd0 })
    p = constraints.level(sys)
    top = constraints.top_level(sys)     -- nonlinear in q^(m), m >= 3: solved, not differentiated
    if top then p = top end
  end
  if not p then
    for key in pairs(opts) do
      if key == "qdd0" or level_option(key) then
        fail(sys, "'%s' is for constraints of order 3 or more; this system's accelerations follow from q and qd: leave it out", key)
      end
    end
  end
  engine.orders = orders
  check_memory(sys, cfg, p, top)
  -- method = "taylor": Taylor's method (src/ode/taylor.c, made by
  -- src/lua/lua_taylor.c) behind the same integrator interface as GSL's
  -- steppers (src/ode/stepper.h), in the same C loop below; what it does not
  -- do is refused here, from the user's line.
  local taylor = cfg.method == "taylor"
  local function refuse(msg, ...) fail(sys, "method 'taylor' " .. msg, ...) end
  if taylor then
    if p then
      fail(sys, "method 'taylor' takes constraints of order 0, 1 and 2 (on q, q', q''), and this system's need the "
        .. "level %d (a constraint on the third derivative or higher): take a GSL stepper (rk8pd, the default, "
        .. "or any of %s)", p, table.concat(method_names(), " "))
    end
    if cfg.monitors.work then
      refuse("does not integrate the 'work' monitor yet (it is part of the GSL steppers' state): leave it out, "
        .. "or take rk8pd")
    end
    -- without constraints both do nothing, said once by validate as for
    -- every method; with them taylor has no use for either
    if (cfg.project or cfg.alpha) and sys.nc > 0 then
      refuse("takes no 'project' or 'baumgarte': its series keeps the constraints to the order of the method "
        .. "along each step (their drift is the truncation's: tr:violation() shows it); take rk8pd to project")
    end
    if not sys.recording then
      refuse("needs a recorded system (made with compile = true, the default): it builds the series on the graphs; "
        .. "take rk8pd for a system made with compile = false")
    end
    if cfg._loop == "lua" then fail(sys, "'_loop' = \"lua\": method 'taylor' runs in the C loop only") end
  end
  local qd0 = cfg.qd0
  if not qd0 then qd0 = {}; for i = 1, k do qd0[i] = 0 end end   -- at rest
  -- T = ... + 1/0 or + 0/0 at the start: the motion has only its
  -- derivatives, so it would run on with a T (or V) that means nothing
  local piece, value = require("nz.model.probe").nonfinite_piece(sys, cfg.t0, cfg.q0, qd0)
  if piece then
    fail(sys, "%s is %s at the start%s: a term such as 1/0 or 0/0 makes it so (only its derivatives enter the "
      .. "motion, so the run would go on with a %s that means nothing)", piece, show(value), state_text(cfg.t0, cfg.q0, qd0),
      piece)
  end
  if sys.nc > 0 and cfg.check ~= false then constraints.check_state(sys, cfg.t0, cfg.q0, qd0) end
  -- Unilateral contacts (nz/motion/contact_run.lua): the run integrates the system
  -- with the contacts' functions (sys.contact.system) in the contacts' mode,
  -- from the velocities after the start's impact, if any.
  local contact = sys.contact and require("nz.motion.contact_run").begin(sys, cfg, cfg.q0, qd0,
    function(...) fail(sys, ...) end)
  if contact then engine, orders, linear, cfg.q0, qd0 = contact.engine, contact.orders, contact.linear, contact.q0, contact.qd0 end
  local tail = p and start_levels(sys, cfg, orders, p, qd0, top)
  local guess = top and cfg.guess and top_guess(sys, cfg.guess, p)

  local ode_cfg = {
    method = cfg.method, rtol = cfg.rtol, atol = cfg.atol, h0 = cfg.h0 or math.min(cfg.dt, 1e-3),
    work = cfg.monitors.work, orders = orders, linear = linear, alpha = cfg.alpha, beta = cfg.beta, level = p,
    top = top ~= nil, guess = guess, contacts = contact and contact.cs,
  }
  local ode
  if taylor then
    -- the binding's refusals (a piece that fell back to Lua, branches on the
    -- state) said as simulate's: the user's line, then what is wrong
    local ok, res = pcall(mech.ode_new, engine, ode_cfg)
    if not ok then
      if type(res) ~= "string" then error(res, 0) end
      local what = strip_library(res):gsub("^[^%s:]+:%d+: ", "", 1):gsub("^system '[^']*': '[%w_]+': ", "")
        :gsub("^system '[^']*': ", "")
      refuse("cannot run this system: %s; take rk8pd", what)
    end
    ode = res
  else
    ode = mech.ode_new(engine, ode_cfg)
  end
  local tr = trajectory.new(sys, cfg)
  tr.step = cfg.step_used            -- the step taken (the summary says it), not the one asked
  tr.warnings = cfg.warnings
  if cfg.monitors.energy then tr.energy, tr.generalized_energy = {}, {} end
  if cfg.monitors.work then tr.work = {} end

  local y = {}
  for i = 1, k do y[i], y[k + i] = cfg.q0[i], qd0[i] end
  if cfg.monitors.work then y[2 * k + 1] = 0 end
  for _, v in ipairs(tail or {}) do y[#y + 1] = v end

  -- The levels q .. q^(p-1) of a state and, when the multipliers are part
  -- of it (constraints linear in q^(p), p >= 3), lambda .. lambda^(p-3).
  local function state_levels(yy)
    local q, qd = split(yy, k)
    local levels, lambdas = { q, qd }, {}
    for j = 2, (p or 2) - 1 do levels[j + 1] = { table.unpack(yy, j * k + 1, (j + 1) * k) } end
    if p and not top then
      for j = 1, p - 2 do lambdas[j] = { table.unpack(yy, p * k + (j - 1) * sys.nc + 1, p * k + j * sys.nc) } end
    end
    return levels, lambdas
  end

  -- How far the state is from the constraints: position and velocity level,
  -- and at level p the equations of the levels the state holds.
  local function state_violation(t, yy)
    local levels, lambdas = state_levels(yy)
    local v = constraints.violation(sys, t, levels[1], levels[2])
    if top then v = math.max(v, (constraints.top_rows(sys, t, levels, p)))
    elseif p then v = math.max(v, constraints.level_violation(sys, t, levels, lambdas, p)) end
    return v
  end

  -- What an output point records besides t, q, qd, qdd, lambda (the C loop
  -- records those and leaves these to this function).
  local extras = tr.violation or (p and p > 3) or top or tr.energy or tr.work
  local function record_extras(n, t, yy, lambda, root)
    if tr.violation then tr.violation[n] = state_violation(t, yy) end
    if p and p > 3 then tr.higher = tr.higher or {}; tr.higher[n] = { table.unpack(state_levels(yy), 4) } end
    if top then                          -- q^(p) solved, and the branch Newton started on
      tr.top = tr.top or {}
      tr.top[n] = root
      tr.branch = tr.branch or { from = guess and "guess" or "least squares", [constraints.level_name(p)] = root, lambda = lambda }
    end
    if tr.energy then tr.energy[n], tr.generalized_energy[n] = sys:energy(t, tr.q[n], tr.qd[n]) end
    if tr.work then tr.work[n] = yy[2 * k + 1] end
  end

  local function record(t, yy)
    local q, qd = split(yy, k)
    local qdd, lambda, root = mech.ode_accel(ode, engine, t, yy)
    local n = #tr.t + 1
    tr.t[n], tr.q[n], tr.qd[n], tr.qdd[n], tr.lambda[n] = t, q, qd, qdd, lambda
    if extras then record_extras(n, t, yy, lambda, root) end
  end

  -- The state at tau in [ta, tb] of the last step, by integrating again from
  -- (ta, ya) with an adaptive rk8pd at the run's tolerances: events are
  -- located to tolerance, whatever the method (multistep ones included).
  local locator
  -- top: the main run's root at (ta, ya), the locator's first Newton start
  -- (it stays on the run's branch).
  local function root_at(ta, ya)
    local _, lambda, root = mech.ode_accel(ode, engine, ta, ya)
    local g = { table.unpack(root) }
    for _, v in ipairs(lambda) do g[#g + 1] = v end
    return g
  end
  local crun                         -- the C loop's run (below): its last step's interpolant
  local function state_at(ta, ya, tau)
    if crun then      -- dense output: the step's interpolant, when it meets the tolerance (nil when off)
      local yy = mech.ode_run_interpolate(crun, engine, tau)
      if yy then return yy end
    end
    locator = locator or mech.ode_new(engine, { method = "rk8pd", rtol = math.min(cfg.rtol, 1e-10),
      atol = math.min(cfg.atol, 1e-12), work = cfg.monitors.work, orders = orders, linear = linear,
      alpha = cfg.alpha, beta = cfg.beta, h0 = math.max(tau - ta, 1e-12), level = p, top = top ~= nil,
      guess = top and root_at(ta, ya), contacts = contact and contact.cs })
    mech.ode_reset(locator)
    local t, h, yy = ta, math.max(tau - ta, 1e-12), ya
    while t < tau do t, h, yy = mech.ode_step(locator, engine, t, tau, h, yy) end
    return yy
  end

  -- The event functions, recorded once on tracers (nz/model/record.lua) into a
  -- graph evaluated in C (mech.ode_events_new): both loops take the values
  -- from it, at the start, after every step and while locating, so that
  -- they see the same numbers (the graph and the Lua function agree to
  -- rounding, not to the bit, and a last bit of g moves a located time).
  -- Where the graph fails at a state (a domain error), the Lua function is
  -- called: it gives the value, or raises with the user's line.  A function
  -- that cannot be recorded (a Lua branch on the state, math.* on it), or a
  -- system made with compile = false, keeps every event in Lua, and the run
  -- in the Lua loop (tr.stats.loop_why says why).
  local evals, events_why = nil, nil
  if #cfg.events > 0 then
    if not sys.recording then
      events_why = "the system is not recorded (compile = false): its event functions run in Lua"
    else
      local fs = {}
      for i, ev in ipairs(cfg.events) do fs[i] = ev.f end
      local rec, bad, why = record_graph.state_functions(engine, fs)
      if rec then evals = mech.ode_events_new(rec.compiled, rec.nodes, rec.values, k)
      elseif taylor then
        refuse("needs event functions it can record, and event '%s' cannot be (%s): take rk8pd, whose Lua loop runs it",
          cfg.events[bad].name, why)
      else events_why = ("event '%s' cannot be recorded (%s)"):format(cfg.events[bad].name, why) end
    end
  end

  -- An event function that raises: its own file:line first (the fault is
  -- there), then the system, the event, the time and the state.
  local function event_value(ev, t, yy)
    if ev.contact then return mech.contacts_event(ev.cs, engine, ev.contact, t, yy) end   -- nz/motion/contact_run.lua
    if evals then
      local g = mech.ode_event_value(evals, ev.index, t, yy)
      if g then return g end
    end
    local q, qd = split(yy, k)
    local ok, v = pcall(ev.f, t, q, qd, sys.params)
    if not ok then
      if type(v) ~= "string" then error(v, 0) end        -- an error object (an interrupt): as it is
      local where, what = v:match("^([^%s:]+:%d+: )(.*)$")
      error(("%ssimulate '%s': event '%s' raised an error%s: %s"):format(where or user_where(), sys.name, ev.name,
        state_text(t, q, qd), what or v), 0)
    end
    if type(v) ~= "number" or v - v ~= 0 then      -- nil, a jet, NaN or an infinity: no sign to follow
      fail(sys, "event '%s' must return a finite number, got %s%s", ev.name, show(v), state_text(t, q, qd))
    end
    return v
  end

  -- A sign change over the step, or a step that lands on the zero (an
  -- event at an output time: g = t - 0.05 with dt = 0.005).
  local function crosses(ev, ga, gb)
    if ga == 0 or (gb ~= 0 and (ga > 0) == (gb > 0)) then return false end
    return ev.direction == 0 or (ev.direction > 0 and gb > ga) or (ev.direction < 0 and gb < ga)
  end

  -- Illinois' variant of regula falsi on [ta, tb]: robust, and superlinear.
  local function locate(ev, ta, ya, ga, tb, gb, yb)
    if gb == 0 then return tb, yb end
    local tol = cfg.event_tol * math.max(1, math.abs(tb))
    local side = 0
    local tm, ym = tb, nil
    for _ = 1, 100 do
      if tb - ta <= tol then break end
      tm = (ta * gb - tb * ga) / (gb - ga)
      -- an end whose value is negligible against the other's (an event that
      -- starts at zero: a bounce) pins the secant to it, and Illinois'
      -- halvings would take hundreds of steps to leave it: bisect
      if not (tm > ta and tm < tb) or math.abs(ga) < M.SECANT_RATIO * math.abs(gb)
        or math.abs(gb) < M.SECANT_RATIO * math.abs(ga) then tm = 0.5 * (ta + tb) end
      ym = state_at(ta, ya, tm)
      local gm = event_value(ev, tm, ym)
      if gm == 0 then return tm, ym end
      if (gm > 0) == (ga > 0) then
        ta, ya, ga = tm, ym, gm
        if side == -1 then gb = gb / 2 end
        side = -1
      else
        tb, gb = tm, gm
        if side == 1 then ga = ga / 2 end
        side = 1
      end
    end
    return tb, state_at(ta, ya, tb)
  end

  -- project = true: q, qd onto the constraints of order <= 1 and, at level
  -- p, q'' .. q^(p-1) (and the multipliers of the state) onto the equations
  -- of their levels, each the least change from its current value.
  local function project_state(tt, yy)
    local q, qd = split(yy, k)
    local popts, nc = nil, sys.nc
    if p then
      popts = { lambdas = {} }
      for j = 2, p - 1 do popts[constraints.level_name(j)] = { table.unpack(yy, j * k + 1, (j + 1) * k) } end
      for j = 1, top and 0 or p - 2 do popts.lambdas[j] = { table.unpack(yy, p * k + (j - 1) * nc + 1, p * k + j * nc) } end
    end
    local pq, pqd, rep = constraints.project(sys, tt, q, qd, popts)
    local out = { table.unpack(yy) }
    for j = 1, k do out[j], out[k + j] = pq[j], pqd[j] end
    for j = 2, p and p - 1 or 1 do
      local v = rep[constraints.level_name(j)]
      for i = 1, k do out[j * k + i] = v[i] end
    end
    for j = 1, (p and not top) and p - 2 or 0 do
      for r = 1, nc do out[p * k + (j - 1) * nc + r] = rep.lambdas[j][r] end
    end
    return out
  end

  local update, done, progress = progress_bar(cfg, cfg.t0, cfg.t1)
  local wall0, compiled0 = mech.now(), compile_seconds(sys)
  local span = cfg.t1 - cfg.t0
  local nsteps, window_t, next_check, announced = 0, cfg.t0, 16, false
  local function stalled(tt, advance)
    local q, qd = split(y, k)
    local window = M.STALL.window
    -- Two causes that are not the motion's, both with steps that did not
    -- shrink (the last window's as large as the run's average; near a
    -- singular point they shrink by orders of magnitude): a time so large
    -- that such steps hardly move it (a few ulps of t each), and a span so
    -- long that they cover only a sliver of it.
    local average = (tt - cfg.t0) / math.max(1, nsteps)
    if advance >= 0.1 * window * average then
      local spacing = ulp(tt)
      if advance <= 16 * window * spacing then
        fail(sys, "the integrator (%s) stopped making progress at t = %s: the last %d steps advanced t by %.3g, a few "
          .. "of its last digits each (an ulp of t is %.3g): t is too large for the steps this motion needs: start the "
          .. "time at 0 (t0 = 0, t1 = the span) and shift it back afterwards", cfg.method, num(tt), window, advance, spacing)
      end
      fail(sys, "the span [%g, %g] is far longer than the steps this motion needs can cover: the last %d steps advanced t "
        .. "by %.3g (about the run's average step, %.3g), so the run would take some %.3g steps: a shorter t1, or a "
        .. "looser tolerance", cfg.t0, cfg.t1, window, advance, average, span / math.max(average, 1e-300))
    end
    local sv = mech.singular_values(sys:mass(tt, q, qd))
    local sv0 = mech.singular_values(sys:mass(cfg.t0, cfg.q0, qd0))
    local smin, smax, smin0 = math.huge, 0, math.huge
    for _, x in ipairs(sv) do smin, smax = math.min(smin, x), math.max(smax, x) end
    for _, x in ipairs(sv0) do smin0 = math.min(smin0, x) end
    fail(sys, "the integrator (%s) stopped making progress: the last %d steps advanced t by %.3g%s; "
      .. "the mass matrix M there has singular values from %.3g to %.3g (condition number %.3g; smallest %.3g at the start): "
      .. "the motion is singular here (M nearly singular, or a velocity blowing up), or the tolerance is too tight: "
      .. "check the system near this state, or change the method or the tolerances",
      cfg.method, M.STALL.window, advance, state_text(tt, q, qd), smin, smax, smax / smin, smin0)
  end

  -- The long-run notice: the pace of its last look, and the spectral radius
  -- of the motion's exact Jacobian at the current state y (the implicit
  -- steppers' own, from a bsimp stepper of the same motion made for it,
  -- so that the run's stepper and its statistics are left alone).
  local pace = { steps = 0, t = cfg.t0, wall = wall0, compiled = compiled0 }
  local function evidence(tt)
    local jcfg = {}
    for key, v in pairs(ode_cfg) do jcfg[key] = v end
    jcfg.method = "bsimp"
    local o = mech.ode_new(engine, jcfg)
    local rho = 0
    for _, e in ipairs((mech.eigen((mech.ode_jacobian(o, engine, tt, y))))) do
      rho = math.max(rho, math.sqrt(e[1] ^ 2 + e[2] ^ 2))
    end
    return rho
  end
  local function long_run(tt) return long_run_notice(sys, cfg, tr, nsteps, tt, wall0, done, compiled0, pace, evidence) end

  local t, h = cfg.t0, cfg.h0 or math.min(cfg.dt, 1e-3)
  local gvals = {}

  -- project = true: back onto the constraints when the violation exceeds a
  -- tolerance, not after every step.  One-step methods carry nothing from
  -- step to step; msadams and msbdf carry a history of the state that a
  -- projection invalidates (they restart at order 1), so they project only
  -- when the drift exceeds 100 times the run's tolerance: at PROJECT_TOL
  -- each restart would cause the drift of the next.
  local multistep = cfg.method == "msadams" or cfg.method == "msbdf"
  local project_tol = multistep and math.min(1e-6, math.max(M.PROJECT_TOL, M.PROJECT_MULTISTEP * math.max(cfg.rtol, cfg.atol)))
    or M.PROJECT_TOL
  tr.projections = cfg.project and sys.nc > 0 and 0 or nil
  local function project(tt)
    if state_violation(tt, y) <= project_tol then return end
    y = project_state(tt, y)
    tr.projections = tr.projections + 1
    if multistep then mech.ode_reset(ode) end     -- keeps the statistics (src/ode/ode.c)
  end

  -- Every accepted step: a run that stopped making progress fails with the
  -- state and the conditioning of M; a run that will take long says so once.
  local function watch(tt)
    if nsteps % M.STALL.window == 0 then
      if tt - window_t < M.STALL.fraction * span then stalled(tt, tt - window_t) end
      window_t = tt
    end
    if nsteps == next_check and not announced then
      next_check = 2 * next_check
      announced = long_run(tt)
    end
  end

  -- Event e at te, state ye, its value rising through zero (dir = 1) or
  -- falling (-1): recorded; true when it stops the run (its point recorded).
  local function on_located(e, te, ye, dir)
    if e > #cfg.events then return contact:located(e - #cfg.events, te, ye) end   -- a contact's event
    local ev = cfg.events[e]
    local q, qd = split(ye, k)
    tr.events[#tr.events + 1] = { name = ev.name, t = te, q = q, qd = qd, direction = dir }
    if ev.stop then
      -- dense output recorded the step's output points before its events:
      -- those past the event go
      while #tr.t > 0 and tr.t[#tr.t] > te do
        local n = #tr.t
        for _, key in ipairs{ "t", "q", "qd", "qdd", "lambda", "violation", "higher", "top", "energy",
          "generalized_energy", "work" } do
          if tr[key] then tr[key][n] = nil end
        end
      end
      record(te, ye)
      tr.status, tr.message = "stopped", ("event '%s' at t = %.12g"):format(ev.name, te)
      return true
    end
    return false
  end

  -- Event e crossed in the step from (ta, ya) to (tb, yb): locate it and
  -- record it; true when it stops the run (its point recorded).
  local function on_event(e, ta, ya, ga, tb, gb, yb)
    local dir = gb > ga and 1 or -1
    if contact then                                  -- the earliest event first
      local ef, te, ye = contact:first(e, ta, ya, ga, tb, gb, yb)
      return on_located(ef, te, ye, dir)
    end
    local te, ye = locate(cfg.events[e], ta, ya, ga, tb, gb, yb)
    return on_located(e, te, ye, dir)
  end

  -- A Taylor step that failed ({taylor_stop = why, message = what} from the
  -- binding): said with the user's line and the last output point.
  local function taylor_failure(err)
    local n = #tr.t
    local why = err.taylor_stop == "hook" and "" or ": the motion may be singular there (a velocity blowing up), "
      .. "or the tolerance too tight"
    return ("%ssimulate '%s': method 'taylor' %s%s%s; last output point%s"):format(user_where(), sys.name, err.message,
      err.taylor_stop == "step" and " (the series predicts a step below the time's resolution)" or "", why,
      state_text(tr.t[n], tr.q[n], tr.qd[n]))
  end

  local function run()
    record(t, y)
    for i, ev in ipairs(cfg.events) do gvals[i] = event_value(ev, t, y) end
    local nout = math.ceil((cfg.t1 - cfg.t0) / cfg.dt - 1e-9)
    for i = 1, nout do
      local tout = i == nout and cfg.t1 or cfg.t0 + i * cfg.dt
      -- Fixed steps: equal steps no longer than `step` that land on tout.
      local nfixed = cfg.step and math.max(1, math.ceil((tout - t) / cfg.step - 1e-9))
      local hfixed = cfg.step and (tout - t) / nfixed
      while t < tout do
        if mech.interrupted() then error(core.interrupted, 0) end
        local ta, ya = t, y
        if cfg.step then
          nfixed = nfixed - 1
          t, y = mech.ode_step_fixed(ode, engine, t, hfixed, y)
          if nfixed == 0 then t = tout end
        else
          t, h, y = mech.ode_step(ode, engine, t, tout, h, y)
        end
        if cfg.project and sys.nc > 0 then project(t) end
        nsteps = nsteps + 1
        watch(t)
        for e, ev in ipairs(cfg.events) do
          local g = event_value(ev, t, y)
          if crosses(ev, gvals[e], g) and on_event(e, ta, ya, gvals[e], t, g, y) then return end
          gvals[e] = g
        end
        update(t, function() return mech.ode_stats(ode).steps end)
      end
      record(t, y)
    end
    tr.status = "done"
  end

  -- The same loop in C (src/ode/ode_run.c).  It returns here only to hand
  -- over the output points (every 1024, and at the end), at the step counts
  -- where long_run looks, every 0.2 s while the progress bar shows, when an
  -- event crossed in the last step ("event": located and recorded here by
  -- on_event, as run() does; the C loop then goes on with the next event of
  -- the same step), when the violation exceeds project_tol ("project": the
  -- violation is computed in C by nz_state_violation, the very numbers of
  -- state_violation(), so both loops project at the same steps; projected
  -- here and written back), and to stop (done, stalled, interrupted,
  -- failed); each step's arithmetic mirrors run() above, so both give the
  -- same trajectory and statistics to the bit.
  -- The C loop hands its points over to tr at each return (or raise):
  -- t, q, qd, qdd, lambda, and in pend each point's state and root, from
  -- which catch_up records the rest.  Ctrl-C's hook may cut catch_up short:
  -- it is taken up again after the run (cdone: the points done).
  local cdone = 0
  local pend = extras and { y = {}, root = {} } or nil
  local function catch_up()
    if not extras then return end
    for n = cdone + 1, #tr.t do
      record_extras(n, tr.t[n], pend.y[n], tr.lambda[n], pend.root[n] or nil)
      pend.y[n], pend.root[n] = nil, nil
      cdone = n
    end
  end
  local projecting = cfg.project and sys.nc > 0
  -- Dense output (src/ode/ode_run.h): the output points inside a step from
  -- its interpolant, under an error control that makes a point a step end
  -- when the interpolant misses the tolerance there.  Such a step is taken
  -- again from its start, which restarts msadams and msbdf at order 1: on a
  -- pendulum (dt = 0.01, rtol 1e-10) msbdf took 79,410 steps with it against
  -- 20,949 without, so those two keep the grid unless asked (dense = true).
  -- Taylor's dense output is its own solution, the step's polynomial.
  local dense = taylor or (not cfg.step and (cfg.dense == true or (cfg.dense == nil and not multistep)))
  local function run_c()
    local directions, orders = {}, {}
    for e, ev in ipairs(cfg.events) do directions[e] = ev.direction end
    if projecting then for r, c in ipairs(constraints.classify(sys)) do orders[r] = c.order end end
    crun = mech.ode_run_new(ode, { t0 = cfg.t0, t1 = cfg.t1, dt = cfg.dt, step = cfg.step, h0 = h, y = y,
      stall_window = M.STALL.window, stall_fraction = M.STALL.fraction,
      capacity = math.min(1024, math.ceil((cfg.t1 - cfg.t0) / cfg.dt - 1e-9) + 1),   -- no larger than the grid
      events = evals, directions = directions,
      -- taylor: no Lua function where a graph fails on the step's polynomial (the run fails)
      fallback = evals and not taylor and function(e, tt, yy) return event_value(cfg.events[e], tt, yy) end or nil,
      project_tol = projecting and project_tol or 0, orders = orders,
      dense = dense, rtol = cfg.rtol, atol = cfg.atol, event_tol = cfg.event_tol })
    -- The bar's next drawing time stays put across the returns that hand
    -- points over ("full"), which may come more often than it.
    local next_draw = mech.now() + M.PROGRESS_PAUSE
    while true do
      local ok, status, a1, a2, a3, a4, a5, a6, a7 = pcall(mech.ode_run, crun, engine, tr, pend,
        not announced and next_check or 0, progress and next_draw or 0)
      t, y, nsteps = mech.ode_run_state(crun)       -- for the messages (the interrupt's t, stalled's state)
      catch_up()
      if not ok then
        if type(status) == "table" and status.taylor_stop then status = taylor_failure(status) end
        error(status, 0)
      end
      if status == "done" then tr.status = "done"; return end
      if status == "stalled" then stalled(t, a1) end
      if status == "project" then                   -- project(t), past its test (made in C)
        y = project_state(t, y)
        tr.projections = tr.projections + 1
        if multistep then mech.ode_reset(ode) end
        mech.ode_run_set_state(crun, y)
      end
      if status == "event" and on_event(a1, a2, a3, a4, a5, a6, a7) then
        cdone = #tr.t                               -- its point recorded whole by record()
        return
      end
      if status == "located" and on_located(a1, a2, a3, a4) then   -- located in C (taylor's polynomial)
        cdone = #tr.t
        return
      end
      cdone = math.min(cdone, #tr.t)                -- a contact's event drops the points after it
      if status == "paused" and nsteps == next_check and not announced then  -- watch(t), its second half
        next_check = 2 * next_check
        announced = long_run(t)
      end
      if progress and mech.now() >= next_draw then
        update(t, function() return mech.ode_stats(ode).steps end)
        next_draw = mech.now() + M.PROGRESS_PAUSE
      end
    end
  end

  -- The C loop when it can do the run; cfg._loop forces one (tests, bench).
  -- What keeps a run in Lua: an event function that is not recorded, and
  -- projection at a level p >= 3 (the violation of the levels above qd,
  -- constraints.level_violation and top_rows, is computed in Lua only).
  local loop_why = events_why
  if projecting and p then
    loop_why = ("project = true with constraints of order %d: the violation at the levels above qd is computed in Lua"):format(p)
  end
  local in_c = loop_why == nil
  if contact and not in_c then fail(sys, "unilateral contacts need the loop in C, and %s", loop_why) end
  if cfg._loop == "c" and not in_c then
    fail(sys, "'_loop' = \"c\": this run needs the Lua loop (%s)", loop_why)
  end
  if cfg._loop == "lua" and in_c then in_c, loop_why = false, "_loop = \"lua\"" end
  cfg.dense_on = dense and in_c      -- for the long-run notice's advice (cheaper)
  if contact then contact:attach(tr, { locate = locate, value = event_value, run = function() return crun end, pend = pend }) end
  local ok, err = pcall(in_c and run_c or run)
  if crun then                 -- what an interrupt cut short (the hook fires once)
    t = mech.ode_run_state(crun)
    local done_ok, done_err = pcall(catch_up)
    if ok and not done_ok then ok, err = false, done_err end
  end
  done()
  local s = mech.ode_stats(ode)
  tr.stats = { steps = s.steps, rejected = s.rejected, nfev = s.nfev, njev = s.njev, order = s.order,
    wall = mech.now() - wall0, loop = in_c and "c" or "lua", loop_why = loop_why, long_run = pace.notice }
  if s.reversed then   -- a constraint's gradient passed through zero (nz_constraint_row_reversed, src/mech/constrained.h)
    local r, ta, tb = s.reversed[1], s.reversed[2], s.reversed[3]
    tr.stats.reversed = { constraint = r, ta = ta, tb = tb }
    local msg = ("%ssimulate '%s': warning: constraint %d's gradient dPhi/d%s passed through zero between t = %s and "
      .. "t = %s: the equations do not determine the motion there (its multiplier grows without bound, and other "
      .. "continuations satisfy them too); the run went on along the one that continues the motion smoothly"):format(
      user_where(), sys.name, r, orders[r] == 0 and "q" or "q'", num(ta), num(tb))
    tr.warnings[#tr.warnings + 1] = msg
    M.warn(msg)
  end
  -- Dense output: how many output points came off an interpolant, how many
  -- its error control made step ends; grid_why: why the output grid capped
  -- the steps (nil when it did not).
  if crun then
    tr.stats.interpolated, tr.stats.forced = mech.ode_run_dense(crun)
    tr.stats.evaluator, tr.stats.native_from_step = evaluator(sys, mech.ode_run_native(crun))
  end
  -- grid_why: the output grid set the steps, because every output point
  -- was a step end (about one step per point) or because the interpolant's
  -- error control made many of them step ends (over 10% of the steps).
  local outputs = math.max(1, #tr.t - 1)
  if cfg.step then tr.stats.grid_why = nil
  elseif not dense and s.steps <= 1.5 * outputs then
    tr.stats.grid_why = cfg.dense == false and "dense = false"
      or multistep and ("%s keeps the grid unless dense = true (a point its interpolant misses would restart it)"):format(cfg.method)
      or "the Lua loop has no dense output (" .. loop_why .. ")"
  elseif dense and in_c and tr.stats.forced > 0.1 * s.steps then
    tr.stats.grid_why = ("the interpolant's error control made %d output points step ends"):format(tr.stats.forced)
  end
  if contact then contact:finish(tr) end
  return finish(sys, cfg, tr, ok, err, t)
end

return M
