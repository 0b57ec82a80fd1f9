-- nz/motion/options.lua - the options of sys:simulate checked, and a run's
-- configuration made from them (validate), with what the start needs at
-- the levels above q' (start_levels) and what methods 'taylor' and
-- 'variational' refuse; every error from the user's line, naming the option and
-- what it accepts.  The first floor of a run: nz/motion/simulate.lua
-- assembles options -> run (nz/motion/run.lua) -> trajectory.
local core = require "nz.core"
local constraints = require "nz.model.constraints"
local settings = require "nz.motion.settings"
local options = require "nz.base.options"
local user_where = require("nz.base.where").user_where
local finite = require("nz.base.args").finite

local mech = core.mech
local M = {}

-- q3d0, q4d0, ...: the start of higher levels (constraints of order >= 3).
local function level_option(key) return type(key) == "string" and key:match("^q%d+d0$") ~= nil end
M.level_option = level_option
local known = options.declare("sys:simulate", {
  q0 = true, qd0 = true, t0 = true, t1 = true, dt = true, method = true, rtol = true, atol = true,
  step = true, events = true, project = true, baumgarte = true, monitors = true, progress = true,
  check = true, h0 = true, event_tol = true, guess = true, qdd0 = true, dense = true, order = true,
}, level_option)
local known_monitors = { energy = true, work = true }

-- A message with its library location prefixes ("lua/nz/motion/simulate.lua:229: ")
-- removed; whether what is left starts with some (user's) file:line.
function M.strip_library(msg)
  repeat
    local rest = msg:match("^@?lua/nz/[%w_/]+%.lua:%d+: (.*)$") or msg:match("^[^:\n]*/lua/nz/[%w_/]+%.lua:%d+: (.*)$")
    if rest then msg = rest end
  until not rest
  return msg
end
function M.located(msg) return msg:find("^[^%s:]+:%d+: ") ~= nil end

-- simulate's error from the user's line: "file:line: simulate 'name': ...".
local function fail(sys, msg, ...) error(user_where() .. ("simulate '%s': " .. msg):format(sys.name, ...), 0) end
M.fail = fail

-- An option's value in a message.
local show = require("nz.base.args").shown
M.show = show

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
M.ulp = ulp

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

-- A fixed step: positive, and not so short that the run takes more than
-- MAX_FIXED_STEPS of them.
local function check_fixed_step(sys, cfg)
  check_positive(sys, cfg, "step", "a fixed step size")
  local nsteps = (cfg.t1 - cfg.t0) / cfg.step
  if nsteps > settings.MAX_FIXED_STEPS then
    fail(sys, "'step' = %g over [%g, %g] means %.3g steps; at most %g: take step >= %.3g (or drop 'step' for adaptive steps)",
      cfg.step, cfg.t0, cfg.t1, nsteps, settings.MAX_FIXED_STEPS, (cfg.t1 - cfg.t0) / settings.MAX_FIXED_STEPS)
  end
end

-- The variational integrators (src/ode/variational.h): a fixed step and an
-- order, no tolerance.
local VARIATIONAL_ORDERS = { [2] = true, [4] = true, [6] = true, [8] = true }
local function check_variational_stepping(sys, cfg)
  if cfg.step == nil then
    fail(sys, "method 'variational' takes a fixed step: give 'step' = h (the steps are then equal, no longer than h, "
      .. "and land on each output time)")
  end
  check_fixed_step(sys, cfg)
  if cfg.h0 ~= nil then fail(sys, "'h0' does not apply to method 'variational', whose steps are 'step': drop 'h0'") end
  cfg.order = cfg.order or 2
  if not VARIATIONAL_ORDERS[cfg.order] then
    fail(sys, "'order' must be 2, 4, 6 or 8 (method 'variational': 2 is the trapezoidal rule, Stormer-Verlet; 4, 6 "
      .. "and 8 its symmetric compositions), got %s", show(cfg.order))
  end
  check_positive(sys, cfg, "event_tol", "the tolerance on event times")
end

local function check_stepping(sys, cfg)
  if cfg.method == "variational" then return check_variational_stepping(sys, cfg) end
  if cfg.order ~= nil then
    fail(sys, "'order' applies to method 'variational' (2, 4, 6 or 8); method '%s' %s: drop 'order'", tostring(cfg.method),
      cfg.method == "taylor" and "takes its order from rtol/atol" or "has an order of its own")
  end
  if cfg.method == "taylor" then
    -- Taylor's method (src/ode/taylor.c): order and step from rtol/atol,
    -- no fixed step and no first step to give.
    for _, key in ipairs{ "step", "h0" } do
      if cfg[key] ~= nil then
        fail(sys, "'%s' does not apply to method 'taylor', which takes its order and steps from rtol/atol: drop '%s'", key, key)
      end
    end
    check_positive(sys, cfg, "rtol", "the relative tolerance")
    if not (cfg.rtol >= settings.MIN_RTOL and cfg.rtol < 1) then
      fail(sys, "'rtol' must be between %g and 1 (double precision cannot do better), got %s", settings.MIN_RTOL, show(cfg.rtol))
    end
    if not finite(cfg.atol) or not (cfg.atol >= 0 and cfg.atol < 1) then
      fail(sys, "'atol' (the absolute tolerance) must be a finite number in [0, 1), got %s", show(cfg.atol))
    end
    check_positive(sys, cfg, "event_tol", "the tolerance on event times")
    return
  end
  if type(cfg.method) ~= "string" then
    fail(sys, "'method' must be the name of a GSL stepper (%s), \"taylor\" or \"variational\", got %s",
      table.concat(method_names(), " "), show(cfg.method))
  end
  if not is_method(cfg.method) then
    fail(sys, "unknown method '%s'; GSL's steppers are: %s; taylor (Taylor's method: the series of the motion, with or "
      .. "without constraints); and variational (variational integrators from the Lagrangian, fixed steps) (option "
      .. "'method')", cfg.method, table.concat(method_names(), " "))
  end
  check_positive(sys, cfg, "rtol", "the relative tolerance")
  if not (cfg.rtol >= settings.MIN_RTOL and cfg.rtol <= 1) then
    fail(sys, "'rtol' must be between %g and 1 (double precision cannot do better), got %s", settings.MIN_RTOL, show(cfg.rtol))
  end
  if not finite(cfg.atol) or not (cfg.atol >= 0) then
    fail(sys, "'atol' (the absolute tolerance) must be a finite number >= 0, got %s", show(cfg.atol))
  end
  check_positive(sys, cfg, "h0", "the first step", true)
  check_positive(sys, cfg, "event_tol", "the tolerance on event times")
  if cfg.step ~= nil then
    check_fixed_step(sys, cfg)
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
  settings.warn(msg)
end

function M.validate(sys, o)
  if type(o) ~= "table" then fail(sys, "a table {q0 = ..., qd0 = ..., t1 = ...} expected, got %s", show(o)) end
  options.check(o, known, function(...) fail(sys, ...) end, level_option)
  check_vector(sys, o.q0, "q0")
  if o.qd0 ~= nil then check_vector(sys, o.qd0, "qd0") end
  local cfg = {}
  for k, v in pairs(settings.defaults) do cfg[k] = v end
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

-- Constraints of order >= 3 (constraints.level): the state is
-- (q, qd, qdd, .., q^(p-1), lambda, .., lambda^(p-3)) (src/mech/constrained_series.h).
-- Check what the start needs and return the part of y after q, qd.
-- top: a constraint of order p nonlinear in q^(p); then the state is only
-- q .. q^(p-1) ((q^(p), lambda) are solved at each time).
function M.start_levels(sys, cfg, orders, p, qd0, top)
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

-- simulate{guess = {lambda = {...}, q3d = {...}}}: Newton's first start for
-- (q^(p), lambda) under a constraint nonlinear in q^(p) (q^(p) = 0 if absent).
function M.top_guess(sys, g, p)
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

-- The bytes one output point keeps: q, q', q'' and lambda as doubles in C
-- (src/lua/lua_points.c), a slot in each Lua series (t, and the
-- violation's and the monitors'), both counted twice for the arrays'
-- doubling (and two more where run.lua records extras), and the tables of
-- the higher levels and q^(p), each a 64-byte
-- header and 16 bytes per number rounded up to a power of two.  Measured
-- (collectgarbage and the C array's size, 5001 points): 65 bytes for a
-- 1-DOF pendulum (this gives 80), 227 with both monitors (240), 222 for 5
-- DOF (272).
local function pow2(n) local c = n > 0 and 1 or 0; while c < n do c = 2 * c end; return c end
function M.point_bytes(sys, cfg, p, top)
  local k, nc = sys.k, sys.nc
  local series, tables, numbers = 1, 0, 0
  if nc > 0 then series = series + 1 end                                  -- violation
  if cfg.monitors.energy then series = series + 2 end
  if cfg.monitors.work then series = series + 1 end
  if p and p > 3 then series, tables, numbers = series + 1, tables + p - 2, numbers + (p - 3) * pow2(k) end
  if top then series, tables, numbers = series + 1, tables + 1, numbers + pow2(k) end
  if series > 1 then series = series + 2 end      -- run.lua's pend.y and pend.root, emptied but kept
  return 16 * (3 * k + nc) + 32 * series + 64 * tables + 16 * numbers
end

-- The output points a run keeps must fit in settings.MAX_MEMORY bytes.
function M.check_memory(sys, cfg, p, top)
  local npoints = math.floor((cfg.t1 - cfg.t0) / cfg.dt + 1e-9) + 1
  local bytes = M.point_bytes(sys, cfg, p, top)
  if npoints * bytes > settings.MAX_MEMORY then
    fail(sys, "'dt' = %g over [%g, %g] asks for %.3g output points of about %d bytes each (%.3g GB); at most %.3g GB "
      .. "are kept in memory (require('nz.motion.simulate').MAX_MEMORY): take dt >= %.3g, or a shorter span",
      cfg.dt, cfg.t0, cfg.t1, npoints, bytes, npoints * bytes / 1e9, settings.MAX_MEMORY / 1e9,
      (cfg.t1 - cfg.t0) / math.floor(settings.MAX_MEMORY / bytes - 1))
  end
end

-- What the GSL steppers' loop alone does, refused by taylor and
-- variational alike (refuse prefixes the method): the work monitor, a part
-- of the GSL steppers' state (take `instead`), and projection or
-- Baumgarte's terms under constraints (`why` the method has no use for
-- them; without constraints both do nothing, said once by validate as for
-- every method).
local function gsl_state_only(sys, cfg, refuse, instead, why)
  if cfg.monitors.work then
    refuse("does not integrate the 'work' monitor (it is part of the GSL steppers' state): leave it out, or take %s",
      instead)
  end
  if (cfg.project or cfg.alpha) and sys.nc > 0 then refuse("takes no 'project' or 'baumgarte': %s", why) end
end

-- What method 'taylor' does not do, refused from the user's line; p: the
-- level of constraints of order >= 3 (nil when none).
local function check_taylor(sys, cfg, p)
  local function refuse(msg, ...) fail(sys, "method 'taylor' " .. msg, ...) end
  if p then
    fail(sys, "method 'taylor' takes constraints of order 0, 1 and 2 (on q, q', q''), and this system's need the "
      .. "level %d (a constraint on the third derivative or higher): take a GSL stepper (rk8pd, the default, "
      .. "or any of %s)", p, table.concat(method_names(), " "))
  end
  gsl_state_only(sys, cfg, refuse, "rk8pd", "its series keeps the constraints to the order of the method along each "
    .. "step (their drift is the truncation's: tr:violation() shows it); take rk8pd to project")
  if not sys.recording then
    refuse("needs a recorded system (made with compile = true, the default): it builds the series on the graphs; "
      .. "take rk8pd for a system made with compile = false")
  end
end
M.method_names = method_names

-- What method 'variational' does not do, refused from the user's line
-- (src/ode/variational.h: holonomic constraints by the constrained
-- discrete equations); p as check_taylor's.
local function check_variational(sys, cfg, p)
  local function refuse(msg, ...) fail(sys, "method 'variational' " .. msg, ...) end
  local other = "take rk8pd, or taylor"
  if sys.contact then
    refuse("does not take unilateral contacts (their impacts break the discrete variational principle): %s", other)
  end
  if p then refuse("takes holonomic constraints (on q and t), and this system's are of order %d: %s", p, other) end
  for r, m in ipairs(cfg.orders) do
    if m == 1 then
      refuse("takes holonomic constraints (on q and t), and constraint %d is on q' (nonholonomic: the discrete "
        .. "Lagrange-d'Alembert principle for those is not built): %s", r, other)
    elseif m ~= 0 then
      refuse("takes holonomic constraints (on q and t), and constraint %d is of order %d (on q''): %s", r, m, other)
    end
  end
  gsl_state_only(sys, cfg, refuse, "rk4 at the same step", "its discrete equations hold the constraints to rounding "
    .. "at every step (RATTLE)")
end

-- A run's configuration from the user's options: validated, with the
-- constraints' classification at the start (cfg.orders, cfg.linear), the
-- level of constraints of order >= 3 (cfg.p; cfg.top when one is nonlinear
-- in q^(p): solved, not differentiated), what 'taylor' refuses and the
-- memory the output points need.
function M.prepare(sys, opts)
  local cfg = M.validate(sys, opts)
  cfg.orders, cfg.linear = {}, {}
  if sys.nc > 0 then
    cfg.orders, cfg.linear = constraints.orders(sys, { t = cfg.t0, q = cfg.q0, qd = cfg.qd0 })
    cfg.p = constraints.level(sys)
    cfg.top = constraints.top_level(sys)
    if cfg.top then cfg.p = cfg.top end
  end
  if not cfg.p then
    for key in pairs(opts) do
      if key == "qdd0" or level_option(key) then
        fail(sys, "'%s' is for constraints of order 3 or more; this system's accelerations follow from q and qd: leave it out", key)
      end
    end
  end
  M.check_memory(sys, cfg, cfg.p, cfg.top)
  if cfg.method == "taylor" then check_taylor(sys, cfg, cfg.p) end
  if cfg.method == "variational" then check_variational(sys, cfg, cfg.p) end
  return cfg
end

return M
