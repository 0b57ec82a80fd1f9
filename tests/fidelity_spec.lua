-- fidelity_spec.lua - a recorded function never answers differently from
-- the same function in Lua.
--
-- Each system is made twice, recorded (the default) and with
-- compile = false (every function run by Lua on jets): the two must give
-- the same accelerations, M, h, values and errors, and where a function
-- cannot be recorded faithfully it falls back to Lua with a reason that
-- names what was found.  Where a figure is known independently (a hand
-- derivation, the branch rule of the README), it is checked too.  The
-- classes of "What a random differential test finds" are named tests here;
-- tests/fuzz_spec.lua runs the random differential test itself.
local h = require "tests.helpers"
local nz = h.nz

-- The system defined by def, recorded and in Lua.
local function twins(def)
  local a, b = {}, {}
  for key, v in pairs(def) do a[key], b[key] = v, v end
  b.compile = false
  return nz.system(a), nz.system(b)
end

-- The line of a function in print(sys).
local function line_of(sys, label)
  for line in tostring(sys):gmatch("[^\n]+") do
    if line:match("^  " .. label:gsub("%p", "%%%0") .. ": ") then return line end
  end
  error(("no line for %s in print(sys):\n%s"):format(label, tostring(sys)))
end

local function vec(v)
  local s = {}
  for i, x in ipairs(v) do s[i] = ("%.17g"):format(x) end
  return "{" .. table.concat(s, ", ") .. "}"
end

-- f(sys) on both twins: equal results (each number to tol relative; the
-- same error message when both fail, and never one failing alone).
local function same(a, b, f, tol, what)
  local oka, ra = pcall(f, a)
  local okb, rb = pcall(f, b)
  assert(oka == okb, ("%s: recorded %s, Lua %s"):format(what, oka and "answers " .. vec(ra) or "fails: " .. tostring(ra),
    okb and "answers " .. vec(rb) or "fails: " .. tostring(rb)))
  if not oka then return false, ra, rb end
  for i = 1, #rb do
    local x, y = ra[i], rb[i]
    assert(math.abs(x - y) <= (tol or 0) * math.max(1, math.abs(y)) or (x ~= x and y ~= y),
      ("%s[%d]: recorded %.17g, Lua %.17g"):format(what, i, x, y))
  end
  return true, ra, rb
end

local function row(M, i) return M[i] end
local T2 = function(t, q, qd) return 0.5 * (qd[1] ^ 2 + qd[2] ^ 2) end
local T1 = function(t, q, qd) return 0.5 * qd[1] ^ 2 end

describe("R1: tracers answer the type tests as jets do", function()
  it("a jet method on the jet path falls back, names it, and raises the user's error where Lua does", function()
    local Q = function(t, q, qd)
      if nz.isjet(t) and t:coef(0) > 3.7 then error("forcing table ran out") end
      return { 0, 0 }
    end
    local a, b = twins{ name = "table", coords = { "x", "y" }, T = T2,
      V = function(t, q) return 0.5 * (q[1] ^ 2 + q[2] ^ 2) end, Q = Q }
    local line = line_of(a, "Q")
    assert.truthy(line:find("runs in Lua", 1, true), line)
    assert.truthy(line:find("'coef'", 1, true), line)
    assert.truthy(line:find("jet method", 1, true), line)
    for _, sys in ipairs{ a, b } do
      local ok, err = pcall(sys.simulate, sys, { q0 = { 1, 1 }, t1 = 10 })
      assert.is_false(ok)
      assert.truthy(tostring(err):find("forcing table ran out", 1, true), tostring(err))
      assert.truthy(tostring(err):find("t = 3.70", 1, true), tostring(err))
    end
  end)

  it("the frozen value idiom v = nz.isjet(x) and x:coef(0) or x gives Lua's accel (V = v x^2: -v x)", function()
    local a, b = twins{ name = "frozen", coords = { "x" }, T = T1,
      V = function(t, q) local x = q[1]; local v = nz.isjet(x) and x:coef(0) or x; return v * x ^ 2 end }
    same(a, b, function(s) return s:accel(0, { 1.5 }, { 0 }) end, 0, "accel")
    -- by hand: the frozen v = 1.5 is a constant, V' = 2 v x = 4.5
    assert.are.equal(-4.5, a:accel(0, { 1.5 }, { 0 })[1])
    assert.truthy(line_of(a, "V"):find("'coef'", 1, true), line_of(a, "V"))
  end)

  it("type(x) == 'userdata' takes the jets' path while recording, so the recording is faithful", function()
    local a, b = twins{ name = "type test", coords = { "x" }, T = T1,
      V = function(t, q) local x = q[1]; if type(x) == "userdata" then return 2 * x ^ 2 end return x ^ 2 end }
    assert.truthy(line_of(a, "V"):find("recorded, runs in C", 1, true), line_of(a, "V"))
    same(a, b, function(s) return s:accel(0, { 1.5 }, { 0 }) end, 0, "accel")
    assert.are.equal(-6, a:accel(0, { 1.5 }, { 0 })[1])
  end)

  it("nz.isjet is true for a tracer, as for the jets the Lua evaluator passes", function()
    local seen
    nz.system{ name = "isjet", coords = { "x" }, T = T1,
      V = function(t, q) seen = seen or { nz.isjet(t), nz.isjet(q[1]), type(q[1]) }; return q[1] ^ 2 end }
    assert.are.same({ true, true, "userdata" }, seen)
  end)
end)

describe("R2: an operation that cannot be recorded fails the recording even when pcall catches it", function()
  local function gt(x, y) local ok, r = pcall(function() return x > y end) return ok and r end
  local def = { name = "pcall", coords = { "x" }, T = T1,
    V = function(t, q) return (gt(q[1], 1) and 5 or 1) * q[1] ^ 2 end }

  it("falls back, names the comparison, and gives Lua's accel (-20 at x = 2)", function()
    local a, b = twins(def)
    local line = line_of(a, "V")
    assert.truthy(line:find("runs in Lua", 1, true), line)
    assert.truthy(line:find("compares a traced value", 1, true), line)
    assert.truthy(line:find("fidelity_spec.lua:%d+"), line)
    same(a, b, function(s) return s:accel(0, { 2 }, { 0 }) end, 0, "accel")
    assert.are.equal(-20, a:accel(0, { 2 }, { 0 })[1])
    local ta = a:simulate{ q0 = { 2 }, t1 = 1, dt = 1 }
    local tb = b:simulate{ q0 = { 2 }, t1 = 1, dt = 1 }
    assert.are.equal(tb.q[#tb.q][1], ta.q[#ta.q][1])
  end)
end)

describe("R3, R4: parameters however the function reaches them", function()
  it("R4: params read through an upvalue of the user's table are inputs, not constants", function()
    local P = { k = 2 }
    local a, b = twins{ name = "upvalue", coords = { "x" }, T = T1, params = P,
      V = function(t, q) return P.k * q[1] ^ 2 / 2 end }
    -- twins copies the definition: both systems hold P itself
    assert.are.equal(P, a.params)
    assert.truthy(line_of(a, "V"):find("recorded, runs in C", 1, true), line_of(a, "V"))
    assert.are.equal(-1, a:accel(0, { 0.5 }, { 0 })[1])
    P.k = 5
    same(a, b, function(s) return s:accel(0, { 0.5 }, { 0 }) end, 0, "accel after P.k = 5")
    assert.are.equal(-2.5, a:accel(0, { 0.5 }, { 0 })[1])
    -- the table is the user's again after recording: no tracer left in it
    for key, v in pairs(P) do assert.are.equal("number", type(v), key) end
    assert.is_nil(getmetatable(P))
  end)

  it("R3: a parameter added after the system was made is seen: the system records again and says so", function()
    local V = function(t, q, p) return p.k * (p.c or 1) * q[1] ^ 2 / 2 end
    local a, b = twins{ name = "added", coords = { "x" }, T = T1, params = { k = 2 }, V = V }
    assert.are.equal(-1, a:accel(0, { 0.5 }, { 0 })[1])
    a.params.c, b.params.c = 10, 10
    same(a, b, function(s) return s:accel(0, { 0.5 }, { 0 }) end, 0, "accel after params.c = 10")
    assert.are.equal(-10, a:accel(0, { 0.5 }, { 0 })[1])
    local text = tostring(a)
    assert.truthy(text:find("params.c", 1, true) and text:find("recorded again", 1, true), text)
    assert.truthy(line_of(a, "V"):find("recorded, runs in C", 1, true), text)
    -- and changes of the new parameter are inputs too
    a.params.c, b.params.c = 3, 3
    same(a, b, function(s) return s:accel(0, { 0.5 }, { 0 }) end, 0, "accel after params.c = 3")
  end)

  it("a default from the params' __index falls back and says so (not 'reads params.zz, a number')", function()
    local P = setmetatable({ k = 2 }, { __index = { zz = 3 } })
    local a, b = twins{ name = "default", coords = { "x" }, T = T1, params = P,
      V = function(t, q, p) return p.k * p.zz * q[1] ^ 2 / 2 end }
    local line = line_of(a, "V")
    assert.truthy(line:find("runs in Lua", 1, true), line)
    assert.truthy(line:find("__index", 1, true) and line:find("params.zz", 1, true), line)
    assert.is_nil(line:find("a number", 1, true), line)
    same(a, b, function(s) return s:accel(0, { 0.5 }, { 0 }) end, 0, "accel")
    assert.are.equal(getmetatable(P).__index.zz, 3)
  end)
end)

describe("each recording is checked on jets with tangents, and a failed check names what it found", function()
  it("a table of the function's own, keyed by traced values, that grows with every call", function()
    local seen = {}
    local a, b = twins{ name = "keyed", coords = { "x" }, T = T1,
      V = function(t, q) seen[q[1]] = true; local n = 0; for _ in pairs(seen) do n = n + 1 end; return n * q[1] ^ 2 end }
    local line = line_of(a, "V")
    assert.truthy(line:find("runs in Lua", 1, true), line)
    assert.truthy(line:find("'seen'", 1, true) and line:find("key", 1, true), line)
  end)

  it("a metatable test that tells a tracer from a jet", function()
    local jet_mt = getmetatable(nz.jet(0, 1))
    local a, b = twins{ name = "metatable", coords = { "x" }, T = T1,
      V = function(t, q) return (getmetatable(q[1]) == jet_mt and 2 or 1) * q[1] ^ 2 end }
    local line = line_of(a, "V")
    assert.truthy(line:find("runs in Lua", 1, true), line)
    assert.truthy(line:find("getmetatable", 1, true), line)
    same(a, b, function(s) return s:accel(0, { 1.5 }, { 0 }) end, 0, "accel")
  end)

  it("an event function (called with numbers) that tests type() runs in Lua, and the reason names the test", function()
    local a, b = twins{ name = "event type test", coords = { "x" }, T = T1, V = function(t, q) return q[1] ^ 2 / 2 end }
    local ev = { f = function(t, q, qd)
      if type(q[1]) == "number" then return q[1] - 0.5 end
      return q[1] - 0.7
    end, stop = true }
    local ta = a:simulate{ q0 = { 1 }, t1 = 3, events = { ev } }
    local tb = b:simulate{ q0 = { 1 }, t1 = 3, events = { ev } }
    assert.truthy(tostring(ta.stats.events_why):find("tests type() of a traced value", 1, true), tostring(ta.stats.events_why))
    -- both stop where the numbers say: x = 0.5 at t = acos(0.5) = pi/3
    assert.is_true(math.abs(ta.t[#ta.t] - math.pi / 3) < 1e-8 and math.abs(tb.t[#tb.t] - math.pi / 3) < 1e-8,
      ("stopped at %.17g and %.17g"):format(ta.t[#ta.t], tb.t[#tb.t]))
  end)

  it("a counter still falls back, and the reason says it depends on something else", function()
    local n = 0
    local a = nz.system{ name = "counter", coords = { "x" }, T = T1,
      V = function(t, q) n = n + 1; return n * q[1] ^ 2 end }
    local line = line_of(a, "V")
    assert.truthy(line:find("runs in Lua", 1, true), line)
    assert.truthy(line:find("other than its arguments", 1, true), line)
  end)

  it("a function that differs from its recording only in its derivatives is caught", function()
    -- the value agrees; the derivative of the frozen x^3 (a number) does not
    local a, b = twins{ name = "frozen derivative", coords = { "x" }, T = T1,
      V = function(t, q) local x = q[1]; if getmetatable(x).__name == "nz.jet" then
        return x:value() ^ 3 end return x ^ 3 end }
    assert.truthy(line_of(a, "V"):find("getmetatable", 1, true), line_of(a, "V"))
    same(a, b, function(s) return s:accel(0, { 1.5 }, { 0 }) end, 0, "accel")
    assert.are.equal(0, a:accel(0, { 1.5 }, { 0 })[1])
  end)
end)
describe("(a) a tie of a branch is decided by the same rule in the graph and on jets", function()
  it("nz.gt(t, 0) at t = 0 is 1 (the motion goes to t > 0): M = 2, q'' = -0.5", function()
    local a, b = twins{ name = "tie t", coords = { "x" },
      T = function(t, q, qd) return 0.5 * (1 + nz.ifelse(nz.gt(t, 0), 1, 0)) * qd[1] ^ 2 end,
      V = function(t, q) return q[1] ^ 2 / 2 end }
    local _, qa = same(a, b, function(s) return s:accel(0, { 1 }, { 0 }) end, 1e-15, "accel")
    assert.is_true(math.abs(qa[1] + 0.5) <= 1e-15, vec(qa))
    same(a, b, function(s) return row(s:mass(0, { 1 }, { 0 }), 1) end, 0, "M")
    assert.are.equal(2, a:mass(0, { 1 }, { 0 })[1][1])
  end)

  it("nz.clamp(t, -1, 1) at t = 1 is the bound from then on: no bias", function()
    local a, b = twins{ name = "tie clamp", coords = { "x", "y" },
      T = function(t, q, qd) return T2(t, q, qd) + 0.3 * nz.clamp(t, -1, 1) * qd[1] * qd[2] end }
    local _, ha = same(a, b, function(s) return s:bias(1, { 0, 0 }, { -1, 0 }) end, 1e-15, "h")
    assert.are.same({ 0, 0 }, { math.abs(ha[1]), math.abs(ha[2]) })
  end)

  it("nz.sign(q1) at q1 = 0 moving up is +1 in every term: q'' = {-0.4, 0.5} (by hand)", function()
    local a, b = twins{ name = "tie sign", coords = { "x", "y" },
      T = function(t, q, qd) return 0.5 * (2 + nz.sign(q[1]) * q[2]) * qd[1] ^ 2 + 0.5 * qd[2] ^ 2 end }
    local _, qa = same(a, b, function(s) return s:accel(0, { 0, 0.5 }, { 1, 1 }) end, 1e-14, "accel")
    -- sign = +1: M = diag(2.5, 1), h = (q1' q2', -q1'^2 / 2) = (1, -0.5)
    assert.is_true(math.abs(qa[1] + 0.4) <= 1e-15 and math.abs(qa[2] - 0.5) <= 1e-15, vec(qa))
    -- the graph's q'' solves its own equations
    local r = a:residual(1, 0, { 0, 0.5 }, { 1, 1 }, qa)
    assert.is_true(math.abs(r[1]) <= 1e-14 and math.abs(r[2]) <= 1e-14, vec(r))
  end)

  it("machine code hands a tie to the jets as the interpreter does", function()
    local a, b = twins{ name = "tie native", coords = { "x" }, native = true,
      T = T1, V = function(t, q) return nz.ifelse(nz.gt(t, 1), 3, 1) * q[1] ^ 2 / 2 end }
    for _, t in ipairs{ 0.5, 1, 1.5 } do
      same(a, b, function(s) return s:accel(t, { 1 }, { 0 }) end, 0, "accel at t = " .. t)
    end
    assert.are.equal(-3, a:accel(1, { 1 }, { 0 })[1])
  end)
end)

describe("(b) a simplification never removes a part that fails at the state", function()
  local cases = {
    { "log(q2) * 0", function(q) return nz.log(q[2]) * 0 end, "'log'" },
    { "sqrt(q2) ^ 0", function(q) return nz.sqrt(q[2]) ^ 0 end, "'sqrt'" },
    { "L - 0.3 L - 0.7 L", function(q) local L = nz.log(q[2]); return L - 0.3 * L - 0.7 * L end, "'log'" },
    { "ifelse(c, log q2, log q2)", function(q) return nz.ifelse(nz.gt(q[1], 0), nz.log(q[2]), nz.log(q[2])) end, "'log'" },
    { "ifelse(1, q1, log q2)", function(q) return nz.ifelse(1, q[1], nz.log(q[2])) end, "'log'" },
    { "gt(log q2, log q2)", function(q) return nz.gt(nz.log(q[2]), nz.log(q[2])) end, "'log'" },
    { "(1 / (q2 - q2)) * 0", function(q) return (1 / (q[2] - q[2])) * 0 end, "divi" },
    { "q2 ^ (q1 - q1)", function(q) return q[2] ^ (q[1] - q[1]) end, "'pow'" },
  }
  for _, c in ipairs(cases) do
    it(c[1] .. " at q2 = -1 raises the function's error in both, and agrees at q2 = 2", function()
      local a, b = twins{ name = c[1], coords = { "x", "y" }, T = T2,
        V = function(t, q) return q[1] ^ 2 / 2 + c[2](q) end }
      local ok, ea = same(a, b, function(s) return s:accel(0, { 0.5, -1 }, { 0.1, 0.2 }) end, 0, "accel")
      assert.is_false(ok)
      assert.truthy(tostring(ea):find(c[3], 1, true), tostring(ea))
      assert.truthy(tostring(ea):find("fidelity_spec.lua:%d+"), tostring(ea))
      same(a, b, function(s) local E, H = s:energy(0, { 0.5, -1 }, { 0.1, 0.2 }); return { E, H } end, 0, "energy")
      same(a, b, function(s) return s:accel(0, { 0.5, 2 }, { 0.1, 0.2 }) end, 0, "accel at q2 = 2")
    end)
  end
end)

describe("(c) signed zero is kept as IEEE arithmetic (and Lua) keep it", function()
  it("atan2(q1 * (-0.0), q2) at q2 < 0 is -pi, in Q and through nz.max in T", function()
    local a, b = twins{ name = "signed zero Q", coords = { "x", "y" }, T = T2,
      Q = function(t, q, qd) return { nz.atan2(q[1] * (-0.0), q[2]), 0 } end }
    local _, qa = same(a, b, function(s) return s:accel(0, { 1.3, -1 }, { 0, 0 }) end, 0, "accel")
    assert.are.equal(-math.pi, qa[1])
    local c, d = twins{ name = "signed zero M", coords = { "x", "y" },
      T = function(t, q, qd) return 0.5 * (1 + nz.max(0, nz.atan2(q[1] * (-0.0), q[2]))) * qd[1] ^ 2 + 0.5 * qd[2] ^ 2 end }
    same(c, d, function(s) return row(s:mass(0, { 1.3, -1 }, { 0, 0 }), 1) end, 0, "M")
    assert.are.equal(1, c:mass(0, { 1.3, -1 }, { 0, 0 })[1][1])
    local e, f = twins{ name = "x * 0", coords = { "x", "y" }, T = T2,
      Q = function(t, q, qd) return { nz.atan2(q[1] * 0, q[2]), nz.atan2(0 + q[1] * (-0.0), q[2]) } end }
    local _, qe = same(e, f, function(s) return s:accel(0, { -1.3, -1 }, { 0, 0 }) end, 0, "accel")
    assert.are.same({ -math.pi, math.pi }, qe)
    _, qe = same(e, f, function(s) return s:accel(0, { 1.3, -1 }, { 0, 0 }) end, 0, "accel")
    assert.are.same({ math.pi, math.pi }, qe)
  end)
end)

describe("(d) like terms are computed as the function computes them", function()
  it("q1 - 0.3 q1 - 0.7 q1 is Lua's rounding, also through nz.sign", function()
    local a, b = twins{ name = "like terms", coords = { "x", "y" },
      T = function(t, q, qd) return T2(t, q, qd) + 0.1 * (1 + nz.sign(q[1] - 0.3 * q[1] - 0.7 * q[1])) * qd[1] * qd[2] end }
    assert.truthy(line_of(a, "T"):find("recorded, runs in C", 1, true), line_of(a, "T"))
    for _, x in ipairs{ 1.3, 0.7, -2.1, 3 } do
      same(a, b, function(s) return row(s:mass(0, { x, 0.2 }, { 0, 0 }), 1) end, 0, "M at q1 = " .. x)
    end
  end)
end)

describe("(e) singular points and overflow: one rule for both evaluators", function()
  local cases = {
    { "q^1.5 at q = 0", function(t, q) return q[1] ^ 1.5 end, 0, 0, "'pow'" },
    { "sqrt(t) q^2 at t = 0", function(t, q) return nz.sqrt(t) * q[1] ^ 2 end, 0, 0.5, "'sqrt'" },
    { "abs(t - 1) q at t = 1", function(t, q) return nz.abs(t - 1) * q[1] + q[1] ^ 2 end, 1, 0.5, "'abs'" },
    { "asin(t) q at t = 1", function(t, q) return nz.asin(t) * q[1] + q[1] ^ 2 end, 1, 0.5, "'asin'" },
    { "acos(t) q at t = -1", function(t, q) return nz.acos(t) * q[1] + q[1] ^ 2 end, -1, 0.5, "'acos'" },
    { "atan2(t, t) q at t = 0", function(t, q) return nz.atan2(t, t) * q[1] + q[1] ^ 2 end, 0, 0.5, "'atan2'" },
    { "hypot(t, t) q at t = 0", function(t, q) return nz.hypot(t, t) * q[1] + q[1] ^ 2 end, 0, 0.5, "'hypot'" },
    { "0^t q at t = 1", function(t, q) return nz.pow(0, t) * q[1] + q[1] ^ 2 end, 1, 0.5, "'pow'" },
    { "q^2/2 + tanh(exp(t)) at t = 800", function(t, q) return q[1] ^ 2 / 2 + nz.tanh(nz.exp(t)) end, 800, 0.5, "'exp'" },
  }
  for _, c in ipairs(cases) do
    it(c[1] .. ": both refuse, naming the operation", function()
      local a, b = twins{ name = c[1], coords = { "x" }, T = T1, V = c[2] }
      local ok, ea = same(a, b, function(s) return s:accel(c[3], { c[4] }, { 1 }) end, 0, "accel")
      assert.is_false(ok)
      assert.truthy(tostring(ea):find(c[5], 1, true), tostring(ea))
      -- and both answer a little away from the point
      same(a, b, function(s) return s:accel(c[3] + 0.25, { c[4] + 0.25 }, { 1 }) end, 1e-14, "accel nearby")
    end)
  end
end)

describe("(f) the Lua evaluator's mass matrix beside a large term linear in q'", function()
  it("T = q'^2/2 + q'/(-1.5 q): M = 1 at q = 1e-8 and 1e-10", function()
    local a, b = twins{ name = "linear term", coords = { "x" },
      T = function(t, q, qd) return qd[1] ^ 2 / 2 + qd[1] / (-1.5 * q[1]) end }
    for _, x in ipairs{ 1e-8, 1e-10, 1e-3 } do
      assert.are.equal(1, b:mass(0, { x }, { 1 })[1][1], "Lua at q = " .. x)
      assert.are.equal(1, a:mass(0, { x }, { 1 })[1][1], "graph at q = " .. x)
    end
  end)
end)

describe("what the differential fuzzer found next, each as the jets compute it", function()
  local mech = require("nz.core").mech
  -- jets of order 3 with random coefficients, one per coordinate, and t
  local function jets(seed, k)
    math.randomseed(seed)
    local function jet(v)
      local c = { v, order = 3 }
      for j = 1, 3 do c[j + 1] = math.random() - 0.5 end
      return nz.jet(c)
    end
    local q, qd = {}, {}
    for i = 1, k do q[i], qd[i] = jet(math.random() * 2 - 1), jet(math.random() * 2 - 1) end
    return jet(math.random()), { q, qd }
  end
  local function same_jets(a, b, f, piece, what)
    for seed = 1, 40 do
      local tj, lv = jets(seed, a.k)
      local oka, ra = pcall(mech.piece, a.engine, piece, 1, tj, lv)
      local okb, rb = pcall(mech.piece, b.engine, piece, 1, tj, lv)
      assert(oka == okb, ("%s, seed %d: recorded %s, Lua %s"):format(what, seed, tostring(ra), tostring(rb)))
      for o = 1, oka and #rb or 0 do
        for j = 0, 3 do
          assert(ra[o]:coef(j) == rb[o]:coef(j) or (ra[o]:coef(j) ~= ra[o]:coef(j) and rb[o]:coef(j) ~= rb[o]:coef(j)),
            ("%s, seed %d, coefficient %d: recorded %.17g, Lua %.17g"):format(what, seed, j, ra[o]:coef(j), rb[o]:coef(j)))
        end
      end
    end
  end

  it("a product is the Cauchy sum in the order written (q1 t and t q1 round apart)", function()
    local a, b = twins{ name = "product order", coords = { "x" },
      T = function(t, q, qd) local x = q[1] * t; return 0.5 * qd[1] ^ 2 + (x - 0.3 * x - 0.7 * x) end }
    same_jets(a, b, nil, "F", "q1 t - 0.3 q1 t - 0.7 q1 t")
  end)

  it("x / 3 and x / p.c are x times the reciprocal, as a jet divided by a number", function()
    local a, b = twins{ name = "division", coords = { "x" }, params = { c = 3.0 }, T = T1,
      Q = function(t, q, qd, p) return { nz.sign(q[1] / 3 - q[1] * (1 / 3)) + nz.sign(q[1] / p.c - q[1] * (1 / p.c)) } end }
    -- recorded faithfully, not sent back to Lua by the check
    assert.truthy(line_of(a, "Q"):find("recorded, runs in C", 1, true), line_of(a, "Q"))
    same_jets(a, b, nil, "Q", "sign(x / 3 - x (1/3))")
    for i = 1, 40 do
      local x = 0.1 * i + 0.013
      same(a, b, function(s) return s:accel(0, { x }, { 0 }) end, 0, "accel at x = " .. x)
    end
  end)

  it("a product keeps the sign of a zero on jets too: atan2(q1 p.c, -1) at q1 = 0 is -pi for p.c < 0", function()
    local a, b = twins{ name = "signed zero product", coords = { "x" }, params = { c = -0.125 }, T = T1,
      Q = function(t, q, qd, p) return { nz.atan2(q[1] * p.c, -1) } end }
    local _, ra = same(a, b, function(s) return s:residual(1, 0, { 0 }, { 0 }, { 0 }) end, 0, "residual")
    assert.are.equal(math.pi, ra[1])   -- r = q'' - Q = 0 - (-pi)
  end)

  it("a traced constant stays a jet: sqrt(q - q), asin(-(t^0)), lt(q, q)^0.5 refuse on jets as in Lua", function()
    for _, V in ipairs{
      function(t, q) return nz.sqrt(q[1] - q[1]) + q[1] ^ 2 end,
      function(t, q) return nz.asin(-(t ^ 0)) * q[1] + q[1] ^ 2 end,
      function(t, q) return nz.lt(q[1], q[1]) ^ 0.5 + q[1] ^ 2 end,
      function(t, q) return nz.sqrt(nz.gt(q[1], 5)) + q[1] ^ 2 end,
    } do
      local a, b = twins{ name = "traced constant", coords = { "x" }, T = T1, V = V }
      local ok, err = same(a, b, function(s) return s:accel(0, { 0.5 }, { 1 }) end, 0, "accel")
      assert.is_false(ok)
      assert.truthy(tostring(err):find("not differentiable", 1, true), tostring(err))
      same(a, b, function(s) local E, H = s:energy(0, { 0.5 }, { 1 }); return { E, H } end, 0, "energy")
    end
  end)

  it("a NaN number met in the function fails it, as a jet refuses one", function()
    -- (constant M, and V's derivative never meets the NaN)
    local a, b = twins{ name = "NaN", coords = { "x" }, T = T1,
      V = function(t, q) return nz.gt(nz.max(t, (-1.375) ^ 1.5), 0) + q[1] ^ 2 end }
    local ok, err = same(a, b, function(s) return s:accel(0, { 0.5 }, { 1 }) end, 0, "accel")
    assert.is_false(ok)
    assert.truthy(tostring(err):find("NaN", 1, true), tostring(err))
  end)
end)
