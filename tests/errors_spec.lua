-- errors_spec.lua - failures that lose nothing and messages that name the
-- user's code first: the interrupt is an object recognised by identity, an
-- error in a user function starts with the user's file:line, a nested
-- failure keeps its root cause, and no Lua error unwinds through the C core
-- while the arguments of a user function are being built.
local h = require "tests.helpers"
local nz = h.nz

local g = 9.81

-- The line of the caller, to say where an error must point.
local function here() return debug.getinfo(2, "l").currentline end
local SPEC = "tests/errors_spec.lua"

-- A pendulum whose potential calls `hook(t, q)` first (set per test).  The
-- hook changes after the system is made, which a recording would not see
-- (it bakes what V does when the system is made): these systems run in Lua,
-- whose error paths this file tests; the graph's are tested at the end.
local hook = function() end
local pendulum = nz.system{ name = "pendulum", coords = { "th" }, compile = false,
  T = function(t, q, qd) return 0.5 * qd[1] ^ 2 end,
  V = function(t, q) hook(t, q); return -g * nz.cos(q[1]) end }

-- The driven hoop: its implicit integration (bsimp) evaluates its functions
-- along state directions for the exact Jacobian, so lua_eval builds dualjet
-- arguments (src/lua/lua_dualjet.c).
local m, R, W = 0.3, 0.5, 4.0
local hoop = nz.system{ name = "driven hoop", coords = { "th", "ph" }, compile = false,
  T = function(t, q, qd) return 0.5 * m * R * R * (qd[1] ^ 2 + nz.sin(q[1]) ^ 2 * qd[2] ^ 2) end,
  V = function(t, q) return -m * g * R * nz.cos(q[1]) end,
  constraints = { function(t, q) return q[2] - W * t end } }
-- dense = false: the failure tests count on the 1000th dualjet argument, which
-- the steps of the output grid reach (dense output takes fewer steps)
local hoop_run = { q0 = { 0.7, 0 }, qd0 = { 0.3, W }, t1 = 3, method = "bsimp", monitors = { work = true }, dense = false }

-- Run `fail` where the n-th dualjet argument is being built, for f(): the
-- engine's testing hook (core.mech.argument_hook) is called inside the
-- protected call that builds the arguments, where running out of memory or
-- Ctrl-C's hook can raise.
local function failing_constructor(n, fail, f)
  local mech = require("nz.core").mech
  local calls = 0
  mech.argument_hook(function()
    calls = calls + 1
    if calls == n then fail() end
  end)
  local ok, a, b = pcall(f)
  mech.argument_hook(nil)
  assert(calls >= n, ("the constructor was called %d times, fewer than %d"):format(calls, n))
  return ok, a, b
end

describe("the interrupt is an object, recognised by identity", function()
  after_each(function() hook = function() end end)

  it("nz.interrupted prints as 'interrupted!' and is one object", function()
    assert.are.equal("interrupted!", tostring(nz.interrupted))
    assert.are.equal(rawequal(nz.interrupted, require("nz.core").interrupted), true)
    assert.are.equal(false, getmetatable(nz.interrupted))       -- protected
  end)
  it("a user's error that says 'interrupted!' keeps its message (accel)", function()
    hook = function() error("the user says interrupted! here") end
    h.checkerror("the user says interrupted! here", pendulum.accel, pendulum, 0, { 0.385 }, { 0 })
  end)
  it("a user's error that says 'interrupted!' fails simulate instead of stopping it quietly", function()
    hook = function(t) if t > 0.5 then error("interrupted! (a message, not Ctrl-C)") end end
    local ok, err = pcall(pendulum.simulate, pendulum, { q0 = { 0.385 }, t1 = 1 })
    assert.are.equal(false, ok)
    assert.truthy(tostring(err):find("interrupted! (a message, not Ctrl-C)", 1, true), tostring(err))
    assert.are.equal("failed", nz.last.status)
  end)
  it("the interrupt object raised in a user function stops simulate and keeps the part in nz.last", function()
    hook = function(t) if t > 0.5 then error(nz.interrupted) end end
    local tr = pendulum:simulate{ q0 = { 0.385 }, t1 = 1, dt = 0.1 }
    assert.are.equal("interrupted", tr.status)
    assert.are.equal(tr, nz.last)
    -- the output grid holds t = 0, 0.1, ..., up to the last point before 0.5
    assert(#tr.t >= 5 and tr.t[#tr.t] <= 0.5, ("%d points up to t = %g"):format(#tr.t, tr.t[#tr.t]))
  end)
  it("the interrupt object crosses the mechanics unchanged (accel raises it, not a message)", function()
    hook = function() error(nz.interrupted) end
    local ok, err = pcall(pendulum.accel, pendulum, 0, { 0.385 }, { 0 })
    assert.are.equal(false, ok)
    assert.are.equal(rawequal(err, nz.interrupted), true)
  end)
end)

describe("no Lua error unwinds through the C core", function()
  -- Under AddressSanitizer a Lua error that crossed nz_ode_jacobian would
  -- leak its work space (the sanitized run of this spec checks leaks at exit).
  it("an error while building the dualjet arguments fails cleanly, naming the system and the state", function()
    local ok, err = failing_constructor(1000, function() error("boom in the constructor") end,
      function() return hoop:simulate(hoop_run) end)
    assert.are.equal(false, ok)
    err = tostring(err)
    assert.truthy(err:find("system 'driven hoop': ", 1, true), err)
    assert.truthy(err:find("could not build the arguments: ", 1, true), err)
    assert.truthy(err:find("boom in the constructor at t = ", 1, true), err)
  end)
  it("the interrupt raised while building the dualjet arguments stops the run, keeping what it computed", function()
    local ok, tr = failing_constructor(1000, function() error(nz.interrupted) end,
      function() return hoop:simulate(hoop_run) end)
    assert.are.equal(true, ok, tostring(tr))
    assert.are.equal("interrupted", tr.status)
    assert(#tr.t > 1, #tr.t)
  end)
end)

describe("messages name the user's code first", function()
  after_each(function() hook = function() end end)

  it("an error in a user function starts with its file:line, then the system, function and state", function()
    local line
    hook = function() line = here(); error("a deliberate failure") end
    local ok, err = pcall(pendulum.accel, pendulum, 0.25, { 0.385 }, { 1.5 })
    assert.are.equal(false, ok)
    local want = ("%s:%d: system 'pendulum': V raised an error: a deliberate failure at t = 0.25, q = {0.385}")
      :format(SPEC, line)
    assert.are.equal(want, err:sub(1, #want))
    assert.falsy(err:find("lua/nz/", 1, true), err)
  end)
  it("a runtime error in a user function points at the line that failed", function()
    local line
    hook = function(t, q) line = here(); return q.no_such_field.x end
    local ok, err = pcall(pendulum.mass_bias, pendulum, 0, { 0.385 }, { 0 })
    assert.are.equal(false, ok)
    assert.are.equal(("%s:%d: system 'pendulum': V raised an error: attempt to index a nil value"):format(SPEC, line),
      err:match("^(.-value)"))
  end)
  it("a bad result names the line where the function is defined, at the nz.system line", function()
    local line = here() + 1
    local ok, err = pcall(nz.system, { name = "bad", coords = { "x" }, T = function(t, q, qd) return "fast" end })
    assert.are.equal(false, ok)
    assert.truthy(err:find(("^%s:%d: nz.system 'bad': T fails at every state %%(.-%%): %s:%d: T returned a string: a number "
      .. "or a jet expected"):format(SPEC:gsub("%p", "%%%0"), line, SPEC:gsub("%p", "%%%0"), line)), err)
  end)
  it("a recursive failure keeps its root cause whole, however deep, and the state of each end once", function()
    -- V calls the mechanics again at another state, 40 times deep: the
    -- message of each level wrapped the one below (some 100 characters each,
    -- the state 40 times); now the root cause whole, then the outermost call.
    local depth, line = 0, nil
    local deep
    deep = nz.system{ name = "deep", coords = { "x", "y", "z" },
      T = function(t, q, qd) return 0.5 * (qd[1] ^ 2 + qd[2] ^ 2 + qd[3] ^ 2) end,
      V = function(t, q)
        depth = depth + 1
        if depth > 40 then line = here(); error("the root cause 4711") end
        local a = deep:accel(0.5, { 1.2345678, 2.3456789, 3.456789 }, { 0.1234567, 0.2345678, 0.3456789 })
        return q[1] + a[1]
      end }
    depth = 0                      -- the calls made when the system was made do not count
    local ok, err = pcall(deep.accel, deep, 0, { 1, 2, 3 }, { 0, 0, 0 })
    assert.are.equal(false, ok)
    -- the root cause first, whole (the old 1 kB buffer cut it off), with its state
    assert.truthy(err:find(("^%s:%d: system 'deep': V raised an error: the root cause 4711 at t = 0.5, q = {1.2345678, "
      .. "2.3456789, 3.456789} %%(nested 40 deep"):format(SPEC:gsub("%p", "%%%0"), line)), err)
    -- and it ends with the outermost state (V sees t and q), once
    assert.are.equal("; the outermost call: V at t = 0, q = {1, 2, 3})", err:sub(-#"; the outermost call: V at t = 0, q = {1, 2, 3})"))
    assert.are.equal(2, select(2, err:gsub("at t = ", "")))
  end)
  it("sys:residual names the argument it got wrong, counted as the user counts", function()
    local ok, err = pcall(pendulum.residual, pendulum, 2.5, 0, { 0.385 }, { 0 }, { 0 })
    assert.are.equal(false, ok)
    assert.truthy(err:find("bad argument #1 to 'residual' (n: an integer order from 1 to", 1, true), err)
    assert.truthy(err:find("got 2.5)", 1, true), err)
    h.checkerror("bad argument #2 to 'residual' (t: a number expected, got the string \"0\")",
      pendulum.residual, pendulum, 2, "0", { 0.385 }, { 0 }, { 0 })
    h.checkerror("bad argument #1 to 'residual' (n: an integer order from 1 to",
      pendulum.residual, pendulum, 0, 0, { 0.385 }, { 0 }, { 0 })
    -- a float with an integer value is an order: th'' + g sin th = 0 at rest
    local r = pendulum:residual(2.0, 0, { 0.385 }, { 0 }, { -g * math.sin(0.385) })
    assert(math.abs(r[1]) <= 1e-12, r[1])
  end)
  it("every method checks its state in one place: Lua's 'bad argument #i to', the caller's line first", function()
    local sys = nz.system{ name = "plane", coords = { "x", "y" },
      T = function(t, q, qd) return 0.5 * 1.7 * (qd[1] ^ 2 + qd[2] ^ 2) end,
      V = function(t, q) return 1.7 * 2.385 * q[2] end }
    local q, qd = { 0.385, -1.25 }, { 0.5, 0.75 }
    -- f's error must start with the line of the call inside f (this file); the
    -- calls are in parentheses: a tail call leaves no line of f to name
    local function fails(want, f)
      local ok, err = pcall(f)
      assert.are.equal(false, ok)
      local info = debug.getinfo(f, "S")
      local line = tonumber(err:match("^" .. SPEC:gsub("%p", "%%%0") .. ":(%d+): "))
      assert(line and line >= info.linedefined and line <= info.lastlinedefined, err)
      assert.are.equal(want, (err:gsub("^[^:]+:%d+: ", "", 1)))
    end
    local two = "a table of 2 numbers expected (one per coordinate: x, y)"
    -- qd missing, too long, empty; q too short; a NaN; t a string
    fails("bad argument #3 to 'accel' (qd: " .. two .. ", got nil)", function()
      return (sys:accel(0, { 0.385, -1.25 })) end)
    fails("bad argument #2 to 'accel' (q: " .. two .. ", got a table of 1 entry)", function()
      return (sys:accel(0, { 0.385 }, qd)) end)
    fails("bad argument #3 to 'project' (qd: " .. two .. ", got a table of 3 entries)", function()
      return (sys:project(0, q, { 0.2, 4, 5 })) end)
    fails("bad argument #4 to 'equations' (qd: " .. two .. ", got a table of 0 entries)", function()
      return (sys:equations(2, 0, q, {})) end)
    fails("bad argument #3 to 'mass_bias' (qd[2]: a finite number expected, got NaN)", function()
      return (sys:mass_bias(0, q, { 0.5, 0 / 0 })) end)
    fails("bad argument #1 to 'accel' (t: a finite number expected, got the string \"0\")", function()
      return (sys:accel("0", q, qd)) end)
    -- each method under its own name
    for _, name in ipairs{ "bias", "reduced", "energy", "reaction_power", "check_state" } do
      fails(("bad argument #3 to '%s' (qd: %s, got nil)"):format(name, two), function()
        return (sys[name](sys, 0.25, q)) end)
    end
    fails("bad argument #2 to 'mass' (q: " .. two .. ", got nil)", function()
      return (sys:mass(0.25)) end)
    fails("bad argument #3 to 'residual' (q: " .. two .. ", got a table of 1 entry)", function()
      return (sys:residual(2, 0, { 0.1 }, qd, { 0, 0 })) end)
    -- options of accel: unknown, mistyped
    fails("bad argument #4 to 'accel' (unknown option 'bogus' (options: check, lambda, maxit, out, qdd, rcond_min, tol))",
      function() return (sys:accel(0, q, qd, { bogus = 1 })) end)
    fails("bad argument #4 to 'accel' (option 'check': true or false expected, got the string \"no\")",
      function() return (sys:accel(0, q, qd, { check = "no" })) end)
    -- without multipliers, argument 7 is still the form
    fails("bad argument #7 to 'residual' (unknown form 'zzz'; forms: " .. table.concat(nz.forms or require("nz.system").forms, ", ") .. ")",
      function() return (sys:residual(2, 0, q, qd, { 0, 0 }, nil, "zzz")) end)
    -- the arguments that pass give the closed form: x'' = 0, y'' = -2.385
    local a = sys:accel(0, q, qd, { check = true })
    assert(math.abs(a[1]) <= 1e-15 and math.abs(a[2] + 2.385) <= 1e-14, a[2])
  end)
  it("nz.check with an equation written as a string says so, with the student's line", function()
    local line = here() + 1
    local ok, err = pcall(nz.check, pendulum, function(t, q, qd, qdd) return { "th'' + g sin(th)" } end, { quiet = true })
    assert.are.equal(false, ok)
    assert.are.equal(("%s:%d: check: equation 1 must be a number computed from t, q, qd, qdd, got the string \"th'' + g sin(th)\"")
      :format(SPEC, line), err:match("^(.-%)\")"))
    -- the same equation written in Lua passes
    assert.are.equal(true, (nz.check(pendulum, function(t, q, qd, qdd) return { qdd[1] + g * nz.sin(q[1]) } end, { quiet = true })))
  end)
  it("nz.check and the operators check their arguments as the methods do", function()
    local line = here() + 1
    local ok, err = pcall(function() return (nz.check(pendulum, "th'' + g sin(th)")) end)
    assert.are.equal(false, ok)
    assert.are.equal(("%s:%d: bad argument #2 to 'check' (your equations: a function(t, q, qd, qdd) returning 1 expressions "
      .. "expected, got the string \"th'' + g sin(th)\")"):format(SPEC, line), err)
    h.checkerror("bad argument #1 to 'check' (a system from nz.system{...} expected, got a table of 0 entries)",
      nz.check, {}, function() end)
    h.checkerror("bad argument #3 to 'check' (option 'quiet': true or false expected, got the string \"yes\")",
      nz.check, pendulum, function(t, q, qd, qdd) return { qdd[1] } end, { quiet = "yes" })
    h.checkerror("bad argument #3 to 'check' (unknown option 'state' (did you mean 'states'?) (options: quiet, seed, states, tol))",
      nz.check, pendulum, function(t, q, qd, qdd) return { qdd[1] } end, { state = 3 })
    h.checkerror("bad argument #2 to 'nielsen_op' (a function f(t, q, qd) expected, got nil)",
      nz.nielsen_op, 1, nil, 0, { 0.385 }, { 0 })
    h.checkerror("bad argument #4 to 'euler_op' (q: a table of numbers expected, got 0.385)",
      nz.euler_op, 1, function(t, q, qd) return qd[1] ^ 2 end, 0, 0.385, { 0 })
  end)
  it("a NaN is written NaN in messages (never -nan, whatever the C library)", function()
    -- an equation that gives NaN: 0/0 everywhere
    local ok, text = nz.check(pendulum, function(t, q, qd, qdd) return { 0 / 0 } end, { quiet = true })   -- NaN everywhere
    assert.are.equal(false, ok)
    assert.truthy(text:find("should give 0 but gives NaN", 1, true), text)
    assert.falsy(text:lower():find("-nan", 1, true), text)
    h.checkerror("bad argument #3 to 'accel' (qd[1]: a finite number expected, got NaN)", pendulum.accel, pendulum, 0, { 0.385 }, { 0 / 0 })
    h.checkerror("bad argument #3 to 'accel' (qd[1]: a finite number expected, got -inf)", pendulum.accel, pendulum, 0, { 0.385 }, { -math.huge })
  end)
  it("a method called with a dot says so and to write a colon, for every method of each object nz makes", function()
    local tr = pendulum:simulate{ q0 = { 0.3 }, t1 = 0.1 }
    local lin = pendulum:linearize{ q = { 0 }, qd = { 0 } }
    local sw = pendulum:eigen_sweep{ values = { 1, 2 }, at = function() return { q = { 0 }, qd = { 0 } } end }
    local objects = { { pendulum, "sys", "system" }, { tr, "tr", "trajectory" }, { lin, "lin", "linearization" },
      { sw, "sw", "eigenvalue sweep" } }
    local count = 0
    for _, o in ipairs(objects) do
      for name, f in pairs(getmetatable(o[1]).__index) do
        if type(f) == "function" and not name:match("^__") then
          -- x.f{...}: the options arrive as the object; x.f(): nothing does
          for _, arg in ipairs{ { q0 = { 1 }, t1 = 1 }, false } do
            local ok, err = pcall(f, arg or nil)
            assert.is_false(ok, name)
            local args = arg and "{...}" or "(...)"
            local want = ("%s called with a dot: write %s:%s%s (%s: your %s), with a colon, so that the method gets its %s")
              :format(name, o[2], name, args, o[2], o[3], o[3])
            assert.truthy(tostring(err):find(want, 1, true), tostring(err))
            count = count + 1
          end
        end
      end
    end
    assert(count > 2 * 30, count)
    -- the colon (or the object given explicitly) still works
    assert.are.equal(#pendulum:accel(0, { 0.3 }, { 0 }), #pendulum.accel(pendulum, 0, { 0.3 }, { 0 }))
  end)
  it("in a script, the dot's message names the user's line and object", function()
    local script = os.tmpname()
    local f = assert(io.open(script, "w"))
    f:write("pend = nz.system{ coords = { 'th' }, T = function(t, q, qd) return qd[1]^2 / 2 end }\n",
      "tr = pend.simulate{ q0 = { 1 }, t1 = 1 }\n")
    f:close()
    local rc, _, err = h.run(h.nzlua .. " " .. script)
    os.remove(script)
    assert.are.equal(1, rc)
    assert.truthy(err:find(script .. ":2: pend.simulate called with a dot: write pend:simulate{...}, with a colon, "
      .. "so that the method gets its system", 1, true), err)
  end)
end)

describe("a mistake that fails at every state is said at the nz.system line", function()
  local function T(t, q, qd) return 0.5 * (qd[1] ^ 2 + qd[2] ^ 2) end
  -- The error of nz.system{...} made from def, its message (made on MADE: that line is the user's nz.system line).
  local MADE = here() + 3
  local function made(def)
    def.name, def.coords, def.T = def.name or "pend", def.coords or { "th", "ph" }, def.T or T
    local ok, err = pcall(nz.system, def)
    assert.are.equal(false, ok, "nz.system accepted the system")
    return err
  end
  it("math.cos on the state (recorded or compile = false): the nz.system line, V's line, nz.cos", function()
    for _, compile in ipairs{ true, false } do
      local line = here() + 1
      local err = made{ compile = compile, V = function(t, q) return -9.81 * math.cos(q[1]) end }
      local want = ("%s:%d: nz.system 'pend': V fails at every state (tried once as the system is made, at t = 0.3, "
        .. "q = {0.2, 0.2}): %s:%d: bad argument #1 to 'cos' (number expected, got nz.jet): math.cos works on numbers "
        .. "only: write nz.cos(...), or cos(...) in the session"):format(SPEC, MADE, SPEC, line)
      assert.are.equal(want, err)
    end
  end)
  it("a coordinate read by name: 'th' is qd[1]", function()
    local line = here() + 1
    local err = made{ T = function(t, q, qd) return 0.5 * qd.th ^ 2 + 0.5 * qd[2] ^ 2 end }
    assert.are.equal(("%s:%d: nz.system 'pend': T fails at every state (tried once as the system is made, at t = 0.3, "
      .. "q = {0.2, 0.2}, qd = {0.4, 0.4}): %s:%d: T reads qd.th, and qd is a list indexed by number (q[1], qd[1], "
      .. "...): 'th' is qd[1]"):format(SPEC, MADE, SPEC, line), err)
    -- inside a jet function too (where Lua's own message names no field)
    assert.truthy(made{ V = function(t, q) return nz.cos(q.ph) end }:find("'ph' is q[2]", 1, true))
  end)
  it("a state list taken as a number, a misspelled function of nz, a forgotten return, Q's shape", function()
    assert.truthy(made{ V = function(t, q) return 0.5 * q * q end }:find(
      "attempt to perform arithmetic on a table value (local 'q'): 'q' is a list (q[1], qd[1], ...), not a number", 1, true))
    assert.truthy(made{ V = function(t, q) return nz.coss(q[1]) end }:find("did you mean nz.cos?", 1, true))
    assert.truthy(made{ V = function(t, q) local v = q[1] ^ 2 end }:find("V returned nil (no return?)", 1, true))
    assert.truthy(made{ V = function(t, q) return { q[1] ^ 2 } end }:find("V returned a table", 1, true))
    assert.truthy(made{ Q = function(t, q, qd) return { -qd[1] } end }:find("Q returned 1 forces for 2 coordinates", 1, true))
    assert.truthy(made{ constraints = { function(t, q, qd) return math.sin(q[1]) - q[2] end } }:find(
      "constraint 1 fails at every state", 1, true))
  end)
  it("the sample state is the system's own sample when given", function()
    local err = made{ sample = { t = 2, q = { 1.5, -1 }, qd = { 3, 4 } }, V = function(t, q) return math.exp(q[1]) end }
    assert.truthy(err:find("at t = 2, q = {1.5, -1})", 1, true), err)
  end)
  it("refuses no system that is only undefined at the sample state, or depends on what is set later", function()
    -- undefined at the sample (q = 0.2): a domain error, an error of the user's own, a NaN
    local s1 = nz.system{ name = "log", coords = { "x", "y" }, T = T, V = function(t, q) return nz.log(q[1] - 1) end }
    local s2 = nz.system{ name = "guard", coords = { "x", "y" }, T = T, compile = false,
      V = function(t, q) if q[1]:value() < 1 then error("x below 1") end return q[1] ^ 2 end }
    local s3 = nz.system{ name = "sqrt", coords = { "x", "y" }, T = T, V = function(t, q) return nz.sqrt(1 - q[1] - q[2]) end }
    assert.are.equal(-1, s1:accel(0, { 2, 0 }, { 0, 0 })[1])                -- dV/dx = 1/(x - 1)
    assert.are.equal(-6, s2:accel(0, { 3, 0 }, { 0, 0 })[1])
    assert(math.abs(s3:accel(0, { -1, 0 }, { 0, 0 })[1] - 0.5 / math.sqrt(2)) < 1e-15)
    -- a global defined after the system, a parameter added later, the system called from its own force
    local s4 = nz.system{ name = "later", coords = { "x", "y" }, T = T, V = function(t, q) return STIFFNESS_SET_LATER * q[1] end }
    rawset(_G, "STIFFNESS_SET_LATER", 3)
    assert.are.equal(-3, s4:accel(0, { 0, 0 }, { 0, 0 })[1])
    rawset(_G, "STIFFNESS_SET_LATER", nil)
    local s5 = nz.system{ name = "param", coords = { "x", "y" }, T = T, params = {}, V = function(t, q, p) return p.k * q[2] end }
    s5.params.k = 2
    assert.are.equal(-2, s5:accel(0, { 0, 0 }, { 0, 0 })[2])
    local s6
    s6 = nz.system{ name = "self", coords = { "x", "y" }, T = T, compile = false,
      Q = function(t, q, qd) return { -s6.params.c * qd[1], 0 } end, params = { c = 0.5 } }
    assert.are.equal(-0.5, s6:accel(0, { 0, 0 }, { 1, 0 })[1])
  end)
  it("costs nothing for a system whose functions are recorded (each runs as it is recorded and checked, not more)", function()
    -- (without NZ_GRAPH_CHECK, whose comparisons call the functions again)
    local rc, out = h.run("env -u NZ_GRAPH_CHECK " .. h.nzlua .. [[ -e '
      local calls, T = 0, function(t, q, qd) return qd[1] ^ 2 end
      local V = function(t, q) calls = calls + 1; return q[1] ^ 2 end
      nz.system{ coords = { "x" }, T = T, V = V }
      io.write(calls, " ")
      calls = 0
      nz.system{ coords = { "x" }, T = T, V = V, compile = false }
      io.write(calls)']])
    assert.are.equal(0, rc, out)
    -- recorded: on traced values, then twice through the Lua evaluator for
    -- the recording's check (jets with tangents at one state, along a state
    -- direction at another: record_check.lua); in Lua: once, on jets
    assert.are.equal("3 1", out)
  end)
end)

describe("errors raised by the engine start with the caller's file:line", function()
  -- Raised in C (a singular M, dependent constraints, a parameter that is no
  -- longer a number) or in the library's Lua (a wrong quantity name in
  -- tr:plot), they once began with lua/nz/motion/simulate.lua:600, lua/nz/
  -- trajectory.lua:196 or nothing; README: a failing script prints
  -- file:line: message.
  local SPEC_PAT = SPEC:gsub("%p", "%%%0")
  -- f() must fail with a message that starts with this file and the line
  -- the call is on (given), and names no library file; returns the rest.
  local function fails_at(line, f)
    local ok, err = pcall(f)
    assert.are.equal(false, ok)
    err = tostring(err)
    assert.truthy(err:find(("^%s:%d: "):format(SPEC_PAT, line)), err)
    assert.falsy(err:find("lua/nz/", 1, true), err)
    return (err:gsub("^[^:]+:%d+: ", "", 1))
  end
  -- The spherical pendulum at its pole: M = diag(1, sin^2 th) = diag(1, 0).
  local function spherical()
    return nz.system{ name = "sph", coords = { "th", "ph" },
      T = function(t, q, qd) return 0.5 * (qd[1] ^ 2 + nz.sin(q[1]) ^ 2 * qd[2] ^ 2) end,
      V = function(t, q) return g * nz.cos(q[1]) end }
  end

  it("a singular M: accel, simulate, linearize (raised in C)", function()
    local sp = spherical()
    local line = here() + 1
    local msg = fails_at(line, function() return (sp:accel(0, { 0, 0 }, { 1, 0 })) end)
    assert.truthy(msg:find("^system 'sph': the mass matrix M = d2T/dqd2 is not positive definite at t = 0"), msg)
    line = here() + 1
    fails_at(line, function() return (sp:simulate{ q0 = { 0, 0 }, qd0 = { 1, 0 }, t1 = 1 }) end)
    line = here() + 1
    fails_at(line, function() return (sp:linearize{ q = { 0, 0 }, qd = { 0, 0 } }) end)
  end)
  it("dependent constraints (raised in C), a projection that fails (in Lua)", function()
    local T = function(t, q, qd) return 0.5 * (qd[1] ^ 2 + qd[2] ^ 2) end
    local dup = nz.system{ name = "dup", coords = { "x", "y" }, T = T, constraints = {
      function(t, q) return q[1] ^ 2 + q[2] ^ 2 - 1 end, function(t, q) return 2 * (q[1] ^ 2 + q[2] ^ 2 - 1) end } }
    local line = here() + 1
    local msg = fails_at(line, function() return (dup:accel(0, { 0, -1 }, { 1, 0 })) end)
    assert.truthy(msg:find("^system 'dup': dependent constraints: constraints 1 and 2"), msg)
    -- two circles that do not meet
    local apart = nz.system{ name = "apart", coords = { "x", "y" }, T = T, constraints = {
      function(t, q) return q[1] ^ 2 + q[2] ^ 2 - 1 end, function(t, q) return (q[1] - 5) ^ 2 + q[2] ^ 2 - 1 end } }
    line = here() + 1
    msg = fails_at(line, function() return (apart:project(0, { 1, 0 }, { 0, 0 })) end)
    assert.truthy(msg:find("the constraints may have no common solution near the start", 1, true), msg)
  end)
  it("a wrong quantity in tr:plot or tr:column, with the quantities the trajectory has", function()
    local tr = pendulum:simulate{ q0 = { 0.385 }, t1 = 0.1 }
    local line = here() + 1
    local msg = fails_at(line, function() return (tr:plot{ y = { "thx" }, quiet = true }) end)
    assert.are.equal("trajectory: no quantity 'thx' (quantities: t, th, th', th'')", msg)
    line = here() + 1
    msg = fails_at(line, function() return (tr:column("E")) end)
    assert.truthy(msg:find("trajectory: 'E' was not recorded: ask for it with monitors", 1, true), msg)
    -- plot's own refusals (a file it cannot write; gnuplot missing) too: once lua/nz/motion/trajectory.lua
    line = here() + 1
    msg = fails_at(line, function() return (tr:plot{ file = "motion.jpg" }) end)
    assert.truthy(msg:find("^plot: file 'motion.jpg' must end in .svg or .png") or msg:find("gnuplot is not installed", 1, true), msg)
  end)
end)

describe("a parameter that is no longer a finite number is named", function()
  -- Checked once per call of the mechanics, before any function runs: once
  -- params.g = 0/0 surfaced as "bad argument #1 to 'mul' (got NaN ...)"
  -- inside V, and params.g = nil at lua/nz/motion/simulate.lua:600.
  local function pend(compile)
    return nz.system{ name = "pend", coords = { "th" }, params = { g = g, l = 2.0 }, compile = compile,
      T = function(t, q, qd, p) return 0.5 * p.l ^ 2 * qd[1] ^ 2 end,
      V = function(t, q, p) return -p.g * p.l * nz.cos(q[1]) end }
  end
  local SPEC_PAT = SPEC:gsub("%p", "%%%0")
  for _, compile in ipairs{ true, false } do
    it(("NaN, inf, nil, a string: accel, simulate, energy, linearize (%s)"):format(compile and "recorded" or "in Lua"), function()
      local sys = pend(compile)
      local good = sys:accel(0, { 0.385 }, { 0 })[1]
      local cases = {
        { 0 / 0, "params.g is NaN (a NaN comes from an earlier computation, such as 0/0" },
        { math.huge, "params.g is inf: set sys.params.g to a finite number" },
        { nil, "params.g is nil (removed, or never set again), and it was a number when the system was made" },
        { "9.81", "params.g is the string \"9.81\", and it was a number when the system was made" },
      }
      for _, case in ipairs(cases) do
        sys.params.g = case[1]
        local calls = {
          function() return (sys:accel(0, { 0.385 }, { 0 })) end,
          function() return (sys:simulate{ q0 = { 0.385 }, t1 = 1 }) end,
          function() return (sys:energy(0, { 0.385 }, { 0 })) end,
          function() return (sys:linearize{ q = { 0 } }) end,
        }
        for n, f in ipairs(calls) do
          local info = debug.getinfo(f, "S")
          local ok, err = pcall(f)
          assert.are.equal(false, ok)
          err = tostring(err)
          assert.are.equal(info.linedefined, tonumber(err:match("^" .. SPEC_PAT .. ":(%d+): ")), err)
          assert.truthy(err:find("system 'pend': " .. case[2], 1, true), ("call %d: %s"):format(n, err))
          assert.falsy(err:find("'mul'", 1, true), err)
        end
      end
      sys.params.g = g              -- and it works again
      assert.are.equal(good, sys:accel(0, { 0.385 }, { 0 })[1])
      sys.params.g = 2 * g          -- a new value is read: th'' = -(g/l) sin th
      assert(math.abs(sys:accel(0, { 0.385 }, { 0 })[1] - 2 * good) <= 1e-14 * math.abs(good))
    end)
  end
  it("parameters that were not numbers are not checked", function()
    local sys = nz.system{ name = "tabled", coords = { "x" }, params = { k = 4, data = { 1, 2 } },
      T = function(t, q, qd, p) return 0.5 * qd[1] ^ 2 end, V = function(t, q, p) return 0.5 * p.k * q[1] ^ 2 end }
    sys.params.data = "anything"
    assert.are.equal(-4 * 0.5, sys:accel(0, { 0.5 }, { 0 })[1])
  end)
end)

describe("a recorded function that fails at a state", function()
  it("hands the evaluation to Lua, whose error names the user's line, the system and the state", function()
    local line = here() + 2
    local sys = nz.system{ name = "log well", coords = { "x" },
      T = function(t, q, qd) return 0.5 * qd[1] ^ 2 end, V = function(t, q) return nz.log(q[1]) end }
    assert.truthy(tostring(sys):find("V: recorded, runs in C", 1, true), tostring(sys))
    assert.are.equal(-1 / 0.5, sys:accel(0, { 0.5 }, { 0 })[1])
    local ok, err = pcall(sys.accel, sys, 0, { -0.5 }, { 0 })
    assert.are.equal(false, ok)
    err = tostring(err)
    assert.are.equal(("%s:%d:"):format(SPEC, line), err:sub(1, #SPEC + #tostring(line) + 2), err)
    assert.truthy(err:find("system 'log well': V raised an error", 1, true), err)
    assert.truthy(err:find("q = {-0.5}", 1, true), err)
  end)
  it("stops simulate at that time and keeps what was computed", function()
    local sys = nz.system{ name = "edge", coords = { "x" },
      T = function(t, q, qd) return 0.5 * qd[1] ^ 2 end, V = function(t, q) return nz.sqrt(1 - q[1]) end }
    -- x'' = -V' = 1 / (2 sqrt(1 - x)) pushes x towards 1, where sqrt leaves its domain
    local ok, err = pcall(sys.simulate, sys, { q0 = { 0.5 }, qd0 = { 1 }, t1 = 5, dt = 0.01 })
    assert.are.equal(false, ok)
    assert.truthy(tostring(err):find("V raised an error", 1, true), tostring(err))
    assert.are.equal("failed", nz.last.status)
    assert.is_true(#nz.last.t > 2)
  end)
end)

-- Probes: each a value or a state nothing said anything about,
-- or said too much about.
describe("what is not finite, off the constraints, or nested is said once and clearly", function()
  local osc = nz.system{ name = "osc", coords = { "x" }, T = function(t, q, qd) return 0.5 * qd[1] ^ 2 end,
    V = function(t, q) return 0.5 * q[1] ^ 2 end }
  it("an event function that returns inf is refused like one that returns nil", function()
    for _, f in ipairs{ function() return nil end, function() return 1 / 0 end, function() return 0 / 0 end } do
      h.checkerror("simulate 'osc': event 'event 1' must return a finite number, got ", osc.simulate, osc,
        { q0 = { 1 }, t1 = 1, events = { f } })
    end
    -- recorded and run in C, infinite only at the start (1/(x - 1) at x = 1):
    -- the graph fails there and the Lua function says what it returned
    local ok, e = pcall(osc.simulate, osc, { q0 = { 1 }, t1 = 1, events = { function(t, q) return 1 / (q[1] - 1) end } })
    assert.is_false(ok)
    assert.truthy(tostring(e):find("event 'event 1' must return a finite number, got inf at t = 0, q = {1}", 1, true), e)
  end)
  it("T = ... + 1/0 or + 0/0 is refused at the start of a run, naming T and the state", function()
    local function make(c)
      return nz.system{ name = "bad T", coords = { "x" }, V = function(t, q) return q[1] ^ 2 end,
        T = function(t, q, qd) return 0.5 * qd[1] ^ 2 + c end }
    end
    -- both ran: a constant in T has no derivative in M or h
    for _, c in ipairs{ { 1 / 0, "inf" }, { 0 / 0, "NaN" }, { -1 / 0, "-inf" } } do
      local sys = make(c[1])
      local line = here() + 1
      local ok, e = pcall(sys.simulate, sys, { q0 = { 0.3 }, t1 = 1 })
      assert.is_false(ok)
      e = tostring(e)
      assert.truthy(e:find(("%s:%d: simulate 'bad T': T is %s at the start at t = 0, q = {0.3}, qd = {0}: a term such "
        .. "as 1/0 or 0/0 makes it so"):format(SPEC, line, c[2]), 1, true), e)
    end
    -- one that is not finite only later is the integrator's to meet (a V
    -- that turns NaN at t = 0.3 runs to there: simulate_loop_spec)
  end)
  it("a fixed step longer than the output spacing: the summary says the step taken", function()
    local simulate = require "nz.motion.simulate"
    local said, saved = {}, simulate.warn
    simulate.warn = function(msg) said[#said + 1] = msg end
    local ok, tr = pcall(osc.simulate, osc, { q0 = { 1 }, t1 = 1, dt = 0.05, step = 1e6 })
    simulate.warn = saved
    assert(ok, tostring(tr))
    -- it said "fixed step 1e+06"; 20 steps of 0.05 were taken
    assert.are.equal(20, tr.stats.steps)
    assert.truthy(tostring(tr):find("(fixed step 0.05)", 1, true), tostring(tr))
    assert.are.equal(1, #said)
    assert.truthy(said[1]:find("'step' = 1000000.0 is longer than the output spacing 'dt' = 0.05: every output point "
      .. "ends a step, so the steps are 0.05", 1, true), said[1])
    -- x'' = -x from x = 1 at rest: cos t
    assert(math.abs(tr.q[#tr.q][1] - math.cos(1)) <= 1e-9)
  end)
  it("sys:accel at a state off a holonomic constraint warns once, naming it and its value", function()
    local system = require "nz.system"
    local pend = nz.system{ name = "cartesian", coords = { "x", "y" },
      T = function(t, q, qd) return 0.5 * (qd[1] ^ 2 + qd[2] ^ 2) end, V = function(t, q) return g * q[2] end,
      constraints = { function(t, q) return q[1] ^ 2 + q[2] ^ 2 - 1 end } }
    local said, saved = {}, system.warn
    system.warn = function(msg) said[#said + 1] = msg end
    local ok, e = pcall(function()
      pend:accel(0, { 0.6, -0.8 }, { 0.8, 0.6 })            -- on it: nothing to say
      assert.are.equal(0, #said)
      -- (0.7, -0.8), (0.8, 0.6): Phi = 0.13 (0.13 / 2.39 of its terms
      -- 2 x^2 + 2 y^2 + |Phi|), Phi' = 2 (x x' + y y') = 0.16 (of 1.12 +
      -- 0.96 + 0.16): the velocity level is the worse, 0.0714
      local _, _, report = pend:accel(0, { 0.7, -0.8 }, { 0.8, 0.6 })
      assert.are.equal(1, #said)
      assert.truthy(said[1]:find("sys:accel: warning: system 'cartesian': the state at t = 0 violates constraint 1 at "
        .. "velocity level by 0.16 (0.0714 of the size of its terms)", 1, true), said[1])
      assert.truthy(said[1]:find("q, qd = sys:project(t, q, qd)", 1, true), said[1])
      assert(math.abs(report.violation.value - 0.16) <= 1e-15 and math.abs(report.violation.relative - 0.16 / 2.24) <= 1e-15)
      pend:accel(0, { 0.9, -0.8 }, { 0.8, 0.6 })            -- once
      assert.are.equal(1, #said)
    end)
    system.warn = saved
    assert(ok, e)
  end)
  it("an error deep in a recursion of T says the root cause and the state once", function()
    local depth, sys = 0, nil
    local line = here() + 5
    sys = nz.system{ name = "recursive", coords = { "x" }, compile = false,
      T = function(t, q, qd)
        depth = depth + 1
        if sys then
          if depth > 40 then error("too deep") end
          sys:energy(0, { 0.1 }, { 0.2 })
        end
        return 0.5 * qd[1] ^ 2
      end }
    depth = 0
    local ok, e = pcall(sys.accel, sys, 0, { 1 }, { 0 })
    assert.is_false(ok)
    e = tostring(e)
    -- it repeated "T raised an error" and the state 40 times (2.5 kB)
    assert.are.equal(("%s:%d: system 'recursive': T raised an error: too deep at t = 0, q = {0.1}, qd = {0.2} (nested 40 "
      .. "deep; the outermost call: T at t = 0, q = {1}, qd = {0})"):format(SPEC, line), e)
  end)
  it("error({}) in T shows the object's __tostring, or its type", function()
    local function with(obj)
      return nz.system{ name = "object", coords = { "x" }, compile = false,
        T = function(t, q, qd) if q[1]:value() > 0.5 then error(obj) end return 0.5 * qd[1] ^ 2 end }
    end
    local plain = with({})
    h.checkerror("system 'object': T raised an error: an error object of type table (give error() a string, or the "
      .. "object a __tostring) at t = 0, q = {1}", plain.accel, plain, 0, { 1 }, { 0 })
    local named = with(setmetatable({}, { __tostring = function() return "the wheel came off" end }))
    h.checkerror("system 'object': T raised an error: the wheel came off at t = 0, q = {1}", named.accel, named, 0, { 1 }, { 0 })
  end)
  it("taylor with project on a system without constraints warns as every method does, and runs", function()
    local simulate = require "nz.motion.simulate"
    local free = nz.system{ name = "free osc", coords = { "x" }, T = function(t, q, qd) return 0.5 * qd[1] ^ 2 end,
      V = function(t, q) return 0.5 * q[1] ^ 2 end }
    local said, saved = {}, simulate.warn
    simulate.warn = function(msg) said[#said + 1] = msg end
    local ok, tr = pcall(free.simulate, free, { q0 = { 1 }, t1 = 1, project = true, method = "taylor" })
    simulate.warn = saved
    assert(ok, tostring(tr))
    assert.are.equal(1, #said)
    assert.truthy(said[1]:find("'project' does nothing: the system has no constraints", 1, true), said[1])
    assert(math.abs(tr.q[#tr.q][1] - math.cos(1)) <= 1e-9)
  end)
end)
