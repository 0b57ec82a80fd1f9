-- nz/linearize.lua - sys:linearize{...}: the motion linearized about an
-- equilibrium or a steady motion, x' = A x, with its eigenvalues; and
-- sys:equilibrium{...}, Newton's method for one near a guess (issue 12,
-- first part: systems without constraints).
--
-- A is exact: the rows of q'' are the exact Jacobian of the accelerations
-- (the jets along each state direction, src/mech/mech_jacobian.c, through
-- core.mech.ode_jacobian), not finite differences.  The state keeps the
-- coordinates in `coords` and the speeds in `speeds` (default: the same);
-- a coordinate left out must not appear in the kept equations (it is
-- ignorable: its column of the Jacobian is zero there, else the call says
-- so), and a speed left out is either held at its steady value (`hold`: a
-- motor, a wheel's rate) or must not appear either.  M, C, K of
-- M q'' + C q' + K q = 0 are given when every coordinate is kept with its
-- speed: M the mass matrix at the point, C = -M dq''/dq', K = -M dq''/dq.
local core = require "nz.core"
local mech = core.mech

local M = {}

local Linear = {}
Linear.__index = Linear

local method = "linearize"   -- the public function running, for messages

local function fail(sys, fmt, ...)
  error(("%ssys:%s '%s': " .. fmt):format(require("nz.where").user_where(), method, sys.name, ...), 0)
end

-- Coordinate numbers from names or 1-based indices.
local function indices(sys, list, what)
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

-- What both public functions read first: the point (t, q, qd; qd at rest
-- by default) and the kept coordinates (all by default).
local function start(sys, opts, name)
  method = name
  local k = sys.k
  if sys.nc > 0 then
    fail(sys, "systems with constraints are not handled yet (this one has %d): the elimination of the dependent "
      .. "coordinates and speeds comes next; take the free system, or see examples/bicycle.lua", sys.nc)
  end
  if type(opts.q) ~= "table" or #opts.q ~= k then fail(sys, "q: a table of %d numbers expected", k) end
  local qd = opts.qd
  if not qd then qd = {}; for i = 1, k do qd[i] = 0 end end
  if #qd ~= k then fail(sys, "qd: a table of %d numbers expected", k) end
  local all = {}
  for i = 1, k do all[i] = i end
  local coords, kept = indices(sys, opts.coords or all, "coords")
  return opts.t or 0, opts.q, qd, coords, kept
end

function M.linearize(sys, opts)
  opts = opts or {}
  local k = sys.k
  local t, q, qd, coords, kept = start(sys, opts, "linearize")
  local speeds, moving = indices(sys, opts.speeds or coords, "speeds")
  local hold, held = indices(sys, opts.hold or {}, "hold")
  for _, i in ipairs(hold) do
    if moving[i] then fail(sys, "'%s' is both a kept speed and held", sys.coords[i]) end
  end
  -- the exact Jacobian of (q', q'') in (q, q')
  local ode = mech.ode_new(sys.engine, { method = "rk8pd", rtol = 1e-10, atol = 1e-10 })
  local y = {}
  for i = 1, k do y[i], y[k + i] = q[i], qd[i] end
  local J = mech.ode_jacobian(ode, sys.engine, t, y)
  local qdd = mech.ode_accel(ode, sys.engine, t, y)
  -- the state x = (kept coordinates, kept speeds) and its columns in J
  local state, cols = {}, {}
  for _, i in ipairs(coords) do state[#state + 1], cols[#cols + 1] = sys.coords[i], i end
  for _, i in ipairs(speeds) do state[#state + 1], cols[#cols + 1] = sys.coords[i] .. "'", k + i end
  -- what is left out must not move the kept equations
  local scale = 0
  for _, i in ipairs(speeds) do for j = 1, 2 * k do scale = math.max(scale, math.abs(J[k + i][j])) end end
  local tiny = 1e-12 * math.max(scale, 1)
  for _, i in ipairs(speeds) do
    for j = 1, k do
      if not kept[j] and math.abs(J[k + i][j]) > tiny then
        fail(sys, "coordinate '%s' is left out but appears in the equation of %s'' (d/d%s = %.3g): keep it in coords",
          sys.coords[j], sys.coords[i], sys.coords[j], J[k + i][j])
      end
      if not moving[j] and not held[j] and math.abs(J[k + i][k + j]) > tiny then
        fail(sys, "the speed of '%s' is left out but appears in the equation of %s'': keep it in speeds, or hold it",
          sys.coords[j], sys.coords[i])
      end
    end
  end
  local A = {}
  for r, i in ipairs(coords) do       -- q_i' = the speed, kept or held
    local row = {}
    for c = 1, #cols do row[c] = 0 end
    if moving[i] then
      for c, col in ipairs(cols) do if col == k + i then row[c] = 1 end end
    elseif not held[i] then
      fail(sys, "the speed of kept coordinate '%s' is neither kept nor held: add it to speeds or hold", sys.coords[i])
    end
    A[r] = row
  end
  for _, i in ipairs(speeds) do
    local row = {}
    for c, col in ipairs(cols) do row[c] = J[k + i][col] end
    A[#A + 1] = row
  end
  local lin = setmetatable({ system = sys, state = state, A = A, t = t, q = q, qd = qd, coords = coords, speeds = speeds,
    hold = hold, qdd = qdd }, Linear)
  -- how far the point is from an equilibrium or a steady motion: the kept
  -- accelerations there (0 for one)
  lin.residual = 0
  for _, i in ipairs(speeds) do lin.residual = math.max(lin.residual, math.abs(qdd[i])) end
  if #coords == k and #speeds == k then
    local same = true
    for n = 1, k do same = same and coords[n] == speeds[n] end
    if same then
      local Mf = sys:mass(t, q, qd)
      local Mk, C, K = {}, {}, {}
      for a = 1, k do
        Mk[a], C[a], K[a] = {}, {}, {}
        for b = 1, k do
          Mk[a][b] = Mf[coords[a]][coords[b]]
          local sc, sk = 0, 0
          for c = 1, k do
            sc = sc - Mf[coords[a]][coords[c]] * J[k + coords[c]][k + coords[b]]
            sk = sk - Mf[coords[a]][coords[c]] * J[k + coords[c]][coords[b]]
          end
          C[a][b], K[a][b] = sc, sk
        end
      end
      lin.M, lin.C, lin.K = Mk, C, K
    end
  end
  return lin
end

-- An equilibrium or a steady motion near a guess: Newton on the kept
-- accelerations q''_i(q, qd) = 0 (i in coords) in the kept coordinates,
-- the others and every speed held at their values, with the exact
-- Jacobian (the jets').  Returns q and a report {iterations, residual}; a
-- Jacobian that is singular there, or no convergence in maxit steps, is an
-- error that says so with the last iterate.
function M.equilibrium(sys, opts)
  opts = opts or {}
  local k = sys.k
  local t, guess, qd, coords = start(sys, opts, "equilibrium")
  local q = { table.unpack(guess) }
  local tol, maxit = opts.tol or 1e-12, opts.maxit or 50
  local ode = mech.ode_new(sys.engine, { method = "rk8pd", rtol = 1e-10, atol = 1e-10 })
  local res = math.huge
  for it = 0, maxit do
    local y = {}
    for i = 1, k do y[i], y[k + i] = q[i], qd[i] end
    local qdd = mech.ode_accel(ode, sys.engine, t, y)
    res = 0
    local b = {}
    for r, i in ipairs(coords) do b[r] = -qdd[i]; res = math.max(res, math.abs(qdd[i])) end
    if res <= tol then return q, { iterations = it, residual = res } end
    if it == maxit then break end
    local J = mech.ode_jacobian(ode, sys.engine, t, y)
    local Jk = {}
    for r, i in ipairs(coords) do
      Jk[r] = {}
      for c, j in ipairs(coords) do Jk[r][c] = J[k + i][j] end
    end
    local sv = mech.singular_values(Jk)
    if sv[#sv] <= 1e-13 * sv[1] then
      fail(sys, "the accelerations do not depend on the kept coordinates at q = {%s} (their Jacobian is singular): "
        .. "a neutral direction; keep fewer coordinates, or start elsewhere", table.concat(q, ", "))
    end
    local dx = mech.lstsq(Jk, b)
    for c, j in ipairs(coords) do q[j] = q[j] + dx[c] end
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

-- One row per mode: the eigenvalue, its frequency (rad/s and Hz), damping
-- ratio, and whether it grows.
-- Its shape: the eigenvector's kept coordinates, turned so that the largest
-- is real and 1 (the phase of each relative to it in `phase`, radians).
local function shape(self, v)
  local ncoord = #self.coords
  local big, at = -1, 1
  for i = 1, ncoord do
    local m = math.sqrt(v[i][1] ^ 2 + v[i][2] ^ 2)
    if m > big then big, at = m, i end
  end
  local amp, phase = {}, {}
  local a0 = math.atan(v[at][2], v[at][1])
  for i = 1, ncoord do
    amp[i] = big > 0 and math.sqrt(v[i][1] ^ 2 + v[i][2] ^ 2) / big or 0
    local p = math.atan(v[i][2], v[i][1]) - a0
    p = (p + math.pi) % (2 * math.pi) - math.pi
    if amp[i] < 1e-12 then p = 0 end
    phase[i] = p
  end
  return amp, phase
end

function Linear:modes()
  local rows = {}
  local ev = self:eigenvalues()
  for n, e in ipairs(ev) do
    local re, im = e[1], e[2]
    if im >= 0 then
      local w = math.sqrt(re * re + im * im)
      local amp, phase = shape(self, self.vectors[n])
      rows[#rows + 1] = { re = re, im = im, omega = math.abs(im), hz = math.abs(im) / (2 * math.pi),
        damping = w > 0 and -re / w or 0, stable = re < -1e-12 * (1 + w) and "stable" or re > 1e-12 * (1 + w)
          and "unstable" or "neutral", shape = amp, phase = phase }
    end
  end
  return rows
end

function Linear:__tostring()
  local sys = self.system
  local lines = { ("linearization of '%s' at t = %g: state (%s)%s"):format(sys.name, self.t, table.concat(self.state, ", "),
    #self.hold > 0 and ("; held: " .. table.concat((function() local n = {}; for _, i in ipairs(self.hold) do n[#n + 1] = sys.coords[i] .. "'" end; return n end)(), ", ")) or "") }
  if self.residual > 1e-9 then
    lines[#lines + 1] = ("  not an equilibrium or a steady motion: the kept accelerations are %.3g there"):format(self.residual)
  end
  local names = {}
  for n, i in ipairs(self.coords) do names[n] = self.system.coords[i] end
  local t = { { "eigenvalue", "frequency (rad/s)", "(Hz)", "damping", "", "shape (" .. table.concat(names, ", ") .. ")" } }
  for _, m in ipairs(self:modes()) do
    local sh = {}
    for i, a in ipairs(m.shape) do
      sh[i] = math.abs(m.phase[i]) > 3.1 and ("%.4g"):format(-a) or math.abs(m.phase[i]) < 0.04 and ("%.4g"):format(a)
        or ("%.4g@%.2g"):format(a, m.phase[i])
    end
    t[#t + 1] = { m.im > 0 and ("%.6g +- %.6gi"):format(m.re, m.im) or ("%.6g"):format(m.re), ("%.6g"):format(m.omega),
      ("%.6g"):format(m.hz), ("%.3g"):format(m.damping), m.stable, table.concat(sh, ", ") }
  end
  lines[#lines + 1] = require("nz.system").table_text(t, "  ")
  return table.concat(lines, "\n")
end

return M
