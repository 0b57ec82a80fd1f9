-- nz/analysis/linearize.lua - sys:linearize{...}: the motion linearized about an
-- equilibrium or a steady motion, x' = A x, with its eigenvalues and modes;
-- sys:equilibrium{...}, Newton's method for one near a guess.  With
-- constraints of order 0 and 1 (holonomic and nonholonomic, linear or not
-- in the velocities) and 2 (on the accelerations: they act through the
-- accelerations alone).
--
-- A is exact: nothing here takes a finite difference.  The state is a point
-- (q, q') on the constraints, and the linearized motion lives in the
-- tangent space of the constraints there:
--   position:  Phi_q dq = 0                     (holonomic Phi)
--   velocity:  G_q dq + G_q' dq' = 0           (G = Phi' of a holonomic one,
--                                               or a first-order constraint)
-- The tangent space is parametrized by the kept coordinates and speeds: the
-- dependent coordinates follow from the first rows, the dependent speeds
-- from the second, both through exact gradients (jets with tangents,
-- core.mech.constraint_state_gradient); the accelerations along a tangent
-- direction come from the exact Jacobian of the constrained accelerations
-- (core.mech.ode_jacobian, src/mech/mech_jacobian.c).  The constrained
-- accelerations keep the constraints to second order, so the flow maps the
-- tangent space to itself and this is the linearization of the reduced
-- motion (what Tsenov's reduced equations give, without multipliers).
--
-- What is left out of the state: a coordinate that is not kept is either
-- dependent (solved from the holonomic constraints, Newton, reported) or
-- ignorable (held at its value: it must not appear in the kept equations,
-- else the call says so); a speed that is not kept is dependent (solved
-- from the velocity constraints), held (`hold`: a motor, a wheel's rate in a
-- steady run) or must not appear.  nzlua chooses the dependent ones by
-- complete pivoting on the constraints' gradients unless told
-- (`dependent`), and says which.
--
-- M, C, K of M q'' + C q' + K q = 0 are given when the kept coordinates and
-- the kept speeds are the same: M is the reduced mass matrix V^T M V (V:
-- the full velocity along each kept speed on the constraints), C = -M
-- dq''/dq', K = -M dq''/dq (the rows of A).
local core = require "nz.core"
local mech = core.mech
local constraints = require "nz.model.constraints"
local options = require "nz.base.options"

local M = {}

local Linear = {}
Linear.__index = Linear

local method = "linearize"   -- the public function running, for messages

local function fail(sys, ...) require("nz.base.where").method_error(method, sys, ...) end

-- Coordinate numbers from names or 1-based indices.
local function indices(sys, list, what)
  if type(list) ~= "table" then fail(sys, "%s: a list of coordinate names or numbers expected, got %s", what, type(list)) end
  local out, seen = {}, {}
  for n, v in ipairs(list) do
    local i = v
    if type(v) == "string" then
      for j, name in ipairs(sys.coords) do if name == v then i = j end end
      if type(i) ~= "number" then
        fail(sys, "%s[%d] = '%s' is not a coordinate (coordinates: %s)", what, n, v, table.concat(sys.coords, ", "))
      end
    end
    if math.type(i) ~= "integer" or i < 1 or i > sys.k then
      fail(sys, "%s[%d] must be a coordinate's name or its number 1..%d, got %s", what, n, sys.k, tostring(v))
    end
    if seen[i] then fail(sys, "%s names coordinate '%s' twice", what, sys.coords[i]) end
    seen[i] = true
    out[#out + 1] = i
  end
  return out, seen
end

local function names(sys, list, suffix)
  local out = {}
  for n, i in ipairs(list) do out[n] = sys.coords[i] .. (suffix or "") end
  return out
end

local function set_of(list) local s = {}; for _, i in ipairs(list) do s[i] = true end; return s end
local function max_abs(v) local m = 0; for i = 1, #v do m = math.max(m, math.abs(v[i])) end; return m end
local function zeros(n) local v = {}; for i = 1, n do v[i] = 0 end; return v end

-- The columns `cols` of the rows G, as a matrix.
local function columns(G, cols)
  local S = {}
  for r = 1, #G do
    S[r] = {}
    for c, j in ipairs(cols) do S[r][c] = G[r][j] end
  end
  return S
end

-- #G columns of G (rows of length >= max(cand)) chosen among `cand` by
-- complete pivoting (Gauss elimination, the largest remaining entry first):
-- a well-conditioned square block.  nil when the rows are dependent there.
local function pick_columns(G, cand)
  local n = #G
  local W, scale = {}, 0
  for r = 1, n do
    W[r] = { table.unpack(G[r]) }
    for _, j in ipairs(cand) do scale = math.max(scale, math.abs(G[r][j])) end
  end
  local chosen, used = {}, {}
  for r = 1, n do
    local best, bc, br = 0, nil, nil
    for rr = r, n do
      for _, j in ipairs(cand) do
        if not used[j] and math.abs(W[rr][j]) > best then best, bc, br = math.abs(W[rr][j]), j, rr end
      end
    end
    if not bc or best <= 1e-10 * scale then return nil end
    W[r], W[br] = W[br], W[r]
    for rr = r + 1, n do
      local f = W[rr][bc] / W[r][bc]
      if f ~= 0 then for j = 1, #W[rr] do W[rr][j] = W[rr][j] - f * W[r][j] end end
    end
    chosen[r], used[bc] = bc, true
  end
  table.sort(chosen)
  return chosen
end
M.pick_columns = pick_columns   -- also sys:show's choice of dependent coordinates

-- The constraints' rows on the state: `list` holds {r = constraint, level =
-- 0 or 1}; values and gradients in (q, q') (rows of 2k).
local function constraint_rows(sys, t, q, qd, list)
  local k, vals, G = sys.k, {}, {}
  for n, c in ipairs(list) do
    local v, gq, gqd = mech.constraint_state_gradient(sys.engine, c.r, c.level, t, q, qd)
    local row = {}
    for i = 1, k do row[i], row[k + i] = gq[i], gqd[i] end
    vals[n], G[n] = v, row
  end
  return vals, G
end

-- Newton's method on the rows `list` in the unknowns `unknown` of x (q for
-- offset 0, q' for offset k): x is changed in place.  Returns the iterations
-- and the last residual.
local function newton(sys, t, q, qd, list, unknown, offset, what)
  local x = offset == 0 and q or qd
  local res, last = math.huge, math.huge
  for it = 0, 50 do
    local vals, G = constraint_rows(sys, t, q, qd, list)
    res = max_abs(vals)
    -- converged: the residual is at rounding level of its terms, or stops falling
    local size = 0
    for r = 1, #G do
      for j = 1, 2 * sys.k do size = math.max(size, math.abs(G[r][j] * (j <= sys.k and q[j] or qd[j - sys.k]))) end
    end
    if res <= 1e-15 * (1 + size) or (it > 2 and res >= 0.5 * last) then return it, res end
    if it == 50 then break end
    local cols = {}
    for c, i in ipairs(unknown) do cols[c] = offset + i end
    local neg = {}
    for r = 1, #vals do neg[r] = -vals[r] end
    local step = mech.lstsq(columns(G, cols), neg)
    for c, i in ipairs(unknown) do x[i] = x[i] + step[c] end
    last = res
  end
  fail(sys, "Newton's method did not solve the %s (residual %.3g): start nearer to the constraints", what, res)
end

-- Read the point and the choice of the state, solve the dependent
-- coordinates and speeds there: everything the linearization needs but the
-- derivatives.  `hold_rest` (equilibrium): speeds left out and not dependent
-- are held rather than checked.
local function prepare(sys, opts, name, hold_rest)
  method = name
  local k = sys.k
  if type(opts.q) ~= "table" or #opts.q ~= k then fail(sys, "q: a table of %d numbers expected", k) end
  local qd = opts.qd or zeros(k)
  if type(qd) ~= "table" or #qd ~= k then fail(sys, "qd: a table of %d numbers expected", k) end
  local t = opts.t or 0
  local q = { table.unpack(opts.q) }
  qd = { table.unpack(qd) }
  local c = { t = t, q = q, qd = qd }
  local hold = indices(sys, opts.hold or {}, "hold")
  local held = set_of(hold)
  local coords_given = opts.coords ~= nil
  local kept_given = coords_given and set_of((indices(sys, opts.coords, "coords"))) or {}

  -- the constraints: position rows (holonomic) and velocity rows
  local orders, linear = {}, {}
  c.pos, c.vel = {}, {}
  if sys.nc > 0 then
    orders, linear = constraints.orders(sys, { t = t, q = q, qd = qd })
    for r, m in ipairs(orders) do
      if m >= 3 then
        fail(sys, "constraint %d is of order %d: the state would hold q'' and more, which linearization does not handle "
          .. "(constraints of order 0, 1 and 2 are)", r, m)
      end
      if m == 0 then c.pos[#c.pos + 1] = { r = r, level = 0 } end
      if m <= 1 then c.vel[#c.vel + 1] = { r = r, level = 1 - m } end
    end
  end
  c.orders, c.linear = orders, linear

  -- dependent coordinates: named, or picked among those not kept
  local dep
  if #c.pos > 0 then
    local _, P = constraint_rows(sys, t, q, qd, c.pos)
    if opts.dependent then
      dep = indices(sys, opts.dependent, "dependent")
      if #dep ~= #c.pos then
        fail(sys, "dependent names %d coordinates; the %d holonomic constraints fix %d", #dep, #c.pos, #c.pos)
      end
      for _, i in ipairs(dep) do
        if kept_given[i] then fail(sys, "'%s' is both kept (coords) and dependent", sys.coords[i]) end
      end
      local sv = mech.singular_values(columns(P, dep))
      if sv[#sv] <= 1e-10 * sv[1] then
        fail(sys, "the holonomic constraints do not fix the dependent coordinates {%s} here (their gradient is singular): "
          .. "name others, or leave dependent out for nzlua to choose", table.concat(names(sys, dep), ", "))
      end
    else
      local cand = {}
      for i = 1, k do if not kept_given[i] then cand[#cand + 1] = i end end
      dep = pick_columns(P, cand)
      if not dep then
        fail(sys, "the holonomic constraints cannot be solved for coordinates outside coords {%s} here: keep fewer "
          .. "coordinates, or name the dependent ones", table.concat(names(sys, opts.coords and indices(sys, opts.coords, "coords") or {}), ", "))
      end
    end
    c.position_newton = { newton(sys, t, q, qd, c.pos, dep, 0, "holonomic constraints for the dependent coordinates") }
  else
    dep = {}
  end
  local is_dep = set_of(dep)
  for _, i in ipairs(hold) do
    if is_dep[i] then fail(sys, "'%s' is dependent (fixed by the holonomic constraints): its speed cannot be held", sys.coords[i]) end
  end

  -- kept coordinates: given, or every one not dependent (the ignorable ones
  -- are dropped after the derivatives are known)
  local coords
  if coords_given then coords = indices(sys, opts.coords, "coords")
  else coords = {}; for i = 1, k do if not is_dep[i] then coords[#coords + 1] = i end end end

  -- speeds: kept (given, or those of the kept coordinates), held, dependent
  -- (picked among the rest, the dependent coordinates' own first), and any
  -- left over must not appear
  local speeds
  if opts.speeds then speeds = indices(sys, opts.speeds, "speeds")
  elseif coords_given then speeds = {}; for _, i in ipairs(coords) do if not held[i] then speeds[#speeds + 1] = i end end
  end
  local moving = set_of(speeds or {})
  for _, i in ipairs(hold) do
    if moving[i] then fail(sys, "'%s' is both a kept speed and held", sys.coords[i]) end
  end
  local dep_speeds = {}
  if #c.vel > 0 then
    local _, V = constraint_rows(sys, t, q, qd, c.vel)
    local Vd = {}
    for r = 1, #V do Vd[r] = { table.unpack(V[r], k + 1, 2 * k) } end
    local first, rest = {}, {}
    local kept = set_of(coords)
    for i = 1, k do
      if not moving[i] and not held[i] then
        if is_dep[i] or not kept[i] then first[#first + 1] = i else rest[#rest + 1] = i end
      end
    end
    dep_speeds = pick_columns(Vd, first)
    if not dep_speeds then
      local all = { table.unpack(first) }
      for _, i in ipairs(rest) do all[#all + 1] = i end
      dep_speeds = pick_columns(Vd, all)
    end
    if not dep_speeds then
      local free = { table.unpack(first) }
      for _, i in ipairs(rest) do free[#free + 1] = i end
      fail(sys, "the %d velocity constraints cannot be solved for the speeds left free (%s) here: keep or hold fewer "
        .. "speeds (%d of the %d must be dependent)", #c.vel,
        -- first, then rest, as pick_columns took them ("(, x, y)" when first was empty)
        #free > 0 and table.concat(names(sys, free), ", ") or "none",
        #c.vel, k)
    end
    c.velocity_newton = { newton(sys, t, q, qd, c.vel, dep_speeds, sys.k, "velocity constraints for the dependent speeds") }
  end
  local is_dep_speed = set_of(dep_speeds)
  if not speeds then
    speeds = {}
    for i = 1, k do if not held[i] and not is_dep_speed[i] then speeds[#speeds + 1] = i end end
    moving = set_of(speeds)
  end
  local free_speeds = {}             -- left out, not held, not dependent
  for i = 1, k do
    if not moving[i] and not held[i] and not is_dep_speed[i] then
      if hold_rest then hold[#hold + 1], held[i] = i, true else free_speeds[#free_speeds + 1] = i end
    end
  end
  c.coords, c.coords_given, c.speeds, c.hold = coords, coords_given, speeds, hold
  c.dependent, c.dependent_speeds, c.free_speeds = dep, dep_speeds, free_speeds
  c.held, c.moving, c.is_dep, c.is_dep_speed = held, moving, is_dep, is_dep_speed
  return c
end

-- The tangent direction of the constraints with the free parts dq (0 on the
-- dependent coordinates) and dqd (0 on the dependent speeds): the dependent
-- parts solved from the gradients, and the accelerations' derivative.
local function tangent(sys, c, dq, dqd)
  local k = sys.k
  if #c.dependent > 0 then
    local b = {}
    for r = 1, #c.P do
      local s = 0
      for j = 1, k do s = s + c.P[r][j] * dq[j] end
      b[r] = -s
    end
    local x = mech.lstsq(c.P_dep, b)
    for n, i in ipairs(c.dependent) do dq[i] = x[n] end
  end
  if #c.dependent_speeds > 0 then
    local b = {}
    for r = 1, #c.V do
      local s = 0
      for j = 1, k do s = s + c.V[r][j] * dq[j] + c.V[r][k + j] * dqd[j] end
      b[r] = -s
    end
    local x = mech.lstsq(c.V_dep, b)
    for n, i in ipairs(c.dependent_speeds) do dqd[i] = x[n] end
  end
  local acc = {}
  for i = 1, k do
    local row, s = c.J[k + i], 0
    for j = 1, k do s = s + row[j] * dq[j] + row[k + j] * dqd[j] end
    acc[i] = s
  end
  return { dq = dq, dqd = dqd, acc = acc }
end

-- The derivatives at the prepared point: the Jacobian of the constrained
-- accelerations, the constraint gradients, the accelerations there.
local function differentiate(sys, c)
  local k = sys.k
  local ode = mech.ode_new(sys.engine, { method = "rk8pd", rtol = 1e-10, atol = 1e-10, orders = c.orders, linear = c.linear })
  local y = {}
  for i = 1, k do y[i], y[k + i] = c.q[i], c.qd[i] end
  c.J = mech.ode_jacobian(ode, sys.engine, c.t, y)
  c.qdd = mech.ode_accel(ode, sys.engine, c.t, y)
  local _
  if #c.dependent > 0 then
    _, c.P = constraint_rows(sys, c.t, c.q, c.qd, c.pos)
    c.P_dep = columns(c.P, c.dependent)
  end
  if #c.dependent_speeds > 0 then
    _, c.V = constraint_rows(sys, c.t, c.q, c.qd, c.vel)
    local cols = {}
    for n, i in ipairs(c.dependent_speeds) do cols[n] = k + i end
    c.V_dep = columns(c.V, cols)
  end
end

-- A's rows at a column: the kept coordinates' rates, the kept speeds' accelerations.
local function column_rows(c, col)
  local out = {}
  for _, i in ipairs(c.coords) do out[#out + 1] = col.dqd[i] end
  for _, i in ipairs(c.speeds) do out[#out + 1] = col.acc[i] end
  return out
end

-- Whether coordinate i is absent from the kept accelerations near the
-- point too.  Its column can vanish at the point alone: at a degenerate
-- equilibrium (V = x^4: dx''/dx = -12 x^2) dropping x would hide the
-- double zero eigenvalue and its Jordan block (x = x0 + v0 t).  An
-- ignorable coordinate (cyclic: a wheel's angle, a position on the ground)
-- is absent from the equations everywhere, so its raw column vanishes at a
-- nearby state as well (below 1e-9 of the rows' scale; V = x^4 gives 1e-5
-- there).  One more Jacobian, only for a candidate to drop.
local function absent_nearby(sys, c, i)
  local k = sys.k
  if not c.J_near then
    local y = {}
    for j = 1, k do
      local d = 1e-3 * (1 + math.abs(c.q[j]))
      y[j], y[k + j] = c.q[j] + d * (0.3 + 0.07 * j), c.qd[j] + d * (0.2 + 0.05 * j)
    end
    local ode = mech.ode_new(sys.engine, { method = "rk8pd", rtol = 1e-10, atol = 1e-10, orders = c.orders, linear = c.linear })
    local ok, J = pcall(mech.ode_jacobian, ode, sys.engine, c.t, y)
    c.J_near = ok and J or false
  end
  if not c.J_near then return true end       -- no Jacobian there: the point's verdict stands
  local worst, scale = 0, 0
  for _, m in ipairs(c.speeds) do
    local row = c.J_near[k + m]
    worst = math.max(worst, math.abs(row[i]))
    for j = 1, 2 * k do scale = math.max(scale, math.abs(row[j])) end
  end
  return worst <= 1e-9 * math.max(scale, 1)
end

local function assemble(sys, c, check_left_out)
  local k = sys.k
  local colq, cols = {}, {}
  for i = 1, k do
    if not c.is_dep[i] then
      local dq = zeros(k); dq[i] = 1
      colq[i] = tangent(sys, c, dq, zeros(k))
    end
    if not c.is_dep_speed[i] then
      local dqd = zeros(k); dqd[i] = 1
      cols[i] = tangent(sys, c, zeros(k), dqd)
    end
  end
  -- the scale of the kept rows, below which an entry is rounding
  local function scale_now()
    local s = 0
    for i = 1, k do
      for _, col in ipairs{ colq[i] or false, cols[i] or false } do
        if col then s = math.max(s, max_abs(column_rows(c, col))) end
      end
    end
    return 1e-12 * math.max(s, 1)
  end
  -- coordinates left to nzlua: drop those that do not appear (ignorable),
  -- again until none does (a dropped row can leave another unused)
  c.ignorable = {}
  if not c.coords_given then
    local changed = true
    while changed do
      changed = false
      local tiny = scale_now()
      for n = #c.coords, 1, -1 do
        local i = c.coords[n]
        if max_abs(column_rows(c, colq[i])) <= tiny and absent_nearby(sys, c, i) then
          table.remove(c.coords, n)
          table.insert(c.ignorable, 1, i)
          changed = true
        end
      end
    end
  end
  local kept = set_of(c.coords)
  for _, i in ipairs(c.coords) do
    if not c.moving[i] and not c.held[i] and not c.is_dep_speed[i] then
      fail(sys, "the speed of kept coordinate '%s' is neither kept, held nor dependent: add it to speeds or hold", sys.coords[i])
    end
  end
  if check_left_out then
    local tiny = scale_now()
    local rows_named = {}
    for _, i in ipairs(c.coords) do rows_named[#rows_named + 1] = sys.coords[i] .. "'" end
    for _, i in ipairs(c.speeds) do rows_named[#rows_named + 1] = sys.coords[i] .. "''" end
    local function where(col)
      local v = column_rows(c, col)
      local worst, at = 0, 1
      for n = 1, #v do if math.abs(v[n]) > worst then worst, at = math.abs(v[n]), n end end
      return worst > tiny, rows_named[at], v[at]
    end
    for i = 1, k do
      if c.coords_given and not kept[i] and not c.is_dep[i] then
        local appears, row, d = where(colq[i])
        if appears then
          fail(sys, "coordinate '%s' is left out but appears in the equation of %s (d/d%s = %.3g): keep it in coords%s",
            sys.coords[i], row, sys.coords[i], d, #c.pos > 0 and ", or name it dependent" or "")
        end
      end
    end
    for _, i in ipairs(c.free_speeds) do
      local appears, row = where(cols[i])
      if appears then
        fail(sys, "the speed of '%s' is left out but appears in the equation of %s: keep it in speeds, or hold it",
          sys.coords[i], row)
      end
    end
  end
  c.colq, c.cols = colq, cols
end

-- The linearization from a prepared point.
local function build(sys, c)
  local k = sys.k
  local state, columns_of = {}, {}
  for _, i in ipairs(c.coords) do state[#state + 1], columns_of[#columns_of + 1] = sys.coords[i], c.colq[i] end
  for _, i in ipairs(c.speeds) do state[#state + 1], columns_of[#columns_of + 1] = sys.coords[i] .. "'", c.cols[i] end
  local n = #state
  local A = {}
  for r = 1, n do A[r] = {} end
  for col, tcol in ipairs(columns_of) do
    local v = column_rows(c, tcol)
    for r = 1, n do A[r][col] = v[r] end
  end
  -- An entry below 64 eps of the largest in its row and its column is the
  -- rounding of terms that cancel (a zero of the symmetry: d psi''/d th of
  -- an upright disk), not a number the computation can resolve: it is made
  -- the exact zero it stands for, since where modes meet (a defective
  -- eigenvalue) such a residue moves the eigenvalues by its square or cube
  -- root and blurs where stability changes.
  local rowmax, colmax = {}, {}
  for r = 1, n do rowmax[r] = max_abs(A[r]) end
  for col = 1, n do colmax[col] = 0; for r = 1, n do colmax[col] = math.max(colmax[col], math.abs(A[r][col])) end end
  for r = 1, n do
    for col = 1, n do
      if math.abs(A[r][col]) <= 64 * 2.2e-16 * math.max(rowmax[r], colmax[col]) then A[r][col] = 0 end
    end
  end
  local lin = setmetatable({ system = sys, state = state, A = A, t = c.t, q = c.q, qd = c.qd, qdd = c.qdd,
    coords = c.coords, speeds = c.speeds, hold = c.hold, dependent = c.dependent,
    dependent_speeds = c.dependent_speeds, ignorable = c.ignorable,
    position_newton = c.position_newton, velocity_newton = c.velocity_newton }, Linear)
  -- how far the point is from an equilibrium or a steady motion: the kept
  -- accelerations there (0 for one)
  lin.residual = 0
  for _, i in ipairs(c.speeds) do lin.residual = math.max(lin.residual, math.abs(c.qdd[i])) end
  -- M q'' + C q' + K q = 0 when the kept speeds are the kept coordinates'
  local nc, same = #c.coords, #c.coords == #c.speeds
  for m = 1, nc do same = same and c.coords[m] == c.speeds[m] end
  if same and nc > 0 then
    local Mf = sys:mass(c.t, c.q, c.qd)
    local Mr = {}
    for a = 1, nc do
      Mr[a] = {}
      local va = c.cols[c.speeds[a]].dqd
      for b = 1, nc do
        local vb, s = c.cols[c.speeds[b]].dqd, 0
        for i = 1, k do
          if va[i] ~= 0 then for j = 1, k do s = s + va[i] * Mf[i][j] * vb[j] end end
        end
        Mr[a][b] = s
      end
    end
    local C, K = {}, {}
    for a = 1, nc do
      C[a], K[a] = {}, {}
      for b = 1, nc do
        local sc, sk = 0, 0
        for m = 1, nc do
          sk = sk - Mr[a][m] * A[nc + m][b]
          sc = sc - Mr[a][m] * A[nc + m][nc + b]
        end
        C[a][b], K[a][b] = sc, sk
      end
    end
    lin.M, lin.C, lin.K = Mr, C, K
  end
  return lin
end

M.OPTIONS = options.declare("sys:linearize", { "t", "q", "qd", "coords", "speeds", "hold", "dependent" })
local EQUILIBRIUM_OPTIONS = options.declare("sys:equilibrium", { "t", "q", "qd", "coords", "hold", "dependent", "tol", "maxit" })

function M.linearize(sys, opts)
  opts = opts or {}
  method = "linearize"
  if type(opts) ~= "table" then fail(sys, "options {q = {...}, qd = {...}, coords =, speeds =, hold =} expected") end
  options.check(opts, M.OPTIONS, function(...) fail(sys, ...) end)
  local c = prepare(sys, opts, "linearize")
  differentiate(sys, c)
  assemble(sys, c, true)
  return build(sys, c)
end

-- An equilibrium or a steady motion near a guess: Newton on the kept
-- accelerations q''_i = 0 (i in coords) in the kept coordinates, the
-- dependent coordinates and speeds solved at every iterate, the other
-- coordinates and speeds held at their values, with the exact Jacobian
-- (the linearization's rows).  Returns q and a report {iterations,
-- residual, qd}; a Jacobian that is singular there, or no convergence in
-- maxit steps, is an error that says so with the last iterate.
function M.equilibrium(sys, opts)
  opts = opts or {}
  method = "equilibrium"
  if type(opts) ~= "table" then fail(sys, "options {q = {...} [, qd =, coords =, hold =, tol =, maxit =]} expected") end
  options.check(opts, EQUILIBRIUM_OPTIONS, function(...) fail(sys, ...) end)
  local tol, maxit = opts.tol or 1e-12, opts.maxit or 50
  -- every coordinate the constraints leave free, unless told
  local point = { t = opts.t, q = opts.q, qd = opts.qd, coords = opts.coords, speeds = opts.coords, hold = opts.hold,
    dependent = opts.dependent }
  local res = math.huge
  local q = opts.q
  for it = 0, maxit do
    local c = prepare(sys, point, "equilibrium", true)
    if not point.coords then point.coords = c.coords end
    q = c.q
    local b = {}
    res = 0
    differentiate(sys, c)
    for r, i in ipairs(c.coords) do b[r] = -c.qdd[i]; res = math.max(res, math.abs(c.qdd[i])) end
    if res <= tol then return q, { iterations = it, residual = res, qd = c.qd } end
    if it == maxit then break end
    c.speeds, c.coords_given = c.coords, true   -- every kept coordinate is an unknown: none dropped
    assemble(sys, c, false)
    local Jk = {}
    for r, i in ipairs(c.coords) do
      Jk[r] = {}
      for col, j in ipairs(c.coords) do Jk[r][col] = c.colq[j].acc[i] end
    end
    local sv = mech.singular_values(Jk)
    if sv[#sv] <= 1e-13 * sv[1] then
      fail(sys, "the accelerations do not depend on the kept coordinates at q = {%s} (their Jacobian is singular): "
        .. "a neutral direction; keep fewer coordinates, or start elsewhere", table.concat(q, ", "))
    end
    local dx = mech.lstsq(Jk, b)
    q = { table.unpack(q) }
    for col, j in ipairs(c.coords) do q[j] = q[j] + dx[col] end
    point.q, point.qd = q, c.qd
  end
  fail(sys, "Newton's method did not reach an equilibrium in %d steps (kept accelerations %.3g at q = {%s}): "
    .. "start nearer, or raise maxit", maxit, res, table.concat(q, ", "))
end

-- Eigenvalues {re, im}, sorted by growth rate (re, largest first), then by
-- frequency; a pair's members together.
function Linear:eigenvalues()
  local ev, vec = mech.eigen(self.A)
  local order = {}
  for i = 1, #ev do order[i] = i end
  table.sort(order, function(a, b)
    local ea, eb = ev[a], ev[b]
    if math.abs(ea[1] - eb[1]) > 1e-12 * (1 + math.abs(ea[1])) then return ea[1] > eb[1] end
    return ea[2] > eb[2]
  end)
  local out, vectors = {}, {}
  for n, i in ipairs(order) do out[n], vectors[n] = ev[i], vec[i] end
  self.vectors = vectors
  return out
end

-- Its shape: the eigenvector's kept coordinates, turned so that the largest
-- is real and 1 (the phase of each relative to it in `phase`, radians).
-- Without kept coordinates, the kept speeds.
local function shape(self, v)
  local first, last = 1, #self.coords
  if last == 0 then first, last = 1, #self.speeds end
  local big, at = -1, first
  for i = first, last do
    local m = math.sqrt(v[i][1] ^ 2 + v[i][2] ^ 2)
    if m > big then big, at = m, i end
  end
  local amp, phase = {}, {}
  local a0 = math.atan(v[at][2], v[at][1])
  for i = first, last do
    amp[i] = big > 0 and math.sqrt(v[i][1] ^ 2 + v[i][2] ^ 2) / big or 0
    local p = math.atan(v[i][2], v[i][1]) - a0
    p = (p + math.pi) % (2 * math.pi) - math.pi
    if amp[i] < 1e-12 then p = 0 end
    phase[i] = p
  end
  return amp, phase
end

-- Whether a mode grows: its real part against the threshold of the
-- matrix.  A's entries carry rounding of ~1e-15 |A|; an eigenvalue that is
-- simple moves by as much, but where modes meet (a defective eigenvalue, at
-- the very parameter values where stability changes) it moves by the square
-- or cube root of that.  1e-8 (1 + max |A_ij|) lies above both near such a
-- point and far below any growth rate of physical interest.
local function threshold(A)
  local big = 0
  for _, row in ipairs(A) do for _, v in ipairs(row) do big = math.max(big, math.abs(v)) end end
  return 1e-8 * (1 + big)
end
M.threshold = threshold

local function stability(re, thr)
  return re < -thr and "stable" or re > thr and "unstable" or "neutral"
end
M.stability = stability

-- An eigenvalue as print(lin) and print(sw) show it, by the rule that
-- decides the stability: a real or imaginary part within thr of zero is
-- rounding and is shown as 0 (a mode on the imaginary axis is 0 +- wi, a
-- real one has no imaginary part).  A complex pair is shown once, by its
-- member with im > 0: nil for the other.
function M.eigenvalue_text(re, im, thr, fmt)
  fmt = fmt or "%.6g"
  if math.abs(re) <= thr then re = 0 end
  if math.abs(im) <= thr then return fmt:format(re) end
  if im < 0 then return nil end
  return (fmt .. " +- " .. fmt .. "i"):format(re, im)
end

-- One row per mode (a complex pair once): the eigenvalue, its frequency
-- (rad/s and Hz), damping ratio, whether it grows, and its shape.
function Linear:modes()
  local rows = {}
  local ev, thr = self:eigenvalues(), threshold(self.A)
  for n, e in ipairs(ev) do
    local re, im = e[1], e[2]
    if im >= 0 then
      local w = math.sqrt(re * re + im * im)
      local amp, phase = shape(self, self.vectors[n])
      rows[#rows + 1] = { re = re, im = im, omega = math.abs(im), hz = math.abs(im) / (2 * math.pi),
        damping = w > 0 and -re / w or 0, stable = stability(re, thr), shape = amp, phase = phase }
    end
  end
  return rows
end

function Linear:__tostring()
  local sys = self.system
  local head = ("linearization of '%s' at t = %g: state (%s)"):format(sys.name, self.t, table.concat(self.state, ", "))
  local lines = { head }
  local function say(label, list, suffix)
    if list and #list > 0 then lines[#lines + 1] = ("  %s: %s"):format(label, table.concat(names(sys, list, suffix), ", ")) end
  end
  say("held at their values", self.hold, "'")
  if #self.dependent > 0 then
    local it, res = table.unpack(self.position_newton)
    lines[#lines + 1] = ("  dependent (from the holonomic constraints, Newton: %d iterations, residual %.1e): %s"):format(
      it, res, table.concat(names(sys, self.dependent), ", "))
  end
  say("dependent speeds (from the velocity constraints)", self.dependent_speeds, "'")
  say("ignorable, dropped (they do not appear in the kept equations)", self.ignorable)
  if self.residual > 1e-9 then
    lines[#lines + 1] = ("  not an equilibrium or a steady motion: the kept accelerations are %.3g there"):format(self.residual)
  end
  local shown = #self.coords > 0 and names(sys, self.coords) or names(sys, self.speeds, "'")
  local t = { { "eigenvalue", "frequency (rad/s)", "(Hz)", "damping", "stability",
    "shape (" .. table.concat(shown, ", ") .. ")" } }
  local thr, phased = threshold(self.A), false
  for _, m in ipairs(self:modes()) do
    local sh = {}
    for i, a in pairs(m.shape) do
      if math.abs(m.phase[i]) > 3.1 then sh[#sh + 1] = ("%.4g"):format(-a)
      elseif math.abs(m.phase[i]) < 0.04 then sh[#sh + 1] = ("%.4g"):format(a)
      else
        sh[#sh + 1] = ("%.4g@%.2g"):format(a, m.phase[i])
        phased = true
      end
    end
    local w = math.abs(m.im) <= thr and 0 or m.omega
    t[#t + 1] = { M.eigenvalue_text(m.re, m.im, thr), ("%.6g"):format(w), ("%.6g"):format(w / (2 * math.pi)),
      ("%.3g"):format(m.stable == "neutral" and 0 or m.damping), m.stable, table.concat(sh, ", ") }
  end
  lines[#lines + 1] = require("nz.base.text").table(t, "  ")
  lines[#lines + 1] = "  shape: each coordinate's amplitude, the largest 1; -a: in opposite phase to it"
  if phased then
    lines[#lines + 1] = "  a@p: amplitude a, ahead of the largest by p radians (behind for p < 0; at"
    lines[#lines + 1] = "  +-1.57, a quarter period, the two go round together, as a top's axis does)"
  end
  -- zero eigenvalues with fewer eigenvectors (A's null space) than their
  -- multiplicity: a Jordan block, a degenerate point (V = x^4), where the
  -- linear motion grows like t and decides nothing of the stability
  local zeros, n = 0, #self.A
  for _, e in ipairs(self:eigenvalues()) do
    if math.abs(e[1]) <= thr and math.abs(e[2]) <= thr then zeros = zeros + 1 end
  end
  if zeros > 1 then
    local sv, null = mech.singular_values(self.A), 0
    for _, x in ipairs(sv) do if x <= thr then null = null + 1 end end
    if null < zeros then
      lines[#lines + 1] = ("  the eigenvalue 0 is %d-fold with %d eigenvector%s (a Jordan block): the linear motion grows "
        .. "like t there, and the nonlinear terms decide the stability (a degenerate point)"):format(zeros, null,
        null == 1 and "" or "s")
    end
  end
  return table.concat(lines, "\n")
end

-- lin.modes() (a dot) is named as such (nz/base/where.lua); help finds the methods here.
require("nz.base.where").methods(Linear, "lin", "linearization")
M.Linear = Linear

return M
