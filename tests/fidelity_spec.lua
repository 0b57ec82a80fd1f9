-- fidelity_spec.lua - a recorded function never answers differently from
-- the same function in Lua (issue 23).
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
