-- nz/motion/settings.lua - the defaults and limits of sys:simulate, in one
-- table that the modules of a run read when they need them (options.lua,
-- run.lua, advice.lua) and that nz.motion.simulate shows as its own fields:
-- require("nz.motion.simulate").MAX_MEMORY reads and writes this table, so a
-- test or a user who changes a limit changes it for every part of the run.
local M = {}

-- Defaults chosen so that a first run is accurate: an 8th-order adaptive
-- method at tight tolerances (documented in help(nz.system)).
M.defaults = { method = "rk8pd", rtol = 1e-10, atol = 1e-12, points = 200, event_tol = 1e-12 }

-- Limits that keep a run finite and its memory bounded.
M.MAX_MEMORY = 1e9        -- bytes of output points kept in memory (see options.point_bytes)
M.MAX_FIXED_STEPS = 1e9   -- steps of a fixed-step run
M.MIN_RTOL = 1e-15        -- below this (~5 eps) no stepper can make progress
M.PROJECT_TOL = 1e-10     -- project = true projects when the violation exceeds this
M.PROJECT_MULTISTEP = 100  -- ... times max(rtol, atol) for msadams and msbdf (up to 1e-6)
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
-- The locator: an event is located on the step integrated again at these
-- tolerances (or the run's, when tighter) where the dense output misses.
M.LOCATOR = { method = "rk8pd", rtol = 1e-10, atol = 1e-12 }

-- Warnings go to stderr once and into tr.warnings (tests replace M.warn).
function M.warn(msg) io.stderr:write(msg, "\n") end

return M
