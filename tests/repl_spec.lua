-- repl_spec.lua - the nzlua session tested as a person uses it: a real
-- terminal (tmux), keys typed, the screen read back.
local h = require "tests.helpers"

local session = "nzlua_test_" .. tostring(os.time()) .. "_" .. tostring(math.random(1e6))
local history = os.tmpname()

-- A tmux server of our own (-L): never the user's, started from this
-- process's environment (so ASAN_OPTIONS and the like reach the pane).
local tmux = "tmux -L " .. session .. " "

local function sh(cmd)
  local code, out = h.run((cmd:gsub("^tmux ", tmux)))
  return code, out
end

local function screen()
  local _, out = sh("tmux capture-pane -p -J -S -200 -t " .. session)
  return out
end

-- Wait until the screen shows `text` (plain) `count` times; return the screen.
local function wait_for(text, count, timeout)
  count, timeout = count or 1, timeout or 10
  local deadline = os.time() + timeout
  local s
  repeat
    s = screen()
    local n, i = 0, 1
    while true do
      local a, b = s:find(text, i, true)
      if not a then break end
      n, i = n + 1, b + 1
    end
    if n >= count then return s end
    sh("sleep 0.05")
  until os.time() > deadline
  error(("screen never showed %q %d time(s); it shows:\n%s"):format(text, count, s))
end

local function type_keys(...)
  local keys = {}
  for i = 1, select("#", ...) do keys[#keys + 1] = "'" .. select(i, ...):gsub("'", "'\\''") .. "'" end
  sh("tmux send-keys -t " .. session .. " " .. table.concat(keys, " "))
end

local function type_line(text) type_keys("-l", text); type_keys("Enter") end

local function start()
  sh("tmux kill-session -t " .. session)
  -- The shell around nzlua prints its exit status, so that a test can see
  -- the session end (and end well); `sleep` keeps the pane readable.
  local cmd = ("env NZLUA_HISTORY=%s TERM=xterm %s; echo \"[nzlua exited with status $?]\"; sleep 60")
    :format(history, h.nzlua)
  assert(sh(("tmux new-session -d -s %s -x 150 -y 50 '%s'"):format(session, cmd)) == 0, "tmux failed to start")
  wait_for("nz> ")
end

describe("the nzlua session", function()
  setup(function() os.remove(history); start() end)
  teardown(function() sh("tmux kill-server"); os.remove(history) end)

  it("prints the value of an expression", function()
    type_line("1 + 41")
    wait_for("\n42\n")
  end)
  it("prints jets and tables readably", function()
    type_line("jet(0, 2)")
    wait_for("jet{0, 1, 0; order 2}")
    type_line("{1, 2, x = 3}")
    wait_for("{1, 2, x = 3}")
  end)
  it("prints a jet's coefficients in the shortest digits that read back exactly", function()
    type_line("sin(jet(0, 5))")
    wait_for("jet{0, 1, 0, -0.16666666666666666, 0, 0.008333333333333333; order 5}")
  end)
  it("prints a system's constraints and rule, and help(tr), within 80 columns, the rule as sentences", function()
    type_line("skate = nz.system{name = 'sleigh', coords = {'x', 'y', 'th'}, T = function(t, q, v) return (v[1]^2 + v[2]^2 + v[3]^2) / 2 end, constraints = {function(t, q, v) return -v[1] * nz.sin(q[3]) + v[2] * nz.cos(q[3]) end}}")
    type_line("skate:constraints()")
    local s = wait_for("  1: ")
    local table_text = s:match("\nSystem 'sleigh': 1 constraint\n(.-)\nnz> ")
    assert(table_text, s)
    for line in table_text:gmatch("[^\n]+") do assert(#line <= 80, ("%d columns: %s"):format(#line, line)) end
    type_line("select(2, skate:rule())")
    wait_for("Dolapchiev's rule: n = 1, Nielsen's equations (Jourdain's principle), since constraint 1 is of first order")
    type_line("help(skate:simulate{q0 = {0, 0, 0}, qd0 = {1, 0, 0.5}, t1 = 1})")
    s = wait_for("Each event crossing, tr.events[e]")
    local help_text = s:match("\n(tr: a trajectory of 'sleigh'.-)\nnz> ")
    assert(help_text, s)
    for line in help_text:gmatch("[^\n]+") do assert(#line <= 80, ("%d columns: %s"):format(#line, line)) end
  end)
  it("reads a statement over two lines", function()
    type_line("for i = 1, 3 do")
    wait_for("nz>> ")
    type_line("io.write(i, ';') end")
    wait_for("1;2;3;")
  end)
  it("reports an error and goes on, without a traceback for a typed call", function()
    type_line("nz.log(-2)")
    local s = wait_for("'log' of a non-positive value (got -2)")
    assert.falsy(s:find("stack traceback", 1, true), s)
    type_line("6 * 7 + 1")
    wait_for("\n43\n")
  end)
  it("shows a traceback when the error came from inside a function", function()
    type_line("function inner() error('deep trouble') end; function outer() inner() end")
    type_line("outer()")
    wait_for("deep trouble")
    wait_for("in function 'inner'")
  end)
  it("a traceback shows only the frames of the functions typed, none of the library's or C's", function()
    type_line("function go() local tr = nz.system{coords = {'x'}, T = function(t, q, v) return v[1]^2 / 2 end}:simulate{q0 = {0}, t1 = 1, rtol = -1}; return tr end")
    type_line("go()")
    local s = wait_for("in function 'go'")
    local tb = s:match("nz> go%(%)\n.-stack traceback:\n(.-)nz> ") or ""
    assert.truthy(s:find("stdin:1: simulate 'unnamed': 'rtol' (the relative tolerance) must be a positive finite number, got -1", 1, true), s)
    assert.falsy(tb:find("lua/nz/", 1, true), tb)
    assert.falsy(tb:find("[C]", 1, true), tb)
    assert.truthy(tb:find("stdin:1: in function 'go'\n%s*stdin:1: in main chunk"), tb)
  end)
  it("Ctrl-C interrupts a busy loop and the session goes on", function()
    type_line("while true do end")
    sh("sleep 0.3")
    type_keys("C-c")
    wait_for("interrupted!")
    type_line("2 * 22")
    wait_for("\n44\n")
  end)
  it("Ctrl-C at the prompt discards the line", function()
    type_keys("-l", "undefined_function_xyz()")
    type_keys("C-c")
    type_line("3 * 15")
    local s = wait_for("\n45\n")
    assert.falsy(s:find("attempt to call", 1, true), s)
  end)
  it("completes globals, fields and methods with Tab", function()
    type_keys("-l", "nz.hyp")
    type_keys("Tab")
    type_line("(3, 4)")
    wait_for("\n5.0\n")
    type_line("xj = jet(1, 2)")
    type_keys("-l", "xj:coe")
    type_keys("Tab")
    type_line("(1)")
    wait_for("xj:coef(1)")
    type_line("sy = nz.system{coords = {'x'}, T = function(t, q, v) return v[1]^2 / 2 end}")
    type_keys("-l", "sy:acc")
    type_keys("Tab")
    type_line("(0, {0}, {0})")
    wait_for("sy:accel(0, {0}, {0})")
  end)
  it("a long simulation shows progress, and Ctrl-C keeps what it computed", function()
    type_line("osc = nz.system{coords = {'x'}, T = function(t, q, v) return v[1]^2 / 2 end, V = function(t, q) return q[1]^2 / 2 end}")
    type_line("long = osc:simulate{q0 = {1}, t1 = 1e7, dt = 10}")
    wait_for("(Ctrl-C stops, keeping what is done)")
    type_keys("C-c")
    wait_for("the part computed so far is kept (")
    type_line("print(long.status .. ' ' .. tostring(#long.t > 10))")
    wait_for("\ninterrupted true")
  end)
  it("Ctrl-C on a bare simulate at the prompt leaves the part computed in nz.last", function()
    type_line("osc2 = nz.system{coords = {'x'}, T = function(t, q, v) return v[1]^2 / 2 end, V = function(t, q) return q[1]^2 / 2 end}")
    type_line("osc2:simulate{q0 = {1}, t1 = 1e7, dt = 10}")
    wait_for("(Ctrl-C stops, keeping what is done)")
    type_keys("C-c")
    wait_for("the part computed so far is kept (", 2)
    type_line("print('last ' .. nz.last.status .. ' ' .. tostring(#nz.last.t > 10) .. ' ' .. nz.last.system.name)")
    wait_for("\nlast interrupted true unnamed")
  end)
  it("a user's error that says 'interrupted!' prints its message, with the user's line", function()
    type_line("bad = nz.system{coords = {'x'}, T = function(t, q, v) error('interrupted! said the user') end}")
    type_line("bad:accel(0, {0}, {0})")
    wait_for("stdin:1: system 'unnamed': T raised an error: interrupted! said the user")
  end)
  it("the banner says how to get help; quit says how to leave; numbers print in their shortest exact form", function()
    local s = screen()
    assert.truthy(s:find("Type help() for what nz offers", 1, true), s)
    type_line("quit")
    wait_for("leave with Ctrl-D, or os.exit()")
    type_line("math.pi")
    s = wait_for("\n3.141592653589793\n")
    assert.falsy(s:find("3.1415926535897931", 1, true), s)
  end)
  it("_ holds the last value; a function that prints returns no stray nil; a printed table once", function()
    type_line("6 * 7")
    wait_for("\n42\n")
    type_line("_ + 1")
    wait_for("\n43\n")
    type_line("help(nz.jet) ; print('after help')")
    local s = wait_for("after help")
    type_line("print('mark A')")
    s = wait_for("mark A")
    assert.falsy(s:find("after help\nnil", 1, true), s)
    type_line("help(nz.jet)")
    type_line("print('mark B')")
    s = wait_for("mark B")
    assert.falsy(s:find("\nnil\nnz> print('mark B')", 1, true), s)
    type_line("sl = nz.system{coords = {'x', 'y', 'th'}, T = function(t, q, v) return (v[1]^2 + v[2]^2 + v[3]^2) / 2 end,"
      .. " constraints = {function(t, q, v) return v[1] * nz.sin(q[3]) - v[2] * nz.cos(q[3]) end}}")
    type_line("sl:constraints()")
    s = wait_for("1 constraint")
    type_line("print('mark C')")
    s = wait_for("mark C", 2)
    local tail = s:sub((s:find("sl:constraints()", 1, true)))
    assert.falsy(tail:find("{{", 1, true), tail)   -- no raw dump of the classes after the table
  end)
  it("a call that prints its result shows it once (nz.check, sys:report); the values kept from it print later", function()
    local function count(s, text)
      local _, n = s:gsub(text:gsub("%p", "%%%0"), "")
      return n
    end
    type_line("ck = nz.system{name = 'once', coords = {'x'}, T = function(t, q, v) return v[1]^2 / 2 end,"
      .. " V = function(t, q) return q[1]^2 / 2 end}")
    type_line("nz.check(ck, function(t, q, qd, qdd) return { qdd[1] + q[1] } end)")
    type_line("ck:report{ q = {1}, plot = false }")
    type_line("print('mark E')")
    local s = wait_for("mark E", 2)
    local tail = s:sub((s:find("nz.check(ck", 1, true)))
    assert.are.equal(1, count(tail, "Your equations are equivalent"), tail)
    assert.falsy(tail:find("\ntrue\t", 1, true), tail)                 -- not ok, text again
    assert.are.equal(1, count(tail, "trajectory of 'once'"), tail)      -- not tr, n again
    -- kept in variables (an assignment prints nothing), they print when typed
    type_line("ok1, text1 = nz.check(ck, function(t, q, qd, qdd) return { 2 * qdd[1] + 2 * q[1] } end)")
    type_line("ok1")
    s = wait_for("ok1\ntrue\n")
  end)
  it("a method called with a dot says what to write, after the typed line's place, without a traceback", function()
    type_line("dt_sys = nz.system{coords = {'x'}, T = function(t, q, v) return v[1]^2 / 2 end}")
    type_line("dt_sys.simulate{ q0 = {1}, t1 = 1 }")
    local s = wait_for("stdin:1: simulate called with a dot: write sys:simulate{...} (sys: your system), with a colon,"
      .. " so that the method gets its system")
    type_line("print('mark F')")
    s = wait_for("mark F", 2)
    local tail = s:sub((s:find("dt_sys.simulate{", 1, true)))
    assert.falsy(tail:find("stack traceback", 1, true), tail)
  end)
  it("a plot typed at the prompt is drawn once", function()
    type_line("po = nz.system{coords = {'x'}, T = function(t, q, v) return v[1]^2 / 2 end, V = function(t, q) return q[1]^2 / 2 end}")
    type_line("ptr = po:simulate{q0 = {1}, t1 = 3}")
    type_line("ptr:plot{ y = {'x'}, title = 'drawn once' }")
    type_line("print('mark D')")
    local s = wait_for("mark D", 2)   -- the typed line and its output: the plot is drawn by then
    local n = 0
    for _ in s:gmatch("drawn once") do n = n + 1 end
    assert.are.equal(1 + 1, n)   -- the typed line and the plot's title
  end)
  it("keeps history across sessions, and Ctrl-D leaves", function()
    type_line("marker_value = 12345")
    type_keys("C-d")
    wait_for("[nzlua exited with status 0]")
    local f = assert(io.open(history))
    local text = f:read("a")
    f:close()
    assert.truthy(text:find("marker_value = 12345", 1, true), text)
    start()
    type_keys("Up")
    type_keys("Enter")
    type_line("marker_value + 1")
    wait_for("\n12346\n")
  end)
  it("a statement typed over two lines comes back from the history as one entry after a restart", function()
    type_line("for i = 1, 3 do")
    wait_for("nz>> ")
    type_line("io.write(i * 7, ';') end")
    wait_for("7;14;21;")
    type_keys("C-d")
    wait_for("[nzlua exited with status 0]")
    start()
    type_keys("Up")
    type_keys("Enter")
    wait_for("7;14;21;")    -- the whole loop ran again from one recalled entry
  end)
end)
