-- help_spec.lua - nz.help lists exactly what the module offers.
local h = require "tests.helpers"
local nz = h.nz
local entries = require("nz.help").entries

describe("nz.help", function()
  it("has one entry for every public name of nz, and no entry for a missing one", function()
    local documented = {}
    for _, e in ipairs(entries) do
      documented[e.name] = true
      assert(e.optional or nz[e.name] ~= nil, ("help documents nz.%s, which does not exist"):format(e.name))
    end
    for name in pairs(nz) do
      assert(documented[name], ("nz.%s has no help entry"):format(name))
    end
  end)
  it("lists every entry with its summary", function()
    local text = nz.help(nil, { quiet = true })
    for _, e in ipairs(entries) do
      assert(text:find(e.summary, 1, true), ("the listing lacks the summary of %s"):format(e.name))
    end
  end)
  it("explains one function given the function or its name", function()
    local text = nz.help(nz.jet, { quiet = true })
    assert.truthy(text:find("normalized coefficients c_0..c_K", 1, true), text)
    assert.are.equal(text, nz.help("jet", { quiet = true }))
  end)
  it("says what to do when there is no help, in one line and without an error", function()
    assert.are.equal("no help for 'nothing_here': help() lists what nz offers", nz.help("nothing_here", { quiet = true }))
    assert.are.equal("no help for this table: help() lists what nz offers", nz.help({}, { quiet = true }))
    -- in the session: the line, no traceback
    local rc, out = h.run(h.nzlua .. " -i", "help(42)\n")
    assert.are.equal(0, rc)
    assert.truthy(out:find("no help for this number: help() lists what nz offers", 1, true), out)
    assert.falsy(out:find("traceback", 1, true), out)
  end)

  it("covers every method of a system and of a trajectory", function()
    local text = nz.help(nz.system, { quiet = true })
    local sys = nz.system{ name = "p", coords = { "x" }, T = function(t, q, qd) return qd[1] ^ 2 / 2 end }
    local System = getmetatable(sys).__index
    for name, f in pairs(System) do
      if type(f) == "function" and not name:match("^_") then
        assert(text:find("sys:" .. name, 1, true), ("help(nz.system) does not mention sys:%s"):format(name))
      end
    end
    local tr = sys:simulate{ q0 = { 0 }, qd0 = { 1 }, t1 = 0.1 }
    local Traj = getmetatable(tr).__index
    local ttext = text     -- the trajectory's methods are in help(nz.system)
    for name, f in pairs(Traj) do
      if type(f) == "function" and not name:match("^_") then
        assert(ttext:find("tr:" .. name, 1, true), ("help(nz.system) does not mention tr:%s"):format(name))
      end
    end
  end)
end)
