-- tests/fuzz/systems.lua - random mechanical systems over every operation a
-- recording holds (README, "Recorded functions"), written as Lua source, so
-- that a system the differential test finds at fault prints as the code
-- that reproduces it.
--
-- A system has k = 1..3 coordinates, params {a, b}, a kinetic energy whose
-- mass matrix is positive definite whatever the random parts (constant, or
-- diagonal 1 + tanh(E)/2 with couplings tanh(E)/10), a term linear in the
-- velocities, a potential, sometimes forces Q and, for k >= 2, sometimes a
-- holonomic or a (linear) nonholonomic constraint.  E are random
-- expressions of t, q (and qd in Q) and the params, up to a depth.
local M = {}

-- A generator of its own (xorshift64*): the same seed gives the same
-- systems whatever else draws random numbers.
function M.rng(seed)
  local s = seed ~ 0x9E3779B97F4A7C15
  if s == 0 then s = 1 end
  local r = {}
  function r.next()
    s = s ~ (s >> 12); s = s ~ (s << 25); s = s ~ (s >> 27)
    return ((s * 2685821657736338717) >> 11) / 9007199254740992.0
  end
  function r.uniform(a, b) return a + (b - a) * r.next() end
  function r.int(a, b) return a + math.floor(r.next() * (b - a + 1)) end
  function r.pick(list) return list[r.int(1, #list)] end
  function r.chance(p) return r.next() < p end
  return r
end

-- A number as Lua source that reads back exactly (-0.0 included).
local function num(v)
  if v == 0 and 1 / v < 0 then return "(-0.0)" end
  local s = ("%.17g"):format(v)
  return v < 0 and "(" .. s .. ")" or s
end
M.num = num

-- A number as a float literal (1.0, not the integer 1).
local function float(v)
  local s = num(v)
  return s:find("[%.e]") and s or s:gsub("^(%(?%-?%d+)", "%1.0")
end

local CONSTANTS = { 0, -0.0, 1, -1, 0.5, 2, 0.3, 0.7, 3 }
local UNARY = { "exp", "log", "sqrt", "sin", "cos", "tan", "asin", "acos", "atan", "sinh", "cosh", "tanh",
                "abs", "sign" }
local POWERS = { 2, 3, 0.5, 1.5, -1, 0, 1, -2 }
local COMPARE = { "lt", "le", "gt", "ge" }

-- A random expression of the variables vars (source names: "t", "q[1]",
-- ...), depth levels deep at most.
local function expr(r, vars, depth)
  if depth <= 0 or r.chance(0.25) then
    if r.chance(0.2) then
      return num(r.chance(0.5) and r.pick(CONSTANTS) or math.floor(r.uniform(-3, 3) * 8 + 0.5) / 8)
    end
    return r.pick(vars)
  end
  local d = depth - 1
  local function e() return expr(r, vars, d) end
  -- an exponent that reads the state: x^p with p made of parameters only
  -- is x^y of jets in the graph and the power of a number in Lua, which
  -- round differently (README, "Recorded functions")
  local function exponent()
    local y = e()
    local state = y:find("q%[") or y:find("qd%[") or y:find("%f[%w_.]t%f[^%w_]")
    return (state or y:find("^%(?%-?[%d.]+%)?$")) and y or "t"
  end
  local kind = r.int(1, 12)
  if kind <= 3 then return ("(%s %s %s)"):format(e(), r.pick{ "+", "-", "*", "*", "/" }, e())
  elseif kind == 4 then return ("nz.%s(%s)"):format(r.pick(UNARY), e())
  elseif kind == 5 then return ("(%s)^%s"):format(e(), num(r.pick(POWERS)))
  elseif kind == 6 then return ("(-%s)"):format(e())
  elseif kind == 7 then
    local f = r.pick{ "atan2", "hypot", "max", "min", "pow" }
    return ("nz.%s(%s, %s)"):format(f, e(), f == "pow" and exponent() or e())
  elseif kind == 8 then return ("nz.%s(%s, %s)"):format(r.pick(COMPARE), e(), e())
  elseif kind == 9 then
    return ("nz.ifelse(nz.%s(%s, %s), %s, %s)"):format(r.pick(COMPARE), e(), e(), e(), e())
  elseif kind == 10 then
    local lo = math.floor(r.uniform(-2, 1) * 4) / 4
    return ("nz.clamp(%s, %s, %s)"):format(e(), num(lo), num(lo + r.pick{ 0, 0.5, 1, 2 }))
  elseif kind == 11 then return ("nz.smooth_abs(%s, %s)"):format(e(), num(r.pick{ 0.1, 1 }))
  end
  -- like terms and signed zeros, which simplifications once got wrong;
  -- like terms only where their rounding (1e-16, where exact arithmetic
  -- gives 0) decides a branch: a function that divides by it is as
  -- ill-conditioned on the jets as anywhere
  local x = e()
  return r.pick{ ("nz.sign(%s - 0.3 * %s - 0.7 * %s)"):format(x, x, x), ("(%s * 0)"):format(x),
                 ("nz.atan2(%s - 0.3 * %s - 0.7 * %s, -1)"):format(x, x, x),
                 ("(%s * (-0.0))"):format(x), ("(0 + %s)"):format(x),
                 ("(%s)^(%s - %s)"):format(x, exponent(), exponent()) }
end
M.expr = expr

local function names(prefix, k)
  local out = {}
  for i = 1, k do out[i] = ("%s[%d]"):format(prefix, i) end
  return out
end

-- The variables a function of (t, q [, qd]) may read.
local function vars_of(k, with_qd)
  local v = { "t", "p.a", "p.b" }
  for _, n in ipairs(names("q", k)) do v[#v + 1] = n end
  if with_qd then for _, n in ipairs(names("qd", k)) do v[#v + 1] = n end end
  return v
end

-- A random system: {source = Lua text of the definition, k =, make =
-- function(compile) -> the nz.system}.
function M.system(r, depth)
  depth = depth or 3
  local k = r.int(1, 3)
  local coords = {}
  for i = 1, k do coords[i] = ("'x%d'"):format(i) end
  local vq, vqd = vars_of(k, false), vars_of(k, true)
  local function E(vars) return expr(r, vars, depth) end
  -- T: positive definite whatever the random parts
  local terms = {}
  local constant_M = r.chance(0.4)
  for i = 1, k do
    local m = constant_M and num(r.pick{ 1, 2, 0.5 }) or ("(1 + 0.5 * nz.tanh(%s))"):format(E(vq))
    terms[#terms + 1] = ("0.5 * %s * qd[%d]^2"):format(m, i)
    if not constant_M then
      for j = i + 1, k do terms[#terms + 1] = ("0.1 * nz.tanh(%s) * qd[%d] * qd[%d]"):format(E(vq), i, j) end
    end
    if r.chance(0.3) then terms[#terms + 1] = ("(%s) * qd[%d]"):format(E(vq), i) end
  end
  local lines = {
    "local nz = ...",
    "return function(compile) return nz.system{ name = 'fuzzed', compile = compile,",
    -- params as floats: a Lua integer has no -0 (-p.b is +0 for b = 0)
    ("  coords = { %s }, params = { a = %s, b = %s },"):format(table.concat(coords, ", "),
      float(math.floor(r.uniform(-2, 2) * 8 + 0.5) / 8), float(r.pick{ 0, 1, 0.5, -1.5 })),
    ("  T = function(t, q, qd, p) return %s end,"):format(table.concat(terms, " + ")),
    ("  V = function(t, q, p) return %s end,"):format(E(vq)),
  }
  if r.chance(0.4) then
    local f = {}
    for i = 1, k do f[i] = E(vqd) end
    lines[#lines + 1] = ("  Q = function(t, q, qd, p) return { %s } end,"):format(table.concat(f, ", "))
  end
  local constrained = k >= 2 and r.chance(0.3)
  if constrained then
    -- constants for the params: a constraint's last argument is params only
    -- from the sixth on (README, "Constraints")
    local cq = vars_of(1, false)
    for i, v in ipairs(cq) do if v:find("^p%.") then cq[i] = "0.5" end end
    local phi = r.chance(0.5) and ("q[2] - (%s)"):format(E(cq))
      or ("qd[2] - (%s) * qd[1] - (%s)"):format(E(cq), E(cq))
    lines[#lines + 1] = ("  constraints = { function(t, q, qd) return %s end },"):format(phi)
  end
  lines[#lines + 1] = "} end"
  local source = table.concat(lines, "\n")
  local make = assert(load(source, "=fuzzed system", "t"))(rawget(_G, "nz") or require("nz"))
  -- a run crosses the switches of a branch or a kink where a last-bit
  -- difference of the state (the graph's derivatives and the jets' differ
  -- by rounding) takes the other side: only a smooth system is run
  local smooth = true
  for _, f in ipairs{ "sign", "gt", "lt", "ge", "le", "ifelse", "max", "min", "clamp", "abs" } do
    if source:find("nz%." .. f .. "%(") then smooth = false end
  end
  return { source = source, k = k, constrained = constrained, constant_M = constant_M, smooth = smooth, make = make }
end

-- States to compare at: random ones, and boundary ones where branches tie
-- and functions meet their singular points (0, -0.0, +-1).
function M.states(r, k, n_random, n_boundary)
  local out = {}
  for _ = 1, n_random do
    local q, qd = {}, {}
    for i = 1, k do q[i], qd[i] = r.uniform(-1.5, 1.5), r.uniform(-1.5, 1.5) end
    out[#out + 1] = { t = r.uniform(-1, 2), q = q, qd = qd }
  end
  for _ = 1, n_boundary do
    local q, qd = {}, {}
    for i = 1, k do q[i], qd[i] = r.pick{ 0, -0.0, 1, -1, 0.5 }, r.pick{ 0, 1, -1 } end
    out[#out + 1] = { t = r.pick{ 0, 1, 0.5, -0.0 }, q = q, qd = qd }
  end
  return out
end

return M
