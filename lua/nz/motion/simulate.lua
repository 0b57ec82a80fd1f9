-- nz/motion/simulate.lua - sys:simulate{...}: the motion from a start, as a
-- trajectory.  It assembles three steps, each a module of its own:
--   options   nz/motion/options.lua: the options checked, the run's
--             configuration (the constraints' classification, the levels
--             above q' the start needs, what a method refuses);
--   run       nz/motion/run.lua: the integrator stepped by the one stepping
--             loop, in C (src/ode/ode_run.c), with the events, projection,
--             monitors and progress the options asked for and nothing
--             else; nz/motion/advice.lua says what a long run would cost;
--   result    the trajectory (nz/motion/trajectory.lua), returned whole,
--             or partial when interrupted, or kept in nz.last when the run
--             fails (the error with one location: the user's).
-- Unilateral contacts (nz/motion/contact_run.lua) change the start (an
-- impact at t0), the integrated system and the events.
-- Its fields are the run's settings (nz/motion/settings.lua: defaults,
-- limits, warn), read and written through this module.
local core = require "nz.core"
local constraints = require "nz.model.constraints"
local trajectory = require "nz.motion.trajectory"
local settings = require "nz.motion.settings"
local options = require "nz.motion.options"
local run = require "nz.motion.run"
local state_text = require("nz.motion.advice").state_text
local user_where = require("nz.base.where").user_where
local session = require "nz.base.session"

local mech = core.mech
local fail, show = options.fail, options.show
local M = setmetatable({}, { __index = settings, __newindex = settings })
M.point_bytes = options.point_bytes

-- The end of a run (every method): interrupted at t, it returns the
-- partial trajectory (also in nz.last); failed, it raises the error with one
-- location, the user's, and keeps the part computed in nz.last; else tr.
local function finish(sys, cfg, tr, ok, err, t)
  if ok then return tr end
  if rawequal(err, core.interrupted) then     -- by identity: a user's message may say "interrupted!"
    tr.status, tr.message = "interrupted", ("stopped by Ctrl-C at t = %.6g; the trajectory is partial "
      .. "(t1 = %g not reached), the part computed so far is kept"):format(t, cfg.t1)
    io.stderr:write(("simulate '%s': %s (%d points, also in nz.last)\n"):format(sys.name, tr.message, #tr.t))
    session.last = tr
    return tr
  end
  -- The engine's messages come with the library's line
  -- (lua/nz/motion/run.lua:...), which says nothing.
  local msg = options.strip_library(tostring(err))
  if not options.located(msg) then msg = user_where() .. msg end
  tr.status, tr.message = "failed", msg
  session.last = tr
  error(("%s\n(the trajectory computed so far, %d points up to t = %.6g, is kept in nz.last)"):format(
    msg, #tr.t, tr.t[#tr.t] or cfg.t0), 0)
end

-- The start of the run: the state y (q, qd, then the work or the higher
-- levels), checked (a T or V not finite there, the constraints), and the
-- contacts' start (an impact at t0 changes qd).
local function start_state(sys, cfg)
  local k, engine = sys.k, sys.engine
  engine.orders = cfg.orders
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
  local st = { engine = engine, orders = cfg.orders, linear = cfg.linear }
  -- Unilateral contacts: the run integrates the system with the contacts'
  -- functions (sys.contact.system) in the contacts' mode, from the
  -- velocities after the start's impact, if any.
  if sys.contact then
    st.contact = require("nz.motion.contact_run").begin(sys, cfg, cfg.q0, qd0, function(...) fail(sys, ...) end)
    st.engine, st.orders, st.linear = st.contact.engine, st.contact.orders, st.contact.linear
    cfg.q0, qd0 = st.contact.q0, st.contact.qd0
  end
  local tail = cfg.p and options.start_levels(sys, cfg, st.orders, cfg.p, qd0, cfg.top)
  st.guess = cfg.top and cfg.guess and options.top_guess(sys, cfg.guess, cfg.p)
  st.y, st.qd0 = {}, qd0
  for i = 1, k do st.y[i], st.y[k + i] = cfg.q0[i], qd0[i] end
  if cfg.monitors.work then st.y[2 * k + 1] = 0 end
  for _, v in ipairs(tail or {}) do st.y[#st.y + 1] = v end
  return st
end

function M.simulate(sys, opts)
  -- A script that Ctrl-C interrupted during an earlier simulate (which
  -- returned its partial trajectory) stops here: a later run would
  -- otherwise stop at once and return a 1-point trajectory as if it were
  -- the answer.  The session clears the request at every prompt.
  if mech.interrupted() then error(core.interrupted, 0) end
  local cfg = options.prepare(sys, opts)
  local st = start_state(sys, cfg)
  local tr = trajectory.new(sys, cfg)
  tr.step = cfg.step_used            -- the step taken (the summary says it), not the one asked
  tr.warnings = cfg.warnings
  if cfg.monitors.energy then tr.energy, tr.generalized_energy = {}, {} end
  if cfg.monitors.work then tr.work = {} end
  local ok, err, t = run.run(sys, cfg, tr, st)
  return finish(sys, cfg, tr, ok, err, t)
end

return M
