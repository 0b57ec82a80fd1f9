-- nz/system.lua - nz.system{...}: a mechanical system and its generalized
-- equations of motion of any order (THEORY.md §2-§5, §9, §11).
--
-- The definition is validated here, then handed to the C mechanics
-- (core.mech) as a plain table of piece lists; the C side never sees this
-- class.  Pieces: F = T and L functions (the "kinetic" part the forms
-- differentiate), T, V, Q, S (acceleration energy, from particles).
local core = require "nz.core"
local bodies = require "nz.bodies"
local repl = require "nz.repl"

local mech = core.mech
local System = { __name = "nz.system" }
System.__index = System

local M = { System = System }

local known_fields = {
  coords = true, T = true, V = true, Q = true, L = true, S = true, params = true,
  name = true, bodies = true,
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
      error(("nz.system '%s': coords[%d] must be a name (a string)"):format(name, i), 2)
    end
    if seen[c] then error(("nz.system '%s': coordinate '%s' appears twice"):format(name, c), 2) end
    seen[c] = true
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
    error(("nz.system '%s': give the kinetic energy T (or a Lagrangian L)"):format(name), 2)
  end
  local F, Flab = {}, {}
  append(F, Flab, T, lab.T)
  append(F, Flab, L, lab.L)

  local self = setmetatable({
    name = name,
    coords = { table.unpack(coords) },
    k = #coords,
    params = def.params or {},
    pieces = { T = #T, V = #V, Q = #Q, L = #L, S = #S },
  }, System)
  -- What the C mechanics reads (params is the same table: change a mass in
  -- sys.params and the next call sees it).
  self.engine = {
    k = #coords, name = name, coords = self.coords, params = self.params,
    F = F, T = T, V = V, Q = Q, S = S,
    labels = { F = Flab, T = lab.T, V = lab.V, Q = lab.Q, S = lab.S },
  }
  return self
end

-- ------------------------------------------------------------------ --
-- Equations                                                            --

local form_set = {}
for _, f in ipairs(mech.forms()) do form_set[f] = true end
M.forms = mech.forms()

-- residual(n, t, q, qd, qdd [, opts]); opts: a form name, or a table
-- {form = ..., higher = {q3, q4, ...}} (derivatives beyond qdd that the jets
-- use; 0 when not given: the result does not depend on them).
function System:residual(n, t, q, qd, qdd, opts)
  local form, higher = "generalized", nil
  if type(opts) == "string" then form = opts
  elseif type(opts) == "table" then form, higher = opts.form or form, opts.higher
  elseif opts ~= nil then error("bad argument #6 to 'residual' (form name or options table expected)", 2) end
  if not form_set[form] then
    error(("bad argument to 'residual' (unknown form '%s'; forms: %s)"):format(
      tostring(form), table.concat(M.forms, ", ")), 2)
  end
  self.params = self.params   -- (params is shared with the engine table)
  return (mech.residual(self.engine, form, n, t, q, qd, qdd, higher))
end

-- M(t, q [, qd]) and h(t, q, qd) of M qdd + h = 0 (h includes -Q and dV/dq).
function System:mass(t, q, qd)
  local Mm = mech.mass_bias(self.engine, t, q, qd)
  return Mm
end

function System:bias(t, q, qd)
  local _, h = mech.mass_bias(self.engine, t, q, qd)
  return h
end

function System:mass_bias(t, q, qd) return mech.mass_bias(self.engine, t, q, qd) end

function System:accel(t, q, qd) return mech.accel(self.engine, t, q, qd) end

-- Returns T + V (nil when the system is given by L without T) and the
-- generalized energy H = sum qd dL/dqd - L.
function System:energy(t, q, qd)
  local T, V, _, H = mech.energy(self.engine, t, q, qd)
  return T and (T + V) or nil, H
end

-- ------------------------------------------------------------------ --
-- Printing                                                             --

local principles = {
  [1] = "Nielsen's equations (Jourdain's principle)",
  [2] = "Tsenov's equations (Gauss's principle)",
  [3] = "equations with the jerk q''' (generalized Gauss principle of order 3)",
}
function M.principle(n)
  return principles[n] or ("generalized Lagrange equations of order %d (d'Alembert principle for the %d-th derivatives)"):format(n, n)
end

local function fmt(x) return ("%.10g"):format(x) end

local function vector_text(v)
  local parts = {}
  for i = 1, #v do parts[i] = repl.number(v[i]) end
  return "{" .. table.concat(parts, ", ") .. "}"
end

-- Aligned table of rows of strings; the first row is the header.
function M.table_text(rows, indent)
  local widths = {}
  for _, row in ipairs(rows) do
    for c, cell in ipairs(row) do widths[c] = math.max(widths[c] or 0, #cell) end
  end
  local out = {}
  for r, row in ipairs(rows) do
    local cells = {}
    for c, cell in ipairs(row) do
      cells[c] = c == 1 and cell .. (" "):rep(widths[c] - #cell) or (" "):rep(widths[c] - #cell) .. cell
    end
    out[#out + 1] = (indent or "  ") .. table.concat(cells, "   ")
    if r == 1 then
      local rule = {}
      for c = 1, #row do rule[c] = ("-"):rep(widths[c]) end
      out[#out + 1] = (indent or "  ") .. table.concat(rule, "   ")
    end
  end
  return table.concat(out, "\n")
end

-- The terms of (3.1) of order n at a state, per coordinate.  Without qdd,
-- the accelerations of the motion are used (the residual is then ~0).
function System:equations(n, t, q, qd, qdd, opts)
  n = n or 1
  t = t or 0
  if q == nil then error("bad argument to 'equations' (a state t, q, qd is needed)", 2) end
  qd = qd or {}
  if #qd == 0 then for i = 1, self.k do qd[i] = 0 end end
  local given = qdd ~= nil
  qdd = qdd or self:accel(t, q, qd)
  local r, terms = mech.residual(self.engine, "generalized", n, t, q, qd, qdd, nil, true)
  local lines = {
    ("System '%s', order n = %d: %s"):format(self.name, n, M.principle(n)),
    ("  (1/%d) (dT^(%d)/dq^(%d) - %d dT/dq) - Q = residual,  Q includes -dV/dq"):format(n, n, n, n + 1),
    ("  at t = %s, q = %s, qd = %s, qdd = %s%s"):format(repl.number(t), vector_text(q), vector_text(qd),
      vector_text(qdd), given and "" or " (the system's accelerations)"),
    "",
  }
  local rows = { { "coordinate", ("dT^(%d)/dq^(%d)"):format(n, n), ("%d dT/dq"):format(n + 1), "Q", "residual" } }
  for i = 1, self.k do
    rows[#rows + 1] = { self.coords[i], fmt(terms.dFn[i]), fmt((n + 1) * terms.dFq[i]), fmt(terms.force[i]),
      ("%.3e"):format(r[i]) }
  end
  lines[#lines + 1] = M.table_text(rows)
  local text = table.concat(lines, "\n")
  if opts and opts.quiet then return text, r end
  print(text)
  return nil
end

function System:__tostring()
  local have = {}
  for _, p in ipairs{ "T", "L", "V", "Q", "S" } do
    if self.pieces[p] > 0 then have[#have + 1] = self.pieces[p] > 1 and ("%s (%d pieces)"):format(p, self.pieces[p]) or p end
  end
  local params = {}
  for k, v in pairs(self.params) do params[#params + 1] = ("%s = %s"):format(k, tostring(v)) end
  table.sort(params)
  return ("nz.system '%s': %d coordinate%s (%s); %s%s"):format(self.name, self.k, self.k == 1 and "" or "s",
    table.concat(self.coords, ", "), table.concat(have, ", "),
    #params > 0 and ("; params {" .. table.concat(params, ", ") .. "}") or "")
end

-- ------------------------------------------------------------------ --
-- The operators of §5 on a function f(t, q, qd [, params])             --

local function operator(which, m, f, t, q, qd, qdd, higher)
  if type(f) ~= "function" then error("bad argument #2 (a function f(t, q, qd) expected)", 3) end
  if type(q) ~= "table" or #q == 0 then error("bad argument #4 (q: a table of numbers expected)", 3) end
  local engine = { k = #q, name = "operator", F = { f }, T = {}, V = {}, Q = {}, S = {}, params = {},
    labels = { F = { "f" } } }
  return mech.operator(engine, which, m, t, q, qd, qdd, higher)
end

function M.nielsen_op(m, f, t, q, qd, qdd, higher) return operator("N", m, f, t, q, qd, qdd, higher) end
function M.euler_op(m, f, t, q, qd, qdd, higher) return operator("E", m, f, t, q, qd, qdd, higher) end
function M.top_coefficient(m, f, t, q, qd, qdd, higher) return operator("top", m, f, t, q, qd, qdd, higher) end
function M.partial(m, f, t, q, qd, qdd, higher) return operator("partial", m, f, t, q, qd, qdd, higher) end

return M
