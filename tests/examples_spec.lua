-- examples_spec.lua - every example runs (exit 0) and prints its key figure
-- within bounds: the examples are part of the documentation, so they must
-- never go stale.
local h = require "tests.helpers"

local function run(name)
  local code, out, err = h.run(h.nzlua .. " examples/" .. name)
  assert(code == 0, ("examples/%s exited with %d:\n%s"):format(name, code, err))
  return out
end

local function number_after(text, label)
  local v = text:match(label:gsub("%p", "%%%0") .. "%s*([%-%d%.e+]+)")
  assert(v, ("no number after %q in:\n%s"):format(label, text))
  return tonumber(v)
end

describe("examples", function()
  it("demo.lua: the pendulum's acceleration matches -(g/l) sin th", function()
    local out = run("demo.lua")
    local a = number_after(out, "th'' =")
    assert(math.abs(a - (-9.81 / 1.3 * math.sin(0.7))) < 1e-12, out)
    assert.truthy(out:find("n = 12: 16.43141633068", 1, true), out)
  end)
  it("double_pendulum.lua: every form's residual is at rounding level", function()
    local out = run("double_pendulum.lua")
    local n = 0
    for v in out:gmatch("max |residual| = ([%d%.e+%-]+)") do
      n = n + 1
      assert(tonumber(v) < 1e-12, out)
    end
    assert.are.equal(7, n)
  end)
  it("chaplygin_sleigh.lua: n = 1, and three ways give the same th''", function()
    local out = run("chaplygin_sleigh.lua")
    assert.truthy(out:find("Dolapchiev's rule: n = 1", 1, true), out)
    local a = tonumber(out:match("multipliers%): [%-%d%.]+ [%-%d%.]+ ([%-%d%.]+)"))
    local b = tonumber(out:match("elimination%): [%-%d%.]+ [%-%d%.]+ ([%-%d%.]+)"))
    local c = number_after(out, "(I + m a^2) =")
    assert(math.abs(a - c) < 1e-11 and math.abs(b - c) < 1e-11, out)
  end)
  it("hamel.lua: n = 3 and the closed-form equations hold at the root", function()
    local out = run("hamel.lua")
    assert.truthy(out:find("Dolapchiev's rule: n = 3", 1, true), out)
    for v in out:gmatch("Q3 q%d''%s*=%s*([%-%d%.e+]+)") do assert(math.abs(tonumber(v)) < 1e-12, out) end
    assert.truthy(out:find("from the unconstrained accelerations", 1, true), out)
  end)
  it("every example in examples/ has a test here and a line in examples/README.md", function()
    local index = assert(io.open("examples/README.md")):read("a")
    local spec = assert(io.open("tests/examples_spec.lua")):read("a")
    local p = io.popen("ls examples/*.lua")
    for path in p:lines() do
      local name = path:match("examples/(.*)")
      assert(index:find("`" .. name .. "`", 1, true), name .. " is missing from examples/README.md")
      assert(spec:find('run("' .. name .. '")', 1, true), name .. " has no test in tests/examples_spec.lua")
    end
    p:close()
  end)
end)
