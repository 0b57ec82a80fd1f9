-- cli_spec.lua - nzlua as a script runner, tested as a black box.
local h = require "tests.helpers"
local nzlua = h.nzlua

describe("nzlua script runner", function()
  it("runs a script with arg set as the standalone lua does", function()
    local code, out = h.run(nzlua .. " tests/data/args.lua one two")
    assert.are.equal(0, code)
    assert.truthy(out:find("arg0=tests/data/args.lua\tn=2\tfirst=one\tdots=2", 1, true), out)
    assert.truthy(out:find("nz=table\tsin=function\tversion=", 1, true), out)
  end)
  it("a syntax error exits 1 with file:line", function()
    local code, _, err = h.run(nzlua .. " tests/data/syntax_error.lua")
    assert.are.equal(1, code)
    assert.truthy(err:find("tests/data/syntax_error.lua:2:", 1, true), err)
  end)
  it("a runtime error exits 1 with file:line, message and traceback", function()
    local code, _, err = h.run(nzlua .. " tests/data/runtime_error.lua")
    assert.are.equal(1, code)
    assert.truthy(err:find("tests/data/runtime_error.lua:2: 'log' of a non-positive value (got -1)", 1, true), err)
    assert.truthy(err:find("stack traceback:", 1, true), err)
  end)
  it("a failing script prints file:line: message, and a traceback only through functions it wrote, of their frames only", function()
    local script = os.tmpname()
    local function run(text)
      local f = assert(io.open(script, "w"))
      f:write(text)
      f:close()
      return h.run(nzlua .. " " .. script)
    end
    local sys = 'sys = nz.system{ name = "p", coords = { "x" }, T = function(t, q, qd) return qd[1] ^ 2 / 2 end }\n'
    -- an engine error from the main chunk: the message alone (its library frames said nothing)
    local code, _, err = run(sys .. "sys:simulate{ q0 = { 0 }, t1 = 1, rtoll = 1e-6 }\n")
    assert.are.equal(1, code)
    assert.are.equal(("nzlua: %s:2: simulate 'p': unknown option 'rtoll' (did you mean 'rtol'?)"):format(script),
      err:match("^[^\n]*"):gsub(" %(options: .*", ""))
    assert.falsy(err:find("traceback", 1, true), err)
    -- through a function of the script: its frames, and nothing of the library's or C's
    code, _, err = run(sys .. "local function run(tol)\n  local tr = sys:simulate{ q0 = { 0 }, t1 = 1, rtol = tol }\n  return tr\nend\n"
      .. "run(-1)\n")   -- line 6
    os.remove(script)
    assert.are.equal(1, code)
    assert.truthy(err:find(("^nzlua: %s:3: simulate 'p': "):format(script:gsub("%p", "%%%0"))), err)
    local frames = err:match("\nstack traceback:\n(.*)$")
    assert(frames, err)
    assert.are.equal(("\t%s:3: in local 'run'\n\t%s:6: in main chunk\n"):format(script, script), frames)
  end)
  it("a missing script exits 1 and says so", function()
    local code, _, err = h.run(nzlua .. " tests/data/no_such_file.lua")
    assert.are.equal(1, code)
    assert.truthy(err:find("cannot open tests/data/no_such_file.lua", 1, true), err)
  end)
  it("-e runs a statement; a failing one exits 1", function()
    local code, out = h.run(nzlua .. [[ -e 'print(nz.exp(0) + 1)']])
    assert.are.equal(0, code)
    assert.are.equal("2.0\n", out)
    local code2, _, err = h.run(nzlua .. [[ -e 'error("boom")']])
    assert.are.equal(1, code2)
    assert.truthy(err:find("(command line):1: boom", 1, true), err)
  end)
  it("-l requires a library into a global", function()
    local code, out = h.run(nzlua .. [[ -l tests.helpers -e 'print(type(tests))']])
    assert.are.equal(0, code, out)
  end)
  it("- reads the script from stdin", function()
    local code, out = h.run(nzlua .. " - x y", "print(select('#', ...), ...)")
    assert.are.equal(0, code)
    assert.are.equal("2\tx\ty\n", out)
  end)
  it("no arguments and stdin not a terminal runs stdin", function()
    local code, out = h.run(nzlua, "print(sin(0))")
    assert.are.equal(0, code)
    assert.are.equal("0.0\n", out)
  end)
  it("-i runs the script, then reads the session from stdin", function()
    local code, out = h.run(nzlua .. " -i tests/data/define.lua", "answer\nanswer + 1\n")
    assert.are.equal(0, code)
    assert.truthy(out:find("42\n", 1, true), out)
    assert.truthy(out:find("43\n", 1, true), out)
  end)
  it("--help and --version", function()
    local code, out = h.run(nzlua .. " --help")
    assert.are.equal(0, code)
    assert.truthy(out:find("usage: nzlua [options] [script [args]]", 1, true), out)
    code, out = h.run(nzlua .. " --version")
    assert.are.equal(0, code)
    assert.truthy(out:match("^nzlua %d+%.%d+%.%d+"), out)
  end)
  it("an unknown option exits 1 with the usage", function()
    local code, _, err = h.run(nzlua .. " --frobnicate")
    assert.are.equal(1, code)
    assert.truthy(err:find("unrecognized option or missing argument '--frobnicate'", 1, true), err)
    assert.truthy(err:find("usage:", 1, true), err)
    code, _, err = h.run(nzlua .. " -e")
    assert.are.equal(1, code)
    assert.truthy(err:find("missing argument '-e'", 1, true), err)
  end)
  it("a script is stopped by SIGINT with 'interrupted!' and exit 130 (128 + SIGINT)", function()
    local code, _, err = h.run("timeout --foreground --preserve-status -s INT 1 " .. nzlua .. [[ -e 'while true do end']])
    assert.are.equal(130, code)
    assert.truthy(err:find("interrupted!", 1, true), err)
  end)
  it("no progress bar when the output is not a terminal", function()
    local code, _, err = h.run(nzlua .. [[ -e 'local s = nz.system{coords = {"x"}, T = function(t, q, v) return v[1]^2 / 2 end, V = function(t, q) return q[1]^2 / 2 end}; s:simulate{q0 = {1}, t1 = 3000, dt = 1}']])
    assert.are.equal(0, code)
    assert.falsy(err:find("Ctrl-C stops", 1, true), err)
  end)
  it("SIGINT inside a user function called by the C mechanics stops cleanly", function()
    local code, _, err = h.run("timeout --foreground --preserve-status -s INT 1 " .. nzlua ..
      [[ -e 'local s = nz.system{coords = {"x"}, T = function(t, q, v) while true do end end}; s:accel(0, {0}, {0})']])
    assert.are.equal(130, code)
    assert.truthy(err:find("interrupted!", 1, true), err)
    assert.falsy(err:find("raised an error", 1, true), err)
  end)
end)

-- A script file with `text`, removed by the caller.
local function script(text)
  local name = os.tmpname()
  local f = assert(io.open(name, "w"))
  f:write(text)
  f:close()
  return name
end

local slurp = h.slurp

local OSCILLATOR = [[
local osc = nz.system{ name = "osc", coords = {"x"}, T = function(t, q, v) return 0.5 * v[1]^2 end,
  V = function(t, q) return 0.5 * q[1]^2 end }
]]

-- The driven hoop integrated by bsimp with the work monitor: the exact
-- Jacobian evaluates T, V and the constraint on nested dual numbers.
local HOOP = [[
local m, R, W, g = 0.3, 0.5, 4.0, 9.81
local hoop = nz.system{ name = "driven hoop", coords = { "th", "ph" },
  T = function(t, q, qd) return 0.5 * m * R * R * (qd[1] ^ 2 + nz.sin(q[1]) ^ 2 * qd[2] ^ 2) end,
  V = function(t, q) return -m * g * R * nz.cos(q[1]) end,
  constraints = { function(t, q) return q[2] - W * t end } }
]]

describe("interrupts and failures lose nothing", function()
  it("a script interrupted during simulate keeps the part computed, can save it, and exits 130", function()
    local csv = os.tmpname()
    local name = script(OSCILLATOR .. ([[
local tr = osc:simulate{ q0 = {1}, t1 = 1e7, dt = 10, rtol = 1e-12 }
tr:csv("%s")
print("status " .. tr.status .. " points " .. #tr.t)
local again = osc:simulate{ q0 = {1}, t1 = 1e7, dt = 10 }
print("then " .. again.status .. " points " .. #again.t)
]]):format(csv))
    local code, out, err = h.run("timeout --foreground --preserve-status -s INT 2 " .. nzlua .. " " .. name)
    os.remove(name)
    local text = slurp(csv) or ""
    os.remove(csv)
    assert.are.equal(130, code, err)
    local n = tonumber(out:match("status interrupted points (%d+)"))
    assert(n and n > 1, out .. err)
    local _, rows = text:gsub("\n", "")
    assert.are.equal(n + 1, rows)            -- the header and every point
    -- the user asked to stop: a later simulate raises the interrupt, so the
    -- script stops there (never a 1-point "interrupted" result taken for an answer)
    assert.is_nil(out:find("then ", 1, true), out)
    assert.truthy(err:find("stopped by Ctrl-C at t = ", 1, true), err)
    assert.truthy(err:find("the trajectory is partial (t1 = 1e+07 not reached)", 1, true), err)
    assert.truthy(err:find("interrupted!", 1, true), err)
  end)
  it("a user's error that says 'interrupted!' is an error (exit 1), with its message", function()
    local code, _, err = h.run(nzlua .. [[ -e 'local s = nz.system{coords = {"x"}, T = function(t, q, v) error("not interrupted! really") end}; s:accel(0, {0}, {0})']])
    assert.are.equal(1, code)
    assert.truthy(err:find("(command line):1: system 'unnamed': T raised an error: not interrupted! really", 1, true), err)
  end)
  for _, sig in ipairs{ "INT", "TERM" } do
    it("SIG" .. sig .. " while tr:csv writes leaves the previous complete file, never a cut one", function()
      local out, ref = os.tmpname(), os.tmpname()
      -- 20001 rows per write; the script signals itself 0.5 s after the
      -- first complete file, while it rewrites the same file in a loop.
      local name = script(OSCILLATOR .. ([[
local tr = osc:simulate{ q0 = {1}, t1 = 100, dt = 0.005 }
tr:csv("%s")
tr:csv("%s")
os.execute("(sleep 0.5; kill -%s $PPID) &")
for i = 1, 3000 do tr:csv("%s") end
print("the loop ended before the signal")
]]):format(ref, out, sig, out))
      local code, stdout = h.run(nzlua .. " " .. name)
      os.remove(name)
      local want, got = slurp(ref), slurp(out)
      local _, leftovers = h.run(("ls %s.* 2>/dev/null"):format(out))
      h.run(("rm -f %s %s %s.*"):format(ref, out, out))
      assert.are.equal(sig == "INT" and 130 or 143, code, stdout)
      assert(want and #want > 500000, "the reference file was not written")
      assert(got == want, ("the file is not the complete one: %d bytes of %d"):format(got and #got or 0, #want))
      -- Ctrl-C removes the file being written; a kill is held until the
      -- write and the rename are done: neither leaves a file beside.
      assert.are.equal("", leftovers)
    end)
  end
  it("Ctrl-C during a bsimp run with monitors stops cleanly (and leaks nothing under ASan)", function()
    local name = script(HOOP .. [[
local tr = hoop:simulate{ q0 = { 0.7, 0 }, qd0 = { 0.3, W }, t1 = 1e6, dt = 5, method = "bsimp", monitors = { work = true } }
print("status " .. tr.status .. " points " .. #tr.t)
]])
    local code, out, err = h.run("timeout --foreground --preserve-status -s INT 1.5 " .. nzlua .. " " .. name)
    os.remove(name)
    assert.are.equal(130, code, err)
    assert.truthy(out:find("status interrupted points", 1, true), out .. err)
    assert.falsy(err:find("LeakSanitizer", 1, true), err)
  end)
  it("an error or the interrupt while building the dualjet arguments does not unwind through the core", function()
    -- Deterministic: the engine's testing hook raises before the 1000th
    -- dualjet argument, in the middle of an exact Jacobian evaluated by the
    -- Lua evaluator (compile = false; running out of memory raises there).
    local name = script(HOOP:gsub('coords = { "th", "ph" },', 'coords = { "th", "ph" }, compile = false,', 1) .. [[
local mech = require("nz.core").mech
local function failing(raise)
  local calls = 0
  mech.argument_hook(function() calls = calls + 1; if calls == 1000 then raise() end end)
end

local run = { q0 = { 0.7, 0 }, qd0 = { 0.3, W }, t1 = 3, method = "bsimp", monitors = { work = true }, dense = false }
failing(function() error("boom") end)
local ok, err = pcall(hoop.simulate, hoop, run)
print(ok, err)
failing(function() error(nz.interrupted) end)
local tr = hoop:simulate(run)
print("status " .. tr.status)
]])
    local code, out, err = h.run(nzlua .. " " .. name)
    os.remove(name)
    assert.are.equal(0, code, err)
    -- the script's line that raised comes first (line 13: the hook)
    assert.truthy(out:find(":13: system 'driven hoop': T could not build the arguments: boom at t = ", 1, true), out)
    assert.truthy(out:find("status interrupted", 1, true), out)
    assert.falsy(err:find("LeakSanitizer", 1, true), err)
  end)
end)

describe("make install", function()
  it("installs nzlua and nz.so where plain lua5.4 finds the module", function()
    local dest = os.tmpname()
    os.remove(dest)
    local code, out, err = h.run(("make -s install DESTDIR=%s PREFIX=/usr/local"):format(dest))
    assert.are.equal(0, code, out .. err)
    code, out, err = h.run(("LUA_CPATH='%s/usr/local/lib/lua/5.4/?.so' lua5.4 -e 'print(require(\"nz\").version)'"):format(dest))
    assert.are.equal(0, code, err)
    assert.truthy(out:match("^%d+%.%d+%.%d+"), out)
    code, out = h.run(dest .. "/usr/local/bin/nzlua -e 'print(nz.sin(0))'")
    assert.are.equal(0, code)
    assert.are.equal("0.0\n", out)
    h.run("rm -rf " .. dest)
  end)
end)

describe("the nz module from plain Lua", function()
  it("require 'nz' works from lua5.4 and touches no global", function()
    local code, out, err = h.run([[LUA_CPATH='build/?.so;;' lua5.4 -e '
      local before = {}
      for k in pairs(_G) do before[k] = true end
      local nz = require "nz"
      for k in pairs(_G) do assert(before[k], "new global " .. k) end
      print(nz.exp(nz.jet(0, 2)))']])
    assert.are.equal(0, code, err)
    assert.are.equal("jet{1, 1, 0.5; order 2}\n", out)
  end)
end)
