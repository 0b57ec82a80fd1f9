-- nz/model/hyperdual.lua - numbers v + eta d with eta^2 = 0, where v and d are
-- numbers or jets (which carry their own tangents).
--
-- Why: a point's velocity is the derivative of its position r(t, q) along
-- q' (r' = dr/dq q' + dr/dt).  T(t, q, q') is evaluated on jets that already
-- carry tangent directions, and the engine needs the tangents of r' with
-- respect to q and q' too: a second, independent infinitesimal eta whose
-- products with the jets' own directions are kept.  Evaluating r at
-- (t + eta, q + eta q') gives r + eta r' exactly.
local core = require "nz.core"

local HD = { __name = "nz.hyperdual" }
HD.__index = HD

local function make(v, d) return setmetatable({ v = v, d = d }, HD) end
local function is_hd(x) return getmetatable(x) == HD end
local function parts(x) if is_hd(x) then return x.v, x.d end return x, 0 end

HD.__add = function(a, b)
  local av, ad = parts(a); local bv, bd = parts(b)
  return make(av + bv, ad + bd)
end
HD.__sub = function(a, b)
  local av, ad = parts(a); local bv, bd = parts(b)
  return make(av - bv, ad - bd)
end
HD.__mul = function(a, b)
  local av, ad = parts(a); local bv, bd = parts(b)
  return make(av * bv, ad * bv + av * bd)
end
HD.__div = function(a, b)
  local av, ad = parts(a); local bv, bd = parts(b)
  local v = av / bv
  return make(v, (ad - v * bd) / bv)
end
HD.__unm = function(a) return make(-a.v, -a.d) end
HD.__pow = function(a, b)
  if is_hd(b) then return HD.exp(b * HD.log(a)) end
  local av, ad = parts(a)
  if b == 0 then return 1 end
  return make(core.pow(av, b), b * core.pow(av, b - 1) * ad)
end
HD.__lt = function(a, b) return (parts(a)) < (parts(b)) end
HD.__le = function(a, b) return (parts(a)) <= (parts(b)) end
HD.__tostring = function(a) return ("hyperdual(%s + eta %s)"):format(tostring(a.v), tostring(a.d)) end

-- Each function: f(v + eta d) = f(v) + eta f'(v) d.
function HD.exp(a) local e = core.exp(a.v); return make(e, e * a.d) end
function HD.log(a) return make(core.log(a.v), a.d / a.v) end
function HD.sqrt(a) local s = core.sqrt(a.v); return make(s, a.d / (2 * s)) end
function HD.sin(a) return make(core.sin(a.v), core.cos(a.v) * a.d) end
function HD.cos(a) return make(core.cos(a.v), -core.sin(a.v) * a.d) end
function HD.tan(a) local t = core.tan(a.v); return make(t, (1 + t * t) * a.d) end
function HD.asin(a) return make(core.asin(a.v), a.d / core.sqrt(1 - a.v * a.v)) end
function HD.acos(a) return make(core.acos(a.v), -a.d / core.sqrt(1 - a.v * a.v)) end
function HD.atan(a) return make(core.atan(a.v), a.d / (1 + a.v * a.v)) end
function HD.sinh(a) return make(core.sinh(a.v), core.cosh(a.v) * a.d) end
function HD.cosh(a) return make(core.cosh(a.v), core.sinh(a.v) * a.d) end
function HD.tanh(a) local t = core.tanh(a.v); return make(t, (1 - t * t) * a.d) end
function HD.abs(a) return (parts(a)) < 0 and -a or a end
function HD.atan2(y, x)
  local yv, yd = parts(y); local xv, xd = parts(x)
  return make(core.atan2(yv, xv), (xv * yd - yv * xd) / (xv * xv + yv * yv))
end
function HD.hypot(x, y)
  local xv, xd = parts(x); local yv, yd = parts(y)
  local h = core.hypot(xv, yv)
  return make(h, (xv * xd + yv * yd) / h)
end

-- Branches (nz.ifelse, nz.max, ...).  A comparison looks at v alone and
-- gives a plain constant (its eta part, the derivative of a step, is 0); a
-- selection takes v and d from the same branch, so that the eta part is the
-- derivative of the branch taken.
local function value_part(x) return (parts(x)) end
for _, name in ipairs { "lt", "le", "gt", "ge" } do
  HD[name] = function(a, b) return core[name](value_part(a), value_part(b)) end
end
function HD.sign(a) return core.sign(value_part(a)) end
function HD.ifelse(c, a, b)
  local cv = value_part(c)
  local av, ad = parts(a); local bv, bd = parts(b)
  return make(core.ifelse(cv, av, bv), core.ifelse(cv, ad, bd))
end
function HD.max(a, b) return HD.ifelse(HD.ge(a, b), a, b) end
function HD.min(a, b) return HD.ifelse(HD.le(a, b), a, b) end
-- The same choices as nz.clamp in C: lo where x < lo, hi where x > hi, else x.
function HD.clamp(x, lo, hi)
  local lov, hiv = value_part(lo), value_part(hi)
  core.clamp(lov, lov, hiv)   -- the check lo <= hi, with C's message
  return HD.ifelse(HD.lt(x, lo), lo, HD.ifelse(HD.gt(x, hi), hi, x))
end

return { new = make, is = is_hd, parts = parts }
