-- nz/analysis/check.lua - nz.check(sys, eqs): does a student's derivation give the
-- system's equations of motion?
--
-- The student writes eqs(t, q, qd, qdd) returning k expressions meant to
-- vanish on the motion.  They may differ from the system's by an invertible
-- recombination and scaling of the rows, so the test is, at many random
-- admissible states (projected onto the constraints):
--   1. every expression vanishes at the true accelerations;
--   2. together they determine the accelerations: their Jacobian in qdd
--      (computed with dual numbers) has full rank k.
-- A failure says which equation, at which state, with the expected and the
-- student's values.
local core = require "nz.core"
local mech = core.mech

local M = {}
M.STATES = 10
M.TOL = 1e-8

-- %.6g, with NaN as "NaN" on every C library (not "-nan")
local function g6(x) return x ~= x and "NaN" or ("%.6g"):format(x) end
local function vec(v) return require("nz.base.text").list(v, g6) end

local generator = require("nz.model.constraints").generator   -- deterministic draws

-- "file:line: " where the student's function is defined: errors name it first.
local function defined_at(eqs)
  local info = debug.getinfo(eqs, "S")
  return info.linedefined > 0 and ("%s:%d: "):format(info.short_src, info.linedefined) or ""
end

-- Evaluate the student's function; errors say what to fix.
local function evaluate(sys, eqs, t, q, qd, qdd)
  local ok, E = pcall(eqs, t, q, qd, qdd, sys.params)
  if not ok then
    if rawequal(E, core.interrupted) then error(E, 0) end    -- Ctrl-C stays Ctrl-C
    local msg = tostring(E)
    if core.isjet(qdd[1]) then
      msg = msg .. " (your equations are evaluated with dual numbers to find how they depend on qdd: "
        .. "write them with nz.sin, nz.cos, ... (sin, cos in nzlua), not math.sin)"
    end
    local at, rest = msg:match("^([^\n]-:%d+: )(.*)$")     -- their file:line first
    error((at or defined_at(eqs)) .. "check: your equations raised an error: " .. (rest or msg), 0)
  end
  if type(E) ~= "table" or #E ~= sys.k then
    error((defined_at(eqs) .. "check: your equations must return a table of %d expressions (one per coordinate: %s), got %s")
      :format(sys.k, table.concat(sys.coords, ", "), type(E) == "table" and (#E .. " values") or type(E)), 0)
  end
  for i = 1, sys.k do
    if type(E[i]) ~= "number" and not core.isjet(E[i]) then
      local shown = type(E[i]) == "string" and ("the string %q"):format(E[i]) or ("a %s"):format(type(E[i]))
      error((defined_at(eqs) .. "check: equation %d must be a number computed from t, q, qd, qdd, got %s: write it as a Lua "
        .. "expression, e.g. qdd[1] + q[1] rather than \"x'' + x\""):format(i, shown), 0)
    end
  end
  return E
end

local function value(x) return core.isjet(x) and x:value() or x end

-- nz.check(sys, eqs [, {states =, tol =, seed =, quiet =}]) -> ok, text
local OPTIONS
do
  local args = require("nz.base.args")
  OPTIONS = require("nz.base.options").declare("nz.check", { states = args.count, tol = args.positive, quiet = args.boolean,
    seed = function(v) return math.type(v) == "integer", "an integer" end })
end
function M.check(sys, eqs, opts)
  local args = require("nz.base.args")
  if not require("nz.base.classes").is_system(sys) then
    args.error("check", 1, "a system from nz.system{...} expected, got %s", args.shown(sys))
  end
  if type(eqs) ~= "function" then
    args.error("check", 2, "your equations: a function(t, q, qd, qdd) returning %d expressions expected, got %s", sys.k, args.shown(eqs))
  end
  args.options("check", 3, opts, OPTIONS)
  opts = opts or {}
  local nstates, tol = opts.states or M.STATES, opts.tol or M.TOL
  local rand = generator(opts.seed or 4711)
  local base = sys.sample or {}
  local k = sys.k
  local lines, ok, checked, worst = {}, true, 0, 0
  local attempts = 0
  while checked < nstates and attempts < 10 * nstates do
    attempts = attempts + 1
    local t = (base.t or 0.3) + rand(-0.5, 0.5)
    local q, qd = {}, {}
    for i = 1, k do
      q[i] = ((base.q or {})[i] or 0.2) + rand(-1, 1)
      qd[i] = ((base.qd or {})[i] or 0.3) + rand(-1, 1)
    end
    local good, a = pcall(function()
      if sys.nc > 0 then q, qd = sys:project(t, q, qd) end
      return (sys:accel(t, q, qd))
    end)
    if good then
      checked = checked + 1
      -- Values at the true accelerations, and the Jacobian in qdd by duals.
      local E = evaluate(sys, eqs, t, q, qd, a)
      local duals = {}
      for i = 1, k do duals[i] = core.dual(a[i], i, k) end
      local Ed = evaluate(sys, eqs, t, q, qd, duals)
      local J = {}
      for i = 1, k do
        J[i] = {}
        for j = 1, k do J[i][j] = core.isjet(Ed[i]) and Ed[i]:tangent(j):value() or 0 end
      end
      local E0 = evaluate(sys, eqs, t, q, qd, (function() local z = {}; for i = 1, k do z[i] = 0 end; return z end)())
      for i = 1, k do
        -- The size of the terms: what equation i is made of near the motion.
        local scale = math.abs(value(E0[i]))
        for j = 1, k do scale = scale + math.abs(J[i][j] * a[j]) end
        local rel = math.abs(value(E[i])) / math.max(scale, 1e-300)
        worst = math.max(worst, scale > 0 and rel or 0)
        if not (rel <= tol) and ok then
          ok = false
          lines[#lines + 1] = ("Equation %d is wrong: at t = %.6g, q = %s, qd = %s the true accelerations are qdd = %s; "
            .. "there your equation %d should give 0 but gives %s (its terms are of size %.3g).")
            :format(i, t, vec(q), vec(qd), vec(a), i, g6(value(E[i])), scale)
          -- side by side: the system's row M q'' + h (h with the forces) and
          -- the student's own coefficients of q'' and rest, so that the
          -- wrong term shows (an equation may be scaled: compare ratios)
          local okmb, Mm, hh = pcall(sys.mass_bias, sys, t, q, qd)
          if okmb then
            local Jrow = {}
            for j = 1, k do Jrow[j] = J[i][j] end
            lines[#lines + 1] = ("  the system's equation %d there:  M[%d] = %s (the coefficients of qdd), h[%d] = %s"
              .. "%s"):format(i, i, vec(Mm[i]), i, g6(hh[i]), sys.nc > 0 and " (before the constraint forces A^T lambda)" or "")
            lines[#lines + 1] = ("  your equation %d there:           coefficients of qdd %s, the rest (at qdd = 0) %s")
              :format(i, vec(Jrow), g6(value(E0[i])))
          end
        end
      end
      if ok then
        local sv = mech.singular_values(J)
        local rank = 0
        for _, s in ipairs(sv) do if s > 1e-10 * sv[1] then rank = rank + 1 end end
        if rank < k then
          ok = false
          lines[#lines + 1] = ("Your equations vanish on the true motion but do not determine the accelerations: "
            .. "at t = %.6g, q = %s, qd = %s only %d of the %d are independent in qdd (one is a combination of the "
            .. "others, or does not contain the accelerations)."):format(t, vec(q), vec(qd), rank, k)
        end
      end
      if not ok then break end
    end
  end
  if checked == 0 then error("check: no admissible state could be drawn (accelerations failed everywhere)", 2) end
  if ok then
    lines[#lines + 1] = ("Your equations are equivalent to the system's: at %d random admissible states they vanish on "
      .. "the true accelerations (largest relative residual %.1e) and determine them."):format(checked, worst)
  end
  local text = table.concat(lines, "\n")
  if opts.quiet then return ok, text end
  print(text)
  return require("nz.base.frontend").shown(ok, text)     -- typed at the prompt: the verdict once
end

return M
