-- nz/help.lua - nz.help(): what the module offers, and one function explained.
--
-- Every public name of nz has one entry here (a test checks both directions),
-- so the list a user sees is the module as it is.
local M = {}

-- Sections in the order they are listed.
local sections = {
  { id = "jets", title = "Jets: truncated Taylor series with tangent (dual) directions" },
  { id = "functions", title = "Functions of numbers and jets (numbers give numbers)" },
  { id = "session", title = "Session" },
}

local entries = {
  { name = "jet", section = "jets", usage = "nz.jet(t0, order [, d, D])  |  nz.jet{c0, c1, ...}",
    summary = "make a jet: the variable t0 + (t - t0), or one from its coefficients",
    text = [[
A jet is a truncated Taylor series in normalized coefficients c_0..c_K,
c_j = f^(j)(t0) / j!, optionally carrying D tangent (dual) directions, each
itself a series: the partial derivatives of the coefficients along that
direction.  Orders up to 1024 and up to 1024 directions are accepted.

  nz.jet(t0, K)          the variable t of order K at t0 (c = {t0, 1, 0, ...})
  nz.jet(t0, K, d, D)    the same, with tangent direction d of D seeded to 1
  nz.jet{c0, c1, ..., order = K, tangents = {{...}, ...}}
                         explicit coefficients (missing ones are zero)

Methods:  x:coef(j)  normalized coefficient c_j     x:deriv(j)  j! c_j
          x:order()  K       x:value()  c_0          x:coefs()   {c_0, ..., c_K}
          x:ntangents()      x:tangent(d)  the series of direction d as a jet
Operators + - * / ^ and unary minus mix jets and numbers in either order.
Comparisons < <= == compare values (c_0); note that Lua never calls == between
a jet and a number, so compare x:value() with a number.
A result combines operands of different orders at the lower order, and of
different tangent counts with the larger count (a missing direction is zero).
Outside a function's domain (log of a non-positive value, sqrt at 0 with
derivatives, division by a series with zero constant term) an error names the
function and the value: never a silent NaN or infinity.

Example:  t = nz.jet(0, 5); print(nz.exp(t))   --> jet{1, 1, 0.5, ...}]] },
  { name = "dual", section = "jets", usage = "nz.dual(v, d [, D])",
    summary = "the dual number v + eps_d (a jet of order 0 with D directions)",
    text = [[
Dual numbers are the jets of order 0.  nz.dual(2, 1, 3) is 2 + eps_1 with three
directions; f(x):tangent(1):value() is then df/dx at 2.]] },
  { name = "isjet", section = "jets", usage = "nz.isjet(v)", summary = "true if v is a jet" },
  { name = "exp", section = "functions", usage = "nz.exp(x)", summary = "exponential" },
  { name = "log", section = "functions", usage = "nz.log(x)", summary = "natural logarithm (x > 0)" },
  { name = "sqrt", section = "functions", usage = "nz.sqrt(x)",
    summary = "square root (x >= 0; x > 0 for a jet with derivatives)" },
  { name = "pow", section = "functions", usage = "nz.pow(x, y)",
    summary = "x^y: integer, real or jet exponent (same as the ^ operator)" },
  { name = "sin", section = "functions", usage = "nz.sin(x)", summary = "sine" },
  { name = "cos", section = "functions", usage = "nz.cos(x)", summary = "cosine" },
  { name = "tan", section = "functions", usage = "nz.tan(x)", summary = "tangent" },
  { name = "asin", section = "functions", usage = "nz.asin(x)", summary = "arc sine (|x| <= 1)" },
  { name = "acos", section = "functions", usage = "nz.acos(x)", summary = "arc cosine (|x| <= 1)" },
  { name = "atan", section = "functions", usage = "nz.atan(x)", summary = "arc tangent" },
  { name = "atan2", section = "functions", usage = "nz.atan2(y, x)",
    summary = "angle of the point (x, y), in (-pi, pi]" },
  { name = "sinh", section = "functions", usage = "nz.sinh(x)", summary = "hyperbolic sine" },
  { name = "cosh", section = "functions", usage = "nz.cosh(x)", summary = "hyperbolic cosine" },
  { name = "tanh", section = "functions", usage = "nz.tanh(x)", summary = "hyperbolic tangent" },
  { name = "abs", section = "functions", usage = "nz.abs(x)",
    summary = "absolute value (not differentiable at 0)" },
  { name = "hypot", section = "functions", usage = "nz.hypot(x, y)",
    summary = "sqrt(x^2 + y^2) without overflow" },
  { name = "help", section = "session", usage = "nz.help([f])",
    summary = "list what nz offers, or explain one function (help(nz.jet))" },
  { name = "version", section = "session", usage = "nz.version", summary = "the version string" },
}

M.entries = entries

local function find(nz, what)
  for _, e in ipairs(entries) do
    if what == e.name or (type(what) ~= "string" and rawequal(nz[e.name], what)) then return e end
  end
end

local function listing(nz)
  local out = { ("nz %s: analytical mechanics with Taylor jets.  help(f) explains f."):format(nz.version) }
  for _, s in ipairs(sections) do
    out[#out + 1] = ""
    out[#out + 1] = s.title
    for _, e in ipairs(entries) do
      if e.section == s.id then out[#out + 1] = ("  %-28s %s"):format(e.usage:match("^[^|]*"):gsub("%s+$", ""), e.summary) end
    end
  end
  return table.concat(out, "\n")
end

-- bind(nz) returns the help function of that module table.
function M.bind(nz)
  return function(what, opts)
    local text
    if what == nil then
      text = listing(nz)
    else
      local e = find(nz, what)
      if not e then
        error(("no help for %s: help() lists what nz offers"):format(
          type(what) == "string" and ("'" .. what .. "'") or ("this " .. type(what))), 2)
      end
      text = ("%s\n  %s\n%s"):format(e.usage, e.summary, e.text and ("\n" .. e.text) or "")
    end
    if opts and opts.quiet then return text end
    print(text)
    return nil
  end
end

return M
