-- nz/system.lua - nz.system{...}: a mechanical system and its generalized
-- equations of motion of any order (docs/theory.md §2-§5, §9, §11).
--
-- The definition is validated here, then handed to the C mechanics
-- (core.mech) as a plain table of piece lists; the C side never sees this
-- class.  Pieces: F = T and L functions (the "kinetic" part the forms
-- differentiate), T, V, Q, S (acceleration energy, from particles).
local core = require "nz.core"
local bodies = require "nz.model.bodies"
local constraints = require "nz.model.constraints"
local record = require "nz.model.record"
local probe = require "nz.model.probe"
-- NZ_GRAPH_CHECK=1: check every recording against the Lua evaluator when the
-- system is made (the test suite runs with it; nz/model/record.lua).
local GRAPH_CHECK = os.getenv("NZ_GRAPH_CHECK") == "1"
local text = require "nz.base.text"
-- The trajectory's methods that live above it (tr:section, tr:animate in
-- nz/presentation/views.lua; tr:residuals, tr:consistency in nz/analysis/defect.lua) are attached
-- to its class when those modules load: the face loads them.
require "nz.presentation.views"
require "nz.analysis.defect"

local mech = core.mech
local classes = require "nz.base.classes"
local System = classes.System

local M = { System = System }

-- ------------------------------------------------------------------ --
-- Arguments of the methods: checked here, before the C mechanics reads  --
-- them, so that an error is in Lua's own style ("bad argument #2 to      --
-- 'accel' (...)"), counts the arguments as the user writes them (self    --
-- not counted) and starts with the user's file:line.                     --

local user_where = require("nz.base.where").user_where
local unwrap = require("nz.base.where").unwrap
local args = require "nz.base.args"
local shown, arg_error, finite = args.shown, args.error, args.finite
local check_number, check_vector, check_state = args.number, args.vector, args.state
local check_options, positive, count, boolean = args.options, args.positive, args.count, args.boolean

-- For the other entry points (nz.check): the same messages.
M.args = args

local known_fields = {
  coords = true, T = true, V = true, Q = true, L = true, S = true, params = true,
  name = true, bodies = true, constraints = true, sample = true, compile = true, native = true,
}

-- A function or a list of functions, as a list.
local function as_list(v, field, name)
  if v == nil then return {} end
  if type(v) == "function" then return { v } end
  if type(v) == "table" and getmetatable(v) == nil then
    local list = {}
    for i, f in ipairs(v) do
      if type(f) ~= "function" then
        error(("nz.system '%s': %s[%d] must be a function, got %s"):format(name, field, i, type(f)), 4)
      end
      list[i] = f
    end
    return list
  end
  error(("nz.system '%s': %s must be a function or a list of functions, got %s"):format(name, field, type(v)), 4)
end

local function labels(list, field)
  local out = {}
  for i = 1, #list do out[i] = #list == 1 and field or ("%s[%d]"):format(field, i) end
  return out
end

local function append(dst, dst_labels, src, src_labels)
  for i = 1, #src do
    dst[#dst + 1] = src[i]
    dst_labels[#dst_labels + 1] = src_labels[i]
  end
end

-- Where the methods' warnings go (tests replace it).
function M.warn(msg) io.stderr:write(msg, "\n") end

function M.system(def)
  if type(def) ~= "table" then error("nz.system: a table {coords = ..., T = ...} expected", 2) end
  local name = def.name
  if name ~= nil and type(name) ~= "string" then error("nz.system: 'name' must be a string", 2) end
  name = name or "unnamed"
  for key in pairs(def) do
    if not known_fields[key] then
      local expected = {}
      for k in pairs(known_fields) do expected[#expected + 1] = k end
      table.sort(expected)
      error(("nz.system '%s': unknown field '%s' (expected one of %s)"):format(
        name, tostring(key), table.concat(expected, ", ")), 2)
    end
  end
  local coords = def.coords
  if type(coords) ~= "table" or #coords == 0 then
    error(("nz.system '%s': 'coords' must be a non-empty list of coordinate names"):format(name), 2)
  end
  local seen = {}
  for i, c in ipairs(coords) do
    if type(c) ~= "string" or c == "" then
      local got = type(c) == "string" and "an empty string" or ("the %s %s"):format(type(c), tostring(c))
      error(("nz.system '%s': coords[%d] must be the coordinate's name, a string, got %s (write coords = "
        .. "{ \"x\", \"th\" }: the names q.x, qd.th and the messages use)"):format(name, i, got), 2)
    end
    if seen[c] then
      error(("nz.system '%s': coordinate '%s' appears twice (coords[%d] and coords[%d]): each coordinate needs a "
        .. "name of its own"):format(name, c, seen[c], i), 2)
    end
    seen[c] = i
  end
  if def.params ~= nil and type(def.params) ~= "table" then
    error(("nz.system '%s': 'params' must be a table of named numbers"):format(name), 2)
  end

  local T, V, Q = as_list(def.T, "T", name), as_list(def.V, "V", name), as_list(def.Q, "Q", name)
  local L, S = as_list(def.L, "L", name), as_list(def.S, "S", name)
  local lab = { T = labels(T, "T"), V = labels(V, "V"), Q = labels(Q, "Q"), L = labels(L, "L"), S = labels(S, "S") }
  if def.bodies ~= nil then
    local ok, pieces = pcall(bodies.bodies, def.bodies)
    if not ok then error(("nz.system '%s': %s"):format(name, pieces), 2) end
    append(T, lab.T, { pieces.T }, { "T (bodies)" })
    if pieces.V then append(V, lab.V, { pieces.V }, { "V (gravity on bodies)" }) end
    if pieces.S and #S == 0 then append(S, lab.S, { pieces.S }, { "S (bodies)" }) end
  end
  if #T == 0 and #L == 0 then
    error(("nz.system '%s': it has no kinetic energy: give the kinetic energy T = function(t, q, qd, params) "
      .. "(or a Lagrangian L), without which there is no motion to derive"):format(name), 2)
  end
  local F, Flab = {}, {}
  append(F, Flab, T, lab.T)
  append(F, Flab, L, lab.L)
  -- nz.unilateral entries are contacts (nz/model/contact.lua), the rest equalities
  local bilateral, contacts = def.constraints, nil
  if type(bilateral) == "table" then
    local any = getmetatable(bilateral) ~= nil
    for _, c in ipairs(bilateral) do any = any or type(c) == "table" end
    if any then bilateral, contacts = require("nz.model.contact").split(bilateral) end
  end
  local C = as_list(bilateral, "constraints", name)
  local Clab = {}
  for i = 1, #C do Clab[i] = select(2, unwrap(C[i])) or ("constraint %d"):format(i) end
  local Clevels = constraints.levels(C, name)
  for _, key in ipairs{ "compile", "native" } do
    if def[key] ~= nil and type(def[key]) ~= "boolean" then
      error(("nz.system '%s': '%s' must be true or false"):format(name, key), 2)
    end
  end
  if def.sample ~= nil and type(def.sample) ~= "table" then
    error(("nz.system '%s': 'sample' must be a state {t = ..., q = {...}, qd = {...}}"):format(name), 2)
  end

  local self = setmetatable({
    name = name,
    coords = { table.unpack(coords) },
    k = #coords,
    nc = #C,
    constraint_levels = Clevels,
    params = def.params or {},
    sample = def.sample,
    bodies = def.bodies,      -- kept for drawing (tr:animate)
    pieces = { T = #T, V = #V, Q = #Q, L = #L, S = #S },
  }, System)
  -- What the C mechanics reads (params is the same table: change a mass in
  -- sys.params and the next call sees it).
  self.engine = {
    k = #coords, name = name, coords = self.coords, params = self.params,
    F = F, T = T, V = V, Q = Q, S = S, constraints = C, constraint_levels = mech.constraint_levels(Clevels),
    labels = { F = Flab, T = lab.T, V = lab.V, Q = lab.Q, S = lab.S, constraints = Clab },
    -- the parameters declared as numbers: each call of the mechanics checks
    -- that they still are finite numbers (sys.params.g = 0/0 is named there)
    param_names = {},
  }
  for key, v in pairs(self.params) do
    if type(key) == "string" and type(v) == "number" then self.engine.param_names[#self.engine.param_names + 1] = key end
  end
  table.sort(self.engine.param_names)
  -- Record the functions once as graphs evaluated in C (nz/model/record.lua);
  -- compile = false: do not record (every function runs in Lua; the option's
  -- old name, "compile" now meaning machine code).
  if def.compile ~= false then self.recording = record.record_system(self.engine, Clevels, def.native) end
  -- A function that fails at every state (math.cos on a jet, q.th) is said
  -- here, at the user's nz.system line (nz/model/probe.lua).
  probe.check(self)
  if GRAPH_CHECK and self.recording then record.diff_check(self.engine, Clevels, name) end
  if contacts then
    require("nz.model.contact").attach(self, def, contacts, C)
    local notice = require("nz.model.contact_check").notice(self)   -- two contacts with one gap
    if notice then M.warn(require("nz.base.where").user_where() .. notice) end
  end
  return self
end

-- ------------------------------------------------------------------ --
-- Equations                                                            --

local form_set = {}
for _, f in ipairs(mech.forms()) do form_set[f] = true end
M.forms = mech.forms()

-- residual(n, t, q, qd, qdd [, lambda] [, opts]); opts: a form name, or a
-- table {form = ..., higher = {q3, q4, ...}} (derivatives beyond qdd that the
-- jets use; 0 when not given: the result does not depend on them).  With
-- multipliers lambda (one per constraint) the constraint terms of (6.2),
-- -A^T lambda with A = dPhi/dq^(m), are included.  n = nil: the rule's n.
-- n (argument #1) of residual and equations: nil for the rule's n.
local check_order = args.order

-- A list of numbers (not an options table): multipliers.
local function is_list(v) return type(v) == "table" and getmetatable(v) == nil and v[1] ~= nil end

-- The options' checkers, made once (not on every call).
local declare = require("nz.base.options").declare
local RESIDUAL_OPTIONS = declare("sys:residual", {
  form = function(v) return type(v) == "string", "a form name" end,
  higher = function(v) return type(v) == "table", "a list {q3, q4, ...} of derivatives" end,
})
local EQUATIONS_OPTIONS = declare("sys:equations", { quiet = boolean })

function System:residual(n, t, q, qd, qdd, a6, a7)
  check_order("residual", n)
  if type(t) ~= "number" then arg_error("residual", 2, "t: a number expected, got %s", shown(t)) end
  check_state(self, "residual", 2, t, q, qd)
  if qdd ~= nil then check_vector(self, "residual", 5, "qdd", qdd) end
  -- argument 6: the multipliers (a list, or nil) or, without them, the form
  local lambda, opts, oi = nil, a6, 6
  if is_list(a6) or (a6 == nil and a7 ~= nil) then lambda, opts, oi = a6, a7, 7 end
  if lambda ~= nil then
    check_vector(self, "residual", 6, "lambda", lambda, self.nc, "one multiplier per constraint")
  end
  local form, higher = "generalized", nil
  if type(opts) == "string" then form = opts
  elseif type(opts) == "table" and getmetatable(opts) == nil then
    check_options("residual", oi, opts, RESIDUAL_OPTIONS)
    form, higher = opts.form or form, opts.higher
    for j, v in ipairs(higher or {}) do check_vector(self, "residual", oi, ("higher[%d]"):format(j), v) end
  elseif opts ~= nil then
    arg_error("residual", oi, "%sa form name or options {form =, higher =} expected, got %s",
      oi == 6 and "multipliers, " or "", shown(opts))
  end
  if not form_set[form] then
    arg_error("residual", oi, "unknown form '%s'; forms: %s", tostring(form), table.concat(M.forms, ", "))
  end
  n = n or self:rule()
  local r = mech.residual(self.engine, form, n, t, q, qd, qdd, higher)
  if lambda then
    local f = constraints.multiplier_terms(self, t, { q, qd, qdd, table.unpack(higher or {}) }, lambda)
    for i = 1, self.k do r[i] = r[i] - f[i] end
  end
  return r
end

-- M(t, q [, qd]) and h(t, q, qd) of M qdd + h = 0 (h includes -Q and dV/dq).
function System:mass(t, q, qd)
  check_state(self, "mass", 1, t, q, qd, true)
  local Mm = mech.mass_bias(self.engine, t, q, qd)
  return Mm
end

function System:bias(t, q, qd)
  check_state(self, "bias", 1, t, q, qd)
  local _, h = mech.mass_bias(self.engine, t, q, qd)
  return h
end

function System:mass_bias(t, q, qd)
  check_state(self, "mass_bias", 1, t, q, qd)
  return mech.mass_bias(self.engine, t, q, qd) end

-- Accelerations, multipliers (one per constraint) and, with constraints, a
-- report {iterations, residual, rcond, start}.  opts (constraints of second
-- order nonlinear in qdd): {qdd = guess, lambda = guess, tol =, maxit =};
-- out = a table that receives qdd (entries 1 .. k) and is returned.
-- (made once: accel is called on every step of a user's own loop)
local ACCEL_OPTIONS = declare("sys:accel", {
  tol = positive, maxit = count, check = boolean,
  rcond_min = function(v) return finite(v) and v >= 0, "a finite number >= 0" end,
  qdd = function(v) return type(v) == "table", "a table of numbers (a first guess)" end,
  lambda = function(v) return type(v) == "table", "a table of numbers (a first guess)" end,
  out = function(v) return type(v) == "table" and getmetatable(v) == nil, "a plain table (it receives qdd)" end,
})

-- The multipliers of a system without constraints when opts.out asked for
-- no new table: one empty table for every call, which refuses to be written.
local NO_MULTIPLIERS = setmetatable({}, {
  __newindex = function() error("sys:accel: the multipliers of a system without constraints (with opts.out) are "
    .. "an empty table shared by every call: it cannot be written", 2) end,
  __metatable = false })

-- qdd into opts.out when it is given (that table returned), else qdd.
local function into_out(opts, qdd)
  local out = opts and opts.out
  if not out then return qdd end
  for i = 1, #qdd do out[i] = qdd[i] end
  return out
end

local accel_try = mech.accel_try
function System:accel(t, q, qd, opts)
  -- The common call first: C reads and checks the state (and opts, when it
  -- is {out = table} alone), and gives nil when something is wrong with
  -- them, for the checks below to say what.
  if self.nc == 0 then
    local qdd = accel_try(self.engine, t, q, qd, opts)
    if qdd then return qdd, opts and NO_MULTIPLIERS or {} end
  end
  check_state(self, "accel", 1, t, q, qd)
  check_options("accel", 4, opts, ACCEL_OPTIONS)
  if opts and opts.qdd then check_vector(self, "accel", 4, "option 'qdd'", opts.qdd) end
  if opts and opts.lambda then check_vector(self, "accel", 4, "option 'lambda'", opts.lambda, self.nc, "one per constraint") end
  if self.nc == 0 then return into_out(opts, mech.accel(self.engine, t, q, qd)), opts and opts.out and NO_MULTIPLIERS or {} end
  local orders, linear = constraints.orders(self, { t = t, q = q, qd = qd })
  local qdd, lambda, report = mech.accel_constrained(self.engine, t, q, qd, orders, linear, opts)
  qdd = into_out(opts, qdd)
  -- A state off the constraints of order <= 1 has accelerations all the
  -- same (those of (6.2) there), but no motion on them passes through it:
  -- said once per system, with the constraint and its value.
  local v = report.violation
  if v and v.relative > constraints.CHECK_TOL and not self._warned_off then
    self._warned_off = true
    M.warn(("%ssys:accel: warning: system '%s': the state at t = %s violates constraint %d at %s level by %.3g (%.3g of "
      .. "the size of its terms): the accelerations are those of the equations at this state, which no motion on the "
      .. "constraints passes through; q, qd = sys:project(t, q, qd) gives the nearest state on them (said once)")
      :format(user_where(), self.name, shown(t), v.constraint, v.level, v.value, v.relative))
  end
  return qdd, lambda, report
end

-- Returns T + V (nil when the system is given by L without T), the
-- generalized energy H = sum qd dL/dqd - L, and whether H is a first
-- integral here: {holds, explicit_t = dL/dt, homogeneous, reasons}.
function System:energy(t, q, qd)
  check_state(self, "energy", 1, t, q, qd)
  local T, V, _, H = mech.energy(self.engine, t, q, qd)
  return T and (T + V) or nil, H, constraints.energy_conditions(self, t, q, qd)
end

-- The power of the reactions of moving constraints, R_0 of (9.1).
function System:reaction_power(t, q, qd)
  check_state(self, "reaction_power", 1, t, q, qd)
  local qdd, lambda = self:accel(t, q, qd)
  return constraints.reaction_power(self, t, q, qd, qdd, lambda)
end

-- The classification of the constraints, a list that prints as its table
-- (print(sys:constraints()) in a script; typed at the prompt, the session
-- prints it once).  It prints nothing itself, so opts (quiet) change nothing.
local CONSTRAINTS_OPTIONS = declare("sys:constraints", { quiet = boolean })
function System:constraints(opts)
  check_options("constraints", 1, opts, CONSTRAINTS_OPTIONS)
  local classes = constraints.classify(self)
  local out = {}
  for i, c in ipairs(classes) do out[i] = c end
  local sys = self
  return setmetatable(out, { __tostring = function() return constraints.report(sys) end })
end

-- Dolapchiev's order n and why; opts.extremal for the extremal form (4.3).
local RULE_OPTIONS = declare("sys:rule", { extremal = boolean })
function System:rule(opts)
  check_options("rule", 1, opts, RULE_OPTIONS)
  local n, text = constraints.rule(self, opts)
  if self.contact then   -- its unilateral contacts, held while they push (nz/presentation/contact_laws.lua)
    text = text .. " " .. require("nz.presentation.contact_laws").rule_text(self)
  end
  return n, text
end

-- Accelerations from Tsenov's reduced equations (7.1), without multipliers.
function System:reduced(t, q, qd, n, form)
  check_state(self, "reduced", 1, t, q, qd)
  if n ~= nil and not (type(n) == "number" and n == math.floor(n) and n >= 1 and n <= mech.max_order) then
    arg_error("reduced", 4, "n: an integer order from 1 to %d expected, got %s", mech.max_order, shown(n))
  end
  if form ~= nil and not form_set[form] and not (type(form) == "table" and getmetatable(form) == nil) then
    arg_error("reduced", 5, "a form name (%s) or the state's higher levels {qdd =, lambdas =} expected, got %s",
      table.concat(M.forms, ", "), shown(form))
  end
  return constraints.reduced(self, t, q, qd, n or self:rule(), form)
end

-- sys:project's options: tol, maxit, and for constraints of order p >= 3
-- the start's levels qdd .. q^(p-1) and the multipliers the user chose
-- (lambda, or lambdas = {lambda, lambda', ..., lambda^(p-3)}), which are
-- otherwise whatever the equations need.
local function check_project_options(self, opts)
  local top = self.nc > 0 and constraints.top_level(self)
  local p = top or (self.nc > 0 and constraints.level(self)) or nil
  local keys = { tol = positive, maxit = count }
  local vector = function(n, what) return function(v)
    local want = ("a table of %d finite number%s (%s)"):format(n, n == 1 and "" or "s", what)
    if type(v) ~= "table" or #v ~= n then return false, want end
    for j = 1, n do if not finite(v[j]) then return false, want end end
    return true
  end end
  for j = 2, (p or 2) - 1 do keys[constraints.level_name(j)] = vector(self.k, "one per coordinate") end
  if p and not top then
    local one = vector(self.nc, "one multiplier per constraint")
    keys.lambda = one
    keys.lambdas = function(v)
      if type(v) ~= "table" then return false, ("a list of %d tables of multipliers (lambda, lambda', ...)"):format(p - 2) end
      for j, l in pairs(v) do
        if math.type(j) ~= "integer" or j < 1 or j > p - 2 or not one(l) then
          return false, ("a list of %d tables of %d multipliers (lambda, lambda', ...)"):format(p - 2, self.nc)
        end
      end
      return true
    end
  end
  for key in pairs(opts) do
    local j = type(key) == "string" and (key == "qdd" and 2 or tonumber(key:match("^q(%d+)d$")))
    if j and not keys[key] then
      arg_error("project", 4, "option '%s': %s", key, p and ("the constraints are of order %d at most, so the start "
        .. "has levels q .. %s"):format(p, constraints.level_name(p - 1)) or "no constraint is of order 3 or more, so "
        .. "the start is q and qd alone")
    end
    if (key == "lambda" or key == "lambdas") and not keys[key] then
      arg_error("project", 4, "option '%s': %s", key, top and "with a constraint nonlinear in its top derivative the "
        .. "multipliers are solved at each time, not part of the start" or "no constraint is of order 3 or more, so "
        .. "the start has no multipliers")
    end
  end
  check_options("project", 4, opts, keys)
  if opts.lambda and opts.lambdas then
    arg_error("project", 4, "options 'lambda' and 'lambdas': give one of them (lambda is lambdas[1])")
  end
end

-- qdd, q3d, q4d, ...: the start's higher levels (constraints of order p >= 3);
-- the options as help lists them (checked above, by the system's levels)
local function level_key(key) return type(key) == "string" and (key == "qdd" or key:match("^q%d+d$") ~= nil) end
local PROJECT_OPTIONS = declare("sys:project", { "tol", "maxit", "qdd", "lambda", "lambdas" }, level_key)
function System:project(t, q, qd, opts)
  check_state(self, "project", 1, t, q, qd)
  if opts ~= nil and (type(opts) ~= "table" or getmetatable(opts) ~= nil) then
    arg_error("project", 4, "options: a table {tol =, maxit =, qdd =, ...} expected, got %s", shown(opts))
  end
  if opts then check_project_options(self, opts) end
  return constraints.project(self, t, q, qd, opts)
end

function System:check_state(t, q, qd, tol)
  check_state(self, "check_state", 1, t, q, qd)
  if tol ~= nil then check_number("check_state", 4, "tol", tol) end
  return constraints.check_state(self, t, q, qd, tol)
end

-- What a scene shows, in one call (lua/nz/analysis/report.lua).
local REPORT_OPTIONS = declare("sys:report", { "q", "qd", "t", "orders", "extremal", "simulate", "plot" })
function System:report(opts)
  if opts ~= nil and (type(opts) ~= "table" or getmetatable(opts) ~= nil) then
    arg_error("report", 1, "options: a table {q =, qd =, ...} expected, got %s", shown(opts))
  end
  if opts then require("nz.base.options").check(opts, REPORT_OPTIONS, function(...) arg_error("report", 1, ...) end) end
  return require("nz.analysis.report").report(self, opts)
end

-- The defect of points from anywhere (a student's integrator, a lab's
-- measurement): the equations on the curve through them (nz/analysis/defect.lua).
function System:residuals_of(opts) return require("nz.analysis.defect").of(self, opts) end

-- Integrate the motion (lua/nz/motion/simulate.lua): returns a trajectory.
function System:simulate(opts) return require("nz.motion.simulate").simulate(self, opts) end
-- The motion linearized about an equilibrium or a steady motion (nz/analysis/linearize.lua).
function System:linearize(opts) return require("nz.analysis.linearize").linearize(self, opts) end
-- The eigenvalues against a parameter and where stability changes (nz/analysis/eigen_sweep.lua).
function System:eigen_sweep(opts) return require("nz.analysis.eigen_sweep").sweep(self, opts) end
-- The equations as formulas (nz/presentation/show.lua).
function System:show(opts) return require("nz.presentation.show").show(self, opts) end
-- The equations as code that runs without nzlua (nz/presentation/export.lua).
function System:export(opts) return require("nz.presentation.export").export(self, opts) end
-- Time as a coordinate (Rumyantsev, nz/analysis/rumyantsev.lua): the parametric
-- system, the energy integral and theorem, the Jacobi-Whittaker reduction.
function System:parametric(opts) return require("nz.analysis.rumyantsev").parametric(self, opts) end
function System:energy_integral() return require("nz.analysis.rumyantsev").energy_integral(self) end
function System:energy_theorem(tr) return require("nz.analysis.rumyantsev").energy_theorem(self, tr) end
function System:jacobi_whittaker(opts) return require("nz.analysis.rumyantsev").jacobi_whittaker(self, opts) end
-- An equilibrium or a steady motion near a guess (Newton, nz/analysis/linearize.lua).
function System:equilibrium(opts) return require("nz.analysis.linearize").equilibrium(self, opts) end

-- ------------------------------------------------------------------ --
-- Printing                                                             --

-- The name of the equations of order n (nz/model/constraints.lua: the rule's words).
M.principle = require("nz.model.constraints").principle

local function fmt(x) return ("%.10g"):format(x) end

local function vector_text(v) return text.list(v) end

-- Aligned table of rows of strings; the first row is the header
-- (nz/base/text.lua: every table of nz is made there).
M.table_text = require("nz.base.text").table

-- The terms of (3.1) of order n at a state, per coordinate, and the
-- residual at the accelerations qdd.  Without qdd, the system's own
-- accelerations (and multipliers) are used: the last column is then the
-- rounding of that solve seen in the form of order n, which says that the
-- forms agree and nothing about a motion, so it is headed and explained
-- as such (tr:residuals and sys:residuals_of measure a motion).
function System:equations(n, t, q, qd, qdd, opts)
  check_order("equations", n)
  check_state(self, "equations", 2, t, q, qd)
  if qdd ~= nil then check_vector(self, "equations", 5, "qdd", qdd) end
  check_options("equations", 6, opts, EQUATIONS_OPTIONS)
  n = n or self:rule()
  local given = qdd ~= nil
  local lambda
  if not given then qdd, lambda = self:accel(t, q, qd) end
  if self.nc == 0 then lambda = nil end
  local r, terms = mech.residual(self.engine, "generalized", n, t, q, qd, qdd, nil, true)
  local reaction = lambda and constraints.multiplier_terms(self, t, { q, qd, qdd }, lambda)
  if reaction then for i = 1, self.k do r[i] = r[i] - reaction[i] end end
  local last = given and "residual" or "rounding"
  local lines = {
    ("System '%s', order n = %d: %s"):format(self.name, n, M.principle(n)),
    ("  (1/%d) (dT^(%d)/dq^(%d) - %d dT/dq) - Q%s = %s,  Q includes -dV/dq"):format(n, n, n, n + 1,
      lambda and " - A^T lambda" or "", last),
    ("  at t = %s, q = %s, qd = %s, qdd = %s%s"):format(text.number(t), vector_text(q), vector_text(qd),
      vector_text(qdd), given and "" or " (the system's accelerations)"),
    "",
  }
  local rows = { { "coordinate", ("dT^(%d)/dq^(%d)"):format(n, n), ("%d dT/dq"):format(n + 1), "Q" } }
  if lambda then rows[1][#rows[1] + 1] = "A^T lambda" end
  rows[1][#rows[1] + 1] = last
  for i = 1, self.k do
    local row = { self.coords[i], fmt(terms.dFn[i]), fmt((n + 1) * terms.dFq[i]), fmt(terms.force[i]) }
    if lambda then row[#row + 1] = fmt(reaction[i]) end
    row[#row + 1] = ("%.3e"):format(r[i])
    rows[#rows + 1] = row
  end
  lines[#lines + 1] = M.table_text(rows)
  if not given then
    lines[#lines + 1] = ("  %s solved from these equations: the last column is the"):format(
      lambda and "qdd and lambda were" or "qdd was")
    lines[#lines + 1] = "  rounding of that solve (the forms agree), not a check of a motion.  Give"
    lines[#lines + 1] = "  qdd (measured, say) to see a residual; tr:residuals and sys:residuals_of"
    lines[#lines + 1] = "  measure the defect of a motion."
  end
  local text = table.concat(lines, "\n")
  if opts and opts.quiet then return text, r end
  require("nz.base.frontend").print(text)     -- (a notebook shows its table as HTML too)
  return nil
end

function System:__tostring()
  local have = {}
  for _, p in ipairs{ "T", "L", "V", "Q", "S" } do
    if self.pieces[p] > 0 then have[#have + 1] = self.pieces[p] > 1 and ("%s (%d pieces)"):format(p, self.pieces[p]) or p end
  end
  if self.nc > 0 then have[#have + 1] = ("%d constraint%s"):format(self.nc, self.nc == 1 and "" or "s") end
  if self.contact then have[#have + 1] = require("nz.model.contact").describe(self) end
  if self.effects and #self.effects > 0 then have[#have + 1] = "effects " .. table.concat(self.effects, ", ") end
  local params = {}
  for k, v in pairs(self.params) do params[#params + 1] = ("%s = %s"):format(k, tostring(v)) end
  table.sort(params)
  local lines = { ("nz.system '%s': %d coordinate%s (%s); %s%s"):format(self.name, self.k, self.k == 1 and "" or "s",
    table.concat(self.coords, ", "), table.concat(have, ", "),
    #params > 0 and ("; params {" .. table.concat(params, ", ") .. "}") or "") }
  -- One line per function: recorded into the graph (run in C), or in Lua and why.
  for _, r in ipairs(self.recording or {}) do
    lines[#lines + 1] = r.recorded and ("  %s: recorded, runs in C"):format(r.label)
      or ("  %s: runs in Lua: %s"):format(r.label, r.why)
  end
  if not self.recording then lines[#lines + 1] = "  every function runs in Lua (compile = false)" end
  if self.recording and self.recording.again then lines[#lines + 1] = "  " .. self.recording.again end
  return table.concat(lines, "\n")
end

-- The recording's figures: nodes in the graph, seconds it took, nodes of the
-- mass-bias graph (0 until the first accelerations), functions in C and in Lua,
-- plans running as machine code (native_series of them: series for taylor),
-- compiles still under way in the background, the seconds compiling took and
-- of those the seconds runs waited (native = true), and why a plan has no
-- machine code.
function System:graph_info()
  if not self.recording then return { nodes = 0, record_seconds = 0, mass_bias_nodes = 0, compiled = 0, interpreted = 0 } end
  local info = self.engine.recording:info()
  local nc, ni = 0, 0
  for _, r in ipairs(self.recording) do if r.recorded then nc = nc + 1 else ni = ni + 1 end end
  return { nodes = info.nodes, record_seconds = self.recording.seconds, mass_bias_nodes = info.mass_bias_nodes,
    compiled = nc, interpreted = ni, native_plans = info.native_plans, native_series = info.native_series,
    native_seconds = info.native_seconds, native_waited = info.native_waited,
    native_compiling = info.native_compiling, native_why = info.native_why, recorded_again = self.recording.again }
end

-- ------------------------------------------------------------------ --
-- The operators of §5 on a function f(t, q, qd [, params])             --

local function operator(which, m, f, t, q, qd, qdd, higher)
  local fname = ({ N = "nielsen_op", E = "euler_op", top = "top_coefficient", partial = "partial" })[which]
  if type(f) ~= "function" then arg_error(fname, 2, "a function f(t, q, qd) expected, got %s", shown(f)) end
  if type(q) ~= "table" or #q == 0 then arg_error(fname, 4, "q: a table of numbers expected, got %s", shown(q)) end
  local engine = { k = #q, name = "operator", F = { f }, T = {}, V = {}, Q = {}, S = {}, params = {},
    labels = { F = { "f" } } }
  return mech.operator(engine, which, m, t, q, qd, qdd, higher)
end

function M.nielsen_op(m, f, t, q, qd, qdd, higher) return operator("N", m, f, t, q, qd, qdd, higher) end
function M.euler_op(m, f, t, q, qd, qdd, higher) return operator("E", m, f, t, q, qd, qdd, higher) end
function M.top_coefficient(m, f, t, q, qd, qdd, higher) return operator("top", m, f, t, q, qd, qdd, higher) end
function M.partial(m, f, t, q, qd, qdd, higher) return operator("partial", m, f, t, q, qd, qdd, higher) end

-- sys.simulate{...} (a dot) is named as such by every method (nz/base/where.lua).
require("nz.base.where").methods(System, "sys", "system")

-- The modules below the face make and recognize systems through this.
classes.new_system = M.system

return M
