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
  it("says what to do when there is no help", function()
    h.checkerror("no help for 'nothing_here': help() lists what nz offers", nz.help, "nothing_here")
    h.checkerror("no help for this table", nz.help, {})
  end)
end)
