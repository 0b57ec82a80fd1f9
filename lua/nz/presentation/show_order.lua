-- nz/presentation/show_order.lua - Dolapchiev's equations of order n as formulas, for
-- sys:show{n = ...} (lua/nz/presentation/show.lua lays them out).  docs/theory.md (3.1):
--
--   (1/n) (dF^(n)/dq_i^(n) - (n + 1) dF/dq_i) = Q_i - dV/dq_i
--
-- and (4.1)-(4.2): R_n = (1/n) (F^(n) - (n + 1) F_0^(n)), dR_n/dq_i^(n) =
-- Q_i - dV/dq_i, where F (T and L) with its velocity argument held still
-- while t and q move is F_0.  F^(n) = D^n F, D the derivative along the
-- motion (t -> 1, q^(j) -> q^(j+1)) taken on the graph; it reads q ..
-- q^(n+1), so F is copied into a graph of its own with n + 2 slots (the
-- system's graph has the slots its functions receive, and its layout
-- sizes the arrays of the mechanics), and F_0 is that copy with q'
-- replaced by the frozen velocity, an input of the layout that D does not
-- move (src/mech/mech_graph.h).  Nothing here evaluates, and the system's
-- graph is left as it was.
local core = require "nz.core"
local formula = require "nz.base.formula"

local M = {}

-- q_i^(j) as a symbol: th, th', th'', th''', th^(4), ...; in Lua q, qd,
-- qdd, then higher[j - 2] (sys:residual's option higher = {q3, q4, ...}).
function M.symbol(sys, j, i)
  local name = sys.coords[i] .. (j <= 3 and ("'"):rep(j) or ("^(" .. j .. ")"))
  local lua = j <= 2 and ({ "q", "qd", "qdd" })[j + 1] .. ("[%d]"):format(i) or ("higher[%d][%d]"):format(j - 2, i)
  return formula.symbol(name, { lua = lua, base = sys.coords[i], dots = j, slot = j, coord = i })
end

-- The graph of the equations of order n of sys: { c = the graph, n, F, F0,
-- Fn, F0n = nodes (F, F_0, F^(n), F_0^(n)), partial = function(node, j,
-- i) -> d node/dq_i^(j) }, or nil and why.
function M.graph(sys, n)
  local e = sys.engine
  local src = e.recording
  local k, np = sys.k, #(e.recording_params or {})
  local F = src:piece_outputs("F", 1)
  if #F == 0 then return nil, "T (or L) is not recorded" end
  local nslots = n + 2
  local c = core.mech.recording_new(k, np, 0, nslots)
  c:set_native(false)
  -- the input numbers of t, the parameters and the slots are the same in
  -- both layouts (mech_graph.h): F is copied as it is
  local function slot(j, i) return 1 + np + j * k + (i - 1) end
  local Fc = c:copy(src, F, {})[1]
  local hold = {}
  for i = 1, k do hold[slot(1, i)] = c:frozen(i) end
  local F0 = c:copy(c, { Fc }, hold)[1]
  -- D: t -> 1, q_i^(j) -> q_i^(j+1); the frozen velocities do not move
  local dir = { [0] = c:const(1) }
  for j = 0, nslots - 2 do
    for i = 1, k do dir[slot(j, i)] = c:slot(j + 1, i) end
  end
  local Fn, F0n = Fc, F0
  for _ = 1, n do Fn, F0n = c:derivative(Fn, dir), c:derivative(F0n, dir) end
  local one = c:const(1)
  return { c = c, n = n, F = Fc, F0 = F0, Fn = Fn, F0n = F0n,
    partial = function(node, j, i) return c:derivative(node, { [slot(j, i)] = one }) end }
end

-- The terms of (3.1) of the graph g as polynomials, per coordinate: top[i]
-- = dF^(n)/dq_i^(n), dq[i] = dF/dq_i, lhs[i] = (top - (n + 1) dq) / n -
-- force (force: Q - dV/dq, per coordinate); and R(), Dolapchiev's R_n
-- (4.1), appell(i) = dR_n/dq_i^(n) - force_i (4.2), on demand.  reader(
-- frozen) reads g's nodes as polynomials (lua/nz/presentation/show.lua), the frozen
-- velocities as q' or, with frozen = true, apart (q'_0).
function M.terms(sys, g, force, reader)
  local n, c, rd = g.n, g.c, reader(false)
  local out = { top = {}, dq = {}, lhs = {}, graph = g, reader = rd, force = force }
  local k1, kn = formula.const(n + 1), formula.const(n)
  for i = 1, sys.k do
    out.top[i] = rd.poly(g.partial(g.Fn, n, i))
    out.dq[i] = rd.poly(g.partial(g.F, 0, i))
    out.lhs[i] = formula.sub(formula.div(formula.sub(out.top[i], formula.mul(k1, out.dq[i])), kn), force[i])
  end
  -- n R_n = F^(n) - (n + 1) F_0^(n) as a node, and its gradient G in q^(n)
  local nR = c:op("sub", g.Fn, c:op("mul", c:const(n + 1), g.F0n))
  local G = {}
  local function grad(i)
    G[i] = G[i] or g.partial(nR, n, i)
    return G[i]
  end
  -- R_n: for n = 1 whole, the velocities held in F_0 apart from q' (dR_1/dq'
  -- holds them); for n >= 2 the part that holds q^(n), R_n(x) - R_n(0) with
  -- x = q^(n).  There R_n is at most quadratic in x (F reads t, q and q'
  -- only, so by Faa di Bruno F^(n) holds q^(n) only in F_q q^(n) + n (d/dt
  -- F_q') q^(n) for n >= 3, and with F_q'q' q'' q'' for n = 2: docs/theory.md
  -- §4), and R_n(x) - R_n(0) = sum_i x_i G_i(x) -
  -- 1/2 sum_ij x_i x_j H_ij, H = dG/dx: made from the derivatives alone,
  -- never the whole of F^(n), whose terms grow with n (the heavy top from
  -- its body at n = 6: 42 s for F^(n) whole, 0.1 s this way)
  function out.R()
    if n == 1 then return formula.div(reader(true).poly(nR), kn) end
    local R, half = formula.const(0), formula.const(0.5)
    for i = 1, sys.k do
      local xi = rd.sym(rd.input(n, i))
      R = formula.add(R, formula.mul(xi, rd.poly(grad(i))))
      for j = 1, sys.k do
        local H = rd.poly(g.partial(grad(i), n, j))
        R = formula.sub(R, formula.mul(formula.mul(half, H), formula.mul(xi, rd.sym(rd.input(n, j)))))
      end
    end
    return formula.div(R, kn)
  end
  -- (4.2): dR_n/dq_i^(n) - (Q - dV/dq)_i, the residual's form "appell"
  function out.appell(i) return formula.sub(formula.div(rd.poly(grad(i)), kn), force[i]) end
  return out
end

-- The equations of order n by name.
function M.form(n)
  return ({ "Nielsen's equations", "Tsenov's equations", "Dolapchiev's equations with the jerk q'''" })[n]
    or ("Dolapchiev's equations of order %d"):format(n)
end

-- q^(j) in text: q, q', q'', q''', q^(4), ...
local function level(j) return j <= 3 and ("q" .. ("'"):rep(j)) or ("q^(" .. j .. ")") end
M.level = level

-- The names (3.1) of order n is written with, in lang: F (T, or L when the
-- system has one) and Fn, its n-th derivative; the labels of the terms of
-- coordinate i (top, dq, Q); the equation and what its terms hold (2.1), in
-- words (text).
function M.names(sys, n, lang)
  local e = sys.engine
  local F = #e.F > #e.T and "L" or "T"
  local tex = lang == "tex"
  local Fn = tex and (n == 1 and "\\dot{" .. F .. "}" or n == 2 and "\\ddot{" .. F .. "}" or ("%s^{(%d)}"):format(F, n))
    or F .. (n <= 3 and ("'"):rep(n) or ("^(" .. n .. ")"))
  local qn, qn1 = level(n), level(n + 1)
  local names = { F = F, Fn = Fn, qn = qn }
  local function coord(j, i) return formula.print(M.symbol(sys, j, i), lang) end
  local function partial(f, x) return tex and ("\\frac{\\partial %s}{\\partial %s}"):format(f, x) or ("d%s/d%s"):format(f, x) end
  function names.top(i) return partial(Fn, coord(n, i)) end
  function names.dq(i) return partial(F, coord(0, i)) end
  function names.Q(i) return tex and ("Q_{%s}"):format(coord(0, i)) or ("Q_" .. coord(0, i)) end
  local scaled = ("d%s/d%s - %d d%s/dq"):format(Fn, qn, n + 1, F)
  names.equation = n == 1 and scaled or ("(1/%d) (%s)"):format(n, scaled)
  if n == 1 then
    names.note = ("(%s reads q, q', q'', and by (2.1) d%s/dq' = d/dt d%s/dq' + d%s/dq)"):format(Fn, Fn, F, F)
  else
    names.note = ("(%s reads q to %s, %s only in d%s/dq' %s, free of %s: by (2.1) d%s/d%s = %d d/dt d%s/dq' + "
      .. "d%s/dq holds q'' at most)"):format(Fn, qn1, qn1, F, qn1, qn, Fn, qn, n, F, F)
  end
  return names
end

return M
