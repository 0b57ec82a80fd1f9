-- sweep_spec.lua - nz.sweep: worker processes give the numbers of one
-- process bit for bit, the results file keeps every finished point, a
-- resume computes only the missing ones, failures are recorded, the
-- worker protocol of nzlua --sweep-worker, GNU parallel across two "hosts"
-- (a local ssh wrapper), the periods against the elliptic closed form.
local h = require "tests.helpers"
local nz = h.nz
local sweep = require "nz.motion.sweep"

local SCENE = "tests/data/sweep_pendulum.lua"
local GRID = { amp = { 0.3, 0.9, 1.5, 2.1 }, l = { 1, 2.5 } }

local slurp = h.slurp

local function write(path, text)
  local f = assert(io.open(path, "wb"))
  f:write(text)
  f:close()
end

local lines = h.lines

local function quiet(opts)
  opts.progress = false
  return opts
end

-- The same numbers, the same types (an integer stays an integer).
local function same_value(a, b)
  return a == b and math.type(a) == math.type(b) or (a ~= a and b ~= b)
end

local function assert_same_rows(want, got, what)
  assert.are.equal(#want, #got, what .. ": number of rows")
  for i, w in ipairs(want) do
    for k, v in pairs(w) do
      assert(same_value(v, got[i][k]), ("%s: row %d, '%s': expected %s, got %s"):format(what, i, k,
        tostring(v), tostring(got[i][k])))
    end
    for k in pairs(got[i]) do assert(w[k] ~= nil, ("%s: row %d has an extra '%s'"):format(what, i, k)) end
  end
end

describe("nz.sweep", function()
  it("jobs = 2 gives the rows of jobs = 1 bit for bit; each period is 4 K(sin(amp/2)) sqrt(l/g)", function()
    local one = nz.sweep(quiet{ file = SCENE, grid = GRID, jobs = 1 })
    local two = nz.sweep(quiet{ file = SCENE, grid = GRID, jobs = 2 })
    assert.are.equal("complete", two.status)
    assert.are.equal(8, two.computed)
    assert_same_rows(one, two, "jobs = 2 against jobs = 1")
    for _, r in ipairs(two) do
      local want = 4 * nz.special.ellint_K(math.sin(r.amp / 2)) * math.sqrt(r.l / 9.81)
      local err = math.abs(r.period - want) / want
      assert(err < 1e-9, ("amp %g, l %g: period %.15g, closed form %.15g (relative error %.2e)"):format(
        r.amp, r.l, r.period, want, err))
    end
    -- rows come in the order of the points: the first name varies slowest
    assert.are.same({ 0.3, 1 }, { two[1].amp, two[1].l })
    assert.are.same({ 0.3, 2.5 }, { two[2].amp, two[2].l })
    assert.are.same({ 2.1, 2.5 }, { two[8].amp, two[8].l })
  end)

  it("runs a system and a run function given inline, with the point's parameters set (and restored)", function()
    local sys = nz.system{ name = "spring", coords = { "x" }, params = { k = 4.0, m = 1.0 },
      T = function(t, q, qd, p) return 0.5 * p.m * qd[1]^2 end,
      V = function(t, q, p) return 0.5 * p.k * q[1]^2 end }
    local seen = 7       -- an upvalue reaches the workers (fork keeps the closure)
    local function run(s, p) return { omega2 = s:accel(0, { -1 }, { 0 })[1], k_seen = s.params.k, seen = seen, x = p.x } end
    for _, jobs in ipairs{ 1, 2 } do
      local rows = nz.sweep(quiet{ system = sys, list = { { k = 1.5, y = 1 }, { k = 9, y = 2 }, { k = 2.25, y = 3 } },
        run = function(s, p) local r = run(s, p); r.x = nil; return r end, jobs = jobs })
      for i, k in ipairs{ 1.5, 9, 2.25 } do
        assert.are.equal(k, rows[i].omega2)
        assert.are.equal(k, rows[i].k_seen)
        assert.are.equal(7, rows[i].seen)
      end
      assert.are.equal(4.0, sys.params.k)
    end
  end)

  it("writes a CSV: a header (inputs, outputs, error), one row per point, numbers that read back exactly", function()
    local out = os.tmpname()
    local rows = nz.sweep(quiet{ file = SCENE, grid = GRID, jobs = 2, out = out })
    local text = slurp(out)
    local l = lines(text)
    assert.are.equal("amp,l,crossings,period,error", l[1])
    assert.are.equal(9, #l)
    local back = {}
    local records = sweep.parse_csv(text)
    for r = 2, #records do
      local rec = records[r]
      assert.are.equal(5, rec.n)
      assert.is_nil(rec[5])
      back[#back + 1] = { amp = rec[1], l = rec[2], crossings = rec[3], period = rec[4] }
    end
    table.sort(back, function(a, b) return a.amp < b.amp or a.amp == b.amp and a.l < b.l end)
    assert_same_rows(rows, back, "the CSV read back")
    -- the same sweep again finds every point done: nothing is computed, the rows are the same
    local again = nz.sweep(quiet{ file = SCENE, grid = GRID, jobs = 2, out = out })
    assert.are.equal(0, again.computed)
    assert.are.equal(8, again.resumed)
    assert_same_rows(rows, again, "the rows resumed from the CSV")
    assert.are.equal(text, slurp(out))
    os.remove(out)
  end)

  it("resumes a partial file (a line cut short too): computes only the missing points", function()
    local out, calls = os.tmpname(), os.tmpname()
    local full = nz.sweep(quiet{ file = SCENE, grid = GRID, jobs = 2, out = out })
    local l = lines(slurp(out))
    -- keep the header and 3 rows, and half of a fourth as a kill leaves it
    write(out, table.concat({ l[1], l[2], l[3], l[4] }, "\n") .. "\n" .. l[5]:sub(1, 9))
    os.remove(calls)
    local base = loadfile(SCENE)().run
    local function run(s, p)            -- each call leaves a line in a file (workers are processes)
      local f = assert(io.open(calls, "a"))
      f:write(("%s %s\n"):format(p.amp, p.l))
      f:close()
      return base(s, p)
    end
    local rows = nz.sweep(quiet{ file = SCENE, run = run, grid = GRID, jobs = 2, out = out })
    assert.are.equal(5, #lines(slurp(calls)))
    assert.are.equal(5, rows.computed)
    assert.are.equal(3, rows.resumed)
    assert_same_rows(full, rows, "after the resume")
    local after = lines(slurp(out))
    assert.are.equal(9, #after)           -- the cut line is gone, one row per point
    local seen = {}
    for i = 2, #after do
      assert.is_nil(seen[after[i]], "a row written twice: " .. after[i])
      seen[after[i]] = true
    end
    os.remove(out)
    os.remove(calls)
  end)

  it("keeps what finished when Ctrl-C stops a sweep (exit 130); the next run computes only the rest", function()
    local out, script, res = os.tmpname(), os.tmpname(), os.tmpname()
    os.remove(out)
    write(script, ([[
      local rows = nz.sweep{ grid = { x = { 1, 2, 3, 4, 5, 6, 7, 8, 9, 10, 11, 12 } }, jobs = 2, out = %q,
        progress = false, run = function(_, p)
          local t = os.clock(); while os.clock() - t < 0.2 do end
          return { y = p.x * p.x } end }
      print(rows.status, rows.computed, rows.missing)
    ]]):format(out))
    -- Ctrl-C (SIGINT to nzlua alone) once the file holds two rows
    local shell = ([[%s %s > %s.out 2> %s.err & pid=$!
      i=0; while [ "$(cat %s 2>/dev/null | wc -l)" -lt 3 ] && [ $i -lt 600 ]; do sleep 0.05; i=$((i+1)); done
      kill -INT $pid; wait $pid; echo $? > %s.rc]]):format(h.nzlua, script, res, res, out, res)
    os.execute(shell)
    local code, stdout, stderr = tonumber(slurp(res .. ".rc")), slurp(res .. ".out"), slurp(res .. ".err")
    for _, f in ipairs{ script, res, res .. ".rc", res .. ".out", res .. ".err" } do os.remove(f) end
    assert.are.equal(130, code, stderr)
    local status, computed, missing = stdout:match("^(%S+)\t(%d+)\t(%d+)")
    assert.are.equal("interrupted", status, stdout .. stderr)
    assert.truthy(stderr:find("sweep: stopped by Ctrl-C after", 1, true), stderr)
    local kept = #lines(slurp(out) or "") - 1
    assert.truthy(kept >= 2 and kept < 12, "rows kept: " .. kept)
    assert.are.equal(tonumber(computed), kept)
    assert.are.equal(12 - kept, tonumber(missing))
    local rows = nz.sweep(quiet{ grid = { x = { 1, 2, 3, 4, 5, 6, 7, 8, 9, 10, 11, 12 } }, jobs = 2, out = out,
      run = function(_, p) return { y = p.x * p.x } end })
    assert.are.equal(12 - kept, rows.computed)
    assert.are.equal(13, #lines(slurp(out)))
    for i, r in ipairs(rows) do assert.are.equal(i * i, r.y) end
    os.remove(out)
  end)

  it("records a failing point with its message and computes the others; a worker that dies loses only its point", function()
    local out = os.tmpname()
    local rows = nz.sweep(quiet{ file = SCENE, grid = { amp = { 1, math.pi, 2 }, l = { 1 } }, jobs = 2, out = out })
    assert.are.equal(3, #rows)
    assert.are.equal(1, rows.failed)
    assert.is_nil(rows[1].error)
    assert.truthy(rows[2].error:find("tests/data/sweep_pendulum.lua:15: no period: 0 upward crossings", 1, true), rows[2].error)
    assert.is_nil(rows[2].period)
    assert.truthy(rows[3].period > rows[1].period)
    local text = slurp(out)
    assert.truthy(text:find('3.141592653589793,1,,,"tests/data/sweep_pendulum.lua:15: no period: 0 upward crossings"', 1, true), text)
    os.remove(out)
    local died = nz.sweep(quiet{ grid = { x = { 1, 2, 3, 4 } }, jobs = 2, run = function(_, p)
      if p.x == 2 then os.exit(3) end
      return { y = -p.x }
    end })
    assert.are.equal("the worker process died (exit status 3) while computing this point", died[2].error)
    assert.are.same({ -1, -3, -4 }, { died[1].y, died[3].y, died[4].y })
    -- a run that returns something else than a table of outputs fails its point
    local bad = nz.sweep(quiet{ grid = { x = { 1, 2 } }, jobs = 1, run = function(_, p) return p.x == 1 and 5 or { x = 1 } end })
    assert.are.equal("run returned 5; a table of outputs {name = number, ...} expected", bad[1].error)
    assert.are.equal("run returned 'x', which is an input of the sweep: name the output differently", bad[2].error)
  end)

  it("draws a progress bar with the time left when asked (on a terminal by default), none when redirected", function()
    local script = os.tmpname()
    write(script, [[
      require("nz.motion.sweep").PROGRESS.delay = 0
      local progress = arg[1] == "on" or nil
      nz.sweep{ grid = { x = { 1, 2, 3, 4, 5, 6 } }, jobs = 2, progress = progress, run = function(_, p)
        local t = os.clock(); while os.clock() - t < 0.05 do end
        return { y = p.x } end }
    ]])
    local code, _, err = h.run(h.nzlua .. " " .. script .. " on")
    assert.are.equal(0, code, err)
    assert.truthy(err:find("%] %d/6 points, [%d.]+ s left  %(Ctrl%-C stops, keeping what is done%)"), err)
    local code2, _, err2 = h.run(h.nzlua .. " " .. script)
    assert.are.equal(0, code2, err2)
    assert.are.equal("", err2)
    os.remove(script)
  end)

  it("retry = true computes the failed points of a resumed file again (their new row comes last)", function()
    local out = os.tmpname()
    local fail = true
    local function run(_, p)
      if fail and p.x == 2 then error("not yet") end
      return { y = 10 * p.x }
    end
    local first = nz.sweep(quiet{ grid = { x = { 1, 2, 3 } }, run = run, jobs = 1, out = out })
    assert.are.equal(1, first.failed)
    fail = false
    local kept = nz.sweep(quiet{ grid = { x = { 1, 2, 3 } }, run = run, jobs = 1, out = out })
    assert.are.equal(0, kept.computed)
    assert.truthy(kept[2].error:find("not yet", 1, true))
    local again = nz.sweep(quiet{ grid = { x = { 1, 2, 3 } }, run = run, jobs = 1, out = out, retry = true })
    assert.are.equal(1, again.computed)
    assert.are.equal(20, again[2].y)
    assert.is_nil(again[2].error)
    assert.are.equal(20, nz.sweep(quiet{ grid = { x = { 1, 2, 3 } }, run = run, jobs = 1, out = out })[2].y)
    os.remove(out)
  end)

  it("leaves no worker behind (no zombie children)", function()
    nz.sweep(quiet{ grid = { x = { 1, 2, 3, 4, 5 } }, jobs = 3, run = function(_, p) return { y = p.x } end })
    local pid = slurp("/proc/self/stat"):match("^(%d+)")
    local p = io.popen("ps -o stat= --ppid " .. pid)
    local states = p:read("a")
    p:close()
    assert.is_nil(states:find("Z"), "zombie children: " .. states)
  end)

  it("draws a reproducible sample: the same seed the same points, within the ranges", function()
    local function points(seed)
      return nz.sweep(quiet{ sample = { n = 20, seed = seed, ranges = { a = { -1, 1 }, b = { 10, 20 } } }, jobs = 1,
        run = function(_, p) return { s = p.a + p.b } end })
    end
    local p1, p2, p3 = points(42), points(42), points(43)
    assert_same_rows(p1, p2, "the same seed")
    assert.are_not.equal(p1[1].a, p3[1].a)
    for _, r in ipairs(p1) do
      assert.truthy(r.a >= -1 and r.a <= 1 and r.b >= 10 and r.b <= 20)
    end
  end)

  it("round-trips awkward values through CSV cells and worker records", function()
    local row = { a = 0.1, b = -0.0, c = 1e-300, d = math.huge, e = -math.huge, f = 3, g = 2.0,
      s = 'a "quoted", multi\nline \\ text', t = true }
    local names = { "a", "b", "c", "d", "e", "f", "g", "s", "t" }
    local rec, got_names = sweep.parse_record(sweep.record_line(names, row):gsub("\n$", ""))
    assert.are.same(names, got_names)
    for _, k in ipairs(names) do assert(same_value(row[k], rec[k]), k) end
    assert.are.equal("-0.0", sweep.number(rec.b))
    local cells = {}
    for i, k in ipairs(names) do cells[i] = k end
    local text = table.concat(cells, ",") .. "\n"
    local parts = {}
    for i, k in ipairs(names) do
      local v = row[k]
      parts[i] = type(v) == "string" and ('"' .. v:gsub('"', '""') .. '"') or (type(v) == "number" and sweep.number(v) or tostring(v))
    end
    local records = sweep.parse_csv(text .. table.concat(parts, ",") .. "\n")
    for i, k in ipairs(names) do assert(same_value(row[k], records[2][i]), k) end
    assert.is_nil(sweep.parse_record("x=1 y"))
    assert.is_nil(sweep.parse_record('x="open'))
  end)

  it("nzlua --sweep-worker: points on stdin, result rows on stdout, a bad line reported", function()
    local code, out, err = h.run(h.nzlua .. " --sweep-worker " .. SCENE, "amp=0.9 l=2.5\n# a comment\n\namp=3.141592653589793 l=1\n")
    assert.are.equal(0, code, err)
    local l = lines(out)
    assert.are.equal(2, #l)
    local r = sweep.parse_record(l[1])
    local want = nz.sweep(quiet{ file = SCENE, list = { { amp = 0.9, l = 2.5 } }, jobs = 1 })[1]
    assert.are.equal(want.period, r.period)
    assert.truthy(l[1]:find("^amp=0.9 l=2.5 crossings=%d+ period=[%d.]+$"), l[1])
    assert.truthy(l[2]:find('^amp=3.141592653589793 l=1 error="tests/data/sweep_pendulum.lua:15: no period', 1), l[2])
    local code2, out2, err2 = h.run(h.nzlua .. " --sweep-worker " .. SCENE, "amp=0.9 l=2.5\nnonsense\n")
    assert.are.equal(1, code2)
    assert.are.equal(1, #lines(out2))
    assert.truthy(err2:find("sweep worker: stdin:2: expected name=value at column 1: nonsense", 1, true), err2)
    local code3, _, err3 = h.run(h.nzlua .. " --sweep-worker tests/data/args.lua", "x=1\n")
    assert.are.equal(1, code3)
    assert.truthy(err3:find("must return a system or {system = sys, run = function(sys, point) ... end}", 1, true), err3)
    local code4, out4 = h.run(h.nzlua .. " --help")
    assert.are.equal(0, code4)
    assert.truthy(out4:find("--sweep-worker file", 1, true), out4)
  end)

  it("runs across two hosts with GNU parallel (ssh replaced by a local wrapper): the rows of one process", function()
    if not os.execute("command -v parallel >/dev/null 2>&1") then
      pending("GNU parallel is not installed ('make deps' installs the Debian package 'parallel'): multi-host path not tested")
      return
    end
    local out, todo, done, log = os.tmpname(), os.tmpname(), os.tmpname(), os.tmpname()
    os.remove(out)
    os.remove(log)
    local grid = { amp = { 0.3, 0.9, 1.5, 2.1, math.pi }, l = { 1, 2.5 } }
    local listed = nz.sweep(quiet{ file = SCENE, grid = grid, out = out, todo = todo })
    assert.are.equal("todo", listed.status)
    assert.are.equal(10, listed.todo)
    assert.are.equal(10, #lines(slurp(todo)))
    local nzlua = h.nzlua:find("^/") and h.nzlua or os.getenv("PWD") .. "/" .. h.nzlua
    local cmd = ("FAKE_SSH_LOG=%s parallel --ssh tests/data/fake_ssh.sh -S 1/hostA,1/hostB --pipe -N 2 "
      .. "%s --sweep-worker %s/%s < %s > %s"):format(log, nzlua, os.getenv("PWD"), SCENE, todo, done)
    local ok = os.execute(cmd)
    assert.truthy(ok, cmd)
    local hosts = {}
    for host in slurp(log):gmatch("%S+") do hosts[host] = (hosts[host] or 0) + 1 end
    assert.truthy(hosts.hostA and hosts.hostB, "both hosts ran jobs: " .. slurp(log))
    local merged = nz.sweep(quiet{ file = SCENE, grid = grid, out = out, from = done, jobs = 1 })
    assert.are.equal(0, merged.computed)
    assert.are.equal(10, merged.resumed)
    local single = nz.sweep(quiet{ file = SCENE, grid = grid, jobs = 1 })
    -- the error names the scene by the path the worker was given
    for _, r in ipairs(merged) do if r.error then r.error = r.error:gsub("^.*tests/data/", "tests/data/") end end
    assert_same_rows(single, merged, "GNU parallel on two hosts against one process")
    assert.are.equal(11, #lines(slurp(out)))
    -- the same in one call: nz.sweep runs GNU parallel and appends its rows as they come
    os.remove(out)
    os.remove(log)
    local through = nz.sweep(quiet{ file = SCENE, grid = grid, out = out, jobs = 1,
      parallel = ("--ssh 'env FAKE_SSH_LOG=%s tests/data/fake_ssh.sh' -S 1/hostA,1/hostB -N 3"):format(log), worker = nzlua })
    assert.are.equal("complete", through.status)
    assert.are.equal(10, through.computed)
    assert.are.equal(11, #lines(slurp(out)))
    for _, r in ipairs(through) do if r.error then r.error = r.error:gsub("^.*tests/data/", "tests/data/") end end
    assert_same_rows(single, through, "nz.sweep{parallel = ...} against one process")
    assert.truthy(slurp(log):find("hostA", 1, true) and slurp(log):find("hostB", 1, true), slurp(log))
    -- hosts whose worker fails answer for no point: they stay missing, not failed
    os.remove(out)
    local none = nz.sweep(quiet{ file = SCENE, grid = grid, out = out, parallel = "-S : -N 5", worker = "false" })
    assert.are.equal("incomplete", none.status)
    assert.are.equal(10, none.missing)
    assert.are.equal(0, #none)
    for _, f in ipairs{ out, todo, done, log } do os.remove(f) end
  end)

  it("refuses bad options with the caller's file:line and what was expected", function()
    local run = function() return {} end
    local cases = {
      { { grid = { x = { 1 } }, run = run, jbos = 2 }, "sweep: unknown option 'jbos' (did you mean 'jobs'?) (options: file, from, grid, jobs, list, out, parallel, progress, resume, retry, run, sample, system, todo, worker)" },
      { { run = run }, "sweep: no points: give 'grid', 'list' or 'sample'" },
      { { grid = { x = { 1 } }, list = { { x = 1 } }, run = run }, "sweep: give one of 'grid', 'list', 'sample', not grid and list" },
      { { grid = { x = {} }, run = run }, "sweep: 'grid.x' must be a non-empty list of values, got a table" },
      { { grid = { x = { 1, 0 / 0 } }, run = run }, "sweep: 'grid.x'[2] must be a number (not NaN) or a string, got NaN" },
      { { grid = { error = { 1 } }, run = run }, "sweep: grid name \"error\" must be a name" },
      { { grid = { x = { 1 } } }, "sweep: no 'run': give run = function(sys, point)" },
      { { grid = { x = { 1 } }, run = 5 }, "sweep: 'run' must be a function(sys, point) returning a table of outputs, got 5" },
      { { grid = { x = { 1 } }, run = run, jobs = 0 }, "sweep: 'jobs' (worker processes) must be a positive integer, got 0" },
      { { grid = { x = { 1 } }, run = run, system = {} }, "sweep: 'system' must be a system made by nz.system or nz.scene, got a table" },
      { { grid = { x = { 1 } }, run = run, file = "tests/data/nope.lua" }, "sweep: cannot load 'file' (cannot open tests/data/nope.lua" },
      { { grid = { x = { 1 } }, run = run, file = SCENE, system = {} }, "sweep: give 'system' or 'file', not both" },
      { { list = { { x = 1 }, { y = 2 } }, run = run }, "sweep: 'list'[2] has the names {y}, the first point {x}: every point gives the same names" },
      { { sample = { n = 2.5, ranges = { x = { 0, 1 } } }, run = run }, "sweep: 'sample.n' (the number of points) must be a positive integer, got 2.5" },
      { { sample = { n = 2, ranges = { x = { 1, 0 } } }, run = run }, "sweep: 'sample.ranges.x' must be {low, high} with finite low <= high, got {1, 0}" },
      { { grid = { x = { 1 } }, run = run, out = 3 }, "sweep: 'out' must be a file name, got 3" },
      { { grid = { x = { 1 } }, run = run, retry = true }, "sweep: 'retry' needs 'out'" },
      { { grid = { x = { 1 } }, run = run, from = "tests/data/nope.txt" }, "sweep: 'from': cannot read tests/data/nope.txt" },
      { { grid = { x = { 1 } }, run = run, parallel = "-S host" }, "sweep: 'parallel' needs 'file': the hosts load the system and run from it" },
      { { grid = { x = { 1 } }, run = run, worker = "nzlua" }, "sweep: 'worker' (the command on the hosts) goes with 'parallel'" },
      { { grid = { x = { 1 } }, file = SCENE, parallel = true }, "sweep: 'parallel' must be a string, got true" },
    }
    for _, c in ipairs(cases) do
      local ok, msg = pcall(nz.sweep, c[1])
      assert.is_false(ok)
      assert.truthy(msg:find("^tests/sweep_spec%.lua:%d+: "), msg)
      assert.truthy(msg:find(c[2], 1, true), ("expected %q in %q"):format(c[2], msg))
    end
    -- a results file of another sweep is not overwritten
    local out = os.tmpname()
    write(out, "a,b,error\n1,2,\n")
    h.checkerror("holds other results (columns: a, b, error; this sweep's inputs: x): choose another file, or resume = false",
      nz.sweep, { grid = { x = { 1 } }, run = run, out = out, progress = false })
    assert.are.equal("a,b,error\n1,2,\n", slurp(out))
    local rows = nz.sweep{ grid = { x = { 1 } }, run = function() return { y = 2 } end, out = out, resume = false, progress = false }
    assert.are.equal(2, rows[1].y)
    assert.are.equal("x,y,error\n1,2,\n", slurp(out))
    os.remove(out)
  end)
end)
