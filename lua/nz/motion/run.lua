-- nz/motion/run.lua - a run of sys:simulate: the integrator made for the
-- system (src/ode/ode.c's GSL steppers, Taylor's method, src/ode/taylor.c,
-- or a variational integrator, src/ode/variational.c)
-- and stepped by the one stepping loop, in C (src/ode/ode_run.c).  The loop
-- keeps the output grid, locates the events and watches the drift off the
-- constraints; it asks this module, through hooks, for what only Lua knows
-- (an event function that could not be recorded, the violation of
-- constraints of order >= 3) and returns here to hand over the output
-- points, a located event, a projection to make, a pause for the progress
-- bar and the long-run notice, or the end.  This module records what an
-- output point holds besides t, q, qd, q'' and lambda (the monitors, the
-- violation, the higher levels), projects, and keeps what was computed
-- when the run is interrupted or fails.
local core = require "nz.core"
local constraints = require "nz.model.constraints"
local record_graph = require "nz.model.record"
local settings = require "nz.motion.settings"
local options = require "nz.motion.options"
local advice = require "nz.motion.advice"
local variational = require "nz.motion.variational"
local frontend = require "nz.base.frontend"
local trajectory = require "nz.motion.trajectory"

local mech = core.mech
local fail, show, state_text = options.fail, options.show, advice.state_text
local M = {}

local function split(y, k)
  local q, qd = {}, {}
  for i = 1, k do q[i], qd[i] = y[i], y[k + i] end
  return q, qd
end

-- Progress on a terminal (or a notebook) only, after half a second, at most
-- 5 times a second: update(t, steps) with steps a function, asked only when
-- the bar is drawn; done() erases the line.
local function progress_bar(cfg)
  local enabled = cfg.progress
  if enabled == nil then enabled = frontend.progress() end
  if not enabled then return function() end, function() end, false end
  local start, last, shown = mech.now(), 0, false
  local function update(t, steps)
    local now = mech.now()
    if now - start < 0.5 or now - last < 0.2 then return end
    last, shown = now, true
    local frac = (t - cfg.t0) / (cfg.t1 - cfg.t0)
    local width = 30
    local fill = math.floor(frac * width + 0.5)
    io.stderr:write(("\r[%s%s] %3d%%  t = %-10.4g steps %d  (Ctrl-C stops, keeping what is done)")
      :format(("#"):rep(fill), (" "):rep(width - fill), math.floor(100 * frac), t, steps()))
  end
  local function done()
    if shown then io.stderr:write("\r\27[K") end
  end
  return update, done, true
end

-- The levels q .. q^(p-1) of a state and, when the multipliers are part of
-- it (constraints linear in q^(p), p >= 3), lambda .. lambda^(p-3).
local function state_levels(run, yy)
  local k, p = run.k, run.cfg.p
  local q, qd = split(yy, k)
  local levels, lambdas = { q, qd }, {}
  for j = 2, (p or 2) - 1 do levels[j + 1] = { table.unpack(yy, j * k + 1, (j + 1) * k) } end
  if p and not run.cfg.top then
    for j = 1, p - 2 do lambdas[j] = { table.unpack(yy, p * k + (j - 1) * run.sys.nc + 1, p * k + j * run.sys.nc) } end
  end
  return levels, lambdas
end

-- How far the state is from the constraints: position and velocity level,
-- and at level p the equations of the levels the state holds.
local function state_violation(run, t, yy)
  local sys, cfg = run.sys, run.cfg
  local levels, lambdas = state_levels(run, yy)
  local v = constraints.violation(sys, t, levels[1], levels[2])
  if cfg.top then v = math.max(v, (constraints.top_rows(sys, t, levels, cfg.p)))
  elseif cfg.p then v = math.max(v, constraints.level_violation(sys, t, levels, lambdas, cfg.p)) end
  return v
end

-- project = true: q, qd onto the constraints of order <= 1 and, at level
-- p, q'' .. q^(p-1) (and the multipliers of the state) onto the equations
-- of their levels, each the least change from its current value.
local function project_state(run, tt, yy)
  local sys, k, p, top = run.sys, run.k, run.cfg.p, run.cfg.top
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

-- What an output point records besides t, q, qd, qdd, lambda (the C loop
-- records those and leaves these to this function): point n at (t, yy),
-- with its multipliers and (top) the root q^(p) there.
local function record_extras(run, n, t, yy, lambda, root)
  local tr, sys, cfg = run.tr, run.sys, run.cfg
  if tr.violation then tr.violation[n] = state_violation(run, t, yy) end
  if cfg.p and cfg.p > 3 then tr.higher = tr.higher or {}; tr.higher[n] = { table.unpack(state_levels(run, yy), 4) } end
  if cfg.top then                        -- q^(p) solved, and the branch Newton started on
    tr.top = tr.top or {}
    tr.top[n] = root
    tr.branch = tr.branch or { from = cfg.guess and "guess" or "least squares", [constraints.level_name(cfg.p)] = root,
      lambda = lambda }
  end
  if tr.energy then tr.energy[n], tr.generalized_energy[n] = sys:energy(t, split(yy, run.k)) end   -- (not tr.q[n]: that would make the point's tables)
  if tr.work then tr.work[n] = yy[2 * run.k + 1] end
end

-- The extras of the points the loop handed over since the last call.
-- Ctrl-C's hook may cut it short: it is taken up again after the run
-- (run.cdone: the points done).
local function catch_up(run)
  if not run.pend then return end
  local tr, pend = run.tr, run.pend
  for n = run.cdone + 1, #tr.t do
    record_extras(run, n, tr.t[n], pend.y[n], tr.lambda[n], pend.root[n] or nil)
    pend.y[n], pend.root[n] = nil, nil
    run.cdone = n
  end
end

-- A point recorded from Lua (a stopping event's): the state with q'' and
-- lambda there, as the loop records its points.
local function record(run, t, yy)
  local tr, k = run.tr, run.k
  local q, qd = split(yy, k)
  local qdd, lambda, root = mech.ode_accel(run.ode, run.engine, t, yy)
  local n = trajectory.append(tr, t, q, qd, qdd, lambda)
  if run.pend then record_extras(run, n, t, yy, lambda, root) end
  run.cdone = n
end

-- An event function that raises: its own file:line first (the fault is
-- there), then the system, the event, the time and the state.
local function lua_event_value(run, ev, t, yy)
  local sys = run.sys
  local q, qd = split(yy, run.k)
  local ok, v = pcall(ev.f, t, q, qd, sys.params)
  if not ok then
    if type(v) ~= "string" then error(v, 0) end        -- an error object (an interrupt): as it is
    local where, what = v:match("^([^%s:]+:%d+: )(.*)$")
    error(("%ssimulate '%s': event '%s' raised an error%s: %s"):format(where or require("nz.base.where").user_where(),
      sys.name, ev.name, state_text(t, q, qd), what or v), 0)
  end
  if type(v) ~= "number" or v - v ~= 0 then      -- nil, a jet, NaN or an infinity: no sign to follow
    fail(sys, "event '%s' must return a finite number, got %s%s", ev.name, show(v), state_text(t, q, qd))
  end
  return v
end

-- The event functions, recorded once on tracers (nz/model/record.lua) into
-- graphs the loop evaluates in C after every step and while locating.
-- Where a graph fails at a state (a domain error) or could not be recorded
-- (a Lua branch on the state, math.* on it, a system made with compile =
-- false), the loop asks the Lua function (the hook's fallback), which gives
-- the value or raises with the user's line; Taylor's method needs them all
-- recorded (on the step's polynomial a Lua function would see numbers).
local function events_hooks(run)
  local sys, cfg = run.sys, run.cfg
  if #cfg.events == 0 then return nil, nil, nil end
  local evals, why
  if sys.recording then
    local fs = {}
    for i, ev in ipairs(cfg.events) do fs[i] = ev.f end
    local rec, bad, reason = record_graph.state_functions(run.engine, fs)
    if rec then evals = mech.ode_events_new(rec.recording, rec.nodes, rec.values, run.k)
    elseif run.taylor then
      fail(sys, "method 'taylor' needs event functions it can record, and event '%s' cannot be (%s): take rk8pd, which "
        .. "calls it in Lua", cfg.events[bad].name, reason)
    else why = ("event '%s' cannot be recorded (%s): the events are called in Lua"):format(cfg.events[bad].name, reason) end
  else
    why = "the system is not recorded (compile = false): its event functions are called in Lua"
  end
  local fallback = not (evals and run.taylor) and function(e, tt, yy) return lua_event_value(run, cfg.events[e], tt, yy) end
    or nil
  return evals, fallback, why
end

-- The integrator at the run's tolerances: a GSL stepper, or Taylor's method
-- (whose binding's refusals are said as simulate's: the user's line, then
-- what is wrong).
local function make_ode(run, ode_cfg)
  if not run.taylor then return mech.ode_new(run.engine, ode_cfg) end
  local ok, res = pcall(mech.ode_new, run.engine, ode_cfg)
  if ok then return res end
  if type(res) ~= "string" then error(res, 0) end
  local what = options.strip_library(res):gsub("^[^%s:]+:%d+: ", "", 1):gsub("^system '[^']*': '[%w_]+': ", "")
    :gsub("^system '[^']*': ", "")
  fail(run.sys, "method 'taylor' cannot run this system: %s; take rk8pd", what)
end

-- The locator (ode_run.h): where a GSL stepper's dense output misses the
-- tolerance at a point an event is looked for, the step is integrated again
-- at tight tolerances (settings.LOCATOR, or the run's when tighter), so
-- that events are located to tolerance whatever the method (multistep ones
-- included).  A top integrator's locator starts Newton from the run's root
-- at the start (it stays on the run's branch).
local function make_locator(run, ode_cfg)
  local cfg, loc = run.cfg, settings.LOCATOR
  local lcfg = {}
  for key, v in pairs(ode_cfg) do lcfg[key] = v end
  lcfg.method, lcfg.rtol, lcfg.atol = loc.method, math.min(cfg.rtol, loc.rtol), math.min(cfg.atol, loc.atol)
  if cfg.top then
    local _, lambda, root = mech.ode_accel(run.ode, run.engine, cfg.t0, run.y0)
    lcfg.guess = { table.unpack(root) }
    for _, v in ipairs(lambda) do lcfg.guess[#lcfg.guess + 1] = v end
  end
  return mech.ode_new(run.engine, lcfg)
end

-- The constraints' drift watched after every step (project = true): in C
-- for constraints of order <= 2 (their orders), else by state_violation.
local function projection_hooks(run)
  local sys, cfg = run.sys, run.cfg
  if not run.projecting then return 0, nil, nil end
  -- msadams and msbdf carry a history that a projection invalidates (they
  -- restart at order 1): they project only when the drift exceeds 100 times
  -- the run's tolerance, since at PROJECT_TOL each restart would cause the
  -- drift of the next
  local tol = run.multistep and math.min(1e-6, math.max(settings.PROJECT_TOL,
    settings.PROJECT_MULTISTEP * math.max(cfg.rtol, cfg.atol))) or settings.PROJECT_TOL
  if cfg.p then return tol, nil, function(tt, yy) return state_violation(run, tt, yy) end end
  local orders = {}
  for r, c in ipairs(constraints.classify(sys)) do orders[r] = c.order end
  return tol, orders, nil
end

-- A Taylor step that failed ({taylor_stop = why, message = what} from the
-- binding): said with the user's line and the last output point.
local function taylor_failure(run, err)
  local tr = run.tr
  local n = #tr.t
  local why = err.taylor_stop == "hook" and "" or ": the motion may be singular there (a velocity blowing up), "
    .. "or the tolerance too tight"
  return ("%ssimulate '%s': method 'taylor' %s%s%s; last output point%s"):format(require("nz.base.where").user_where(),
    run.sys.name, err.message, err.taylor_stop == "step" and " (the series predicts a step below the time's resolution)"
    or "", why, state_text(tr.t[n], tr.q[n], tr.qd[n]))
end

-- Event e located at te, state ye, its value rising through zero (dir = 1)
-- or falling (-1): recorded, a contact's transition made; true when it stops
-- the run (its point recorded).
local function on_event(run, e, te, ye, dir)
  local cfg = run.cfg
  if e > #cfg.events then return run.contact:located(e - #cfg.events, te, ye) end
  local ev = cfg.events[e]
  local q, qd = split(ye, run.k)
  local tr = run.tr
  tr.events[#tr.events + 1] = { name = ev.name, t = te, q = q, qd = qd, direction = dir }
  if not ev.stop then return false end
  record(run, te, ye)
  tr.status, tr.message = "stopped", ("event '%s' at t = %.12g"):format(ev.name, te)
  return true
end

-- The long-run notice's evidence: the spectral radius of the motion's exact
-- Jacobian at the current state (the implicit steppers' own, from a bsimp
-- stepper of the same motion made for it, so that the run's stepper and
-- its statistics are left alone).
local function evidence(run, tt)
  local jcfg = {}
  for key, v in pairs(run.ode_cfg) do jcfg[key] = v end
  jcfg.method = "bsimp"
  local o = mech.ode_new(run.engine, jcfg)
  local rho = 0
  for _, e in ipairs((mech.eigen((mech.ode_jacobian(o, run.engine, tt, run.y))))) do
    rho = math.max(rho, math.sqrt(e[1] ^ 2 + e[2] ^ 2))
  end
  return rho
end

-- A collapse of the steps: a branch that flips at rounding level at the
-- current state stops the run, naming it (advice.rounding_flip).
local function flip(run, why)
  local ok, qdd = pcall(mech.ode_accel, run.ode, run.engine, run.t, run.y)
  advice.rounding_flip(run.sys, run.cfg, run.engine, run.t, run.y, ok and qdd or nil, why)
end

-- The loop, from the start to the end, a stop or a raise: it returns here
-- to hand over the output points (every 1024, and at the end), at the step
-- counts where the long-run notice looks, every PROGRESS_PAUSE seconds
-- while the progress bar shows, when an event was located, when the
-- violation exceeds the projection's tolerance, and to stop.
local function step_all(run)
  local cfg, tr = run.cfg, run.tr
  local next_draw = mech.now() + settings.PROGRESS_PAUSE
  local next_check = 16
  while true do
    local ok, status, a1, a2, a3, a4 = pcall(mech.ode_run, run.crun, run.engine, tr, run.pend,
      not run.announced and next_check or 0, run.progress and next_draw or 0)
    run.t, run.y, run.nsteps = mech.ode_run_state(run.crun)   -- for the messages
    catch_up(run)
    if not ok then
      if type(status) == "table" and status.taylor_stop then status = taylor_failure(run, status) end
      error(status, 0)
    end
    if status == "done" then tr.status = "done"; return end
    if status == "stalled" then
      local q, qd = split(run.y, run.k)
      advice.stalled(run.sys, cfg, run.t, a1, run.nsteps, q, qd, run.qd0, function(why) flip(run, why) end)
    end
    if status == "project" then
      run.y = project_state(run, run.t, run.y)
      tr.projections = tr.projections + 1
      if run.multistep then mech.ode_reset(run.ode) end     -- keeps the statistics (src/ode/ode.c)
      mech.ode_run_set_state(run.crun, run.y)
    end
    if status == "event" and on_event(run, a1, a2, a3, a4) then return end
    if status == "paused" and run.nsteps == next_check and not run.announced then
      next_check = 2 * next_check
      run.announced = advice.long_run_notice(run.sys, cfg, tr, run.nsteps, run.t, run.wall0, run.done, run.compiled0,
        run.pace, function(tt) return evidence(run, tt) end, function(why) flip(run, why) end)
    end
    if run.progress and mech.now() >= next_draw then
      run.update(run.t, function() return mech.ode_stats(run.ode).steps end)
      next_draw = mech.now() + settings.PROGRESS_PAUSE
    end
  end
end

-- The statistics (tr.stats) and what they say: a constraint whose gradient
-- passed through zero, why the output grid set the steps.
local function statistics(run)
  local sys, cfg, tr = run.sys, run.cfg, run.tr
  local s = mech.ode_stats(run.ode)
  tr.stats = { steps = s.steps, rejected = s.rejected, nfev = s.nfev, njev = s.njev, order = s.order,
    wall = mech.now() - run.wall0, long_run = run.pace.notice, events_why = run.events_why }
  if s.reversed then   -- nz_constraint_row_reversed, src/mech/constrained.h
    local r, ta, tb = s.reversed[1], s.reversed[2], s.reversed[3]
    tr.stats.reversed = { constraint = r, ta = ta, tb = tb }
    local msg = ("%ssimulate '%s': warning: constraint %d's gradient dPhi/d%s passed through zero between t = %s and "
      .. "t = %s: the equations do not determine the motion there (its multiplier grows without bound, and other "
      .. "continuations satisfy them too); the run went on along the one that continues the motion smoothly"):format(
      require("nz.base.where").user_where(), sys.name, r, run.orders[r] == 0 and "q" or "q'", advice.num(ta), advice.num(tb))
    tr.warnings[#tr.warnings + 1] = msg
    settings.warn(msg)
  end
  tr.stats.interpolated, tr.stats.forced = mech.ode_run_dense(run.crun)
  tr.stats.evaluator, tr.stats.native_from_step = advice.evaluator(sys, mech.ode_run_native(run.crun))
  -- grid_why: the output grid set the steps, because every output point
  -- was a step end (about one step per point) or because the interpolant's
  -- error control made many of them step ends (over 10% of the steps).
  local outputs = math.max(1, #tr.t - 1)
  if cfg.step then tr.stats.grid_why = nil
  elseif not run.dense and s.steps <= 1.5 * outputs then
    tr.stats.grid_why = cfg.dense == false and "dense = false"
      or ("%s keeps the grid unless dense = true (a point its interpolant misses would restart it)"):format(cfg.method)
  elseif run.dense and tr.stats.forced > 0.1 * s.steps then
    tr.stats.grid_why = ("the interpolant's error control made %d output points step ends"):format(tr.stats.forced)
  end
end

-- The integrator and the loop for the run, with the hooks it needs.
local function start(run)
  local sys, cfg = run.sys, run.cfg
  run.ode_cfg = {
    method = cfg.method, rtol = cfg.rtol, atol = cfg.atol, h0 = cfg.h0 or math.min(cfg.dt, 1e-3),
    work = cfg.monitors.work, orders = run.orders, linear = run.linear, alpha = cfg.alpha, beta = cfg.beta,
    level = cfg.p, top = cfg.top ~= nil, guess = run.guess, contacts = run.contact and run.contact.cs,
    order = cfg.order, verlet = cfg.method == "variational" and variational.verlet(sys, run.engine),
  }
  run.ode = make_ode(run, run.ode_cfg)
  local evals, fallback, why = events_hooks(run)
  run.events_why = why
  local directions = {}
  for e, ev in ipairs(cfg.events) do directions[e] = ev.direction end
  local nevents = #cfg.events + (run.contact and 2 * run.contact.n or 0)
  local locator = nevents > 0 and not run.taylor and make_locator(run, run.ode_cfg) or nil
  local project_tol, orders, violation = projection_hooks(run)
  run.crun = mech.ode_run_new(run.ode, { t0 = cfg.t0, t1 = cfg.t1, dt = cfg.dt, step = cfg.step,
    h0 = cfg.h0 or math.min(cfg.dt, 1e-3), y = run.y0,
    stall_window = settings.STALL.window, stall_fraction = settings.STALL.fraction,
    capacity = math.min(1024, math.ceil((cfg.t1 - cfg.t0) / cfg.dt - 1e-9) + 1),   -- no larger than the grid
    events = evals, directions = directions, fallback = fallback, locator = locator, event_tol = cfg.event_tol,
    project_tol = project_tol, orders = orders, violation = violation,
    dense = run.dense, rtol = cfg.rtol, atol = cfg.atol })
end

-- The run of sys with the prepared configuration cfg (nz/motion/options.lua)
-- from the state y0 (q, qd, then the work or the higher levels), in the
-- integrator's engine (the system's, or its contacts' system: contact, from
-- nz/motion/contact_run.lua).  Returns the trajectory tr, whether the run
-- ended without raising, the error, and the time reached.
function M.run(sys, cfg, tr, start_state)
  local run = {
    sys = sys, cfg = cfg, tr = tr, k = sys.k, engine = start_state.engine, orders = start_state.orders,
    linear = start_state.linear, contact = start_state.contact, guess = start_state.guess, y0 = start_state.y,
    qd0 = start_state.qd0, taylor = cfg.method == "taylor", cdone = 0, nsteps = 0, t = cfg.t0,
  }
  run.y = run.y0
  run.multistep = cfg.method == "msadams" or cfg.method == "msbdf"
  run.projecting = cfg.project and sys.nc > 0
  -- Dense output (src/ode/ode_run.h): the output points inside a step from
  -- its interpolant, under an error control that makes a point a step end
  -- when the interpolant misses the tolerance there.  Such a step is taken
  -- again from its start, which restarts msadams and msbdf at order 1: on a
  -- pendulum (dt = 0.01, rtol 1e-10) msbdf took 79,410 steps with it against
  -- 20,949 without, so those two keep the grid unless asked (dense = true).
  -- Taylor's dense output is its own solution, the step's polynomial.
  run.dense = run.taylor or (not cfg.step and (cfg.dense == true or (cfg.dense == nil and not run.multistep)))
  cfg.dense_on = run.dense      -- for the long-run notice's advice
  run.pend = (tr.violation or (cfg.p and cfg.p > 3) or cfg.top or tr.energy or tr.work) and { y = {}, root = {} } or nil
  tr.projections = run.projecting and 0 or nil
  run.update, run.done, run.progress = progress_bar(cfg)
  run.wall0, run.compiled0 = mech.now(), advice.compile_seconds(sys)
  run.pace = { steps = 0, t = cfg.t0, wall = run.wall0, compiled = run.compiled0 }
  if run.contact then run.contact:attach(tr, { run = function() return run.crun end }) end
  local ok, err = pcall(function()
    start(run)
    step_all(run)
  end)
  if run.crun then             -- what an interrupt cut short (the hook fires once)
    run.t = mech.ode_run_state(run.crun)
    local done_ok, done_err = pcall(catch_up, run)
    if ok and not done_ok then ok, err = false, done_err end
  end
  run.done()
  if run.crun then statistics(run) else tr.stats = { steps = 0, rejected = 0, nfev = 0, njev = 0 } end
  if run.contact then run.contact:finish(tr) end
  return ok, err, run.t
end

return M
