-- nz/analysis/rumyantsev.lua - time as a coordinate, after Rumyantsev, "On the
-- dynamics of Lagrangian rheonomic systems with constraints" (1978; the
-- formulas and their numbers: docs/theory.md §9):
--
--   sys:parametric{...}        the system in the extended space (q, t) with a
--                              parameter tau and the homogeneous Lagrangian
--                              Lambda = L(t, q, x'/t') t' (eq. 1.14-1.17)
--   sys:energy_integral()      whether H = h is a first integral, and why
--                              (eq. 2.1-2.2)
--   sys:energy_theorem(tr)     the two forms of the energy theorem along a
--                              trajectory (eq. 1.19, 3.3-3.7)
--   sys:jacobi_whittaker{...}  the path as a system in "time" q_1, by the
--                              energy integral (eq. 2.8-2.12)
--
-- The new systems are ordinary nz systems built from the user's own
-- functions (their T, L, V, Q and constraints, called on the new
-- arguments), so they are recorded, evaluated, printed and integrated like
-- any other.
local constraints = require "nz.model.constraints"
local options = require "nz.base.options"
local mech = require("nz.core").mech

local M = {}

local function fail(sys, fname, ...) require("nz.base.where").method_error(fname, sys, ...) end

local function coordinate(sys, fname, v, what)
  if type(v) == "string" then
    for i, name in ipairs(sys.coords) do if name == v then return i end end
    fail(sys, fname, "%s = '%s' is not a coordinate (coordinates: %s)", what, v, table.concat(sys.coords, ", "))
  end
  if math.type(v) ~= "integer" or v < 1 or v > sys.k then
    fail(sys, fname, "%s must be a coordinate's name or its number 1..%d, got %s", what, sys.k, tostring(v))
  end
  return v
end

-- L of the system from its pieces: the T and L pieces less the V pieces,
-- each called as the mechanics calls it (V without velocities).
local function lagrangian(sys)
  local e = sys.engine
  return function(t, q, qd, params)
    local s = 0
    for _, f in ipairs(e.F) do s = s + f(t, q, qd, params) end
    for _, f in ipairs(e.V) do s = s - f(t, q, params) end
    return s
  end
end

-- The generalized forces of the Q pieces, summed (nil without any).
local function forces(sys)
  local e = sys.engine
  if #e.Q == 0 then return nil end
  return function(t, q, qd, params)
    local out = {}
    for i = 1, sys.k do out[i] = 0 end
    for _, f in ipairs(e.Q) do
      local v = f(t, q, qd, params)
      if type(v) ~= "table" then v = { v } end
      for i = 1, sys.k do out[i] = out[i] + (v[i] or 0) end
    end
    return out
  end
end

-- Constraint r called with the slots it receives (q'' and above: zeros,
-- which a constraint of order <= 1 does not read) and params after them.
local function constraint_call(sys, r)
  local f, nslots = sys.engine.constraints[r], math.max(sys.constraint_levels[r] or 4, 4)
  local zero = {}
  for i = 1, sys.k do zero[i] = 0 end
  return function(t, q, qd, params)
    local args = { q, qd }
    for j = 3, nslots do args[j] = zero end
    args[nslots + 1] = params
    return f(t, table.unpack(args, 1, nslots + 1))
  end
end

-- The constraints' orders (the classification), refusing order 2 and more:
-- a constraint on q'' does not carry over to the new variables here.
local function orders_at_most_one(sys, fname)
  local orders = sys.nc > 0 and constraints.orders(sys) or {}
  for r, m in ipairs(orders) do
    if m >= 2 then
      fail(sys, fname, "constraint %d is of order %d: only constraints on q and q' (order 0 and 1) carry over", r, m)
    end
  end
  return orders
end

-- ------------------------------------------------------------------ --
-- The parametric form (eq. 1.14-1.17)

-- sys:parametric{[time = "t", tau = function(tau) return t end]}: the
-- system in x = (q_1..q_k, t) with the parameter tau (the new system's own
-- time), Lambda(x, x') = L(x_{k+1}, x_1..x_k, x'_i / x'_{k+1}) x'_{k+1}
-- (homogeneous of degree 1 in x'), the constraints f_l(x_{k+1}, x, x'/x'_{k+1})
-- and the forces Q_i x'_{k+1} (i <= k), -sum_i Q_i x'_i (the last: the
-- power of Q, so that sum_alpha Q_alpha x'_alpha = 0 as Lambda's
-- homogeneity requires).  Its k + 1 equations (1.17) are dependent: the
-- mass matrix is singular (x' is in its kernel).  `tau` fixes the
-- parametrization by the constraint t = tau(tau_value), which makes the
-- motion determined, so that it can be integrated.
local PARAMETRIC_OPTIONS = options.declare("sys:parametric", { "time", "tau" })
local JW_OPTIONS = options.declare("sys:jacobi_whittaker", { "h", "independent" })

function M.parametric(sys, opts)
  local fname = "parametric"
  opts = opts or {}
  if type(opts) ~= "table" then fail(sys, fname, "options must be a table {time =, tau =}") end
  options.check(opts, PARAMETRIC_OPTIONS, function(...) fail(sys, fname, ...) end)
  local tname = opts.time or "t"
  for _, c in ipairs(sys.coords) do
    if c == tname then fail(sys, fname, "a coordinate is already named '%s': name time otherwise (time = \"...\")", tname) end
  end
  if opts.tau ~= nil and type(opts.tau) ~= "function" then
    fail(sys, fname, "tau must be a function of the parameter giving t (t = tau(s)), got %s", type(opts.tau))
  end
  local k = sys.k
  local orders = orders_at_most_one(sys, fname)
  local L, Q = lagrangian(sys), forces(sys)
  -- (x, x') -> (t, q, q', t')
  local function split(x, xd)
    local q, qd, tp = {}, {}, xd[k + 1]
    for i = 1, k do q[i], qd[i] = x[i], xd[i] / tp end
    return x[k + 1], q, qd, tp
  end
  local def = { name = sys.name .. " (parametric: time as a coordinate)", params = sys.params }
  def.coords = { table.unpack(sys.coords) }
  def.coords[k + 1] = tname
  def.L = function(_, x, xd, params)
    local t, q, qd, tp = split(x, xd)
    return L(t, q, qd, params) * tp
  end
  if Q then
    def.Q = function(_, x, xd, params)
      local t, q, qd, tp = split(x, xd)
      local f, out, power = Q(t, q, qd, params), {}, 0
      for i = 1, k do out[i], power = f[i] * tp, power + f[i] * xd[i] end
      out[k + 1] = -power
      return out
    end
  end
  local list = {}
  for r = 1, sys.nc do
    local f = constraint_call(sys, r)
    if orders[r] == 0 then
      list[r] = function(_, x, xd, _, _, params)   -- holonomic: no velocities
        local q = {}
        for i = 1, k do q[i] = x[i] end
        return f(x[k + 1], q, nil, params)
      end
    else
      list[r] = function(_, x, xd, _, _, params)
        local t, q, qd = split(x, xd)
        return f(t, q, qd, params)
      end
    end
  end
  if opts.tau then
    local tau = opts.tau
    list[#list + 1] = function(s, x) return x[k + 1] - tau(s) end
  end
  if #list > 0 then def.constraints = list end
  -- a sample state with t' = 1 (the recording divides by it)
  local base = sys.sample or {}
  local sq, sqd = {}, {}
  for i = 1, k do sq[i], sqd[i] = (base.q and base.q[i]) or 0.2, (base.qd and base.qd[i]) or 0.3 end
  sq[k + 1], sqd[k + 1] = base.t or 0.3, 1
  def.sample = { t = 0.1, q = sq, qd = sqd }
  local ok, p = pcall(require("nz.base.classes").new_system, def)
  if not ok then fail(sys, fname, "the parametric system could not be made: %s", tostring(p)) end
  p.parent, p.time_index = sys, k + 1
  return p
end

-- ------------------------------------------------------------------ --
-- The energy integral (eq. 2.1-2.2) and the energy theorem (eq. 3.3-3.7)

local Integral = {}
Integral.__index = Integral

-- Whether H = sum q' dL/dq' - L = T2 - T0 + V is a first integral: L free
-- of t, every constraint homogeneous in the velocities (a holonomic one
-- free of t), and no force Q doing work.  Checked at the classification's
-- sample states (dL/dt, the forces' power), with the reasons.
function M.energy_integral(sys)
  local fname = "energy_integral"
  local rep = setmetatable({ system = sys, reasons = {}, holds = true }, Integral)
  local states = constraints.sample_states(sys, 8)
  local dLdt, at = 0, nil
  local scleronomic = true      -- T1 = T0 = 0: then H = T + V
  local power, size = 0, 1      -- size: the energies' scale, for the tests below
  local Qf = forces(sys)
  for _, st in ipairs(states) do
    local q, qd = st[1], st[2]
    local _, _, _, H = mech.energy(sys.engine, st.t, q, qd)   -- T, V, F, H
    size = math.max(size, math.abs(H))
    local d, T0, T1 = mech.energy_terms(sys.engine, st.t, q, qd)
    if math.abs(d) > math.abs(dLdt) then dLdt, at = d, st.t end
    if math.abs(T0) + math.abs(T1) > 1e-12 then scleronomic = false end
    if Qf then
      local f = Qf(st.t, q, qd, sys.params)
      local pw = 0
      for i = 1, sys.k do pw = pw + f[i] * qd[i] end
      power = math.max(power, math.abs(pw))
    end
  end
  if math.abs(dLdt) > 1e-10 * size then
    rep.holds = false
    rep.reasons[#rep.reasons + 1] = ("L depends on t explicitly (dL/dt = %.3g at t = %.3g)"):format(dLdt, at)
  end
  if power > 1e-10 * size then
    rep.holds = false
    rep.reasons[#rep.reasons + 1] = ("the forces Q do work (their power sum Q_i q'_i reaches %.3g)"):format(power)
  end
  if sys.nc > 0 then
    for r, c in ipairs(constraints.classify(sys)) do
      if c.order >= 2 then
        rep.holds = false
        rep.reasons[#rep.reasons + 1] = ("constraint %d is of order %d: the energy theorem here covers constraints on q and q'"):format(r, c.order)
      elseif not c.homogeneous then
        rep.holds = false
        rep.reasons[#rep.reasons + 1] = c.order == 0
          and ("constraint %d moves (it depends on t): its reaction does work"):format(r)
          or ("constraint %d is not homogeneous in the velocities: sum_i (dPhi/dq'_i) q'_i != k Phi, and its multiplier does work"):format(r)
      end
    end
  end
  rep.scleronomic = scleronomic
  rep.quantity = scleronomic and "H = T + V" or "H = T2 - T0 + V (Jacobi's integral)"
  return rep
end

function Integral:__tostring()
  local sys = self.system
  if self.holds then
    local s = ("'%s': %s is a first integral (Rumyantsev eq. 2.2): L does not depend on t, "):format(sys.name, self.quantity)
    s = s .. (sys.nc > 0 and "every constraint is homogeneous in the velocities" or "there are no constraints")
    s = s .. (#sys.engine.Q > 0 and ", and the forces Q do no work." or ".")
    if not self.scleronomic then s = s .. "\n  T + V is not conserved: T has parts of degree 1 or 0 in the velocities (a moving frame)." end
    return s
  end
  local lines = { ("'%s': H = T2 - T0 + V is not a first integral:"):format(sys.name) }
  for _, r in ipairs(self.reasons) do lines[#lines + 1] = "  - " .. r end
  lines[#lines + 1] = "  What holds instead: dH/dt = -dL/dt + sum_i Q_i q'_i + sum_l lambda_l sum_i (df_l/dq'_i) q'_i (eq. 1.19 with the"
    .. " forces' power), and T + V - W is constant, W = integral (R_0 + sum_i Q_i q'_i) dt the work of the moving constraints"
    .. " and of the forces Q (eq. 3.3-3.7): simulate with monitors = {energy = true, work = true} and see sys:energy_theorem(tr)."
  return table.concat(lines, "\n")
end

-- Along a trajectory recorded with monitors = {energy = true, work = true}:
-- the drift of H (its conservation, when energy_integral holds) and of
-- T + V - W, W = integral (R_0 + Q.q') dt (always: eq. 3.3-3.7 with the
-- forces' work), each relative to the size of the energy.
function M.energy_theorem(sys, tr)
  local fname = "energy_theorem"
  if type(tr) ~= "table" or not tr.t then fail(sys, fname, "a trajectory of sys:simulate expected") end
  if not tr.energy or not tr.generalized_energy then
    fail(sys, fname, "the trajectory has no energies: simulate with monitors = {energy = true, work = true}")
  end
  local function span(v)
    local lo, hi = math.huge, -math.huge
    for _, x in ipairs(v) do lo, hi = math.min(lo, x), math.max(hi, x) end
    return hi - lo
  end
  local out = { H_drift = span(tr.generalized_energy), T_V_change = span(tr.energy), integral = M.energy_integral(sys) }
  if tr.work then
    local c = {}
    for i = 1, #tr.t do c[i] = tr.energy[i] - tr.work[i] end
    out.T_V_minus_work_drift = span(c)
  end
  return out
end

-- ------------------------------------------------------------------ --
-- The Jacobi-Whittaker reduction (eq. 2.8-2.12)

-- sys:jacobi_whittaker{h = h, independent = "phi"}: with H = h conserved,
-- q_1 = the independent coordinate as "time" and the others q_s as
-- coordinates, R(q_1, q_s, q_s') = 2 sqrt((h + L0) G) + Phi1 (eq. 2.12), G =
-- T2 and Phi1 = T1 at q_1' = 1, q_s' = dq_s/dq_1, and L0 the part of L free of
-- the velocities; the constraints f_l(q, (1, q_s')) (homogeneous, so that
-- they hold at every speed along the path).  The time along the path:
-- dt/dq_1 = sqrt(G / (h + L0)) (path:elapsed(tr)).
function M.jacobi_whittaker(sys, opts)
  local fname = "jacobi_whittaker"
  if type(opts) ~= "table" then fail(sys, fname, "options {h = ..., independent = ...} expected") end
  options.check(opts, JW_OPTIONS, function(...) fail(sys, fname, ...) end)
  local h = opts.h
  if type(h) ~= "number" or h ~= h or math.abs(h) == math.huge then
    fail(sys, fname, "h: the value of the energy integral H = h (a finite number) expected, got %s",
      type(h) == "number" and require("nz.base.text").number(h) or tostring(h))   -- NaN as "NaN", not the C library's "-nan"
  end
  if opts.independent == nil then fail(sys, fname, "independent: the coordinate that plays the part of time, by name or number") end
  local j = coordinate(sys, fname, opts.independent, "independent")
  if sys.k < 2 then fail(sys, fname, "one coordinate: its path is the coordinate itself; the time along it is t(q) = integral dq / q'") end
  local integral = M.energy_integral(sys)
  if not integral.holds then
    fail(sys, fname, "H = h is not a first integral of this system, so the reduction does not apply: %s",
      table.concat(integral.reasons, "; "))
  end
  orders_at_most_one(sys, fname)
  local k, L = sys.k, lagrangian(sys)
  local others = {}
  for i = 1, k do if i ~= j then others[#others + 1] = i end end
  -- q and the velocity direction (q_1' = 1) from (q_1, q_s, q_s')
  local function full(q1, qs, qsd)
    local q, v = {}, {}
    q[j], v[j] = q1, 1
    for n, i in ipairs(others) do q[i], v[i] = qs[n], qsd[n] end
    return q, v
  end
  -- G, Phi1, L0 of L = G + Phi1 + L0 (degrees 2, 1, 0 in the velocity),
  -- exactly from L at v, -v and 0 (L is quadratic in the velocities)
  local function parts(q, v, params)
    local nv = {}
    for i = 1, k do nv[i] = -v[i] end
    local zero = {}
    for i = 1, k do zero[i] = 0 end
    local lp, lm, l0 = L(0, q, v, params), L(0, q, nv, params), L(0, q, zero, params)
    return 0.5 * (lp + lm) - l0, 0.5 * (lp - lm), l0
  end
  -- L must be quadratic in the velocities: L(2v) = 4 G + 2 Phi1 + L0 at a sample
  do
    local q, v = {}, {}
    for i = 1, k do q[i], v[i] = 0.3 + 0.1 * i, 0.5 - 0.2 * i end
    local G, P, L0 = parts(q, v, sys.params)
    local v2 = {}
    for i = 1, k do v2[i] = 2 * v[i] end
    local l2 = L(0, q, v2, sys.params)
    if math.abs(l2 - (4 * G + 2 * P + L0)) > 1e-9 * (1 + math.abs(l2)) then
      fail(sys, fname, "L is not quadratic in the velocities (T2 + T1 + L0): eq. 2.12 does not apply")
    end
  end
  local sqrt = require("nz.core").sqrt   -- numbers, jets and the recorder's tracers
  local def = { name = ("%s: path in %s (Jacobi-Whittaker, h = %.6g)"):format(sys.name, sys.coords[j], h), params = sys.params }
  def.coords = {}
  for n, i in ipairs(others) do def.coords[n] = sys.coords[i] end
  -- The value a number, jet or dualjet carries (nil for the recorder's
  -- tracers: a recorded L that meets h + L0 < 0 fails in its graph, which
  -- hands that evaluation back to this function, on jets).
  local function value_of(x)
    if type(x) == "number" then return x end
    local mt = getmetatable(x)
    local name = type(mt) == "table" and mt.__name
    if name == "nz.jet" or name == "nz.dualjet" then return x:value() end
  end
  def.L = function(q1, qs, qsd, params)
    local q, v = full(q1, qs, qsd)
    local G, P, L0 = parts(q, v, params)
    -- Where h + L0 <= 0 the motion with H = h cannot be: say so, with the
    -- numbers, rather than let sqrt fail ("'sqrt' of a negative value" at a
    -- line of this file, which told the user nothing).
    local e = value_of(h + L0)
    if e and not (e > 0) then
      local at = {}
      for i = 1, k do at[i] = ("%s = %.6g"):format(sys.coords[i], value_of(q[i]) or 0 / 0) end
      error(("the energy h = %.6g is too low here: raise h above %.6g (= -L0 here), or start where h + L0 > 0; L0 = "
        .. "%.6g is the part of L free of the velocities (-V for a natural system), and h + L0 = %.6g is not positive "
        .. "at %s, so no motion with H = h reaches it"):format(h, h - e, e - h, e, table.concat(at, ", ")), 0)
    end
    return 2 * sqrt((h + L0) * G) + P
  end
  if sys.nc > 0 then
    def.constraints = {}
    for r = 1, sys.nc do
      local f = constraint_call(sys, r)
      def.constraints[r] = function(q1, qs, qsd, _, _, params)
        local q, v = full(q1, qs, qsd)
        return f(0, q, v, params)
      end
    end
  end
  local ok, path = pcall(require("nz.base.classes").new_system, def)
  if not ok then fail(sys, fname, "the reduced system could not be made: %s", tostring(path)) end
  path.parent, path.h, path.independent = sys, h, j
  -- The path with the elapsed time as one more coordinate tau (made at the
  -- first path:elapsed): L + (tau' - f)^2 / 2, f = dt/dq_1 = sqrt(G / (h +
  -- L0)).  tau is cyclic, so its momentum tau' - f is conserved, and from
  -- tau' = f at the start it stays 0: its terms in the other coordinates'
  -- equations, d/dq_1(-(tau' - f) df/dq_s') + (tau' - f) df/dq_s, vanish and
  -- the path is the same, while tau = the integral of f is integrated with
  -- it under the stepper's error control.  Its mass matrix [M + f_v f_v^T,
  -- -f_v; -f_v^T, 1] (v = q_s') has M as its Schur complement: as regular as
  -- the path's.
  local with_time
  function path.time_system()
    if with_time then return with_time end
    local n = #others
    local function split(x, xd)
      local qs, qsd = {}, {}
      for i = 1, n do qs[i], qsd[i] = x[i], xd and xd[i] end
      return qs, qsd
    end
    local function rate(q1, qs, qsd, params)
      local q, v = full(q1, qs, qsd)
      local G, _, L0 = parts(q, v, params)
      return sqrt(G / (h + L0))
    end
    local tdef = { name = path.name .. " with its elapsed time", params = sys.params, coords = {} }
    for i = 1, n do tdef.coords[i] = def.coords[i] end
    tdef.coords[n + 1] = "elapsed time"
    tdef.L = function(q1, x, xd, params)
      local qs, qsd = split(x, xd)
      local c = xd[n + 1] - rate(q1, qs, qsd, params)
      return def.L(q1, qs, qsd, params) + 0.5 * c * c
    end
    if def.constraints then
      tdef.constraints = {}
      for r, f in ipairs(def.constraints) do
        tdef.constraints[r] = function(q1, x, xd, a, b, params)
          local qs, qsd = split(x, xd)
          return f(q1, qs, qsd, a, b, params)
        end
      end
    end
    local made
    made, with_time = pcall(require("nz.base.classes").new_system, tdef)
    if not made then fail(sys, "elapsed", "the path with its time could not be made: %s", tostring(with_time)) end
    return with_time
  end
  -- dt/dq_1 = sqrt(G / (h + L0)) at a point of the path
  function path.time_rate(_, q1, qs, qsd)
    local q, v = full(q1, qs, qsd)
    local G, _, L0 = parts(q, v, sys.params)
    if not (h + L0 > 0 and G > 0) then
      fail(sys, fname, "at %s = %.6g the energy h + L0 = %.6g or G = %.6g is not positive: the motion does not reach here "
        .. "with this h", sys.coords[j], q1, h + L0, G)
    end
    return math.sqrt(G / (h + L0))
  end
  path.elapsed = M.elapsed
  return path
end

-- The physical time at each point of a trajectory of the reduced system,
-- 0 at its first point: the path integrated again from its first state with
-- the elapsed time tau as one more coordinate (path.time_system: tau' =
-- dt/dq_1 = sqrt(G / (h + L0))), by the trajectory's method and tolerances
-- (or fixed step) on the same output grid, so that tau is as accurate as the
-- path at every point whatever the grid.  Off the grid (a point that is not
-- t0 + i dt of path:simulate) it refuses.
function M.elapsed(path, tr)
  local where = require("nz.base.where").user_where
  if type(tr) ~= "table" or not tr.t or not tr.q or not tr.qd or not tr.qdd then
    error(("%spath:elapsed: a trajectory of path:simulate expected"):format(where()), 0)
  end
  local n = #tr.t
  if n == 0 then return {} end
  if n == 1 then return { 0 } end
  if tr.system ~= nil and tr.system ~= path then
    error(("%spath:elapsed: the trajectory is of system '%s', not of the path '%s'"):format(where(), tr.system.name,
      path.name), 0)
  end
  -- The grid of path:simulate: t0 + i dt, and the last point t1 (or where
  -- the run stopped) at most dt after the one before.
  local t0 = tr.t[1]
  local dt = n > 2 and (tr.t[n - 1] - t0) / (n - 2) or tr.t[2] - t0
  for i = 2, n - 1 do
    if math.abs(tr.t[i] - (t0 + (i - 1) * dt)) > 1e-9 * dt then
      error(("%spath:elapsed: the trajectory's points are not the output grid of path:simulate (t%d = %.17g, not t0 + "
        .. "%d dt = %.17g): integrate the path with path:simulate{..., dt = ...}"):format(where(), i, tr.t[i], i - 1,
        t0 + (i - 1) * dt), 0)
    end
  end
  local sys = path.time_system()
  local q0, qd0 = { table.unpack(tr.q[1]) }, { table.unpack(tr.qd[1]) }
  local k = path.k
  q0[k + 1], qd0[k + 1] = 0, path:time_rate(t0, tr.q[1], tr.qd[1])
  local opts = { q0 = q0, qd0 = qd0, t0 = t0, t1 = tr.t[n], dt = dt, method = tr.method }
  if tr.step then opts.step = tr.step else opts.rtol, opts.atol = tr.rtol, tr.atol end
  local run = sys:simulate(opts)
  if #run.t ~= n then
    error(("%spath:elapsed: the path with its time gave %d points where the trajectory has %d (status '%s')"):format(
      where(), #run.t, n, tostring(run.status)), 0)
  end
  local out = { 0 }
  for i = 2, n do
    -- the grids agree to rounding: move tau by tau' over the difference
    out[i] = run.q[i][k + 1] + run.qd[i][k + 1] * (tr.t[i] - run.t[i])
  end
  return out
end

return M
