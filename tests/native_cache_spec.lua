-- native_cache_spec.lua - the cache of machine code (src/graph/native_object.h)
-- as a user and as a hostile local user meet it: only objects the user made
-- are loaded, a damaged cache never crashes, compiling never stalls a run,
-- the cache stays bounded.  Every case runs build/nzlua as a black box with
-- a cache directory of its own.  The cases with a second user need root
-- (they make files of uid 65534 with chown, and run the attacker's part as
-- that uid with setpriv); without it they are skipped with the reason.
local h = require "tests.helpers"
local nzlua = h.nzlua

local is_root = h.run("test \"$(id -u)\" = 0") == 0
local has_setpriv = h.run("command -v setpriv") == 0

-- A fresh directory of this test's, 0700 (mktemp -d).
local function tempdir()
  local code, out = h.run("mktemp -d")
  assert(code == 0, "mktemp -d failed")
  return (out:gsub("%s+$", ""))
end

local function sh(cmd)
  local code, out, err = h.run(cmd)
  assert(code == 0, ("%s: exit %d\n%s%s"):format(cmd, code, out, err))
  return out
end

local function q(s) return "'" .. s:gsub("'", "'\\''") .. "'" end

-- The pendulum of the README; prints accel, graph_info's fields and the
-- run's evaluator as key=value lines.  native: "true", "false" or "nil".
local function script(dir, native, t1, extra)
  local path = dir .. "/pend.lua"
  local f = assert(io.open(path, "w"))
  f:write(([[
local pend = nz.system{ name = "pendulum", coords = { "th" }, params = { g = 9.81, l = 1.3, m = 2 }, native = %s,
  T = function(t, q, qd, p) return 0.5 * p.m * p.l^2 * qd[1]^2 end,
  V = function(t, q, p) return -p.m * p.g * p.l * nz.cos(q[1]) end }
%s
local tr = pend:simulate{ q0 = { 2.5 }, t1 = %s, dt = %s / 4 }
print("accel=" .. string.format("%%.17g", pend:accel(0, { 0.7 }, { 0.3 })[1]))
local gi = pend:graph_info()
print("native_plans=" .. tostring(gi.native_plans))
print("native_compiling=" .. tostring(gi.native_compiling))
print("native_waited=" .. tostring(gi.native_waited))
print("native_why=" .. tostring(gi.native_why))
print("evaluator=" .. tostring(tr.stats.evaluator))
print("native_from_step=" .. tostring(tr.stats.native_from_step))
]]):format(native or "nil", extra or "", t1 or 1, t1 or 1))
  f:close()
  return path
end

local function fields(out)
  local t = {}
  for k, v in out:gmatch("([%w_]+)=([^\n]*)") do t[k] = v end
  return t
end

-- The pendulum's accel at (0.7, 0.3), from its closed form -g/l sin(th).
local ACCEL = -9.81 / 1.3 * math.sin(0.7)

local function run_pend(env, dir, native, t1, extra)
  local code, out, err = h.run(("env %s %s %s"):format(env, nzlua, script(dir, native, t1, extra)))
  local f = fields(out)
  f.code, f.err, f.out = code, err, out
  return f
end

-- The objects (nz?-<hash>.so) in dir.
local function objects(dir)
  local list = {}
  local p = io.popen("ls " .. q(dir) .. " 2>/dev/null")
  for name in p:lines() do if name:match("^nz%a%-%x+%.so$") then list[#list + 1] = name end end
  p:close()
  table.sort(list)
  return list
end

-- Wait (up to 120 s: never fail because the machine is slow) until dir
-- holds n objects and no temporaries.
local function wait_objects(dir, n)
  for _ = 1, 1200 do
    local all = sh("(ls -a " .. q(dir) .. " || true) 2>/dev/null")
    if #objects(dir) >= n and not all:find("%.tmp%-") then return #objects(dir) end
    os.execute("sleep 0.1")
  end
  return #objects(dir)
end

local function file_size(path)
  local f = io.open(path, "rb")
  local n = f:seek("end")
  f:close()
  return n
end

local function mode_of(path) return (sh("stat -c %a " .. q(path)):gsub("%s+$", "")) end

-- A shared object whose constructor writes the file `marker`: what an
-- attacker plants.  Built by the attacker's uid when there is one.
local function evil_object(dir, marker, as)
  local c = dir .. "/evil.c"
  local f = assert(io.open(c, "w"))
  f:write(([[
#include <stdio.h>
__attribute__((constructor)) static void plant(void) { FILE *f = fopen("%s", "w"); if (f) { fputs("ran", f); fclose(f); } }
const char nzn_id[] = "0000000000000000";
int nzn_eval(const double *in, double *out, double *w) { (void)in; (void)w; out[0] = 1; return 0; }
]]):format(marker))
  f:close()
  sh(("%s cc -shared -fPIC -o %s %s"):format(as or "", q(dir .. "/evil.so"), q(c)))
  return dir .. "/evil.so"
end

describe("the machine-code cache: only objects the user made are loaded", function()
  local function name_of_object(native_dir)
    -- the object's name is predictable: compile once into a cache of our own
    local r = run_pend("NZLUA_CACHE=" .. q(native_dir), native_dir:match("^(.*)/[^/]+$"), "true")
    assert.equal(0, r.code, r.err)
    local objs = objects(native_dir)
    assert.equal(1, #objs, "one object expected in " .. native_dir)
    return objs[1]
  end

  it("refuses a cache directory others can write (1777, 0777), runs interpreted and says why", function()
    local base = tempdir()
    local name = name_of_object(base .. "/mine")
    for _, mode in ipairs{ "1777", "0777", "0775" } do
      local shared = base .. "/shared" .. mode
      sh("mkdir " .. q(shared) .. " && chmod " .. mode .. " " .. q(shared))
      local marker = base .. "/ran" .. mode
      local evil = evil_object(base, marker)
      sh(("cp %s %s"):format(q(evil), q(shared .. "/" .. name)))
      for _, native in ipairs{ "nil", "true" } do
        local r = run_pend("NZLUA_CACHE=" .. q(shared), base, native)
        assert.equal(0, r.code, r.err)
        assert.is_nil(io.open(marker), "the planted object's constructor ran (mode " .. mode .. ")")
        assert.near(ACCEL, tonumber(r.accel), 1e-13)
        assert.equal("0", r.native_plans)
        assert.truthy(r.native_why:find("can be written by", 1, true), r.native_why)
        assert.truthy(r.native_why:find(shared, 1, true), r.native_why)
      end
    end
  end)

  it("a planted object of another user (built and copied as uid 65534) never runs, default mode and native = true",
    function()
      if not (is_root and has_setpriv) then pending("needs root and setpriv to act as a second user") return end
      local base = tempdir()
      sh("chmod 755 " .. q(base))
      local name = name_of_object(base .. "/mine")
      local shared = base .. "/shared"
      sh("mkdir " .. q(shared) .. " && chmod 1777 " .. q(shared))
      local attacker = base .. "/attacker"
      sh("mkdir " .. q(attacker) .. " && chown 65534:65534 " .. q(attacker))
      local marker = base .. "/ran-as-victim"
      local as = "setpriv --reuid=65534 --regid=65534 --clear-groups"
      -- the attacker's object writes the marker only when it runs as root
      local evil, c = attacker .. "/evil.so", attacker .. "/evil.c"
      local f = assert(io.open(c, "w"))
      f:write(([[
#include <stdio.h>
#include <unistd.h>
__attribute__((constructor)) static void plant(void) { if (geteuid() == 0) { FILE *f = fopen("%s", "w"); if (f) fclose(f); } }
]]):format(marker))
      f:close()
      sh(("chown 65534:65534 %s && %s cc -shared -fPIC -o %s %s"):format(q(c), as, q(evil), q(c)))
      sh(("%s cp %s %s"):format(as, q(evil), q(shared .. "/" .. name)))
      -- the victim's own directory, 0700, but with the planted file chowned in
      local own = base .. "/own"
      sh("mkdir -m 700 " .. q(own))
      sh(("cp %s %s && chown 65534:65534 %s"):format(q(evil), q(own .. "/" .. name), q(own .. "/" .. name)))
      -- a directory of the attacker's, not writable by others
      local theirs = base .. "/theirs"
      sh(("mkdir -m 755 %s && chown 65534:65534 %s"):format(q(theirs), q(theirs)))
      sh(("%s cp %s %s"):format(as, q(evil), q(theirs .. "/" .. name)))
      for _, dir in ipairs{ shared, own, theirs } do
        for _, native in ipairs{ "nil", "true" } do
          local r = run_pend("NZLUA_CACHE=" .. q(dir), base, native)
          assert.equal(0, r.code, r.err)
          assert.is_nil(io.open(marker), "another user's object ran as root from " .. dir)
          assert.near(ACCEL, tonumber(r.accel), 1e-13)
        end
      end
      -- in the victim's own directory the planted file was removed and the
      -- object compiled again (with one line saying so)
      local r = run_pend("NZLUA_CACHE=" .. q(own), base, "true")
      assert.equal("1", r.native_plans)
      assert.equal("0", sh("stat -c %u " .. q(own .. "/" .. name)):gsub("%s+$", ""))
      local rt = run_pend("NZLUA_CACHE=" .. q(theirs), base, "true")
      assert.truthy(rt.native_why:find("belongs to another user", 1, true), rt.native_why)
    end)

  it("a symbolic link planted under the object's name is not followed", function()
    local base = tempdir()
    local name = name_of_object(base .. "/mine")
    local own = base .. "/own"
    sh("mkdir -m 700 " .. q(own))
    local marker = base .. "/ran"
    local evil = evil_object(base, marker)
    sh(("ln -s %s %s"):format(q(evil), q(own .. "/" .. name)))
    local r = run_pend("NZLUA_CACHE=" .. q(own), base, "true")
    assert.equal(0, r.code, r.err)
    assert.is_nil(io.open(marker), "the linked object ran")
    assert.truthy(r.err:find("is a symbolic link", 1, true), r.err)
    assert.equal("1", r.native_plans)     -- compiled again, as a file of its own
    assert.equal("", sh("find " .. q(own) .. " -type l"))
  end)

  it("without a usable HOME (cron, env -i) and no NZLUA_CACHE there is no cache: interpreted, and it says so", function()
    local base = tempdir()
    local uid = sh("id -u"):gsub("%s+$", "")
    local trap = "/tmp/nzlua-" .. uid     -- the old fallback: anyone could make it first
    local existed = io.open(trap) ~= nil
    local before = existed and #objects(trap) or 0
    local r = run_pend("-i PATH=/usr/bin:/bin", base, "true")
    assert.equal(0, r.code, r.err)
    assert.near(ACCEL, tonumber(r.accel), 1e-13)
    assert.equal("0", r.native_plans)
    assert.truthy(r.native_why:find("HOME is not set", 1, true), r.native_why)
    assert.equal(before, existed and #objects(trap) or 0, "an object was written to " .. trap)
    if not existed then assert.is_nil(io.open(trap), trap .. " was created") end
  end)

  it("creates its directory 0700 and its objects 0600 whatever the umask", function()
    local base = tempdir()
    local dir = base .. "/a/b"
    local code, _, err = h.run(("umask 000 && env NZLUA_CACHE=%s %s %s"):format(q(dir), nzlua, script(base, "true")))
    assert.equal(0, code, err)
    assert.equal("700", mode_of(base .. "/a"))
    assert.equal("700", mode_of(dir))
    local objs = objects(dir)
    assert.equal(1, #objs)
    assert.equal("600", mode_of(dir .. "/" .. objs[1]))
    local all = sh("ls -a " .. q(dir))
    assert.is_nil(all:find("%.c\n"), "the generated source is kept: " .. all)
  end)
end)

describe("a damaged cache never crashes", function()
  -- A good object, then the same cut to n bytes (or with a flipped bit):
  -- every later run, default and native = true, finishes with the right
  -- answer, says once that the object was damaged, and compiles it again.
  local function damaged(cut, what)
    local base = tempdir()
    local dir = base .. "/c"
    local r = run_pend("NZLUA_CACHE=" .. q(dir), base, "true")
    assert.equal(0, r.code, r.err)
    local obj = dir .. "/" .. objects(dir)[1]
    local good = file_size(obj)
    sh(("cp -p %s %s.good"):format(q(obj), q(obj)))
    for _, native in ipairs{ "true", "nil" } do
      cut(obj, good)
      local rr = run_pend("NZLUA_CACHE=" .. q(dir), base, native)
      assert.equal(0, rr.code, "exit " .. rr.code .. ": " .. rr.err)
      assert.near(ACCEL, tonumber(rr.accel), 1e-13)
      assert.truthy(rr.err:find(what or "is damaged", 1, true), rr.err)
      local _, lines = rr.err:gsub("removed; it is compiled again", "")
      assert.equal(1, lines, rr.err)
      if native == "true" then
        assert.equal("1", rr.native_plans)
        assert.equal(good, file_size(obj))
      else   -- a short run in the default mode: interpreted, and the object is gone
        assert.equal("0", rr.native_plans)
        assert.is_nil(io.open(obj))
        sh(("cp -p %s.good %s"):format(q(obj), q(obj)))
      end
    end
  end

  for _, n in ipairs{ 1000, 4096, 12000 } do
    it(("an object truncated to %d bytes"):format(n), function()
      damaged(function(obj) sh(("truncate -s %d %s"):format(n, q(obj))) end)
    end)
  end

  it("an object with a flipped bit in its code", function()
    damaged(function(obj, size)
      local f = assert(io.open(obj, "r+b"))
      f:seek("set", size // 2)
      local b = f:read(1):byte()
      f:seek("set", size // 2)
      f:write(string.char(b ~ 0x10))
      f:close()
    end)
  end)

  it("an object that is not a regular file (a FIFO) does not hang the run", function()
    damaged(function(obj) sh(("rm -f %s && mkfifo %s"):format(q(obj), q(obj))) end, "is not a regular file")
  end)
end)

describe("the compiler: its identity, its flags, its failures", function()
  -- A compiler of the test's: a shell script that calls cc and says its own
  -- version (what `$CC --version` prints keys the cache).
  local function wrapper(dir, version, body)
    local path = dir .. "/mycc"
    local f = assert(io.open(path, "w"))
    f:write(("#!/bin/sh\nif [ \"$1\" = --version ]; then echo %q; exit 0; fi\n%s\n"):format(version,
      body or 'echo "$@" >> "$(dirname "$0")/calls"; exec cc "$@"'))
    f:close()
    sh("chmod 755 " .. q(path))
    return path
  end

  it("a CC that now names another compiler does not reuse the old object", function()
    local base = tempdir()
    local dir = base .. "/c"
    local cc = wrapper(base, "mycc 1.0")
    run_pend(("NZLUA_CACHE=%s CC=%s"):format(q(dir), q(cc)), base, "true")
    assert.equal(1, #objects(dir))
    wrapper(base, "mycc 2.0")
    local r = run_pend(("NZLUA_CACHE=%s CC=%s"):format(q(dir), q(cc)), base, "true")
    assert.equal("1", r.native_plans, r.err)
    assert.equal(2, #objects(dir), "the same object was reused for another compiler")
    -- and the same compiler again reuses its object
    run_pend(("NZLUA_CACHE=%s CC=%s"):format(q(dir), q(cc)), base, "true")
    assert.equal(2, #objects(dir))
  end)

  for _, case in ipairs{ { "NZLUA_COPT=-Ofast", "-Ofast", "NZLUA_COPT" }, { "CC='cc -ffast-math'", "-ffast-math", "CC" },
                         { "NZLUA_COPT=-funsafe-math-optimizations", "-funsafe-math-optimizations", "NZLUA_COPT" } } do
    it(("refuses %s, which breaks the bit-for-bit promise"):format(case[1]), function()
      local base = tempdir()
      local r = run_pend(("NZLUA_CACHE=%s %s"):format(q(base .. "/c"), case[1]), base, "true")
      assert.equal(0, r.code, r.err)
      assert.equal("0", r.native_plans)
      assert.truthy(r.native_why:find("'" .. case[2] .. "' in " .. case[3], 1, true), r.native_why)
      assert.truthy(r.native_why:find("bit for bit", 1, true), r.native_why)
      assert.equal(0, #objects(base .. "/c"))
    end)
  end

  it("CC=/bin/false gives a reason", function()
    local base = tempdir()
    local r = run_pend(("NZLUA_CACHE=%s CC=/bin/false"):format(q(base .. "/c")), base, "true")
    assert.equal(0, r.code, r.err)
    assert.truthy(r.native_why:find("'/bin/false' failed (exit status 1) and printed nothing", 1, true), r.native_why)
  end)

  it("a compiler that exits 0 with a short output leaves no object behind", function()
    local base = tempdir()
    local cc = wrapper(base, "short 1", [[
for a; do if [ "$prev" = -o ]; then out=$a; fi; prev=$a; done
cc "$@" && head -c 3000 "$out" > "$out.part" && mv "$out.part" "$out"]])
    local dir = base .. "/c"
    local r = run_pend(("NZLUA_CACHE=%s CC=%s"):format(q(dir), q(cc)), base, "true")
    assert.equal(0, r.code, r.err)
    assert.near(ACCEL, tonumber(r.accel), 1e-13)
    assert.truthy(r.native_why:find("not a whole shared object", 1, true), r.native_why)
    assert.equal(0, #objects(dir))
  end)

  it("a compiler that hangs is stopped after NZLUA_CC_TIMEOUT", function()
    local base = tempdir()
    local cc = wrapper(base, "slow 1", "sleep 60")
    local t0 = os.time()
    local r = run_pend(("NZLUA_CACHE=%s CC=%s NZLUA_CC_TIMEOUT=1"):format(q(base .. "/c"), q(cc)), base, "true")
    assert.equal(0, r.code, r.err)
    assert.truthy(os.time() - t0 < 50, "the run waited for the hanging compiler")
    assert.truthy(r.native_why:find("ran longer than 1 s", 1, true), r.native_why)
  end)

  it("a full disk is named as such", function()
    if not is_root then pending("needs root to mount a small tmpfs") return end
    local base = tempdir()
    local dir = base .. "/full"
    sh("mkdir " .. q(dir))
    if h.run(("mount -t tmpfs -o size=8k,mode=0700 tmpfs %s"):format(q(dir))) ~= 0 then
      pending("cannot mount a tmpfs here")
      return
    end
    local r = run_pend("NZLUA_CACHE=" .. q(dir), base, "true")
    h.run("umount " .. q(dir))
    assert.equal(0, r.code, r.err)
    assert.near(ACCEL, tonumber(r.accel), 1e-13)
    assert.truthy(r.native_why:find("No space left on device", 1, true), r.native_why)
  end)

  it("processes that need the same object at once share one compile", function()
    local base = tempdir()
    local cc = wrapper(base, "shared 1")
    local dir = base .. "/c"
    local cmd = ("env NZLUA_CACHE=%s CC=%s %s %s"):format(q(dir), q(cc), nzlua, script(base, "true"))
    sh(("(%s >/dev/null & %s >/dev/null & %s >/dev/null & wait)"):format(cmd, cmd, cmd))
    local calls = h.slurp(base .. "/calls") or ""
    local _, n = calls:gsub("\n", "")
    assert.equal(1, n, "compiles: " .. calls)
    assert.equal(1, #objects(dir))
  end)
end)

describe("compiling never stalls a run", function()
  it("a run shorter than a compile leaves the object in the cache for the next one", function()
    local base = tempdir()
    local dir = base .. "/c"
    -- long enough to start the compile (a sixteenth of its cost interpreted),
    -- shorter than the compile itself (about 0.1 s)
    local r = run_pend("NZLUA_CACHE=" .. q(dir), base, "nil", 300)
    assert.equal(0, r.code, r.err)
    assert.equal(1, wait_objects(dir, 1), "the background compile left no object")
    local r2 = run_pend("NZLUA_CACHE=" .. q(dir), base, "nil", 300)
    assert.equal("machine code", r2.evaluator)
    assert.equal("1", r2.native_plans)
    assert.equal(0, tonumber(r2.native_waited))
  end)

  it("tr.stats says which evaluator ran which steps; the results are the same bit for bit", function()
    local base = tempdir()
    local dir = base .. "/c"
    -- a long run in one process: interpreted first, machine code once the
    -- background compile is ready, the switch at a step
    local extra = [[
local ref = nz.system{ name = "pendulum", coords = { "th" }, params = { g = 9.81, l = 1.3, m = 2 }, native = false,
  T = function(t, q, qd, p) return 0.5 * p.m * p.l^2 * qd[1]^2 end,
  V = function(t, q, p) return -p.m * p.g * p.l * nz.cos(q[1]) end }
local a = pend:simulate{ q0 = { 2.5 }, t1 = 20000, dt = 1000 }
local b = ref:simulate{ q0 = { 2.5 }, t1 = 20000, dt = 1000 }
local same = #a.t == #b.t
for i = 1, #a.t do same = same and a.q[i][1] == b.q[i][1] and a.qd[i][1] == b.qd[i][1] end
print("same_bits=" .. tostring(same))
print("long_evaluator=" .. tostring(a.stats.evaluator))
print("long_from=" .. tostring(a.stats.native_from_step))
print("ref_evaluator=" .. tostring(b.stats.evaluator))
]]
    local r = run_pend("NZLUA_CACHE=" .. q(dir), base, "nil", 1, extra)
    assert.equal(0, r.code, r.err)
    assert.equal("true", r.same_bits)
    assert.equal("interpreted graph (native = false)", r.ref_evaluator)
    local from = tonumber(r.long_from)
    if from then   -- the compile finished within the run (it should, by far)
      assert.truthy(from > 1, r.long_evaluator)
      assert.equal(("interpreted graph for steps 1-%d, machine code from step %d (compiled in the background)")
        :format(from - 1, from), r.long_evaluator)
    else
      assert.truthy(r.long_evaluator:find("interpreted graph", 1, true), r.long_evaluator)
    end
  end)

  it("native = true waits for the compiler: every step in machine code", function()
    local base = tempdir()
    local r = run_pend("NZLUA_CACHE=" .. q(base .. "/c"), base, "true", 10)
    assert.equal(0, r.code, r.err)
    assert.equal("machine code", r.evaluator)
    assert.truthy(tonumber(r.native_waited) > 0, r.native_waited)
  end)

  it("a background compile never leaves a zombie child, whether or not its run asks again", function()
    local base = tempdir()
    local dir = base .. "/c"
    local extra = [[
local long = pend:simulate{ q0 = { 2.5 }, t1 = 300, dt = 100 }   -- starts the compile, ends before it is done
local function objects()
  local p, n = io.popen("ls " .. os.getenv("NZLUA_CACHE")), 0
  for name in p:lines() do if name:match("%.so$") then n = n + 1 end end
  p:close()
  return n
end
for _ = 1, 1200 do   -- until the worker has written the object (nothing polls it meanwhile)
  if objects() >= 1 then break end
  os.execute("sleep 0.1")
end
os.execute("sleep 0.3")
local pid = io.open("/proc/self/stat"):read("a"):match("^(%d+)")
local p = io.popen("ps -o stat= --ppid " .. pid)
local states = p:read("a"); p:close()
print("zombies=" .. tostring(select(2, states:gsub("Z", ""))))
]]
    local r = run_pend("NZLUA_CACHE=" .. q(dir), base, "nil", 1, extra)
    assert.equal(0, r.code, r.err)
    assert.equal(1, #objects(dir))
    assert.equal("0", r.zombies)
  end)

  it("a one-off accel at the prompt does not compile", function()
    local base = tempdir()
    local dir = base .. "/c"
    local f = assert(io.open(base .. "/one.lua", "w"))
    f:write([[
local pend = nz.system{ name = "pendulum", coords = { "th" }, params = { g = 9.81, l = 1.3, m = 2 },
  T = function(t, q, qd, p) return 0.5 * p.m * p.l^2 * qd[1]^2 end,
  V = function(t, q, p) return -p.m * p.g * p.l * nz.cos(q[1]) end }
print(pend:accel(0, { 0.7 }, { 0.3 })[1])
]])
    f:close()
    sh(("env NZLUA_CACHE=%s %s %s"):format(q(dir), nzlua, q(base .. "/one.lua")))
    os.execute("sleep 0.5")
    assert.equal(0, #objects(dir))
  end)
end)

describe("the cache stays bounded, and can be emptied", function()
  -- n different systems (a spring of stiffness k), each compiled with
  -- native = true: what each object costs, then a limit of three objects.
  local function springs(dir, base, ks, env)
    for _, k in ipairs(ks) do
      local f = assert(io.open(base .. "/s.lua", "w"))
      f:write(([[
local s = nz.system{ coords = { "x" }, native = true, T = function(t, q, qd) return qd[1]^2 / 2 end,
  V = function(t, q) return %d * q[1]^2 / 2 end }
s:simulate{ q0 = { 1 }, t1 = 0.1 }
]]):format(k))
      f:close()
      sh(("env NZLUA_CACHE=%s %s %s %s"):format(q(dir), env or "", nzlua, q(base .. "/s.lua")))
    end
  end

  it("keeps under NZLUA_CACHE_MAX, the least recently used out first", function()
    local base = tempdir()
    local dir = base .. "/c"
    springs(dir, base, { 1 })
    local one = file_size(dir .. "/" .. objects(dir)[1])
    local limit = math.floor(3.5 * one)
    springs(dir, base, { 2, 3 }, "NZLUA_CACHE_MAX=" .. limit)
    assert.equal(3, #objects(dir))
    local first = objects(dir)
    -- use spring 1 again (it becomes the most recently used), then add 4, 5
    os.execute("sleep 1.1")
    springs(dir, base, { 1 }, "NZLUA_CACHE_MAX=" .. limit)
    local kept_1 = {}
    for _, o in ipairs(objects(dir)) do kept_1[o] = true end
    springs(dir, base, { 4, 5 }, "NZLUA_CACHE_MAX=" .. limit)
    local objs = objects(dir)
    assert.equal(3, #objs)
    local total = 0
    for _, o in ipairs(objs) do total = total + file_size(dir .. "/" .. o) end
    assert.truthy(total <= limit, ("%d bytes over the limit %d"):format(total, limit))
    -- spring 1, used last before 4 and 5, is still there
    local names = sh(("cd %s && for f in nz*.so; do echo $f; done"):format(q(dir)))
    local still = 0
    for o in pairs(kept_1) do if names:find(o, 1, true) then still = still + 1 end end
    assert.truthy(still >= 1, "the recently used object was removed before older ones")
    assert.equal(3, #first)
  end)

  it("nzlua --cache-info and --cache-clear, nz.cache.info() and nz.cache.clear()", function()
    local base = tempdir()
    local dir = base .. "/c"
    springs(dir, base, { 1, 2 })
    local code, out = h.run(("env NZLUA_CACHE=%s %s --cache-info"):format(q(dir), nzlua))
    assert.equal(0, code)
    assert.truthy(out:find(dir, 1, true), out)
    assert.truthy(out:find("2 objects", 1, true), out)
    assert.truthy(out:find("trusted", 1, true), out)
    code, out = h.run(("env NZLUA_CACHE=%s %s -e %s"):format(q(dir), nzlua,
      q("local i = nz.cache.info() print(i.objects, i.trusted, i.bytes > 0, i.dir)")))
    assert.equal(0, code)
    assert.equal("2\ttrue\ttrue\t" .. dir .. "\n", out)
    sh("touch " .. q(dir .. "/notes.txt"))   -- not nzlua's: left alone
    code, out = h.run(("env NZLUA_CACHE=%s %s --cache-clear"):format(q(dir), nzlua))
    assert.equal(0, code)
    assert.truthy(out:find("removed 2 files", 1, true), out)
    assert.equal(0, #objects(dir))
    assert.truthy(io.open(dir .. "/notes.txt"), "--cache-clear removed a file that is not nzlua's")
    code, out = h.run(("env NZLUA_CACHE=%s %s -e %s"):format(q(dir), nzlua, q("print(nz.cache.clear())")))
    assert.equal("0\n", out)
    code, out = h.run(("env NZLUA_CACHE=%s %s --cache-info"):format(q(base), nzlua))
    sh("chmod 777 " .. q(base))
    code, out = h.run(("env NZLUA_CACHE=%s %s --cache-info"):format(q(base), nzlua))
    sh("chmod 700 " .. q(base))
    assert.truthy(out:find("NOT trusted", 1, true), out)
  end)
end)

-- A second local user, real (useradd makes it when it is missing), and the
-- prefix that runs a command as that user; or nil and why not.  CI runs as
-- root on a fresh Debian machine: there it is always possible.
local OTHER = "nzlua-other"
local function second_user()
  if not is_root then return nil, "needs root to act as a second user" end
  if not has_setpriv then return nil, "needs setpriv (util-linux) to act as a second user" end
  if h.run("id -u " .. OTHER) ~= 0 and
     h.run("useradd --system --no-create-home --shell /usr/sbin/nologin " .. OTHER) ~= 0 then
    return nil, "useradd could not make the user " .. OTHER
  end
  local uid = sh("id -u " .. OTHER):gsub("%s+$", "")
  local gid = sh("id -g " .. OTHER):gsub("%s+$", "")
  return ("setpriv --reuid=%s --regid=%s --clear-groups"):format(uid, gid), uid
end

-- The second user's prefix and a fresh directory others may enter (0755),
-- or nil and why there is no second user.
local function two_users()
  local as, why = second_user()
  if not as then return nil, why end
  local base = tempdir()
  sh("chmod 755 " .. q(base))
  return as, base
end

-- A compiler of the victim's own (a shell script in dir, `$CC --version`
-- says version), its body after the version line.
local function cc_script(dir, name, body)
  local path = dir .. "/" .. name
  local f = assert(io.open(path, "w"))
  f:write("#!/bin/sh\nif [ \"$1\" = --version ]; then echo " .. name .. " 1; exit 0; fi\n" .. body .. "\n")
  f:close()
  sh("chmod 755 " .. q(path))
  return path
end

describe("another local user cannot reach the cache through its path, its compiler or its objects", function()
  it("a directory on the path that another user owns: no cache, interpreted, native_why names it and its owner",
    function()
      local as, base = two_users()
      if not as then pending(base) return end
      local shared = base .. "/shared"
      sh(("mkdir -m 755 %s && chown %s %s"):format(q(shared), OTHER, q(shared)))
      local cache = shared .. "/cache"   -- root's own 0700 directory, inside theirs
      sh("mkdir -m 700 " .. q(cache))
      for _, native in ipairs{ "nil", "true" } do
        local r = run_pend("NZLUA_CACHE=" .. q(cache), base, native)
        assert.equal(0, r.code, r.err)
        assert.near(ACCEL, tonumber(r.accel), 1e-13)
        assert.equal("0", r.native_plans)
        assert.truthy(r.native_why:find("the directory '" .. shared .. "' on the cache's path belongs to '" .. OTHER
          .. "'", 1, true), r.native_why)
      end
      assert.equal(0, #objects(cache), "an object was written below another user's directory")
      -- nothing is made below their directory either (mkdir then chmod by name could be turned)
      local r = run_pend("NZLUA_CACHE=" .. q(shared .. "/new/cache"), base, "true")
      assert.equal("0", r.native_plans)
      assert.is_nil(io.open(shared .. "/new"), "a directory was made inside another user's directory")
      -- --cache-clear and --cache-info neither read nor remove anything there
      local planted = cache .. "/nzg-0123456789abcdef.so"
      sh("touch " .. q(planted))
      local code, out, err = h.run(("env NZLUA_CACHE=%s %s --cache-clear"):format(q(cache), nzlua))
      assert.equal(1, code, out)
      assert.truthy(err:find("belongs to '" .. OTHER .. "'", 1, true), err)
      assert.truthy(io.open(planted), "--cache-clear removed a file through another user's directory")
      code, out = h.run(("env NZLUA_CACHE=%s %s --cache-info"):format(q(cache), nzlua))
      assert.truthy(out:find("NOT trusted", 1, true), out)
    end)

  it("a sticky directory others write (as /tmp) may be passed only to what is the user's own", function()
    local as, base = two_users()
    if not as then pending(base) return end
    local sticky = base .. "/tmp"
    sh(("mkdir -m 1777 %s"):format(q(sticky)))
    local mine, theirs = sticky .. "/mine", sticky .. "/theirs"
    sh("mkdir -m 700 " .. q(mine))
    sh(("%s mkdir -m 755 %s"):format(as, q(theirs)))
    local r = run_pend("NZLUA_CACHE=" .. q(mine .. "/c"), base, "true")
    assert.equal("1", r.native_plans, r.native_why)
    r = run_pend("NZLUA_CACHE=" .. q(theirs .. "/c"), base, "true")
    assert.equal("0", r.native_plans)
    assert.truthy(r.native_why:find("'" .. theirs .. "' on the cache's path belongs to '" .. OTHER .. "'", 1, true),
      r.native_why)
    assert.truthy(r.native_why:find("and lies in a directory others can write", 1, true), r.native_why)
    -- a symbolic link of theirs in the sticky directory is not followed, one of the user's is
    sh(("%s ln -s %s %s"):format(as, q(mine), q(sticky .. "/their-link")))
    sh(("ln -s %s %s"):format(q(mine), q(sticky .. "/my-link")))
    r = run_pend("NZLUA_CACHE=" .. q(sticky .. "/their-link/c"), base, "true")
    assert.equal("0", r.native_plans)
    assert.truthy(r.native_why:find("their-link' on the cache's path belongs to '" .. OTHER, 1, true), r.native_why)
    r = run_pend("NZLUA_CACHE=" .. q(sticky .. "/my-link/c"), base, "true")
    assert.equal("1", r.native_plans, r.native_why)
    -- a directory others may write that is not sticky is never passed
    local open = base .. "/open"
    sh(("mkdir -m 777 %s && mkdir -m 700 %s"):format(q(open), q(open .. "/c")))
    r = run_pend("NZLUA_CACHE=" .. q(open .. "/c"), base, "true")
    assert.equal("0", r.native_plans)
    assert.truthy(r.native_why:find("can be written by others (mode 0777) and is not sticky", 1, true), r.native_why)
  end)

  it("the compiler never sees a path that can move: the parent swapped while it compiles changes nothing", function()
    -- The race of the issue, driven by the compiler itself: while it reads
    -- its source, the cache's parent is another user's directory holding a
    -- source of theirs (the victim's own source with a constructor added)
    -- under the same name; while it links, the parent is back.  A compiler
    -- given paths through the parent compiles their source into the
    -- victim's cache; one given names in a directory it was started in
    -- compiles the victim's.
    local as, base = two_users()
    if not as then pending(base) return end
    local parent, marker = base .. "/p", base .. "/ran"
    sh("mkdir -m 755 " .. q(parent))
    local cc = cc_script(base, "racecc", ([[
P=%s; AS=%q; MARK=%s
src=; out=; prev=; n=0
for a; do case "$a" in *.c) src=$a;; esac; [ "$prev" = -o ] && out=$a; prev=$a; done
mv "$P" "$P.real"; mkdir -m 755 "$P"; chown %s "$P"
case "$src" in
  /*) rel=${src#$P/};;
  *) rel=c/$src;;
esac
$AS mkdir -p "$P/$(dirname "$rel")"
if [ -f "$P.real/$rel" ]; then
  { cat "$P.real/$rel"; echo "#include <stdio.h>"; echo "__attribute__((constructor)) static void evil(void) { FILE *f = fopen(\"$MARK\", \"w\"); if (f) fclose(f); }"; } > "$P/$rel"
fi
obj=$(mktemp /tmp/racecc.XXXXXX.o)
args=; for a; do case "$a" in "$src"|"$out"|-o|-lm|-shared|-nostartfiles) ;; *) args="$args $a";; esac; done
cc $args -c -o "$obj" "$src"; st=$?
rm -rf "$P"; mv "$P.real" "$P"
[ $st = 0 ] || exit $st
cc "$@" >/dev/null 2>&1 || true
for a; do case "$a" in "$src") ;; *) set -- "$@" "$a";; esac; done
cc -shared -nostartfiles -o "$out" "$obj" -lm; st=$?
rm -f "$obj"; exit $st]]):format(q(parent), as, q(marker), OTHER))
    local r = run_pend(("NZLUA_CACHE=%s CC=%s"):format(q(parent .. "/c"), q(cc)), base, "true")
    assert.equal(0, r.code, r.err)
    assert.is_nil(io.open(marker), "the other user's source was compiled into the cache and its constructor ran")
    assert.is_nil(r.err:find("refused", 1, true), "the other user's source was compiled (then refused): " .. r.err)
    assert.equal("1", r.native_plans, r.native_why)
    assert.near(ACCEL, tonumber(r.accel), 1e-13)
  end)

  -- What a CC of the user's own may add to the object, and the line that
  -- refuses it (the object is never loaded, never kept).
  local additions = {
    { "a constructor", [[__attribute__((constructor)) static void evil(void) { FILE *f = fopen("MARK", "w"); if (f) fclose(f); }]],
      "", "constructors (DT_INIT_ARRAY)" },
    { "a destructor", [[__attribute__((destructor)) static void evil(void) { FILE *f = fopen("MARK", "w"); if (f) fclose(f); }]],
      "", "destructors (DT_FINI_ARRAY)" },
    { "gcc's start files (_init, frame_dummy)", "int nzlua_extra;", "-startfiles", "an initialisation function (DT_INIT)" },
    { "an indirect function", [[static void real(void) { FILE *f = fopen("MARK", "w"); if (f) fclose(f); }
static void (*pick(void))(void) { real(); return real; }
void nzlua_ifunc(void) __attribute__((ifunc("pick")));]], "", "IFUNC" },
    { "another library", "int nzlua_extra;", "-lgslcblas -Wl,--no-as-needed -lgsl", "needs the library 'libgsl" },
    { "an executable stack", "int nzlua_extra;", "-Wl,-z,execstack", "executable stack" },
  }
  for _, add in ipairs(additions) do
    it(("an object that a CC of the user's own gives %s is refused before it is loaded, with one line"):format(add[1]),
      function()
        local base = tempdir()
        local marker = base .. "/ran"
        local extra = base .. "/extra.c"
        local f = assert(io.open(extra, "w"))
        f:write("#include <stdio.h>\n" .. add[2]:gsub("MARK", marker) .. "\n")
        f:close()
        local link = add[3] == "-startfiles" and "" or add[3]
        local cc = cc_script(base, "addcc", ([[
out=; prev=; for a; do [ "$prev" = -o ] && out=$a; prev=$a; done
if [ %q = -startfiles ]; then
  for a; do shift; [ "$a" = -nostartfiles ] || set -- "$@" "$a"; done
fi
exec cc "$@" %s %s]]):format(add[3], q(extra), link))
        local dir = base .. "/c"
        local r = run_pend(("NZLUA_CACHE=%s CC=%s"):format(q(dir), q(cc)), base, "true")
        assert.equal(0, r.code, r.err)
        assert.is_nil(io.open(marker), "the object's code ran")
        assert.near(ACCEL, tonumber(r.accel), 1e-13)
        assert.equal("0", r.native_plans)
        assert.truthy(r.native_why:find(add[4], 1, true), r.native_why)
        local lines = h.lines(r.err)
        assert.equal(1, #lines, r.err)
        assert.truthy(lines[1]:find("refused and removed, never loaded", 1, true), r.err)
        assert.truthy(lines[1]:find(add[4], 1, true), r.err)
        assert.equal(0, #objects(dir))
        assert.equal("", sh("ls -A " .. q(dir) .. " | grep -v '\\.lock$' || true"))
      end)
  end

  it("--cache-clear and the bound remove only files whose trailer says they are nzlua's", function()
    local base = tempdir()
    local dir = base .. "/c"
    local r = run_pend("NZLUA_CACHE=" .. q(dir), base, "true")
    assert.equal("1", r.native_plans, r.native_why)
    -- a file of the user's under an object's name, and a source that is not generated
    local mine, notes = dir .. "/nzg-0123456789abcdef.so", dir .. "/nzg-0123456789abcdef.c"
    sh(("head -c 20000 /dev/urandom > %s && echo 'int main(void) { return 0; }' > %s"):format(q(mine), q(notes)))
    local code, out = h.run(("env NZLUA_CACHE=%s %s --cache-info"):format(q(dir), nzlua))
    assert.truthy(out:find("1 object,", 1, true), out)
    code, out = h.run(("env NZLUA_CACHE=%s NZLUA_CACHE_MAX=1 %s --cache-clear"):format(q(dir), nzlua))
    assert.equal(0, code, out)
    assert.truthy(out:find("removed 1 file", 1, true), out)
    assert.truthy(io.open(mine), "a file without nzlua's trailer was removed")
    assert.truthy(io.open(notes), "a source nzlua did not generate was removed")
    -- the bound: a compile with a limit of one byte keeps the new object and the user's files
    r = run_pend(("NZLUA_CACHE=%s NZLUA_CACHE_MAX=1"):format(q(dir)), base, "true")
    assert.equal("1", r.native_plans, r.native_why)
    assert.truthy(io.open(mine), "the size bound removed a file without nzlua's trailer")
  end)
end)

describe("the settings are read strictly: one line says what was read and what is used", function()
  local cases = {
    { "NZLUA_CACHE_MAX", "inf", "is more than the largest accepted, 1T: 1T is used", "limit 1048576 MB" },
    { "NZLUA_CACHE_MAX", "1e400", "is more than the largest accepted, 1T: 1T is used", "limit 1048576 MB" },
    { "NZLUA_CACHE_MAX", "18446744073709551616", "is more than the largest accepted, 1T: 1T is used", "limit 1048576 MB" },
    { "NZLUA_CACHE_MAX", "lots", "is not a size in bytes (a positive number, K, M, G or T may follow): the default, "
      .. "100M, is used", "limit 100 MB" },
    { "NZLUA_CACHE_MAX", "-5M", "is not a size in bytes", "limit 100 MB" },
    { "NZLUA_CACHE_MAX", "0", "is not a size in bytes", "limit 100 MB" },
    { "NZLUA_CACHE_MAX", "300K", nil, "limit 0 MB" },
  }
  for _, c in ipairs(cases) do
    it(("%s=%s"):format(c[1], c[2]), function()
      local base = tempdir()
      local code, out, err = h.run(("env NZLUA_CACHE=%s %s=%s %s --cache-info"):format(q(base), c[1], q(c[2]), nzlua))
      assert.equal(0, code, err)
      assert.truthy(out:find(c[4], 1, true), out)
      if not c[3] then assert.equal("", err) return end
      local lines = h.lines(err)
      assert.equal(1, #lines, err)
      assert.truthy(lines[1]:find(("%s='%s' "):format(c[1], c[2]), 1, true), err)
      assert.truthy(lines[1]:find(c[3], 1, true), err)
    end)
  end

  for _, c in ipairs{ { "NZLUA_CC_TIMEOUT", "soon", "is not a number of seconds (positive): the default, 300, is used" },
                      { "NZLUA_CC_TIMEOUT", "1e400", "is more than the largest accepted, 86400: 86400 is used" },
                      { "NZLUA_CC_TIMEOUT", "-3", "is not a number of seconds" },
                      { "NZLUA_CC_JOBS", "2.5", "is not a whole number of compiles at once (1 or more): the default, 2, "
                        .. "is used" },
                      { "NZLUA_CC_JOBS", "many", "is not a whole number" },
                      { "NZLUA_CC_JOBS", "-99999999999999999999", "is not a whole number" },
                      { "NZLUA_CC_JOBS", "18446744073709551616", "is more than the largest accepted, 64: 64 is used" } } do
    it(("%s=%s, read when a run compiles"):format(c[1], c[2]), function()
      local base = tempdir()
      local r = run_pend(("NZLUA_CACHE=%s %s=%s"):format(q(base .. "/c"), c[1], q(c[2])), base, "true")
      assert.equal(0, r.code, r.err)
      assert.equal("1", r.native_plans, r.native_why)
      local lines = h.lines(r.err)
      assert.equal(1, #lines, r.err)
      assert.truthy(lines[1]:find(("%s='%s' "):format(c[1], c[2]), 1, true), r.err)
      assert.truthy(lines[1]:find(c[3], 1, true), r.err)
    end)
  end

  it("a relative NZLUA_CACHE is ignored as a relative XDG_CACHE_HOME is, with one line each", function()
    local base = tempdir()
    local home = base .. "/home"
    sh("mkdir -m 700 " .. q(home))
    local prog = nzlua:sub(1, 1) == "/" and nzlua or os.getenv("PWD") .. "/" .. nzlua
    local code, out, err = h.run(("cd %s && env -u XDG_CACHE_HOME HOME=%s NZLUA_CACHE=rel %s --cache-info")
      :format(q(base), q(home), prog))
    assert.equal(0, code, err)
    assert.truthy(out:find("cache of machine code: " .. home .. "/.cache/nzlua", 1, true), out)
    assert.truthy(err:find("NZLUA_CACHE='rel' is not an absolute path: ignored", 1, true), err)
    code, out, err = h.run(("cd %s && env -u NZLUA_CACHE HOME=%s XDG_CACHE_HOME=rel %s --cache-info")
      :format(q(base), q(home), prog))
    assert.truthy(out:find("cache of machine code: " .. home .. "/.cache/nzlua", 1, true), out)
    assert.truthy(err:find("XDG_CACHE_HOME='rel' is not an absolute path: ignored", 1, true), err)
  end)
end)
