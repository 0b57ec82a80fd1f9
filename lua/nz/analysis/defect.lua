-- nz/analysis/defect.lua - the defect of a motion given by points: how far the curve
-- through them is from satisfying the equations of motion (W. H. Enright,
-- "A new error-control for initial value solvers", Appl. Math. Comput. 31
-- (1989) 288-301; Hairer, Norsett, Wanner, Solving ODEs I, II.6 and II.8).
--
-- The motion is a first-order system in y = (q, v), v = q', as every
-- stepper integrates it.  The points t_j, q_j, v_j are joined by curves of
-- their own: Q(t) through the q_j and V(t) through the v_j, on each
-- interval the polynomial through the 8 nearest points (degree 7).  No
-- value of the right-hand side enters them (a trajectory's stored q'' came
-- from the equations at the same points, so a check that used it could
-- not fail).  Enright's defect Y' - F(t, Y) of the curve Y = (Q, V) has two
-- parts, evaluated at the 2 Gauss-Legendre points inside each interval
-- (so that the RMS is a quadrature of the defect over time):
--
--   dynamic:    the residual of the equations of order n (theory (3.1))
--               with q = Q, q' = V, q'' = V', q''' = V'', ... :
--               (1/n)(dT^(n)/dq^(n) - (n+1) dT/dq) - Q [- A^T lambda],
--               which for every n is E(T) - Q there (theory (2.1): the
--               order changes the computation, not the number);
--   kinematic:  V - Q', the velocities against the positions' derivative.
--
-- With positions alone (a measurement) the curve is Q with q' = Q',
-- q'' = Q'', ... and only the dynamic part exists.  With constraints, the
-- multipliers at each point are the least-squares choice: the dynamic
-- defect is the part of the equations no constraint force can absorb
-- (Tsenov's projection (7.1), in the Euclidean metric of the
-- coordinates), and each constraint's value Phi_r(Q, V, V', ...) is
-- reported beside it.
--
-- How it scales.  Points y + e on a smooth curve, y a motion and e the
-- integration's global error, give a defect e' - J e: the error the
-- integration makes per unit time (the principal error function's source,
-- Hairer-Norsett-Wanner II.8), about C h^p for a method of order p with
-- steps h (p = 4: 16 times smaller for half the step); for an adaptive
-- pair that keeps each step's estimated error near rtol, between rtol^(p-1)/p
-- and rtol (points read off a stepper's interpolant carry its q'' error:
-- rkf45 measured rtol^0.7..0.8, README).  Not the error accumulated: that
-- is the defect carried by the motion's own sensitivity (the variational
-- equation).  The curves add their own error, ~dt^7 in V' and Q' and
-- ~dt^6 in Q'' for points dt apart, and rounding, ~eps |v| / dt and ~eps
-- |q| / dt^2: the floor, estimated here (the next Newton term through one
-- more point; the data's rounding through the curve's weights) and
-- reported, so that a defect at the floor reads "the output grid limits
-- what is seen", not "the motion is exact".
local core = require "nz.core"
local mech = core.mech

local M = {}

M.NODES = 8               -- points of each interpolant (degree 7)
M.EPS = 2 ^ -52
-- Inside each interval: the 2 Gauss-Legendre points (weights 1/2 each).
M.SAMPLES = { 0.5 - math.sqrt(3) / 6, 0.5 + math.sqrt(3) / 6 }
-- A point closer than this part of the typical spacing to the one before
-- is left out (an event's point just after an output point: two nearly
-- equal nodes would turn the data's rounding into a large derivative).
M.MIN_GAP = 1e-3

-- ------------------------------------------------------------------ --
-- Interpolation in Newton form                                         --

-- The stencil of interval [t_a, t_a+1] inside the points lo..hi: the
-- `count` points nearest to it, in the order a, a+1, a-1, a+2, a-2, ...
-- (nearest first keeps the Newton form well conditioned; at an end of the
-- run the stencil reaches further to the other side), then the next point
-- in that order, if there is one, for the error estimate (nil otherwise).
local function stencil(a, lo, hi, count)
  local nodes, left, right = { a, a + 1 }, a - 1, a + 2
  while true do
    local j
    if #nodes % 2 == 0 then       -- left's turn, else right's
      if left >= lo then j, left = left, left - 1 elseif right <= hi then j, right = right, right + 1 end
    else
      if right <= hi then j, right = right, right + 1 elseif left >= lo then j, left = left, left - 1 end
    end
    if not j or #nodes == count then return nodes, j end
    nodes[#nodes + 1] = j
  end
end
M.stencil = stencil

-- The polynomial through values[j] (vectors) at t[j], j in nodes, in
-- Newton form: coef[c][i] = f[z_1..z_i] for coordinate c, by divided
-- differences in place; with the extra point, coef[c][m+1] is the next
-- divided difference, whose term estimates the polynomial's error.
local function newton(t, values, nodes, extra)
  local z, data = {}, {}
  for i, j in ipairs(nodes) do z[i], data[i] = t[j], values[j] end
  local m = #z
  if extra then z[m + 1], data[m + 1] = t[extra], values[extra] end
  local k, coef = #data[1], {}
  for c = 1, k do
    local f = {}
    for i = 1, #z do f[i] = data[i][c] end
    for j = 1, #z - 1 do
      for i = #z, j + 1, -1 do f[i] = (f[i] - f[i - 1]) / (z[i] - z[i - j]) end
    end
    coef[c] = f
  end
  return { z = z, data = data, coef = coef, m = m, k = k, extra = extra ~= nil }
end

local factorial = { [0] = 1 }
for l = 1, 40 do factorial[l] = factorial[l - 1] * l end

-- The Newton basis of the nodes z (m of them, and the extra point when
-- there is one) at s, W[i][l+1] = coefficient of (x - s)^l in
-- (x - z_1)...(x - z_i-1), l = 0..top; and the weights g[i] of the data
-- in the derivative of level lf at s (the divided differences run
-- backwards), for the rounding bound.  One per sample: the positions and
-- the velocities share their nodes.
local function basis(z, m, s, top, lf)
  local w = { 1 }
  for l = 2, top + 1 do w[l] = 0 end
  local W = { w }
  for i = 2, #z do
    local nw, d = {}, s - z[i - 1]
    nw[1] = d * w[1]
    for l = 2, top + 1 do nw[l] = d * w[l] + w[l - 1] end
    W[i], w = nw, nw
  end
  local g = {}
  for i = 1, m do g[i] = factorial[lf] * W[i][lf + 1] end
  for j = m - 1, 1, -1 do
    for i = j + 1, m do
      local x = g[i] / (z[i] - z[i - j])
      g[i], g[i - 1] = x, g[i - 1] - x
    end
  end
  return { W = W, g = g, lf = lf }
end

-- The derivatives of the polynomial p at the point of basis b,
-- levels[l+1] = p^(l)(s) for l = 0..L (exactly 0 beyond its degree), and,
-- per coordinate, two bounds on the error of level b.lf: the next Newton
-- term (0 without the extra point) and the data's rounding carried to it
-- (eps times the data's sizes weighted by b.g).
local function derivatives(p, b, L)
  local W, g, lf, m, levels = b.W, b.g, b.lf, p.m, {}
  for l = 0, L do
    local v = {}
    for c = 1, p.k do
      local sum, cc = 0, p.coef[c]
      for i = l + 1, m do sum = sum + W[i][l + 1] * cc[i] end
      v[c] = sum * factorial[l]
    end
    levels[l + 1] = v
  end
  local trunc, round = {}, {}
  for c = 1, p.k do
    trunc[c] = p.extra and math.abs(factorial[lf] * W[m + 1][lf + 1] * p.coef[c][m + 1]) or 0
    local r = 0
    for i = 1, m do r = r + math.abs(g[i] * p.data[i][c]) end
    round[c] = M.EPS * r
  end
  return levels, trunc, round
end
M.newton, M.basis, M.derivatives = newton, basis, derivatives

-- ------------------------------------------------------------------ --
-- The defect along the points                                          --

-- Runs of points with increasing t (a repeated or decreasing t starts a
-- new run: the curve is not joined across it), without the points closer
-- than M.MIN_GAP of the typical spacing to the one kept before.  Returns
-- the runs as lists of indices and the number of points left out.
local function runs(t)
  local gaps = {}
  for j = 2, #t do if t[j] > t[j - 1] then gaps[#gaps + 1] = t[j] - t[j - 1] end end
  table.sort(gaps)
  local typical = gaps[(#gaps + 1) // 2] or 0
  local out, cur, dropped = {}, { 1 }, 0
  for j = 2, #t do
    if t[j] <= t[j - 1] then
      out[#out + 1] = cur
      cur = { j }
    elseif t[j] - t[cur[#cur]] < M.MIN_GAP * typical then
      dropped = dropped + 1
    else
      cur[#cur + 1] = j
    end
  end
  out[#out + 1] = cur
  return out, dropped
end

local function slots_of(sys)
  local n = 0
  for _, v in ipairs(sys.constraint_levels or {}) do n = math.max(n, v) end
  return n
end

-- Accumulates max (with its time), time-weighted mean square and the
-- largest floor of `size` quantities.
local function tally(size)
  local s = { max = {}, at = {}, sq = {}, floor = {} }
  for i = 1, size do s.max[i], s.sq[i], s.floor[i] = 0, 0, 0 end
  function s.add(i, v, w, t, floor)
    v = math.abs(v)
    s.sq[i] = s.sq[i] + w * v * v
    if v > s.max[i] or not s.at[i] then s.max[i], s.at[i] = v, t end
    if floor and floor > s.floor[i] then s.floor[i] = floor end
  end
  return s
end

-- The defect of the points pts = {t =, q =, qd = (optional)} (checked by
-- the caller) for the equations of order n of sys.  Returns a list, one
-- entry per equation {coordinate, max, t_max, rms, floor}, with fields
-- kinematic (per coordinate, the same fields; nil without qd),
-- constraints (per constraint {constraint, max, t_max, rms}), t (the
-- sample times), dynamic and phi (the values there, vectors), n, points,
-- intervals, dropped, skipped.
function M.measure(sys, pts, n)
  local constraints = require "nz.model.constraints"
  local k, nc = sys.k, sys.nc
  local with_qd = pts.qd ~= nil
  -- every level of the curves the jets or the constraints take (those
  -- beyond the degree are 0, as the C side takes a level not given)
  local L = math.min(M.NODES - 1, math.max(2, n + 1, slots_of(sys) - 1))
  local classes = nc > 0 and constraints.classify(sys) or {}
  local dyn, kin, con = tally(k), tally(k), tally(nc)
  local result = { constraints = {}, t = {}, dynamic = {}, phi = {}, n = n, points = #pts.t, with_qd = with_qd }
  local total, intervals, skipped = 0, 0, 0
  local list, dropped = runs(pts.t)
  for _, run in ipairs(list) do
    if #run < M.NODES then
      skipped = skipped + #run - 1
    else
      local sub = { t = {}, q = {}, qd = {} }
      for j, idx in ipairs(run) do sub.t[j], sub.q[j], sub.qd[j] = pts.t[idx], pts.q[idx], with_qd and pts.qd[idx] end
      for a = 1, #run - 1 do
        local nodes, extra = stencil(a, 1, #run, M.NODES)
        local P = newton(sub.t, sub.q, nodes, extra)
        local V = with_qd and newton(sub.t, sub.qd, nodes, extra)
        local h = sub.t[a + 1] - sub.t[a]
        intervals = intervals + 1
        for _, x in ipairs(M.SAMPLES) do
          local s = sub.t[a] + x * h
          local lev, trunc, round, Ql, Qt, Qr
          if with_qd then
            local b = basis(P.z, P.m, s, math.max(L - 1, 1), 1)
            Ql, Qt, Qr = derivatives(P, b, 1)
            local Vl
            Vl, trunc, round = derivatives(V, b, L - 1)
            lev = { Ql[1], table.unpack(Vl) }
          else
            lev, trunc, round = derivatives(P, basis(P.z, P.m, s, L, 2), L)
          end
          local higher = L >= 3 and { table.unpack(lev, 4, L + 1) } or nil
          local r = mech.residual(sys.engine, "generalized", n, s, lev[1], lev[2], lev[3], higher)
          local phi = {}
          if nc > 0 then
            -- lambda by least squares: r - A^T lambda orthogonal to A's rows
            local At = {}
            for i = 1, k do At[i] = {} end
            for c, cl in ipairs(classes) do
              local v, partials = mech.constraint_partials(sys.engine, c, s, lev[1], lev[2], lev[3], lev[4],
                constraints.higher_of(lev))
              phi[c] = v
              for i = 1, k do At[i][c] = partials[cl.order + 1][i] end
            end
            local lambda = mech.lstsq(At, r)
            for i = 1, k do
              for c = 1, nc do r[i] = r[i] - At[i][c] * lambda[c] end
            end
          end
          -- the floor in the equations' units: |M| times the error of q''
          local Mm = mech.mass_bias(sys.engine, s, lev[1], lev[2])
          local w = h / 2        -- Gauss-Legendre weight of each point
          total = total + w
          for i = 1, k do
            local f = 0
            for j = 1, k do f = f + math.abs(Mm[i][j]) * (trunc[j] + round[j]) end
            dyn.add(i, r[i], w, s, f)
            if with_qd then
              kin.add(i, lev[2][i] - Ql[2][i], w, s, Qt[i] + Qr[i] + M.EPS * math.abs(lev[2][i]))
            end
          end
          for c = 1, nc do con.add(c, phi[c], w, s) end
          local at = #result.t + 1
          result.t[at], result.dynamic[at], result.phi[at] = s, r, phi
        end
      end
    end
  end
  result.intervals, result.dropped, result.skipped = intervals, dropped, skipped
  local function entry(tl, i)
    return { max = tl.max[i], t_max = tl.at[i], rms = total > 0 and math.sqrt(tl.sq[i] / total) or 0, floor = tl.floor[i] }
  end
  for i = 1, k do
    result[i] = entry(dyn, i)
    result[i].coordinate = sys.coords[i]
  end
  if with_qd then
    result.kinematic = {}
    for i = 1, k do
      result.kinematic[i] = entry(kin, i)
      result.kinematic[i].coordinate = sys.coords[i]
    end
  end
  for c = 1, nc do
    result.constraints[c] = entry(con, c)
    result.constraints[c].constraint, result.constraints[c].floor = c, nil
  end
  return result
end

-- ------------------------------------------------------------------ --
-- The printout                                                         --

local function e3(x) return ("%.3e"):format(x) end
local function when(x) return x and ("%.6g"):format(x) or "-" end

-- Words filled into lines of at most 80 columns.
local function fill(text)
  local lines, line = {}, ""
  for word in text:gmatch("%S+") do
    if #line > 0 and #line + 1 + #word > 80 then lines[#lines + 1], line = line, word
    else line = #line > 0 and (line .. " " .. word) or word end
  end
  lines[#lines + 1] = line
  return table.concat(lines, "\n")
end

-- The text of a result: what was measured, the tables, and how to read
-- them.  source names the points ("the 201 points of its run (rkf45,
-- rtol 0.001)"), last is the closing sentence (where the other check is).
function M.text(sys, result, source, last)
  local table_text = require("nz.base.text").table
  local n = result.n
  local out = { fill(("Defect of the motion of '%s' along %s: the equations of order %d, %s, on the curve "
    .. "through the points, at 2 points inside each of its %d intervals (in the units of the equations):"):format(
    sys.name, source, n, require("nz.model.constraints").principle(n), result.intervals)) }
  local rows = { { "equation", "max |defect|", "at t", "RMS", "floor" } }
  for _, r in ipairs(result) do rows[#rows + 1] = { r.coordinate, e3(r.max), when(r.t_max), e3(r.rms), e3(r.floor) } end
  out[#out + 1] = table_text(rows)
  if result.kinematic then
    rows = { { "velocity", "max |q' - dq/dt|", "at t", "RMS", "floor" } }
    for _, r in ipairs(result.kinematic) do
      rows[#rows + 1] = { r.coordinate .. "'", e3(r.max), when(r.t_max), e3(r.rms), e3(r.floor) }
    end
    out[#out + 1] = table_text(rows)
  end
  if #result.constraints > 0 then
    rows = { { "constraint", "max |Phi|", "at t", "RMS" } }
    for _, r in ipairs(result.constraints) do rows[#rows + 1] = { tostring(r.constraint), e3(r.max), when(r.t_max), e3(r.rms) } end
    out[#out + 1] = table_text(rows)
  end
  local words = {
    result.with_qd and "What it is: the positions Q(t) and the velocities V(t), each through the points (degree 7 "
      .. "through 8 of them: no right-hand side enters), give q = Q, q' = V, q'' = V', ... to the equations, and V "
      .. "is compared with dQ/dt."
      or "What it is: the positions Q(t) through the points (degree 7 through 8 of them: no right-hand side "
      .. "enters) give q = Q, q' = Q', q'' = Q'', ... to the equations.",
    #result.constraints > 0 and "The multipliers at each point are the least-squares ones: the defect is the part "
      .. "of the equations no constraint force can take up; Phi is each constraint's value on the curve." or nil,
    "It is 0 only on an exact motion. It measures the error made per unit time (about C h^p for steps h of a "
      .. "method of order p; about rtol for an adaptive one), not the error accumulated since the start.",
    ("floor: what the curve through the points adds (~dt^%s, and rounding ~eps/dt%s): a defect near it is set by "
      .. "the spacing dt of the points, not by the motion."):format(result.with_qd and "7" or "6",
      result.with_qd and "" or "^2"),
    result.skipped > 0 and ("Not measured: %d intervals in runs of fewer than %d points (a run ends where t "
      .. "does not increase)."):format(result.skipped, M.NODES) or nil,
    result.dropped > 0 and ("Left out: %d points closer than %g of the spacing to the one before."):format(
      result.dropped, M.MIN_GAP) or nil,
    last,
  }
  for i = 1, 7 do if words[i] then out[#out + 1] = fill(words[i]) end end
  return table.concat(out, "\n")
end

-- ------------------------------------------------------------------ --
-- Points that did not come from nzlua: sys:residuals_of               --

local function fail(sys, fmt, ...) require("nz.base.where").method_error("residuals_of", sys, fmt, ...) end

local shown = require("nz.base.args").shown

-- The columns of a CSV file with a header line (as tr:csv writes it):
-- t, each coordinate, and each coordinate's velocity name' when every one
-- of them is there (other columns are ignored).
local function read_csv(sys, file)
  local f, why = io.open(file, "r")
  if not f then fail(sys, "csv: cannot read '%s': %s", file, tostring(why)) end
  local header = f:read("l")
  if not header then f:close(); fail(sys, "csv '%s' is empty: a header line t,%s,... expected", file, sys.coords[1]) end
  local index, names = {}, {}
  for name in (header:gsub("\r$", "") .. ","):gmatch("([^,]*),") do
    names[#names + 1] = name
    index[name] = index[name] or #names
  end
  local function column(name)
    if not index[name] then
      f:close()
      fail(sys, "csv '%s' has no column '%s' (its columns: %s): a header naming t and every coordinate (%s) "
        .. "expected, as tr:csv writes it", file, name, table.concat(names, ", "), table.concat(sys.coords, ", "))
    end
    return index[name]
  end
  local ct, cq, cv = column("t"), {}, {}
  for i, c in ipairs(sys.coords) do cq[i] = column(c) end
  for i, c in ipairs(sys.coords) do cv[i] = index[c .. "'"] end
  if #cv < sys.k then cv = nil end
  local pts, line_no = { t = {}, q = {}, qd = cv and {} or nil }, 1
  for line in f:lines() do
    line_no = line_no + 1
    line = line:gsub("\r$", "")
    if line:find("%S") then
      local cells = {}
      for cell in (line .. ","):gmatch("([^,]*),") do cells[#cells + 1] = cell end
      local function number(col)
        local v = tonumber(cells[col])
        if not v or v - v ~= 0 then
          f:close()
          fail(sys, "csv '%s' line %d, column '%s': a finite number expected, got %s", file, line_no, names[col],
            cells[col] and ("%q"):format(cells[col]) or "nothing")
        end
        return v
      end
      local j = #pts.t + 1
      pts.t[j], pts.q[j] = number(ct), {}
      for i = 1, sys.k do pts.q[j][i] = number(cq[i]) end
      if cv then
        pts.qd[j] = {}
        for i = 1, sys.k do pts.qd[j][i] = number(cv[i]) end
      end
    end
  end
  f:close()
  return pts
end

-- One entry of q or qd: a list of k finite numbers (a plain number when
-- there is one coordinate).
local function point(sys, key, j, v)
  if type(v) == "number" and sys.k == 1 then v = { v } end
  if type(v) ~= "table" or #v ~= sys.k then
    fail(sys, "%s[%d]: a list of %d number%s expected (one per coordinate: %s), got %s", key, j, sys.k,
      sys.k == 1 and "" or "s", table.concat(sys.coords, ", "), type(v) == "table" and ("a list of %d"):format(#v) or shown(v))
  end
  for i = 1, sys.k do
    if type(v[i]) ~= "number" or v[i] - v[i] ~= 0 then
      fail(sys, "%s[%d][%d]: a finite number expected, got %s", key, j, i, shown(v[i]))
    end
  end
  return v
end

local OF_OPTIONS = require("nz.base.options").declare("sys:residuals_of", { "t", "q", "qd", "csv", "n", "quiet" })

-- sys:residuals_of{t = {...}, q = {{...}, ...} [, qd = ...] [, n =]
-- [, quiet =]} or {csv = "file"}: the defect of points from anywhere.
function M.of(sys, opts)
  if type(opts) ~= "table" then
    fail(sys, "a table {t = {...}, q = {{...}, ...} [, qd = ...]} or {csv = \"file\"} expected, got %s", shown(opts))
  end
  require("nz.base.options").check(opts, OF_OPTIONS, function(fmt, ...) fail(sys, fmt, ...) end)
  local args = require("nz.base.args")
  args.order("residuals_of", opts.n)
  if opts.quiet ~= nil and type(opts.quiet) ~= "boolean" then fail(sys, "quiet: true or false expected, got %s", shown(opts.quiet)) end
  local pts, source
  if opts.csv ~= nil then
    if type(opts.csv) ~= "string" then fail(sys, "csv: a file name expected, got %s", shown(opts.csv)) end
    if opts.t or opts.q or opts.qd then fail(sys, "give either csv or t, q (and qd), not both") end
    pts = read_csv(sys, opts.csv)
    source = ("the %d points of '%s'"):format(#pts.t, opts.csv)
  else
    if type(opts.t) ~= "table" then fail(sys, "t: a list of times expected, got %s", shown(opts.t)) end
    if type(opts.q) ~= "table" then
      fail(sys, "q: a list of positions expected, one list {%s} per time, got %s", table.concat(sys.coords, ", "), shown(opts.q))
    end
    pts = { t = opts.t, q = {}, qd = opts.qd ~= nil and {} or nil }
    for j, tj in ipairs(opts.t) do
      if type(tj) ~= "number" or tj - tj ~= 0 then fail(sys, "t[%d]: a finite number expected, got %s", j, shown(tj)) end
    end
    for _, key in ipairs{ "q", "qd" } do
      local list = opts[key]
      if list ~= nil then
        if type(list) ~= "table" or #list ~= #opts.t then
          fail(sys, "%s: one entry per time expected (%d), got %s", key, #opts.t,
            type(list) == "table" and ("%d"):format(#list) or shown(list))
        end
        for j = 1, #list do pts[key][j] = point(sys, key, j, list[j]) end
      end
    end
    source = ("%d points given"):format(#pts.t)
  end
  for j = 2, #pts.t do
    if not (pts.t[j] > pts.t[j - 1]) then
      fail(sys, "t[%d] = %s does not come after t[%d] = %s: the times must increase", j, shown(pts.t[j]), j - 1,
        shown(pts.t[j - 1]))
    end
  end
  if #pts.t < M.NODES then
    fail(sys, "%d points: the curve through them is of degree %d and needs at least %d", #pts.t, M.NODES - 1, M.NODES)
  end
  local n = opts.n or sys:rule()
  local result = M.measure(sys, pts, n)
  local text = M.text(sys, result, source, "To check an integrator of order p: with half its step h the "
    .. "defect falls by 2^p.")
  return M.show(result, text, opts.quiet)
end

-- The result printed (unless quiet) and returned; it prints as the text.
function M.show(result, text, quiet)
  setmetatable(result, { __tostring = function() return text end })
  if quiet then return result end
  require("nz.base.frontend").print(text)      -- (a notebook shows its tables as HTML too)
  return require("nz.base.frontend").shown(result)      -- typed at the prompt: the table once
end

-- ------------------------------------------------------------------ --
-- The trajectory's methods of this module (nz/motion/trajectory.lua is below).  --

local Trajectory = require("nz.motion.trajectory").Trajectory

-- The order n (argument #1) and the options of tr:residuals and
-- tr:consistency, named as the user called them; a run with contacts is
-- refused (nz/motion/contact_run.lua).
local ORDER_OPTIONS = { quiet = function(v) return type(v) == "boolean", "true or false" end }
require("nz.base.options").declare("tr:residuals", ORDER_OPTIONS)
require("nz.base.options").declare("tr:consistency", ORDER_OPTIONS)
local function check_order_options(self, sys, fname, n, opts)
  if self.contacts then require("nz.motion.contact_run").refuse_defect(self, fname) end
  local args = require("nz.base.args")
  args.order(fname, n)
  args.options(fname, 2, opts, ORDER_OPTIONS)
  return n or sys:rule()
end

-- The defect of the motion (nz/analysis/defect.lua): the equations of order n on
-- the curve through the points' q and q', at points inside the intervals.
function Trajectory:residuals(n, opts)
  local sys, defect = self.system, M
  n = check_order_options(self, sys, "residuals", n, opts)
  local result = defect.measure(sys, { t = self.t, q = self.q, qd = self.qd }, n)
  if result.intervals == 0 then
    error(("%str:residuals: the %d points of this run are too few for the curve through them (%d in a run "
      .. "at least): simulate with a smaller dt"):format(require("nz.base.where").user_where(), #self.t, defect.NODES), 0)
  end
  local run = self.step and ("fixed step %g"):format(self.step) or ("rtol %g"):format(self.rtol)
  local text = defect.text(sys, result, ("the %d points of its run (%s, %s)"):format(#self.t, self.method, run),
    (self.step and "It falls as the step shrinks (as h^p)." or "It falls as rtol tightens.")
    .. " tr:consistency(n) checks instead that the forms agree with the run's own q''.")
  return defect.show(result, text, opts and opts.quiet)
end

-- The forms of order n at the trajectory's own q'' and multipliers, which
-- the solver computed from the equations at the same points: rounding by
-- construction, whatever the integration did.  It checks the engine (the
-- equations of order n agree with the form the accelerations were solved
-- from), not the motion: tr:residuals does that.  max and RMS per equation.
function Trajectory:consistency(n, opts)
  local sys = self.system
  n = check_order_options(self, sys, "consistency", n, opts)
  local k, worst, sq = sys.k, {}, {}
  for j = 1, k do worst[j], sq[j] = 0, 0 end
  for i = 1, #self.t do
    local lam = sys.nc > 0 and self.lambda[i] or nil
    local r = sys:residual(n, self.t[i], self.q[i], self.qd[i], self.qdd[i], lam)
    for j = 1, k do
      worst[j] = math.max(worst[j], math.abs(r[j]))
      sq[j] = sq[j] + r[j] * r[j]
    end
  end
  local result = {}
  local rows = { { "equation", "max |r|", "RMS" } }
  for j = 1, k do
    result[j] = { coordinate = self.coords[j], max = worst[j], rms = math.sqrt(sq[j] / math.max(#self.t, 1)) }
    rows[#rows + 1] = { self.coords[j], ("%.3e"):format(result[j].max), ("%.3e"):format(result[j].rms) }
  end
  local text = table.concat({
    ("Consistency of the forms of order %d with the run's own q''%s at %d points of '%s':"):format(n,
      sys.nc > 0 and " and multipliers" or "", #self.t, sys.name),
    require("nz.base.text").table(rows),
    "The run's q'' came from the equations at these same points, so this is",
    "rounding whatever the integration did: it checks that the equations of order",
    ("%d agree with the form the accelerations were solved from, not the motion"):format(n),
    "(tr:residuals(n) measures the motion).",
  }, "\n")
  return M.show(result, text, opts and opts.quiet)
end

require("nz.base.where").methods(Trajectory, "tr", "trajectory")

return M
