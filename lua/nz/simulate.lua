-- nz/simulate.lua - sys:simulate{...}: integrate the motion with a GSL
-- stepper (src/ode.c), one step at a time, so that this loop decides the
-- output grid, locates events, projects onto the constraints, records the
-- monitors a scene asked for (and nothing else), shows progress on a
-- terminal, and keeps what it computed when interrupted or when it fails.
local core = require "nz.core"
local constraints = require "nz.constraints"
local trajectory = require "nz.trajectory"

local mech = core.mech
local M = {}

-- Defaults chosen so that a first run is accurate: an 8th-order adaptive
-- method at tight tolerances (documented in help(nz.system)).
M.defaults = { method = "rk8pd", rtol = 1e-10, atol = 1e-12, points = 200, event_tol = 1e-12 }

local known = {
  q0 = true, qd0 = true, t0 = true, t1 = true, dt = true, method = true, rtol = true, atol = true,
  step = true, events = true, project = true, baumgarte = true, monitors = true, progress = true,
  check = true, h0 = true, event_tol = true, guess = true, qdd0 = true,
}
-- q3d0, q4d0, ...: the start of higher levels (constraints of order >= 3).
local function level_option(key) return type(key) == "string" and key:match("^q%d+d0$") ~= nil end
local known_monitors = { energy = true, work = true }

local function fail(sys, msg, ...) error(("simulate '%s': " .. msg):format(sys.name, ...), 3) end

local function check_vector(sys, v, what)
  if type(v) ~= "table" or #v ~= sys.k then
    fail(sys, "'%s' must be a table of %d numbers (one per coordinate: %s)", what, sys.k, table.concat(sys.coords, ", "))
  end
  for i = 1, sys.k do
    if type(v[i]) ~= "number" or v[i] ~= v[i] or math.abs(v[i]) == math.huge then
      fail(sys, "'%s'[%d] must be a finite number", what, i)
    end
  end
end

local function validate(sys, o)
  if type(o) ~= "table" then fail(sys, "a table {q0 = ..., qd0 = ..., t1 = ...} expected") end
  for key in pairs(o) do
    if not known[key] and not level_option(key) then
      local names = {}
      for k in pairs(known) do names[#names + 1] = k end
      table.sort(names)
      fail(sys, "unknown option '%s' (options: %s)", tostring(key), table.concat(names, ", "))
    end
  end
  check_vector(sys, o.q0, "q0")
  if o.qd0 ~= nil then check_vector(sys, o.qd0, "qd0") end
  local cfg = {}
  for k, v in pairs(M.defaults) do cfg[k] = v end
  for k, v in pairs(o) do cfg[k] = v end
  cfg.t0 = cfg.t0 or 0
  if type(cfg.t1) ~= "number" or not (cfg.t1 > cfg.t0) then fail(sys, "'t1' must be a number greater than t0 = %g", cfg.t0) end
  cfg.dt = cfg.dt or (cfg.t1 - cfg.t0) / cfg.points
  if type(cfg.dt) ~= "number" or not (cfg.dt > 0) then fail(sys, "'dt' (the output spacing) must be a positive number") end
  for _, key in ipairs{ "rtol", "atol" } do
    if type(cfg[key]) ~= "number" or not (cfg[key] > 0) then fail(sys, "'%s' must be a positive number", key) end
  end
  if cfg.step ~= nil and (type(cfg.step) ~= "number" or not (cfg.step > 0)) then
    fail(sys, "'step' (a fixed step size) must be a positive number")
  end
  cfg.monitors = cfg.monitors or {}
  for key in pairs(cfg.monitors) do
    if not known_monitors[key] then fail(sys, "unknown monitor '%s' (monitors: energy, work)", tostring(key)) end
  end
  if cfg.monitors.work then cfg.monitors.energy = true end   -- T + V - work needs T + V
  if cfg.baumgarte ~= nil and cfg.baumgarte ~= false then
    local b = cfg.baumgarte
    if type(b) == "number" then b = { alpha = b, beta = b } end
    if type(b) ~= "table" or type(b.alpha) ~= "number" or type(b.beta or b.alpha) ~= "number" then
      fail(sys, "'baumgarte' must be {alpha = a, beta = b} (or one number for both)")
    end
    cfg.alpha, cfg.beta = b.alpha, b.beta or b.alpha
  end
  cfg.events = cfg.events or {}
  for i, ev in ipairs(cfg.events) do
    if type(ev) == "function" then ev = { f = ev }; cfg.events[i] = ev end
    if type(ev) ~= "table" or type(ev.f) ~= "function" then
      fail(sys, "event %d must be {f = function(t, q, qd) ... end [, stop = true, direction = 1 or -1, name = ...]}", i)
    end
    ev.name = ev.name or ("event " .. i)
    ev.direction = ev.direction or 0
  end
  return cfg
end

-- Progress on a terminal only, after half a second, at most 5 times a second.
local function progress_bar(cfg, t0, t1)
  local enabled = cfg.progress
  if enabled == nil then enabled = mech.isatty(2) end
  if not enabled then return function() end, function() end end
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
  return update, done
end

-- Constraints of order >= 3 (constraints.level): the state is
-- (q, qd, qdd, .., q^(p-1), lambda, .., lambda^(p-3)) (src/constrained_series.h).
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

local function split(y, k)
  local q, qd = {}, {}
  for i = 1, k do q[i], qd[i] = y[i], y[k + i] end
  return q, qd
end

function M.simulate(sys, opts)
  local cfg = validate(sys, opts)
  local k, engine = sys.k, sys.engine
  local orders, linear, p, top = {}, {}, nil, nil
  if sys.nc > 0 then
    orders, linear = constraints.orders(sys)
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
  local qd0 = cfg.qd0
  if not qd0 then qd0 = {}; for i = 1, k do qd0[i] = 0 end end   -- at rest
  if sys.nc > 0 and cfg.check ~= false then constraints.check_state(sys, cfg.t0, cfg.q0, qd0) end
  local tail = p and start_levels(sys, cfg, orders, p, qd0, top)
  local guess = top and cfg.guess and top_guess(sys, cfg.guess, p)

  local ode = mech.ode_new(engine, {
    method = cfg.method, rtol = cfg.rtol, atol = cfg.atol, h0 = cfg.h0 or math.min(cfg.dt, 1e-3),
    work = cfg.monitors.work, orders = orders, linear = linear, alpha = cfg.alpha, beta = cfg.beta, level = p,
    top = top ~= nil, guess = guess,
  })
  local tr = trajectory.new(sys, cfg)
  if cfg.monitors.energy then tr.energy, tr.generalized_energy = {}, {} end
  if cfg.monitors.work then tr.work = {} end

  local y = {}
  for i = 1, k do y[i], y[k + i] = cfg.q0[i], qd0[i] end
  if cfg.monitors.work then y[2 * k + 1] = 0 end
  for _, v in ipairs(tail or {}) do y[#y + 1] = v end

  local function record(t, yy)
    local q, qd = split(yy, k)
    local qdd, lambda, root = mech.ode_accel(ode, engine, t, yy)
    local n = #tr.t + 1
    tr.t[n], tr.q[n], tr.qd[n], tr.qdd[n], tr.lambda[n] = t, q, qd, qdd, lambda
    if tr.violation then tr.violation[n] = (constraints.violation(sys, t, q, qd)) end
    if top then                          -- q''' .. q^(p-1) of the state, q^(p) solved
      local levels = { q, qd }
      for j = 2, p - 1 do levels[j + 1] = { table.unpack(yy, j * k + 1, (j + 1) * k) } end
      tr.top = tr.top or {}
      tr.top[n] = root
      if p > 3 then tr.higher = tr.higher or {}; tr.higher[n] = { table.unpack(levels, 4) } end
      tr.branch = tr.branch or { from = guess and "guess" or "least squares", [constraints.level_name(p)] = root, lambda = lambda }
      tr.violation[n] = math.max(tr.violation[n], (constraints.top_rows(sys, t, levels, p)))
    elseif p then                        -- q''' .. q^(p-1) and the multipliers of the state
      local levels, lambdas = { q, qd }, {}
      for j = 2, p - 1 do levels[j + 1] = { table.unpack(yy, j * k + 1, (j + 1) * k) } end
      for j = 1, p - 2 do lambdas[j] = { table.unpack(yy, p * k + (j - 1) * sys.nc + 1, p * k + j * sys.nc) } end
      if p > 3 then tr.higher = tr.higher or {}; tr.higher[n] = { table.unpack(levels, 4) } end
      tr.violation[n] = math.max(tr.violation[n], constraints.level_violation(sys, t, levels, lambdas, p))
    end
    if tr.energy then tr.energy[n], tr.generalized_energy[n] = sys:energy(t, q, qd) end
    if tr.work then tr.work[n] = yy[2 * k + 1] end
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
  local function state_at(ta, ya, tau)
    locator = locator or mech.ode_new(engine, { method = "rk8pd", rtol = math.min(cfg.rtol, 1e-10),
      atol = math.min(cfg.atol, 1e-12), work = cfg.monitors.work, orders = orders, linear = linear,
      alpha = cfg.alpha, beta = cfg.beta, h0 = math.max(tau - ta, 1e-12), level = p, top = top ~= nil,
      guess = top and root_at(ta, ya) })
    mech.ode_reset(locator)
    local t, h, yy = ta, math.max(tau - ta, 1e-12), ya
    while t < tau do t, h, yy = mech.ode_step(locator, engine, t, tau, h, yy) end
    return yy
  end

  local function event_value(ev, t, yy)
    local q, qd = split(yy, k)
    local v = ev.f(t, q, qd, sys.params)
    if type(v) ~= "number" or v ~= v then
      fail(sys, "event '%s' must return a number, got %s at t = %g", ev.name, tostring(v), t)
    end
    return v
  end

  local function crosses(ev, ga, gb)
    if ga == 0 or (ga > 0) == (gb > 0) then return false end
    return ev.direction == 0 or (ev.direction > 0 and gb > ga) or (ev.direction < 0 and gb < ga)
  end

  -- Illinois' variant of regula falsi on [ta, tb]: robust, and superlinear.
  local function locate(ev, ta, ya, ga, tb, gb)
    local tol = cfg.event_tol * math.max(1, math.abs(tb))
    local side = 0
    local tm, ym = tb, nil
    for _ = 1, 100 do
      if tb - ta <= tol then break end
      tm = (ta * gb - tb * ga) / (gb - ga)
      if not (tm > ta and tm < tb) then tm = 0.5 * (ta + tb) end
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

  local update, done = progress_bar(cfg, cfg.t0, cfg.t1)
  local wall0 = mech.now()
  local t, h = cfg.t0, cfg.h0 or math.min(cfg.dt, 1e-3)
  local gvals = {}

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
        if mech.interrupted() then error("interrupted!", 0) end
        local ta, ya = t, y
        if cfg.step then
          nfixed = nfixed - 1
          t, y = mech.ode_step_fixed(ode, engine, t, hfixed, y)
          if nfixed == 0 then t = tout end
        else
          t, h, y = mech.ode_step(ode, engine, t, tout, h, y)
        end
        if cfg.project and sys.nc > 0 then
          y = project_state(t, y)
          mech.ode_reset(ode)
        end
        for e, ev in ipairs(cfg.events) do
          local g = event_value(ev, t, y)
          if crosses(ev, gvals[e], g) then
            local te, ye = locate(ev, ta, ya, gvals[e], t, g)
            local q, qd = split(ye, k)
            tr.events[#tr.events + 1] = { name = ev.name, t = te, q = q, qd = qd }
            if ev.stop then
              record(te, ye)
              tr.status, tr.message = "stopped", ("event '%s' at t = %.12g"):format(ev.name, te)
              return
            end
          end
          gvals[e] = g
        end
        update(t, function() return mech.ode_stats(ode).steps end)
      end
      record(t, y)
    end
    tr.status = "done"
  end

  local ok, err = pcall(run)
  done()
  local s = mech.ode_stats(ode)
  tr.stats = { steps = s.steps, rejected = s.rejected, nfev = s.nfev, njev = s.njev, wall = mech.now() - wall0 }
  if not ok then
    local msg = tostring(err)
    if msg:find("interrupted!", 1, true) then
      tr.status, tr.message = "interrupted", ("stopped by Ctrl-C at t = %.6g; the part computed so far is kept"):format(t)
      io.stderr:write(("simulate '%s': %s (%d points)\n"):format(sys.name, tr.message, #tr.t))
      return tr
    end
    tr.status, tr.message = "failed", msg
    require("nz").last = tr
    error(("%s\n(the trajectory computed so far, %d points up to t = %.6g, is kept in nz.last)"):format(
      msg, #tr.t, tr.t[#tr.t] or cfg.t0), 2)
  end
  return tr
end

return M
