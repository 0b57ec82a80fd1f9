-- nz/analysis/report.lua - sys:report{...}: what a scene shows, in one call: the
-- system, its constraints and Dolapchiev's choice of n with the reason, the
-- residuals of two orders at a state (the forms agree), a short
-- integration with the defect of its motion, and a plot.
local constraints = require "nz.model.constraints"

local M = {}

local function max_abs(v) local m = 0; for i = 1, #v do m = math.max(m, math.abs(v[i])) end; return m end

-- opts: t, q, qd (the state; projected onto the constraints), orders
-- ({n, n + 1} by default), simulate = {t1 =, dt =, ...} (the run from the
-- state; false for none), plot = {y = ..., phase = ..., file = ...} or false.
-- Returns the trajectory (or nil) and the rule's n (the session does not
-- print them again: the summary above showed them).
function M.report(sys, opts)
  opts = opts or {}
  print(tostring(sys))
  local n, why = sys:rule(opts.extremal and { extremal = true } or nil)
  if sys.nc > 0 then print(constraints.report(sys)) end
  print(why)
  local t, q, qd = opts.t or 0, opts.q, opts.qd
  if not q then error("report: give the state q (and qd)", 2) end
  if not qd then qd = {}; for i = 1, sys.k do qd[i] = 0 end end
  if sys.nc > 0 then q, qd = sys:project(t, q, qd) end
  local qdd, lambda = sys:accel(t, q, qd)
  local orders = opts.orders or { n, n + 1 }
  for _, order in ipairs(orders) do
    local r = sys:residual(order, t, q, qd, qdd, sys.nc > 0 and lambda or nil)
    -- qdd and lambda were solved from these equations: this shows that the
    -- forms of each order agree (rounding), not how good a motion is
    print(("residual of order %d (%s) at the solved accelerations (the forms agree): max |r| = %.1e"):format(order,
      require("nz.model.constraints").principle(order), max_abs(r)))
  end
  local tr
  if opts.simulate ~= false then
    local s = { t0 = t, q0 = q, qd0 = qd, t1 = t + 5 }
    for key, v in pairs(opts.simulate or {}) do s[key] = v end
    tr = sys:simulate(s)
    print(tostring(tr))
    if tr.contacts then           -- (its motion is smooth only between its events: nz/motion/contact_run.lua)
      print("  defect of the motion: not measured across contact events (tr:residuals says why)")
    elseif #tr.t >= require("nz.analysis.defect").NODES then
      -- the motion itself on the equations (nz/analysis/defect.lua): can fail, unlike the line above
      local d, worst, floor = tr:residuals(n, { quiet = true }), 0, 0
      for _, e in ipairs(d) do worst, floor = math.max(worst, e.max), math.max(floor, e.floor) end
      print(("  defect of the motion (tr:residuals): max %.1e, %s of the curve through its points (%.1e)%s"):format(
        worst, worst > 3 * floor and "above the floor" or "at the floor", floor,
        worst > 3 * floor and "" or ": the spacing dt limits what is seen"))
    end
    if opts.plot ~= false then
      local p = { width = 72, height = 18 }
      for key, v in pairs(opts.plot or {}) do p[key] = v end
      tr:plot(p)
    end
  end
  return require("nz.base.frontend").shown(tr, n)
end

return M
