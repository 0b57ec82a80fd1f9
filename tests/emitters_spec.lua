-- emitters_spec.lua - the two emitters of machine code (straight-line code,
-- src/graph/graph_native.c and series_native.c; compact code,
-- graph_compact.c and series_compact.c) against the interpreter, on real
-- systems: a chain of six bodies (M and h not constant), Henon-Heiles (q''
-- as one plan, the fused series loop), the Chaplygin sleigh (constraint
-- rows) and the Whipple bicycle (twelve plans).  tests/data/emitters.lua
-- runs each (accel, rk8pd and taylor runs) in a process of its own: with
-- the interpreter (NZLUA_NATIVE=0), and with every plan and series as
-- machine code (NZLUA_NATIVE=1) of one emitter forced (NZLUA_COMPACT=0 or
-- 1).  Machine code stands in for the interpreter, so every number must
-- be the interpreter's bit for bit (printed with %a), the step counts too;
-- the kept sources (NZLUA_KEEP_C=1) say which emitter wrote them.
local h = require "tests.helpers"

-- Run the script in a fresh cache with these settings: its output, and the
-- first line of every C source it left in the cache.
local function run(env)
  local dir = os.tmpname()
  os.remove(dir)
  assert(os.execute("mkdir -m 700 " .. dir))
  local code, out, err = h.run(("env %s NZLUA_KEEP_C=1 NZLUA_CACHE=%s %s tests/data/emitters.lua"):format(env, dir, h.nzlua))
  assert(code == 0, ("emitters.lua under %s failed (%s): %s"):format(env, tostring(code), err))
  local _, heads = h.run(("head -q -n 1 %s/*.c 2>/dev/null"):format(dir))
  os.execute("rm -rf " .. dir)
  return out, h.lines(heads)
end

-- The figures (every line but the machine code's), and what ran as machine
-- code per system: plans, series.
local function split(out)
  local figures, native = {}, {}
  for _, line in ipairs(h.lines(out)) do
    local name, plans, series = line:match("^(.-)\tmachine code\t(%d+)\t(%d+)")
    if name then native[name] = { tonumber(plans), tonumber(series) }
    else figures[#figures + 1] = line end
  end
  return figures, native
end

describe("compact and straight-line machine code on real systems", function()
  local interp, straight, compact, sources = {}, {}, {}, {}
  setup(function()
    local out
    out = run("NZLUA_NATIVE=0")
    interp.figures, interp.native = split(out)
    out, sources.straight = run("NZLUA_NATIVE=1 NZLUA_COMPACT=0")
    straight.figures, straight.native = split(out)
    out, sources.compact = run("NZLUA_NATIVE=1 NZLUA_COMPACT=1")
    compact.figures, compact.native = split(out)
  end)

  it("the interpreter ran no machine code; each emitter ran every plan and series the runs used", function()
    for name, n in pairs(interp.native) do
      assert(n[1] == 0 and n[2] == 0, name .. ": machine code under NZLUA_NATIVE=0")
      for _, which in ipairs{ straight, compact } do
        local m = which.native[name]
        assert(m and m[1] > 0, name .. ": no plan ran as machine code")
      end
    end
    -- the series of taylor's runs: the chain's M and h, Henon-Heiles' q''
    for _, name in ipairs{ "6-link pendulum", "Henon-Heiles" } do
      assert(straight.native[name][2] == 1 and compact.native[name][2] == 1, name .. ": its series is not machine code")
    end
  end)

  it("every source says which emitter wrote it", function()
    assert(#sources.straight >= 10 and #sources.compact == #sources.straight,
      ("sources kept: %d straight-line, %d compact"):format(#sources.straight, #sources.compact))
    for _, line in ipairs(sources.straight) do assert(line:find("straight%-line code"), "not straight-line: " .. line) end
    for _, line in ipairs(sources.compact) do assert(line:find("compact code"), "not compact: " .. line) end
  end)

  it("both give the interpreter's accelerations and runs bit for bit", function()
    assert(#interp.figures == 10, ("%d figures"):format(#interp.figures))
    for i, line in ipairs(interp.figures) do
      assert.are.equal(line, straight.figures[i], "straight-line code")
      assert.are.equal(line, compact.figures[i], "compact code")
    end
  end)
end)
