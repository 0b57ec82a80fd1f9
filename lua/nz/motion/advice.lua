-- nz/motion/advice.lua - what a run says about its own cost: the long-run
-- notice (a run that will take long says so once, with what would be
-- cheaper: stiffness, the output grid, the order, the tolerance), the
-- diagnosis of a run that stopped making progress, and which evaluator ran
-- its steps (tr.stats.evaluator).  Asked by nz/motion/run.lua; it computes
-- nothing on the run's path beyond the step counts it is handed.
local core = require "nz.core"
local settings = require "nz.motion.settings"
local text = require "nz.base.text"
local user_where = require("nz.base.where").user_where
local fail = require("nz.motion.options").fail

local mech = core.mech
local M = {}

-- " at t = ..., q = {...}, qd = {...}" as the engine's messages say it.
local function num(v)
  local s = ("%.15g"):format(v)
  return tonumber(s) == v and s or ("%.17g"):format(v)
end
local function nums(v) return text.list(v, num) end
function M.state_text(t, q, qd) return (" at t = %s, q = %s, qd = %s"):format(num(t), nums(q), nums(qd)) end
M.num = num

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
  if cfg.method == "variational" then
    -- fixed steps only; its error is C h^order, bounded in time
    local p = cfg.order or 2
    return ("a larger 'step' (the variational integrator's error, bounded in time, grows as step^%d)%s"):format(p,
      p < 8 and (", or order = %d at a larger step (its error falls as step^%d; a step is %d substeps)")
        :format(p + 2, p + 2, ({ [2] = 5, [4] = 9, [6] = 17 })[p]) or "")
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
  local c = sys.engine.recording
  return c and c:info().native_waited or 0
end
M.compile_seconds = compile_seconds

-- Which evaluator ran the steps (tr.stats.evaluator), from the loop's
-- nz_run_native_from: machine code from step `from` on, none (0), or no
-- machine code at all (-1); and that step, when machine code took over
-- during the run.
function M.evaluator(sys, from)
  if from == 1 then return "machine code" end
  if from > 1 then
    return ("interpreted graph for steps 1-%d, machine code from step %d (compiled in the background)")
      :format(from - 1, from), from
  end
  local info = sys.engine.recording and sys.engine.recording:info()
  if not info then return "jets, the functions in Lua (compile = false)" end
  if from == 0 then
    return "interpreted graph" .. (info.native_compiling > 0 and " (machine code was still compiling)" or "")
  end
  if info.native_mode == 0 then return "interpreted graph (native = false)" end
  return "jets (a function of the system runs in Lua: print(sys) says which)"
end

-- What each kind of branch is, said where the number that decides it lies
-- within its rounding error (src/graph/graph_rounding.h).
local FLIPS = {
  atan2 = function(b) return ("atan2's first argument is %.3g, within its rounding error (%.3g) of 0, where atan2(y, x) "
    .. "jumps between pi and -pi (x = %.6g < 0)"):format(b.value, b.bound, b.b) end,
  cmp = function(b) return ("the two sides of a comparison (nz.lt, nz.le, nz.gt, nz.ge, or a condition of nz.ifelse) "
    .. "differ by %.3g, within their rounding error (%.3g)"):format(b.value, b.bound) end,
  fn = function(b) return ("sign's argument (nz.sign, or the derivative of nz.abs, which has a corner at 0) is %.3g, "
    .. "within its rounding error (%.3g) of 0"):format(b.value, b.bound) end,
  select = function(b) return ("the condition of nz.ifelse is %.3g, within its rounding error (%.3g) of 0")
    :format(b.value, b.bound) end,
}

-- The same where the deciding number is near its switch, beyond rounding.
local NEAR = {
  atan2 = function(b) return ("atan2's first argument is %.3g, at the cut of atan2(y, x) (x = %.6g < 0), where "
    .. "it jumps between pi and -pi"):format(b.value, b.b) end,
  cmp = function(b) return ("the two sides of a comparison (nz.lt, nz.le, nz.gt, nz.ge, or a condition of nz.ifelse) "
    .. "differ by %.3g"):format(b.value) end,
  fn = function(b) return ("sign's argument (nz.sign, or the derivative of nz.abs) is %.3g"):format(b.value) end,
  select = function(b) return ("the condition of nz.ifelse is %.3g"):format(b.value) end,
}

-- A right-hand side that jumps makes the steps collapse: every step sees
-- the jump, whatever its size.  When a run's steps have collapsed (the
-- long-run notice, the stall), the recording is asked for a branch whose
-- choice lies within rounding at the state y (q, qd, with q'' there), or
-- whose deciding number is within the run's tolerance on the state of
-- its switch (SWITCH_TOL times atol + rtol |y|); found, the run stops with
-- the function and the operation, the time and the state (the part
-- computed is kept in nz.last).
M.SWITCH_TOL = 100
function M.rounding_flip(sys, cfg, engine, tt, y, qdd, why)
  if not engine.recording then return end
  local k = sys.k
  local q, qd, ymax = {}, {}, 0
  for i = 1, k do
    q[i], qd[i] = y[i], y[k + i]
    ymax = math.max(ymax, math.abs(y[i]), math.abs(y[k + i]))
  end
  local tol = M.SWITCH_TOL * ((cfg.atol or 0) + (cfg.step and 0 or cfg.rtol) * ymax)
  local ok, b = pcall(mech.ode_rounding_branch, engine, tt, q, qd, qdd, tol)
  if not ok or not b then return end
  local where = b.constraint and ("constraint %d"):format(b.constraint) or (b.piece ~= "" and b.piece or "M and h")
  if not b.rounding then
    fail(sys, "the integrator (%s) %s: the right-hand side jumps there%s: in %s, %s, and every step across the switch "
      .. "sees the jump: the model switches there (a force by sign or a comparison of the state); make the switch an "
      .. "event, or a unilateral contact with friction (nz.unilateral), or smooth it (nz.smooth_abs)", cfg.method, why,
      M.state_text(tt, q, qd), where, (NEAR[b.op] or NEAR.cmp)(b))
  end
  fail(sys, "the integrator (%s) %s: the right-hand side jumps there at rounding level%s: in %s, %s, so it flips with "
    .. "the last bits of the state and every step sees the jump: write the expression so that it is exactly 0 where it "
    .. "should vanish (a sum that cancels to a rounding residue: w - 0.3 w - 0.7 w), or smooth the switch "
    .. "(nz.smooth_abs)", cfg.method, why, M.state_text(tt, q, qd), where, (FLIPS[b.op] or FLIPS.cmp)(b))
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
function M.long_run_notice(sys, cfg, tr, nsteps, tt, wall0, done, compiled0, pace, evidence, flip)
  local now, compiled = mech.now(), compile_seconds(sys)
  local elapsed = now - wall0 - (compiled - compiled0)
  local dsteps, dt_run = nsteps - pace.steps, tt - pace.t
  local dwall = now - pace.wall - (compiled - pace.compiled)
  pace.steps, pace.t, pace.wall, pace.compiled = nsteps, tt, now, compiled
  if not (dsteps > 0 and dt_run > 0) then return false end
  local windows = (cfg.t1 - tt) / dt_run          -- windows like the last one still to go
  local steps, seconds = nsteps + windows * dsteps, elapsed + windows * math.max(dwall, 0)
  if not ((nsteps >= settings.LONG_RUN.check_steps and steps > settings.LONG_RUN.steps)
      or (elapsed >= 1 and seconds > settings.LONG_RUN.seconds)) then return false end
  local h = dt_run / dsteps
  done()                                  -- the progress bar's line, if shown
  flip(("took steps of only %.3g (at that pace the run would take %.3g steps)"):format(h, steps))
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
  settings.warn(msg)
  return true
end

local ulp = require("nz.motion.options").ulp

-- A run whose last window of steps advanced t by `advance` (nsteps steps
-- brought it to tt, at state q, qd): the error that says why, with the
-- evidence.  Two causes that are not the motion's, both with steps that
-- did not shrink (the last window's as large as the run's average; near a
-- singular point they shrink by orders of magnitude): a time so large that
-- such steps hardly move it (a few ulps of t each), and a span so long that
-- they cover only a sliver of it.  Else the motion: M's conditioning there.
function M.stalled(sys, cfg, tt, advance, nsteps, q, qd, qd0, flip)
  local window = settings.STALL.window
  flip(("stopped making progress (the last %d steps advanced t by %.3g)"):format(window, advance))
  local span = cfg.t1 - cfg.t0
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
    cfg.method, window, advance, M.state_text(tt, q, qd), smin, smax, smax / smin, smin0)
end

return M
