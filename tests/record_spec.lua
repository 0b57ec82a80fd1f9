-- record_spec.lua - what a recording holds and what falls back to Lua.
--
-- A system's functions are recorded once into a graph evaluated in C
-- (lua/nz/model/record.lua).  Branches written with nz.gt, nz.ifelse, nz.max,
-- nz.min, nz.clamp and nz.sign are recorded; a Lua `if` on the state,
-- math.* on the state and a function that depends on more than its
-- arguments (math.random) fall back to Lua, visibly, and stay right.  Every
-- acceleration is checked against the same system with compile = false (the
-- Lua evaluator, no graph) and against the hand derivative of V written
-- here, on both sides of every branch.
local h = require "tests.helpers"
local nz = h.nz

-- One coordinate x, T = m x'^2 / 2: x'' = -V'(x) / m.
local function particle(name, V, params, compile)
  return nz.system{ name = name, coords = { "x" }, compile = compile,
    params = params or { m = 2 },
    T = function(t, q, qd, P) return P.m * qd[1] ^ 2 / 2 end,
    V = V }
end

local function accel(sys, x) return sys:accel(0, { x }, { 0.3 })[1] end

local function close(got, want, tol, what)
  assert(math.abs(got - want) <= tol * math.max(1, math.abs(want)),
    ("%s: got %.17g, expected %.17g"):format(what, got, want))
end

-- The line of V in print(sys).
local function line_of(sys, label)
  for line in tostring(sys):gmatch("[^\n]+") do
    if line:match("^  " .. label .. ": ") then return line end
  end
  error(("no line for %s in print(sys):\n%s"):format(label, tostring(sys)))
end

-- Both sides of every branch of V_branches below.
local XS = { -3, -1.5, -0.5, 0.5, 1.5, 2.5 }

-- V = k/2 max(0, x - 1)^2 + ifelse(x > 0, x^2, x^2 / 2) + clamp(x, -2, 2) / 10
--     + 0.3 sign(x) x + 0.2 min(x, -1) + 0.05 ifelse(0, 5, x)
-- (the tracer as first, second and third argument of the branch functions).
local function V_branches(t, q, P)
  local x = q[1]
  return P.k / 2 * nz.max(0, x - 1) ^ 2 + nz.ifelse(nz.gt(x, 0), x ^ 2, x ^ 2 / 2)
    + nz.clamp(x, -2, 2) / 10 + 0.3 * nz.sign(x) * x + 0.2 * nz.min(x, -1) + 0.05 * nz.ifelse(0, 5, x)
end
-- Its derivative by hand.
local function dV_branches(x, k)
  local d = x > 1 and k * (x - 1) or 0
  d = d + (x > 0 and 2 * x or x)
  d = d + ((x > -2 and x < 2) and 0.1 or 0)
  d = d + 0.3 * (x > 0 and 1 or -1)
  d = d + (x < -1 and 0.2 or 0)
  return d + 0.05
end

describe("recording branches written with nz.* functions", function()
  it("records V with nz.ifelse, nz.max, nz.min, nz.clamp, nz.sign and nz.gt", function()
    local sys = particle("branches", V_branches, { m = 2, k = 50 })
    assert.truthy(line_of(sys, "V"):find("recorded, runs in C", 1, true), tostring(sys))
    assert.truthy(line_of(sys, "T"):find("recorded, runs in C", 1, true), tostring(sys))
  end)

  it("gives the accelerations of the Lua evaluator and of the hand derivative on both sides of every branch", function()
    local sys = particle("branches", V_branches, { m = 2, k = 50 })
    local lua = particle("branches", V_branches, { m = 2, k = 50 }, false)
    assert.truthy(tostring(lua):find("every function runs in Lua (compile = false)", 1, true))
    for _, x in ipairs(XS) do
      local want = -dV_branches(x, 50) / 2
      close(accel(sys, x), want, 1e-13, ("graph at x = %g"):format(x))
      close(accel(lua, x), want, 1e-13, ("Lua evaluator at x = %g"):format(x))
    end
  end)

  it("records nz.min(nz.max(x, lo), hi) with bounds that are params, and sees them change", function()
    local V = function(t, q, P) return 3 * nz.min(nz.max(q[1], P.lo), P.hi) end
    local sys = particle("clamp by params", V, { m = 1, lo = -1, hi = 1 })
    assert.truthy(line_of(sys, "V"):find("recorded, runs in C", 1, true), tostring(sys))
    -- x'' = -3 inside [lo, hi], 0 outside
    for _, x in ipairs(XS) do close(accel(sys, x), (x > -1 and x < 1) and -3 or 0, 1e-15, "x = " .. x) end
    sys.params.hi = 2
    close(accel(sys, 1.5), -3, 1e-15, "hi = 2, x = 1.5")
  end)

  it("keeps nz.clamp with traced bounds in Lua, says why, and stays right", function()
    local V = function(t, q, P) return 3 * nz.clamp(q[1], P.lo, P.hi) end
    local sys = particle("clamp traced bounds", V, { m = 1, lo = -1, hi = 1 })
    local line = line_of(sys, "V")
    assert.truthy(line:find("runs in Lua", 1, true), line)
    assert.truthy(line:find("nz.min(nz.max(x, lo), hi)", 1, true), line)
    assert.truthy(line:find("record_spec.lua:%d+"), line)
    for _, x in ipairs(XS) do close(accel(sys, x), (x > -1 and x < 1) and -3 or 0, 1e-15, "x = " .. x) end
  end)

  it("records a smooth abs built from the existing operations", function()
    local V = function(t, q) return nz.smooth_abs(q[1], 0.1) end
    local sys = particle("smooth abs", V, { m = 1 })
    assert.truthy(line_of(sys, "V"):find("recorded, runs in C", 1, true), tostring(sys))
    for _, x in ipairs(XS) do close(accel(sys, x), -x / math.sqrt(x * x + 0.01), 1e-14, "x = " .. x) end
  end)
end)

describe("functions that cannot be recorded fall back to Lua", function()
  it("a Lua `if` on the state: runs in Lua, says why with file:line, and gives right answers", function()
    local IF_LINE = debug.getinfo(1, "l").currentline + 3
    local V = function(t, q)
      local x = q[1]
      if x > 0 then return x ^ 2 end
      return x ^ 2 / 2
    end
    local sys = particle("lua if", V)
    local line = line_of(sys, "V")
    assert.truthy(line:find("runs in Lua", 1, true), line)
    assert.truthy(line:find("compares a traced value", 1, true), line)
    assert.truthy(line:find("nz.ifelse", 1, true), line)
    assert.truthy(line:find("record_spec.lua:" .. IF_LINE, 1, true), line .. " (expected line " .. IF_LINE .. ")")
    assert.truthy(line_of(sys, "T"):find("recorded, runs in C", 1, true))
    for _, x in ipairs(XS) do close(accel(sys, x), -(x > 0 and 2 * x or x) / 2, 1e-15, "x = " .. x) end
  end)

  it("math.sin on a parameter: runs in Lua with the hint to use nz.sin", function()
    -- (math.cos on the state fails at every state: refused when the system is made, tests/errors_spec.lua)
    local V = function(t, q, p) return -math.cos(p.m) * q[1] end
    local sys = particle("math on the state", V)
    local line = line_of(sys, "V")
    assert.truthy(line:find("runs in Lua", 1, true), line)
    assert.truthy(line:find("use nz.sin", 1, true), line)
    assert.truthy(line:find("record_spec.lua:%d+"), line)
  end)

  it("a boolean condition in nz.ifelse: runs in Lua with the hint to use nz.gt", function()
    local V = function(t, q) return nz.ifelse(true, q[1], 0) end
    local line = line_of(particle("boolean condition", V), "V")
    assert.truthy(line:find("runs in Lua", 1, true), line)
    assert.truthy(line:find("nz.gt(x, 0)", 1, true), line)
  end)

  it("math.random: the check against the function keeps it in Lua", function()
    local V = function(t, q) return (1 + 1e-3 * math.random()) * q[1] ^ 2 end
    local line = line_of(particle("random", V), "V")
    assert.truthy(line:find("runs in Lua", 1, true), line)
    assert.truthy(line:find("depends on something other than its arguments", 1, true), line)
  end)
end)

describe("forces Q are recorded", function()
  -- A one-coordinate Q returns a list of one force: the check at the sample
  -- state once compared that list with the number it holds and sent every
  -- such Q to Lua as "depending on something other than its arguments".
  for k = 1, 2 do
    it(("with %d coordinate%s"):format(k, k == 1 and "" or "s"), function()
      local coords, c = {}, 130.65
      for i = 1, k do coords[i] = "q" .. i end
      local sys = nz.system{ name = "damped", coords = coords,
        T = function(t, q, qd) local s = 0; for i = 1, k do s = s + 0.5 * qd[i] ^ 2 end; return s end,
        Q = function(t, q, qd) local f = {}; for i = 1, k do f[i] = -c * qd[i] end; return f end }
      local text = tostring(sys)
      assert.truthy(text:find("Q: recorded, runs in C", 1, true), text)
      local qd = {}
      for i = 1, k do qd[i] = 0.1 * i end
      local a = sys:accel(0, qd, qd)
      for i = 1, k do assert.are.equal(-c * qd[i], a[i]) end      -- m = 1: q'' = Q exactly
    end)
  end
end)

describe("params stay inputs of the recording", function()
  it("sys.params.m = 3 changes the accelerations without recording again", function()
    local sys = particle("branches", V_branches, { m = 2, k = 50 })
    local compiled = sys.engine.recording
    for _, x in ipairs(XS) do close(accel(sys, x), -dV_branches(x, 50) / 2, 1e-13, "m = 2, x = " .. x) end
    local nodes = sys:graph_info().nodes   -- M and h are built at the first accel
    sys.params.m = 3
    sys.params.k = 20
    for _, x in ipairs(XS) do close(accel(sys, x), -dV_branches(x, 20) / 3, 1e-13, "m = 3, x = " .. x) end
    assert.are.equal(compiled, sys.engine.recording)
    assert.are.equal(nodes, sys:graph_info().nodes)
    assert.truthy(line_of(sys, "V"):find("recorded, runs in C", 1, true))
  end)
end)
