-- nz/base/formula.lua - the recorded graphs as formulas: a small normal form for
-- printing (sums of monomials with rational coefficients folded, like terms
-- collected, sin^2 + cos^2 combined, sqrt(u)^2 = u, common factors taken
-- out), and printers for plain text, LaTeX and Lua.  The normal form is for
-- reading only: every number it shows is the graph's own (constants folded
-- in double precision), and the Lua printer's output is checked against the
-- engine's residual (tests/show_spec.lua).  Code export does not go through
-- it: nz/presentation/export.lua writes the graph's nodes as straight-line code.
--
-- An expression is a polynomial P = { terms = { {c = number, f = {factor,
-- ...}}, ... } } whose factors {a = atom, p = integer power} are sorted by
-- the atoms' keys; an atom is a symbol (an input of the graph), a function
-- of a polynomial, a power with a non-integer or symbolic exponent, or a
-- group (a sum kept whole: a divisor, or a power too large to expand).
local M = {}

-- ------------------------------------------------------------------ --
-- Numbers

-- The shortest decimal that reads back as the same double.
function M.number(v)
  if v == math.floor(v) and math.abs(v) < 1e15 then return ("%d"):format(v) end
  for digits = 1, 17 do
    local s = ("%." .. digits .. "g"):format(v)
    if tonumber(s) == v then return s end
  end
  return ("%.17g"):format(v)
end

-- ------------------------------------------------------------------ --
-- Atoms and polynomials

local atoms = setmetatable({}, { __mode = "v" })   -- interned by key

local function atom(kind, key, fields)
  local a = atoms[key]
  if a then return a end
  fields.kind, fields.key = kind, key
  atoms[key] = fields
  return fields
end

local function term_key(f)
  local parts = {}
  for n, x in ipairs(f) do parts[n] = x.a.key .. "^" .. x.p end
  return table.concat(parts, "*")
end

-- Like terms that add up to less than this part of the largest of them
-- have cancelled, up to the rounding of the graph's constants: (3 c x) / 3
-- - c x leaves 2e-16 c x where c = 0.7 (a sum of like terms of the
-- equations of order n, nz/presentation/show_order.lua), which is no term of theirs.
local CANCELLED = 64 * 2 ^ -52

-- A polynomial from {key -> term}, zero terms dropped, in a stable order.
local function make(map)
  local terms = {}
  for key, t in pairs(map) do
    if t.c ~= 0 and not (t.big and math.abs(t.c) <= CANCELLED * t.big) then t.key = key; terms[#terms + 1] = t end
  end
  table.sort(terms, function(x, y) return x.key < y.key end)
  local keys = {}
  for n, t in ipairs(terms) do keys[n] = M.number(t.c) .. "|" .. t.key end
  return { terms = terms, key = table.concat(keys, " + ") }
end

local function const(v) return make({ [""] = { c = v, f = {} } }) end
M.const = const

local function of_atom(a, p) return make({ [a.key .. "^" .. (p or 1)] = { c = 1, f = { { a = a, p = p or 1 } } } }) end

function M.symbol(name, info)
  -- the key holds where the symbol comes from too: "th" is q[1] in one
  -- system and q[3] in another, and atoms are shared between calls
  local where = info and info.lua or ""
  local a = atom("sym", "s:" .. name .. "|" .. where, { name = name, info = info })
  return of_atom(a)
end

local function is_const(P)
  if #P.terms == 0 then return true, 0 end
  if #P.terms == 1 and #P.terms[1].f == 0 then return true, P.terms[1].c end
  return false
end
M.is_const = is_const

local function add_into(map, t, scale)
  local key = term_key(t.f)
  local cur = map[key]
  if cur then
    -- the largest like term summed so far (make drops a sum that cancelled)
    cur.big = math.max(cur.big or math.abs(cur.c), math.abs(scale * t.c), t.big and math.abs(scale) * t.big or 0)
    cur.c = cur.c + scale * t.c
  else map[key] = { c = scale * t.c, f = t.f, big = t.big and math.abs(scale) * t.big } end
end

local function sum(a, b, sb)
  local map = {}
  for _, t in ipairs(a.terms) do add_into(map, t, 1) end
  for _, t in ipairs(b.terms) do add_into(map, t, sb or 1) end
  return M.tidy(make(map))
end
function M.add(a, b) return sum(a, b, 1) end
function M.sub(a, b) return sum(a, b, -1) end
function M.neg(a) return sum(const(0), a, -1) end

-- The product of two factor lists (merged by atom, powers added).
local function mul_factors(f, g)
  local byk, out = {}, {}
  for _, list in ipairs{ f, g } do
    for _, x in ipairs(list) do
      local cur = byk[x.a.key]
      if cur then cur.p = cur.p + x.p else byk[x.a.key] = { a = x.a, p = x.p } end
    end
  end
  for _, x in pairs(byk) do if x.p ~= 0 then out[#out + 1] = x end end
  table.sort(out, function(x, y) return x.a.key < y.a.key end)
  return out
end

function M.mul(a, b)
  local map = {}
  for _, s in ipairs(a.terms) do
    for _, t in ipairs(b.terms) do add_into(map, { c = s.c * t.c, f = mul_factors(s.f, t.f) }, 1) end
  end
  return M.tidy(make(map))
end

-- A sum kept whole, as an atom.
local function group(P) return atom("group", "g:(" .. P.key .. ")", { poly = P }) end

-- P^n for an integer n: a monomial's powers multiply; a small sum to a
-- small power is expanded (so that identities between terms are seen);
-- anything else is a group.
function M.powi(P, n)
  if n == 0 then return const(1) end
  if n == 1 then return P end
  if #P.terms == 1 then
    local t = P.terms[1]
    local f = {}
    for i, x in ipairs(t.f) do f[i] = { a = x.a, p = x.p * n } end
    return M.tidy(make({ [term_key(f)] = { c = t.c ^ n, f = f } }))
  end
  if n > 1 and n <= 4 and #P.terms <= 6 then
    local r = P
    for _ = 2, n do r = M.mul(r, P) end
    return r
  end
  return of_atom(group(P), n)
end

-- A quotient by a constant divides each coefficient (as the graph's x / v
-- does), so that (3 x) / 3 is x exactly where x times 1/3 may not be.
function M.div(a, b)
  local c, v = is_const(b)
  if c then
    local map = {}
    for _, t in ipairs(a.terms) do add_into(map, { c = t.c / v, f = t.f }, 1) end
    return M.tidy(make(map))
  end
  return M.mul(a, M.powi(b, -1))
end

-- P split by the symbols pick(atom) names (an index, or nil): P = sum_j
-- coef[j] x_j + rest, where a term goes to coef[j] when x_j is its only
-- picked factor and appears to the power 1, to rest otherwise.
function M.linear_in(P, pick)
  local maps, rest = {}, {}
  for _, t in ipairs(P.terms) do
    local at, others = nil, false
    for _, x in ipairs(t.f) do
      local j = pick(x.a)
      if j then
        if at or x.p ~= 1 then others = true end
        at = at or { j = j, x = x }
      end
    end
    if at and not others then
      local f = {}
      for _, x in ipairs(t.f) do if x ~= at.x then f[#f + 1] = x end end
      maps[at.j] = maps[at.j] or {}
      add_into(maps[at.j], { c = t.c, f = f }, 1)
    else
      add_into(rest, t, 1)
    end
  end
  local coef = {}
  for j, map in pairs(maps) do coef[j] = make(map) end
  return coef, make(rest)
end

-- A function's atom, its argument's sign made canonical: odd functions take
-- the minus out (sin(-x) = -sin x), even ones drop it (cos(-x) = cos x).
local odd = { sin = true, tan = true, asin = true, atan = true, sinh = true, tanh = true, sign = true }
local even = { cos = true, cosh = true, abs = true }
function M.fn(name, P)
  local cst, v = is_const(P)
  if cst then
    local f = math[name] or ({ sinh = function(x) return (math.exp(x) - math.exp(-x)) / 2 end,
      cosh = function(x) return (math.exp(x) + math.exp(-x)) / 2 end })[name]
    if f then return const(f(v)) end
  end
  local flip = #P.terms > 0 and P.terms[1].c < 0
  if flip and (odd[name] or even[name]) then
    P = M.neg(P)
    local r = of_atom(atom("fn", name .. "(" .. P.key .. ")", { fn = name, arg = P }))
    return odd[name] and M.neg(r) or r
  end
  if name == "sqrt" then return of_atom(atom("fn", "sqrt(" .. P.key .. ")", { fn = "sqrt", arg = P })) end
  return of_atom(atom("fn", name .. "(" .. P.key .. ")", { fn = name, arg = P }))
end

function M.binary(name, a, b)      -- atan2, hypot, pow (symbolic exponent)
  return of_atom(atom("bin", name .. "(" .. a.key .. "," .. b.key .. ")", { fn = name, a = a, b = b }))
end

function M.powc(P, v)
  if v == math.floor(v) and math.abs(v) <= 64 then return M.powi(P, math.tointeger(v)) end
  if v == 0.5 then return M.fn("sqrt", P) end
  if v == -0.5 then return M.powi(M.fn("sqrt", P), -1) end
  return of_atom(atom("powc", "p:(" .. P.key .. ")^" .. M.number(v), { base = P, exp = v }))
end

function M.select(c, a, b)
  return of_atom(atom("select", "sel(" .. c.key .. "," .. a.key .. "," .. b.key .. ")", { c = c, a = a, b = b }))
end
function M.cmp(op, a, b)
  return of_atom(atom("cmp", "cmp:" .. op .. "(" .. a.key .. "," .. b.key .. ")", { op = op, a = a, b = b }))
end

-- The identities applied after every sum and product: sqrt(u)^2 = u, and
-- c X sin(u)^2 + c X cos(u)^2 = c X.
function M.tidy(P)
  -- sqrt(u)^p, p >= 2: u^(p // 2) sqrt(u)^(p % 2)
  for _, t in ipairs(P.terms) do
    for _, x in ipairs(t.f) do
      if x.a.kind == "fn" and x.a.fn == "sqrt" and (x.p >= 2 or x.p <= -2) then
        local map = {}
        for _, s in ipairs(P.terms) do
          if s ~= t then add_into(map, s, 1) end
        end
        local rest = {}
        for _, y in ipairs(t.f) do if y ~= x then rest[#rest + 1] = y end end
        local q = x.p >= 0 and x.p // 2 or -((-x.p) // 2)
        local mono = make({ [term_key(rest)] = { c = t.c, f = rest } })
        local keep = M.mul(mono, M.powi(x.a.arg, q))
        if x.p - 2 * q ~= 0 then keep = M.mul(keep, of_atom(x.a, x.p - 2 * q)) end
        return sum(make(map), keep)
      end
    end
  end
  -- cos a cos b + sin a sin b = cos(a - b), sin a cos b - cos a sin b = sin(a - b)
  -- (and the sums: cos(a + b), sin(a + b)), as a double pendulum written
  -- from its bobs' positions produces them
  local merged = M.angle_sums(P)
  if merged then return M.tidy(merged) end
  -- sin^2 + cos^2
  if #P.terms >= 2 then
    local by = {}
    for n, t in ipairs(P.terms) do by[t.key] = n end
    for _, t in ipairs(P.terms) do
      for _, x in ipairs(t.f) do
        if x.a.kind == "fn" and x.a.fn == "sin" and x.p >= 2 then
          local cosa = atom("fn", "cos(" .. x.a.arg.key .. ")", { fn = "cos", arg = x.a.arg })
          local f2 = {}
          for _, y in ipairs(t.f) do
            if y == x then
              if x.p > 2 then f2[#f2 + 1] = { a = x.a, p = x.p - 2 } end
              f2[#f2 + 1] = { a = cosa, p = 2 }
            else f2[#f2 + 1] = y end
          end
          table.sort(f2, function(u, v) return u.a.key < v.a.key end)
          -- merge a cos^2 already there with its own power
          local merged = mul_factors(f2, {})
          local other = by[term_key(merged)]
          if other and P.terms[other].c == t.c then
            local map = {}
            for _, s in ipairs(P.terms) do
              if s ~= t and s ~= P.terms[other] then add_into(map, s, 1) end
            end
            local rest = {}
            for _, y in ipairs(t.f) do
              if y == x then
                if x.p > 2 then rest[#rest + 1] = { a = x.a, p = x.p - 2 } end
              else rest[#rest + 1] = y end
            end
            add_into(map, { c = t.c, f = rest }, 1)
            return M.tidy(make(map))
          end
        end
      end
    end
  end
  return P
end

-- The term's factors split into one sin or cos of power 1 at u and one at
-- v (u.key < v.key) and the rest; nil when the term is not such a product.
local function trig_pair(t)
  local tr, rest = {}, {}
  for _, x in ipairs(t.f) do
    if x.a.kind == "fn" and (x.a.fn == "sin" or x.a.fn == "cos") and x.p == 1 and #tr < 2 then tr[#tr + 1] = x.a
    else rest[#rest + 1] = x end
  end
  if #tr ~= 2 or tr[1].arg.key == tr[2].arg.key then return nil end
  if tr[1].arg.key > tr[2].arg.key then tr[1], tr[2] = tr[2], tr[1] end
  return tr[1], tr[2], rest
end

function M.angle_sums(P)
  if #P.terms < 2 then return nil end
  local index = {}
  for n, t in ipairs(P.terms) do
    local a, b, rest = trig_pair(t)
    if a then
      local key = a.arg.key .. "|" .. b.arg.key .. "|" .. term_key(rest)
      index[key] = index[key] or {}
      index[key][a.fn .. b.fn] = { n = n, c = t.c, rest = rest, u = a.arg, v = b.arg }
    end
  end
  for _, e in pairs(index) do
    local cc, ss, sc, cs = e.coscos, e.sinsin, e.sincos, e.cossin
    local combo
    if cc and ss and math.abs(cc.c) == math.abs(ss.c) then
      -- c (cos u cos v +- sin u sin v) = c cos(u -+ v)
      local arg = cc.c == ss.c and M.sub(cc.u, cc.v) or M.add(cc.u, cc.v)
      combo = { drop = { cc.n, ss.n }, c = cc.c, rest = cc.rest, fn = "cos", arg = arg }
    elseif sc and cs and math.abs(sc.c) == math.abs(cs.c) then
      -- c (sin u cos v -+ cos u sin v) = c sin(u -+ v)
      local arg = sc.c == -cs.c and M.sub(sc.u, sc.v) or M.add(sc.u, sc.v)
      combo = { drop = { sc.n, cs.n }, c = sc.c, rest = sc.rest, fn = "sin", arg = arg }
    end
    if combo then
      local map = {}
      for n, t in ipairs(P.terms) do
        if n ~= combo.drop[1] and n ~= combo.drop[2] then add_into(map, t, 1) end
      end
      local mono = make({ [term_key(combo.rest)] = { c = combo.c, f = combo.rest } })
      return sum(make(map), M.mul(mono, M.fn(combo.fn, combo.arg)))
    end
  end
  return nil
end

-- ------------------------------------------------------------------ --
-- From the graph

-- The polynomial of node `id` of a graph dump (core.mech compiled:nodes()),
-- memoized in `memo`; sym(input number) gives the symbol of an input.
function M.from_graph(nodes, id, sym, memo)
  local stack = { id }
  while #stack > 0 do
    local x = stack[#stack]
    if memo[x] then stack[#stack] = nil
    else
      local op, a, b, c = nodes.op[x + 1], nodes.a[x + 1], nodes.b[x + 1], nodes.c[x + 1]
      local need = {}
      if op ~= "const" and op ~= "input" then
        if a >= 0 and not memo[a] then need[#need + 1] = a end
        if b >= 0 and not memo[b] and op ~= "powc" then need[#need + 1] = b end
        if c >= 0 and not memo[c] then need[#need + 1] = c end
      end
      if #need > 0 then for _, y in ipairs(need) do stack[#stack + 1] = y end
      else
        stack[#stack] = nil
        local A, B = memo[a], memo[b]
        local v
        if op == "const" then v = const(nodes.v[x + 1])
        elseif op == "input" then v = sym(a)
        elseif op == "add" then v = M.add(A, B)
        elseif op == "sub" then v = M.sub(A, B)
        elseif op == "mul" then v = M.mul(A, B)
        elseif op == "div" then v = M.div(A, B)
        elseif op == "neg" then v = M.neg(A)
        elseif op == "powc" then v = M.powc(A, nodes.v[x + 1])
        elseif op == "pow" then v = M.binary("pow", A, B)
        elseif op == "fn" then v = M.fn(nodes.fn[x + 1], A)
        elseif op == "atan2" or op == "hypot" then v = M.binary(op, A, B)
        elseif op == "cmp" then v = M.cmp(nodes.fn[x + 1], A, B)
        elseif op == "select" then v = M.select(memo[c], A, B)
        else error("formula: unknown node " .. tostring(op)) end
        memo[x] = v
      end
    end
  end
  return memo[id]
end

-- ------------------------------------------------------------------ --
-- Printing

-- A printer: how each language writes symbols, numbers, products, powers,
-- quotients and functions.
local printers = {}

printers.text = {
  sym = function(a) return a.name end,
  mul = " ", fn = function(name, arg) return name .. "(" .. arg .. ")" end,
  pow = function(base, p) return base .. "^" .. p end,
  frac = function(num, den) return num .. " / " .. den end,
  paren = function(s) return "(" .. s .. ")" end,
  sqrt = function(s) return "sqrt(" .. s .. ")" end,
  bin = function(name, a, b) return name .. "(" .. a .. ", " .. b .. ")" end,
  powc = function(base, e) return base .. "^" .. e end,
  select = function(c, a, b) return "ifelse(" .. c .. ", " .. a .. ", " .. b .. ")" end,
  cmp = function(op, a, b)
    return a .. " " .. ({ lt = "<", le = "<=", gt = ">", ge = ">=", eq = "==", ne = "~=" })[op] .. " " .. b
  end,
}

printers.lua = {
  sym = function(a) return a.info and a.info.lua or a.name end,
  mul = " * ", fn = function(name, arg)
    if name == "sign" then return "nz.sign(" .. arg .. ")" end
    if name == "sinh" or name == "cosh" or name == "tanh" then return "nz." .. name .. "(" .. arg .. ")" end
    return "math." .. name .. "(" .. arg .. ")"
  end,
  pow = function(base, p) return base .. "^" .. p end,
  frac = function(num, den) return num .. " / " .. den end,
  paren = function(s) return "(" .. s .. ")" end,
  sqrt = function(s) return "math.sqrt(" .. s .. ")" end,
  bin = function(name, a, b)
    if name == "atan2" then return "math.atan(" .. a .. ", " .. b .. ")" end
    if name == "hypot" then return "nz.hypot(" .. a .. ", " .. b .. ")" end
    return "(" .. a .. ")^(" .. b .. ")"
  end,
  powc = function(base, e) return base .. "^" .. e end,
  select = function(c, a, b) return "((" .. c .. ") ~= 0 and (" .. a .. ") or (" .. b .. "))" end,
  cmp = function(op, a, b)
    return "((" .. a .. ") " .. ({ lt = "<", le = "<=", gt = ">", ge = ">=", eq = "==", ne = "~=" })[op] .. " (" .. b .. ") and 1 or 0)"
  end,
  explicit = true,   -- every product and power written out, no layout
}

local greek = { alpha = true, beta = true, gamma = true, delta = true, epsilon = true, zeta = true, eta = true,
  theta = true, iota = true, kappa = true, lambda = true, mu = true, nu = true, xi = true, pi = true, rho = true,
  sigma = true, tau = true, upsilon = true, phi = true, chi = true, psi = true, omega = true, Gamma = true,
  Delta = true, Theta = true, Lambda = true, Xi = true, Pi = true, Sigma = true, Phi = true, Psi = true, Omega = true }
local short = { th = "theta", ph = "varphi", phi = "varphi", psi = "psi", al = "alpha", be = "beta", ga = "gamma",
  om = "omega", w = "omega", la = "lambda", del = "delta", eps = "epsilon", ka = "kappa", sig = "sigma" }

-- A coordinate or parameter name in LaTeX: th1 -> \theta_{1}, x -> x, mass -> \mathrm{mass}.
function M.tex_name(name)
  local base, index = name:match("^(%a+)_?(%d*)$")
  if not base then return "\\mathrm{" .. name:gsub("_", "\\_") .. "}" end
  local g = short[base] or (greek[base] and base)
  local b = g and ("\\" .. g) or (#base == 1 and base or ("\\mathrm{" .. base .. "}"))
  return index ~= "" and (b .. "_{" .. index .. "}") or b
end

printers.tex = {
  sym = function(a)
    local info = a.info or {}
    if info.tex then return info.tex end   -- written out by its maker (a contact's force, N_{floor})
    local n = M.tex_name(info.base or a.name)
    local d = info.dots or 0
    if d == 1 and info.frozen then return "\\dot{" .. n .. "}_{0}" end   -- held in T_0 (R_1 of sys:show{n = 1})
    if d == 1 then return "\\dot{" .. n .. "}" end
    if d == 2 then return "\\ddot{" .. n .. "}" end
    if d >= 3 then return n .. "^{(" .. d .. ")}" end
    return n
  end,
  mul = " \\, ", fn = function(name, arg)
    local known = { sin = 1, cos = 1, tan = 1, exp = 1, log = 1, sinh = 1, cosh = 1, tanh = 1, arcsin = 1 }
    local n = ({ asin = "arcsin", acos = "arccos", atan = "arctan" })[name] or name
    if known[n] or n == "arccos" or n == "arctan" then return "\\" .. n .. "\\left(" .. arg .. "\\right)" end
    return "\\operatorname{" .. n .. "}\\left(" .. arg .. "\\right)"
  end,
  pow = function(base, p) return base .. "^{" .. p .. "}" end,
  frac = function(num, den) return "\\frac{" .. num .. "}{" .. den .. "}" end,
  paren = function(s) return "\\left(" .. s .. "\\right)" end,
  sqrt = function(s) return "\\sqrt{" .. s .. "}" end,
  bin = function(name, a, b)
    if name == "pow" then return "\\left(" .. a .. "\\right)^{" .. b .. "}" end
    return "\\operatorname{" .. name .. "}\\left(" .. a .. ", " .. b .. "\\right)"
  end,
  powc = function(base, e) return base .. "^{" .. e .. "}" end,
  select = function(c, a, b) return "\\begin{cases}" .. a .. " & " .. c .. "\\\\ " .. b .. " & \\text{otherwise}\\end{cases}" end,
  cmp = function(op, a, b)
    return a .. ({ lt = " < ", le = " \\le ", gt = " > ", ge = " \\ge ", eq = " = ", ne = " \\ne " })[op] .. b
  end,
}

M.printers = printers

local print_poly

-- An atom, printed; `names` maps atom keys to short names (where c1 = ...).
local function print_atom(a, pr, names)
  if names and names[a.key] then return names[a.key] end
  if a.kind == "sym" then return pr.sym(a) end
  if a.kind == "fn" then
    if a.fn == "sqrt" then return pr.sqrt(print_poly(a.arg, pr, names)) end
    return pr.fn(a.fn, print_poly(a.arg, pr, names))
  end
  if a.kind == "bin" then return pr.bin(a.fn, print_poly(a.a, pr, names), print_poly(a.b, pr, names)) end
  if a.kind == "powc" then return pr.powc(pr.paren(print_poly(a.base, pr, names)), M.number(a.exp)) end
  if a.kind == "group" then return pr.paren(print_poly(a.poly, pr, names)) end
  if a.kind == "select" then
    return pr.select(print_poly(a.c, pr, names), print_poly(a.a, pr, names), print_poly(a.b, pr, names))
  end
  if a.kind == "cmp" then return pr.cmp(a.op, print_poly(a.a, pr, names), print_poly(a.b, pr, names)) end
  error("formula: unknown atom " .. tostring(a.kind))
end

local function print_factor(x, pr, names, p)
  local s = print_atom(x.a, pr, names)
  if p == 1 then return s end
  return pr.pow(s, M.number(p))
end

-- The order of factors in a printed term, as a textbook writes them:
-- parameters, coordinates, functions, then velocities and accelerations.
local function category(a)
  if a.kind ~= "sym" then return 3 end
  local slot = a.info and a.info.slot
  if not slot then return 1 end
  return slot == 0 and 2 or 3 + slot
end
local function by_category(x, y)
  local cx, cy = category(x.a), category(y.a)
  if cx ~= cy then return cx < cy end
  local ix, iy = x.a.info and x.a.info.coord, y.a.info and y.a.info.coord
  if ix and iy and ix ~= iy then return ix < iy end      -- coordinates in their order
  return x.a.key < y.a.key
end

-- Where a term stands in a sum: its highest category first, then by the
-- first coordinate of that category (x' before y').
local function term_rank(t)
  local top, coord = 0, math.huge
  for _, x in ipairs(t.f) do
    local c = category(x.a)
    local i = x.a.info and x.a.info.coord or math.huge
    if c > top then top, coord = c, i elseif c == top then coord = math.min(coord, i) end
  end
  return top, coord
end

-- A term without its sign: coefficient and factors, a quotient when some
-- power is negative.
local function print_term(t, pr, names)
  local c = math.abs(t.c)
  local num, den = {}, {}
  local f = { table.unpack(t.f) }
  table.sort(f, by_category)
  for _, x in ipairs(f) do
    if x.p > 0 then num[#num + 1] = print_factor(x, pr, names, x.p)
    else den[#den + 1] = print_factor(x, pr, names, -x.p) end
  end
  local cs = M.number(c)
  if pr.explicit then
    local parts = {}
    if c ~= 1 or #num == 0 then parts[1] = cs end
    for _, s in ipairs(num) do parts[#parts + 1] = s end
    local s = table.concat(parts, pr.mul)
    if #den > 0 then s = s .. " / (" .. table.concat(den, pr.mul) .. ")" end
    return s
  end
  if c ~= 1 then table.insert(num, 1, cs) end
  local n = #num > 0 and table.concat(num, pr.mul) or "1"
  if #den == 0 then return n end
  return pr.frac(n, table.concat(den, pr.mul))
end

-- Factors every term has (symbols and functions to their smallest power),
-- and the coefficients' common size when they agree up to sign.
local function common_factor(P)
  if #P.terms < 2 then return nil end
  local lowest
  for _, t in ipairs(P.terms) do
    local here = {}
    for _, x in ipairs(t.f) do if x.p > 0 and x.a.kind ~= "group" then here[x.a.key] = x end end
    if not lowest then
      lowest = {}
      for k, x in pairs(here) do lowest[k] = { a = x.a, p = x.p } end
    else
      for k, x in pairs(lowest) do
        if not here[k] then lowest[k] = nil else x.p = math.min(x.p, here[k].p) end
      end
    end
  end
  local c0 = math.abs(P.terms[1].c)
  for _, t in ipairs(P.terms) do if math.abs(t.c) ~= c0 then c0 = 1 end end
  local f = {}
  for _, x in pairs(lowest) do f[#f + 1] = x end
  if #f == 0 and c0 == 1 then return nil end
  table.sort(f, function(u, v) return u.a.key < v.a.key end)
  local divisor = make({ [term_key(f)] = { c = c0, f = f } })
  local inv = {}
  for i, x in ipairs(f) do inv[i] = { a = x.a, p = -x.p } end
  local rest = M.mul(P, make({ [term_key(inv)] = { c = 1 / c0, f = inv } }))
  return divisor, rest
end

print_poly = function(P, pr, names, factor, flat)
  if #P.terms == 0 then return "0" end
  if factor and not pr.explicit then
    local d, rest = common_factor(P)
    if d then
      return print_term(d.terms[1], pr, names) .. pr.mul .. pr.paren(print_poly(rest, pr, names))
    end
  end
  local out = {}
  local terms = { table.unpack(P.terms) }
  if not P.ordered then
    table.sort(terms, function(x, y)
      local tx, cx = term_rank(x)
      local ty, cy = term_rank(y)
      if tx ~= ty then return tx > ty end
      if cx ~= cy then return cx < cy end
      return x.key < y.key
    end)
  end
  -- like terms in the textbook's sense: the same state part (coordinates,
  -- functions, rates) with different parameters, written once with their
  -- parameters' sum: g l1 (m1 + m2) sin(th1)
  local groups, order = {}, {}
  for _, t in ipairs(terms) do
    local state, params = {}, {}
    for _, x in ipairs(t.f) do
      if flat or pr.explicit or category(x.a) >= 2 then state[#state + 1] = x else params[#params + 1] = x end
    end
    local key = term_key(state)
    if flat or pr.explicit then key = t.key end
    if not groups[key] then groups[key] = { state = state, map = {} }; order[#order + 1] = key end
    add_into(groups[key].map, { c = t.c, f = params }, 1)
  end
  local n = 0
  for _, key in ipairs(order) do
    local gr = groups[key]
    local C = make(gr.map)
    n = n + 1
    if #C.terms == 1 then
      local t = { c = C.terms[1].c, f = mul_factors(C.terms[1].f, gr.state) }
      local s = print_term(t, pr, names)
      if n == 1 then out[1] = (t.c < 0 and "-" or "") .. s
      else out[#out + 1] = (t.c < 0 and " - " or " + ") .. s end
    elseif #C.terms > 1 then
      -- every parameter negative: the sign in front, -g l1 (m1 + m2) sin(th1)
      local neg = true
      for _, t in ipairs(C.terms) do neg = neg and t.c < 0 end
      if neg then C = M.neg(C) end
      local coef = print_poly(C, pr, names, true, true)
      local s = coef
      if #gr.state > 0 then
        if coef:find(" [%+%-] ") and not coef:find("^[^(]*%(.*%)$") then coef = pr.paren(coef) end
        s = coef .. pr.mul .. print_term({ c = 1, f = gr.state }, pr, names)
      end
      out[#out + 1] = (n == 1 and (neg and "-" or "") or (neg and " - " or " + ")) .. s
    else
      n = n - 1
    end
  end
  if #out == 0 then return "0" end
  return table.concat(out)
end

-- P as text in language `lang` (text, tex, lua); factor: take a common
-- factor out; names: {atom key -> short name}.
function M.print(P, lang, names, factor)
  return print_poly(P, assert(printers[lang], "formula: unknown language"), names, factor)
end

-- Sort the terms of P for an equation: those with a highest derivative
-- (rank(atom) > 0) first, by rank, then the rest, each in key order.
function M.ordered(P, rank)
  local function r(t)
    local best = 0
    for _, x in ipairs(t.f) do best = math.max(best, rank(x.a) or 0) end
    return best
  end
  local terms = { table.unpack(P.terms) }
  table.sort(terms, function(x, y)
    local rx, ry = r(x), r(y)
    if rx ~= ry then return rx > ry end
    return x.key < y.key
  end)
  return { terms = terms, key = P.key, ordered = true }
end

-- The atoms under P (fn, bin, powc, group) with how often they occur, for naming.
function M.count_atoms(P, counts)
  for _, t in ipairs(P.terms) do
    for _, x in ipairs(t.f) do
      local a = x.a
      counts[a.key] = counts[a.key] or { atom = a, n = 0 }
      counts[a.key].n = counts[a.key].n + 1
      if a.arg then M.count_atoms(a.arg, counts) end
      if a.kind == "bin" or a.kind == "cmp" then M.count_atoms(a.a, counts); M.count_atoms(a.b, counts) end
      if a.kind == "powc" then M.count_atoms(a.base, counts) end
      if a.kind == "group" then M.count_atoms(a.poly, counts) end
    end
  end
  return counts
end

M.print_atom = print_atom
return M
