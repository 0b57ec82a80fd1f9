-- nz/presentation/show.lua - sys:show{...}: the equations of motion as formulas, read
-- from the recorded graphs: per coordinate M(q) q'' + h(q, q') = A^T lambda
-- (docs/theory.md (6.2): the equations of every order n collected; h holds the
-- forces, dV/dq - Q), the constraints Phi_r = 0, and on request the mass
-- matrix and the bias.  Plain text (coordinate names and primes as the
-- user named them), LaTeX (an aligned block), or Lua (a function of t, q,
-- qd, qdd, lambda, params returning the residuals: what the tests load back
-- and compare with sys:residual).
local formula = require "nz.base.formula"
local order_n = require "nz.presentation.show_order"
local constraints = require "nz.model.constraints"
local options = require "nz.base.options"
local display = require "nz.draw.display"

local M = {}

local function fail(sys, ...) require("nz.base.where").method_error("show", sys, ...) end

local derivative_symbol = order_n.symbol

-- The graph of a system, read once per call: the node dump, its symbols,
-- and a memo of the polynomials already made.  c: another graph of the
-- same layout (the equations of order n: nz/presentation/show_order.lua), whose frozen
-- velocities read as q' (frozen = true: as q'_0, where R_1 must tell them
-- from q').
local function reader(sys, c, frozen)
  local e = sys.engine
  if not e.recording then
    fail(sys, "the system is not recorded (made with compile = false), so there are no formulas to read: make it without compile = false")
  end
  c = c or e.recording
  local k, np = sys.k, #(e.recording_params or {})
  local frozen_from = 1 + np + c:nslots() * k
  local function sym(input)
    if input == 0 then return formula.symbol("t", { lua = "t", base = "t" }) end
    if input <= np then
      local name = e.recording_params[input]
      return formula.symbol(name, { lua = ("params[%q]"):format(name), base = name })
    end
    if input >= frozen_from then
      local i = input - frozen_from + 1
      if not frozen then return derivative_symbol(sys, 1, i) end
      return formula.symbol(sys.coords[i] .. "'_0", { lua = ("frozen[%d]"):format(i), base = sys.coords[i], dots = 1,
        slot = 1, coord = i, frozen = true })
    end
    local s = input - 1 - np
    return derivative_symbol(sys, s // k, s % k + 1)
  end
  local rd = { c = c, k = k, np = np, memo = {}, sym = sym }
  -- the graph grows as derivatives are taken: only its new nodes are read
  function rd.poly(id)
    if not rd.nodes then rd.nodes = c:nodes() end
    if id + 1 > #rd.nodes.op then
      -- c:nodes(from) keys its lists by id + 1 from from + 1 on, as the whole dump does
      for field, list in pairs(c:nodes(#rd.nodes.op)) do
        local dst = rd.nodes[field]
        for x, v in pairs(list) do dst[x] = v end
      end
    end
    return formula.from_graph(rd.nodes, id, sym, rd.memo)
  end
  function rd.input(j, i) return 1 + np + j * k + (i - 1) end
  return rd
end

-- Refuse a system whose T, V or Q runs in Lua (in part): the graph would
-- lack that piece, and the formulas would be wrong without a word.
local function check_recorded(sys)
  local in_lua = require("nz.model.record").mass_bias_in_lua(sys)
  if in_lua then fail(sys, "no formulas: %s. Only recorded functions can be shown", in_lua) end
end

-- M (k x k) and h (k) as polynomials.
local function mass_bias(sys, rd)
  check_recorded(sys)
  local ids = rd.c:mass_bias_outputs(sys.k)
  if not ids then fail(sys, "M and h could not be built from the recording (a piece of T, V or Q runs in Lua)") end
  local k, Mp, h = sys.k, {}, {}
  for i = 1, k do
    Mp[i] = {}
    for j = 1, k do Mp[i][j] = rd.poly(ids[(i - 1) * k + j]) end
    h[i] = rd.poly(ids[k * k + i])
  end
  return Mp, h
end

-- Constraint r: Phi_r and its gradient A_r = dPhi_r/dq^(m) (m its order).
local function constraint(sys, rd, r, m)
  local out = rd.c:piece_outputs("constraints", r)
  if #out == 0 then fail(sys, "constraint %d runs in Lua: only recorded functions can be shown", r) end
  local one = rd.c:const(1)
  local A = {}
  for i = 1, sys.k do
    local d = rd.c:derivative(out[1], { [rd.input(m, i)] = one })
    A[i] = d
  end
  local phi = rd.poly(out[1])
  for i = 1, sys.k do A[i] = rd.poly(A[i]) end
  return phi, A
end

-- The equations as polynomials: lhs[i] = sum_j M_ij q_j'' + h_i and rhs[i]
-- = sum_r A_ri lambda_r; with the constraints and their orders.  With n,
-- lhs is (3.1) of order n, built from F^(n) (nz/presentation/show_order.lua), and M and h
-- are read off it: the coefficients of q'' and the rest (which would hold
-- whatever else the collected form kept: by (2.1) nothing above q'').
function M.equations(sys, n, multipliers)
  local rd = reader(sys)
  local k = sys.k
  local lhs, rhs = {}, {}
  local Mp, h, order
  if n then
    check_recorded(sys)
    -- (3.1) of order n from F^(n) (nz/presentation/show_order.lua), whose collected
    -- form then gives M and h: the coefficients of q'' and the rest
    local eq0 = { reader = rd }
    local g, why = order_n.graph(sys, n)
    if not g then fail(sys, "no formulas of order %d: %s", n, why) end
    order = order_n.terms(sys, g, M.forces(sys, eq0), function(frozen) return reader(sys, g.c, frozen) end)
    Mp, h = {}, {}
    for i = 1, k do
      lhs[i], rhs[i] = order.lhs[i], formula.const(0)
      local coef, rest = formula.linear_in(lhs[i], function(a)
        local info = a.kind == "sym" and a.info
        return info and info.slot == 2 and not info.frozen and info.coord or nil
      end)
      Mp[i], h[i] = {}, rest
      for j = 1, k do Mp[i][j] = coef[j] or formula.const(0) end
    end
  else
    Mp, h = mass_bias(sys, rd)
    for i = 1, k do
      local s = h[i]
      for j = 1, k do s = formula.add(s, formula.mul(Mp[i][j], rd.sym(rd.input(2, j)))) end
      lhs[i], rhs[i] = s, formula.const(0)
    end
  end
  local phis, As, orders = {}, {}, {}
  if sys.nc > 0 then
    orders = constraints.orders(sys)
    for r = 1, sys.nc do
      phis[r], As[r] = constraint(sys, rd, r, orders[r])
      -- (multipliers: a contact system's, nz/presentation/contact_laws.lua; nil: no force)
      local lam = multipliers and multipliers(r)
        or not multipliers and formula.symbol("lambda" .. r, { lua = ("lambda[%d]"):format(r), base = "lambda_" .. r })
      if lam then
        for i = 1, k do rhs[i] = formula.add(rhs[i], formula.mul(As[r][i], lam)) end
      end
    end
  end
  return { lhs = lhs, rhs = rhs, M = Mp, h = h, phi = phis, A = As, orders = orders, reader = rd, n = n, order = order }
end

-- The applied forces -dV/dq + Q, per coordinate (Appell's function needs them).
function M.forces(sys, eq)
  local rd = eq.reader
  local V, Q = rd.c:piece_outputs("V", 1), rd.c:piece_outputs("Q", 1)
  local one = rd.c:const(1)
  local force = {}
  for i = 1, sys.k do
    local f = formula.const(0)
    if #V > 0 then f = formula.neg(rd.poly(rd.c:derivative(V[1], { [rd.input(0, i)] = one }))) end
    if #Q >= i then f = formula.add(f, rd.poly(Q[i])) end
    force[i] = f
  end
  return force
end

-- Appell's function of the accelerations up to terms free of q'' (docs/theory.md
-- §4: R_2, which is Appell's S = sum m a^2 / 2 for particles):
-- S = 1/2 q''^T M q'' + q''^T (h + dV/dq - Q), so that dS/dq''_i = Q_i - dV/dq_i
-- are the equations.
function M.appell(sys, eq)
  local k, rd = sys.k, eq.reader
  local force = M.forces(sys, eq)
  local S = formula.const(0)
  for i = 1, k do
    local ai = rd.sym(rd.input(2, i))
    for j = 1, k do
      S = formula.add(S, formula.mul(formula.mul(formula.const(0.5), eq.M[i][j]), formula.mul(ai, rd.sym(rd.input(2, j)))))
    end
    S = formula.add(S, formula.mul(ai, formula.add(eq.h[i], force[i])))
  end
  return S
end

-- Is the text a sum at its top level (a + or - outside every parenthesis)?
local function top_level_sum(text)
  local depth = 0
  for n = 1, #text do
    local ch = text:sub(n, n)
    if ch == "(" or ch == "{" then depth = depth + 1
    elseif ch == ")" or ch == "}" then depth = depth - 1
    elseif depth == 0 and (ch == "+" or ch == "-") and n > 1 and text:sub(n - 1, n - 1) == " " then return true end
  end
  return false
end

-- Rank of an atom in an equation: q'' first (2), then q' (1).
local function rank(a) return a.kind == "sym" and a.info and a.info.slot and a.info.slot >= 1 and a.info.slot or 0 end

-- Tsenov's reduced equations (docs/theory.md §7): the multipliers eliminated by
-- combining the equations along the admissible directions.  With the
-- dependent coordinates D chosen at a sample state by complete pivoting on
-- the constraint rows (as sys:reduced does), a = -A_D^-1 A_I, and each
-- independent l gives E_l + sum_r a_rl E_D_r = 0; multiplied through by
-- det A_D to stay free of fractions: det E_l - sum_r (adj(A_D) A_I)_rl E_D_r.
-- Up to two constraints (the adjugate written out).
function M.reduced(sys, eq)
  local k, nc = sys.k, sys.nc
  if nc == 0 then return nil, "the system has no constraints: its equations are already free of multipliers" end
  if nc > 2 then return nil, ("%d constraints: the reduced equations are printed for one or two"):format(nc) end
  local _, linear = constraints.orders(sys)
  for r = 1, nc do
    if eq.orders[r] > 2 or (eq.orders[r] == 2 and not linear[r]) then
      return nil, ("constraint %d is not linear at the acceleration level: Tsenov's elimination does not apply"):format(r)
    end
  end
  local st = constraints.sample_states(sys, 1)[1]
  local zero = {}
  for i = 1, k do zero[i] = 0 end
  local Anum = {}
  for r = 1, nc do Anum[r] = require("nz.core").mech.constraint_row(sys.engine, r, eq.orders[r], st.t, st[1], st[2], zero) end
  local all = {}
  for i = 1, k do all[i] = i end
  local dep = require("nz.analysis.linearize").pick_columns(Anum, all)
  if not dep then return nil, "the constraints are dependent at the sample state: no set of dependent coordinates" end
  local is_dep = {}
  for _, i in ipairs(dep) do is_dep[i] = true end
  local A = eq.A
  local det, adj
  if nc == 1 then
    det, adj = A[1][dep[1]], { { formula.const(1) } }
  else
    local a, b, c, d = A[1][dep[1]], A[1][dep[2]], A[2][dep[1]], A[2][dep[2]]
    det = formula.sub(formula.mul(a, d), formula.mul(b, c))
    adj = { { d, formula.neg(b) }, { formula.neg(c), a } }   -- rows: dependent r, columns: constraint s
  end
  local out, ind = {}, {}
  for l = 1, k do
    if not is_dep[l] then
      local e, coupled = formula.mul(det, eq.lhs[l]), false
      for r = 1, nc do
        local coef = formula.const(0)
        for s = 1, nc do coef = formula.add(coef, formula.mul(adj[r][s], A[s][l])) end
        if #coef.terms > 0 then coupled = true end
        e = formula.sub(e, formula.mul(coef, eq.lhs[dep[r]]))
      end
      if not coupled then e = eq.lhs[l] end          -- no constraint moves q_l: its own equation
      local lead = formula.ordered(e, rank).terms[1]
      if lead and lead.c < 0 then e = formula.neg(e) end   -- "= 0": the sign is free
      out[#out + 1], ind[#ind + 1] = e, l
    end
  end
  return { equations = out, independent = ind, dependent = dep, det = det }
end


-- Names for atoms that repeat, when the text would run over a screen:
-- cos(...) -> c1, sin(...) -> s1, anything else -> w1.
local function short_names(polys)
  local counts = {}
  for _, P in ipairs(polys) do formula.count_atoms(P, counts) end
  local list = {}
  for key, e in pairs(counts) do
    local a = e.atom
    local compound = a.kind ~= "sym" and not (a.arg and #a.arg.terms == 1 and #a.arg.terms[1].f == 1 and a.arg.terms[1].c == 1)
    if e.n >= 2 and compound and a.kind ~= "group" then list[#list + 1] = { key = key, atom = a } end
  end
  table.sort(list, function(x, y) return x.key < y.key end)
  local names, where, n = {}, {}, { c = 0, s = 0, w = 0 }
  for _, e in ipairs(list) do
    local letter = e.atom.fn == "cos" and "c" or e.atom.fn == "sin" and "s" or "w"
    n[letter] = n[letter] + 1
    names[e.key] = letter .. n[letter]
    where[#where + 1] = e
  end
  return names, where
end

-- What sys:show prints beside the equations when asked (reduced, appell,
-- mass, bias), and with n the terms of (3.1): a list of {title, rows =
-- {{left, right}, ...}} in lang.
local function extras(sys, eq, opts, lang, names)
  local k, out = sys.k, {}
  local tex = lang == "tex"
  -- a coordinate as the equations write it (th -> \theta in LaTeX)
  local function name(i)
    return formula.print(formula.symbol(sys.coords[i], { base = sys.coords[i], dots = 0, slot = 0, coord = i }), lang)
  end
  local width = 0
  for i = 1, k do width = math.max(width, #sys.coords[i]) end
  local n = eq.n
  -- the labels in lang, the titles in text (LaTeX comments in LaTeX)
  local on, ot = n and order_n.names(sys, n, lang), n and order_n.names(sys, n, "text")
  if n then
    -- (3.1)'s terms as they come: dF^(n)/dq^(n), dF/dq and the force, per coordinate
    local x = { title = "the terms of (3.1) as they come, per coordinate (Q includes -dV/dq)\n  " .. ot.note,
      rows = {}, align = true }
    for i = 1, k do
      x.rows[#x.rows + 1] = { on.top(i), formula.print(formula.ordered(eq.order.top[i], rank), lang, names) }
      x.rows[#x.rows + 1] = { on.dq(i), formula.print(formula.ordered(eq.order.dq[i], rank), lang, names) }
      x.rows[#x.rows + 1] = { on.Q(i), formula.print(formula.ordered(eq.order.force[i], rank), lang, names) }
    end
    out[#out + 1] = x
  end
  if opts.reduced then
    local red, why = M.reduced(sys, eq)
    if not red then fail(sys, "reduced = true: %s", why) end
    local dn = {}
    for n, i in ipairs(red.dependent) do dn[n] = sys.coords[i] end
    local x = { title = ("Tsenov's reduced equations, without multipliers (dependent: %s; the coupled ones multiplied by %s), "
      .. "one per independent coordinate"):format(table.concat(dn, ", "), formula.print(red.det, "text", names, true)), rows = {} }
    for n, e in ipairs(red.equations) do
      local left = formula.print(formula.ordered(e, rank), lang, names)
      x.rows[n] = tex and { left, "0" } or { ("%-" .. width .. "s:  %s"):format(sys.coords[red.independent[n]], left), "0" }
    end
    out[#out + 1] = x
  end
  if opts.appell and n then
    local title
    if n == 1 then
      title = ("Dolapchiev's R_1 = %s' - 2 %s_0' (4.1), %s_0: %s with its velocities held, written %s'_0, ... (dR_1/dq'_i, "
        .. "with them held, = Q_i + (A^T lambda)_i)"):format(ot.F, ot.F, ot.F, ot.F, sys.coords[1])
    else
      title = ("Dolapchiev's R_%d = (1/%d) (%s - %d %s_0%s) (4.1) up to terms free of %s, %s_0: %s with its velocities "
        .. "held (dR_%d/d%s_i = Q_i + (A^T lambda)_i; %s)"):format(n, n, ot.Fn, n + 1, ot.F, ot.Fn:sub(#ot.F + 1), ot.qn, ot.F,
        ot.F, n, ot.qn, n == 2 and "Appell's S" or ("linear in %s: sum_i E_i(%s) %s_i"):format(ot.qn, ot.F, ot.qn))
    end
    out[#out + 1] = { title = title, rows = { { lang == "tex" and ("R_{%d}"):format(n) or ("R_" .. n),
      formula.print(formula.ordered(eq.order.R(), rank), lang, names) } } }
  elseif opts.appell then
    out[#out + 1] = { title = "Appell's function of the accelerations (up to terms free of q''; dS/dq''_i = Q_i - dV/dq_i + (A^T lambda)_i)",
      rows = { { "S", formula.print(formula.ordered(M.appell(sys, eq), rank), lang, names) } } }
  end
  if opts.mass then
    local x = { title = "the mass matrix M(q)", rows = {} }
    for i = 1, k do
      for j = i, k do
        if #eq.M[i][j].terms > 0 then
          local left = tex and ("M_{%s %s}"):format(name(i), name(j)) or ("M[%s, %s]"):format(sys.coords[i], sys.coords[j])
          x.rows[#x.rows + 1] = { left, formula.print(eq.M[i][j], lang, names, true) }
        end
      end
    end
    out[#out + 1] = x
  end
  if opts.bias then
    local x = { title = "the bias h(q, q') (with the forces: dV/dq - Q)", rows = {} }
    for i = 1, k do
      x.rows[i] = { tex and ("h_{%s}"):format(name(i)) or ("h[%s]"):format(sys.coords[i]), formula.print(eq.h[i], lang, names, true) }
    end
    out[#out + 1] = x
  end
  return out
end

local OPTIONS = options.declare("sys:show", { "n", "tex", "lua", "mass", "bias", "reduced", "appell", "width", "names" })

function M.show(sys, opts)
  opts = opts or {}
  if type(opts) ~= "table" then fail(sys, "options must be a table {n =, tex =, lua =, mass =, bias =, width =}") end
  options.check(opts, OPTIONS, function(...) fail(sys, ...) end)
  local n = opts.n
  local max_order = require("nz.core").mech.max_order
  if n ~= nil and not (type(n) == "number" and n == math.floor(n) and n >= 1 and n <= max_order) then
    fail(sys, "option 'n': an integer order from 1 to %d expected, got %s", max_order, require("nz.base.args").shown(n))
  end
  n = n and math.tointeger(n)
  -- unilateral contacts: the equations of the contact system (its forces on
  -- the right), its equalities as constraints, the contacts' laws after
  local laws = sys.contact and require("nz.presentation.contact_laws")
  local eq = M.equations(sys.contact and sys.contact.system or sys, n, laws and laws.multipliers(sys))
  local nb = sys.contact and sys.contact.nb or sys.nc
  local k = sys.k
  if opts.lua then
    local what = n and ("the residuals of order %d, %s - Q - A^T lambda (Q includes -dV/dq),"):format(n,
      order_n.names(sys, n, "text").equation) or "the residuals M q'' + h - A^T lambda"
    local lines = { ("-- %s of '%s' (nzlua sys:show{%slua = true})"):format(what, sys.name, n and ("n = %d, "):format(n) or ""),
      "-- higher = {q''', q^(4), ...}: the derivatives above q'' (as sys:residual's option higher)",
      "return function(t, q, qd, qdd, lambda, params, higher)", "  lambda = lambda or {}", "  params = params or {}",
      "  higher = higher or {}", "  return {" }
    for i = 1, k do
      local r = formula.sub(eq.lhs[i], eq.rhs[i])
      lines[#lines + 1] = "    " .. formula.print(r, "lua") .. ","
    end
    lines[#lines + 1] = "  }"
    lines[#lines + 1] = "end"
    return table.concat(lines, "\n")
  end
  local lang = opts.tex and "tex" or "text"
  local polys = {}
  for i = 1, k do
    eq.lhs[i] = formula.ordered(eq.lhs[i], rank)
    polys[#polys + 1], polys[#polys + 2] = eq.lhs[i], eq.rhs[i]
  end
  for r = 1, #eq.phi do polys[#polys + 1] = eq.phi[r] end
  -- name repeated subexpressions when the equations run long
  -- a row: sum_j (M_ij) q_j'' + h_i = A^T lambda, each coefficient of q''
  -- whole (in parentheses when a sum), then the bias' terms
  local function lhs_text(i, names)
    local parts = {}
    for j = 1, k do
      local C = eq.M[i][j]
      if #C.terms > 0 then
        local acc = formula.print(formula.symbol(sys.coords[j] .. "''", { base = sys.coords[j], dots = 2, slot = 2, coord = j,
          lua = ("qdd[%d]"):format(j) }), lang)
        local text
        local cst, v = formula.is_const(C)
        if cst then
          text = (v == 1 and "" or v == -1 and "-" or (formula.number(v) .. (lang == "tex" and " \\, " or " "))) .. acc
        elseif #C.terms == 1 then
          text = formula.print(formula.mul(C, formula.const(1)), lang, names) .. (lang == "tex" and " \\, " or " ") .. acc
        else
          local inner = formula.print(C, lang, names, true)
          if top_level_sum(inner) then
            inner = (lang == "tex" and "\\left(" .. inner .. "\\right)" or "(" .. inner .. ")")
          end
          text = inner .. (lang == "tex" and " \\, " or " ") .. acc
        end
        parts[#parts + 1] = text
      end
    end
    local rest = formula.print(eq.h[i], lang, names)
    local s = table.concat(parts, " + "):gsub("%+ %-", "- ")
    if rest ~= "0" then
      s = s == "" and rest or (rest:sub(1, 1) == "-" and (s .. " - " .. rest:sub(2)) or (s .. " + " .. rest))
    end
    return s == "" and "0" or s
  end
  local function render(names)
    local rows = {}
    for i = 1, k do rows[i] = { lhs_text(i, names), formula.print(eq.rhs[i], lang, names, true) } end
    return rows
  end
  local rows, names, where = render(nil), nil, {}
  local total = 0
  for _, r in ipairs(rows) do total = total + #r[1] + #r[2] end
  if opts.names ~= false and (total > (opts.width or 100) * 3 or opts.names) then
    names, where = short_names(polys)
    if #where > 0 then rows = render(names) else names = nil end
  end
  local rule_n = sys.nc > 0 and (sys:rule()) or 1
  local form = ({ "Nielsen's", "Tsenov's" })[rule_n] or ("Dolapchiev's, of order " .. rule_n)
  if lang == "tex" then
    local out = { "\\begin{aligned}" }
    for i = 1, k do
      out[#out + 1] = ("  %s &= %s \\\\"):format(rows[i][1], rows[i][2])
    end
    for r = 1, nb do out[#out + 1] = ("  %s &= 0 \\\\"):format(formula.print(eq.phi[r], "tex", names, true)) end
    if laws then
      for _, l in ipairs(laws.show_lines(sys, eq, "tex", names)) do out[#out + 1] = "  " .. l .. " \\\\" end
    end
    for _, e in ipairs(where) do
      out[#out + 1] = ("  %s &= %s \\\\"):format(names[e.key]:gsub("^(%a)(%d+)$", "%1_{%2}"), formula.print_atom(e.atom, formula.printers.tex, nil))
    end
    out[#out] = out[#out]:gsub(" \\\\$", "")
    out[#out + 1] = "\\end{aligned}"
    -- what was asked for beside the equations: a block each, named in a
    -- LaTeX comment, so that each compiles on its own
    local function block(title, lines)
      out[#out + 1] = "% " .. title:gsub("\n%s*", "\n%% ")
      out[#out + 1] = "\\begin{aligned}"
      for n, l in ipairs(lines) do out[#out + 1] = "  " .. l .. (n < #lines and " \\\\" or "") end
      out[#out + 1] = "\\end{aligned}"
    end
    for _, x in ipairs(extras(sys, eq, opts, "tex", names)) do
      local lines = {}
      for _, row in ipairs(x.rows) do lines[#lines + 1] = ("%s &= %s"):format(row[1], row[2]) end
      block(x.title, lines)
    end
    local s = table.concat(out, "\n")
    if names then   -- short names are plain letters in text; typeset them with an index
      for _, e in ipairs(where) do
        local nm = names[e.key]
        s = s:gsub("([^%a_])" .. nm .. "([^%d])", "%1" .. nm:gsub("^(%a)(%d+)$", "%1_{%2}") .. "%2")
      end
    end
    return display.offer(s, { ["text/latex"] = function() return display.latex(s) end })   -- a notebook typesets it
  end
  local out
  if n then
    local T = order_n.names(sys, n, "text")
    out = { ("equations of order n = %d of '%s', %s:"):format(n, sys.name, order_n.form(n)),
      ("  %s = Q + A^T lambda (Q includes -dV/dq), collected as for every n by (2.1)"):format(T.equation),
      ("  to M(q) q'' + h(q, q') = A^T lambda, per coordinate (Dolapchiev's rule picks n = %d)"):format(rule_n) }
  else
    out = { ("equations of motion of '%s': M(q) q'' + h(q, q') = A^T lambda, per coordinate"):format(sys.name),
      ("  (Dolapchiev's rule picks n = %d, %s equations; the equations of every order n collect to these:"
        .. " show{n = %d} prints them with their terms)"):format(rule_n, form, rule_n) }
  end
  local width = 0
  for i = 1, k do width = math.max(width, #sys.coords[i]) end
  for i = 1, k do
    out[#out + 1] = ("  %-" .. width .. "s:  %s = %s"):format(sys.coords[i], rows[i][1], rows[i][2])
  end
  if nb > 0 then
    out[#out + 1] = "with the constraints"
    for r = 1, nb do
      out[#out + 1] = ("  (%d)  %s = 0   (order %d: A = dPhi/d%s)"):format(r, formula.print(eq.phi[r], "text", names, true),
        eq.orders[r], order_n.level(eq.orders[r]))
    end
  end
  if laws then
    out[#out + 1] = "with the unilateral contacts (N: the normal force on the gap's gradient, T: the friction on the slip's)"
    for _, l in ipairs(laws.show_lines(sys, eq, "text", names)) do out[#out + 1] = l end
  end
  if #where > 0 then
    out[#out + 1] = "where"
    for _, e in ipairs(where) do
      out[#out + 1] = ("  %s = %s"):format(names[e.key], formula.print_atom(e.atom, formula.printers.text, nil))
    end
  end
  for _, x in ipairs(extras(sys, eq, opts, "text", names)) do
    out[#out + 1] = x.title .. ":"
    local w = 0
    for _, row in ipairs(x.rows) do w = x.align and math.max(w, #row[1]) or 0 end
    for _, row in ipairs(x.rows) do out[#out + 1] = "  " .. row[1] .. (" "):rep(w - #row[1]) .. " = " .. row[2] end
  end
  -- a notebook shows the same equations typeset (made only when it asks)
  local tex_opts = setmetatable({ tex = true }, { __index = opts })
  return display.offer(table.concat(out, "\n"), { ["text/latex"] = function() return display.latex(M.show(sys, tex_opts)) end })
end

return M
